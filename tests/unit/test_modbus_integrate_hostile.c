/*
 * test_modbus_integrate_hostile.c - what a careless or hostile master can
 * do to the integration block (protocol/MODBUS.md section 9), through the
 * pure handler: stale, future and reused request numbers, values written
 * in pieces or with the wrong quantity, NaN and infinities, registers out
 * of range or read-only, setups the core refuses, a start past the
 * bank's memory, retried and restarted starts.  Each refusal must be the
 * exception MODBUS.md names and change nothing a master can read (the
 * whole block compared before and after); each acknowledged retry too.
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "modbus_device.h"
#include "qmc/modbus.h"
#include "qmc/result.h"

static const qmc_modbus_env env = {.version = "0.1.0", .integration_bytes_max = 64u << 20};

static double one(const double *x, uint32_t dims)
{
    (void)x, (void)dims;
    return 1.0;
}

static double first(const double *x, uint32_t dims)
{
    (void)dims;
    return x[0];
}

/* rqmc, 2 dims, 8 x 1024 points, no tolerance: a fixed job of 8192 values. */
static const uint16_t rqmc_setup[QMC_MODBUS_SETUP_COUNT] = {3, 2, 0, 0, 1, 0, 1024, 8, 0, 0,
                                                            0, 0, 0x000F, 0x4240, 950, 0};

static qmc_modbus_session *started(uint16_t start)
{
    qmc_modbus_session *s = NULL;
    assert_int_equal(qmc_modbus_session_new(&s), 0);
    uint16_t w[QMC_MODBUS_SETUP_COUNT];
    memcpy(w, rqmc_setup, sizeof w);
    w[15] = start;
    mb_reply r = mb_write(s, &env, QMC_MODBUS_SETUP_BASE, w, QMC_MODBUS_SETUP_COUNT);
    mb_assert_written(&r);
    return s;
}

static uint32_t request_of(const mb_snapshot *m)
{
    return mb_u32(&m->ib[QMC_MODBUS_IB_REQUEST]);
}

/* The value write for request req, f = v (high word first). */
static void value_regs(uint32_t req, float v, uint16_t w[4])
{
    w[0] = (uint16_t)(req >> 16), w[1] = (uint16_t)req;
    mb_put_f32(&w[2], v, 0);
}

static void assert_unchanged(qmc_modbus_session *s, const mb_snapshot *before)
{
    mb_snapshot after;
    mb_snapshot_take(s, &env, &after);
    assert_memory_equal(before, &after, sizeof after);
}

/* Stale, future and reused request numbers; the retry of the write taken
 * last is acknowledged and changes nothing. */
static void test_request_numbers(void **state)
{
    (void)state;
    qmc_modbus_session *s = started(1);
    mb_snapshot m;
    mb_snapshot_take(s, &env, &m);
    assert_int_equal(m.ib[QMC_MODBUS_IB_STATUS], QMC_MODBUS_INTEG_WAITING);
    const uint32_t first = request_of(&m);
    assert_true(first != 0);
    uint16_t w[4];
    /* Nothing written yet: the previous number, and the next, are refused. */
    for (int k = -1; k <= 1; k += 2) {
        value_regs(first + (uint32_t)k, 0.5f, w);
        mb_reply r = mb_write(s, &env, QMC_MODBUS_VALUE_BASE, w, 4);
        mb_assert_exception(&r, 0x10, QMC_MODBUS_EX_ILLEGAL_VALUE);
        assert_unchanged(s, &m);
    }
    value_regs(first, 0.5f, w);
    mb_reply r = mb_write(s, &env, QMC_MODBUS_VALUE_BASE, w, 4);
    mb_assert_written(&r);
    mb_snapshot_take(s, &env, &m);
    assert_int_equal(request_of(&m), first + 1);
    assert_int_equal(mb_u64(&m.ib[QMC_MODBUS_IB_EVALS]), 1);
    assert_memory_equal(m.value, w, sizeof w);
    /* The same write again (its reply was lost): acknowledged, nothing moves. */
    r = mb_write(s, &env, QMC_MODBUS_VALUE_BASE, w, 4);
    mb_assert_written(&r);
    assert_unchanged(s, &m);
    /* The same number with another value: stale, refused. */
    value_regs(first, 0.25f, w);
    r = mb_write(s, &env, QMC_MODBUS_VALUE_BASE, w, 4);
    mb_assert_exception(&r, 0x10, QMC_MODBUS_EX_ILLEGAL_VALUE);
    assert_unchanged(s, &m);
    /* Through FC23 too: a refused value stores nothing and reads nothing. */
    value_regs(first + 7, 0.25f, w);
    r = mb_read_write(s, &env, QMC_MODBUS_INTEG_BASE, 4, QMC_MODBUS_VALUE_BASE, w, 4);
    mb_assert_exception(&r, 0x17, QMC_MODBUS_EX_ILLEGAL_VALUE);
    assert_unchanged(s, &m);
    qmc_modbus_session_free(s);
}

