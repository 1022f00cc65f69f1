/*
 * test_command_codec.c - the bytes of `qmc integrate --command`
 * (client/cli/command_codec.c), with no process around them.
 *
 *   - cli_cmd_shortest against an oracle written here: the fewest
 *     significant digits p (1..17) for which "%.{p-1}e" reads back as x,
 *     found by trying them all; every output reads back, and has exactly
 *     that many digits for normal numbers (points of [0,1) and beyond,
 *     dyadic grid values, tie cases, powers of ten);
 *   - a text batch: the exact bytes for known points, the same whatever
 *     buffer size it is cut into; f64: a little-endian count and doubles;
 *   - values, fed whole and a byte at a time, give the same values and
 *     the same verdicts: done exactly at count, "too many" for any byte
 *     past it, "not a number" for words, empty lines, NULs and overlong
 *     lines; NaN and infinities taken as numbers; a last line without its
 *     newline counts at the end.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "command_codec.h"

/* ---- shortest ------------------------------------------------------------------ */

static int oracle_digits(double x)
{
    char buf[64];
    for (int p = 1; p <= 17; p++) {
        snprintf(buf, sizeof buf, "%.*e", p - 1, x);
        if (strtod(buf, NULL) == x)
            return p;
    }
    return 17;
}

/* Significant digits of a decimal string ("0.00123" -> 3, "1.5e-07" -> 2). */
static int digits_of(const char *s)
{
    int n = 0, leading = 1;
    for (; *s && *s != 'e'; s++) {
        if (*s < '0' || *s > '9')
            continue;
        if (*s == '0' && leading)
            continue;
        leading = 0;
        n++;
    }
    /* trailing zeros of an integer part are not significant either */
    return n;
}

static void check_shortest(double x)
{
    char buf[CLI_CMD_NUMBER_BYTES + 1];
    size_t n = cli_cmd_shortest(x, buf);
    assert_int_equal(n, strlen(buf));
    if (strtod(buf, NULL) != x)
        fail_msg("%a written as '%s' does not read back", x, buf);
    if (x != 0 && fpclassify(x) == FP_NORMAL && digits_of(buf) != oracle_digits(x))
        fail_msg("%a written as '%s': %d digits, the shortest has %d", x, buf, digits_of(buf),
                 oracle_digits(x));
}

static uint64_t rng = 0x9e3779b97f4a7c15ull;
static uint64_t next_u64(void)
{
    rng ^= rng << 13;
    rng ^= rng >> 7;
    rng ^= rng << 17;
    return rng;
}

static void test_shortest(void **state)
{
    (void)state;
    const double fixed[] = {0.0, 0.5, 0.1, 0.2, 0.3, 0.7, 1e-3, 0.001000000000000001,
                            0x1.fffffffffffffp-1, 0x1p-10, 0x1p-11, 0x1.a24fp-1,
                            0x1.3f5cp-4, 0.09999999999999999, 0.01, 0.009999999999999998,
                            1e-4, 1.5e-7, 0x1p-1074, 0x1p-1022, 1.0, 123.25, 1e300, -0.75};
    for (size_t i = 0; i < sizeof fixed / sizeof fixed[0]; i++)
        check_shortest(fixed[i]);
    for (int i = 0; i < 200000; i++) {
        uint64_t u = next_u64();
        check_shortest((double)(u >> 11) * 0x1p-53);      /* [0,1), 53 bits */
        check_shortest((double)(u >> 32) * 0x1p-32);      /* a 32-bit grid */
        check_shortest((double)(u >> 11) * 0x1p-53 * 1e-3); /* below 1e-3 */
    }
    char buf[CLI_CMD_NUMBER_BYTES + 1];
    cli_cmd_shortest(0.0, buf);
    assert_string_equal(buf, "0");
    cli_cmd_shortest(0.1, buf);
    assert_string_equal(buf, "0.1");
    cli_cmd_shortest(0.0025, buf);
    assert_string_equal(buf, "0.0025");
    /* A tie between two 16-digit neighbours goes to the even one, as
     * Python's repr does: 0x1.a24fp-1 = 0.81700897216796875. */
    cli_cmd_shortest(0x1.a24fp-1, buf);
    assert_string_equal(buf, "0.8170089721679688");
}

