/*
 * test_tensor_check.c - the tensor rules' check of their own bar
 * (qmc_quad_tensor, core/quad_tensor.c): sibling levels whose nodes the
 * two nested levels never used, and a rounding probe.
 *
 * Oracles: closed forms (prod sin(a)/a for a product of cosines, (e - 1)^d
 * for exp), and the nested levels' own difference recomputed here from
 * qmc_rule1d_nodes, so that each test can show the bar the levels alone
 * would give and fail if the check did nothing.  Must not: depend on a
 * clock or on more than the public headers.
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "qmc/quad.h"

#define E_MINUS_1 1.71828182845904523536

typedef struct prod_fn {
    int exp;          /* 1: prod exp(x_j); 0: prod cos(a x_j) */
    double a;
    uint64_t *calls;  /* points evaluated */
} prod_fn;

static void prod_eval(const void *ctx, const double *x, size_t n, uint32_t dims, double *out)
{
    const prod_fn *c = ctx;
    for (size_t i = 0; i < n; i++) {
        double v = 1.0;
        for (uint32_t j = 0; j < dims; j++)
            v *= c->exp ? exp(x[i * dims + j]) : cos(c->a * x[i * dims + j]);
        out[i] = v;
    }
    *c->calls += n;
}

/* One qmc_quad_tensor run; *calls counts the evaluations it made. */
static qmc_result run(const prod_fn *c, uint32_t d, qmc_rule1d rule, uint32_t n,
                      uint64_t max_evals)
{
    qmc_integrand f;
    memset(&f, 0, sizeof f);
    f.eval = prod_eval;
    f.ctx = c;
    f.dims = d;
    f.name = "prod";
    size_t bytes = qmc_quad_tensor_rule_workspace_bytes(rule, n, d);
    void *ws = malloc(bytes);
    assert_non_null(ws);
    qmc_result r;
    char why[200];
    *c->calls = 0;
    int rc = qmc_quad_tensor(&f, rule, n, max_evals, NULL, ws, bytes, &r, why, sizeof why);
    free(ws);
    if (rc)
        fail_msg("%s", why);
    assert_int_equal(*c->calls, r.evals);
    return r;
}

/* The 1D rule's sum of g at m nodes, and the product rule's in d dims
 * (the integrand is a product, so the tensor sum is the d-th power). */
static double rule_pow(qmc_rule1d rule, uint32_t m, const prod_fn *c, uint32_t d)
{
    double *x = malloc(m * sizeof *x), *w = malloc(m * sizeof *w);
    assert_non_null(x);
    assert_non_null(w);
    assert_int_equal(qmc_rule1d_nodes(rule, m, x, w), 0);
    double s = 0.0;
    for (uint32_t i = 0; i < m; i++) {
        double xi = x[i] >= 1.0 ? nextafter(1.0, 0.0) : x[i];
        s += w[i] * (c->exp ? exp(xi) : cos(c->a * xi));
    }
    free(x);
    free(w);
    return pow(s, (double)d);
}

static double cos_truth(double a, uint32_t d)
{
    return pow(sin(a) / a, (double)d);
}

/* In-phase aliasing: cos(2 pi 16 x) is -1 at every one of midpoint's 16
 * nodes and +1 at every one of its 8, so in 2D both levels give exactly 1
 * and |fine - coarse| = 0 where the integral is 0.  The siblings at 9 and
 * 10 nodes see other phases. */
static void test_in_phase_aliasing(void **state)
{
    (void)state;
    uint64_t calls;
    const double a = 2.0 * 3.14159265358979323846 * 16.0;
    prod_fn c = {0, a, &calls};
    const double fine = rule_pow(QMC_RULE1D_MIDPOINT, 16, &c, 2);
    const double coarse = rule_pow(QMC_RULE1D_MIDPOINT, 8, &c, 2);
    assert_true(fabs(fine - 1.0) < 1e-12 && fabs(fine - coarse) < 1e-12); /* the trap */
    qmc_result r = run(&c, 2, QMC_RULE1D_MIDPOINT, 16, UINT64_MAX);
    const double truth = cos_truth(a, 2);
    assert_true(fabs(r.estimate - fine) < 1e-12); /* the estimate is the fine rule's */
    assert_true(fabs(r.estimate - truth) > 0.99);
    assert_true(fabs(r.estimate - truth) <= r.error); /* the bar now holds it */
    const double s9 = rule_pow(QMC_RULE1D_MIDPOINT, 9, &c, 2);
    const double s10 = rule_pow(QMC_RULE1D_MIDPOINT, 10, &c, 2);
    assert_true(fabs(r.error - fmax(fabs(s9 - fine), fabs(s10 - fine))) < 1e-12);
}

