/*
 * fuzz_modbus.c - libFuzzer target for the Modbus request handler
 * (protocol/modbus.c, protocol/modbus_ident.c, protocol/modbus_integrate.c).
 *
 * The input is a sequence of PDUs, each a length byte (1..253; 0 skips)
 * and that many bytes, fed one after another to one session, as a client
 * would over one connection; a second session gets the same sequence.
 * After every request: the answer is 2..253 bytes, echoes the function
 * code (bit 7 set exactly for an exception, which is 2 bytes with a code
 * the handler sends, 01..04), a read's byte count matches its quantity,
 * both sessions gave the same bytes (the handler is a pure function of
 * the session and the request), the holding registers still hold values
 * their ranges allow, and a request that qmc_modbus_request_writes calls
 * read-only, or one answered with an exception, left the registers, the
 * result block and the integration block (setup, value, status block,
 * request numbering) as they were (the TCP transport answers such
 * requests from one shared bank, and drops a bank made for a refused
 * write).  The integration session runs for real: the seeds in
 * tests/fuzz/corpus/modbus/integrate_*.bin start sessions and answer
 * their points in order, so mutations reach the batch boundaries, the
 * end of a session, NaN values and stale numbers.  Its memory room is
 * 32 MiB, so a mutated setup may also be refused for memory.  ASan and
 * UBSan watch every access.
 *
 * The Makefile's fuzz rule links build/fuzz/libqmc.a (the points come from
 * core), so the handler's sources are compiled in here with the fuzzer's
 * coverage flags, as fuzz_proto.c does with the codec.
 */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "../../protocol/modbus.c"
#include "../../protocol/modbus_ident.c"
#include "../../protocol/modbus_integrate.c"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static const qmc_modbus_env env = {.uptime_s = 1, .requests = 2, .exceptions = 3,
                                   .sobol_table_hash = 0xfeedfacecafebeefull,
                                   .version = "0.1.0", .integration_bytes_max = 32u << 20};

static void check_reply(const uint8_t *req, size_t n, const uint8_t *resp, int r)
{
    if (r < 2 || r > (int)QMC_MODBUS_MAX_PDU)
        __builtin_trap();
    if ((resp[0] & 0x7F) != (req[0] & 0x7F))
        __builtin_trap();
    int is_exc = (resp[0] & 0x80) && (r == 2) && resp[1] >= 1 && resp[1] <= 4;
    if (req[0] & 0x80) {
        if (!is_exc || resp[1] != QMC_MODBUS_EX_ILLEGAL_FUNCTION)
            __builtin_trap();
        return;
    }
    if (resp[0] & 0x80) {
        if (!is_exc)
            __builtin_trap();
        return;
    }
    if ((req[0] == 0x03 || req[0] == 0x04) &&
        (n != 5 || resp[1] != 2 * (req[3] << 8 | req[4]) || r != 2 + resp[1]))
        __builtin_trap();
    if (req[0] == 0x17 && r != 2 + resp[1])
        __builtin_trap();
    if (req[0] == 0x06 && (r != 5 || memcmp(req, resp, 5) != 0))
        __builtin_trap();
    if (req[0] == 0x10 && (r != 5 || memcmp(req, resp, 5) != 0))
        __builtin_trap();
}

static void check_holding(qmc_modbus_session *s)
{
    for (unsigned i = 0; i < QMC_MODBUS_HOLDING_COUNT; i++)
        if (s->hr[i] < hr_min[i] || s->hr[i] > hr_max[i])
            __builtin_trap();
    if (s->result[1] > QMC_MODBUS_STATUS_BAD_INDEX)
        __builtin_trap();
    const qmc__mb_integ *g = &s->integ;
    for (unsigned i = 0; i < QMC_MODBUS_SETUP_COUNT; i++)
        if (g->setup[i] < setup_min[i] || g->setup[i] > setup_max[i])
            __builtin_trap();
    if (g->status < QMC_MODBUS_INTEG_NONE || g->status > QMC_MODBUS_INTEG_NO_MEMORY ||
        (g->status == QMC_MODBUS_INTEG_WAITING) != (g->sess != NULL) || g->next_request == 0)
        __builtin_trap();
    if (g->sess && (g->cursor >= g->batch.count || g->batch.count > g->vals_cap ||
                    g->request == 0 || g->evals < g->cursor))
        __builtin_trap();
}

/* What a master can see of the integration block, and what decides what
 * it will see (the request numbering and the last value taken). */
typedef struct integ_view {
    uint16_t setup[QMC_MODBUS_SETUP_COUNT], value[QMC_MODBUS_VALUE_COUNT];
    uint16_t ib[QMC_MODBUS_INTEG_COUNT];
    int has_value;
    uint32_t next_request;
    uint64_t refused;
} integ_view;

static void view_of(const qmc_modbus_session *s, integ_view *v)
{
    memset(v, 0, sizeof *v);
    memcpy(v->setup, s->integ.setup, sizeof v->setup);
    memcpy(v->value, s->integ.value, sizeof v->value);
    qmc__mb_integ_render(&s->integ, s->hr, v->ib);
    v->has_value = s->integ.has_value;
    v->next_request = s->integ.next_request;
    v->refused = s->integ.refused;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    qmc_modbus_session *a = NULL, *b = NULL;
    if (qmc_modbus_session_new(&a) != 0 || qmc_modbus_session_new(&b) != 0)
        goto out;
    size_t off = 0;
    while (off < size) {
        size_t n = data[off++];
        if (n == 0)
            continue;
        if (n > size - off)
            n = size - off;
        if (n == 0 || n > QMC_MODBUS_MAX_PDU)
            break;
        uint8_t ra[QMC_MODBUS_MAX_PDU], rb[QMC_MODBUS_MAX_PDU];
        uint16_t hr[QMC_MODBUS_HOLDING_COUNT], result[QMC_MODBUS_RESULT_REGS];
        int had = a->has_result;
        memcpy(hr, a->hr, sizeof hr);
        memcpy(result, a->result, sizeof result);
        integ_view before, after;
        view_of(a, &before);
        int x = qmc_modbus_handle(a, &env, data + off, n, ra, sizeof ra);
        view_of(a, &after);
        if ((!qmc_modbus_request_writes(data + off, n) || (x > 0 && (ra[0] & 0x80))) &&
            (had != a->has_result || memcmp(hr, a->hr, sizeof hr) != 0 ||
             memcmp(result, a->result, sizeof result) != 0 ||
             memcmp(&before, &after, sizeof before) != 0))
            __builtin_trap();
        int y = qmc_modbus_handle(b, &env, data + off, n, rb, sizeof rb);
        check_reply(data + off, n, ra, x);
        if (x != y || memcmp(ra, rb, (size_t)x) != 0)
            __builtin_trap();
        check_holding(a);
        off += n;
    }
out:
    qmc_modbus_session_free(a);
    qmc_modbus_session_free(b);
    return 0;
}
