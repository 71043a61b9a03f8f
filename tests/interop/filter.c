/* erc-codec interop filter: nanopb's C library on one end of a pipe, the Python codec on the other.
 *
 * Reads one request a line from stdin and writes one answer a line to stdout, flushed, so one
 * process serves a whole test session:
 *   E <fields>  build a PBEnvelope from <fields>, pb_encode it into a PBEnvelope_size buffer
 *                                                        -> "OK <hex>"
 *   D <hex>     pb_decode the datagram (plain)           -> "OK <hex of re-encoding> <fields>"
 *   N <hex>     pb_decode_ex(..., PB_DECODE_NULLTERMINATED), answered like D
 * Any failure answers "ERR <reason>". An empty <hex> is written "-".
 *
 * <fields> is a space-separated list of field paths from the envelope: "12.9=3" is field 9 of the
 * message in envelope field 12, "12.6" alone says that submessage is present. Values are decimal;
 * float, double and fixed fields carry their raw bits, since nanopb stores them alike. The fields
 * are reached through nanopb's own field iterators, so this file knows no message of the schema.
 */
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <pb_common.h>
#include <pb_decode.h>
#include <pb_encode.h>

#include "components/common/envelope.pb.h"

#define LINE_MAX_BYTES 65536

static const char *failure;

static bool fail(const char *why)
{
    failure = why;
    return false;
}

static void write_value(void *data, pb_size_t size, uint64_t bits)
{
    uint8_t u8 = (uint8_t)bits;
    uint16_t u16 = (uint16_t)bits;
    uint32_t u32 = (uint32_t)bits;
    switch (size) {
    case 1: memcpy(data, &u8, 1); break;
    case 2: memcpy(data, &u16, 2); break;
    case 4: memcpy(data, &u32, 4); break;
    default: memcpy(data, &bits, 8); break;
    }
}

static int64_t read_signed(const void *data, pb_size_t size)
{
    int8_t i8; int16_t i16; int32_t i32; int64_t i64;
    switch (size) {
    case 1: memcpy(&i8, data, 1); return i8;
    case 2: memcpy(&i16, data, 2); return i16;
    case 4: memcpy(&i32, data, 4); return i32;
    default: memcpy(&i64, data, 8); return i64;
    }
}

static uint64_t read_unsigned(const void *data, pb_size_t size)
{
    uint64_t value = 0;
    memcpy(&value, data, size); /* little-endian host */
    return value;
}

static bool is_zero(const void *data, pb_size_t size)
{
    const uint8_t *bytes = data;
    for (pb_size_t i = 0; i < size; i++) {
        if (bytes[i]) return false;
    }
    return true;
}

/* Mark the iterator's field present: the oneof's which_ member, or a submessage's has_ flag. */
static void mark_present(pb_field_iter_t *it)
{
    if (PB_HTYPE(it->type) == PB_HTYPE_ONEOF) {
        *(pb_size_t *)it->pSize = it->tag;
    } else if (PB_HTYPE(it->type) == PB_HTYPE_OPTIONAL && it->pSize != NULL) {
        *(bool *)it->pSize = true;
    }
}

static bool set_path(const pb_msgdesc_t *desc, void *message, char *path, const char *value)
{
    char *rest = strchr(path, '.');
    if (rest != NULL) *rest++ = '\0';
    pb_field_iter_t it;
    if (!pb_field_iter_begin(&it, desc, message) || !pb_field_iter_find(&it, (uint32_t)atol(path)))
        return fail("no such field");
    if (PB_HTYPE(it.type) == PB_HTYPE_REPEATED) return fail("repeated fields are not supported");
    mark_present(&it);
    bool submessage = PB_LTYPE(it.type) == PB_LTYPE_SUBMESSAGE;
    if (rest != NULL) {
        if (!submessage) return fail("path goes through a scalar");
        return set_path(it.submsg_desc, it.pData, rest, value);
    }
    if (value == NULL) return submessage ? true : fail("scalar without a value");
    switch (PB_LTYPE(it.type)) {
    case PB_LTYPE_BOOL:
        *(bool *)it.pData = strtoull(value, NULL, 10) != 0;
        return true;
    case PB_LTYPE_VARINT:
    case PB_LTYPE_SVARINT:
        write_value(it.pData, it.data_size, (uint64_t)strtoll(value, NULL, 10));
        return true;
    case PB_LTYPE_UVARINT:
    case PB_LTYPE_FIXED32:
    case PB_LTYPE_FIXED64:
        write_value(it.pData, it.data_size, strtoull(value, NULL, 10));
        return true;
    default:
        return fail("field type not supported");
    }
}

