/*
 * test_proto_part.c - the part-session messages of the codec (protocol
 * version 6, PROTOCOL.md section 6.22) beyond what test_proto.c checks for
 * every type (round trips, truncation, lengths, the worked examples):
 * each field the decoder must refuse, mutated in the worked example; what
 * the encoder refuses; the version they need; and a real part session's
 * sums (qmc_session_part, libqmc in-process) through the codec, bit for
 * bit, with the part's range as `qmc integrate --part` cuts it.
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <string.h>

#include "codec.h"
#include "proto_check.h"
#include "proto_part.h"
#include "qmc/proto.h"

static uint8_t frame[PROTO_CHECK_FRAME_BYTES];

typedef proto_mutation mutation; /* proto_check.h */

/* Offsets are those of PROTOCOL.md section 6.22's tables; a record starts
 * at 24 in SESSION_PART_SUMS, its top values at 24 + 96. */
static const mutation mutations[] = {
    {QMC_MSG_SESSION_PART, 16, 8, 0, "no blocks"},
    {QMC_MSG_SESSION_PART, 16, 8, QMC_SAMPLING_MAX_BLOCKS + 1ull, "blocks past the limit"},
    {QMC_MSG_SESSION_PART, 16, 8, 17, "blocks that do not cut to first and count"},
    {QMC_MSG_SESSION_PART, 24, 8, 4, "first that is not part k's"},
    {QMC_MSG_SESSION_PART, 32, 8, 6, "count that is not part k's"},
    {QMC_MSG_SESSION_PART, 32, 8, UINT64_MAX, "count past the job"},
    {QMC_MSG_SESSION_PART, 40, 4, 0, "part 0"},
    {QMC_MSG_SESSION_PART, 40, 4, 4, "part k past p"},
    {QMC_MSG_SESSION_PART, 44, 4, 0, "p 0"},
    {QMC_MSG_SESSION_PART, 48, 1, 5, "sampler 5"},
    {QMC_MSG_SESSION_PART, 51, 1, 1, "reserved in the sampling spec"},
    {QMC_MSG_SESSION_PART, 72, 8, 0x7ff8000000000000u, "confidence NaN"},
    {QMC_MSG_SESSION_PART_SUMS, 8, 8, QMC_SAMPLING_MAX_BLOCKS, "first past the limit"},
    {QMC_MSG_SESSION_PART_SUMS, 16, 4, 0, "no records"},
    {QMC_MSG_SESSION_PART_SUMS, 16, 4, 2, "more records than the payload"},
    {QMC_MSG_SESSION_PART_SUMS, 20, 1, 1, "reserved"},
    {QMC_MSG_SESSION_PART_SUMS, 24, 4, QMC_SAMPLING_BLOCK + 1, "count past a block"},
    {QMC_MSG_SESSION_PART_SUMS, 28, 4, 4097, "nonfinite past count"},
    {QMC_MSG_SESSION_PART_SUMS, 24 + 96, 8, 0xbff0000000000000u, "a negative largest value"},
    {QMC_MSG_SESSION_PART_SUMS, 24 + 96, 8, 0x7ff8000000000000u, "a NaN largest value"},
    {QMC_MSG_SESSION_PART_SUMS, 24 + 96 + 24, 8, 0x4014000000000000u, "largest values rising"},
};

static void test_mutations(void **state)
{
    (void)state;
    proto_check_mutations(mutations, sizeof mutations / sizeof mutations[0], proto_part_build,
                          PROTO_PART_EXAMPLE, frame, sizeof frame);
}

static void refuse(const qmc_msg *m, const char *what)
{
    proto_check_refused(m, what, frame, sizeof frame);
}

static void test_encoder_refuses(void **state)
{
    (void)state;
    qmc_msg m;
    proto_part_build(QMC_MSG_SESSION_PART, PROTO_PART_EXAMPLE, &m);
    m.u.session_part.count = 6;
    refuse(&m, "a count that is not part 2/3's");
    proto_part_build(QMC_MSG_SESSION_PART, PROTO_PART_EXAMPLE, &m);
    m.u.session_part.part_k = 4;
    refuse(&m, "part 4 of 3");
    proto_part_build(QMC_MSG_SESSION_PART, PROTO_PART_EXAMPLE, &m);
    m.u.session_part.sampling.confidence = INFINITY;
    refuse(&m, "an infinite confidence");

    qmc_sampling_sums s[2];
    memset(s, 0, sizeof s);
    proto_part_build(QMC_MSG_SESSION_PART_SUMS, PROTO_PART_EXAMPLE, &m);
    s[0] = m.u.part_sums.sums[0];
    s[1] = s[0];
    s[1].block = 7; /* not first + 1 */
    m.u.part_sums.sums = s;
    m.u.part_sums.n = 2;
    refuse(&m, "sums out of block order");
    s[1].block = 6;
    s[1].nonfinite = s[1].count + 1;
    refuse(&m, "more non-finite values than points");
    s[1].nonfinite = 0;
    s[1].count = QMC_SAMPLING_BLOCK + 1;
    refuse(&m, "more points than a block");
    s[1].count = 1;
    s[1].top[1] = s[1].top[0] * 2;
    refuse(&m, "largest values out of order");
    s[1].top[1] = s[0].top[1];
    assert_true(qmc_proto_encode(&m, frame, sizeof frame) > 0); /* and now it is whole */
    m.u.part_sums.sums = NULL;
    refuse(&m, "no sums");
    proto_part_build(QMC_MSG_SESSION_PART_SUMS, PROTO_PART_MAXIMAL, &m);
    m.u.part_sums.n++;
    refuse(&m, "more records than a frame carries");
}

