/*
 * test_session.c - integration sessions (qmc/session.h): the caller
 * evaluates f, the session keeps the rest.
 *
 * The oracle is qmc_integrate itself on the same built-in integrand: a
 * session whose caller answers every batch with f's values must return
 * the same report, bit for bit in every field, for every method - auto
 * over integrands that make it pick each branch - and for any batch size.
 * Besides: the running estimate of a fixed RQMC job after r replicates is
 * the whole job with r replicates (replicate r's points do not depend on
 * how many there are); hostile callers (NaN, Inf, 1e308, wrong counts,
 * tell without ask, stale and future batch numbers) are refused or
 * counted and flagged, and the session goes on; a session closed in the
 * middle frees everything (the sanitized build's leak check); a session
 * moves between threads; and a part of a fixed-n job has the block sums
 * and fingerprint of the built-in part, whose merge is the whole job.
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hook.h"
#include "session_impl.h"
#include "qmc/integrate.h"
#include "qmc/sampling.h"
#include "qmc/session.h"
#include "qmc/testfn.h"

/* ---- the integrands ------------------------------------------------------ */

typedef struct problem {
    qmc_testfn *fn;
    const qmc_integrand *f;
} problem;

static problem make(const char *name, uint32_t dims, const double *a, const double *u)
{
    problem p;
    char why[256];
    int err = qmc_testfn_new(name, dims, a, a ? dims : 0, u, u ? dims : 0, &p.fn, why,
                             sizeof why);
    if (err)
        fail_msg("%s: %s", name, why);
    p.f = qmc_testfn_integrand(p.fn);
    return p;
}

/* A built-in integrand with hostile values: NaN where x0 < 0.01, +Inf
 * where 0.01 <= x0 < 0.015 and 1e308 where 0.5 <= x0 < 0.5005 (enough to
 * overflow a sum) - a pure function of the point, so qmc_integrate and a
 * session see the same values. */
typedef struct hostile {
    const qmc_integrand *inner;
    int nan, inf, huge;
} hostile;

static void hostile_eval(const void *ctx, const double *x, size_t n, uint32_t dims, double *out)
{
    const hostile *h = ctx;
    h->inner->eval(h->inner->ctx, x, n, dims, out);
    for (size_t i = 0; i < n; i++) {
        double x0 = x[i * dims];
        if (h->nan && x0 < 0.01)
            out[i] = NAN;
        else if (h->inf && x0 >= 0.01 && x0 < 0.015)
            out[i] = INFINITY;
        else if (h->huge && x0 >= 0.5 && x0 < 0.5005)
            out[i] = 1e308;
    }
}

/* ---- running a session ----------------------------------------------------- */

static void spec_for(qmc_session_spec *ss, const qmc_integrate_spec *is, const qmc_integrand *f)
{
    qmc_session_spec_init(ss);
    ss->integrate = *is;
    ss->dims = f->dims;
    ss->smoothness = f->smoothness;
    ss->has_exact = f->has_exact;
    ss->exact = f->exact;
    if (f->name)
        snprintf(ss->name, sizeof ss->name, "%s", f->name);
}

typedef struct outcome {
    int err;
    qmc_integrate_report rep;
    char why[512];
    qmc_session_report status;
    uint64_t batches, largest;
} outcome;

/* Answers every batch with f until the session is done. */
static void drive(qmc_session *s, const qmc_integrand *f, outcome *o)
{
    double *vals = NULL;
    size_t cap = 0;
    o->batches = o->largest = 0;
    uint64_t seq0 = 0;
    for (;;) {
        qmc_session_batch b;
        assert_int_equal(qmc_session_ask(s, &b), 0);
        if (b.count == 0) {
            assert_int_not_equal(b.end, QMC_SESSION_RUNNING);
            break;
        }
        assert_int_equal(b.end, QMC_SESSION_RUNNING);
        if (o->batches == 0)
            seq0 = b.seq;
        assert_int_equal(b.seq, seq0 + o->batches); /* numbered in order */
        assert_int_equal(b.dims, f->dims);
        if (b.count > cap) {
            cap = b.count;
            vals = realloc(vals, cap * sizeof *vals);
            assert_non_null(vals);
        }
        f->eval(f->ctx, b.points, b.count, b.dims, vals);
        char why[256];
        int err = qmc_session_tell(s, b.seq, vals, b.count, why, sizeof why);
        if (err)
            fail_msg("tell: %s", why);
        o->batches++;
        o->largest = b.count > o->largest ? b.count : o->largest;
    }
    free(vals);
    o->err = qmc_session_result(s, &o->rep, o->why, sizeof o->why);
    qmc_session_status(s, &o->status);
    qmc_session_batch done;
    assert_int_equal(qmc_session_ask(s, &done), 0);
    assert_int_equal(done.end, o->status.end);
}

