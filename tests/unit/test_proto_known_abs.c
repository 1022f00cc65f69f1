/*
 * test_proto_known_abs.c - protocol version 6's tail of JOB_RESULT and
 * SESSION_RESULT: the integral of |f| known in closed form (PROTOCOL.md
 * section 6.10, "Version 6"; protocol/known_abs.c).
 *
 * The oracles: the version-5 frames of PROTOCOL.md as they were before
 * version 6 existed (tests/vectors/proto/v5/, kept byte for byte), which a
 * version-5 connection must still be sent; and the tail's bytes written
 * out here from the text (a bool, 7 reserved zeros, a little-endian f64).
 * A frame of one layout read as the other is malformed either way; what
 * a version-5 frame decodes to says it told nothing (-1), and that cannot
 * be passed on to a version-6 peer as if it had.
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "qmc/proto.h"
#include "proto_check.h"

#define CAP 4096
#define H QMC_PROTO_HEADER_BYTES
#define V5 QMC_PROTO_VERSION_SESSIONS
#define V6 QMC_PROTO_VERSION_KNOWN_ABS

static uint32_t payload_len(const uint8_t *frame)
{
    return (uint32_t)frame[16] | (uint32_t)frame[17] << 8 | (uint32_t)frame[18] << 16 |
           (uint32_t)frame[19] << 24;
}

/* The version-6 example decodes at 6; encoded for a version-5 peer it is
 * the frame version 5 always had, which decodes at 5 as "not told" and
 * at 6 as malformed (16 bytes short), as the version-6 frame is at 5 (16
 * bytes over). */
static void old_layout(const char *name, const char *v6_path, const char *v5_path)
{
    uint8_t v6[CAP], v5[CAP], out[CAP];
    size_t n6 = proto_read_hex(v6_path, v6, CAP), n5 = proto_read_hex(v5_path, v5, CAP);
    qmc_msg m, d;
    assert_int_equal(qmc_proto_decode_version(v6, n6, CAP, V6, &m), (int)n6);
    assert_true(m.u.result.has_known_abs == 0 || m.u.result.has_known_abs == 1);
    int n = qmc_proto_encode_version(&m, V5, out, sizeof out);
    if (n != (int)n5 || memcmp(out, v5, n5) != 0)
        fail_msg("%s: a version-5 peer is not sent the version-5 frame", name);
    assert_int_equal(n6, n5 + 16);
    assert_int_equal(payload_len(v6), payload_len(v5) + 16);
    assert_memory_equal(v6 + H, v5 + H, n5 - H); /* the tail is appended */

    assert_int_equal(qmc_proto_decode_version(v5, n5, CAP, V5, &d), (int)n5);
    assert_int_equal(d.u.result.has_known_abs, -1);
    assert_true(d.u.result.known_abs == 0.0);
    assert_int_equal(qmc_proto_encode_version(&d, V5, out, sizeof out), (int)n5);
    assert_memory_equal(out, v5, n5);
    /* Untold is not unknown: it cannot go out as a version-6 answer. */
    assert_int_equal(qmc_proto_encode_version(&d, V6, out, sizeof out), QMC_EINVAL);
    for (unsigned v = 1; v <= QMC_PROTO_VERSION_MAX; v++) {
        int want5 = v < V6 ? (int)n5 : QMC_EPROTO, want6 = v < V6 ? QMC_EPROTO : (int)n6;
        /* Versions 1 and 2 refuse flag bits above 11; the examples have none. */
        assert_int_equal(qmc_proto_decode_version(v5, n5, CAP, v, &d), want5);
        assert_int_equal(qmc_proto_decode_version(v6, n6, CAP, v, &d), want6);
    }
}

static void test_version_5_gets_the_old_layout(void **state)
{
    (void)state;
    old_layout("JOB_RESULT", "tests/vectors/proto/job_result.hex",
               "tests/vectors/proto/v5/job_result.hex");
    old_layout("SESSION_RESULT", "tests/vectors/proto/session_result.hex",
               "tests/vectors/proto/v5/session_result.hex");
}

/* The tail's bytes, as the text lays them out, for known and unknown. */
static void test_tail_bytes(void **state)
{
    (void)state;
    uint8_t buf[CAP], v6[CAP];
    size_t n6 = proto_read_hex("tests/vectors/proto/job_result.hex", v6, CAP);
    qmc_msg m, d;
    assert_int_equal(qmc_proto_decode(v6, n6, CAP, &m), (int)n6);
    const struct {
        int has;
        double value;
        uint8_t tail[16];
    } cases[] = {
        {1, 0.5, {1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0xe0, 0x3f}},
        {1, 0.0, {1}},   /* a known 0: poly with all-zero coefficients */
        {0, 0.0, {0}},
        {1, 1.7976931348623157e308,
         {1, 0, 0, 0, 0, 0, 0, 0, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xef, 0x7f}},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        m.u.result.has_known_abs = cases[i].has;
        m.u.result.known_abs = cases[i].value;
        int n = qmc_proto_encode(&m, buf, sizeof buf);
        assert_int_equal(n, (int)n6);
        assert_memory_equal(buf + n - 16, cases[i].tail, 16);
        assert_int_equal(qmc_proto_decode(buf, (size_t)n, CAP, &d), n);
        assert_int_equal(d.u.result.has_known_abs, cases[i].has);
        assert_true(d.u.result.known_abs == cases[i].value);
    }
    /* Values no integral of |f| has, and a value beside "unknown". */
    const struct {
        int has;
        double value;
    } bad[] = {{1, NAN}, {1, INFINITY}, {1, -1.0}, {1, -DBL_MIN}, {0, 1.0},
               {0, -0.0}, {2, 1.0}, {-1, 0.0}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        m.u.result.has_known_abs = bad[i].has;
        m.u.result.known_abs = bad[i].value;
        if (qmc_proto_encode(&m, buf, sizeof buf) != QMC_EINVAL)
            fail_msg("case %zu: has %d, value %g encoded", i, bad[i].has, bad[i].value);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_version_5_gets_the_old_layout),
        cmocka_unit_test(test_tail_bytes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
