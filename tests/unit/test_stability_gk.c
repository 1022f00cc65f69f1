/*
 * test_stability_gk.c - issue 23's one-dimensional jumps: Gauss-Kronrod
 * near its end points, declared jump positions (qmc_integrand.breaks), and
 * `auto`'s choice for a 1D integrand with declared jumps.  Closed forms
 * written here: a step 1 for x < u has integral u; genz-discontinuous in
 * 1D, e^(a x) for x <= u, has (e^(a u) - 1) / a (stability_cases.h).
 *
 *   case                                               must
 *   step at 1 - 1e-9, declared (testfn)                be exact, unflagged
 *   genz-discontinuous d = 1 by auto (1.0e-8 bar,     pick gauss-kronrod
 *     5.2e-7 error with split-net RQMC before)          and cover
 *   a step 1e-9 from either end, jump declared but     cover (the end gaps are
 *     not where (a user's integrand)                     bisected) and carry
 *                                                        error_unreliable
 *   an undeclared interior step                        cover, error_unreliable
 *   x^-1/2 and log x by auto (RQMC flagged              pick gauss-kronrod,
 *     heavy_tail before)                                  unflagged, cover
 *   |x - 1/2|^-1/2 by auto (GK's centre node is inf)   RQMC with the rest
 *   x^-0.97 by GK and auto at 1e-2 (converged,         error_unreliable (the
 *     32.28 +- 0.32 against 33.33)                       check at 1e-2 / 16)
 *   breaks out of order or out of (0,1)                QMC_EINVAL
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

#include "qmc/integrate.h"
#include "qmc/quad.h"

#include "stability_cases.h"

/* Covered as qmc stability judges: within 3 bars plus 64 ulps of the scale. */
static void assert_covers(const qmc_result *r, double truth, double scale)
{
    double allowed = 3.0 * r->error + 64.0 * DBL_EPSILON * scale;
    if (!(fabs(r->estimate - truth) <= allowed))
        fail_msg("%.17g +- %.3g against %.17g (flags 0x%x, %llu evaluations)", r->estimate,
                 r->error, truth, r->flags, (unsigned long long)r->evals);
}

static void test_declared_step_at_the_end(void **state)
{
    (void)state;
    const double u[] = {0.999999999};
    run_out o = run_au("step", 1, NULL, u, QMC_METHOD_GAUSS_KRONROD, NULL);
    assert_int_equal(o.err, 0);
    assert_covers(&o.rep.res, u[0], u[0]);
    assert_true(fabs(o.rep.res.estimate - u[0]) <= 4 * DBL_EPSILON);
    assert_int_equal(o.rep.res.flags, 0);
    /* one rule on each side of the jump, nothing more */
    assert_int_equal(o.rep.res.evals, 42);
}

static void test_auto_takes_gk_for_a_declared_jump(void **state)
{
    (void)state;
    const double a[] = {3}, u[] = {0.41};
    run_out o = run_au("genz-discontinuous", 1, a, u, QMC_METHOD_AUTO, NULL);
    assert_int_equal(o.err, 0);
    assert_int_equal(o.rep.method_used, QMC_METHOD_GAUSS_KRONROD);
    assert_non_null(strstr(o.rep.auto_reason, "declares where its 1 jump is"));
    double truth = discontinuous_truth(1, a, u);
    assert_covers(&o.rep.res, truth, truth);
    assert_true(fabs(o.rep.res.estimate - truth) <= 1e-14 * truth);
    assert_int_equal(o.rep.res.flags, 0);
    /* and the kink of genz-continuous, also declared, costs two rules too */
    const double ac[] = {5}, uc[] = {0.31};
    o = run_au("genz-continuous", 1, ac, uc, QMC_METHOD_AUTO, NULL);
    assert_int_equal(o.err, 0);
    double tc = (2.0 - exp(-5 * 0.31) - exp(-5 * 0.69)) / 5;
    assert_covers(&o.rep.res, tc, tc);
    assert_int_equal(o.rep.res.evals, 42);
}

/* A user's step, discontinuous by declaration but with no breaks given. */
typedef struct user_step {
    double u;
    int rising; /* 0: 1 below u; 1: 1 above u */
} user_step;

static void user_step_eval(const void *ctx, const double *x, size_t n, uint32_t dims,
                           double *out)
{
    const user_step *s = ctx;
    (void)dims;
    for (size_t i = 0; i < n; i++)
        out[i] = (x[i] < s->u) != s->rising ? 1.0 : 0.0;
}