static outcome via_session(const qmc_session_spec *ss, const qmc_integrand *f)
{
    outcome o;
    memset(&o, 0, sizeof o);
    qmc_session *s = NULL;
    o.err = qmc_session_new(ss, &s, o.why, sizeof o.why);
    if (o.err)
        return o;
    drive(s, f, &o);
    qmc_session_free(s);
    return o;
}

static outcome via_integrate(const qmc_integrate_spec *is, const qmc_integrand *f)
{
    outcome o;
    memset(&o, 0, sizeof o);
    o.err = qmc_integrate(is, f, NULL, NULL, NULL, &o.rep, o.why, sizeof o.why);
    return o;
}

#define SAME(x, y) (memcmp(&(x), &(y), sizeof(x)) == 0)

/* Every field of the two reports, and the return value. */
static void assert_same(const outcome *a, const outcome *b, const char *what)
{
    if (a->err != b->err)
        fail_msg("%s: err %d vs %d (%s / %s)", what, a->err, b->err, a->why, b->why);
    if (!test_same_result(&a->rep.res, &b->rep.res))
        fail_msg("%s: results differ: %.17g +- %.17g (%llu evals, flags %x) vs %.17g +- %.17g "
                 "(%llu evals, flags %x)", what, a->rep.res.estimate, a->rep.res.error,
                 (unsigned long long)a->rep.res.evals, a->rep.res.flags, b->rep.res.estimate,
                 b->rep.res.error, (unsigned long long)b->rep.res.evals, b->rep.res.flags);
    assert_true(SAME(a->rep.cv, b->rep.cv));
    assert_int_equal(a->rep.method_used, b->rep.method_used);
    const qmc_sampling_spec *x = &a->rep.sampling, *y = &b->rep.sampling;
    assert_true(x->sampler == y->sampler && x->seq == y->seq && x->scramble == y->scramble &&
                x->seq_flags == y->seq_flags && x->seed == y->seed && x->n == y->n &&
                x->reps == y->reps && SAME(x->confidence, y->confidence) &&
                x->split_net == y->split_net);
    assert_string_equal(a->rep.detail, b->rep.detail);
    assert_string_equal(a->rep.auto_reason, b->rep.auto_reason);
    if (a->err)
        assert_string_equal(a->why, b->why);
}

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
} eq_case;

static const double peak1_a[] = {30000}, peak1_u[] = {0.37};

static const eq_case eq_cases[] = {
    /* sampling, fixed n (n not a multiple of the block: a short last block) */
    {"genz-gaussian", 3, NULL, NULL, "mc", 0, 0, 10000, 0, QMC_METHOD_MC},
    {"genz-gaussian", 3, NULL, NULL, "mc", 0, 0, 5000, 4, QMC_METHOD_MC},
    {"genz-continuous", 2, NULL, NULL, "stratified", 0, 0, 0, 0, QMC_METHOD_STRATIFIED},
    {"genz-continuous", 4, NULL, NULL, "lhs", 0, 0, 9000, 0, QMC_METHOD_LHS},
    {"genz-oscillatory", 5, NULL, NULL, "qmc", 0, 0, 8192, 0, QMC_METHOD_QMC},
    {"genz-product-peak", 4, NULL, NULL, "rqmc", 0, 0, 0, 0, QMC_METHOD_RQMC},
    {"genz-product-peak", 4, NULL, NULL, "rqmc", 0, 0, 3000, 8, QMC_METHOD_RQMC},
    /* sampling, adaptive */
    {"genz-gaussian", 6, NULL, NULL, "rqmc", 1e-5, 2000000, 1024, 0, QMC_METHOD_RQMC},
    {"genz-corner-peak", 3, NULL, NULL, "mc", 1e-3, 1000000, 0, 0, QMC_METHOD_MC},
    {"genz-continuous", 3, NULL, NULL, "stratified", 1e-3, 1000000, 0, 0, QMC_METHOD_STRATIFIED},
    {"genz-continuous", 3, NULL, NULL, "lhs", 1e-3, 500000, 0, 0, QMC_METHOD_LHS},
    /* tensor rules */
    {"genz-gaussian", 2, NULL, NULL, "midpoint", 0, 0, 0, 0, QMC_METHOD_MIDPOINT},
    {"genz-gaussian", 3, NULL, NULL, "trapezoid", 0, 0, 0, 0, QMC_METHOD_TRAPEZOID},
    {"genz-gaussian", 2, NULL, NULL, "simpson", 0, 0, 0, 0, QMC_METHOD_SIMPSON},
    {"genz-oscillatory", 3, NULL, NULL, "gauss-legendre", 0, 0, 0, 0, QMC_METHOD_GAUSS_LEGENDRE},
    /* adaptive rules */
    {"exp", 1, NULL, NULL, "gauss-kronrod", 1e-10, 0, 0, 0, QMC_METHOD_GAUSS_KRONROD},
    {"inv-sqrt", 1, NULL, NULL, "gauss-kronrod", 1e-8, 0, 0, 0, QMC_METHOD_GAUSS_KRONROD},
    {"genz-product-peak", 3, NULL, NULL, "cubature", 1e-6, 2000000, 0, 0, QMC_METHOD_CUBATURE},
    {"genz-oscillatory", 3, NULL, NULL, "clenshaw-curtis", 1e-9, 0, 0, 0,
     QMC_METHOD_CLENSHAW_CURTIS},
    /* auto, every branch */
    {"cos", 1, NULL, NULL, "auto", 0, 0, 0, 0, QMC_METHOD_GAUSS_KRONROD},
    {"genz-oscillatory", 2, NULL, NULL, "auto", 0, 10000, 0, 0, QMC_METHOD_CLENSHAW_CURTIS},
    {"genz-gaussian", 7, NULL, NULL, "auto", 1e-4, 1000000, 0, 0, QMC_METHOD_CUBATURE},
    {"genz-continuous", 3, NULL, NULL, "auto", 1e-4, 1000000, 0, 0, QMC_METHOD_CUBATURE},
    {"genz-discontinuous", 3, NULL, NULL, "auto", 1e-3, 1000000, 0, 0, QMC_METHOD_RQMC},
    /* rqmc over a VEGAS map (its pilot's batches come in the map's chunks) */
    {"genz-product-peak", 12, NULL, NULL, "auto", 1e-3, 2000000, 0, 0, QMC_METHOD_RQMC},
    {"genz-continuous", 6, NULL, NULL, "auto", 1e-3, 300000, 0, 0, QMC_METHOD_RQMC},
    /* a rule that saw nothing, then rqmc with the rest of the budget */
    {"genz-gaussian", 1, peak1_a, peak1_u, "auto", 0, 2000000, 0, 0, QMC_METHOD_RQMC},
    /* a small budget: auto's first round of 8 x 512 */
    {"genz-continuous", 8, NULL, NULL, "auto", 1e-2, 10000, 0, 0, QMC_METHOD_RQMC},
};

