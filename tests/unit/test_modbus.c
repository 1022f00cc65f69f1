/*
 * test_modbus.c - the pure Modbus request handler (protocol/modbus.c), no
 * sockets: every function code served, every exception code, the
 * register map of protocol/MODBUS.md, its word orders and formats, the
 * idempotent request number and auto-advance, and the rule that a refused
 * write stores nothing.
 *
 * Oracles: closed-form points of the unscrambled sequences (Sobol's first
 * points are dyadic: (1/2, 1/2), (1/4, 3/4), (3/4, 1/4); Halton's are
 * radical inverses: (1/2, 1/3), (1/4, 2/3)) with their IEEE float32 bits
 * written out by hand, and for scrambled sequences the core's own
 * qmc_seq_at (the e2e test compares with `qmc points` from outside).
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "modbus_device.h"
#include "qmc/modbus.h"
#include "qmc/seq.h"

/* ---- failing the allocation of the sequence (torture mode) ---------------- */
/* core/seq.c allocates an instance with aligned_alloc and nothing else; a
 * plain build may interpose it to make qmc_seq_new fail.  The sanitizers
 * own the allocator, so under them the out-of-memory test is skipped. */
#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define NO_ALLOC_HOOK 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__)
#define NO_ALLOC_HOOK 1
#endif

#ifndef NO_ALLOC_HOOK
static int fail_aligned_alloc;
void *__libc_memalign(size_t alignment, size_t bytes);
void *aligned_alloc(size_t alignment, size_t bytes);
void *aligned_alloc(size_t alignment, size_t bytes)
{
    if (fail_aligned_alloc) {
        errno = ENOMEM;
        return NULL;
    }
    return __libc_memalign(alignment, bytes);
}
#endif

/* ---- request builders: modbus_device.c's master, with this file's env ---- */

typedef mb_reply reply;

static qmc_modbus_env env = {
    .uptime_s = 77, .requests = 1234, .exceptions = 5, .conns_accepted = 9,
    .conns_refused = 2, .conns_open = 3, .sobol_table_hash = 0x0123456789abcdefull,
    .version = "0.1.0"};

static reply call(qmc_modbus_session *s, const uint8_t *req, size_t n)
{
    return mb_call(s, &env, req, n);
}

static reply read_regs(qmc_modbus_session *s, uint8_t fc, unsigned addr, unsigned count)
{
    return mb_read(s, &env, fc, addr, count);
}

static reply write_single(qmc_modbus_session *s, unsigned addr, unsigned v)
{
    return mb_write1(s, &env, addr, v);
}

static reply write_multi(qmc_modbus_session *s, unsigned addr, const uint16_t *v, unsigned n)
{
    return mb_write(s, &env, addr, v, n);
}

static reply read_write(qmc_modbus_session *s, unsigned raddr, unsigned rn, unsigned waddr,
                        const uint16_t *v, unsigned wn)
{
    return mb_read_write(s, &env, raddr, rn, waddr, v, wn);
}

/* The holding registers 0..12 as one snapshot. */
static void holding(qmc_modbus_session *s, uint16_t out[13])
{
    reply r = read_regs(s, 0x03, 0, 13);
    assert_int_equal(r.n, 2 + 26);
    for (unsigned i = 0; i < 13; i++)
        out[i] = mb_reg(&r, i);
}

static qmc_modbus_session *fresh(void)
{
    qmc_modbus_session *s = NULL;
    assert_int_equal(qmc_modbus_session_new(&s), 0);
    assert_non_null(s);
    return s;
}

/* ---- tests ------------------------------------------------------------------ */

