/*
 * test_proto_flags.c - result flag bits by protocol version (PROTOCOL.md
 * section 5, protocol/result_flags.c): versions 1 and 2 define bits 0-11,
 * version 3 adds 12-16.  Encoding for a version-2 connection drops bits
 * 12-16 and raises error_unreliable in their place; for version 3 the
 * flags go out as they are.  Decoding as version 2 refuses bits 12-16 (a
 * client built before them does, since undefined bits must be zero);
 * decoding as version 3 accepts them.  The rest of the frame is the same
 * byte for byte whatever the version, up to version 5 (version 6 appends
 * a tail: test_proto_known_abs.c).
 *
 * The oracle is the list of names below, written from PROTOCOL.md, not the
 * codec's own masks.
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <string.h>

#include "qmc/proto.h"
#include "qmc/result.h"

/* Offset of res.flags in a JOB_RESULT frame: the header, then 16 bytes. */
#define FLAGS_AT (QMC_PROTO_HEADER_BYTES + 16)
#define FRAME_CAP 4096

/* Versions 1 and 2: the flags of the first protocol. */
static const uint32_t v1_flags[] = {
    QMC_FLAG_NONFINITE,      QMC_FLAG_HEAVY_TAIL, QMC_FLAG_NOT_POW2,
    QMC_FLAG_DIMS_PAST_GOOD, QMC_FLAG_NOT_CONVERGED, QMC_FLAG_BUDGET,
    QMC_FLAG_ROUNDOFF,       QMC_FLAG_MAX_SUBDIV, QMC_FLAG_MEMORY_BOUND,
    QMC_FLAG_FEW_REPS,       QMC_FLAG_ERROR_UNRELIABLE, QMC_FLAG_ZERO_PDF,
};
/* What version 3 adds. */
static const uint32_t v3_added[] = {
    QMC_FLAG_FEW_NONZERO, QMC_FLAG_ZERO_SPREAD, QMC_FLAG_TAIL_UNTESTED,
    QMC_FLAG_UNRESOLVED,  QMC_FLAG_MIS_UNDERSAMPLED,
};
#define COUNT(a) (sizeof(a) / sizeof(a)[0])

static uint32_t v1_mask(void)
{
    uint32_t m = 0;
    for (size_t i = 0; i < COUNT(v1_flags); i++)
        m |= v1_flags[i];
    return m;
}

static uint32_t v3_mask(void)
{
    uint32_t m = v1_mask();
    for (size_t i = 0; i < COUNT(v3_added); i++)
        m |= v3_added[i];
    return m;
}

static uint32_t load_u32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static void store_u32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

/* A plausible JOB_RESULT: a clenshaw-curtis bar of 0 on a missed peak. */
static qmc_msg result_msg(uint32_t flags)
{
    static const char detail[] = "p-adaptive tensor Clenshaw-Curtis, 25 grid points";
    qmc_msg m;
    memset(&m, 0, sizeof m);
    m.type = QMC_MSG_JOB_RESULT;
    m.request_id = 7;
    qmc_msg_job_result *r = &m.u.result;
    r->job_id = 3;
    r->method_used = QMC_METHOD_CLENSHAW_CURTIS;
    r->res.error_kind = QMC_ERROR_ESTIMATE;
    r->res.dims = 2;
    r->res.flags = flags;
    r->res.n = 25;
    r->res.evals = 25;
    r->res.abs_integral = 1.96e-5;
    r->reference_kind = 1;
    r->reference = 1.96349540849362e-05;
    r->seconds = 0.001;
    r->detail.ptr = detail;
    r->detail.len = sizeof detail - 1;
    return m;
}

static int encode(uint32_t flags, unsigned version, uint8_t *buf)
{
    qmc_msg m = result_msg(flags);
    int n = qmc_proto_encode_version(&m, version, buf, FRAME_CAP);
    assert_true(n > 0);
    assert_int_equal(qmc_proto_encoded_size_version(&m, version), (size_t)n);
    return n;
}

