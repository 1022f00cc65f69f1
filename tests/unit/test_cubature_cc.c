/*
 * test_cubature_cc.c - unit tests for the p-adaptive tensor Clenshaw-Curtis
 * cubature of qmc/quad.h.
 *
 * The first grid (5 points an axis, exact to degree 5) integrates a
 * polynomial of degree <= 3 an axis to rounding and stops there, since the
 * rules one level lower (3 points, degree 3) agree; higher degrees refine
 * until exact.  A Gaussian converges at d = 2..4 with the true error
 * inside the reported one; a function of axis 0 alone raises only axis 0.
 * The budget, the workspace and rounding stop it with their flags; bad
 * arguments are refused before any evaluation.  An interrupt hook that
 * never fires changes no bit; one that fires stops the run at that call
 * (QMC_ECANCELED, no estimate, nothing evaluated after).
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "hook.h"
#include "qmc/quad.h"

enum { F_POLY, F_GAUSS, F_AXIS0, F_NAN };

typedef struct cc_fn {
    int kind;
    int power;        /* F_POLY: every axis x^power */
    double a;         /* F_GAUSS, F_AXIS0: width parameter */
    uint64_t evals;   /* counted by the integrand */
} cc_fn;

static void cc_eval(const void *ctx, const double *x, size_t n, uint32_t dims, double *out)
{
    cc_fn *c = (cc_fn *)(uintptr_t)ctx; /* the test owns it: counts evaluations */
    for (size_t i = 0; i < n; i++) {
        const double *p = x + i * dims;
        double v = 1.0, r2 = 0.0;
        for (uint32_t j = 0; j < dims; j++) {
            v *= pow(p[j], c->power);
            r2 += (p[j] - 0.5) * (p[j] - 0.5);
        }
        switch (c->kind) {
        case F_GAUSS:
            v = exp(-c->a * c->a * r2);
            break;
        case F_AXIS0:
            v = exp(-c->a * c->a * (p[0] - 0.3) * (p[0] - 0.3));
            break;
        case F_NAN:
            v = p[0] > 0.7 ? NAN : 1.0;
            break;
        default:
            break;
        }
        out[i] = v;
    }
    c->evals += n;
}

/* int_0^1 exp(-a^2 (x - c)^2) dx */
static double gauss_1d(double a, double c)
{
    return sqrt(3.14159265358979323846) / (2.0 * a) * (erf(a * (1.0 - c)) + erf(a * c));
}

typedef struct cc_run {
    int rc;
    qmc_result res;
    char why[200];
} cc_run;

static cc_run run_with(cc_fn *c, uint32_t dims, double tol_rel, uint64_t max_evals,
                       size_t bytes, qmc_interrupt hook)
{
    qmc_integrand f = {.eval = cc_eval, .ctx = c, .dims = dims, .name = "cc-test"};
    qmc_cubature_opts o = {.tol_abs = 0.0, .tol_rel = tol_rel, .max_evals = max_evals,
                           .interrupt = hook};
    cc_run r;
    memset(&r, 0, sizeof r);
    void *ws = malloc(bytes);
    assert_non_null(ws);
    r.rc = qmc_cubature_cc(&f, &o, ws, bytes, &r.res, r.why, sizeof r.why);
    free(ws);
    return r;
}

static cc_run run(cc_fn *c, uint32_t dims, double tol_rel, uint64_t max_evals)
{
    qmc_interrupt none = {NULL, NULL};
    c->evals = 0;
    return run_with(c, dims, tol_rel, max_evals,
                    qmc_cubature_cc_workspace_bytes(dims, max_evals), none);
}

static void test_polynomials(void **state)
{
    (void)state;
    cc_fn c = {F_POLY, 3, 0, 0};
    cc_run r = run(&c, 3, 1e-12, 1000000);
    assert_int_equal(r.rc, 0);
    assert_int_equal(r.res.evals, 125); /* 5^3: the lower rules agree */
    assert_int_equal(c.evals, 125);
    assert_true(fabs(r.res.estimate - 1.0 / 64) <= 1e-16);
    assert_int_equal(r.res.flags, 0);
    /* degree 7 an axis: the first grid's lower rules disagree, so axes
     * are raised until the rule one level lower is exact as well (17
     * points, whose lower rule of 9 is exact to degree 9) */
    c.power = 7;
    r = run(&c, 3, 1e-12, 1000000);
    assert_int_equal(r.rc, 0);
    assert_true(fabs(r.res.estimate - 1.0 / 512) <= 1e-16);
    assert_int_equal(r.res.n, 17 * 17 * 17);
    assert_true(r.res.error <= 1e-12 / 512 * 1.0001);
}

