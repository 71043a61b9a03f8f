/* A peer for tests/test_proton_interop.py: Proton 1.0's C runtime (protonc), driven line by line.
 *
 * protonc's generator is not published; what it generated is a proton_bundle_t per bundle over
 * an array of proton_signal_t, each pointing at its value's storage. This driver builds those at
 * run time from a description, then calls PROTON_Encode, PROTON_DecodeId and PROTON_Decode. One
 * request per line on stdin, one answer per line on stdout:
 *
 *   B ID SPEC...   describe bundle ID, one SPEC per signal in order: TYPE[:LENGTH[:CAPACITY]]
 *                  (double, ..., bytes:0:4, list_float:3, list_string:3:8)       -> OK
 *   S ID INDEX V   set the INDEX-th signal of bundle ID                          -> OK | ERR
 *   E ID           PROTON_Encode                                                  -> OK HEX | ERR
 *   D HEX          PROTON_DecodeId, then PROTON_Decode into that bundle           -> OK ID V... | ERR
 *   F HEX, U HEX   PROTON_FillFrameHeader/_FillCRC16; _GetFramedPayloadLength/_CheckFramedPayload
 *
 * A value V is hex of the C variable's bytes (little-endian numbers, a bool's one byte, a
 * string's text without NUL, a bytes buffer); a list's items are joined with ","; "-" is empty.
 */
#define _POSIX_C_SOURCE 200809L

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "protonc/proton.h"

#define MAX_BUNDLES 32
#define MAX_SIGNALS 32

typedef struct {
    pb_size_t tag;      /* the oneof member: 1..18 */
    size_t length;      /* list items, 0 for a scalar */
    size_t capacity;    /* string/bytes size, per item for lists */
    size_t item_size;   /* bytes of one item's storage */
    uint8_t *storage;   /* the value (all items of a list) */
} slot_t;

typedef struct {
    uint32_t id;
    size_t count;
    slot_t slots[MAX_SIGNALS];
    proton_signal_t signals[MAX_SIGNALS];
    proton_bundle_t bundle;
} described_t;

static described_t g_bundles[MAX_BUNDLES];
static size_t g_count;
static uint8_t g_buffer[1 << 17];
static uint8_t g_value[1 << 16];

static const char *const TYPES[] = {
    "double", "float", "int32", "int64", "uint32", "uint64", "bool", "string", "bytes",
};
static const size_t SIZES[] = {8, 4, 4, 8, 4, 8, sizeof(bool), 0, 0};

static int from_hex(const char *text, uint8_t *out, size_t room, size_t *len)
{
    *len = 0;
    if (strcmp(text, "-") == 0) {
        return 1;
    }
    size_t digits = strlen(text);
    if (digits % 2 != 0 || digits / 2 > room) {
        return 0;
    }
    for (size_t i = 0; i < digits / 2; i++) {
        unsigned int byte;
        if (sscanf(text + 2 * i, "%2x", &byte) != 1) {
            return 0;
        }
        out[i] = (uint8_t)byte;
    }
    *len = digits / 2;
    return 1;
}

static void put_hex(const uint8_t *data, size_t len)
{
    if (len == 0) {
        fputs("-", stdout);
    }
    for (size_t i = 0; i < len; i++) {
        printf("%02x", data[i]);
    }
}

static described_t *find(uint32_t id)
{
    for (size_t i = 0; i < g_count; i++) {
        if (g_bundles[i].id == id) {
            return &g_bundles[i];
        }
    }
    return NULL;
}