/* Only a version-6 peer may be sent them, and a part's SESSION_OPEN. */
static void test_versions(void **state)
{
    (void)state;
    qmc_msg m;
    proto_part_build(QMC_MSG_SESSION_PART, PROTO_PART_EXAMPLE, &m);
    assert_int_equal(qmc_proto_msg_min_version(&m), QMC_PROTO_VERSION_PARTS);
    proto_part_build(QMC_MSG_SESSION_PART_SUMS, PROTO_PART_EXAMPLE, &m);
    assert_int_equal(qmc_proto_msg_min_version(&m), QMC_PROTO_VERSION_PARTS);
    memset(&m, 0, sizeof m);
    m.type = QMC_MSG_SESSION_OPEN;
    assert_int_equal(qmc_proto_msg_min_version(&m), QMC_PROTO_VERSION_SESSIONS);
    m.u.session_open.spec.part_k = 1;
    m.u.session_open.spec.part_p = 2;
    assert_int_equal(qmc_proto_msg_min_version(&m), QMC_PROTO_VERSION_PARTS);
    assert_int_equal(QMC_PROTO_VERSION_MAX, QMC_PROTO_VERSION_PARTS);
}

/* prod 2 x_j over [0,1)^d: integral 1. */
static void prod2(const void *ctx, const double *x, size_t n, uint32_t dims, double *out)
{
    (void)ctx;
    for (size_t i = 0; i < n; i++) {
        double p = 1.0;
        for (uint32_t j = 0; j < dims; j++)
            p *= 2.0 * x[i * dims + j];
        out[i] = p;
    }
}

/* A real part session (libqmc, in-process) answered with prod2: its
 * SESSION_PART and its sums, in frames of 3 blocks, decode to what
 * qmc_session_part holds, bit for bit, and its range is --part's. */
static void test_real_part(void **state)
{
    (void)state;
    qmc_session_spec spec;
    qmc_session_spec_init(&spec);
    spec.dims = 2;
    spec.integrate.method = QMC_METHOD_RQMC;
    qmc_sampling_spec_init(&spec.integrate.sampling, QMC_SAMPLER_RQMC);
    spec.integrate.sampling.n = 16384;
    spec.integrate.sampling.reps = 4;
    spec.integrate.sampling.seed = 3;
    spec.integrate.n_given = 1;
    spec.part_k = 2;
    spec.part_p = 3;
    qmc_session *s;
    char why[256];
    assert_int_equal(qmc_session_new(&spec, &s, why, sizeof why), 0);
    static double vals[QMC_SESSION_MAX_BATCH];
    for (;;) {
        qmc_session_batch b;
        assert_int_equal(qmc_session_ask(s, &b), 0);
        if (b.count == 0)
            break;
        assert_true(b.count <= QMC_SESSION_MAX_BATCH);
        prod2(NULL, b.points, b.count, b.dims, vals);
        assert_int_equal(qmc_session_tell(s, b.seq, vals, b.count, why, sizeof why), 0);
    }
    qmc_session_part_sums ps;
    assert_int_equal(qmc_session_part(s, &ps), 0);
    /* 4 x 4 blocks; part 2 of 3: [16/3, 32/3) = [5, 10). */
    assert_true(ps.blocks == 16 && ps.first == 5 && ps.count == 5);

    qmc_msg m, d;
    memset(&m, 0, sizeof m);
    m.type = QMC_MSG_SESSION_PART;
    m.u.session_part = (qmc_msg_session_part){9, ps.fingerprint, ps.blocks, ps.first,
                                              ps.count, 2, 3, ps.sampling};
    size_t n = proto_encode_into(&m, frame, sizeof frame);
    assert_int_equal(qmc_proto_decode(frame, n, QMC_PROTO_MAX_PAYLOAD, &d), (int)n);
    proto_part_same(&m, &d);

    for (uint64_t at = 0; at < ps.count; at += 3) {
        memset(&m, 0, sizeof m);
        m.type = QMC_MSG_SESSION_PART_SUMS;
        m.u.part_sums.session_id = 9;
        m.u.part_sums.first = ps.first + at;
        m.u.part_sums.n = (uint32_t)(ps.count - at < 3 ? ps.count - at : 3);
        m.u.part_sums.sums = ps.sums + at;
        n = proto_encode_into(&m, frame, sizeof frame);
        assert_int_equal(qmc_proto_decode(frame, n, QMC_PROTO_MAX_PAYLOAD, &d), (int)n);
        for (uint32_t i = 0; i < d.u.part_sums.n; i++) {
            qmc_sampling_sums got;
            qmc_proto_part_sums_at(&d.u.part_sums, i, &got);
            /* The record has no padding to compare: field by field is
             * memcmp of the whole struct here. */
            assert_memory_equal(&got, &ps.sums[at + i], sizeof got);
        }
        qmc_sampling_sums none;
        qmc_proto_part_sums_at(&d.u.part_sums, d.u.part_sums.n, &none);
        assert_true(none.count == 0 && none.block == 0); /* past the end: zeroed */
    }
    qmc_session_free(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_mutations),
        cmocka_unit_test(test_encoder_refuses),
        cmocka_unit_test(test_versions),
        cmocka_unit_test(test_real_part),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
