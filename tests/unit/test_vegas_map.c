/*
 * test_vegas_map.c - the VEGAS map in front of auto's RQMC
 * (core/vegas_map.c, core/integrate.c).
 *
 * The map must be a bijection of [0,1) per axis whose Jacobian is exact
 * (so f J integrates to the integral of f: checked by 1D Gauss-Kronrod to
 * 1e-12), with positive density everywhere and the density high where a
 * corner peak is; training is deterministic, refuses what it cannot do,
 * stops for the interrupt hook and drops the map on non-finite values.
 * auto must take the map where the pilot shows a large gain (a kinked peak
 * at d = 20), not where it does not (oscillatory) or where jumps make its
 * weights heavy-tailed (discontinuous), count the pilot in its
 * evaluations, and keep its 95% intervals honest over 200 seeds.
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <string.h>

#include "qmc/integrate.h"
#include "qmc/quad.h"
#include "qmc/testfn.h"
#include "vegas_map.h"

static qmc_testfn *genz(const char *family, uint32_t dims, uint64_t seed)
{
    double a[64], u[64];
    qmc_genz_family fam;
    assert_true(dims <= 64);
    assert_int_equal(qmc_genz_family_parse(family, &fam), 0);
    assert_int_equal(qmc_genz_draw(fam, dims, QMC_DIFFICULTY_FIXED, seed, a, u), 0);
    qmc_testfn *fn = NULL;
    char why[200];
    if (qmc_testfn_new(family, dims, a, dims, u, dims, &fn, why, sizeof why) != 0)
        fail_msg("%s", why);
    return fn;
}

static qmc__vmap *train(const qmc_integrand *f, uint64_t evals, uint64_t seed,
                        qmc__vmap_report *rep)
{
    qmc__vmap *m = NULL;
    assert_int_equal(qmc__vmap_train(f, evals, seed, NULL, &m, rep), 0);
    assert_non_null(m);
    return m;
}

/* Edges increase strictly from 0 to 1, and the peak at the origin pulls
 * the first bins narrower than the last. */
static void test_edges(void **state)
{
    (void)state;
    qmc_testfn *fn = genz("genz-corner-peak", 6, 3);
    qmc__vmap_report rep;
    qmc__vmap *m = train(qmc_testfn_integrand(fn), 60000, 1, &rep);
    assert_int_equal(rep.evals, 60000 / rep.rounds * rep.rounds);
    assert_true(rep.bins >= 16);
    for (uint32_t a = 0; a < 6; a++) {
        const double *e = qmc__vmap_edges(m, a);
        assert_true(e[0] == 0.0 && e[rep.bins] == 1.0);
        for (uint32_t k = 0; k < rep.bins; k++)
            assert_true(e[k + 1] > e[k]);
        assert_true(e[1] - e[0] < e[rep.bins] - e[rep.bins - 1]);
    }
    assert_true(rep.var_mapped < rep.var_plain);
    qmc__vmap_free(m);
    qmc_testfn_free(fn);
}

/* In 1D the mapped integrand f(x(u)) x'(u) integrates exactly to int f:
 * the Jacobian is right, bin by bin.  Each bin of u is smooth inside (x is
 * linear there), so 20-point Gauss-Legendre per bin is exact to rounding. */
static void test_jacobian_exact_in_1d(void **state)
{
    (void)state;
    qmc_testfn *fn = genz("genz-gaussian", 1, 5);
    const qmc_integrand *f = qmc_testfn_integrand(fn);
    qmc__vmap_report rep;
    qmc__vmap *m = train(f, 20000, 2, &rep);
    const qmc_integrand *g = qmc__vmap_integrand(m);
    double x[20], w[20], u[20], y[20], sum = 0;
    assert_int_equal(qmc_gauss_legendre(20, x, w), 0);
    for (uint32_t k = 0; k < rep.bins; k++) {
        double lo = (double)k / rep.bins, h = 1.0 / rep.bins;
        for (int i = 0; i < 20; i++)
            u[i] = lo + h * x[i];
        g->eval(g->ctx, u, 20, 1, y);
        for (int i = 0; i < 20; i++)
            sum += h * w[i] * y[i];
    }
    assert_true(fabs(sum - f->exact) <= 1e-13 * fabs(f->exact));
    qmc__vmap_free(m);
    qmc_testfn_free(fn);
}

static void test_deterministic(void **state)
{
    (void)state;
    qmc_testfn *fn = genz("genz-continuous", 8, 1);
    const qmc_integrand *f = qmc_testfn_integrand(fn);
    qmc__vmap_report r1, r2, r3;
    qmc__vmap *a = train(f, 50000, 9, &r1), *b = train(f, 50000, 9, &r2),
              *c = train(f, 50000, 10, &r3);
    size_t bytes = (r1.bins + 1) * sizeof(double);
    for (uint32_t k = 0; k < 8; k++)
        assert_memory_equal(qmc__vmap_edges(a, k), qmc__vmap_edges(b, k), bytes);
    assert_true(memcmp(qmc__vmap_edges(a, 0), qmc__vmap_edges(c, 0), bytes) != 0);
    qmc__vmap_free(a);
    qmc__vmap_free(b);
    qmc__vmap_free(c);
    qmc_testfn_free(fn);
}

static void nan_eval(const void *ctx, const double *x, size_t n, uint32_t dims, double *out)
{
    (void)ctx;
    for (size_t i = 0; i < n; i++)
        out[i] = x[i * dims] > 0.9 ? NAN : 1.0;
}

static int stop_now(void *ctx)
{
    (void)ctx;
    return 1;
}

