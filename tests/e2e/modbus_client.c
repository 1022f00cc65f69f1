/*
 * modbus_client.c - a small Modbus master on libmodbus for the e2e test
 * (tests/e2e/test_modbus.sh), over TCP or an RTU serial line.
 *
 *   modbus-client tcp:HOST:PORT|rtu:DEVICE UNIT point KIND DIMS SCRAMBLE SEED
 *                 FORMAT WORDORDER INDEX REQUEST
 *       One FC23 (modbus_write_and_read_registers): writes holding 0..12
 *       (auto-advance off) and reads the result block back from 100 in the
 *       same transaction.  Prints the six header registers on one line
 *       and the coordinate registers on the next, as 4-digit hex words.
 *   ... UNIT report        FC17: prints the additional data as text.
 *   ... UNIT input ADDR N  FC04: prints N registers, decimal.
 *   ... UNIT write ADDR V  FC06 (UNIT 0: a broadcast, no answer awaited).
 *
 * Exit status 0, or 3 after "modbus-client: <what>: <libmodbus error>"
 * (an exception arrives as EMBXILADD and friends; a unit that does not
 * answer as a timeout).
 *
 * The response timeout is 10 s, or MODBUS_CLIENT_TIMEOUT_MS from the
 * environment: a test that expects no answer sets it short, so that the
 * answers every other call expects are not raced by a sanitized daemon on
 * a loaded machine.
 */
#include <errno.h>
#include <modbus.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int fail(modbus_t *ctx, const char *what)
{
    fprintf(stderr, "modbus-client: %s: %s\n", what, modbus_strerror(errno));
    if (ctx) {
        modbus_close(ctx);
        modbus_free(ctx);
    }
    return 3;
}

static modbus_t *open_ctx(const char *ep)
{
    if (strncmp(ep, "tcp:", 4) == 0) {
        char host[128];
        const char *colon = strrchr(ep + 4, ':');
        if (!colon || (size_t)(colon - ep - 4) >= sizeof host)
            return NULL;
        memcpy(host, ep + 4, (size_t)(colon - ep - 4));
        host[colon - ep - 4] = '\0';
        return modbus_new_tcp_pi(host, colon + 1);
    }
    if (strncmp(ep, "rtu:", 4) == 0)
        return modbus_new_rtu(ep + 4, 19200, 'E', 8, 1);
    return NULL;
}

int main(int argc, char **argv)
{
    if (argc < 4) {
        fprintf(stderr, "usage: modbus-client ENDPOINT UNIT point|report|input|write ...\n");
        return 2;
    }
    modbus_t *ctx = open_ctx(argv[1]);
    if (!ctx)
        return fail(NULL, "bad endpoint");
    int unit = atoi(argv[2]);
    const char *t = getenv("MODBUS_CLIENT_TIMEOUT_MS");
    long ms = t ? strtol(t, NULL, 10) : 10000;
    if (ms < 1)
        ms = 10000;
    modbus_set_response_timeout(ctx, (uint32_t)(ms / 1000), (uint32_t)(ms % 1000) * 1000);
    if (modbus_set_slave(ctx, unit) != 0)
        return fail(ctx, "unit");
    if (modbus_connect(ctx) != 0)
        return fail(ctx, "connect");
    const char *op = argv[3];
    if (strcmp(op, "point") == 0 && argc == 12) {
        unsigned long v[8];
        for (int i = 0; i < 8; i++)
            v[i] = strtoul(argv[4 + i], NULL, 0);
        unsigned long long index = strtoull(argv[10], NULL, 0);
        uint16_t w[13] = {(uint16_t)v[0], (uint16_t)v[1], (uint16_t)v[2],
                          (uint16_t)(v[3] >> 16), (uint16_t)v[3], (uint16_t)v[4],
                          (uint16_t)(index >> 48), (uint16_t)(index >> 32),
                          (uint16_t)(index >> 16), (uint16_t)index,
                          (uint16_t)strtoul(argv[11], NULL, 0), 0, (uint16_t)v[5]};
        unsigned dims = (unsigned)v[1];
        int words = (int)(v[4] == 1 ? dims : 2 * dims);
        uint16_t r[6 + 64];
        if (modbus_write_and_read_registers(ctx, 0, 13, w, 100, 6 + words, r) != 6 + words)
            return fail(ctx, "write_and_read_registers");
        for (int i = 0; i < 6; i++)
            printf(i < 5 ? "%04x " : "%04x\n", r[i]);
        for (int i = 0; i < words; i++)
            printf(i + 1 < words ? "%04x " : "%04x\n", r[6 + i]);
    } else if (strcmp(op, "report") == 0) {
        uint8_t id[256];
        int n = modbus_report_slave_id(ctx, sizeof id, id);
        if (n < 2)
            return fail(ctx, "report_slave_id");
        printf("%02x %02x %.*s\n", id[0], id[1], n - 2, (const char *)id + 2);
    } else if (strcmp(op, "input") == 0 && argc == 6) {
        int addr = atoi(argv[4]), n = atoi(argv[5]);
        uint16_t r[125];
        if (n < 1 || n > 125 || modbus_read_input_registers(ctx, addr, n, r) != n)
            return fail(ctx, "read_input_registers");
        for (int i = 0; i < n; i++)
            printf(i + 1 < n ? "%u " : "%u\n", r[i]);
    } else if (strcmp(op, "write") == 0 && argc == 6) {
        if (modbus_write_register(ctx, atoi(argv[4]), atoi(argv[5])) != 1)
            return fail(ctx, "write_register");
    } else {
        fprintf(stderr, "modbus-client: unknown operation '%s' or wrong arguments\n", op);
        modbus_free(ctx);
        return 2;
    }
    modbus_close(ctx);
    modbus_free(ctx);
    return 0;
}
