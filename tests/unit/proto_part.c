/*
 * proto_part.c - builds and compares the part-session messages for the
 * codec's tests (proto_part.h).  The examples are the worked examples of
 * PROTOCOL.md section 6.22 (tests/vectors/proto/session_part*.hex).
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
#include "proto_part.h"

/* The largest frame's records: every count at its limit, sums of any bit
 * pattern (NaN, infinities, -0), the largest values descending from
 * infinity to 0. */
static qmc_sampling_sums big_sums[QMC_PROTO_PART_MAX_SUMS];

int proto_part_is(qmc_msg_type type)
{
    return type == QMC_MSG_SESSION_PART || type == QMC_MSG_SESSION_PART_SUMS;
}

/* The job of the examples: RQMC over Sobol with Owen scrambling, seed 7,
 * 16 replicates of 4096 points (16 blocks), as SESSION_OPEN's example. */
static void example_sampling(qmc_sampling_spec *q)
{
    qmc_sampling_spec_init(q, QMC_SAMPLER_RQMC);
    q->seed = 7;
    q->n = 4096;
    q->reps = 16;
}

static void build_part(qmc_msg *m, int variant)
{
    qmc_msg_session_part *p = &m->u.session_part;
    if (variant == PROTO_PART_EXAMPLE) {
        /* Session 5 was opened as part 2 of 3 of that job: blocks 5 to 9
         * (16 x 1/3 = 5, 16 x 2/3 = 10).  The fingerprint shown stands
         * for the job's (qmc_sampling_fingerprint). */
        m->request_id = 11;
        p->session_id = 5;
        p->fingerprint = 0x1bf08c2ca4d55adeull;
        p->blocks = 16;
        p->first = 5;
        p->count = 5;
        p->part_k = 2;
        p->part_p = 3;
        example_sampling(&p->sampling);
        return;
    }
    if (variant == PROTO_PART_MINIMAL) {
        /* The one block of a one-part job. */
        p->blocks = p->count = 1;
        p->part_k = p->part_p = 1;
        return;
    }
    m->request_id = UINT64_MAX;
    p->session_id = p->fingerprint = UINT64_MAX;
    p->blocks = QMC_SAMPLING_MAX_BLOCKS;
    p->part_k = p->part_p = UINT32_MAX;
    p->first = p->blocks * (p->part_k - 1ull) / p->part_p;
    p->count = p->blocks - p->first;
    qmc_sampling_spec *q = &p->sampling;
    q->sampler = QMC_SAMPLER_RQMC;
    q->seq = QMC_SEQ_LHS;
    q->scramble = QMC_SCRAMBLE_FAURE;
    q->seq_flags = QMC_SEQ_SHUFFLE;
    q->seed = q->n = UINT64_MAX;
    q->reps = UINT32_MAX;
    q->split_net = 1;
    q->confidence = DBL_MAX;
}

/* The example block: f is 4 at one point of the block, 2 at another, 1 at
 * a third and 0 at the other 4093 (no control variate): its Neumaier sums,
 * moments and largest values. */
static qmc_sampling_sums example_block(void)
{
    qmc_sampling_sums s;
    memset(&s, 0, sizeof s);
    s.block = 5;
    s.count = 4096;
    s.f[0] = s.absf[0] = 7.0;
    s.mean_f = 7.0 / 4096.0;
    s.m2_f = 21.0 - 49.0 / 4096.0;
    s.top[0] = 4.0;
    s.top[1] = 2.0;
    s.top[2] = 1.0;
    return s;
}

