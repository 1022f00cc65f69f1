/*
 * test_session.c - integration sessions (qmc/session.h): the caller
 * evaluates f, the session keeps the rest.
 *
 * The oracle is qmc_integrate itself on the same built-in integrand: a
 * session whose caller answers every batch with f's values must return
 * the same report, bit for bit in every field, for every method - auto
 * over integrands that make it pick each branch - and for any batch size.
 * Besides: the batches are the sizes docs/SESSIONS.md gives; the running
 * estimate of a fixed RQMC job after r replicates is the whole job run
 * with r replicates (replicate r's points do not depend on how many there
 * are); the fiber's stack stays well within its size; and a part of a
 * fixed-n job has the block sums and fingerprint of the built-in part,
 * whose merge is the whole job.  Hostile callers: test_session_hostile.c.
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hook.h"
#include "session_drive.h"
#include "session_impl.h"
#include "qmc/sampling.h"

#define SAME(x, y) (memcmp(&(x), &(y), sizeof(x)) == 0)

/* ---- every method, bit for bit ----------------------------------------------- */

typedef struct eq_case {
    const char *integrand;
    uint32_t dims;
    const double *a, *u;
    const char *method;
    double tol_rel;
    uint64_t max_evals;   /* 0: default */
    uint64_t n;           /* 0: default */
    uint32_t reps;        /* 0: default */
    qmc_method expect;    /* auto's pick (method_used) */
    const char *reason;   /* in auto's reason, or NULL */
} eq_case;

static const double peak1_a[] = {30000}, peak1_u[] = {0.37};
/* a kink where auto's cubature is far off and RQMC replaces it */
static const double kink3_a[] = {5, 3, 7}, kink3_u[] = {0.5487, 0.7505, 0.7473};