static void test_defined_by_version(void **state)
{
    (void)state;
    assert_int_equal(qmc_proto_result_flags_defined(1), v1_mask());
    assert_int_equal(qmc_proto_result_flags_defined(2), v1_mask());
    assert_int_equal(qmc_proto_result_flags_defined(3), v3_mask());
    assert_int_equal(v1_mask(), QMC_PROTO_RESULT_FLAGS_V1);
    assert_int_equal(v3_mask(), QMC_PROTO_RESULT_FLAGS_V3);
    assert_int_equal(qmc_proto_result_flags_defined(0), 0);
    assert_int_equal(qmc_proto_result_flags_defined(QMC_PROTO_VERSION_MAX + 1), 0);
}

/* Every v3 bit alone, beside old bits, and all of them together: version
 * 1 and 2 frames carry the old bits and error_unreliable, nothing of
 * 12-16; version 3 frames carry the flags unchanged; the frames differ
 * in the flags word only. */
static void test_encode_masks_for_v2(void **state)
{
    (void)state;
    uint8_t f1[FRAME_CAP], f2[FRAME_CAP], f3[FRAME_CAP];
    const uint32_t old = QMC_FLAG_BUDGET | QMC_FLAG_NOT_CONVERGED;
    for (size_t i = 0; i <= COUNT(v3_added); i++) {
        const uint32_t added = i < COUNT(v3_added) ? v3_added[i] : v3_mask() & ~v1_mask();
        const uint32_t flags = old | added;  /* error_unreliable not set */
        int n3 = encode(flags, 3, f3);
        int n2 = encode(flags, 2, f2);
        int n1 = encode(flags, 1, f1);
        assert_int_equal(n2, n3);
        assert_int_equal(n1, n3);
        assert_int_equal(load_u32(f3 + FLAGS_AT), flags);
        assert_int_equal(load_u32(f2 + FLAGS_AT), old | QMC_FLAG_ERROR_UNRELIABLE);
        assert_int_equal(load_u32(f1 + FLAGS_AT), old | QMC_FLAG_ERROR_UNRELIABLE);
        store_u32(f2 + FLAGS_AT, flags);
        store_u32(f1 + FLAGS_AT, flags);
        assert_memory_equal(f2, f3, (size_t)n3);
        assert_memory_equal(f1, f3, (size_t)n3);
        assert_int_equal(qmc_proto_result_flags_for(2, flags), old | QMC_FLAG_ERROR_UNRELIABLE);
        assert_int_equal(qmc_proto_result_flags_for(3, flags), flags);
    }
    /* Old bits alone are the same at every version: nothing is raised. */
    const uint32_t plain = v1_mask() & ~QMC_FLAG_ERROR_UNRELIABLE;
    for (unsigned v = 1; v <= QMC_PROTO_VERSION_MAX; v++) {
        encode(plain, v, f1);
        assert_int_equal(load_u32(f1 + FLAGS_AT), plain);
        encode(0, v, f1);
        assert_int_equal(load_u32(f1 + FLAGS_AT), 0);
    }
    /* qmc_proto_encode speaks the newest version. */
    qmc_msg m = result_msg(QMC_FLAG_UNRESOLVED);
    int n = qmc_proto_encode(&m, f1, sizeof f1);
    assert_int_equal(n, encode(QMC_FLAG_UNRESOLVED, QMC_PROTO_VERSION_MAX, f3));
    assert_memory_equal(f1, f3, (size_t)n);
}

