/* A peer for tests/test_proton_interop.py: Proton 2.0's C core, driven line by line.
 *
 * Linked with Proton's core (registry, encode/decode, serial framing) and the registry its
 * generator wrote for one node of a configuration (g_proton_registry). One request per line on
 * stdin, one answer per line on stdout; hex "-" stands for no bytes:
 *
 *   S ID HEX   set signal ID through proton_signal_set_<type>: HEX is the value's bytes as the
 *              C variable holds them (little-endian numbers, a bool's one byte), a string's
 *              text without its NUL, a bytes value's bytes           -> OK | ERR status
 *   E ID       proton_encode_bundle(ID)                              -> OK HEX | ERR status
 *   D HEX      proton_decode(HEX), then every signal of the bundle read back through
 *              proton_signal_get_<type>, in the bundle's order       -> OK BUNDLE ID=HEX ... | ERR
 *   F HEX      a serial frame around HEX, by proton_serial_fill_frame_header and _fill_crc16
 *   U HEX      one frame checked by proton_serial_get_framed_payload_length and
 *              _check_framed_payload                                 -> OK PAYLOAD | ERR status
 *   T ID       proton_node_trigger_bundle(ID) on the generated node  -> OK | ERR status
 *   P MS       proton_node_update at uptime MS until it has nothing more to send: every message
 *              it encodes, in its order                             -> OK HEX... | ERR status
 */
#define _POSIX_C_SOURCE 200809L

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "proton/encode_decode.h"
#include "proton/node_manager.h"
#include "proton/registry.h"
#include "proton/transport/serial.h"

extern proton_registry_t g_proton_registry;
extern proton_node_t g_target_node;

static uint8_t g_in[1 << 17];
static uint8_t g_out[1 << 17];

