/* A driving board as the fleet's: sends its periodic diagnostics stripped (trailing zeros cut,
 * as the boards' firmware does) and decodes every datagram it receives with plain pb_decode on
 * the datagram's exact length.
 *
 *   board COUNT PERIOD_MS    binds 127.0.0.1:0, prints "PORT <port>", then reads "RELAY <port>"
 *                            on stdin and sends COUNT diagnostics, one every PERIOD_MS, cycling
 *                            through payloads whose encodings end in zeros (all-zero ones too).
 * stdout, one line each: "SENT <i> <hex>" per datagram sent; per datagram received,
 * "CMD <member number> <distance_to_go> <turning_radius> <timeout>" or "ERR <nanopb's error>".
 * "QUIT" on stdin ends it.
 */
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <pb_decode.h>
#include <pb_encode.h>

#include "components/common/envelope.pb.h"

static double now_ms(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec * 1e3 + t.tv_nsec / 1e6;
}

/* The i-th diagnostic: all-zero diagnostics ("42 00"), a progress report whose float ends in
 * zeros (1e-40 is denormal), an operating board whose last motor is present but empty
 * ("5a 00"), an all-zero progress report ("52 00"). */
static size_t diagnostic(unsigned i, uint8_t *buffer)
{
    PBEnvelope envelope = PBEnvelope_init_zero;
    switch (i % 4) {
    case 0:
        envelope.which_payload = PBEnvelope_drive_diag_tag;
        break;
    case 1:
        envelope.which_payload = PBEnvelope_drive_progress_tag;
        envelope.payload.drive_progress.distance_left = 1e-40f;
        break;
    case 2:
        envelope.which_payload = PBEnvelope_drive_diag_tag;
        envelope.payload.drive_diag.state = DrivingBoardState_DRIVING_BOARD_STATE_OPERATING;
        envelope.payload.drive_diag.has_steering_back_right_motor = true;
        break;
    default:
        envelope.which_payload = PBEnvelope_drive_progress_tag;
        break;
    }
    pb_ostream_t stream = pb_ostream_from_buffer(buffer, PBEnvelope_size);
    if (!pb_encode(&stream, PBEnvelope_fields, &envelope)) {
        fprintf(stderr, "encode: %s\n", PB_GET_ERROR(&stream));
        exit(1);
    }
    size_t length = stream.bytes_written;
    while (length > 0 && buffer[length - 1] == 0) /* the fleet's senders strip */
        length--;
    return length;
}

static void received(const uint8_t *data, size_t length)
{
    PBEnvelope envelope = PBEnvelope_init_zero;
    pb_istream_t stream = pb_istream_from_buffer(data, length);
    if (!pb_decode(&stream, PBEnvelope_fields, &envelope)) { /* plain: exact length */
        printf("ERR %s\n", PB_GET_ERROR(&stream));
    } else if (envelope.which_payload == PBEnvelope_drive_motor_tag) {
        printf("CMD %u %g %g %u\n", (unsigned)envelope.which_payload,
               envelope.payload.drive_motor.distance_to_go,
               envelope.payload.drive_motor.turning_radius, (unsigned)envelope.timeout);
    } else {
        printf("CMD %u - - %u\n", (unsigned)envelope.which_payload, (unsigned)envelope.timeout);
    }
    fflush(stdout);
}

int main(int argc, char **argv)
{
    if (argc != 3)
        return 2;
    unsigned count = (unsigned)atoi(argv[1]);
    double period = atof(argv[2]);
    int sock = socket(AF_INET, SOCK_DGRAM, 0);
    struct sockaddr_in local = {.sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK)};
    socklen_t size = sizeof local;
    if (sock < 0 || bind(sock, (struct sockaddr *)&local, sizeof local) != 0 ||
        getsockname(sock, (struct sockaddr *)&local, &size) != 0)
        return 1;
    printf("PORT %u\n", ntohs(local.sin_port));
    fflush(stdout);

    char line[256];
    unsigned port;
    if (!fgets(line, sizeof line, stdin) || sscanf(line, "RELAY %u", &port) != 1)
        return 2;
    struct sockaddr_in relay = {.sin_family = AF_INET, .sin_port = htons((uint16_t)port),
                                .sin_addr.s_addr = htonl(INADDR_LOOPBACK)};
    unsigned sent = 0;
    double next = now_ms();
    for (;;) {
        double wait = sent < count ? next - now_ms() : 1000;
        struct pollfd fds[2] = {{.fd = sock, .events = POLLIN}, {.fd = 0, .events = POLLIN}};
        if (poll(fds, 2, wait > 0 ? (int)wait + 1 : 0) < 0)
            return 1;
        if (fds[0].revents & POLLIN) {
            uint8_t data[PBEnvelope_size + 64];
            ssize_t length = recv(sock, data, sizeof data, 0);
            if (length >= 0)
                received(data, (size_t)length);
        }
        if (fds[1].revents & (POLLIN | POLLHUP)) {
            if (!fgets(line, sizeof line, stdin) || strncmp(line, "QUIT", 4) == 0)
                return 0;
        }
        if (sent < count && now_ms() >= next) {
            uint8_t buffer[PBEnvelope_size];
            size_t length = diagnostic(sent, buffer);
            sendto(sock, buffer, length, 0, (struct sockaddr *)&relay, sizeof relay);
            printf("SENT %u ", sent);
            for (size_t i = 0; i < length; i++)
                printf("%02x", buffer[i]);
            printf("\n");
            fflush(stdout);
            sent++;
            next += period;
        }
    }
}