static const eq_case eq_cases[] = {
    /* sampling, fixed n (n not a multiple of the block: a short last block) */
    {"genz-gaussian", 3, NULL, NULL, "mc", 0, 0, 10000, 0, QMC_METHOD_MC, NULL},
    {"genz-gaussian", 3, NULL, NULL, "mc", 0, 0, 5000, 4, QMC_METHOD_MC, NULL},
    {"genz-continuous", 2, NULL, NULL, "stratified", 0, 0, 0, 0, QMC_METHOD_STRATIFIED, NULL},
    {"genz-continuous", 4, NULL, NULL, "lhs", 0, 0, 9000, 0, QMC_METHOD_LHS, NULL},
    {"genz-oscillatory", 5, NULL, NULL, "qmc", 0, 0, 8192, 0, QMC_METHOD_QMC, NULL},
    {"genz-product-peak", 4, NULL, NULL, "rqmc", 0, 0, 0, 0, QMC_METHOD_RQMC, NULL},
    {"genz-product-peak", 4, NULL, NULL, "rqmc", 0, 0, 3000, 8, QMC_METHOD_RQMC, NULL},
    /* sampling, adaptive */
    {"genz-gaussian", 6, NULL, NULL, "rqmc", 1e-5, 2000000, 1024, 0, QMC_METHOD_RQMC, NULL},
    {"genz-corner-peak", 3, NULL, NULL, "mc", 1e-3, 1000000, 0, 0, QMC_METHOD_MC, NULL},
    {"genz-continuous", 3, NULL, NULL, "stratified", 1e-3, 1000000, 0, 0,
     QMC_METHOD_STRATIFIED, NULL},
    {"genz-continuous", 3, NULL, NULL, "lhs", 1e-3, 500000, 0, 0, QMC_METHOD_LHS, NULL},
    /* tensor rules */
    {"genz-gaussian", 2, NULL, NULL, "midpoint", 0, 0, 0, 0, QMC_METHOD_MIDPOINT, NULL},
    {"genz-gaussian", 3, NULL, NULL, "trapezoid", 0, 0, 0, 0, QMC_METHOD_TRAPEZOID, NULL},
    {"genz-gaussian", 2, NULL, NULL, "simpson", 0, 0, 0, 0, QMC_METHOD_SIMPSON, NULL},
    {"genz-oscillatory", 3, NULL, NULL, "gauss-legendre", 0, 0, 0, 0,
     QMC_METHOD_GAUSS_LEGENDRE, NULL},
    /* adaptive rules */
    {"exp", 1, NULL, NULL, "gauss-kronrod", 1e-10, 0, 0, 0, QMC_METHOD_GAUSS_KRONROD, NULL},
    {"inv-sqrt", 1, NULL, NULL, "gauss-kronrod", 1e-8, 0, 0, 0, QMC_METHOD_GAUSS_KRONROD, NULL},
    {"genz-product-peak", 3, NULL, NULL, "cubature", 1e-6, 2000000, 0, 0,
     QMC_METHOD_CUBATURE, NULL},
    {"genz-oscillatory", 3, NULL, NULL, "clenshaw-curtis", 1e-9, 0, 0, 0,
     QMC_METHOD_CLENSHAW_CURTIS, NULL},
    /* auto, every branch */
    {"cos", 1, NULL, NULL, "auto", 0, 0, 0, 0, QMC_METHOD_GAUSS_KRONROD, NULL},
    {"genz-oscillatory", 2, NULL, NULL, "auto", 0, 10000, 0, 0, QMC_METHOD_CLENSHAW_CURTIS, NULL},
    {"genz-gaussian", 7, NULL, NULL, "auto", 1e-4, 1000000, 0, 0, QMC_METHOD_CUBATURE, NULL},
    /* cubature on a declared kink, its bar confirmed by nothing off its
     * nodes, then rqmc with the rest of the budget: vouching for it, and
     * (where cubature is far off) replacing it */
    {"genz-continuous", 3, NULL, NULL, "auto", 1e-4, 1000000, 0, 0, QMC_METHOD_CUBATURE,
     "rqmc vouched for the rule's bar"},
    {"genz-continuous", 3, kink3_a, kink3_u, "auto", 1e-4, 1000000, 0, 0, QMC_METHOD_RQMC,
     "nothing off its nodes had confirmed its bar"},
    {"genz-discontinuous", 3, NULL, NULL, "auto", 1e-3, 1000000, 0, 0, QMC_METHOD_RQMC,
     "split one net (more accurate with jumps"},
    /* rqmc over a VEGAS map (its pilot's batches come in the map's chunks) */
    {"genz-product-peak", 12, NULL, NULL, "auto", 1e-3, 2000000, 0, 0, QMC_METHOD_RQMC,
     "over a VEGAS map"},
    {"genz-continuous", 6, NULL, NULL, "auto", 1e-3, 300000, 0, 0, QMC_METHOD_RQMC,
     "over a VEGAS map"},
    /* a rule that saw nothing, then rqmc with the rest of the budget */
    {"genz-gaussian", 1, peak1_a, peak1_u, "auto", 0, 2000000, 0, 0, QMC_METHOD_RQMC,
     "left the integrand unresolved"},
    /* a small budget: auto's first round of 8 x 512 */
    {"genz-continuous", 8, NULL, NULL, "auto", 1e-2, 10000, 0, 0, QMC_METHOD_RQMC,
     "8 dimensions (above cubature's range)"},
};

static void case_spec(const eq_case *c, qmc_integrate_spec *is)
{
    session_test_method(is, c->method);
    is->tol_rel = c->tol_rel;
    if (c->max_evals)
        is->max_evals = c->max_evals;
    if (c->n) {
        is->sampling.n = c->n;
        is->n_given = 1;
    }
    if (c->reps)
        is->sampling.reps = c->reps;
    is->sampling.seed = 20240611;
}

/* Batch sizes: the default, two blocks, one block and a half (groups of one
 * block), and less than a block (the engine's own chunks). */
static const uint64_t batches[] = {0, 2 * QMC_SAMPLING_BLOCK, 6000, 1000};

