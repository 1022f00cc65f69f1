/*
 * test_proto_session.c - the integration-session messages of the codec
 * (protocol version 5) beyond what test_proto.c checks for every type
 * (round trips, truncation, lengths, the worked examples): each field the
 * decoder must refuse, mutated in the worked example; what the encoder
 * refuses; result flags by version in SESSION_REPORT; and the zero-copy
 * SESSION_VALUES prefix, which must give the bytes qmc_proto_encode gives.
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
#include "proto_session.h"
#include "qmc/proto.h"

static uint8_t frame[PROTO_CHECK_FRAME_BYTES];
static uint8_t frame2[sizeof frame];

static size_t encode_ok(const qmc_msg *m)
{
    return proto_encode_into(m, frame, sizeof frame);
}

typedef proto_mutation mutation; /* proto_check.h */

/* Offsets are those of PROTOCOL.md section 6.21's tables. */
static const mutation mutations[] = {
    {QMC_MSG_SESSION_OPEN, 0, 1, 13, "method 13"},
    {QMC_MSG_SESSION_OPEN, 1, 1, 4, "smoothness 4"},
    {QMC_MSG_SESSION_OPEN, 2, 1, 2, "transport 2"},
    {QMC_MSG_SESSION_OPEN, 3, 1, 2, "n_given 2"},
    {QMC_MSG_SESSION_OPEN, 12, 1, 2, "has_exact 2"},
    {QMC_MSG_SESSION_OPEN, 13, 1, 1, "reserved"},
    {QMC_MSG_SESSION_OPEN, 15, 1, 0x80, "reserved"},
    {QMC_MSG_SESSION_OPEN, 48, 8, 0x7ff8000000000000u, "tol_abs NaN"},
    {QMC_MSG_SESSION_OPEN, 56, 8, 0xfff0000000000000u, "tol_rel -inf"},
    {QMC_MSG_SESSION_OPEN, 64, 8, 0x7ff0000000000000u, "exact inf"},
    {QMC_MSG_SESSION_OPEN, 72, 1, 5, "sampler 5"},
    {QMC_MSG_SESSION_OPEN, 73, 1, 7, "seq kind 7"},
    {QMC_MSG_SESSION_OPEN, 75, 1, 1, "reserved"},
    {QMC_MSG_SESSION_OPEN, 96, 8, 0x7ff8000000000001u, "confidence NaN"},
    {QMC_MSG_SESSION_OPEN, 108, 1, 2, "split_net 2"},
    {QMC_MSG_SESSION_OPEN, 112, 2, QMC_SESSION_NAME_BYTES, "name over its limit"},
    {QMC_MSG_SESSION_OPEN, 112, 2, 7, "name past the payload"},
    {QMC_MSG_SESSION_OPEN, 114, 1, 0, "NUL in the name"},
    {QMC_MSG_SESSION_OPENED, 44, 4, 1, "reserved"},
    {QMC_MSG_SESSION_BATCH, 8, 8, 1, "points past the batch's count"},
    {QMC_MSG_SESSION_BATCH, 16, 8, 1, "first + points past count"},
    {QMC_MSG_SESSION_BATCH, 16, 8, UINT64_MAX, "first past count"},
    {QMC_MSG_SESSION_BATCH, 24, 4, 0, "no points"},
    {QMC_MSG_SESSION_BATCH, 28, 4, 0, "no dims"},
    {QMC_MSG_SESSION_BATCH, 28, 4, 2, "data_len disagrees with dims"},
    {QMC_MSG_SESSION_BATCH, 32, 1, 2, "transport 2"},
    {QMC_MSG_SESSION_BATCH, 32, 1, 1, "the ring with data inline"},
    {QMC_MSG_SESSION_BATCH, 33, 1, 1, "reserved"},
    {QMC_MSG_SESSION_BATCH, 36, 4, 1, "a slot inline"},
    {QMC_MSG_SESSION_BATCH, 40, 4, 47, "data_len disagrees"},
    {QMC_MSG_SESSION_BATCH, 40, 4, 56, "data_len past the payload"},
    {QMC_MSG_SESSION_VALUES, 24, 4, 0, "no values"},
    {QMC_MSG_SESSION_VALUES, 24, 4, 3, "count disagrees with data_len"},
    {QMC_MSG_SESSION_VALUES, 28, 1, 2, "transport 2"},
    {QMC_MSG_SESSION_VALUES, 28, 1, 1, "the ring with data inline"},
    {QMC_MSG_SESSION_VALUES, 30, 1, 1, "reserved"},
    {QMC_MSG_SESSION_VALUES, 32, 4, 1, "a slot inline"},
    {QMC_MSG_SESSION_VALUES, 36, 4, 8, "data_len disagrees"},
    {QMC_MSG_SESSION_VALUES, 36, 4, 24, "data_len past the payload"},
    {QMC_MSG_SESSION_REPORT, 32, 1, 6, "end 6"},
    {QMC_MSG_SESSION_REPORT, 32, 1, QMC_SESSION_FAILED, "failed without an error"},
    {QMC_MSG_SESSION_REPORT, 33, 1, 2, "has_estimate 2"},
    {QMC_MSG_SESSION_REPORT, 34, 1, 3, "error kind 3"},
    {QMC_MSG_SESSION_REPORT, 35, 1, 1, "reserved"},
    {QMC_MSG_SESSION_REPORT, 36, 4, 1u << 17, "undefined result flag"},
    {QMC_MSG_SESSION_REPORT, 40, 4, 0xffffffffu, "an error without failing"},
    {QMC_MSG_SESSION_REPORT, 40, 4, 1, "a positive error"},
    {QMC_MSG_SESSION_RESUME, 40, 1, 2, "transport 2"},
    {QMC_MSG_SESSION_RESUME, 41, 1, 1, "reserved"},
    {QMC_MSG_SESSION_RESUME, 47, 1, 0x80, "reserved"},
    {QMC_MSG_SESSION_RESULT, 16, 4, 1u << 17, "undefined result flag"},
};