static void test_decode_v2_rejects(void **state)
{
    (void)state;
    uint8_t f[FRAME_CAP];
    qmc_msg m;
    for (size_t i = 0; i < COUNT(v3_added); i++) {
        const uint32_t flags = v3_added[i] | QMC_FLAG_ERROR_UNRELIABLE;
        int n = encode(flags, 3, f);
        assert_int_equal(qmc_proto_decode_version(f, (size_t)n, FRAME_CAP, 2, &m), QMC_EPROTO);
        assert_int_equal(m.type, 0); /* cleared on error */
        assert_int_equal(qmc_proto_decode_version(f, (size_t)n, FRAME_CAP, 1, &m), QMC_EPROTO);
        assert_int_equal(qmc_proto_decode_version(f, (size_t)n, FRAME_CAP, 3, &m), n);
        assert_int_equal(m.u.result.res.flags, flags);
        n = encode(flags, QMC_PROTO_VERSION_MAX, f); /* what qmc_proto_decode reads */
        assert_int_equal(qmc_proto_decode(f, (size_t)n, FRAME_CAP, &m), n);
        assert_int_equal(m.u.result.res.flags, flags);
        /* What a version-2 connection is sent decodes as version 2 and
         * re-encodes to the same bytes (the canonical form holds per
         * version). */
        n = encode(flags, 2, f);
        assert_int_equal(qmc_proto_decode_version(f, (size_t)n, FRAME_CAP, 2, &m), n);
        assert_int_equal(m.u.result.res.flags, QMC_FLAG_ERROR_UNRELIABLE);
        uint8_t again[FRAME_CAP];
        assert_int_equal(qmc_proto_encode_version(&m, 2, again, sizeof again), n);
        assert_memory_equal(again, f, (size_t)n);
    }
    /* Every old bit decodes at every version (in the frame that version
     * lays out: version 6 appends the known integral of |f|). */
    for (unsigned v = 1; v <= QMC_PROTO_VERSION_MAX; v++) {
        int n = encode(v1_mask(), v, f);
        assert_int_equal(qmc_proto_decode_version(f, (size_t)n, FRAME_CAP, v, &m), n);
        assert_int_equal(m.u.result.res.flags, v1_mask());
    }
}

/* A bit no version defines is refused by every version either way; the
 * projection does not launder it. */
static void test_undefined_everywhere(void **state)
{
    (void)state;
    uint8_t f[FRAME_CAP];
    qmc_msg m = result_msg(1u << 17);
    qmc_msg d;
    for (unsigned v = 1; v <= QMC_PROTO_VERSION_MAX; v++)
        assert_int_equal(qmc_proto_encode_version(&m, v, f, sizeof f), QMC_EINVAL);
    int n = encode(0, 3, f);
    store_u32(f + FLAGS_AT, 1u << 17);
    for (unsigned v = 1; v <= QMC_PROTO_VERSION_MAX; v++)
        assert_int_equal(qmc_proto_decode_version(f, (size_t)n, FRAME_CAP, v, &d), QMC_EPROTO);
    assert_int_equal(qmc_proto_result_flags_for(2, 1u << 17 | QMC_FLAG_UNRESOLVED),
                     1u << 17 | QMC_FLAG_ERROR_UNRELIABLE);
}

static void test_bad_version(void **state)
{
    (void)state;
    uint8_t f[FRAME_CAP];
    qmc_msg m = result_msg(0), d;
    int n = encode(0, 3, f);
    const unsigned bad[] = {0, QMC_PROTO_VERSION_MAX + 1, 255};
    for (size_t i = 0; i < COUNT(bad); i++) {
        assert_int_equal(qmc_proto_encode_version(&m, bad[i], f, sizeof f), QMC_EINVAL);
        assert_int_equal(qmc_proto_encoded_size_version(&m, bad[i]), 0);
        assert_int_equal(qmc_proto_decode_version(f, (size_t)n, FRAME_CAP, bad[i], &d),
                         QMC_EINVAL);
        assert_int_equal(qmc_proto_result_flags_for(bad[i], QMC_FLAG_UNRESOLVED),
                         QMC_FLAG_UNRESOLVED);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_defined_by_version),
        cmocka_unit_test(test_encode_masks_for_v2),
        cmocka_unit_test(test_decode_v2_rejects),
        cmocka_unit_test(test_undefined_everywhere),
        cmocka_unit_test(test_bad_version),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