/* A value comes whole: exactly registers 320..323 in one write. */
static void test_wrong_counts(void **state)
{
    (void)state;
    qmc_modbus_session *s = started(1);
    mb_snapshot m;
    mb_snapshot_take(s, &env, &m);
    uint16_t w[6];
    value_regs(request_of(&m), 0.5f, w);
    w[4] = w[5] = 0;
    static const struct {
        unsigned addr, count;
        uint8_t code;
    } bad[] = {
        {320, 1, 3}, {320, 2, 3}, {320, 3, 3}, {320, 5, 3}, {321, 3, 3}, {322, 2, 3},
        {323, 1, 3}, {318, 4, 2}, {316, 1, 2}, {324, 1, 2}, {314, 4, 2}, {400, 1, 2},
        {468, 2, 2},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        mb_reply r = mb_write(s, &env, bad[i].addr, w, bad[i].count);
        mb_assert_exception(&r, 0x10, bad[i].code);
        assert_unchanged(s, &m);
    }
    for (unsigned a = 320; a < 324; a++) {
        mb_reply r = mb_write1(s, &env, a, 1);
        mb_assert_exception(&r, 0x06, QMC_MODBUS_EX_ILLEGAL_VALUE);
    }
    mb_reply r = mb_write1(s, &env, 400, 1);
    mb_assert_exception(&r, 0x06, QMC_MODBUS_EX_ILLEGAL_ADDRESS);
    r = mb_read_write(s, &env, QMC_MODBUS_INTEG_BASE, 4, QMC_MODBUS_VALUE_BASE, w, 2);
    mb_assert_exception(&r, 0x17, QMC_MODBUS_EX_ILLEGAL_VALUE);
    assert_unchanged(s, &m);
    /* Reads: unmapped addresses are 02, a read running off a block 03. */
    static const struct {
        uint8_t fc;
        unsigned addr, count;
        uint8_t code;
    } reads[] = {
        {0x03, 316, 1, 2}, {0x03, 319, 1, 2}, {0x03, 324, 1, 2}, {0x03, 496, 1, 2},
        {0x04, 300, 1, 2}, {0x04, 399, 1, 2}, {0x04, 496, 1, 2}, {0x03, 310, 7, 3},
        {0x03, 322, 3, 3}, {0x04, 490, 7, 3}, {0x03, 400, 97, 3}, {0x04, 224, 1, 2},
    };
    for (size_t i = 0; i < sizeof reads / sizeof reads[0]; i++) {
        r = mb_read(s, &env, reads[i].fc, reads[i].addr, reads[i].count);
        mb_assert_exception(&r, reads[i].fc, reads[i].code);
    }
    assert_unchanged(s, &m);
    qmc_modbus_session_free(s);
}

/* Setup registers out of their ranges: 03, nothing stored, the running
 * session untouched. */