/* The valid message a mutation is written over: the variant, but for
 * SESSION_RESULT (JOB_RESULT's layout: its own example is test_proto.c's,
 * any valid result serves here). */
static void build_for_mutation(qmc_msg_type type, int variant, qmc_msg *m)
{
    if (type == QMC_MSG_SESSION_RESULT) {
        memset(m, 0, sizeof *m);
        m->type = QMC_MSG_SESSION_RESULT;
        m->request_id = 11;
    } else {
        proto_session_build(type, variant, m);
    }
}

static void test_mutations(void **state)
{
    (void)state;
    proto_check_mutations(mutations, sizeof mutations / sizeof mutations[0], build_for_mutation,
                          PROTO_SESSION_EXAMPLE, frame, sizeof frame);
}

static void refuse(const qmc_msg *m, const char *what)
{
    proto_check_refused(m, what, frame, sizeof frame);
}

static void test_encoder_refuses(void **state)
{
    (void)state;
    qmc_msg m;
    proto_session_build(QMC_MSG_SESSION_OPEN, PROTO_SESSION_EXAMPLE, &m);
    memset(m.u.session_open.spec.name, 'x', QMC_SESSION_NAME_BYTES);
    refuse(&m, "an unterminated name");
    proto_session_build(QMC_MSG_SESSION_OPEN, PROTO_SESSION_EXAMPLE, &m);
    m.u.session_open.spec.exact = NAN;
    refuse(&m, "a NaN exact value");
    proto_session_build(QMC_MSG_SESSION_OPEN, PROTO_SESSION_EXAMPLE, &m);
    m.u.session_open.spec.smoothness = (qmc_smoothness)4;
    refuse(&m, "smoothness 4");
    proto_session_build(QMC_MSG_SESSION_OPEN, PROTO_SESSION_EXAMPLE, &m);
    m.u.session_open.transport = (qmc_points_transport)2;
    refuse(&m, "transport 2");

    proto_session_build(QMC_MSG_SESSION_BATCH, PROTO_SESSION_EXAMPLE, &m);
    m.u.session_batch.data = NULL;
    refuse(&m, "inline points without data");
    proto_session_build(QMC_MSG_SESSION_BATCH, PROTO_SESSION_EXAMPLE, &m);
    m.u.session_batch.data_len = 40;
    refuse(&m, "data_len that is not points x dims x 8");
    proto_session_build(QMC_MSG_SESSION_BATCH, PROTO_SESSION_EXAMPLE, &m);
    m.u.session_batch.first = 1;
    refuse(&m, "a piece past its batch");
    proto_session_build(QMC_MSG_SESSION_BATCH, PROTO_SESSION_MINIMAL, &m);
    m.u.session_batch.slot = QMC_PROTO_SHM_MAX_SLOTS;
    refuse(&m, "slot 64");
    proto_session_build(QMC_MSG_SESSION_BATCH, PROTO_SESSION_MINIMAL, &m);
    m.u.session_batch.dims = QMC_PROTO_SHM_MAX_SLOT_BYTES / 8;
    m.u.session_batch.data_len = QMC_PROTO_SHM_MAX_SLOT_BYTES;
    refuse(&m, "a ring piece whose values do not fit the largest slot");
    proto_session_build(QMC_MSG_SESSION_BATCH, PROTO_SESSION_MAXIMAL, &m);
    m.u.session_batch.dims++;
    m.u.session_batch.data_len += 8;
    refuse(&m, "inline points over a chunk");

    proto_session_build(QMC_MSG_SESSION_VALUES, PROTO_SESSION_EXAMPLE, &m);
    m.u.session_values.count = 0;
    m.u.session_values.data_len = 0;
    refuse(&m, "no values");
    proto_session_build(QMC_MSG_SESSION_VALUES, PROTO_SESSION_MAXIMAL, &m);
    m.u.session_values.count++;
    m.u.session_values.data_len += 8;
    refuse(&m, "more values than a frame carries");
    proto_session_build(QMC_MSG_SESSION_VALUES, PROTO_SESSION_MINIMAL, &m);
    m.u.session_values.data_len = 8;
    refuse(&m, "ring values with inline data");

    proto_session_build(QMC_MSG_SESSION_REPORT, PROTO_SESSION_EXAMPLE, &m);
    m.u.session_report.report.end = QMC_SESSION_FAILED;
    refuse(&m, "failed without its error");
    proto_session_build(QMC_MSG_SESSION_REPORT, PROTO_SESSION_EXAMPLE, &m);
    m.u.session_report.report.err = QMC_EINVAL;
    refuse(&m, "an error while complete");
    proto_session_build(QMC_MSG_SESSION_REPORT, PROTO_SESSION_EXAMPLE, &m);
    m.u.session_report.report.end = (qmc_session_end)6;
    refuse(&m, "end 6");
    proto_session_build(QMC_MSG_SESSION_REPORT, PROTO_SESSION_EXAMPLE, &m);
    m.u.session_report.report.running.flags = 1u << 31;
    refuse(&m, "an undefined flag");

    proto_session_build(QMC_MSG_SESSION_RESUME, PROTO_SESSION_EXAMPLE, &m);
    m.u.session_ref.transport = (qmc_points_transport)2;
    refuse(&m, "transport 2");
}

