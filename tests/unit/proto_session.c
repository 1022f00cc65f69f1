/*
 * proto_session.c - builds and compares the integration-session messages
 * for the codec's tests (proto_session.h).  The examples are the worked
 * examples of PROTOCOL.md section 6.21 (tests/vectors/proto/session_*.hex);
 * SESSION_RESULT shares JOB_RESULT's layout and is test_proto.c's.
 *
 * Must not: encode or decode anything itself (the tests do, through the
 * codec).
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <float.h>
#include <math.h>
#include <string.h>

#include "proto_check.h"
#include "proto_session.h"

/* The example's token: the bytes 0x80 .. 0x9f (a real one comes from the
 * server's random number generator). */
static void example_token(uint8_t *t, int variant)
{
    for (unsigned i = 0; i < QMC_PROTO_SESSION_TOKEN_BYTES; i++)
        t[i] = variant == PROTO_SESSION_MAXIMAL   ? 0xff
               : variant == PROTO_SESSION_MINIMAL ? 0
                                                  : (uint8_t)(0x80 + i);
}

/* The example batch: two points of three coordinates, as binary64 LE. */
static const double example_points[6] = {0.5, 0.25, 0.75, 0.125, 0.625, 0.375};
/* f at them. */
static const double example_values[2] = {1.5, -0.25};

/* The largest inline data (a chunk's bytes): any bit pattern, NaNs too. */
static uint8_t big_data[QMC_PROTO_CHUNK_BYTES];

static const uint8_t *le_bytes(const double *v, size_t n, uint8_t *out)
{
    for (size_t i = 0; i < n; i++) {
        uint64_t bits;
        memcpy(&bits, &v[i], 8);
        for (int k = 0; k < 8; k++)
            out[8 * i + (size_t)k] = (uint8_t)(bits >> (8 * k));
    }
    return out;
}

int proto_session_is(qmc_msg_type type)
{
    switch (type) {
    case QMC_MSG_SESSION_OPEN:
    case QMC_MSG_SESSION_OPENED:
    case QMC_MSG_SESSION_BATCH:
    case QMC_MSG_SESSION_VALUES:
    case QMC_MSG_SESSION_REPORT:
    case QMC_MSG_SESSION_RESUME:
    case QMC_MSG_SESSION_CLOSE:
        return 1;
    default:
        return 0;
    }
}

static void build_open(qmc_msg *m, int variant)
{
    qmc_msg_session_open *o = &m->u.session_open;
    qmc_session_spec *s = &o->spec;
    qmc_integrate_spec *in = &s->integrate;
    if (variant == PROTO_SESSION_MINIMAL) {
        /* All zeros: analytic, auto, dims 0 (the server's to refuse). */
        return;
    }
    if (variant == PROTO_SESSION_EXAMPLE) {
        /* Request 11: f of 3 dims declared analytic, with its exact value,
         * by RQMC (Sobol, Owen, seed 7, 16 x 4096 points, n given), no
         * tolerance, the default budget, batches of at most 65536 points,
         * inline, named "gauss3". */
        qmc_session_spec_init(s);
        s->dims = 3;
        s->smoothness = QMC_SMOOTH_ANALYTIC;
        s->has_exact = 1;
        s->exact = 0.3126145;
        strcpy(s->name, "gauss3");
        s->max_batch = 65536;
        in->method = QMC_METHOD_RQMC;
        qmc_sampling_spec_init(&in->sampling, QMC_SAMPLER_RQMC);
        in->sampling.seed = 7;
        in->n_given = 1;
        o->transport = QMC_TRANSPORT_INLINE;
        return;
    }
    s->dims = UINT32_MAX;
    s->smoothness = QMC_SMOOTH_SINGULAR;
    s->has_exact = 1;
    s->exact = -DBL_MAX;
    memset(s->name, 'n', QMC_SESSION_NAME_BYTES - 1);
    s->max_batch = UINT64_MAX;
    s->part_k = s->part_p = UINT32_MAX;
    in->method = QMC_METHOD_CLENSHAW_CURTIS;
    in->n_given = 1;
    in->n_axis = UINT32_MAX;
    in->tol_abs = DBL_MAX;
    in->tol_rel = 4.9e-324;
    in->max_evals = in->max_memory = UINT64_MAX;
    in->sampling.sampler = QMC_SAMPLER_RQMC;
    in->sampling.seq = QMC_SEQ_LHS;
    in->sampling.scramble = QMC_SCRAMBLE_FAURE;
    in->sampling.seq_flags = QMC_SEQ_SHUFFLE;
    in->sampling.seed = in->sampling.n = UINT64_MAX;
    in->sampling.reps = UINT32_MAX;
    in->sampling.split_net = 1;
    in->sampling.confidence = DBL_MIN;
    o->transport = QMC_TRANSPORT_SHM;
}