static void test_defaults(void **state)
{
    (void)state;
    qmc_modbus_session *s = fresh();
    uint16_t hr[13];
    holding(s, hr);
    const uint16_t want[13] = {1, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
    assert_memory_equal(hr, want, sizeof want);
    /* No request yet: echo 0, status NO_REQUEST. */
    reply r = read_regs(s, 0x04, 0, 6);
    assert_int_equal(r.b[0], 0x04);
    assert_int_equal(r.b[1], 12);
    assert_int_equal(mb_reg(&r, 0), 0);
    assert_int_equal(mb_reg(&r, 1), QMC_MODBUS_STATUS_NO_REQUEST);
    qmc_modbus_session_free(s);
    qmc_modbus_session_free(NULL);
}

/* Sobol index 2 in 2 dims is (1/4, 3/4): float32 0x3E800000, 0x3F400000. */
static void test_fc06_trigger_sobol_float32(void **state)
{
    (void)state;
    qmc_modbus_session *s = fresh();
    reply r = write_single(s, QMC_MODBUS_HR_INDEX_0, 2);
    assert_int_equal(r.n, 5);
    assert_memory_equal(r.b, ((uint8_t[]){0x06, 0, 9, 0, 2}), 5);
    r = write_single(s, QMC_MODBUS_HR_REQUEST, 7);
    assert_int_equal(r.n, 5);
    r = read_regs(s, 0x04, 0, 10);
    assert_int_equal(r.n, 2 + 20);
    const uint16_t want[10] = {7, 0, 0, 0, 0, 2, 0x3E80, 0x0000, 0x3F40, 0x0000};
    for (unsigned i = 0; i < 10; i++)
        assert_int_equal(mb_reg(&r, i), want[i]);
    /* The same block as holding registers 100... */
    reply h = read_regs(s, 0x03, 100, 10);
    assert_memory_equal(h.b + 2, r.b + 2, 20);
    /* Coordinates past dims read 0; the block ends at 69. */
    r = read_regs(s, 0x04, 10, 60);
    for (unsigned i = 0; i < 60; i++)
        assert_int_equal(mb_reg(&r, i), 0);
    qmc_modbus_session_free(s);
}

/* Word order CDAB, u16 and u32 fixed point on Halton (1/4, 2/3) at index 2. */
static void test_formats_and_word_order(void **state)
{
    (void)state;
    qmc_modbus_session *s = fresh();
    /* kind halton, dims 2, no scramble, seed 0, format u32, index 2,
     * request 1, no auto-advance, low word first. */
    const uint16_t w[13] = {2, 2, 0, 0, 0, 2, 0, 0, 0, 2, 1, 0, 1};
    reply r = write_multi(s, 0, w, 13);
    assert_int_equal(r.n, 5);
    assert_memory_equal(r.b, ((uint8_t[]){0x10, 0, 0, 0, 13}), 5);
    r = read_regs(s, 0x04, 0, 10);
    assert_int_equal(mb_reg(&r, 1), 0);
    /* 1/4 * 2^32 = 0x40000000; floor(2/3 * 2^32) = 0xAAAAAAAA. */
    assert_int_equal(mb_reg(&r, 6), 0x0000);
    assert_int_equal(mb_reg(&r, 7), 0x4000);
    assert_int_equal(mb_reg(&r, 8), 0xAAAA);
    assert_int_equal(mb_reg(&r, 9), 0xAAAA);
    /* u16: floor(x * 65536), one register per coordinate. */
    const uint16_t w2[6] = {1, 0, 0, 0, 2, 2}; /* format u16 ... request 2 */
    r = write_multi(s, 5, w2, 6);
    r = read_regs(s, 0x04, 0, 8);
    assert_int_equal(mb_reg(&r, 0), 2);
    assert_int_equal(mb_reg(&r, 6), 0x4000);
    assert_int_equal(mb_reg(&r, 7), 0xAAAA);
    /* float32, high word first: 0.25 = 0x3E800000. */
    const uint16_t w3[8] = {0, 0, 0, 0, 2, 3, 0, 0};
    r = write_multi(s, 5, w3, 8);
    r = read_regs(s, 0x04, 6, 2);
    assert_int_equal(mb_reg(&r, 0), 0x3E80);
    assert_int_equal(mb_reg(&r, 1), 0x0000);
    qmc_modbus_session_free(s);
}

/* Scrambled points are the core's, bit for bit; the seed is u32 hi/lo. */
static void test_scrambled_matches_core(void **state)
{
    (void)state;
    qmc_modbus_session *s = fresh();
    const struct {
        uint16_t kind, scr;
        qmc_seq_kind ck;
        qmc_scramble cs;
    } cases[] = {{1, 1, QMC_SEQ_SOBOL, QMC_SCRAMBLE_OWEN},
                 {1, 2, QMC_SEQ_SOBOL, QMC_SCRAMBLE_SHIFT},
                 {2, 3, QMC_SEQ_HALTON, QMC_SCRAMBLE_FAURE},
                 {2, 1, QMC_SEQ_HALTON, QMC_SCRAMBLE_OWEN},
                 {3, 0, QMC_SEQ_RANDOM, QMC_SCRAMBLE_NONE},
                 {1, 4, QMC_SEQ_SOBOL, QMC_SCRAMBLE_FAST_OWEN}};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        const uint16_t w[11] = {cases[c].kind, 32, cases[c].scr, 0x0001, 0x2345, 2, 0, 0,
                                0, 1000, (uint16_t)(c + 1)};
        reply r = write_multi(s, 0, w, 11);
        assert_int_equal(r.n, 5);
        qmc_seq_spec spec = {.kind = cases[c].ck, .dims = 32, .scramble = cases[c].cs,
                             .seed = 0x12345};
        qmc_seq *q = NULL;
        assert_int_equal(qmc_seq_new(&spec, &q), 0);
        r = read_regs(s, 0x04, 0, 70);
        assert_int_equal(mb_reg(&r, 1), 0);
        assert_int_equal(mb_reg(&r, 5), 1000);
        for (uint32_t j = 0; j < 32; j++) {
            double x;
            assert_int_equal(qmc_seq_at(q, 1000, j, &x), 0);
            uint32_t u = (uint32_t)ldexp(x, 32); /* exact: x has <= 53 bits */
            uint32_t got = (uint32_t)mb_reg(&r, 6 + 2 * j) << 16 | mb_reg(&r, 7 + 2 * j);
            assert_int_equal(got, u);
        }
        qmc_seq_free(q);
    }
    qmc_modbus_session_free(s);
}