static void case_spec(const eq_case *c, qmc_integrate_spec *is)
{
    qmc_integrate_spec_init(is);
    assert_int_equal(qmc_method_parse(c->method, &is->method), 0);
    qmc_sampler sm;
    if (qmc_sampler_parse(c->method, &sm) == 0)
        qmc_sampling_spec_init(&is->sampling, sm);
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
        problem p = make(c->integrand, c->dims, c->a, c->u);
        qmc_integrate_spec is;
        case_spec(c, &is);
        outcome want = via_integrate(&is, p.f);
        if (want.err)
            fail_msg("case %zu (%s %s): qmc_integrate: %s", i, c->integrand, c->method, want.why);
        assert_int_equal(want.rep.method_used, c->expect);
        for (size_t k = 0; k < sizeof batches / sizeof batches[0]; k++) {
            qmc_session_spec ss;
            spec_for(&ss, &is, p.f);
            ss.max_batch = batches[k];
            outcome got = via_session(&ss, p.f);
            char what[128];
            snprintf(what, sizeof what, "case %zu (%s %s), batch %llu", i, c->integrand,
                     c->method, (unsigned long long)batches[k]);
            assert_same(&got, &want, what);
            /* the session's own account agrees with the integrator's */
            assert_int_equal(got.status.evals, want.rep.res.evals);
            assert_int_equal(got.status.has_estimate, 1);
            assert_true(test_same_result(&got.status.running, &want.rep.res));
            assert_int_not_equal(got.status.end, QMC_SESSION_RUNNING);
            assert_int_not_equal(got.status.end, QMC_SESSION_FAILED);
            if (batches[k])
                assert_true(got.largest <= (batches[k] > 256 ? batches[k] : 256) ||
                            c->expect == QMC_METHOD_RQMC /* the map's pilot chunks */);
        }
        qmc_testfn_free(p.fn);
    }
}

/* The batches a session hands out: whole blocks up to max_batch for a
 * fixed-n sampling job, the rule's own for quadrature. */