static void test_every_method_bit_for_bit(void **state)
{
    (void)state;
    for (size_t i = 0; i < sizeof eq_cases / sizeof eq_cases[0]; i++) {
        const eq_case *c = &eq_cases[i];
        problem p = session_test_make(c->integrand, c->dims, c->a, c->u);
        qmc_integrate_spec is;
        case_spec(c, &is);
        outcome want = session_test_via_integrate(&is, p.f);
        if (want.err)
            fail_msg("case %zu (%s %s): qmc_integrate: %s", i, c->integrand, c->method, want.why);
        assert_int_equal(want.rep.method_used, c->expect);
        if (c->reason && !strstr(want.rep.auto_reason, c->reason))
            fail_msg("case %zu: auto's reason '%s' lacks '%s'", i, want.rep.auto_reason,
                     c->reason);
        for (size_t k = 0; k < sizeof batches / sizeof batches[0]; k++) {
            qmc_session_spec ss;
            session_test_spec(&ss, &is, p.f);
            ss.max_batch = batches[k];
            outcome got = session_test_via_session(&ss, p.f);
            char what[128];
            snprintf(what, sizeof what, "case %zu (%s %s), batch %llu", i, c->integrand,
                     c->method, (unsigned long long)batches[k]);
            session_test_assert_same(&got, &want, what);
            /* the session's own account agrees with the integrator's */
            assert_int_equal(got.status.evals, want.rep.res.evals);
            assert_int_equal(got.status.has_estimate, 1);
            assert_true(test_same_result(&got.status.running, &want.rep.res));
            assert_int_not_equal(got.status.end, QMC_SESSION_RUNNING);
            assert_int_not_equal(got.status.end, QMC_SESSION_FAILED);
            if (batches[k])
                assert_true(got.largest <= (batches[k] > 256 ? batches[k] : 256) ||
                            strstr(want.rep.auto_reason, "VEGAS map") /* its pilot's chunks */);
            /* Told ahead: the same bytes, the same batches - none handed
             * out that the integrator did not want - and the same count. */
            outcome ahead = session_test_via_session_ahead(&ss, p.f);
            session_test_assert_same(&ahead, &want, what);
            assert_int_equal(ahead.batches, got.batches);
            assert_int_equal(ahead.status.evals, want.rep.res.evals);
            assert_true(test_same_result(&ahead.status.running, &want.rep.res));
        }
        qmc_testfn_free(p.fn);
    }
}

/* The batches a session hands out: whole blocks up to max_batch for a
 * fixed-n sampling job, the rule's own for quadrature. */
static void test_batch_sizes(void **state)
{
    (void)state;
    problem p = session_test_make("genz-gaussian", 2, NULL, NULL);
    qmc_integrate_spec is;
    session_test_method(&is, "rqmc"); /* 16 x 4096 */
    qmc_session_spec ss;
    session_test_spec(&ss, &is, p.f);
    outcome o = session_test_via_session(&ss, p.f);
    assert_int_equal(o.batches, 1); /* 16 blocks, 65536 points: one batch */
    assert_int_equal(o.largest, 16 * 4096);
    ss.max_batch = 3 * QMC_SAMPLING_BLOCK;
    o = session_test_via_session(&ss, p.f);
    assert_int_equal(o.batches, 6); /* 3+3+3+3+3+1 blocks */
    ss.max_batch = 100;
    o = session_test_via_session(&ss, p.f);
    assert_int_equal(o.batches, 16 * 16); /* the engine's 256-point chunks */
    qmc_testfn_free(p.fn);
    p = session_test_make("exp", 1, NULL, NULL);
    session_test_method(&is, "gauss-kronrod");
    session_test_spec(&ss, &is, p.f);
    o = session_test_via_session(&ss, p.f);
    assert_int_equal(o.largest, 21); /* G10-K21 on [0,1]: converged at once */
    qmc_testfn_free(p.fn);
}

/* ---- the running report ------------------------------------------------------ */

/* After r replicates of a fixed rqmc job, the running estimate is that of
 * the same job with r replicates (each replicate's scramble is seeded from
 * (seed, r) alone) - except evals, which counts every value so far. */