/* The same request number again changes nothing; a new one advances. */
static void test_idempotent_and_auto_advance(void **state)
{
    (void)state;
    qmc_modbus_session *s = fresh();
    write_single(s, QMC_MODBUS_HR_AUTO_ADVANCE, 1);
    write_single(s, QMC_MODBUS_HR_REQUEST, 1);
    reply r = read_regs(s, 0x04, 0, 8);
    assert_int_equal(mb_reg(&r, 5), 0); /* point 0 */
    uint16_t hr[13];
    holding(s, hr);
    assert_int_equal(hr[9], 1); /* next index */
    /* A retry of request 1, even one that also rewrites the index: no-op. */
    const uint16_t retry[5] = {0, 0, 0, 40, 1};
    write_multi(s, 6, retry, 5);
    holding(s, hr);
    assert_int_equal(hr[9], 1);
    r = read_regs(s, 0x04, 0, 8);
    assert_int_equal(mb_reg(&r, 0), 1);
    assert_int_equal(mb_reg(&r, 5), 0);
    /* Request 2: point 1 = (1/2, 1/2). */
    write_single(s, QMC_MODBUS_HR_REQUEST, 2);
    r = read_regs(s, 0x04, 0, 10);
    assert_int_equal(mb_reg(&r, 0), 2);
    assert_int_equal(mb_reg(&r, 5), 1);
    assert_int_equal(mb_reg(&r, 6), 0x3F00);
    assert_int_equal(mb_reg(&r, 8), 0x3F00);
    holding(s, hr);
    assert_int_equal(hr[9], 2);
    qmc_modbus_session_free(s);
}

/* FC23: write index + request, read the answer, in one transaction; the
 * write happens first. */