static run_out run_user_step(user_step *s)
{
    qmc_integrand f = {.eval = user_step_eval, .ctx = s, .dims = 1,
                       .smoothness = QMC_SMOOTH_DISCONTINUOUS, .name = "user-step"};
    qmc_integrate_spec spec;
    qmc_integrate_spec_init(&spec);
    spec.method = QMC_METHOD_GAUSS_KRONROD;
    run_out o;
    memset(&o, 0, sizeof o);
    o.err = qmc_integrate(&spec, &f, NULL, NULL, NULL, &o.rep, o.why, sizeof o.why);
    return o;
}

static void test_undeclared_jump_near_either_end(void **state)
{
    (void)state;
    /* 1 on [0, 1 - 1e-9): the case, without the declaration */
    user_step hi = {0.999999999, 0};
    run_out o = run_user_step(&hi);
    assert_int_equal(o.err, 0);
    assert_covers(&o.rep.res, hi.u, 1.0);
    ASSERT_FLAGS(o, QMC_FLAG_ERROR_UNRELIABLE);
    /* the mirror image: 1 on [1e-9, 1) */
    user_step lo = {1e-9, 1};
    o = run_user_step(&lo);
    assert_int_equal(o.err, 0);
    assert_covers(&o.rep.res, 1.0 - lo.u, 1.0);
    ASSERT_FLAGS(o, QMC_FLAG_ERROR_UNRELIABLE);
    /* and an interior jump, which the bisection floor already caught */
    user_step mid = {0.7071, 0};
    o = run_user_step(&mid);
    assert_int_equal(o.err, 0);
    assert_covers(&o.rep.res, mid.u, 1.0);
    ASSERT_FLAGS(o, QMC_FLAG_ERROR_UNRELIABLE);
}

/* |x - c|^-1/2, declared singular: 2 (sqrt(c) + sqrt(1 - c)). */
static void inv_sqrt_at_eval(const void *ctx, const double *x, size_t n, uint32_t dims,
                             double *out)
{
    const double *c = ctx;
    (void)dims;
    for (size_t i = 0; i < n; i++)
        out[i] = 1.0 / sqrt(fabs(x[i] - *c));
}

/* x^-0.97, declared singular: 1 / 0.03. */
static void strong_pole_eval(const void *ctx, const double *x, size_t n, uint32_t dims,
                             double *out)
{
    (void)ctx, (void)dims;
    for (size_t i = 0; i < n; i++)
        out[i] = pow(x[i], -0.97);
}

/* Gauss-Kronrod's converged bar on a declared singularity is checked by a
 * second run at a sixteenth of the tolerance: x^-0.97 at 1e-2 converged
 * to 32.28 +- 0.32 against 33.33, unflagged, before; the second run
 * cannot converge (each level misses the same share), so it is flagged.
 * x^-1/2 confirms. */
static void test_gk_singular_checked(void **state)
{
    (void)state;
    qmc_integrand f = {.eval = strong_pole_eval, .dims = 1,
                       .smoothness = QMC_SMOOTH_SINGULAR, .name = "x^-0.97"};
    qmc_integrate_spec spec;
    qmc_integrate_spec_init(&spec);
    spec.method = QMC_METHOD_GAUSS_KRONROD;
    spec.tol_rel = 1e-2;
    spec.max_evals = 100000;
    run_out o;
    memset(&o, 0, sizeof o);
    o.err = qmc_integrate(&spec, &f, NULL, NULL, NULL, &o.rep, o.why, sizeof o.why);
    assert_int_equal(o.err, 0);
    assert_false(o.rep.res.flags & QMC_FLAG_NOT_CONVERGED); /* the first run converged */
    ASSERT_FLAGS(o, QMC_FLAG_ERROR_UNRELIABLE);
    assert_true(fabs(o.rep.res.estimate - 1.0 / 0.03) > 3.0 * o.rep.res.error);
    assert_true(o.rep.res.evals <= spec.max_evals);
    /* the same by auto */
    spec.method = QMC_METHOD_AUTO;
    memset(&o, 0, sizeof o);
    o.err = qmc_integrate(&spec, &f, NULL, NULL, NULL, &o.rep, o.why, sizeof o.why);
    assert_int_equal(o.rep.method_used, QMC_METHOD_GAUSS_KRONROD);
    ASSERT_FLAGS(o, QMC_FLAG_ERROR_UNRELIABLE);
    /* x^-1/2 confirms, at the cost of the second run */
    o = run_au("inv-sqrt", 1, NULL, NULL, QMC_METHOD_GAUSS_KRONROD, NULL);
    assert_int_equal(o.err, 0);
    assert_int_equal(o.rep.res.flags, 0);
    assert_covers(&o.rep.res, 2.0, 2.0);
}