static void test_running_estimate(void **state)
{
    (void)state;
    problem p = session_test_make("genz-oscillatory", 4, NULL, NULL);
    qmc_integrate_spec is;
    session_test_method(&is, "rqmc");
    is.sampling.reps = 12;
    qmc_session_spec ss;
    /* one replicate a batch */
    qmc_session *s = session_test_open(&ss, &is, p.f, QMC_SAMPLING_BLOCK);
    qmc_session_report r;
    qmc_session_status(s, &r);
    assert_int_equal(r.end, QMC_SESSION_RUNNING);
    assert_int_equal(r.has_estimate, 0);
    answer_buf buf = {NULL, 0};
    for (uint32_t rep = 1; rep <= 12; rep++) {
        qmc_session_batch b;
        assert_int_equal(session_test_answer(s, p.f, &b, &buf), QMC_SAMPLING_BLOCK);
        qmc_session_status(s, &r);
        assert_int_equal(r.evals, rep * (uint64_t)QMC_SAMPLING_BLOCK);
        assert_int_equal(r.batches, rep);
        if (rep < 2) {
            assert_int_equal(r.has_estimate, 0);
            continue;
        }
        assert_int_equal(r.has_estimate, 1);
        qmc_integrate_spec fewer = is;
        fewer.sampling.reps = rep;
        outcome want = session_test_via_integrate(&fewer, p.f);
        assert_int_equal(want.err, 0);
        assert_true(SAME(r.running.estimate, want.rep.res.estimate));
        assert_true(SAME(r.running.error, want.rep.res.error));
        assert_true(SAME(r.running.ci_low, want.rep.res.ci_low));
        assert_true(SAME(r.running.ci_high, want.rep.res.ci_high));
        assert_int_equal(r.running.flags, want.rep.res.flags);
        assert_int_equal(r.running.evals, want.rep.res.evals);
        assert_int_equal(r.end, rep < 12 ? QMC_SESSION_RUNNING : QMC_SESSION_COMPLETE);
    }
    qmc_session_batch b;
    assert_int_equal(qmc_session_ask(s, &b), 0);
    assert_int_equal(b.count, 0);
    free(buf.vals);
    qmc_session_free(s);
    qmc_testfn_free(p.fn);
}

/* The running estimate is taken again only once the work has grown by an
 * eighth (so the passes over the blocks stay linear in the job): it is
 * never more than an eighth behind the values told, and at the end it is
 * the result. */
static void test_running_lag(void **state)
{
    (void)state;
    problem p = session_test_make("genz-gaussian", 2, NULL, NULL);
    qmc_integrate_spec is;
    qmc_integrate_spec_init(&is);
    is.method = QMC_METHOD_MC;
    is.sampling.n = 200 * QMC_SAMPLING_BLOCK;
    is.n_given = 1;
    qmc_session_spec ss;
    qmc_session *s = session_test_open(&ss, &is, p.f, QMC_SAMPLING_BLOCK);
    answer_buf buf = {NULL, 0};
    uint64_t last_n = 0, updates = 0;
    qmc_session_batch b;
    while (session_test_answer(s, p.f, &b, &buf)) {
        qmc_session_report r;
        qmc_session_status(s, &r);
        assert_int_equal(r.has_estimate, 1); /* mc: from the first block on */
        assert_true(9 * r.running.n >= 8 * r.evals);
        updates += r.running.n != last_n;
        last_n = r.running.n;
    }
    free(buf.vals);
    assert_true(updates < 60); /* about 8 + ln(200/8)/ln(9/8) = 36, not 200 */
    outcome o = session_test_drive(s, p.f);
    assert_true(test_same_result(&o.status.running, &o.rep.res));
    assert_int_equal(o.rep.res.n, is.sampling.n);
    qmc_session_free(s);
    qmc_testfn_free(p.fn);
}

/* A rule has no estimate before its end; its report still counts values
 * and raises nonfinite at once. */