static void test_fc23_one_transaction(void **state)
{
    (void)state;
    qmc_modbus_session *s = fresh();
    const uint16_t w[5] = {0, 0, 0, 3, 9};
    reply r = read_write(s, 100, 10, 6, w, 5);
    assert_int_equal(r.n, 2 + 20);
    assert_int_equal(r.b[0], 0x17);
    assert_int_equal(r.b[1], 20);
    /* Sobol index 3 = (3/4, 1/4). */
    const uint16_t want[10] = {9, 0, 0, 0, 0, 3, 0x3F40, 0, 0x3E80, 0};
    for (unsigned i = 0; i < 10; i++)
        assert_int_equal(mb_reg(&r, i), want[i]);
    /* A refused read stores nothing of the write. */
    const uint16_t w2[5] = {0, 0, 0, 5, 10};
    r = read_write(s, 50, 2, 6, w2, 5);
    mb_assert_exception(&r, 0x17, QMC_MODBUS_EX_ILLEGAL_ADDRESS);
    uint16_t hr[13];
    holding(s, hr);
    assert_int_equal(hr[9], 3);
    assert_int_equal(hr[10], 9);
    qmc_modbus_session_free(s);
}

static void test_status_codes(void **state)
{
    (void)state;
    qmc_modbus_session *s = fresh();
    /* sobol + faure: the core refuses the combination. */
    write_single(s, QMC_MODBUS_HR_SCRAMBLE, QMC_MODBUS_SCRAMBLE_FAURE);
    write_single(s, QMC_MODBUS_HR_REQUEST, 1);
    reply r = read_regs(s, 0x04, 0, 8);
    assert_int_equal(mb_reg(&r, 0), 1);
    assert_int_equal(mb_reg(&r, 1), QMC_MODBUS_STATUS_BAD_SPEC);
    assert_int_equal(mb_reg(&r, 6), 0);
    /* Index 2^32: past the end. */
    write_single(s, QMC_MODBUS_HR_SCRAMBLE, 0);
    const uint16_t idx[5] = {0, 1, 0, 0, 2};
    write_multi(s, 6, idx, 5);
    r = read_regs(s, 0x04, 0, 6);
    assert_int_equal(mb_reg(&r, 1), QMC_MODBUS_STATUS_BAD_INDEX);
    assert_int_equal(mb_reg(&r, 3), 1);
    /* The last valid index works. */
    const uint16_t last[5] = {0, 0, 0xFFFF, 0xFFFF, 3};
    write_multi(s, 6, last, 5);
    r = read_regs(s, 0x04, 0, 6);
    assert_int_equal(mb_reg(&r, 1), QMC_MODBUS_STATUS_OK);
    /* halton + fast-owen (a base-2 scramble): refused by the core too. */
    write_single(s, QMC_MODBUS_HR_KIND, QMC_MODBUS_KIND_HALTON);
    write_single(s, QMC_MODBUS_HR_SCRAMBLE, QMC_MODBUS_SCRAMBLE_FAST_OWEN);
    write_single(s, QMC_MODBUS_HR_REQUEST, 4);
    r = read_regs(s, 0x04, 0, 6);
    assert_int_equal(mb_reg(&r, 0), 4);
    assert_int_equal(mb_reg(&r, 1), QMC_MODBUS_STATUS_BAD_SPEC);
    assert_string_equal(qmc_modbus_status_name(QMC_MODBUS_STATUS_BAD_INDEX),
                        "index past the end of the sequence (2^32)");
    assert_string_equal(qmc_modbus_status_name(99), "");
    qmc_modbus_session_free(s);
}

static void test_counters(void **state)
{
    (void)state;
    qmc_modbus_session *s = fresh();
    reply r = read_regs(s, 0x04, 200, 24);
    assert_int_equal(r.n, 2 + 48);
    const uint64_t want[6] = {77, 1234, 5, 9, 2, 3};
    for (unsigned c = 0; c < 6; c++) {
        uint64_t v = 0;
        for (unsigned k = 0; k < 4; k++)
            v = v << 16 | mb_reg(&r, 4 * c + k);
        assert_int_equal(v, want[c]);
    }
    /* With no env the counters read 0. */
    uint8_t q[5] = {0x04, 0, 204, 0, 4}, b[QMC_MODBUS_MAX_PDU];
    assert_int_equal(qmc_modbus_handle(s, NULL, q, 5, b, sizeof b), 10);
    for (int i = 2; i < 10; i++)
        assert_int_equal(b[i], 0);
    qmc_modbus_session_free(s);
}