/* ---- out ------------------------------------------------------------------------- */

/* The whole batch through buffers of cap bytes. */
static size_t encode_all(cli_cmd_format fmt, const double *pts, size_t count, uint32_t dims,
                         size_t cap, char *out, size_t out_cap)
{
    cli_cmd_enc e;
    cli_cmd_enc_start(&e, fmt, pts, count, dims);
    char *buf = malloc(cap);
    assert_non_null(buf);
    size_t len = 0;
    for (int guard = 0; !cli_cmd_enc_done(&e); guard++) {
        size_t n = cli_cmd_enc_fill(&e, buf, cap);
        assert_true(n > 0 || cli_cmd_enc_done(&e));
        assert_true(len + n <= out_cap);
        memcpy(out + len, buf, n);
        len += n;
        assert_true(guard < 100000);
    }
    assert_int_equal(cli_cmd_enc_fill(&e, buf, cap), 0);
    free(buf);
    return len;
}

static void test_text_batch(void **state)
{
    (void)state;
    const double pts[] = {0.5, 0.25, 0.1, 0x1.fffffffffffffp-1, 0.0, 0.001};
    const char want[] = "0.5 0.25\n0.1 0.9999999999999999\n0 0.001\n\n";
    char out[4096];
    size_t min = cli_cmd_enc_min_bytes(CLI_CMD_TEXT, 2);
    for (size_t cap = min; cap < min + 80; cap++) {
        size_t n = encode_all(CLI_CMD_TEXT, pts, 3, 2, cap, out, sizeof out);
        assert_int_equal(n, strlen(want));
        assert_memory_equal(out, want, n);
    }
    /* Below the minimum nothing is written (and nothing is lost). */
    cli_cmd_enc e;
    cli_cmd_enc_start(&e, CLI_CMD_TEXT, pts, 3, 2);
    char small[8];
    assert_int_equal(cli_cmd_enc_fill(&e, small, sizeof small), 0);
    assert_false(cli_cmd_enc_done(&e));
}

static void test_f64_batch(void **state)
{
    (void)state;
    const double pts[] = {0.5, 0.25, -2.0, 0x1p-1074, 3.0, 0.75};
    char out[256];
    size_t min = cli_cmd_enc_min_bytes(CLI_CMD_F64, 3);
    assert_int_equal(min, 4 + 24);
    for (size_t cap = min; cap < min + 40; cap++) {
        size_t n = encode_all(CLI_CMD_F64, pts, 2, 3, cap, out, sizeof out);
        assert_int_equal(n, 4 + 6 * 8);
        const unsigned char *u = (const unsigned char *)out;
        assert_int_equal(u[0] | u[1] << 8 | u[2] << 16 | (uint32_t)u[3] << 24, 2);
        for (int i = 0; i < 6; i++) {
            uint64_t bits = 0, want;
            for (int k = 0; k < 8; k++)
                bits |= (uint64_t)u[4 + 8 * i + k] << (8 * k);
            memcpy(&want, &pts[i], 8);
            assert_true(bits == want);
        }
    }
}

/* ---- in -------------------------------------------------------------------------- */

typedef struct verdict {
    int status;
    size_t got;
    double v[16];
    char why[160];
} verdict;