static void test_gaussian_converges(void **state)
{
    (void)state;
    for (uint32_t d = 2; d <= 4; d++) {
        cc_fn c = {F_GAUSS, 0, 5.0, 0};
        cc_run r = run(&c, d, 1e-10, 10000000);
        assert_int_equal(r.rc, 0);
        double exact = pow(gauss_1d(5.0, 0.5), d);
        double err = fabs(r.res.estimate - exact);
        print_message("d=%u: evals %llu, error %.3g, reported %.3g\n", d,
                      (unsigned long long)r.res.evals, err, r.res.error);
        assert_int_equal(r.res.flags, 0);
        assert_true(err <= r.res.error);
        assert_true(r.res.error <= 1e-10 * fabs(r.res.estimate));
        assert_true(r.res.error_kind == QMC_ERROR_ESTIMATE);
        assert_int_equal(r.res.evals, c.evals);
        assert_int_equal(r.res.n, r.res.evals); /* every point used once */
        assert_true(r.res.abs_integral > 0.0);
    }
    /* Only axis 0 varies: the other axes keep their first 5 points. */
    cc_fn c = {F_AXIS0, 0, 20.0, 0};
    cc_run r = run(&c, 3, 1e-12, 10000000);
    assert_int_equal(r.rc, 0);
    assert_true(fabs(r.res.estimate - gauss_1d(20.0, 0.3)) <= 1e-13);
    assert_int_equal(r.res.n % 25, 0);
    assert_true(r.res.n / 25 > 17);
}

static void test_stops_and_refusals(void **state)
{
    (void)state;
    cc_fn c = {F_GAUSS, 0, 30.0, 0};
    /* the budget: a narrow Gaussian needs more than 20000 points */
    cc_run r = run(&c, 3, 1e-13, 20000);
    assert_int_equal(r.rc, 0);
    assert_true(r.res.flags & QMC_FLAG_BUDGET);
    assert_true(r.res.flags & QMC_FLAG_NOT_CONVERGED);
    assert_true(r.res.evals <= 20000);
    /* the workspace: room for about 5000 points of a budget of 1e7 */
    qmc_interrupt none = {NULL, NULL};
    size_t small = qmc_cubature_cc_workspace_bytes(3, 5000);
    c.evals = 0;
    r = run_with(&c, 3, 1e-13, 10000000, small, none);
    assert_int_equal(r.rc, 0);
    assert_true(r.res.flags & QMC_FLAG_MEMORY_BOUND);
    assert_true(r.res.n <= 2 * 5000); /* the tables take a share as well */
    assert_true(isfinite(r.res.estimate));
    /* rounding: a tolerance below 16 eps cannot be met */
    c.a = 2.0;
    r = run(&c, 2, 1e-17, 10000000);
    assert_int_equal(r.rc, 0);
    assert_true(r.res.flags & QMC_FLAG_ROUNDOFF);
    assert_true(r.res.evals < 100000);
    /* non-finite values */
    c.kind = F_NAN;
    r = run(&c, 2, 1e-8, 100000);
    assert_int_equal(r.rc, 0);
    assert_true(r.res.flags & QMC_FLAG_NONFINITE);
    assert_true(r.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
    /* refusals, before any evaluation */
    c.kind = F_GAUSS;
    r = run(&c, 10, 1e-8, 50000); /* 3^10 = 59049 */
    assert_int_equal(r.rc, QMC_EBUDGET);
    assert_int_equal(c.evals, 0);
    assert_non_null(strstr(r.why, "59049"));
    r = run_with(&c, QMC_CC_MAX_DIMS + 1, 1e-8, 1000000, 1 << 20, none);
    assert_int_equal(r.rc, QMC_EDIMS);
    r = run(&c, 2, 0.0, 1000);
    assert_int_equal(r.rc, QMC_EINVAL);
    r = run_with(&c, 2, 1e-8, 1000000, 64, none);
    assert_int_equal(r.rc, QMC_EINVAL);
    assert_int_equal(c.evals, 0);
    assert_int_equal(qmc_cubature_cc_workspace_bytes(0, 100), 0);
}

static void test_interrupt(void **state)
{
    (void)state;
    const uint64_t chunk = 256;
    cc_fn c = {F_GAUSS, 0, 30.0, 0};
    const uint64_t budget = 2000000;
    const size_t bytes = qmc_cubature_cc_workspace_bytes(3, budget);
    qmc_interrupt none = {NULL, NULL};
    cc_run plain = run_with(&c, 3, 1e-14, budget, bytes, none);
    c.evals = 0; /* the hook measures gaps on this counter */
    assert_int_equal(plain.rc, 0);
    test_hook h;
    cc_run never = run_with(&c, 3, 1e-14, budget, bytes, test_hook_init(&h, 0, &c.evals));
    assert_int_equal(never.rc, 0);
    assert_true(test_same_result(&plain.res, &never.res));
    const uint64_t calls = h.calls;
    assert_true(calls >= 1 + plain.res.evals / (QMC_INTERRUPT_EVALS + chunk));
    assert_true(h.max_gap <= QMC_INTERRUPT_EVALS + chunk);
    const uint64_t ks[] = {1, 2, calls / 2, calls};
    for (int i = 0; i < 4; i++) {
        c.evals = 0;
        cc_run r = run_with(&c, 3, 1e-14, budget, bytes, test_hook_init(&h, ks[i], &c.evals));
        assert_int_equal(r.rc, QMC_ECANCELED);
        assert_int_equal(h.calls, ks[i]);
        assert_true(r.res.estimate == 0.0 && r.res.error == 0.0 && r.res.n == 0);
        assert_int_equal(c.evals, h.evals_at_fire);
        assert_non_null(strstr(r.why, "stopped by the interrupt hook"));
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_polynomials),
        cmocka_unit_test(test_gaussian_converges),
        cmocka_unit_test(test_stops_and_refusals),
        cmocka_unit_test(test_interrupt),
    };
    return cmocka_run_group_tests_name("cubature_cc", tests, NULL, NULL);
}