static void test_auto_takes_gk_for_a_singularity(void **state)
{
    (void)state;
    /* the built-ins: RQMC flagged heavy_tail on x^-1/2 (2.0002 +- 0.0006
     * at 2e7); Gauss-Kronrod converges unflagged */
    run_out o = run_au("inv-sqrt", 1, NULL, NULL, QMC_METHOD_AUTO, NULL);
    assert_int_equal(o.err, 0);
    assert_int_equal(o.rep.method_used, QMC_METHOD_GAUSS_KRONROD);
    assert_non_null(strstr(o.rep.auto_reason, "declared singularity"));
    assert_int_equal(o.rep.res.flags, 0);
    assert_covers(&o.rep.res, 2.0, 2.0);
    assert_true(fabs(o.rep.res.estimate - 2.0) <= 1e-6 * 2.0);
    o = run_au("log", 1, NULL, NULL, QMC_METHOD_AUTO, NULL);
    assert_int_equal(o.err, 0);
    assert_int_equal(o.rep.method_used, QMC_METHOD_GAUSS_KRONROD);
    assert_int_equal(o.rep.res.flags, 0);
    assert_covers(&o.rep.res, -1.0, 1.0);
    /* a singularity at 1/2, where the first rule has its centre node: f
     * is inf there, and auto hands the rest of the budget to RQMC */
    const double c = 0.5, truth = 2.0 * (sqrt(0.5) + sqrt(0.5));
    qmc_integrand f = {.eval = inv_sqrt_at_eval, .ctx = &c, .dims = 1,
                       .smoothness = QMC_SMOOTH_SINGULAR, .name = "inv-sqrt-at"};
    qmc_integrate_spec spec;
    qmc_integrate_spec_init(&spec);
    spec.method = QMC_METHOD_AUTO;
    spec.max_evals = 1 << 20;
    memset(&o, 0, sizeof o);
    o.err = qmc_integrate(&spec, &f, NULL, NULL, NULL, &o.rep, o.why, sizeof o.why);
    assert_int_equal(o.err, 0);
    assert_int_equal(o.rep.method_used, QMC_METHOD_RQMC);
    assert_non_null(strstr(o.rep.auto_reason, "included the singularity"));
    assert_false(o.rep.res.flags & QMC_FLAG_NONFINITE);
    assert_true(isfinite(o.rep.res.estimate));
    if (!(o.rep.res.flags & QMC_FLAG_ERROR_UNRELIABLE))
        assert_covers(&o.rep.res, truth, truth);
    assert_true(o.rep.res.evals <= spec.max_evals);
}

static void const_eval(const void *ctx, const double *x, size_t n, uint32_t dims, double *out)
{
    (void)ctx, (void)x, (void)dims;
    for (size_t i = 0; i < n; i++)
        out[i] = 1.0;
}

static void test_bad_breaks_refused(void **state)
{
    (void)state;
    qmc_quad_gk_opts g;
    qmc_quad_gk_opts_init(&g);
    size_t bytes = qmc_quad_gk_workspace_bytes(g.max_subdiv);
    void *ws = malloc(bytes);
    assert_non_null(ws);
    const double backwards[] = {0.5, 0.3}, at_end[] = {1.0}, fine[] = {0.25, 0.5};
    qmc_integrand f = {.eval = const_eval, .dims = 1, .smoothness = QMC_SMOOTH_DISCONTINUOUS};
    qmc_result r;
    f.breaks = backwards, f.n_breaks = 2;
    assert_int_equal(qmc_quad_gk(&f, &g, ws, bytes, &r), QMC_EINVAL);
    f.breaks = at_end, f.n_breaks = 1;
    assert_int_equal(qmc_quad_gk(&f, &g, ws, bytes, &r), QMC_EINVAL);
    f.breaks = fine, f.n_breaks = 2;
    assert_int_equal(qmc_quad_gk(&f, &g, ws, bytes, &r), 0);
    assert_true(fabs(r.estimate - 1.0) <= 4 * DBL_EPSILON);
    assert_int_equal(r.evals, 3 * 21);
    assert_int_equal(r.n, 3);
    free(ws);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_declared_step_at_the_end),
        cmocka_unit_test(test_auto_takes_gk_for_a_declared_jump),
        cmocka_unit_test(test_undeclared_jump_near_either_end),
        cmocka_unit_test(test_gk_singular_checked),
        cmocka_unit_test(test_auto_takes_gk_for_a_singularity),
        cmocka_unit_test(test_bad_breaks_refused),
    };
    return cmocka_run_group_tests_name("stability_gk", tests, NULL, NULL);
}