static void test_fc17_report_server_id(void **state)
{
    (void)state;
    qmc_modbus_session *s = fresh();
    uint8_t q[1] = {0x11};
    reply r = call(s, q, 1);
    const char text[] = "qmcd 0.1.0 sobol:0123456789abcdef";
    assert_int_equal(r.n, 2 + 2 + (int)sizeof text - 1);
    assert_int_equal(r.b[0], 0x11);
    assert_int_equal(r.b[1], 2 + sizeof text - 1);
    assert_int_equal(r.b[2], 0x51);
    assert_int_equal(r.b[3], 0xFF);
    assert_memory_equal(r.b + 4, text, sizeof text - 1);
    uint8_t long_q[2] = {0x11, 0};
    r = call(s, long_q, 2);
    mb_assert_exception(&r, 0x11, QMC_MODBUS_EX_ILLEGAL_VALUE);
    qmc_modbus_session_free(s);
}

static void test_fc43_device_id(void **state)
{
    (void)state;
    qmc_modbus_session *s = fresh();
    uint8_t q[4] = {0x2B, 0x0E, 0x01, 0x00};
    reply r = call(s, q, 4);
    const uint8_t want[] = {0x2B, 0x0E, 0x01, 0x81, 0x00, 0x00, 3,
                            0, 4, 'q', 'm', 'c', 'd',
                            1, 11, 'q', 'm', 'c', 'd', '-', 'm', 'o', 'd', 'b', 'u', 's',
                            2, 5, '0', '.', '1', '.', '0'};
    assert_int_equal(r.n, (int)sizeof want);
    assert_memory_equal(r.b, want, sizeof want);
    /* Stream from object 2; an unknown start restarts at 0. */
    q[3] = 2;
    r = call(s, q, 4);
    assert_int_equal(r.b[6], 1);
    assert_int_equal(r.b[7], 2);
    q[3] = 0x80;
    r = call(s, q, 4);
    assert_int_equal(r.b[6], 3);
    /* Individual access. */
    const uint8_t one[4] = {0x2B, 0x0E, 0x04, 0x01};
    r = call(s, one, 4);
    assert_int_equal(r.n, 7 + 2 + 11);
    assert_int_equal(r.b[7], 1);
    const uint8_t none[4] = {0x2B, 0x0E, 0x04, 0x03};
    r = call(s, none, 4);
    mb_assert_exception(&r, 0x2B, QMC_MODBUS_EX_ILLEGAL_ADDRESS);
    const uint8_t bad_code[4] = {0x2B, 0x0E, 0x05, 0x00};
    r = call(s, bad_code, 4);
    mb_assert_exception(&r, 0x2B, QMC_MODBUS_EX_ILLEGAL_VALUE);
    const uint8_t canopen[4] = {0x2B, 0x0D, 0x01, 0x00};
    r = call(s, canopen, 4);
    mb_assert_exception(&r, 0x2B, QMC_MODBUS_EX_ILLEGAL_FUNCTION);
    const uint8_t short_q[3] = {0x2B, 0x0E, 0x01};
    r = call(s, short_q, 3);
    mb_assert_exception(&r, 0x2B, QMC_MODBUS_EX_ILLEGAL_VALUE);
    qmc_modbus_session_free(s);
}