static void test_setup_ranges(void **state)
{
    (void)state;
    qmc_modbus_session *s = started(1);
    mb_snapshot m;
    mb_snapshot_take(s, &env, &m);
    static const struct {
        unsigned addr, v;
    } bad[] = {{300, 0}, {300, 5}, {301, 0}, {301, 33}, {302, 4}, {307, 4097}, {314, 0},
               {314, 1000}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        mb_reply r = mb_write1(s, &env, bad[i].addr, bad[i].v);
        mb_assert_exception(&r, 0x06, QMC_MODBUS_EX_ILLEGAL_VALUE);
        /* In a write that also starts a session: still nothing. */
        uint16_t w[QMC_MODBUS_SETUP_COUNT];
        memcpy(w, rqmc_setup, sizeof w);
        w[bad[i].addr - 300] = (uint16_t)bad[i].v;
        w[15] = 9;
        r = mb_write(s, &env, QMC_MODBUS_SETUP_BASE, w, QMC_MODBUS_SETUP_COUNT);
        mb_assert_exception(&r, 0x10, QMC_MODBUS_EX_ILLEGAL_VALUE);
        assert_unchanged(s, &m);
    }
    qmc_modbus_session_free(s);
}

/* NaN and infinities are taken, counted and flagged at once; the result
 * then says it cannot tell. */
static void test_nonfinite_values(void **state)
{
    (void)state;
    qmc_modbus_session *s = started(1);
    const float odd[3] = {NAN, INFINITY, -INFINITY};
    mb_snapshot m;
    for (int i = 0; i < 3; i++) {
        mb_snapshot_take(s, &env, &m);
        uint16_t w[4];
        value_regs(request_of(&m), odd[i], w);
        mb_reply r = mb_write(s, &env, QMC_MODBUS_VALUE_BASE, w, 4);
        mb_assert_written(&r);
        mb_snapshot_take(s, &env, &m);
        assert_int_equal(mb_u64(&m.ib[QMC_MODBUS_IB_NONFINITE]), (uint64_t)i + 1);
        assert_int_equal(mb_u32(&m.ib[QMC_MODBUS_IB_FLAGS]) &
                             (QMC_FLAG_NONFINITE | QMC_FLAG_ERROR_UNRELIABLE),
                         QMC_FLAG_NONFINITE | QMC_FLAG_ERROR_UNRELIABLE);
    }
    mb_device dev = {2, 0, 0, 0, one};
    assert_int_equal(mb_device_run(s, &env, &dev, 100000), 8192 - 3);
    mb_snapshot_take(s, &env, &m);
    assert_int_equal(m.ib[QMC_MODBUS_IB_STATUS], QMC_MODBUS_INTEG_CANNOT_TELL);
    assert_int_equal(mb_u64(&m.ib[QMC_MODBUS_IB_NONFINITE]), 3);
    assert_true(mb_u32(&m.ib[QMC_MODBUS_IB_FLAGS]) & QMC_FLAG_NONFINITE);
    assert_int_equal(mb_u64(&m.ib[QMC_MODBUS_IB_EVALS]), 8192);
    qmc_modbus_session_free(s);
}

/* Values when nothing waits: before any start, after the end, after a
 * close.  The last value taken is still acknowledged when retried. */
static void test_nothing_waits(void **state)
{
    (void)state;
    qmc_modbus_session *s = NULL;
    assert_int_equal(qmc_modbus_session_new(&s), 0);
    uint16_t w[4];
    value_regs(1, 0.5f, w);
    mb_reply r = mb_write(s, &env, QMC_MODBUS_VALUE_BASE, w, 4);
    mb_assert_exception(&r, 0x10, QMC_MODBUS_EX_ILLEGAL_VALUE);
    qmc_modbus_session_free(s);

    s = started(1);
    mb_device dev = {2, 0, 0, 0, first};
    assert_int_equal(mb_device_run(s, &env, &dev, 100000), 8192);
    mb_snapshot m;
    mb_snapshot_take(s, &env, &m);
    assert_int_equal(m.ib[QMC_MODBUS_IB_STATUS], QMC_MODBUS_INTEG_COMPLETE);
    const double est = mb_f64(&m.ib[QMC_MODBUS_IB_ESTIMATE_F64], 0);
    assert_true(fabs(est - 0.5) <= mb_f64(&m.ib[QMC_MODBUS_IB_BAR_F64], 0));
    memcpy(w, m.value, sizeof w);
    r = mb_write(s, &env, QMC_MODBUS_VALUE_BASE, w, 4); /* the last one, retried */
    mb_assert_written(&r);
    assert_unchanged(s, &m);
    value_regs(mb_u32(w) + 1, 0.5f, w);
    r = mb_write(s, &env, QMC_MODBUS_VALUE_BASE, w, 4);
    mb_assert_exception(&r, 0x10, QMC_MODBUS_EX_ILLEGAL_VALUE);
    assert_unchanged(s, &m);
    qmc_modbus_session_free(s);
}