static void test_refusals(void **state)
{
    (void)state;
    qmc_integrand bad = {.eval = nan_eval, .dims = 3};
    qmc__vmap *m = (qmc__vmap *)&bad;
    qmc__vmap_report rep;
    assert_int_equal(qmc__vmap_train(&bad, 20000, 1, NULL, &m, &rep), 0);
    assert_null(m);
    assert_true(rep.nonfinite);

    qmc_testfn *fn = genz("genz-gaussian", 20, 1);
    const qmc_integrand *f = qmc_testfn_integrand(fn);
    /* 20 dims need 4 rounds of 48 x 20 pilot points. */
    assert_int_equal(qmc__vmap_train(f, 3839, 1, NULL, &m, &rep), QMC_EBUDGET);
    assert_null(m);
    assert_int_equal(qmc__vmap_train(f, 3840, 1, NULL, &m, &rep), 0);
    assert_non_null(m);
    qmc__vmap_free(m);
    m = NULL;
    assert_null(m);
    qmc_interrupt hook = {stop_now, NULL};
    assert_int_equal(qmc__vmap_train(f, 100000, 1, &hook, &m, &rep), QMC_ECANCELED);
    assert_null(m);
    qmc_testfn_free(fn);

    qmc_integrand wide = {.eval = nan_eval, .dims = QMC__VMAP_MAX_DIMS + 1};
    assert_int_equal(qmc__vmap_train(&wide, 1000000, 1, NULL, &m, &rep), QMC_EDIMS);
    assert_null(m);
}

static qmc_integrate_report run_auto(const char *family, uint32_t dims, uint64_t seed,
                                     uint64_t budget, const qmc_integrand **f_out,
                                     qmc_testfn **fn_out)
{
    qmc_testfn *fn = genz(family, dims, seed);
    qmc_integrate_spec s;
    qmc_integrate_spec_init(&s);
    s.method = QMC_METHOD_AUTO;
    s.max_evals = budget;
    s.tol_rel = 1e-14;
    s.sampling.seed = seed;
    qmc_integrate_report r;
    char why[200];
    if (qmc_integrate(&s, qmc_testfn_integrand(fn), NULL, NULL, NULL, &r, why, sizeof why))
        fail_msg("%s", why);
    *f_out = qmc_testfn_integrand(fn);
    *fn_out = fn;
    return r;
}

static void test_auto_takes_the_map_where_it_pays(void **state)
{
    (void)state;
    const qmc_integrand *f;
    qmc_testfn *fn;
    qmc_integrate_report r = run_auto("genz-continuous", 20, 1, 1000000, &f, &fn);
    assert_int_equal(r.method_used, QMC_METHOD_RQMC);
    assert_non_null(strstr(r.auto_reason, "over a VEGAS map"));
    assert_true(r.res.evals <= 1000000);
    assert_true(r.res.evals > 100000); /* the pilot is counted */
    /* Without the map the same budget misses by about 1e-4 of the value
     * (bench_integrate); with it, by about 1e-6. */
    assert_true(fabs(r.res.estimate - f->exact) < 2e-5 * fabs(f->exact));
    qmc_testfn_free(fn);

    r = run_auto("genz-oscillatory", 20, 1, 1000000, &f, &fn);
    assert_null(strstr(r.auto_reason, "over a VEGAS map"));
    assert_non_null(strstr(r.auto_reason, "pilot"));
    qmc_testfn_free(fn);
    /* ... and its pilot gave up early: 4 rounds of 12, about a third of
     * the tenth of the budget. */
    qmc__vmap_report rep;
    qmc__vmap *m = NULL;
    fn = genz("genz-oscillatory", 20, 1);
    assert_int_equal(qmc__vmap_train(qmc_testfn_integrand(fn), 100000, 1, NULL, &m, &rep), 0);
    assert_int_equal(rep.rounds, 4);
    assert_true(rep.evals < 40000);
    qmc__vmap_free(m);
    qmc_testfn_free(fn);

    r = run_auto("genz-discontinuous", 20, 1, 1000000, &f, &fn);
    assert_null(strstr(r.auto_reason, "VEGAS"));
    qmc_testfn_free(fn);
}

/* The map must not cost the interval its meaning: over 200 seeds (each a
 * new draw of the integrand and new scrambles) the 95% interval of auto
 * over its map covers the exact value at least 88% of the time (see
 * test_coverage.c for the margin). */
static void test_auto_map_coverage(void **state)
{
    (void)state;
    static const char *const families[] = {"genz-continuous", "genz-corner-peak"};
    for (size_t k = 0; k < 2; k++) {
        int hits = 0, mapped = 0;
        for (uint64_t seed = 1; seed <= 200; seed++) {
            const qmc_integrand *f;
            qmc_testfn *fn;
            qmc_integrate_report r = run_auto(families[k], 20, seed, 100000, &f, &fn);
            hits += r.res.ci_low <= f->exact && f->exact <= r.res.ci_high;
            mapped += strstr(r.auto_reason, "over a VEGAS map") != NULL;
            qmc_testfn_free(fn);
        }
        if (hits < 176 || mapped < 150)
            fail_msg("%s: %d of 200 intervals cover, %d runs mapped", families[k], hits,
                     mapped);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_edges),
        cmocka_unit_test(test_jacobian_exact_in_1d),
        cmocka_unit_test(test_deterministic),
        cmocka_unit_test(test_refusals),
        cmocka_unit_test(test_auto_takes_the_map_where_it_pays),
        cmocka_unit_test(test_auto_map_coverage),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