/* Exception 01: every function code we do not serve. */
static void test_ex01_illegal_function(void **state)
{
    (void)state;
    qmc_modbus_session *s = fresh();
    for (unsigned fc = 0; fc < 256; fc++) {
        if (fc == 3 || fc == 4 || fc == 6 || fc == 0x10 || fc == 0x11 || fc == 0x17 ||
            fc == 0x2B)
            continue;
        uint8_t q[5] = {(uint8_t)fc, 0, 0, 0, 1};
        reply r = call(s, q, 5);
        mb_assert_exception(&r, (uint8_t)fc, QMC_MODBUS_EX_ILLEGAL_FUNCTION);
    }
    assert_string_equal(qmc_modbus_exception_name(1), "function code not served");
    qmc_modbus_session_free(s);
}

/* Exception 02: unmapped addresses, and writes to read-only registers. */
static void test_ex02_illegal_address(void **state)
{
    (void)state;
    qmc_modbus_session *s = fresh();
    reply r = read_regs(s, 0x03, 13, 1);
    mb_assert_exception(&r, 0x03, 2);
    r = read_regs(s, 0x03, 170, 1);
    mb_assert_exception(&r, 0x03, 2);
    r = read_regs(s, 0x04, 70, 1);
    mb_assert_exception(&r, 0x04, 2);
    r = read_regs(s, 0x04, 224, 1);
    mb_assert_exception(&r, 0x04, 2);
    r = read_regs(s, 0x04, 0xFFFF, 1);
    mb_assert_exception(&r, 0x04, 2);
    r = write_single(s, 100, 1);
    mb_assert_exception(&r, 0x06, 2);
    r = write_single(s, 13, 1);
    mb_assert_exception(&r, 0x06, 2);
    const uint16_t v[2] = {1, 1};
    r = write_multi(s, 12, v, 2); /* runs past register 12 */
    mb_assert_exception(&r, 0x10, 2);
    r = write_multi(s, 105, v, 2);
    mb_assert_exception(&r, 0x10, 2);
    r = read_write(s, 100, 1, 120, v, 1);
    mb_assert_exception(&r, 0x17, 2);
    qmc_modbus_session_free(s);
}

/* Exception 03: quantities, lengths, byte counts, values, reads past a
 * block's end; none of them stores anything. */