/* Simpson at 17 and 9 nodes on cos(100 x): 100/16 is 2 pi - 0.033 a
 * step, so both levels see a slow cosine near 1 and agree to 1e-7; the
 * integral is sin(100)/100 = -0.005. */
static void test_simpson_cos100(void **state)
{
    (void)state;
    uint64_t calls;
    prod_fn c = {0, 100.0, &calls};
    const double levels = fabs(rule_pow(QMC_RULE1D_SIMPSON, 17, &c, 1) -
                               rule_pow(QMC_RULE1D_SIMPSON, 9, &c, 1));
    const double truth = cos_truth(100.0, 1);
    assert_true(fabs(truth + 0.0050636564110975879) < 1e-15);
    qmc_result r = run(&c, 1, QMC_RULE1D_SIMPSON, 17, UINT64_MAX);
    assert_true(fabs(r.estimate - truth) > 0.9);
    assert_true(levels < 1e-6);                        /* would have been silent */
    assert_true(fabs(r.estimate - truth) <= 3 * r.error); /* honest now */
    assert_true(r.error > 0.1 * fabs(r.estimate));     /* and large enough to flag */
}

/* A resolved integrand: the siblings are nearer the truth than the coarse
 * level, so the bar is |fine - coarse| exactly, as before the check. */
static void test_resolved_bar_unchanged(void **state)
{
    (void)state;
    uint64_t calls;
    prod_fn c = {0, 2.0, &calls};
    const struct { qmc_rule1d rule; uint32_t n, nc; } cases[] = {
        {QMC_RULE1D_MIDPOINT, 40, 20}, {QMC_RULE1D_TRAPEZOID, 41, 21},
        {QMC_RULE1D_SIMPSON, 41, 21}, {QMC_RULE1D_GAUSS_LEGENDRE, 6, 3}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        qmc_result r = run(&c, 2, cases[i].rule, cases[i].n, UINT64_MAX);
        double fine = rule_pow(cases[i].rule, cases[i].n, &c, 2);
        double coarse = rule_pow(cases[i].rule, cases[i].nc, &c, 2);
        /* the powers here round differently from the tensor sums */
        if (fabs(r.error - fabs(fine - coarse)) > 1e-9 * fabs(fine - coarse) + 1e-16)
            fail_msg("%s: bar %.17g, levels %.17g", qmc_rule1d_name(cases[i].rule), r.error,
                     fabs(fine - coarse));
        assert_true(fabs(r.estimate - cos_truth(2.0, 2)) <= r.error);
        assert_int_equal(r.flags, 0);
    }
}

/* The check spends what qmc_quad_tensor_check_evals says, and only what
 * the budget leaves: none at exactly the levels' cost, one sibling when
 * only one fits. */
