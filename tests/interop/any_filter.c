/* erc-codec interop for any schema: nanopb's C library decodes and re-encodes the messages of a
 * schema the test generated, and reports the <Msg>_size each generated header defines.
 *
 * One request a line on stdin, one answer a line on stdout, flushed:
 *   S               -> "OK <name>=<Msg_size> ..." for every message messages.h lists
 *   D <name> <hex>  pb_decode the bytes as message <name>, pb_encode it again into a buffer of
 *                   <name>_size bytes -> "OK <hex of the re-encoding>"
 *   N <name> <hex>  as D, decoding with PB_DECODE_NULLTERMINATED (a zero tag ends the message)
 * Any failure answers "ERR <nanopb's own error text>". An empty <hex> is written "-".
 *
 * messages.h, written by the test beside the generated code, includes the .pb.h files and
 * defines MESSAGES as X(Name) for each message with a static size; this file knows no schema.
 */
#include <stdalign.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <pb_decode.h>
#include <pb_encode.h>

#include "messages.h"

#define LINE_MAX_BYTES 65536

typedef struct {
    const char *name;
    const pb_msgdesc_t *fields;
    size_t max_size;
} entry_t;

static const entry_t entries[] = {
#define X(m) {#m, &m##_msg, m##_size},
    MESSAGES
#undef X
};

static alignas(max_align_t) uint8_t storage[16384];
static uint8_t data[LINE_MAX_BYTES / 2];
static uint8_t out[LINE_MAX_BYTES / 2];

static int from_hex(const char *text, uint8_t *bytes, size_t *length)
{
    size_t n = 0;
    if (strcmp(text, "-") == 0) {
        *length = 0;
        return 1;
    }
    for (; text[0] && text[1]; text += 2) {
        unsigned int value;
        if (sscanf(text, "%2x", &value) != 1) return 0;
        bytes[n++] = (uint8_t)value;
    }
    *length = n;
    return text[0] == '\0';
}

static void recode(const char *name, const char *hex, unsigned int flags)
{
    const entry_t *entry = NULL;
    for (size_t i = 0; i < sizeof(entries) / sizeof(entries[0]); i++) {
        if (strcmp(entries[i].name, name) == 0) entry = &entries[i];
    }
    size_t length;
    if (entry == NULL) {
        printf("ERR unknown message %s\n", name);
        return;
    }
    if (!from_hex(hex, data, &length)) {
        printf("ERR bad hex\n");
        return;
    }
    memset(storage, 0, sizeof(storage));
    pb_istream_t input = pb_istream_from_buffer(data, length);
    if (!pb_decode_ex(&input, entry->fields, storage, flags)) {
        printf("ERR %s\n", PB_GET_ERROR(&input));
        return;
    }
    pb_ostream_t output = pb_ostream_from_buffer(out, entry->max_size);
    if (!pb_encode(&output, entry->fields, storage)) {
        printf("ERR %s\n", PB_GET_ERROR(&output));
        return;
    }
    if (output.bytes_written == 0) printf("OK -\n");
    else {
        printf("OK ");
        for (size_t i = 0; i < output.bytes_written; i++) printf("%02x", out[i]);
        printf("\n");
    }
}

int main(void)
{
    static char line[LINE_MAX_BYTES];
    while (fgets(line, sizeof(line), stdin)) {
        line[strcspn(line, "\n")] = '\0';
        char *command = strtok(line, " ");
        if (command == NULL) continue;
        if (strcmp(command, "S") == 0) {
            printf("OK");
            for (size_t i = 0; i < sizeof(entries) / sizeof(entries[0]); i++) {
                printf(" %s=%zu", entries[i].name, entries[i].max_size);
            }
            printf("\n");
        } else if (strcmp(command, "D") == 0 || strcmp(command, "N") == 0) {
            char *name = strtok(NULL, " ");
            char *hex = strtok(NULL, " ");
            if (name == NULL || hex == NULL) printf("ERR bad request\n");
            else recode(name, hex, command[0] == 'N' ? PB_DECODE_NULLTERMINATED : 0);
        } else {
            printf("ERR unknown command\n");
        }
        fflush(stdout);
    }
    return 0;
}