/* Starts: a retried start number changes nothing (the other registers of
 * its write included); a new one restarts from scratch with new request
 * numbers; 0 closes and frees. */
static void test_starts(void **state)
{
    (void)state;
    qmc_modbus_session *s = started(7);
    mb_device dev = {2, 0, 0, 0, one};
    assert_int_equal(mb_device_run(s, &env, &dev, 10), 10);
    mb_snapshot m;
    mb_snapshot_take(s, &env, &m);
    const uint32_t at = request_of(&m);
    const uint16_t again[2] = {5, 7}; /* confidence 5, and start 7 again */
    mb_reply r = mb_write(s, &env, QMC_MODBUS_SETUP_CONFIDENCE, again, 2);
    mb_assert_written(&r);
    assert_unchanged(s, &m);
    r = mb_write1(s, &env, QMC_MODBUS_SETUP_START, 7);
    assert_int_equal(r.n, 5);
    assert_unchanged(s, &m);
    /* Setup written without a start: stored, the session goes on. */
    r = mb_write1(s, &env, QMC_MODBUS_SETUP_DIMS, 3);
    assert_int_equal(r.n, 5);
    mb_snapshot_take(s, &env, &m);
    assert_int_equal(m.setup[1], 3);
    assert_int_equal(m.ib[QMC_MODBUS_IB_STATUS], QMC_MODBUS_INTEG_WAITING);
    assert_int_equal(request_of(&m), at);
    /* A new start: from scratch, at 3 dims, numbers never reused. */
    r = mb_write1(s, &env, QMC_MODBUS_SETUP_START, 8);
    assert_int_equal(r.n, 5);
    mb_snapshot_take(s, &env, &m);
    assert_int_equal(m.ib[QMC_MODBUS_IB_START], 8);
    assert_int_equal(mb_u64(&m.ib[QMC_MODBUS_IB_EVALS]), 0);
    assert_true(request_of(&m) > at);
    uint16_t w[4];
    value_regs(at, 1.0f, w); /* the old session's number */
    r = mb_write(s, &env, QMC_MODBUS_VALUE_BASE, w, 4);
    mb_assert_exception(&r, 0x10, QMC_MODBUS_EX_ILLEGAL_VALUE);
    qmc_modbus_usage u;
    qmc_modbus_session_usage(s, &u);
    assert_int_equal(u.integrating, 1);
    assert_true(u.integration_bytes > 0);
    assert_int_equal(mb_u64(&m.ib[QMC_MODBUS_IB_BYTES]), u.integration_bytes);
    /* Close. */
    r = mb_write1(s, &env, QMC_MODBUS_SETUP_START, 0);
    assert_int_equal(r.n, 5);
    mb_snapshot_take(s, &env, &m);
    assert_int_equal(m.ib[QMC_MODBUS_IB_STATUS], QMC_MODBUS_INTEG_NONE);
    assert_int_equal(request_of(&m), 0);
    qmc_modbus_session_usage(s, &u);
    assert_int_equal(u.integrating, 0);
    assert_int_equal(u.integration_bytes, 0);
    /* Freed with a session open, too (the sanitized build sees leaks). */
    r = mb_write1(s, &env, QMC_MODBUS_SETUP_START, 9);
    assert_int_equal(r.n, 5);
    qmc_modbus_session_free(s);
}

/* Setups the core refuses: accepted writes, status BAD_SETUP with the
 * core's error code; no memory held. */