static int from_hex(const char *text, uint8_t *out, size_t room, size_t *len)
{
    if (strcmp(text, "-") == 0) {
        *len = 0;
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

static proton_status_e set_signal(uint32_t id, const uint8_t *value, size_t len)
{
    const signal_desc_t *desc = proton_registry_get_signal(&g_proton_registry, id, NULL);
    if (desc == NULL) {
        return PROTON_ERROR;
    }
    union {
        double d;
        float f;
        int32_t i32;
        int64_t i64;
        uint32_t u32;
        uint64_t u64;
        bool b;
    } number;
    memset(&number, 0, sizeof number);
    switch (desc->type) {
    case PROTON_STRING: {
        static char text[1 << 16];
        if (len >= sizeof text) {
            return PROTON_INSUFFICIENT_BUFFER_ERROR;
        }
        memcpy(text, value, len);
        text[len] = '\0';
        return proton_signal_set_string(&g_proton_registry, id, text, len + 1);
    }
    case PROTON_BYTES:
        return proton_signal_set_bytes(&g_proton_registry, id, len ? value : NULL, len);
    default:
        break;
    }
    if (len != get_signal_value_size(desc->type, 0)) {
        return PROTON_INSUFFICIENT_BUFFER_ERROR;
    }
    memcpy(&number, value, len);
    switch (desc->type) {
    case PROTON_DOUBLE:
        return proton_signal_set_double(&g_proton_registry, id, number.d);
    case PROTON_FLOAT:
        return proton_signal_set_float(&g_proton_registry, id, number.f);
    case PROTON_INT32:
        return proton_signal_set_int32(&g_proton_registry, id, number.i32);
    case PROTON_INT64:
        return proton_signal_set_int64(&g_proton_registry, id, number.i64);
    case PROTON_UINT32:
        return proton_signal_set_uint32(&g_proton_registry, id, number.u32);
    case PROTON_UINT64:
        return proton_signal_set_uint64(&g_proton_registry, id, number.u64);
    case PROTON_BOOL:
        return proton_signal_set_bool(&g_proton_registry, id, number.b);
    default:
        return PROTON_ERROR;
    }
}

/* The signal's current value, as set_signal takes it. */
static proton_status_e get_signal(uint32_t id, uint8_t *out, size_t room, size_t *len)
{
    const signal_desc_t *desc = proton_registry_get_signal(&g_proton_registry, id, NULL);
    if (desc == NULL) {
        return PROTON_ERROR;
    }
    proton_status_e status = PROTON_ERROR;
    switch (desc->type) {
    case PROTON_STRING:
        status = proton_signal_get_string(&g_proton_registry, id, (char *)out, room, len);
        if (status == PROTON_OK) {
            *len = strnlen((const char *)out, *len);
        }
        return status;
    case PROTON_BYTES:
        return proton_signal_get_bytes(&g_proton_registry, id, out, room, len);
    case PROTON_DOUBLE: {
        double v;
        status = proton_signal_get_double(&g_proton_registry, id, &v);
        memcpy(out, &v, sizeof v);
        break;
    }
    case PROTON_FLOAT: {
        float v;
        status = proton_signal_get_float(&g_proton_registry, id, &v);
        memcpy(out, &v, sizeof v);
        break;
    }
    case PROTON_INT32: {
        int32_t v;
        status = proton_signal_get_int32(&g_proton_registry, id, &v);
        memcpy(out, &v, sizeof v);
        break;
    }
    case PROTON_INT64: {
        int64_t v;
        status = proton_signal_get_int64(&g_proton_registry, id, &v);
        memcpy(out, &v, sizeof v);
        break;
    }
    case PROTON_UINT32: {
        uint32_t v;
        status = proton_signal_get_uint32(&g_proton_registry, id, &v);
        memcpy(out, &v, sizeof v);
        break;
    }
    case PROTON_UINT64: {
        uint64_t v;
        status = proton_signal_get_uint64(&g_proton_registry, id, &v);
        memcpy(out, &v, sizeof v);
        break;
    }
    case PROTON_BOOL: {
        bool v;
        status = proton_signal_get_bool(&g_proton_registry, id, &v);
        out[0] = v ? 1 : 0;
        break;
    }
    default:
        return PROTON_ERROR;
    }
    *len = get_signal_value_size(desc->type, 0);
    return status;
}

static void decode(size_t len)
{
    proton_Proton message = proton_Proton_init_zero;
    proton_status_e status = proton_decode(&g_proton_registry, g_in, len, &message);
    if (status != PROTON_OK) {
        printf("ERR %d", (int)status);
        return;
    }
    uint32_t bundle_id = message.operation.bundle.id;
    const bundle_desc_t *bundle = proton_registry_get_bundle(&g_proton_registry, bundle_id, NULL);
    if (bundle == NULL) {
        printf("ERR no bundle %u", (unsigned)bundle_id);
        return;
    }
    printf("OK %u", (unsigned)bundle_id);
    for (size_t i = 0; i < bundle->signal_ids.count; i++) {
        size_t value_len = 0;
        uint32_t id = bundle->signal_ids.ids[i];
        status = get_signal(id, g_out, sizeof g_out, &value_len);
        if (status != PROTON_OK) {
            printf(" %u=ERR%d", (unsigned)id, (int)status);
            continue;
        }
        printf(" %u=", (unsigned)id);
        put_hex(g_out, value_len);
    }
}

static void frame(size_t len)
{
    if (len > UINT16_MAX || proton_serial_fill_frame_header(g_out, (uint16_t)len) != PROTON_OK ||
        proton_serial_fill_crc16(g_in, (uint16_t)len, g_out + 4 + len) != PROTON_OK) {
        fputs("ERR frame", stdout);
        return;
    }
    memcpy(g_out + 4, g_in, len);
    fputs("OK ", stdout);
    put_hex(g_out, len + PROTON_FRAME_OVERHEAD);
}

static void unframe(size_t len)
{
    uint16_t payload_len = 0;
    proton_status_e status = len < 4 ? PROTON_INVALID_HEADER_ERROR
                                     : proton_serial_get_framed_payload_length(g_in, &payload_len);
    if (status == PROTON_OK && (size_t)payload_len + PROTON_FRAME_OVERHEAD != len) {
        status = PROTON_INSUFFICIENT_BUFFER_ERROR;
    }
    if (status == PROTON_OK) {
        uint16_t crc = (uint16_t)(g_in[4 + payload_len] | g_in[5 + payload_len] << 8);
        status = proton_serial_check_framed_payload(g_in + 4, payload_len, crc);
    }
    if (status != PROTON_OK) {
        printf("ERR %d", (int)status);
        return;
    }
    fputs("OK ", stdout);
    put_hex(g_in + 4, payload_len);
}

static void update(uint64_t uptime_ms)
{
    proton_endpoint_t peers[8];
    fputs("OK", stdout);
    for (;;) {
        size_t written = 0;
        size_t selected = 0;
        proton_status_e status = proton_node_update(
            &g_target_node, uptime_ms, g_out, sizeof g_out, &written, peers, 8, &selected);
        if (status != PROTON_OK) {
            printf(" ERR%d", (int)status);
            return;
        }
        if (written == 0) {
            return; /* nothing was due: every Proton message is at least two bytes */
        }
        fputs(" ", stdout);
        put_hex(g_out, written);
    }
}

int main(void)
{
    g_target_node.registry = &g_proton_registry;
    char *line = NULL;
    size_t room = 0;
    ssize_t got;
    while ((got = getline(&line, &room, stdin)) > 0) {
        line[strcspn(line, "\n")] = '\0';
        char *verb = strtok(line, " ");
        char *first = strtok(NULL, " ");
        char *second = strtok(NULL, " ");
        size_t len = 0;
        if (verb == NULL || first == NULL) {
            fputs("ERR request", stdout);
        } else if (strcmp(verb, "S") == 0 && second != NULL &&
                   from_hex(second, g_in, sizeof g_in, &len)) {
            proton_status_e status = set_signal((uint32_t)strtoul(first, NULL, 0), g_in, len);
            printf(status == PROTON_OK ? "OK" : "ERR %d", (int)status);
        } else if (strcmp(verb, "E") == 0) {
            size_t written = 0;
            proton_status_e status = proton_encode_bundle(
                &g_proton_registry, (uint32_t)strtoul(first, NULL, 0), g_out, sizeof g_out,
                &written);
            if (status == PROTON_OK) {
                fputs("OK ", stdout);
                put_hex(g_out, written);
            } else {
                printf("ERR %d", (int)status);
            }
        } else if (strcmp(verb, "T") == 0) {
            proton_status_e status =
                proton_node_trigger_bundle(&g_target_node, (uint32_t)strtoul(first, NULL, 0));
            printf(status == PROTON_OK ? "OK" : "ERR %d", (int)status);
        } else if (strcmp(verb, "P") == 0) {
            update((uint64_t)strtoull(first, NULL, 0));
        } else if (strchr("DFU", verb[0]) != NULL && verb[1] == '\0' &&
                   from_hex(first, g_in, sizeof g_in, &len)) {
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