static void test_ex03_illegal_value(void **state)
{
    (void)state;
    qmc_modbus_session *s = fresh();
    uint16_t before[13], after[13];
    holding(s, before);
    reply r = read_regs(s, 0x03, 0, 0);
    mb_assert_exception(&r, 0x03, 3);
    r = read_regs(s, 0x04, 0, 126);
    mb_assert_exception(&r, 0x04, 3);
    r = read_regs(s, 0x03, 0, 14); /* past register 12 */
    mb_assert_exception(&r, 0x03, 3);
    r = read_regs(s, 0x03, 160, 11); /* past the result block */
    mb_assert_exception(&r, 0x03, 3);
    r = read_regs(s, 0x04, 60, 11);
    mb_assert_exception(&r, 0x04, 3);
    r = read_regs(s, 0x04, 220, 5);
    mb_assert_exception(&r, 0x04, 3);
    r = write_single(s, QMC_MODBUS_HR_DIMS, 33);
    mb_assert_exception(&r, 0x06, 3);
    r = write_single(s, QMC_MODBUS_HR_DIMS, 0);
    mb_assert_exception(&r, 0x06, 3);
    r = write_single(s, QMC_MODBUS_HR_KIND, 9);
    mb_assert_exception(&r, 0x06, 3);
    r = write_single(s, QMC_MODBUS_HR_SCRAMBLE, 5);
    mb_assert_exception(&r, 0x06, 3);
    r = write_single(s, QMC_MODBUS_HR_FORMAT, 3);
    mb_assert_exception(&r, 0x06, 3);
    r = write_single(s, QMC_MODBUS_HR_AUTO_ADVANCE, 2);
    mb_assert_exception(&r, 0x06, 3);
    r = write_single(s, QMC_MODBUS_HR_WORD_ORDER, 2);
    mb_assert_exception(&r, 0x06, 3);
    /* One bad value refuses the whole write, trigger included. */
    const uint16_t w[11] = {2, 8, 0, 0, 0, 0, 0, 0, 0, 5, 1};
    uint16_t bad[11];
    memcpy(bad, w, sizeof w);
    bad[1] = 40;
    r = write_multi(s, 0, bad, 11);
    mb_assert_exception(&r, 0x10, 3);
    holding(s, after);
    assert_memory_equal(before, after, sizeof before);
    r = read_regs(s, 0x04, 0, 2);
    assert_int_equal(mb_reg(&r, 1), QMC_MODBUS_STATUS_NO_REQUEST);
    /* Malformed PDUs: short, long, byte count that lies, quantity 0/124. */
    const uint8_t short_read[4] = {0x03, 0, 0, 0};
    r = call(s, short_read, 4);
    mb_assert_exception(&r, 0x03, 3);
    const uint8_t long_read[6] = {0x03, 0, 0, 0, 1, 0};
    r = call(s, long_read, 6);
    mb_assert_exception(&r, 0x03, 3);
    const uint8_t short_write[4] = {0x06, 0, 1, 0};
    r = call(s, short_write, 4);
    mb_assert_exception(&r, 0x06, 3);
    const uint8_t lying_count[8] = {0x10, 0, 0, 0, 1, 4, 0, 1};
    r = call(s, lying_count, 8);
    mb_assert_exception(&r, 0x10, 3);
    const uint8_t missing_data[8] = {0x10, 0, 0, 0, 2, 4, 0, 1};
    r = call(s, missing_data, 8);
    mb_assert_exception(&r, 0x10, 3);
    const uint8_t zero_qty[6] = {0x10, 0, 0, 0, 0, 0};
    r = call(s, zero_qty, 6);
    mb_assert_exception(&r, 0x10, 3);
    uint8_t big[QMC_MODBUS_MAX_PDU] = {0x10, 0, 0, 0, 124, 247};
    r = call(s, big, sizeof big);
    mb_assert_exception(&r, 0x10, 3);
    const uint8_t rw_short[9] = {0x17, 0, 100, 0, 1, 0, 0, 0, 1};
    r = call(s, rw_short, 9);
    mb_assert_exception(&r, 0x17, 3);
    const uint8_t rw_zero_read[12] = {0x17, 0, 100, 0, 0, 0, 0, 0, 1, 2, 0, 1};
    r = call(s, rw_zero_read, 12);
    mb_assert_exception(&r, 0x17, 3);
    const uint16_t v[1] = {1};
    r = read_write(s, 100, 126, 0, v, 1);
    mb_assert_exception(&r, 0x17, 3);
    const uint16_t dims40[1] = {40};
    r = read_write(s, 100, 2, 1, dims40, 1);
    mb_assert_exception(&r, 0x17, 3);
    holding(s, after);
    assert_memory_equal(before, after, sizeof before);
    qmc_modbus_session_free(s);
}

/* Exception 04: the sequence cannot be allocated; nothing is stored. */
static void test_ex04_server_failure(void **state)
{
    (void)state;
#ifdef NO_ALLOC_HOOK
    skip();
#else
    qmc_modbus_session *s = fresh();
    const uint16_t w[11] = {2, 8, 0, 0, 0, 0, 0, 0, 0, 5, 1};
    fail_aligned_alloc = 1;
    reply r = write_multi(s, 0, w, 11);
    fail_aligned_alloc = 0;
    mb_assert_exception(&r, 0x10, QMC_MODBUS_EX_SERVER_FAILURE);
    uint16_t hr[13];
    holding(s, hr);
    assert_int_equal(hr[0], 1);
    assert_int_equal(hr[1], 2);
    r = read_regs(s, 0x04, 0, 2);
    assert_int_equal(mb_reg(&r, 1), QMC_MODBUS_STATUS_NO_REQUEST);
    /* And with memory back the same write works. */
    r = write_multi(s, 0, w, 11);
    assert_int_equal(r.n, 5);
    qmc_modbus_session_free(s);
#endif
}