static void test_bad_setups(void **state)
{
    (void)state;
    static const struct {
        unsigned reg;
        uint16_t v[2];
        unsigned n;
        int err;
    } cases[] = {
        {307, {1}, 1, QMC_EINVAL},                   /* rqmc with 1 replicate */
        {308, {0xBF80, 0x0000}, 2, QMC_EINVAL},      /* tol_abs -1 */
        {310, {0x7FC0, 0x0000}, 2, QMC_EINVAL},      /* tol_rel NaN */
        {312, {0, 0}, 2, QMC_EBUDGET},               /* a budget of 0 */
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        qmc_modbus_session *s = NULL;
        assert_int_equal(qmc_modbus_session_new(&s), 0);
        uint16_t w[QMC_MODBUS_SETUP_COUNT];
        memcpy(w, rqmc_setup, sizeof w);
        memcpy(&w[cases[i].reg - 300], cases[i].v, cases[i].n * sizeof *w);
        w[15] = 1;
        mb_reply r = mb_write(s, &env, QMC_MODBUS_SETUP_BASE, w, QMC_MODBUS_SETUP_COUNT);
        mb_assert_written(&r);
        mb_snapshot m;
        mb_snapshot_take(s, &env, &m);
        print_message("  setup %zu: status %u, error %u\n", i, m.ib[QMC_MODBUS_IB_STATUS],
                      m.ib[QMC_MODBUS_IB_ERROR]);
        assert_int_equal(m.ib[QMC_MODBUS_IB_STATUS], QMC_MODBUS_INTEG_BAD_SETUP);
        assert_int_equal(m.ib[QMC_MODBUS_IB_ERROR], -cases[i].err);
        assert_int_equal(request_of(&m), 0);
        qmc_modbus_usage u;
        qmc_modbus_session_usage(s, &u);
        assert_int_equal(u.integration_bytes, 0);
        qmc_modbus_session_free(s);
    }
}

/* A start past the bank's room: NO_MEMORY, the bytes it needed shown,
 * nothing held, counted as refused; with room it starts. */
static void test_memory_room(void **state)
{
    (void)state;
    qmc_modbus_session *s = NULL;
    assert_int_equal(qmc_modbus_session_new(&s), 0);
    uint16_t w[QMC_MODBUS_SETUP_COUNT];
    memcpy(w, rqmc_setup, sizeof w);
    w[15] = 1;
    qmc_modbus_env tight = env;
    tight.integration_bytes_max = 4096;
    mb_reply r = mb_write(s, &tight, QMC_MODBUS_SETUP_BASE, w, QMC_MODBUS_SETUP_COUNT);
    mb_assert_written(&r);
    mb_snapshot m;
    mb_snapshot_take(s, &env, &m);
    assert_int_equal(m.ib[QMC_MODBUS_IB_STATUS], QMC_MODBUS_INTEG_NO_MEMORY);
    const uint64_t need = mb_u64(&m.ib[QMC_MODBUS_IB_BYTES]);
    assert_true(need > 4096);
    qmc_modbus_usage u;
    qmc_modbus_session_usage(s, &u);
    assert_int_equal(u.integration_bytes, 0);
    assert_int_equal(u.integrations_refused, 1);
    /* No env, no room. */
    w[15] = 2;
    r = mb_write(s, NULL, QMC_MODBUS_SETUP_BASE, w, QMC_MODBUS_SETUP_COUNT);
    mb_assert_written(&r);
    mb_snapshot_take(s, &env, &m);
    assert_int_equal(m.ib[QMC_MODBUS_IB_STATUS], QMC_MODBUS_INTEG_NO_MEMORY);
    /* Exactly the room it said it needs: it starts, and holds no more. */
    tight.integration_bytes_max = need;
    w[15] = 3;
    r = mb_write(s, &tight, QMC_MODBUS_SETUP_BASE, w, QMC_MODBUS_SETUP_COUNT);
    mb_assert_written(&r);
    mb_snapshot_take(s, &env, &m);
    assert_int_equal(m.ib[QMC_MODBUS_IB_STATUS], QMC_MODBUS_INTEG_WAITING);
    qmc_modbus_session_usage(s, &u);
    assert_int_equal(u.integration_bytes, need);
    assert_int_equal(u.integrations_refused, 2);
    qmc_modbus_session_free(s);
}