/* SESSION_REPORT's flags follow the negotiated version, as JOB_RESULT's:
 * an older peer hears bits 12-16 as error_unreliable, and refuses them. */
static void test_report_flags_by_version(void **state)
{
    (void)state;
    qmc_msg m, d;
    proto_session_build(QMC_MSG_SESSION_REPORT, PROTO_SESSION_EXAMPLE, &m);
    m.u.session_report.report.running.flags = QMC_FLAG_UNRESOLVED;
    int n = qmc_proto_encode_version(&m, 2, frame, sizeof frame);
    assert_true(n > 0);
    assert_int_equal(qmc_proto_decode_version(frame, (size_t)n, QMC_PROTO_MAX_PAYLOAD, 2, &d), n);
    assert_int_equal(d.u.session_report.report.running.flags, QMC_FLAG_ERROR_UNRELIABLE);
    n = qmc_proto_encode(&m, frame, sizeof frame);
    assert_int_equal(qmc_proto_decode_version(frame, (size_t)n, QMC_PROTO_MAX_PAYLOAD, 2, &d),
                     QMC_EPROTO);
    assert_int_equal(qmc_proto_decode(frame, (size_t)n, QMC_PROTO_MAX_PAYLOAD, &d), n);
    assert_int_equal(d.u.session_report.report.running.flags, QMC_FLAG_UNRESOLVED);
}

