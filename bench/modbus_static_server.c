/*
 * modbus_static_server.c - the benchmark's peer: the minimal libmodbus TCP
 * server a Modbus integrator would write, in the shape of libmodbus's
 * bandwidth-server-many-up example (one thread, select() over the
 * listening socket and every client, modbus_receive then modbus_reply
 * against a static register mapping).  Written here for the benchmark;
 * none of the example's code is used.
 *
 *   modbus-static-server PORT      (0: the kernel picks; "port N" on stdout)
 *
 * The input registers hold what qmcd's result block holds for the bench's
 * point (sobol, 4 dims, float32, index 1: every coordinate 0.5), so both
 * servers answer the same bytes.  Runs until killed.
 */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <errno.h>
#include <modbus.h>
#include <netinet/in.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/select.h>
#include <sys/socket.h>
#include <unistd.h>

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: modbus-static-server PORT\n");
        return 2;
    }
    modbus_t *ctx = modbus_new_tcp("127.0.0.1", atoi(argv[1]));
    modbus_mapping_t *map = modbus_mapping_new(0, 0, 0, 70);
    if (!ctx || !map) {
        fprintf(stderr, "modbus-static-server: %s\n", modbus_strerror(errno));
        return 1;
    }
    /* echo 1, status 0, index 1, then 0.5f = 0x3F000000 four times. */
    const uint16_t block[14] = {1, 0, 0, 0, 0, 1, 0x3F00, 0, 0x3F00, 0, 0x3F00, 0, 0x3F00, 0};
    memcpy(map->tab_input_registers, block, sizeof block);
    int server = modbus_tcp_listen(ctx, 64);
    if (server < 0) {
        fprintf(stderr, "modbus-static-server: listen: %s\n", modbus_strerror(errno));
        return 1;
    }
    struct sockaddr_in sa;
    socklen_t len = sizeof sa;
    getsockname(server, (struct sockaddr *)&sa, &len);
    printf("port %u\n", ntohs(sa.sin_port));
    fflush(stdout);
    fd_set all;
    FD_ZERO(&all);
    FD_SET(server, &all);
    int top = server;
    uint8_t query[MODBUS_TCP_MAX_ADU_LENGTH];
    for (;;) {
        fd_set ready = all;
        if (select(top + 1, &ready, NULL, NULL, NULL) < 0) {
            if (errno == EINTR)
                continue;
            perror("modbus-static-server: select");
            return 1;
        }
        for (int fd = 0; fd <= top; fd++) {
            if (!FD_ISSET(fd, &ready))
                continue;
            if (fd == server) {
                int c = accept(server, NULL, NULL);
                if (c >= 0 && c < FD_SETSIZE) {
                    FD_SET(c, &all);
                    if (c > top)
                        top = c;
                } else if (c >= 0) {
                    close(c); /* select() cannot watch it */
                }
                continue;
            }
            /* modbus_receive waits here for the rest of this client's
             * frame, the stall the benchmark measures. */
            modbus_set_socket(ctx, fd);
            int n = modbus_receive(ctx, query);
            if (n > 0) {
                modbus_reply(ctx, query, n, map);
            } else if (n < 0) {
                close(fd);
                FD_CLR(fd, &all);
            }
        }
    }
}