static void test_batch_sizes(void **state)
{
    (void)state;
    problem p = make("genz-gaussian", 2, NULL, NULL);
    qmc_integrate_spec is;
    qmc_integrate_spec_init(&is);
    is.method = QMC_METHOD_RQMC;
    qmc_sampling_spec_init(&is.sampling, QMC_SAMPLER_RQMC); /* 16 x 4096 */
    qmc_session_spec ss;
    spec_for(&ss, &is, p.f);
    outcome o = via_session(&ss, p.f);
    assert_int_equal(o.batches, 1); /* 16 blocks, 65536 points: one batch */
    assert_int_equal(o.largest, 16 * 4096);
    ss.max_batch = 3 * QMC_SAMPLING_BLOCK;
    o = via_session(&ss, p.f);
    assert_int_equal(o.batches, 6); /* 3+3+3+3+3+1 blocks */
    ss.max_batch = 100;
    o = via_session(&ss, p.f);
    assert_int_equal(o.batches, 16 * 16); /* the engine's 256-point chunks */
    qmc_testfn_free(p.fn);
    p = make("exp", 1, NULL, NULL);
    qmc_integrate_spec_init(&is);
    is.method = QMC_METHOD_GAUSS_KRONROD;
    spec_for(&ss, &is, p.f);
    o = via_session(&ss, p.f);
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
    problem p = make("genz-oscillatory", 4, NULL, NULL);
    qmc_integrate_spec is;
    qmc_integrate_spec_init(&is);
    is.method = QMC_METHOD_RQMC;
    qmc_sampling_spec_init(&is.sampling, QMC_SAMPLER_RQMC);
    is.sampling.reps = 12;
    qmc_session_spec ss;
    spec_for(&ss, &is, p.f);
    ss.max_batch = QMC_SAMPLING_BLOCK; /* one replicate a batch */
    qmc_session *s = NULL;
    char why[256];
    assert_int_equal(qmc_session_new(&ss, &s, why, sizeof why), 0);
    qmc_session_report r;
    qmc_session_status(s, &r);
    assert_int_equal(r.end, QMC_SESSION_RUNNING);
    assert_int_equal(r.has_estimate, 0);
    double vals[QMC_SAMPLING_BLOCK];
    for (uint32_t rep = 1; rep <= 12; rep++) {
        qmc_session_batch b;
        assert_int_equal(qmc_session_ask(s, &b), 0);
        assert_int_equal(b.count, QMC_SAMPLING_BLOCK);
        p.f->eval(p.f->ctx, b.points, b.count, b.dims, vals);
        assert_int_equal(qmc_session_tell(s, b.seq, vals, b.count, why, sizeof why), 0);
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
        outcome want = via_integrate(&fewer, p.f);
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
    qmc_session_free(s);
    qmc_testfn_free(p.fn);
}

/* A rule has no estimate before its end; its report still counts values
 * and raises nonfinite at once. */
static void test_running_rule(void **state)
{
    (void)state;
    problem p = make("genz-gaussian", 3, NULL, NULL);
    qmc_integrate_spec is;
    qmc_integrate_spec_init(&is);
    is.method = QMC_METHOD_CUBATURE;
    qmc_session_spec ss;
    spec_for(&ss, &is, p.f);
    qmc_session *s = NULL;
    char why[256];
    assert_int_equal(qmc_session_new(&ss, &s, why, sizeof why), 0);
    qmc_session_batch b;
    assert_int_equal(qmc_session_ask(s, &b), 0);
    assert_true(b.count > 0 && b.count <= 256);
    double vals[256];
    p.f->eval(p.f->ctx, b.points, b.count, b.dims, vals);
    assert_int_equal(qmc_session_tell(s, b.seq, vals, b.count, why, sizeof why), 0);
    qmc_session_report r;
    qmc_session_status(s, &r);
    assert_int_equal(r.end, QMC_SESSION_RUNNING);
    assert_int_equal(r.has_estimate, 0);
    assert_int_equal(r.evals, b.count);
    assert_int_equal(r.nonfinite, 0);
    assert_int_equal(r.running.flags, 0);
    const size_t first = b.count;
    assert_int_equal(qmc_session_ask(s, &b), 0);
    assert_true(b.count > 0 && b.count <= 256);
    p.f->eval(p.f->ctx, b.points, b.count, b.dims, vals);
    vals[b.count - 1] = NAN;
    assert_int_equal(qmc_session_tell(s, b.seq, vals, b.count, why, sizeof why), 0);
    qmc_session_status(s, &r);
    assert_int_equal(r.evals, first + b.count);
    assert_int_equal(r.nonfinite, 1);
    assert_true(r.running.flags & QMC_FLAG_NONFINITE);
    /* and the integrator counted it too: the answer is flagged */
    outcome o;
    memset(&o, 0, sizeof o);
    drive(s, p.f, &o);
    assert_int_equal(o.err, 0);
    assert_int_equal(o.rep.res.nonfinite, 1);
    assert_true(o.rep.res.flags & QMC_FLAG_NONFINITE);
    assert_int_equal(o.status.end, QMC_SESSION_CANNOT_TELL);
    qmc_session_free(s);
    qmc_testfn_free(p.fn);
}

/* ---- hostile values and callers ----------------------------------------------- */

static void test_hostile_values(void **state)
{
    (void)state;
    problem p = make("genz-gaussian", 2, NULL, NULL);
    const struct { int nan, inf, huge; const char *method; double tol; } cases[] = {
        {1, 0, 0, "mc", 0},     {0, 1, 0, "rqmc", 0},       {0, 0, 1, "mc", 0},
        {1, 1, 0, "rqmc", 1e-3}, {1, 0, 0, "cubature", 0},  {1, 0, 0, "clenshaw-curtis", 0},
        {1, 0, 0, "trapezoid", 0}, {1, 0, 0, "auto", 1e-3}, {0, 1, 1, "auto", 1e-3},
    };
    int seen = 0;
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        hostile h = {p.f, cases[i].nan, cases[i].inf, cases[i].huge};
        qmc_integrand f = *p.f;
        f.eval = hostile_eval;
        f.ctx = &h;
        qmc_integrate_spec is;
        qmc_integrate_spec_init(&is);
        assert_int_equal(qmc_method_parse(cases[i].method, &is.method), 0);
        qmc_sampler sm;
        if (qmc_sampler_parse(cases[i].method, &sm) == 0)
            qmc_sampling_spec_init(&is.sampling, sm);
        is.tol_rel = cases[i].tol;
        is.max_evals = 1000000;
        outcome want = via_integrate(&is, &f);
        qmc_session_spec ss;
        spec_for(&ss, &is, &f);
        outcome got = via_session(&ss, &f);
        char what[64];
        snprintf(what, sizeof what, "hostile case %zu (%s)", i, cases[i].method);
        assert_same(&got, &want, what);
        /* never absorbed: counted and flagged, the bar not trusted (when
         * the method's points met them: a rule's nodes may miss the strip) */
        if (got.status.nonfinite > 0) {
            seen++;
            if (!(want.rep.res.flags & QMC_FLAG_NONFINITE))
                fail_msg("%s: flags %x", what, want.rep.res.flags);
            assert_int_equal(got.status.end, QMC_SESSION_CANNOT_TELL);
            assert_int_equal(got.status.nonfinite, want.rep.res.nonfinite);
        }
        /* 1e308 a value: finite, but its sum overflows in a sampling run */
        if (cases[i].huge && strcmp(cases[i].method, "mc") == 0)
            assert_true(want.rep.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
    }
    assert_true(seen >= 7);
    qmc_testfn_free(p.fn);
}

static void test_hostile_caller(void **state)
{
    (void)state;
    problem p = make("genz-gaussian", 3, NULL, NULL);
    qmc_integrate_spec is;
    qmc_integrate_spec_init(&is);
    is.method = QMC_METHOD_RQMC;
    qmc_sampling_spec_init(&is.sampling, QMC_SAMPLER_RQMC);
    qmc_session_spec ss;
    spec_for(&ss, &is, p.f);
    ss.max_batch = 4 * QMC_SAMPLING_BLOCK;
    qmc_session *s = NULL;
    char why[256];
    assert_int_equal(qmc_session_new(&ss, &s, why, sizeof why), 0);
    double *vals = calloc(ss.max_batch + 1, sizeof *vals);
    assert_non_null(vals);
    /* tell before any ask */
    assert_int_equal(qmc_session_tell(s, 0, vals, ss.max_batch, why, sizeof why), QMC_EINVAL);
    assert_non_null(strstr(why, "ask for it first"));
    /* ask twice: the same batch, the same points */
    qmc_session_batch b1, b2;
    assert_int_equal(qmc_session_ask(s, &b1), 0);
    double first = b1.points[5];
    assert_int_equal(qmc_session_ask(s, &b2), 0);
    assert_int_equal(b1.seq, b2.seq);
    assert_int_equal(b1.count, b2.count);
    assert_ptr_equal(b1.points, b2.points);
    assert_true(SAME(first, b2.points[5]));
    /* wrong counts, a future batch, no values: refused, nothing moves */
    assert_int_equal(qmc_session_tell(s, b1.seq, vals, b1.count - 1, why, sizeof why),
                     QMC_EINVAL);
    assert_non_null(strstr(why, "points; got"));
    assert_int_equal(qmc_session_tell(s, b1.seq, vals, b1.count + 1, why, sizeof why),
                     QMC_EINVAL);
    assert_int_equal(qmc_session_tell(s, b1.seq + 1, vals, b1.count, why, sizeof why),
                     QMC_EINVAL);
    assert_non_null(strstr(why, "not been handed out yet"));
    assert_int_equal(qmc_session_tell(s, b1.seq, NULL, b1.count, why, sizeof why), QMC_EINVAL);
    qmc_session_report r;
    qmc_session_status(s, &r);
    assert_int_equal(r.evals, 0);
    assert_int_equal(r.batches, 0);
    assert_int_equal(qmc_session_ask(s, &b2), 0);
    assert_int_equal(b2.seq, b1.seq);
    assert_int_equal(qmc_session_result(s, &(qmc_integrate_report){0}, why, sizeof why),
                     QMC_EAGAIN);
    /* now answer properly, with a stale retry of batch 0 in between */
    outcome o;
    memset(&o, 0, sizeof o);
    p.f->eval(p.f->ctx, b1.points, b1.count, b1.dims, vals);
    assert_int_equal(qmc_session_tell(s, b1.seq, vals, b1.count, why, sizeof why), 0);
    assert_int_equal(qmc_session_tell(s, b1.seq, vals, b1.count, why, sizeof why), QMC_EINVAL);
    assert_non_null(strstr(why, "answered already"));
    uint64_t told = 1;
    for (;;) {
        qmc_session_batch b;
        assert_int_equal(qmc_session_ask(s, &b), 0);
        if (!b.count)
            break;
        p.f->eval(p.f->ctx, b.points, b.count, b.dims, vals);
        assert_int_equal(qmc_session_tell(s, b.seq, vals, b.count, why, sizeof why), 0);
        told++;
    }
    assert_int_equal(told, 4);
    /* done: a tell is refused, ask keeps saying done */
    assert_int_equal(qmc_session_tell(s, told, vals, 1, why, sizeof why), QMC_EINVAL);
    assert_non_null(strstr(why, "done"));
    o.err = qmc_session_result(s, &o.rep, o.why, sizeof o.why);
    outcome want = via_integrate(&is, p.f);
    assert_same(&o, &want, "after hostile calls");
    free(vals);
    qmc_session_free(s);
    qmc_testfn_free(p.fn);
}

/* ---- open refuses what qmc_integrate refuses ------------------------------------- */

static void test_open_refusals(void **state)
{
    (void)state;
    qmc_session_spec ss;
    qmc_session *s = (qmc_session *)&ss; /* must come back NULL */
    char why[256];
    qmc_session_spec_init(&ss);
    assert_int_equal(qmc_session_new(&ss, &s, why, sizeof why), QMC_EINVAL); /* dims 0 */
    assert_null(s);
    assert_non_null(strstr(why, "dims"));
    ss.dims = QMC_SESSION_MAX_DIMS + 1;
    assert_int_equal(qmc_session_new(&ss, &s, why, sizeof why), QMC_EDIMS);
    ss.dims = 2;
    ss.integrate.method = QMC_METHOD_GAUSS_KRONROD; /* 1D only: its own reason */
    assert_int_equal(qmc_session_new(&ss, &s, why, sizeof why), QMC_EDIMS);
    assert_non_null(strstr(why, "gauss-kronrod integrates in 1D"));
    ss.integrate.method = QMC_METHOD_MC;
    ss.integrate.max_evals = 100; /* 4096 points */
    assert_int_equal(qmc_session_new(&ss, &s, why, sizeof why), QMC_EBUDGET);
    ss.integrate.max_evals = 100000000;
    ss.part_k = 1; /* without p */
    assert_int_equal(qmc_session_new(&ss, &s, why, sizeof why), QMC_EINVAL);
    ss.part_p = 2;
    ss.integrate.tol_rel = 1e-3; /* a part needs a fixed n */
    assert_int_equal(qmc_session_new(&ss, &s, why, sizeof why), QMC_EINVAL);
    assert_non_null(strstr(why, "fixed n"));
    ss.part_k = ss.part_p = 0;
    ss.integrate.tol_rel = 0;
    memset(ss.name, 'x', sizeof ss.name);
    assert_int_equal(qmc_session_new(&ss, &s, why, sizeof why), QMC_EINVAL);
    ss.name[0] = '\0';
    ss.smoothness = (qmc_smoothness)7;
    assert_int_equal(qmc_session_new(&ss, &s, why, sizeof why), QMC_EINVAL);
    assert_null(s);
    qmc_session_free(NULL);
}

/* ---- closing, threads, the caller's own hook ---------------------------------------- */

/* Closing after a few batches, for the runner's batches, a rule's direct
 * ones and auto's pilot: no leak (the sanitized build checks), no hang. */
static void test_close_midway(void **state)
{
    (void)state;
    const struct { const char *fn; uint32_t dims; qmc_method m; double tol; } cases[] = {
        {"genz-gaussian", 3, QMC_METHOD_RQMC, 0},
        {"genz-gaussian", 3, QMC_METHOD_RQMC, 1e-9},
        {"genz-gaussian", 3, QMC_METHOD_CUBATURE, 1e-12},
        {"genz-gaussian", 3, QMC_METHOD_CLENSHAW_CURTIS, 1e-14},
        {"genz-gaussian", 4, QMC_METHOD_GAUSS_LEGENDRE, 0},
        {"cos", 1, QMC_METHOD_GAUSS_KRONROD, 1e-14},
        {"genz-product-peak", 12, QMC_METHOD_AUTO, 1e-6},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        for (uint64_t stop = 0; stop < 3; stop++) {
            problem p = make(cases[i].fn, cases[i].dims, NULL, NULL);
            qmc_integrate_spec is;
            qmc_integrate_spec_init(&is);
            is.method = cases[i].m;
            is.tol_rel = cases[i].tol;
            is.n_axis = 40;
            if (is.method == QMC_METHOD_RQMC)
                qmc_sampling_spec_init(&is.sampling, QMC_SAMPLER_RQMC);
            qmc_session_spec ss;
            spec_for(&ss, &is, p.f);
            ss.max_batch = QMC_SAMPLING_BLOCK;
            qmc_session *s = NULL;
            char why[256];
            assert_int_equal(qmc_session_new(&ss, &s, why, sizeof why), 0);
            double *vals = NULL;
            for (uint64_t k = 0; k < stop; k++) {
                qmc_session_batch b;
                assert_int_equal(qmc_session_ask(s, &b), 0);
                if (b.count == 0)
                    break;
                vals = realloc(vals, b.count * sizeof *vals);
                p.f->eval(p.f->ctx, b.points, b.count, b.dims, vals);
                assert_int_equal(qmc_session_tell(s, b.seq, vals, b.count, why, sizeof why), 0);
            }
            free(vals);
            qmc_session_free(s);
            qmc_testfn_free(p.fn);
        }
    }
}

typedef struct thread_job {
    qmc_session *s;
    const qmc_integrand *f;
    int rc;
} thread_job;

/* Answers one batch, on its own thread. */
static void *answer_one(void *arg)
{
    thread_job *t = arg;
    qmc_session_batch b;
    t->rc = qmc_session_ask(t->s, &b);
    if (t->rc || b.count == 0)
        return NULL;
    double *vals = malloc(b.count * sizeof *vals);
    t->f->eval(t->f->ctx, b.points, b.count, b.dims, vals);
    char why[256];
    t->rc = qmc_session_tell(t->s, b.seq, vals, b.count, why, sizeof why);
    free(vals);
    return NULL;
}

/* Each batch answered by a new thread: the fiber resumes on whichever
 * thread tells, and the result is unchanged. */
static void test_threads(void **state)
{
    (void)state;
    const qmc_method methods[] = {QMC_METHOD_AUTO, QMC_METHOD_CUBATURE, QMC_METHOD_RQMC};
    problem p = make("genz-gaussian", 3, NULL, NULL);
    for (size_t i = 0; i < sizeof methods / sizeof methods[0]; i++) {
        qmc_integrate_spec is;
        qmc_integrate_spec_init(&is);
        is.method = methods[i];
        is.tol_rel = 1e-5;
        is.max_evals = 1000000;
        if (is.method == QMC_METHOD_RQMC)
            qmc_sampling_spec_init(&is.sampling, QMC_SAMPLER_RQMC);
        qmc_session_spec ss;
        spec_for(&ss, &is, p.f);
        ss.max_batch = 2 * QMC_SAMPLING_BLOCK;
        qmc_session *s = NULL;
        char why[256];
        assert_int_equal(qmc_session_new(&ss, &s, why, sizeof why), 0);
        int threads = 0;
        for (;;) {
            qmc_session_report r;
            qmc_session_status(s, &r);
            if (r.end != QMC_SESSION_RUNNING)
                break;
            thread_job t = {s, p.f, 0};
            pthread_t th;
            assert_int_equal(pthread_create(&th, NULL, answer_one, &t), 0);
            assert_int_equal(pthread_join(th, NULL), 0);
            assert_int_equal(t.rc, 0);
            threads++;
        }
        assert_true(threads > 1);
        outcome got;
        memset(&got, 0, sizeof got);
        got.err = qmc_session_result(s, &got.rep, got.why, sizeof got.why);
        outcome want = via_integrate(&is, p.f);
        assert_same(&got, &want, qmc_method_name(methods[i]));
        qmc_session_free(s);
    }
    qmc_testfn_free(p.fn);
}

/* The caller's own interrupt hook still stops the integrator: the session
 * ends failed, with qmc_integrate's QMC_ECANCELED. */
static void test_own_hook(void **state)
{
    (void)state;
    problem p = make("genz-gaussian", 3, NULL, NULL);
    qmc_integrate_spec is;
    qmc_integrate_spec_init(&is);
    is.method = QMC_METHOD_CUBATURE;
    is.tol_rel = 1e-14;
    test_hook h;
    is.interrupt = test_hook_init(&h, 3, NULL);
    qmc_session_spec ss;
    spec_for(&ss, &is, p.f);
    qmc_session *s = NULL;
    char why[256];
    assert_int_equal(qmc_session_new(&ss, &s, why, sizeof why), 0);
    outcome o;
    memset(&o, 0, sizeof o);
    drive(s, p.f, &o);
    assert_int_equal(o.err, QMC_ECANCELED);
    assert_int_equal(o.status.end, QMC_SESSION_FAILED);
    assert_int_equal(o.status.err, QMC_ECANCELED);
    assert_int_equal(o.status.has_estimate, 0);
    is.interrupt = test_hook_init(&h, 3, NULL);
    outcome want = via_integrate(&is, p.f);
    assert_same(&o, &want, "own hook");
    qmc_session_free(s);
    qmc_testfn_free(p.fn);
}

/* Why a session ended, for each reason but failed (above). */
static void test_end_reasons(void **state)
{
    (void)state;
    const struct { const char *fn; const char *method; double tol; uint64_t budget;
                   qmc_session_end end; } cases[] = {
        {"exp", "gauss-kronrod", 1e-10, 0, QMC_SESSION_CONVERGED},
        {"genz-gaussian", "rqmc", 1e-3, 0, QMC_SESSION_CONVERGED},
        {"genz-gaussian", "mc", 0, 0, QMC_SESSION_COMPLETE},
        {"genz-gaussian", "trapezoid", 0, 0, QMC_SESSION_COMPLETE},
        {"genz-gaussian", "rqmc", 1e-12, 200000, QMC_SESSION_BUDGET},
        {"genz-discontinuous", "cubature", 1e-6, 0, QMC_SESSION_CANNOT_TELL},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        problem p = make(cases[i].fn, cases[i].fn[0] == 'e' ? 1 : 2, NULL, NULL);
        qmc_integrate_spec is;
        qmc_integrate_spec_init(&is);
        assert_int_equal(qmc_method_parse(cases[i].method, &is.method), 0);
        qmc_sampler sm;
        if (qmc_sampler_parse(cases[i].method, &sm) == 0)
            qmc_sampling_spec_init(&is.sampling, sm);
        is.tol_rel = cases[i].tol;
        if (cases[i].budget)
            is.max_evals = cases[i].budget;
        qmc_session_spec ss;
        spec_for(&ss, &is, p.f);
        outcome o = via_session(&ss, p.f);
        assert_int_equal(o.err, 0);
        if (o.status.end != cases[i].end)
            fail_msg("case %zu: ended %s (flags %x), want %s", i,
                     qmc_session_end_key(o.status.end), o.rep.res.flags,
                     qmc_session_end_key(cases[i].end));
        assert_true(qmc_session_end_text(o.status.end)[0] != '\0');
        qmc_testfn_free(p.fn);
    }
    assert_string_equal(qmc_session_end_key((qmc_session_end)99), "");
}

/* The fiber's stack: the deepest any method reaches stays well inside it
 * (printed for docs/SESSIONS.md). */
static void test_stack_depth(void **state)
{
    (void)state;
    size_t deepest = 0;
    for (size_t i = 0; i < sizeof eq_cases / sizeof eq_cases[0]; i++) {
        const eq_case *c = &eq_cases[i];
        problem p = make(c->integrand, c->dims, c->a, c->u);
        qmc_integrate_spec is;
        case_spec(c, &is);
        qmc_session_spec ss;
        spec_for(&ss, &is, p.f);
        qmc_session *s = NULL;
        char why[256];
        assert_int_equal(qmc__session_new(&ss, 1, &s, why, sizeof why), 0);
        outcome o;
        memset(&o, 0, sizeof o);
        drive(s, p.f, &o);
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
    problem p = make("genz-corner-peak", 3, NULL, NULL);
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
        outcome whole = via_integrate(&is, p.f);
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
            spec_for(&ss, &is, p.f);
            ss.part_k = k;
            ss.part_p = cases[i].p;
            qmc_session *s = NULL;
            assert_int_equal(qmc_session_new(&ss, &s, why, sizeof why), 0);
            outcome o;
            memset(&o, 0, sizeof o);
            drive(s, p.f, &o);
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
        spec_for(&ss, &is, p.f);
        qmc_session *s = NULL;
        assert_int_equal(qmc_session_new(&ss, &s, why, sizeof why), 0);
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
        cmocka_unit_test(test_running_rule),
        cmocka_unit_test(test_hostile_values),
        cmocka_unit_test(test_hostile_caller),
        cmocka_unit_test(test_open_refusals),
        cmocka_unit_test(test_close_midway),
        cmocka_unit_test(test_threads),
        cmocka_unit_test(test_own_hook),
        cmocka_unit_test(test_end_reasons),
        cmocka_unit_test(test_stack_depth),
        cmocka_unit_test(test_parts),
        cmocka_unit_test(test_memory_bound_terms),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