/* Feeds text whole (step 0) or step bytes at a time, then the end. */
static verdict decode(cli_cmd_format fmt, const char *data, size_t len, size_t count,
                      size_t step, int end)
{
    cli_cmd_dec d;
    verdict out;
    memset(&out, 0, sizeof out);
    assert_int_equal(cli_cmd_dec_init(&d, fmt), 0);
    cli_cmd_dec_start(&d, out.v, count);
    int st = CLI_CMD_MORE;
    if (step == 0)
        st = cli_cmd_dec_feed(&d, data, len);
    else
        for (size_t i = 0; i < len && st >= 0; i += step)
            st = cli_cmd_dec_feed(&d, data + i, len - i < step ? len - i : step);
    if (end && st >= 0)
        st = cli_cmd_dec_end(&d);
    out.status = st;
    out.got = d.got;
    snprintf(out.why, sizeof out.why, "%s", d.why);
    cli_cmd_dec_close(&d);
    return out;
}

/* Whole and byte by byte agree; returns the verdict. */
static verdict decode_both(cli_cmd_format fmt, const char *data, size_t len, size_t count,
                           int end)
{
    verdict a = decode(fmt, data, len, count, 0, end);
    for (size_t step = 1; step <= 3; step++) {
        verdict b = decode(fmt, data, len, count, step, end);
        assert_int_equal(a.status, b.status);
        assert_int_equal(a.got, b.got);
        assert_string_equal(a.why, b.why);
        assert_memory_equal(a.v, b.v, sizeof a.v);
    }
    return a;
}

#define TEXT(s) (s), (sizeof(s) - 1)

static void test_text_values(void **state)
{
    (void)state;
    verdict v = decode_both(CLI_CMD_TEXT, TEXT("0.5\n-1e-3\n  2 \r\nnan\n-inf\n"), 5, 0);
    assert_int_equal(v.status, CLI_CMD_DONE);
    assert_true(v.v[0] == 0.5 && v.v[1] == -1e-3 && v.v[2] == 2.0);
    assert_true(isnan(v.v[3]) && isinf(v.v[4]) && v.v[4] < 0);
    /* Python's repr reads back exactly. */
    v = decode_both(CLI_CMD_TEXT, TEXT("0.1\n0.30000000000000004\n"), 2, 0);
    assert_int_equal(v.status, CLI_CMD_DONE);
    assert_true(v.v[0] == 0.1 && v.v[1] == 0.1 + 0.2);
    v = decode_both(CLI_CMD_TEXT, TEXT("0.5\n0.25\n"), 3, 0);
    assert_int_equal(v.status, CLI_CMD_MORE);
    assert_int_equal(v.got, 2);
    /* Past the count, any byte is too many, a line or a part of one. */
    v = decode_both(CLI_CMD_TEXT, TEXT("0.5\n0.25\n0.75\n"), 2, 0);
    assert_int_equal(v.status, CLI_CMD_TOO_MANY);
    assert_non_null(strstr(v.why, "more values than the batch's 2 points"));
    v = decode_both(CLI_CMD_TEXT, TEXT("0.5\n0.25\n0"), 2, 0);
    assert_int_equal(v.status, CLI_CMD_TOO_MANY);
    v = decode_both(CLI_CMD_TEXT, TEXT("0.5\n0.25\n\n"), 2, 0);
    assert_int_equal(v.status, CLI_CMD_TOO_MANY);
    v = decode_both(CLI_CMD_TEXT, TEXT("x"), 0, 0);
    assert_int_equal(v.status, CLI_CMD_TOO_MANY);
    /* Not numbers. */
    v = decode_both(CLI_CMD_TEXT, TEXT("0.5\n0.5x\n"), 3, 0);
    assert_int_equal(v.status, CLI_CMD_NOT_NUMBER);
    assert_string_equal(v.why, "'0.5x' is not a number (the value for point 2)");
    v = decode_both(CLI_CMD_TEXT, TEXT("0.5\n\n"), 3, 0);
    assert_string_equal(v.why, "an empty line where the value for point 2 was expected");
    v = decode_both(CLI_CMD_TEXT, TEXT("0.5 0.5\n"), 3, 0);
    assert_int_equal(v.status, CLI_CMD_NOT_NUMBER);
    v = decode_both(CLI_CMD_TEXT, "0.\0005\n", 5, 3, 0);
    assert_int_equal(v.status, CLI_CMD_NOT_NUMBER);
    assert_non_null(strstr(v.why, "NUL"));
    char long_line[2100];
    memset(long_line, '1', sizeof long_line);
    long_line[sizeof long_line - 1] = '\n';
    v = decode_both(CLI_CMD_TEXT, long_line, sizeof long_line, 3, 0);
    assert_int_equal(v.status, CLI_CMD_NOT_NUMBER);
    assert_non_null(strstr(v.why, "more than 1024 bytes"));
    /* The end: a last line without its newline counts; a cut one is not
     * a number; nothing missing is "more". */
    v = decode_both(CLI_CMD_TEXT, TEXT("0.5\n0.25"), 2, 1);
    assert_int_equal(v.status, CLI_CMD_DONE);
    v = decode_both(CLI_CMD_TEXT, TEXT("0.5\n0.2e"), 2, 1);
    assert_int_equal(v.status, CLI_CMD_NOT_NUMBER);
    v = decode_both(CLI_CMD_TEXT, TEXT("0.5\n"), 2, 1);
    assert_int_equal(v.status, CLI_CMD_MORE);
}