static void build_report(qmc_msg *m, int variant)
{
    qmc_msg_session_report *r = &m->u.session_report;
    qmc_session_report *p = &r->report;
    qmc_result *res = &p->running;
    if (variant == PROTO_SESSION_MINIMAL)
        return; /* running, nothing yet */
    if (variant == PROTO_SESSION_EXAMPLE) {
        /* Session 5 after its 16th batch of 4096 points: complete, with
         * JOB_RESULT's example estimate. */
        r->session_id = 5;
        p->end = QMC_SESSION_COMPLETE;
        p->batches = 16;
        p->evals = 65536;
        p->has_estimate = 1;
        res->estimate = 0.3126145012;
        res->error = 1.2e-7;
        res->ci_low = 0.31261424;
        res->ci_high = 0.31261476;
        res->error_kind = QMC_ERROR_STDERR;
        res->n = 4096;
        res->evals = 65536;
        res->dims = 3;
        res->abs_integral = 0.3126145012;
        return;
    }
    r->session_id = UINT64_MAX;
    p->end = QMC_SESSION_FAILED;
    p->err = INT32_MIN;
    p->batches = p->evals = p->nonfinite = UINT64_MAX;
    p->has_estimate = 1;
    res->estimate = NAN;
    res->error = INFINITY;
    res->ci_low = -INFINITY;
    res->ci_high = -0.0;
    res->error_kind = QMC_ERROR_ESTIMATE;
    res->n = res->evals = res->nonfinite = UINT64_MAX;
    res->dims = UINT32_MAX;
    res->flags = 0
#define ALL_FLAGS(name, bit, key, text) | QMC_FLAG_##name
        QMC_FLAG_MAP(ALL_FLAGS);
#undef ALL_FLAGS
    res->abs_integral = DBL_MAX;
}