/* The prefix and the values behind it are the frame qmc_proto_encode
 * makes, for the example and for the largest frame. */
static void test_values_prefix(void **state)
{
    (void)state;
    for (int variant = PROTO_SESSION_EXAMPLE; variant <= PROTO_SESSION_MAXIMAL; variant += 2) {
        qmc_msg m;
        proto_session_build(QMC_MSG_SESSION_VALUES, variant, &m);
        const qmc_msg_session_values *v = &m.u.session_values;
        size_t n = encode_ok(&m);
        memset(frame2, 0xaa, sizeof frame2);
        int k = qmc_proto_encode_session_values_prefix(m.request_id, v, frame2, sizeof frame2);
        assert_int_equal(k, QMC_PROTO_HEADER_BYTES + 40);
        assert_int_equal((size_t)k + v->data_len, n);
        memcpy(frame2 + k, v->data, v->data_len);
        assert_memory_equal(frame, frame2, n);
        /* Too small a buffer: nothing written past it. */
        memset(frame2, 0xaa, 64);
        assert_int_equal(qmc_proto_encode_session_values_prefix(m.request_id, v, frame2,
                                                                (size_t)k - 1),
                         QMC_ETOOBIG);
        assert_int_equal(frame2[k - 1], 0xaa);
    }
    qmc_msg m;
    proto_session_build(QMC_MSG_SESSION_VALUES, PROTO_SESSION_MINIMAL, &m);
    assert_int_equal(qmc_proto_encode_session_values_prefix(1, &m.u.session_values, frame2,
                                                            sizeof frame2),
                     QMC_EINVAL); /* the ring: no data follows */
    proto_session_build(QMC_MSG_SESSION_VALUES, PROTO_SESSION_EXAMPLE, &m);
    m.u.session_values.data_len = 8;
    assert_int_equal(qmc_proto_encode_session_values_prefix(1, &m.u.session_values, frame2,
                                                            sizeof frame2),
                     QMC_EINVAL);
    assert_int_equal(qmc_proto_encode_session_values_prefix(1, NULL, frame2, sizeof frame2),
                     QMC_EINVAL);
}

/* A decoded OPEN is a spec qmc_session_new can take as it is: the
 * example opens, in-process, and hands out its first batch. */
static void test_open_is_a_session_spec(void **state)
{
    (void)state;
    qmc_msg m, d;
    proto_session_build(QMC_MSG_SESSION_OPEN, PROTO_SESSION_EXAMPLE, &m);
    size_t n = encode_ok(&m);
    assert_int_equal(qmc_proto_decode(frame, n, QMC_PROTO_MAX_PAYLOAD, &d), (int)n);
    qmc_session *s;
    char why[256];
    assert_int_equal(qmc_session_new(&d.u.session_open.spec, &s, why, sizeof why), 0);
    qmc_session_batch b;
    assert_int_equal(qmc_session_ask(s, &b), 0);
    assert_int_equal(b.dims, 3);
    /* 16 x 4096 points of rqmc, one batch within max_batch 65536. */
    assert_int_equal(b.count, 65536);
    qmc_session_free(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_mutations),
        cmocka_unit_test(test_encoder_refuses),
        cmocka_unit_test(test_report_flags_by_version),
        cmocka_unit_test(test_values_prefix),
        cmocka_unit_test(test_open_is_a_session_spec),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