static void test_f64_values(void **state)
{
    (void)state;
    const double want[3] = {0.5, NAN, -1e308};
    unsigned char bytes[25];
    for (int i = 0; i < 3; i++) {
        uint64_t u;
        memcpy(&u, &want[i], 8);
        for (int k = 0; k < 8; k++)
            bytes[8 * i + k] = (unsigned char)(u >> (8 * k));
    }
    bytes[24] = 0;
    verdict v = decode_both(CLI_CMD_F64, (const char *)bytes, 24, 3, 1);
    assert_int_equal(v.status, CLI_CMD_DONE);
    assert_true(v.v[0] == 0.5 && isnan(v.v[1]) && v.v[2] == -1e308);
    v = decode_both(CLI_CMD_F64, (const char *)bytes, 23, 3, 1);
    assert_int_equal(v.status, CLI_CMD_MORE);
    assert_int_equal(v.got, 2);
    v = decode_both(CLI_CMD_F64, (const char *)bytes, 25, 3, 0);
    assert_int_equal(v.status, CLI_CMD_TOO_MANY);
}

/* A decoder started again is fresh: the pump reuses one for every batch. */
static void test_restart(void **state)
{
    (void)state;
    cli_cmd_dec d;
    double v[2];
    assert_int_equal(cli_cmd_dec_init(&d, CLI_CMD_TEXT), 0);
    cli_cmd_dec_start(&d, v, 1);
    assert_int_equal(cli_cmd_dec_feed(&d, TEXT("x\n")), CLI_CMD_NOT_NUMBER);
    cli_cmd_dec_start(&d, v, 2);
    assert_int_equal(cli_cmd_dec_feed(&d, TEXT("0.5\n0.25\n")), CLI_CMD_DONE);
    assert_true(v[0] == 0.5 && v[1] == 0.25);
    cli_cmd_dec_start(&d, NULL, 0); /* after the last batch: nothing more */
    assert_int_equal(cli_cmd_dec_end(&d), CLI_CMD_DONE);
    assert_int_equal(cli_cmd_dec_feed(&d, TEXT("1\n")), CLI_CMD_TOO_MANY);
    cli_cmd_dec_close(&d);
    cli_cmd_format f;
    assert_int_equal(cli_cmd_format_parse("f64", &f), 0);
    assert_int_equal(f, CLI_CMD_F64);
    assert_int_equal(cli_cmd_format_parse("text", &f), 0);
    assert_int_equal(f, CLI_CMD_TEXT);
    assert_int_equal(cli_cmd_format_parse("csv", &f), -1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_shortest),    cmocka_unit_test(test_text_batch),
        cmocka_unit_test(test_f64_batch),   cmocka_unit_test(test_text_values),
        cmocka_unit_test(test_f64_values),  cmocka_unit_test(test_restart),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