void proto_session_build(qmc_msg_type type, int variant, qmc_msg *m)
{
    static uint8_t points_le[sizeof example_points], values_le[sizeof example_values];
    const int ex = variant == PROTO_SESSION_EXAMPLE, mx = variant == PROTO_SESSION_MAXIMAL;
    memset(m, 0, sizeof *m);
    m->type = type;
    m->request_id = mx ? UINT64_MAX : 0;
    for (size_t i = 0; i < sizeof big_data; i++)
        big_data[i] = (uint8_t)(i * 151u + 3u);
    switch (type) {
    case QMC_MSG_SESSION_OPEN:
        m->request_id = ex ? 11 : m->request_id;
        build_open(m, variant);
        break;
    case QMC_MSG_SESSION_OPENED: {
        /* Session 5 of request 11: batches of at most 65536 points, 3.3 MB
         * reserved, kept 300 s after its connection goes. */
        qmc_msg_session_opened *o = &m->u.session_opened;
        m->request_id = ex ? 11 : m->request_id;
        o->session_id = mx ? UINT64_MAX : ex ? 5 : 0;
        example_token(o->token, variant);
        o->dims = mx ? UINT32_MAX : ex ? 3 : 0;
        o->max_batch = mx ? UINT64_MAX : ex ? 65536 : 0;
        o->memory_bytes = mx ? UINT64_MAX : ex ? 3300000 : 0;
        o->park_ms = mx ? UINT64_MAX : ex ? 300000 : 0;
        break;
    }
    case QMC_MSG_SESSION_BATCH: {
        qmc_msg_session_batch *b = &m->u.session_batch;
        m->request_id = ex ? 11 : m->request_id;
        if (ex) {
            /* Batch 0 of session 5: two points, inline. */
            b->count = b->points = 2;
            b->dims = 3;
            b->data_len = sizeof example_points;
            b->data = le_bytes(example_points, 6, points_le);
        } else if (mx) {
            /* The last point of the largest batch, a chunk's bytes inline. */
            b->seq = UINT64_MAX;
            b->count = UINT64_MAX;
            b->first = UINT64_MAX - 1;
            b->points = 1;
            b->dims = QMC_PROTO_CHUNK_BYTES / 8;
            b->data_len = QMC_PROTO_CHUNK_BYTES;
            b->data = big_data;
        } else {
            /* One point of one coordinate in ring slot 0. */
            b->count = b->points = b->dims = 1;
            b->transport = QMC_TRANSPORT_SHM;
            b->data_len = 8;
        }
        break;
    }
    case QMC_MSG_SESSION_VALUES: {
        qmc_msg_session_values *v = &m->u.session_values;
        m->request_id = ex ? 12 : m->request_id;
        if (ex) {
            /* The values of the example batch, inline, under request 12. */
            v->session_id = 5;
            v->count = 2;
            v->data_len = sizeof example_values;
            v->data = le_bytes(example_values, 2, values_le);
        } else if (mx) {
            v->session_id = v->seq = v->first = UINT64_MAX;
            v->count = QMC_PROTO_SESSION_MAX_VALUES;
            v->data_len = QMC_PROTO_CHUNK_BYTES;
            v->data = big_data;
        } else {
            v->count = 1;
            v->transport = QMC_TRANSPORT_SHM;
        }
        break;
    }
    case QMC_MSG_SESSION_REPORT:
        m->request_id = ex ? 11 : m->request_id;
        build_report(m, variant);
        break;
    case QMC_MSG_SESSION_RESUME:
        /* Session 5 taken up again by request 13, batches through the ring. */
        m->request_id = ex ? 13 : m->request_id;
        m->u.session_ref.session_id = mx ? UINT64_MAX : ex ? 5 : 0;
        example_token(m->u.session_ref.token, variant);
        m->u.session_ref.transport = ex || mx ? QMC_TRANSPORT_SHM : QMC_TRANSPORT_INLINE;
        break;
    case QMC_MSG_SESSION_CLOSE:
        m->request_id = ex ? 14 : m->request_id;
        m->u.session_ref.session_id = mx ? UINT64_MAX : ex ? 5 : 0;
        example_token(m->u.session_ref.token, variant);
        break;
    default:
        fail_msg("proto_session_build: %s is not a session message", qmc_msg_type_name(type));
    }
}


static void same_spec(const qmc_session_spec *s, const qmc_session_spec *t)
{
    assert_int_equal(s->dims, t->dims);
    assert_int_equal(s->smoothness, t->smoothness);
    assert_int_equal(s->has_exact != 0, t->has_exact != 0);
    proto_same_f64(s->exact, t->exact);
    assert_string_equal(s->name, t->name);
    assert_true(s->max_batch == t->max_batch);
    assert_int_equal(s->part_k, t->part_k);
    assert_int_equal(s->part_p, t->part_p);
    const qmc_integrate_spec *a = &s->integrate, *b = &t->integrate;
    assert_int_equal(a->method, b->method);
    assert_int_equal(a->n_given != 0, b->n_given != 0);
    assert_int_equal(a->n_axis, b->n_axis);
    proto_same_f64(a->tol_abs, b->tol_abs);
    proto_same_f64(a->tol_rel, b->tol_rel);
    assert_true(a->max_evals == b->max_evals);
    assert_true(a->max_memory == b->max_memory);
    assert_int_equal(a->sampling.sampler, b->sampling.sampler);
    assert_int_equal(a->sampling.seq, b->sampling.seq);
    assert_int_equal(a->sampling.scramble, b->sampling.scramble);
    assert_int_equal(a->sampling.seq_flags, b->sampling.seq_flags);
    assert_true(a->sampling.seed == b->sampling.seed);
    assert_true(a->sampling.n == b->sampling.n);
    assert_int_equal(a->sampling.reps, b->sampling.reps);
    assert_int_equal(a->sampling.split_net != 0, b->sampling.split_net != 0);
    proto_same_f64(a->sampling.confidence, b->sampling.confidence);
    /* The hook is in-process only: a decoded spec has none. */
    assert_null(b->interrupt.fn);
}