static void build_sums(qmc_msg *m, int variant)
{
    static qmc_sampling_sums one;
    qmc_msg_session_part_sums *p = &m->u.part_sums;
    if (variant == PROTO_PART_EXAMPLE) {
        /* Session 5's first block, alone in its frame. */
        m->request_id = 11;
        one = example_block();
        p->session_id = 5;
        p->first = 5;
        p->n = 1;
        p->sums = &one;
        return;
    }
    if (variant == PROTO_PART_MINIMAL) {
        memset(&one, 0, sizeof one);
        p->n = 1;
        p->sums = &one;
        return;
    }
    m->request_id = UINT64_MAX;
    p->session_id = UINT64_MAX;
    p->n = QMC_PROTO_PART_MAX_SUMS;
    p->first = QMC_SAMPLING_MAX_BLOCKS - p->n;
    const double odd[] = {NAN, INFINITY, -INFINITY, -0.0, DBL_MAX, -DBL_MIN, 4.9e-324};
    for (uint32_t i = 0; i < p->n; i++) {
        qmc_sampling_sums *s = &big_sums[i];
        s->block = p->first + i;
        s->count = s->nonfinite = QMC_SAMPLING_BLOCK;
        double *v[11] = {&s->f[0], &s->f[1], &s->absf[0], &s->absf[1], &s->g[0], &s->g[1],
                         &s->mean_f, &s->mean_g, &s->m2_f, &s->m2_g, &s->c_fg};
        for (int k = 0; k < 11; k++)
            *v[k] = odd[(i + (uint32_t)k) % 7];
        s->top[0] = INFINITY;
        for (int k = 1; k < QMC_SAMPLING_TOP; k++)
            s->top[k] = DBL_MAX / (double)k / (double)(i + 1);
        s->top[QMC_SAMPLING_TOP - 1] = 0.0;
    }
    p->sums = big_sums;
}

void proto_part_build(qmc_msg_type type, int variant, qmc_msg *m)
{
    memset(m, 0, sizeof *m);
    m->type = type;
    if (type == QMC_MSG_SESSION_PART)
        build_part(m, variant);
    else if (type == QMC_MSG_SESSION_PART_SUMS)
        build_sums(m, variant);
    else
        fail_msg("proto_part_build: %s is not a part message", qmc_msg_type_name(type));
}


static void same_sums(const qmc_sampling_sums *s, const qmc_sampling_sums *t)
{
    assert_true(s->block == t->block && s->count == t->count && s->nonfinite == t->nonfinite);
    const double u[11] = {s->f[0], s->f[1], s->absf[0], s->absf[1], s->g[0], s->g[1],
                          s->mean_f, s->mean_g, s->m2_f, s->m2_g, s->c_fg};
    const double w[11] = {t->f[0], t->f[1], t->absf[0], t->absf[1], t->g[0], t->g[1],
                          t->mean_f, t->mean_g, t->m2_f, t->m2_g, t->c_fg};
    for (int k = 0; k < 11; k++)
        proto_same_f64(u[k], w[k]);
    for (int k = 0; k < QMC_SAMPLING_TOP; k++)
        proto_same_f64(s->top[k], t->top[k]);
}

void proto_part_same(const qmc_msg *a, const qmc_msg *b)
{
    assert_int_equal(a->type, b->type);
    assert_true(a->request_id == b->request_id);
    if (a->type == QMC_MSG_SESSION_PART) {
        const qmc_msg_session_part *p = &a->u.session_part, *q = &b->u.session_part;
        assert_true(p->session_id == q->session_id && p->fingerprint == q->fingerprint);
        assert_true(p->blocks == q->blocks && p->first == q->first && p->count == q->count);
        assert_int_equal(p->part_k, q->part_k);
        assert_int_equal(p->part_p, q->part_p);
        const qmc_sampling_spec *x = &p->sampling, *y = &q->sampling;
        assert_int_equal(x->sampler, y->sampler);
        assert_int_equal(x->seq, y->seq);
        assert_int_equal(x->scramble, y->scramble);
        assert_int_equal(x->seq_flags, y->seq_flags);
        assert_true(x->seed == y->seed && x->n == y->n);
        assert_int_equal(x->reps, y->reps);
        assert_int_equal(x->split_net != 0, y->split_net != 0);
        proto_same_f64(x->confidence, y->confidence);
        return;
    }
    if (a->type != QMC_MSG_SESSION_PART_SUMS)
        fail_msg("proto_part_same: %s is not a part message", qmc_msg_type_name(a->type));
    const qmc_msg_session_part_sums *p = &a->u.part_sums, *q = &b->u.part_sums;
    assert_true(p->session_id == q->session_id && p->first == q->first);
    assert_int_equal(p->n, q->n);
    for (uint32_t i = 0; i < p->n; i++) {
        qmc_sampling_sums s, t;
        qmc_proto_part_sums_at(p, i, &s);
        qmc_proto_part_sums_at(q, i, &t);
        same_sums(&s, &t);
    }
}