/* Point signal i at its storage, as protonc's generated init functions do. */
static void wire_up(described_t *d, size_t i)
{
    slot_t *slot = &d->slots[i];
    proton_signal_t *signal = &d->signals[i];
    memset(signal, 0, sizeof *signal);
    signal->signal.which_signal = slot->tag;
    signal->arg.data = slot->storage;
    signal->arg.length = slot->length;
    signal->arg.capacity = slot->capacity;
    void *arg = &signal->arg;
    switch (slot->tag) {
    case proton_Signal_string_value_tag: signal->signal.signal.string_value = arg; break;
    case proton_Signal_bytes_value_tag: signal->signal.signal.bytes_value = arg; break;
    case proton_Signal_list_double_value_tag: signal->signal.signal.list_double_value.doubles = arg; break;
    case proton_Signal_list_float_value_tag: signal->signal.signal.list_float_value.floats = arg; break;
    case proton_Signal_list_int32_value_tag: signal->signal.signal.list_int32_value.int32s = arg; break;
    case proton_Signal_list_int64_value_tag: signal->signal.signal.list_int64_value.int64s = arg; break;
    case proton_Signal_list_uint32_value_tag: signal->signal.signal.list_uint32_value.uint32s = arg; break;
    case proton_Signal_list_uint64_value_tag: signal->signal.signal.list_uint64_value.uint64s = arg; break;
    case proton_Signal_list_bool_value_tag: signal->signal.signal.list_bool_value.bools = arg; break;
    case proton_Signal_list_string_value_tag: signal->signal.signal.list_string_value.strings = arg; break;
    case proton_Signal_list_bytes_value_tag: signal->signal.signal.list_bytes_value.bytes = arg; break;
    default: break;
    }
}

static int describe(uint32_t id, char *specs)
{
    if (g_count == MAX_BUNDLES || find(id) != NULL) {
        return 0;
    }
    described_t *d = &g_bundles[g_count];
    memset(d, 0, sizeof *d);
    d->id = id;
    for (char *spec = strtok(specs, " "); spec != NULL; spec = strtok(NULL, " ")) {
        if (d->count == MAX_SIGNALS) {
            return 0;
        }
        slot_t *slot = &d->slots[d->count];
        char *type = spec;
        char *length = strchr(spec, ':');
        char *capacity = length ? strchr(length + 1, ':') : NULL;
        if (length) *length++ = '\0';
        if (capacity) *capacity++ = '\0';
        int list = strncmp(type, "list_", 5) == 0;
        const char *element = list ? type + 5 : type;
        size_t kind = 0;
        while (kind < 9 && strcmp(element, TYPES[kind]) != 0) {
            kind++;
        }
        if (kind == 9) {
            return 0;
        }
        slot->tag = (pb_size_t)(kind + 1 + (list ? 9 : 0));
        slot->length = length ? strtoul(length, NULL, 0) : 0;
        slot->capacity = capacity ? strtoul(capacity, NULL, 0) : 0;
        slot->item_size = SIZES[kind] ? SIZES[kind] : slot->capacity;
        slot->storage = calloc(list ? slot->length : 1, slot->item_size ? slot->item_size : 1);
        wire_up(d, d->count);
        d->count++;
    }
    PROTON_InitBundle(&d->bundle, id, d->signals, (uint32_t)d->count);
    g_count++;
    return 1;
}

/* Store one item from hex into its storage; a string keeps room for its NUL. */
static int store(const slot_t *slot, uint8_t *into, const char *hex)
{
    size_t len;
    if (!from_hex(hex, g_value, sizeof g_value, &len)) {
        return 0;
    }
    int text = slot->tag == proton_Signal_string_value_tag ||
               slot->tag == proton_Signal_list_string_value_tag;
    if (len > slot->item_size - (text ? 1 : 0) ||
        (!text && len != slot->item_size)) {
        return 0;
    }
    memset(into, 0, slot->item_size);
    memcpy(into, g_value, len);
    return 1;
}

static int set(uint32_t id, size_t index, char *value)
{
    described_t *d = find(id);
    if (d == NULL || index >= d->count) {
        return 0;
    }
    slot_t *slot = &d->slots[index];
    if (slot->length == 0) {
        return store(slot, slot->storage, value);
    }
    size_t i = 0;
    for (char *item = strtok(value, ","); item != NULL; item = strtok(NULL, ",")) {
        if (i == slot->length || !store(slot, slot->storage + i * slot->item_size, item)) {
            return 0;
        }
        i++;
    }
    return i == slot->length;
}

static void show_item(const slot_t *slot, const uint8_t *item)
{
    int text = slot->tag == proton_Signal_string_value_tag ||
               slot->tag == proton_Signal_list_string_value_tag;
    put_hex(item, text ? strnlen((const char *)item, slot->item_size) : slot->item_size);
}