static void test_bad_calls(void **state)
{
    (void)state;
    qmc_modbus_session *s = fresh();
    uint8_t q[254] = {0x03}, b[QMC_MODBUS_MAX_PDU];
    assert_int_equal(qmc_modbus_handle(s, &env, q, 0, b, sizeof b), QMC_EINVAL);
    assert_int_equal(qmc_modbus_handle(s, &env, q, 254, b, sizeof b), QMC_EINVAL);
    assert_int_equal(qmc_modbus_handle(s, &env, q, 5, b, 252), QMC_EINVAL);
    qmc_modbus_session_free(s);
}

/* The largest read fits: 125 registers of the result and counters blocks
 * are not that long, but 70 are; and every truncation of every valid
 * request is an exception, never a crash or a normal answer. */
static void test_truncations(void **state)
{
    (void)state;
    qmc_modbus_session *s = fresh();
    const uint8_t reqs[][12] = {{0x03, 0, 100, 0, 70}, {0x04, 0, 200, 0, 24},
                                {0x06, 0, 1, 0, 3}, {0x10, 0, 1, 0, 1, 2, 0, 3},
                                {0x17, 0, 100, 0, 6, 0, 10, 0, 1, 2, 0, 1},
                                {0x2B, 0x0E, 1, 0}};
    const size_t lens[] = {5, 5, 5, 8, 12, 4};
    for (size_t i = 0; i < 6; i++) {
        reply r = call(s, reqs[i], lens[i]);
        assert_int_equal(r.b[0], reqs[i][0]);
        for (size_t n = 1; n < lens[i]; n++) {
            r = call(s, reqs[i], n);
            mb_assert_exception(&r, reqs[i][0], QMC_MODBUS_EX_ILLEGAL_VALUE);
        }
    }
    qmc_modbus_session_free(s);
}

/* qmc_modbus_request_writes names exactly the write functions of the
 * spec that are served (FC06, FC16, FC23: sections 6.6, 6.12, 6.17), and
 * every other code, run with a request that would write if it could, leaves
 * a session's registers and result block as a fresh one has them (the TCP
 * transport answers those from one shared bank). */
static void test_request_writes(void **state)
{
    (void)state;
    assert_int_equal(qmc_modbus_request_writes((const uint8_t *)"\x06", 0), 0);
    qmc_modbus_session *s = fresh();
    uint16_t want[13], got[13];
    holding(s, want);
    reply before = read_regs(s, 0x04, 0, 70);
    for (unsigned fc = 0; fc < 256; fc++) {
        /* Shaped as an FC16 of register 10 (a trigger) with its byte count. */
        uint8_t q[8] = {(uint8_t)fc, 0, 10, 0, 1, 2, 0, 9};
        int writes = fc == 0x06 || fc == 0x10 || fc == 0x17;
        assert_int_equal(qmc_modbus_request_writes(q, sizeof q), writes);
        if (writes)
            continue;
        for (size_t n = 1; n <= sizeof q; n++)
            (void)call(s, q, n);
        holding(s, got);
        assert_memory_equal(got, want, sizeof want);
        reply after = read_regs(s, 0x04, 0, 70);
        assert_memory_equal(after.b, before.b, (size_t)before.n);
    }
    qmc_modbus_session_free(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_defaults),
        cmocka_unit_test(test_fc06_trigger_sobol_float32),
        cmocka_unit_test(test_formats_and_word_order),
        cmocka_unit_test(test_scrambled_matches_core),
        cmocka_unit_test(test_idempotent_and_auto_advance),
        cmocka_unit_test(test_fc23_one_transaction),
        cmocka_unit_test(test_status_codes),
        cmocka_unit_test(test_counters),
        cmocka_unit_test(test_fc17_report_server_id),
        cmocka_unit_test(test_fc43_device_id),
        cmocka_unit_test(test_ex01_illegal_function),
        cmocka_unit_test(test_ex02_illegal_address),
        cmocka_unit_test(test_ex03_illegal_value),
        cmocka_unit_test(test_ex04_server_failure),
        cmocka_unit_test(test_bad_calls),
        cmocka_unit_test(test_truncations),
        cmocka_unit_test(test_request_writes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