static void same_report(const qmc_session_report *p, const qmc_session_report *q)
{
    assert_int_equal(p->end, q->end);
    assert_int_equal(p->err, q->err);
    assert_true(p->batches == q->batches);
    assert_true(p->evals == q->evals);
    assert_true(p->nonfinite == q->nonfinite);
    assert_int_equal(p->has_estimate != 0, q->has_estimate != 0);
    const qmc_result *a = &p->running, *b = &q->running;
    proto_same_f64(a->estimate, b->estimate);
    proto_same_f64(a->error, b->error);
    proto_same_f64(a->ci_low, b->ci_low);
    proto_same_f64(a->ci_high, b->ci_high);
    proto_same_f64(a->abs_integral, b->abs_integral);
    assert_int_equal(a->error_kind, b->error_kind);
    assert_true(a->n == b->n);
    assert_true(a->evals == b->evals);
    assert_true(a->nonfinite == b->nonfinite);
    assert_int_equal(a->dims, b->dims);
    assert_int_equal(a->flags, b->flags);
}

void proto_session_same(const qmc_msg *a, const qmc_msg *b)
{
    assert_int_equal(a->type, b->type);
    assert_true(a->request_id == b->request_id);
    switch (a->type) {
    case QMC_MSG_SESSION_OPEN:
        same_spec(&a->u.session_open.spec, &b->u.session_open.spec);
        assert_int_equal(a->u.session_open.transport, b->u.session_open.transport);
        break;
    case QMC_MSG_SESSION_OPENED: {
        const qmc_msg_session_opened *o = &a->u.session_opened, *p = &b->u.session_opened;
        assert_true(o->session_id == p->session_id);
        assert_memory_equal(o->token, p->token, QMC_PROTO_SESSION_TOKEN_BYTES);
        assert_int_equal(o->dims, p->dims);
        assert_true(o->max_batch == p->max_batch);
        assert_true(o->memory_bytes == p->memory_bytes);
        assert_true(o->park_ms == p->park_ms);
        break;
    }
    case QMC_MSG_SESSION_BATCH: {
        const qmc_msg_session_batch *x = &a->u.session_batch, *y = &b->u.session_batch;
        assert_true(x->seq == y->seq && x->count == y->count && x->first == y->first);
        assert_int_equal(x->points, y->points);
        assert_int_equal(x->dims, y->dims);
        assert_int_equal(x->transport, y->transport);
        assert_int_equal(x->slot, y->slot);
        assert_int_equal(x->data_len, y->data_len);
        if (x->transport == QMC_TRANSPORT_INLINE)
            assert_memory_equal(x->data, y->data, x->data_len);
        else
            assert_null(y->data);
        break;
    }
    case QMC_MSG_SESSION_VALUES: {
        const qmc_msg_session_values *x = &a->u.session_values, *y = &b->u.session_values;
        assert_true(x->session_id == y->session_id && x->seq == y->seq && x->first == y->first);
        assert_int_equal(x->count, y->count);
        assert_int_equal(x->transport, y->transport);
        assert_int_equal(x->slot, y->slot);
        assert_int_equal(x->data_len, y->data_len);
        if (x->transport == QMC_TRANSPORT_INLINE)
            assert_memory_equal(x->data, y->data, x->data_len);
        else
            assert_null(y->data);
        break;
    }
    case QMC_MSG_SESSION_REPORT:
        assert_true(a->u.session_report.session_id == b->u.session_report.session_id);
        same_report(&a->u.session_report.report, &b->u.session_report.report);
        break;
    case QMC_MSG_SESSION_RESUME:
    case QMC_MSG_SESSION_CLOSE:
        assert_true(a->u.session_ref.session_id == b->u.session_ref.session_id);
        assert_memory_equal(a->u.session_ref.token, b->u.session_ref.token,
                            QMC_PROTO_SESSION_TOKEN_BYTES);
        assert_int_equal(a->u.session_ref.transport, b->u.session_ref.transport);
        break;
    default:
        fail_msg("proto_session_same: %s is not a session message", qmc_msg_type_name(a->type));
    }
}