static void decode(size_t len)
{
    uint32_t id = 0;
    if (!PROTON_DecodeId(&id, g_buffer, len)) {
        id = 0; /* no id first: the bundle of id 0, whose id is not sent */
    }
    described_t *d = find(id);
    if (d == NULL) {
        printf("ERR no bundle %u", (unsigned)id);
        return;
    }
    for (size_t i = 0; i < d->count; i++) {
        slot_t *slot = &d->slots[i];
        memset(slot->storage, 0, (slot->length ? slot->length : 1) * slot->item_size);
        wire_up(d, i);
    }
    d->bundle.arg.size = 0;
    if (PROTON_Decode(&d->bundle, g_buffer, len) < 0) {
        fputs("ERR decode", stdout);
        return;
    }
    printf("OK %u", (unsigned)id);
    for (size_t i = 0; i < d->count; i++) {
        slot_t *slot = &d->slots[i];
        fputs(" ", stdout);
        if (slot->length == 0) {
            if (slot->tag == proton_Signal_bytes_value_tag) {
                put_hex(slot->storage, d->signals[i].arg.size);
            } else {
                show_item(slot, slot->storage);
            }
            continue;
        }
        for (size_t k = 0; k < slot->length; k++) {
            if (k) fputs(",", stdout);
            show_item(slot, slot->storage + k * slot->item_size);
        }
    }
}

static void frame(size_t len)
{
    static uint8_t out[1 << 17];
    if (len > UINT16_MAX || !PROTON_FillFrameHeader(out, (uint16_t)len) ||
        !PROTON_FillCRC16(g_buffer, (uint16_t)len, out + 4 + len)) {
        fputs("ERR frame", stdout);
        return;
    }
    memcpy(out + 4, g_buffer, len);
    fputs("OK ", stdout);
    put_hex(out, len + 6);
}

static void unframe(size_t len)
{
    uint16_t payload = len < 4 ? 0 : PROTON_GetFramedPayloadLength(g_buffer);
    if (len < 6 || (size_t)payload + 6 != len) {
        fputs("ERR length", stdout);
        return;
    }
    uint16_t crc = (uint16_t)(g_buffer[4 + payload] | g_buffer[5 + payload] << 8);
    if (!PROTON_CheckFramedPayload(g_buffer + 4, payload, crc)) {
        fputs("ERR crc", stdout);
        return;
    }
    fputs("OK ", stdout);
    put_hex(g_buffer + 4, payload);
}

int main(void)
{
    char *line = NULL;
    size_t room = 0;
    while (getline(&line, &room, stdin) > 0) {
        line[strcspn(line, "\n")] = '\0';
        char *rest = NULL;
        char *verb = strtok_r(line, " ", &rest);
        char *first = strtok_r(NULL, " ", &rest);
        size_t len = 0;
        if (verb == NULL || first == NULL) {
            fputs("ERR request", stdout);
        } else if (strcmp(verb, "B") == 0) {
            fputs(describe((uint32_t)strtoul(first, NULL, 0), rest) ? "OK" : "ERR describe", stdout);
        } else if (strcmp(verb, "S") == 0) {
            char *index = strtok_r(NULL, " ", &rest);
            char *value = strtok_r(NULL, " ", &rest);
            int ok = index && value && set((uint32_t)strtoul(first, NULL, 0), strtoul(index, NULL, 0), value);
            fputs(ok ? "OK" : "ERR set", stdout);
        } else if (strcmp(verb, "E") == 0) {
            described_t *d = find((uint32_t)strtoul(first, NULL, 0));
            int written = d ? PROTON_Encode(&d->bundle, g_buffer, sizeof g_buffer) : -1;
            if (written < 0) {
                fputs("ERR encode", stdout);
            } else {
                fputs("OK ", stdout);
                put_hex(g_buffer, (size_t)written);
            }
        } else if (strchr("DFU", verb[0]) != NULL && verb[1] == '\0' &&
                   from_hex(first, g_buffer, sizeof g_buffer, &len)) {
            if (verb[0] == 'D') {
                decode(len);
            } else if (verb[0] == 'F') {
                frame(len);
            } else {
                unframe(len);
            }
        } else {
            fputs("ERR request", stdout);
        }
        fputs("\n", stdout);
        fflush(stdout);
    }
    free(line);
    return 0;
}