static void test_check_budget(void **state)
{
    (void)state;
    uint64_t calls;
    prod_fn c = {1, 0.0, &calls};
    /* Gauss-Legendre 12 in 2D: levels 144 + 36, siblings 7^2 and 8^2 */
    assert_int_equal(qmc_quad_tensor_check_evals(QMC_RULE1D_GAUSS_LEGENDRE, 12, 2),
                     49 + 64 + 32);
    qmc_result r = run(&c, 2, QMC_RULE1D_GAUSS_LEGENDRE, 12, UINT64_MAX);
    assert_int_equal(r.evals, 144 + 36 + 49 + 64 + 32);
    r = run(&c, 2, QMC_RULE1D_GAUSS_LEGENDRE, 12, 180);
    assert_int_equal(r.evals, 180);
    r = run(&c, 2, QMC_RULE1D_GAUSS_LEGENDRE, 12, 180 + 49 + 31);
    assert_int_equal(r.evals, 180 + 49); /* the second sibling and the probes do not fit */
    r = run(&c, 2, QMC_RULE1D_GAUSS_LEGENDRE, 12, 180 + 49 + 63);
    assert_int_equal(r.evals, 180 + 49 + 32); /* the second does not; the probes do */
    assert_true(fabs(r.estimate - E_MINUS_1 * E_MINUS_1) < 1e-14);
    /* Simpson's siblings are odd: 17 -> coarse 9 -> 11 and 13 */
    assert_int_equal(qmc_quad_tensor_check_evals(QMC_RULE1D_SIMPSON, 17, 1), 11 + 13 + 32);
    /* no room between the levels: midpoint 3 (coarse 1) has one sibling, 2 */
    assert_int_equal(qmc_quad_tensor_check_evals(QMC_RULE1D_MIDPOINT, 3, 3), 8 + 32);
    /* no coarse level, no check */
    assert_int_equal(qmc_quad_tensor_check_evals(QMC_RULE1D_MIDPOINT, 1, 3), 0);
    r = run(&c, 1, QMC_RULE1D_MIDPOINT, 1, UINT64_MAX);
    assert_int_equal(r.evals, 1);
}

/* Rounding the levels cannot see: trapezoid at 334 nodes on cos(27759 x)
 * (about 4418 periods: far past any grid, folded to a periodic sum near
 * 0) is off by 9e-14 of the integral of |f| because each value is off by
 * about eps a x; nested levels share those values at common nodes, so
 * |fine - coarse| was 21 times below the error.  The probe's floor covers
 * it and says roundoff; with no room for the check the bar is the levels'
 * and does not cover (the test can fail). */
static void test_rounding_floor(void **state)
{
    (void)state;
    uint64_t calls;
    const double a = 27759.112687119414;
    prod_fn c = {0, a, &calls};
    const double truth = cos_truth(a, 1);
    qmc_result bare = run(&c, 1, QMC_RULE1D_TRAPEZOID, 334, 334 + 167);
    assert_true(fabs(bare.estimate - truth) > 3 * bare.error);
    qmc_result r = run(&c, 1, QMC_RULE1D_TRAPEZOID, 334, UINT64_MAX);
    assert_true(r.flags & QMC_FLAG_ROUNDOFF);
    assert_false(r.flags & QMC_FLAG_ERROR_UNRELIABLE);
    assert_true(fabs(r.estimate - truth) <= 3 * r.error);
    assert_true(r.error < 1e-11 * r.abs_integral); /* a floor, not a shrug */
    /* abs_integral is the fine rule's sum of |w f|: about 2/pi here */
    assert_true(fabs(r.abs_integral - 2.0 / 3.14159265358979323846) < 0.05);
    /* smooth values: no roundoff, the bar is the levels' */
    prod_fn e = {1, 0.0, &calls};
    r = run(&e, 3, QMC_RULE1D_SIMPSON, 33, UINT64_MAX);
    assert_int_equal(r.flags, 0);
}

/* The same request gives the same bytes. */
static void test_deterministic(void **state)
{
    (void)state;
    uint64_t calls;
    prod_fn c = {0, 305.74607297166898, &calls};
    qmc_result r1 = run(&c, 1, QMC_RULE1D_SIMPSON, 17, UINT64_MAX);
    qmc_result r2 = run(&c, 1, QMC_RULE1D_SIMPSON, 17, UINT64_MAX);
    assert_memory_equal(&r1.estimate, &r2.estimate, sizeof(double));
    assert_memory_equal(&r1.error, &r2.error, sizeof(double));
    assert_int_equal(r1.evals, r2.evals);
    assert_int_equal(r1.flags, r2.flags);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_in_phase_aliasing),
        cmocka_unit_test(test_simpson_cos100),
        cmocka_unit_test(test_resolved_bar_unchanged),
        cmocka_unit_test(test_check_budget),
        cmocka_unit_test(test_rounding_floor),
        cmocka_unit_test(test_deterministic),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