static void test_running_rule(void **state)
{
    (void)state;
    problem p = session_test_make("genz-gaussian", 3, NULL, NULL);
    qmc_integrate_spec is;
    session_test_method(&is, "cubature");
    qmc_session_spec ss;
    qmc_session *s = session_test_open(&ss, &is, p.f, 0);
    qmc_session_batch b;
    answer_buf buf = {NULL, 0};
    const size_t first = session_test_answer(s, p.f, &b, &buf);
    free(buf.vals);
    assert_true(first > 0 && first <= 256);
    qmc_session_report r;
    qmc_session_status(s, &r);
    assert_int_equal(r.end, QMC_SESSION_RUNNING);
    assert_int_equal(r.has_estimate, 0);
    assert_int_equal(r.evals, b.count);
    assert_int_equal(r.nonfinite, 0);
    assert_int_equal(r.running.flags, 0);
    assert_int_equal(qmc_session_ask(s, &b), 0);
    assert_true(b.count > 0 && b.count <= 256);
    double vals[256];
    char why[256];
    p.f->eval(p.f->ctx, b.points, b.count, b.dims, vals);
    vals[b.count - 1] = NAN;
    assert_int_equal(qmc_session_tell(s, b.seq, vals, b.count, why, sizeof why), 0);
    qmc_session_status(s, &r);
    assert_int_equal(r.evals, first + b.count);
    assert_int_equal(r.nonfinite, 1);
    assert_true(r.running.flags & QMC_FLAG_NONFINITE);
    /* and the integrator counted it too: the answer is flagged */
    outcome o = session_test_drive(s, p.f);
    assert_int_equal(o.err, 0);
    assert_int_equal(o.rep.res.nonfinite, 1);
    assert_true(o.rep.res.flags & QMC_FLAG_NONFINITE);
    assert_int_equal(o.status.end, QMC_SESSION_CANNOT_TELL);
    qmc_session_free(s);
    qmc_testfn_free(p.fn);
}

/* The fiber's stack: the deepest any method reaches stays well inside it
 * (printed for docs/SESSIONS.md). */
static void test_stack_depth(void **state)
{
    (void)state;
    size_t deepest = 0;
    for (size_t i = 0; i < sizeof eq_cases / sizeof eq_cases[0]; i++) {
        const eq_case *c = &eq_cases[i];
        problem p = session_test_make(c->integrand, c->dims, c->a, c->u);
        qmc_integrate_spec is;
        case_spec(c, &is);
        qmc_session_spec ss;
        session_test_spec(&ss, &is, p.f);
        qmc_session *s = NULL;
        char why[256];
        assert_int_equal(qmc__session_new(&ss, 1, &s, why, sizeof why), 0);
        session_test_drive(s, p.f);
        size_t used = qmc__session_stack_used(s);
        assert_true(used > 0);
        deepest = used > deepest ? used : deepest;
        qmc_session_free(s);
        qmc_testfn_free(p.fn);
    }
    print_message("deepest fiber stack: %zu of %u bytes\n", deepest, QMC__FIBER_STACK_BYTES);
    assert_true(deepest <= QMC__FIBER_STACK_BYTES / 2);
}

/* ---- parts ---------------------------------------------------------------------------- */

/* p part sessions of a fixed-n job hold the built-in parts' block sums and
 * fingerprint (what qmc integrate --part writes), and their merge is the
 * whole job. */