/* A batch larger than the 256 values reserved at the start grows them
 * within the room, or fails the session: auto on a continuous f in 6 dims
 * runs RQMC over a VEGAS map, whose pilot asks for thousands of points at
 * once. */
static void test_batch_growth(void **state)
{
    (void)state;
    const uint16_t vegas[QMC_MODBUS_SETUP_COUNT] = {4, 6, 1, 0, 0, 0, 0, 0, 0, 0,
                                                    0, 0, 0x000F, 0x4240, 950, 1};
    qmc_modbus_session *s = NULL;
    assert_int_equal(qmc_modbus_session_new(&s), 0);
    qmc_modbus_env tight = env;
    tight.integration_bytes_max = 1;
    mb_reply r = mb_write(s, &tight, QMC_MODBUS_SETUP_BASE, vegas, QMC_MODBUS_SETUP_COUNT);
    mb_assert_written(&r);
    mb_snapshot m;
    mb_snapshot_take(s, &env, &m);
    assert_int_equal(m.ib[QMC_MODBUS_IB_STATUS], QMC_MODBUS_INTEG_NO_MEMORY);
    const uint64_t start_need = mb_u64(&m.ib[QMC_MODBUS_IB_BYTES]);
    /* Room for the start, not for its first batch: failed, with the bytes
     * that batch needs, nothing held. */
    uint16_t w[QMC_MODBUS_SETUP_COUNT];
    memcpy(w, vegas, sizeof w);
    w[15] = 2;
    tight.integration_bytes_max = start_need;
    r = mb_write(s, &tight, QMC_MODBUS_SETUP_BASE, w, QMC_MODBUS_SETUP_COUNT);
    mb_assert_written(&r);
    mb_snapshot_take(s, &env, &m);
    assert_int_equal(m.ib[QMC_MODBUS_IB_STATUS], QMC_MODBUS_INTEG_FAILED);
    assert_int_equal(m.ib[QMC_MODBUS_IB_ERROR], -QMC_ETOOBIG);
    const uint64_t batch_need = mb_u64(&m.ib[QMC_MODBUS_IB_BYTES]);
    assert_true(batch_need > start_need);
    assert_int_equal((batch_need - start_need) % 8, 0);
    qmc_modbus_usage u;
    qmc_modbus_session_usage(s, &u);
    assert_int_equal(u.integration_bytes, 0);
    /* One byte short: the same. */
    w[15] = 3;
    tight.integration_bytes_max = batch_need - 1;
    r = mb_write(s, &tight, QMC_MODBUS_SETUP_BASE, w, QMC_MODBUS_SETUP_COUNT);
    mb_assert_written(&r);
    mb_snapshot_take(s, &env, &m);
    assert_int_equal(m.ib[QMC_MODBUS_IB_STATUS], QMC_MODBUS_INTEG_FAILED);
    /* With the room: it waits on the first of the batch's points. */
    w[15] = 4;
    tight.integration_bytes_max = batch_need;
    r = mb_write(s, &tight, QMC_MODBUS_SETUP_BASE, w, QMC_MODBUS_SETUP_COUNT);
    mb_assert_written(&r);
    mb_snapshot_take(s, &env, &m);
    assert_int_equal(m.ib[QMC_MODBUS_IB_STATUS], QMC_MODBUS_INTEG_WAITING);
    assert_int_equal(mb_u64(&m.ib[QMC_MODBUS_IB_BYTES]), batch_need);
    qmc_modbus_session_usage(s, &u);
    assert_int_equal(u.integration_bytes, batch_need);
    print_message("  auto d=6: the start needs %llu bytes, its first batch %llu (%llu points)\n",
                  (unsigned long long)start_need, (unsigned long long)batch_need,
                  (unsigned long long)(256 + (batch_need - start_need) / 8));
    qmc_modbus_session_free(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_request_numbers), cmocka_unit_test(test_wrong_counts),
        cmocka_unit_test(test_setup_ranges),    cmocka_unit_test(test_nonfinite_values),
        cmocka_unit_test(test_nothing_waits),   cmocka_unit_test(test_starts),
        cmocka_unit_test(test_bad_setups),      cmocka_unit_test(test_memory_room),
        cmocka_unit_test(test_batch_growth),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