static void dump(const pb_msgdesc_t *desc, const void *message, const char *prefix)
{
    pb_field_iter_t it;
    if (!pb_field_iter_begin_const(&it, desc, message)) return;
    do {
        if (PB_HTYPE(it.type) == PB_HTYPE_ONEOF && *(const pb_size_t *)it.pSize != it.tag) continue;
        if (PB_HTYPE(it.type) == PB_HTYPE_OPTIONAL && it.pSize != NULL && !*(const bool *)it.pSize)
            continue;
        if (PB_LTYPE(it.type) == PB_LTYPE_SUBMESSAGE) {
            char inner[256];
            snprintf(inner, sizeof inner, "%s%u.", prefix, (unsigned)it.tag);
            printf(" %s%u", prefix, (unsigned)it.tag);
            dump(it.submsg_desc, it.pData, inner);
            continue;
        }
        if (is_zero(it.pData, it.data_size)) continue;
        printf(" %s%u=", prefix, (unsigned)it.tag);
        switch (PB_LTYPE(it.type)) {
        case PB_LTYPE_BOOL: printf("%d", *(const bool *)it.pData ? 1 : 0); break;
        case PB_LTYPE_VARINT:
        case PB_LTYPE_SVARINT: printf("%lld", (long long)read_signed(it.pData, it.data_size)); break;
        default: printf("%llu", (unsigned long long)read_unsigned(it.pData, it.data_size)); break;
        }
    } while (pb_field_iter_next(&it));
}

static void print_hex(const uint8_t *bytes, size_t length)
{
    if (length == 0) fputs("-", stdout);
    for (size_t i = 0; i < length; i++) printf("%02x", bytes[i]);
}

static bool parse_hex(const char *text, uint8_t *bytes, size_t *length)
{
    size_t digits = strlen(text);
    *length = 0;
    if (strcmp(text, "-") == 0) return true;
    if (digits % 2 != 0 || digits / 2 > LINE_MAX_BYTES) return fail("odd or overlong hex");
    for (size_t i = 0; i < digits; i += 2) {
        unsigned int byte;
        if (sscanf(text + i, "%2x", &byte) != 1) return fail("not hex");
        bytes[(*length)++] = (uint8_t)byte;
    }
    return true;
}

static bool encode(const PBEnvelope *envelope, uint8_t *out, size_t *length)
{
    pb_ostream_t stream = pb_ostream_from_buffer(out, PBEnvelope_size);
    if (!pb_encode(&stream, PBEnvelope_fields, envelope)) return fail(PB_GET_ERROR(&stream));
    *length = stream.bytes_written;
    return true;
}

static void answer(char *line)
{
    static uint8_t bytes[LINE_MAX_BYTES];
    uint8_t out[PBEnvelope_size];
    PBEnvelope envelope;
    size_t length = 0;
    char command = line[0];
    char *argument = line[1] == ' ' ? line + 2 : line + 1;
    memset(&envelope, 0, sizeof envelope);
    failure = "unknown command";

    if (command == 'E') {
        for (char *item = strtok(argument, " "); item != NULL; item = strtok(NULL, " ")) {
            char *value = strchr(item, '=');
            if (value != NULL) *value++ = '\0';
            if (!set_path(PBEnvelope_fields, &envelope, item, value)) goto error;
        }
        if (!encode(&envelope, out, &length)) goto error;
        fputs("OK ", stdout);
        print_hex(out, length);
        putchar('\n');
        return;
    }
    if (command == 'D' || command == 'N') {
        if (!parse_hex(argument, bytes, &length)) goto error;
        pb_istream_t stream = pb_istream_from_buffer(bytes, length);
        unsigned int flags = command == 'N' ? PB_DECODE_NULLTERMINATED : 0;
        if (!pb_decode_ex(&stream, PBEnvelope_fields, &envelope, flags)) {
            failure = PB_GET_ERROR(&stream);
            goto error;
        }
        if (!encode(&envelope, out, &length)) goto error;
        fputs("OK ", stdout);
        print_hex(out, length);
        dump(PBEnvelope_fields, &envelope, "");
        putchar('\n');
        return;
    }
error:
    printf("ERR %s\n", failure);
}

int main(void)
{
    static char line[2 * LINE_MAX_BYTES + 4];
    while (fgets(line, sizeof line, stdin) != NULL) {
        line[strcspn(line, "\r\n")] = '\0';
        if (line[0] != '\0') answer(line);
        fflush(stdout);
    }
    return 0;
}