static void test_parts(void **state)
{
    (void)state;
    const struct { const char *method; uint64_t n; uint32_t reps; uint32_t p; } cases[] = {
        {"mc", 20000, 1, 3}, {"rqmc", 4096, 16, 5}, {"lhs", 9000, 2, 2}, {"qmc", 3, 1, 2},
    };
    problem p = session_test_make("genz-corner-peak", 3, NULL, NULL);
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        qmc_integrate_spec is;
        qmc_integrate_spec_init(&is);
        assert_int_equal(qmc_method_parse(cases[i].method, &is.method), 0);
        qmc_sampler sm;
        assert_int_equal(qmc_sampler_parse(cases[i].method, &sm), 0);
        qmc_sampling_spec_init(&is.sampling, sm);
        is.sampling.n = cases[i].n;
        is.sampling.reps = cases[i].reps;
        is.sampling.seed = 99;
        is.n_given = 1;
        outcome whole = session_test_via_integrate(&is, p.f);
        assert_int_equal(whole.err, 0);
        qmc_sampling_job *job = NULL;
        char why[256];
        assert_int_equal(qmc_sampling_job_new(&whole.rep.sampling, p.f, NULL, &job, why,
                                              sizeof why), 0);
        const uint64_t nb = qmc_sampling_blocks(job);
        qmc_sampling_sums *all = calloc(nb, sizeof *all), *mine = calloc(nb, sizeof *mine);
        size_t ws_bytes = qmc_sampling_workspace_bytes(job);
        void *ws = malloc(ws_bytes);
        assert_true(all && mine && ws);
        uint64_t covered = 0;
        for (uint32_t k = 1; k <= cases[i].p; k++) {
            qmc_session_spec ss;
            session_test_spec(&ss, &is, p.f);
            ss.part_k = k;
            ss.part_p = cases[i].p;
            qmc_session *s = NULL;
            assert_int_equal(qmc_session_new(&ss, &s, why, sizeof why), 0);
            outcome o = session_test_drive(s, p.f);
            assert_int_equal(o.err, 0);
            assert_int_equal(o.status.end, QMC_SESSION_COMPLETE);
            qmc_session_part_sums part;
            assert_int_equal(qmc_session_part(s, &part), 0);
            assert_int_equal(part.fingerprint, qmc_sampling_fingerprint(job));
            assert_int_equal(part.blocks, nb);
            assert_int_equal(part.first, nb * (k - 1) / cases[i].p);
            assert_int_equal(part.first + part.count, nb * k / cases[i].p);
            assert_int_equal(part.sampling.n, whole.rep.sampling.n);
            for (uint64_t b = 0; b < part.count; b++) {
                assert_int_equal(qmc_sampling_run_block(job, part.first + b, ws, ws_bytes,
                                                        &mine[part.first + b]), 0);
                assert_memory_equal(&mine[part.first + b], &part.sums[b], sizeof *all);
                all[part.first + b] = part.sums[b];
            }
            covered += part.count;
            qmc_session_free(s);
        }
        assert_int_equal(covered, nb);
        qmc_result merged;
        assert_int_equal(qmc_sampling_finish(job, all, nb, &merged, NULL), 0);
        assert_true(test_same_result(&merged, &whole.rep.res));
        /* not a part: refused */
        qmc_session_spec ss;
        qmc_session *s = session_test_open(&ss, &is, p.f, 0);
        qmc_session_part_sums part;
        assert_int_equal(qmc_session_part(s, &part), QMC_EINVAL);
        qmc_session_free(s);
        free(ws);
        free(all);
        free(mine);
        qmc_sampling_job_free(job);
    }
    qmc_testfn_free(p.fn);
}

/* ---- the memory bound's parts ----------------------------------------------------------- */

/* The bound grows with the batch and with the integrator's own bound; the
 * allocator-level check is in test_integrate_memory. */
static void test_memory_bound_terms(void **state)
{
    (void)state;
    qmc_session_spec ss;
    qmc_session_spec_init(&ss);
    ss.dims = 4;
    ss.integrate.method = QMC_METHOD_RQMC;
    qmc_sampling_spec_init(&ss.integrate.sampling, QMC_SAMPLER_RQMC);
    uint64_t base = qmc_session_memory_bytes(&ss);
    ss.max_batch = 2 * QMC_SESSION_MAX_BATCH;
    assert_true(qmc_session_memory_bytes(&ss) >=
                base + QMC_SESSION_MAX_BATCH * 5 * sizeof(double));
    ss.max_batch = 0;
    ss.integrate.method = QMC_METHOD_GAUSS_LEGENDRE;
    uint64_t rule = qmc_session_memory_bytes(&ss);
    assert_true(rule >= QMC__FIBER_STACK_BYTES);
    assert_true(rule < base); /* no batch buffer for a rule */
    ss.dims = QMC_SESSION_MAX_DIMS;
    ss.integrate.method = QMC_METHOD_AUTO;
    /* the default batch shrinks at high dimension */
    assert_true(qmc_session_memory_bytes(&ss) - qmc_integrate_memory_bytes(&ss.integrate,
                                                                           ss.dims) <=
                QMC_SESSION_BATCH_BYTES + (8u << 20));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_method_bit_for_bit),
        cmocka_unit_test(test_batch_sizes),
        cmocka_unit_test(test_running_estimate),
        cmocka_unit_test(test_running_lag),
        cmocka_unit_test(test_running_rule),
        cmocka_unit_test(test_stack_depth),
        cmocka_unit_test(test_parts),
        cmocka_unit_test(test_memory_bound_terms),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
