/*
 * test_session_hostile.c - integration sessions against hostile values and
 * callers: NaN, Inf and 1e308 are counted and flagged as for a built-in
 * integrand (and the answer still equals qmc_integrate's); wrong counts,
 * tell without ask, stale and future batch numbers are refused with a
 * reason and the session goes on; open refuses what qmc_integrate
 * refuses; a session closed in the middle frees everything (the sanitized
 * build's leak check); a session moves between threads; the caller's own
 * interrupt hook still stops it; and each end reason is reached.
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
#include "session_drive.h"

#define SAME(x, y) (memcmp(&(x), &(y), sizeof(x)) == 0)

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


/* ---- hostile values and callers ----------------------------------------------- */

static void test_hostile_values(void **state)
{
    (void)state;
    problem p = session_test_make("genz-gaussian", 2, NULL, NULL);
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
        session_test_method(&is, cases[i].method);
        is.tol_rel = cases[i].tol;
        is.max_evals = 1000000;
        outcome want = session_test_via_integrate(&is, &f);
        qmc_session_spec ss;
        session_test_spec(&ss, &is, &f);
        outcome got = session_test_via_session(&ss, &f);
        char what[64];
        snprintf(what, sizeof what, "hostile case %zu (%s)", i, cases[i].method);
        session_test_assert_same(&got, &want, what);
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
    problem p = session_test_make("genz-gaussian", 3, NULL, NULL);
    qmc_integrate_spec is;
    session_test_method(&is, "rqmc");
    qmc_session_spec ss;
    qmc_session *s = session_test_open(&ss, &is, p.f, 4 * QMC_SAMPLING_BLOCK);
    char why[256];
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
    p.f->eval(p.f->ctx, b1.points, b1.count, b1.dims, vals);
    assert_int_equal(qmc_session_tell(s, b1.seq, vals, b1.count, why, sizeof why), 0);
    assert_int_equal(qmc_session_tell(s, b1.seq, vals, b1.count, why, sizeof why), QMC_EINVAL);
    assert_non_null(strstr(why, "answered already"));
    uint64_t told = 1;
    answer_buf buf = {vals, ss.max_batch + 1};
    qmc_session_batch b;
    while (session_test_answer(s, p.f, &b, &buf))
        told++;
    vals = buf.vals;
    assert_int_equal(told, 4);
    /* done: a tell is refused, ask keeps saying done */
    assert_int_equal(qmc_session_tell(s, told, vals, 1, why, sizeof why), QMC_EINVAL);
    assert_non_null(strstr(why, "done"));
    outcome o = session_test_outcome(s);
    outcome want = session_test_via_integrate(&is, p.f);
    session_test_assert_same(&o, &want, "after hostile calls");
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
            problem p = session_test_make(cases[i].fn, cases[i].dims, NULL, NULL);
            qmc_integrate_spec is;
            session_test_method(&is, qmc_method_name(cases[i].m));
            is.tol_rel = cases[i].tol;
            is.n_axis = 40;
            qmc_session_spec ss;
            qmc_session *s = session_test_open(&ss, &is, p.f, QMC_SAMPLING_BLOCK);
            answer_buf buf = {NULL, 0};
            qmc_session_batch b;
            for (uint64_t k = 0; k < stop; k++)
                if (!session_test_answer(s, p.f, &b, &buf))
                    break;
            free(buf.vals);
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
    problem p = session_test_make("genz-gaussian", 3, NULL, NULL);
    for (size_t i = 0; i < sizeof methods / sizeof methods[0]; i++) {
        qmc_integrate_spec is;
        session_test_method(&is, qmc_method_name(methods[i]));
        is.tol_rel = 1e-5;
        is.max_evals = 1000000;
        qmc_session_spec ss;
        qmc_session *s = session_test_open(&ss, &is, p.f, 2 * QMC_SAMPLING_BLOCK);
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
        outcome got = session_test_outcome(s);
        outcome want = session_test_via_integrate(&is, p.f);
        session_test_assert_same(&got, &want, qmc_method_name(methods[i]));
        qmc_session_free(s);
    }
    qmc_testfn_free(p.fn);
}

/* The caller's own interrupt hook still stops the integrator: the session
 * ends failed, with qmc_integrate's QMC_ECANCELED. */
static void test_own_hook(void **state)
{
    (void)state;
    problem p = session_test_make("genz-gaussian", 3, NULL, NULL);
    qmc_integrate_spec is;
    session_test_method(&is, "cubature");
    is.tol_rel = 1e-14;
    test_hook h;
    is.interrupt = test_hook_init(&h, 3, NULL);
    qmc_session_spec ss;
    qmc_session *s = session_test_open(&ss, &is, p.f, 0);
    outcome o = session_test_drive(s, p.f);
    assert_int_equal(o.err, QMC_ECANCELED);
    assert_int_equal(o.status.end, QMC_SESSION_FAILED);
    assert_int_equal(o.status.err, QMC_ECANCELED);
    assert_int_equal(o.status.has_estimate, 0);
    is.interrupt = test_hook_init(&h, 3, NULL);
    outcome want = session_test_via_integrate(&is, p.f);
    session_test_assert_same(&o, &want, "own hook");
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
        problem p = session_test_make(cases[i].fn, cases[i].fn[0] == 'e' ? 1 : 2, NULL, NULL);
        qmc_integrate_spec is;
        session_test_method(&is, cases[i].method);
        is.tol_rel = cases[i].tol;
        if (cases[i].budget)
            is.max_evals = cases[i].budget;
        qmc_session_spec ss;
        session_test_spec(&ss, &is, p.f);
        outcome o = session_test_via_session(&ss, p.f);
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
int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_hostile_values),
        cmocka_unit_test(test_hostile_caller),
        cmocka_unit_test(test_open_refusals),
        cmocka_unit_test(test_close_midway),
        cmocka_unit_test(test_threads),
        cmocka_unit_test(test_own_hook),
        cmocka_unit_test(test_end_reasons),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
