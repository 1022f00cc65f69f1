/*
 * test_quad.c - unit tests for the one-dimensional rules, Gauss-Legendre,
 * adaptive Gauss-Kronrod and tensor-product rules of qmc/quad.h.
 *
 * Rules: each integrates monomials exactly up to its degree and visibly
 * fails one degree higher; composite midpoint and trapezoid converge like
 * h^2 and Simpson like h^4 (least-squares slopes of log error against
 * log h); Gauss-Legendre converges exponentially, and its nodes and weights
 * match tests/vectors/quad_vectors.h (decimal Newton, cross-checked against
 * NumPy's leggauss) to an ulp or so.  Gauss-Kronrod: the Kronrod rules'
 * own degrees, smooth integrands to 1e-13, endpoint singularities (never
 * evaluated at the endpoint) and steps with error bars that contain the
 * true error, roundoff and budget flags.  Tensor: accuracy, honest error,
 * exact evaluation counts (the check's in test_tensor_check.c), and a
 * budget refusal before any evaluation.
 * Interrupt hook: a hook that never fires changes no bit; one that fires
 * on its K-th call stops Gauss-Kronrod and the tensor rules right there
 * (QMC_ECANCELED, no estimate, no evaluation after the call), with at most
 * QMC_INTERRUPT_EVALS evaluations plus one batch between calls, and stops
 * Gauss-Legendre's O(n^2) node computation before any evaluation.
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

#include "hook.h"
#include "qmc/quad.h"
#include "../vectors/quad_vectors.h"

#define E_MINUS_1 1.71828182845904523536

/* ---- integrands ---------------------------------------------------------
 *
 * Each context holds a pointer to counters the integrand updates: eval
 * must not write to ctx itself, and these tests run single-threaded. */

typedef struct probe {
    uint64_t calls;   /* points evaluated */
    double min_x;     /* smallest and largest coordinate seen */
    double max_x;
} probe;

typedef struct fn_ctx {
    int kind;
    double p;         /* a parameter: power, frequency, step position */
    probe *seen;
} fn_ctx;

enum { F_POW, F_CPOW, F_LEG2, F_EXP, F_COS, F_RSQRT, F_LOG, F_STEP, F_NAN_AT };

static double fn_1(const fn_ctx *c, double x)
{
    switch (c->kind) {
    case F_POW:
        return pow(x, c->p);
    case F_CPOW: /* centred, so that high degrees are not drowned */
        return pow(2.0 * x - 1.0, c->p);
    case F_LEG2: { /* P_p(2x-1)^2: GL with p nodes gives exactly 0 */
        double t = 2.0 * x - 1.0, p0 = 1.0, p1 = t;
        if (c->p == 0.0)
            return 1.0;
        for (int k = 1; k < (int)c->p; k++) {
            double p2 = ((2 * k + 1) * t * p1 - k * p0) / (k + 1);
            p0 = p1;
            p1 = p2;
        }
        return p1 * p1;
    }
    case F_EXP:
        return exp(x);
    case F_COS:
        return cos(c->p * x);
    case F_RSQRT:
        return 1.0 / sqrt(x);
    case F_LOG:
        return log(x);
    case F_STEP:
        return x < c->p ? 1.0 : 0.0;
    case F_NAN_AT:
        return x > c->p ? NAN : 1.0;
    default:
        return 0.0;
    }
}

/* The product over the coordinates of fn_1. */
static void fn_eval(const void *ctx, const double *x, size_t n, uint32_t dims,
                    double *out)
{
    const fn_ctx *c = ctx;
    for (size_t i = 0; i < n; i++) {
        double v = 1.0;
        for (uint32_t j = 0; j < dims; j++) {
            double xj = x[i * dims + j];
            if (c->seen) {
                c->seen->min_x = fmin(c->seen->min_x, xj);
                c->seen->max_x = fmax(c->seen->max_x, xj);
            }
            v *= fn_1(c, xj);
        }
        out[i] = v;
    }
    if (c->seen)
        c->seen->calls += n;
}

static qmc_integrand make_fn(const fn_ctx *c, uint32_t dims)
{
    qmc_integrand f;
    memset(&f, 0, sizeof f);
    f.eval = fn_eval;
    f.ctx = c;
    f.dims = dims;
    f.name = "test";
    return f;
}

static void probe_init(probe *p)
{
    p->calls = 0;
    p->min_x = INFINITY;
    p->max_x = -INFINITY;
}

/* sum w_i g(x_i) for a rule, compensated. */
static double rule_sum(qmc_rule1d rule, uint32_t n, const fn_ctx *c)
{
    double *x = malloc(n * sizeof *x), *w = malloc(n * sizeof *w);
    assert_non_null(x);
    assert_non_null(w);
    assert_int_equal(qmc_rule1d_nodes(rule, n, x, w), 0);
    double s = 0.0, comp = 0.0;
    for (uint32_t i = 0; i < n; i++) {
        double v = w[i] * fn_1(c, x[i]), t = s + v;
        comp += fabs(s) >= fabs(v) ? (s - t) + v : (v - t) + s;
        s = t;
    }
    free(x);
    free(w);
    return s + comp;
}

static double rel_err(double got, double want)
{
    return fabs(got - want) / fabs(want);
}

/* Least-squares slope of log(err) against log(h). */
static double fitted_slope(const double *h, const double *err, int m)
{
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (int i = 0; i < m; i++) {
        double lx = log(h[i]), ly = log(err[i]);
        sx += lx;
        sy += ly;
        sxx += lx * lx;
        sxy += lx * ly;
    }
    return (m * sxy - sx * sy) / (m * sxx - sx * sx);
}

/* ---- names and checks -------------------------------------------------- */

static void test_rule_names(void **state)
{
    (void)state;
    for (int r = 0; r < QMC_RULE1D_COUNT; r++) {
        qmc_rule1d back = QMC_RULE1D_COUNT;
        assert_int_equal(qmc_rule1d_parse(qmc_rule1d_name((qmc_rule1d)r), &back), 0);
        assert_int_equal(back, r);
    }
    assert_string_equal(qmc_rule1d_name(QMC_RULE1D_GAUSS_LEGENDRE), "gauss-legendre");
    assert_string_equal(qmc_rule1d_name((qmc_rule1d)99), "");
    qmc_rule1d r = QMC_RULE1D_SIMPSON;
    assert_int_equal(qmc_rule1d_parse("gauss", &r), QMC_EKIND);
    assert_int_equal(qmc_rule1d_parse(NULL, &r), QMC_EINVAL);
    assert_int_equal(r, QMC_RULE1D_SIMPSON);

    char why[128];
    double x[8], w[8];
    assert_int_equal(qmc_rule1d_check(QMC_RULE1D_SIMPSON, 4, why, sizeof why),
                     QMC_ECOUNT);
    assert_string_equal(why, "simpson needs an odd n >= 3, got 4");
    assert_int_equal(qmc_rule1d_check(QMC_RULE1D_SIMPSON, 1, why, sizeof why),
                     QMC_ECOUNT);
    assert_int_equal(qmc_rule1d_check(QMC_RULE1D_TRAPEZOID, 1, why, sizeof why),
                     QMC_ECOUNT);
    assert_string_equal(why, "trapezoid needs n >= 2, got 1");
    assert_int_equal(qmc_rule1d_check(QMC_RULE1D_MIDPOINT, 0, NULL, 0), QMC_ECOUNT);
    assert_int_equal(qmc_rule1d_check(QMC_RULE1D_GAUSS_LEGENDRE,
                                      QMC_GAUSS_LEGENDRE_MAX_N + 1, NULL, 0),
                     QMC_ECOUNT);
    assert_int_equal(qmc_rule1d_check((qmc_rule1d)7, 5, why, sizeof why), QMC_EKIND);
    assert_int_equal(qmc_rule1d_nodes(QMC_RULE1D_SIMPSON, 4, x, w), QMC_ECOUNT);
    assert_int_equal(qmc_rule1d_nodes(QMC_RULE1D_SIMPSON, 5, NULL, w), QMC_EINVAL);
    assert_int_equal(qmc_gauss_legendre(0, x, w), QMC_ECOUNT);
    assert_int_equal(qmc_rule1d_check(QMC_RULE1D_SIMPSON, 5, NULL, 0), 0);
}

/* ---- degree of exactness ------------------------------------------------ */

/* Exact for x^k, k <= degree, to tol relative; and visibly wrong at
 * degree + 1: for Gauss-Legendre on P_n(2x-1)^2 (zero at every node, so the
 * rule gives 0 for 1/(2n+1)), for the others on (2x-1)^(degree+1) (x^k
 * would hide the top coefficient behind a factor 2^-k). */
static void check_degree(qmc_rule1d rule, uint32_t n, int degree, double tol)
{
    for (int k = 0; k <= degree; k++) {
        fn_ctx c = {F_POW, (double)k, NULL};
        double e = rel_err(rule_sum(rule, n, &c), 1.0 / (k + 1));
        if (e > tol)
            fail_msg("%s n=%u: x^%d off by %.3g (tol %.3g)",
                     qmc_rule1d_name(rule), n, k, e, tol);
    }
    int gl = rule == QMC_RULE1D_GAUSS_LEGENDRE;
    fn_ctx up = {gl ? F_LEG2 : F_CPOW, gl ? (double)n : (double)(degree + 1),
                 NULL};
    double want = gl ? 1.0 / (2.0 * n + 1.0) : 1.0 / (degree + 2);
    double e = rel_err(rule_sum(rule, n, &up), want);
    if (!(e > 100.0 * tol))
        fail_msg("%s n=%u: degree %d should not be exact, error %.3g",
                 qmc_rule1d_name(rule), n, degree + 1, e);
    if (gl && !(e > 0.999))
        fail_msg("gauss-legendre n=%u: P_n^2 gives %.3g, not 0", n, e);
}

static void test_degree_of_exactness(void **state)
{
    (void)state;
    check_degree(QMC_RULE1D_MIDPOINT, 7, 1, 1e-15);
    check_degree(QMC_RULE1D_TRAPEZOID, 7, 1, 1e-15);
    check_degree(QMC_RULE1D_SIMPSON, 7, 3, 1e-15);
    check_degree(QMC_RULE1D_SIMPSON, 101, 3, 1e-14);
    /* 2n-1: the rounding of nodes near 1 costs about k ulps of x^k. */
    check_degree(QMC_RULE1D_GAUSS_LEGENDRE, 5, 9, 1e-15);
    check_degree(QMC_RULE1D_GAUSS_LEGENDRE, 20, 39, 2e-15);
    check_degree(QMC_RULE1D_GAUSS_LEGENDRE, 100, 199, 1e-14);
}

/* ---- convergence orders ---------------------------------------------------- */

static void test_convergence_orders(void **state)
{
    (void)state;
    fn_ctx c = {F_EXP, 0.0, NULL};
    double h[6], em[6], et[6], es[6];
    for (int i = 0; i < 6; i++) {
        uint32_t panels = 4u << i;
        h[i] = 1.0 / panels;
        em[i] = fabs(rule_sum(QMC_RULE1D_MIDPOINT, panels, &c) - E_MINUS_1);
        et[i] = fabs(rule_sum(QMC_RULE1D_TRAPEZOID, panels + 1, &c) - E_MINUS_1);
        es[i] = fabs(rule_sum(QMC_RULE1D_SIMPSON, panels + 1, &c) - E_MINUS_1);
    }
    double sm = fitted_slope(h, em, 6), st = fitted_slope(h, et, 6);
    double ss = fitted_slope(h, es, 6);
    if (fabs(sm - 2.0) > 0.05 || fabs(st - 2.0) > 0.05 || fabs(ss - 4.0) > 0.1)
        fail_msg("slopes: midpoint %.3f trapezoid %.3f simpson %.3f", sm, st, ss);
    /* the classical constants: midpoint error ~ -trapezoid error / 2 */
    assert_true(fabs(em[5] / et[5] - 0.5) < 1e-3);
}

static void test_gauss_legendre_exponential(void **state)
{
    (void)state;
    fn_ctx fe = {F_EXP, 0.0, NULL}, fc = {F_COS, 3.0, NULL};
    double want_c = sin(3.0) / 3.0;
    double prev_e = 1.0, prev_c = 1.0;
    for (uint32_t n = 1; n <= 12; n++) {
        double ee = fabs(rule_sum(QMC_RULE1D_GAUSS_LEGENDRE, n, &fe) - E_MINUS_1);
        double ec = fabs(rule_sum(QMC_RULE1D_GAUSS_LEGENDRE, n, &fc) - want_c);
        /* each extra node gains more than a digit until roundoff */
        if (prev_e > 1e-13 && n > 1 && !(ee < prev_e / 10.0))
            fail_msg("exp: n=%u error %.3g after %.3g", n, ee, prev_e);
        if (prev_c > 1e-13 && n > 2 && !(ec < prev_c / 5.0))
            fail_msg("cos: n=%u error %.3g after %.3g", n, ec, prev_c);
        prev_e = ee;
        prev_c = ec;
    }
    assert_true(prev_e < 1e-15);
    assert_true(prev_c < 1e-15);
}

/* ---- Gauss-Legendre against the reference vectors --------------------------- */

static void test_gauss_legendre_vectors(void **state)
{
    (void)state;
    static double x[1000], w[1000];
    for (size_t v = 0; v < sizeof gl_vectors / sizeof gl_vectors[0]; v++) {
        const gl_vector *g = &gl_vectors[v];
        uint32_t n = g->n;
        assert_int_equal(qmc_gauss_legendre(n, x, w), 0);
        double wtol = n >= 1000 ? 2e-14 : 5e-15;
        double s = 0.0, comp = 0.0;
        for (uint32_t i = 0; i < n; i++) {
            double dx = fabs(x[i] - g->x[i]);
            /* an ulp of the node near 1, full relative precision near 0 */
            if (dx > DBL_EPSILON * fmax(g->x[i], 0.0) * 2.0 + 0x1p-60
                && dx > 2.0 * DBL_EPSILON * g->x[i])
                fail_msg("n=%u node %u: %.17g vs %.17g", n, i, x[i], g->x[i]);
            if (dx > 1.2e-16)
                fail_msg("n=%u node %u: off by %.3g", n, i, dx);
            if (rel_err(w[i], g->w[i]) > wtol)
                fail_msg("n=%u weight %u: relative error %.3g", n, i,
                         rel_err(w[i], g->w[i]));
            if (i > 0 && !(x[i] > x[i - 1]))
                fail_msg("n=%u: nodes not ascending at %u", n, i);
            double t = s + w[i];
            comp += (s - t) + w[i];
            s = t;
        }
        /* weights sum to 1 within a few ulps */
        if (fabs(s + comp - 1.0) > 4.0 * DBL_EPSILON)
            fail_msg("n=%u: weights sum to 1 %+.3g", n, s + comp - 1.0);
    }
}

/* ---- adaptive Gauss-Kronrod --------------------------------------------------- */

typedef struct gk_run {
    qmc_result res;
    int rc;
    probe seen;
} gk_run;

/* With a test hook firing on call fire_at (h NULL: no hook). */
static gk_run run_gk_hook(int kind, double p, double tol_abs, double tol_rel,
                          uint32_t max_subdiv, uint32_t kronrod, uint64_t max_evals,
                          test_hook *h, uint64_t fire_at)
{
    gk_run r;
    probe_init(&r.seen);
    fn_ctx c = {kind, p, &r.seen};
    qmc_integrand f = make_fn(&c, 1);
    qmc_quad_gk_opts o;
    qmc_quad_gk_opts_init(&o);
    o.tol_abs = tol_abs;
    o.tol_rel = tol_rel;
    o.max_subdiv = max_subdiv;
    o.kronrod_points = kronrod;
    o.max_evals = max_evals;
    if (h)
        o.interrupt = test_hook_init(h, fire_at, &r.seen.calls);
    size_t bytes = qmc_quad_gk_workspace_bytes(max_subdiv);
    void *ws = malloc(bytes);
    assert_non_null(ws);
    r.rc = qmc_quad_gk(&f, &o, ws, bytes, &r.res);
    free(ws);
    if (r.rc == 0 && r.res.evals != r.seen.calls)
        fail_msg("evals %llu but the integrand saw %llu",
                 (unsigned long long)r.res.evals, (unsigned long long)r.seen.calls);
    return r;
}

static gk_run run_gk(int kind, double p, double tol_abs, double tol_rel,
                     uint32_t max_subdiv, uint32_t kronrod, uint64_t max_evals)
{
    return run_gk_hook(kind, p, tol_abs, tol_rel, max_subdiv, kronrod, max_evals, NULL, 0);
}

static void test_gk_kronrod_degree(void **state)
{
    (void)state;
    /* One interval: the Kronrod rule alone, on (2x-1)^k so that the top
     * coefficient is not scaled away.  K15 extends G7 (odd n) to degree
     * 3n+2 = 23, K21 extends G10 to 3n+1 = 31; both fail one degree up. */
    const struct { uint32_t k; int degree; } rules[] = {{15, 23}, {21, 31}};
    for (int r = 0; r < 2; r++) {
        for (int k = 0; k <= rules[r].degree + 1; k++) {
            gk_run g = run_gk(F_CPOW, k, 0.0, 1e-13, 1, rules[r].k, UINT64_MAX);
            assert_int_equal(g.rc, 0);
            assert_int_equal(g.res.evals, rules[r].k);
            assert_int_equal(g.res.n, 1);
            double e = fabs(g.res.estimate - (k % 2 ? 0.0 : 1.0 / (k + 1)));
            if (k <= rules[r].degree && e > 1e-15)
                fail_msg("K%u: (2x-1)^%d off by %.3g", rules[r].k, k, e);
            if (k > rules[r].degree && e < 1e-13)
                fail_msg("K%u: (2x-1)^%d should not be exact (%.3g)",
                         rules[r].k, k, e);
        }
    }
}

static void check_honest(const gk_run *g, double want, const char *what)
{
    double e = fabs(g->res.estimate - want);
    if (!(e <= g->res.error))
        fail_msg("%s: true error %.3g above the estimate %.3g (flags %#x)", what,
                 e, g->res.error, g->res.flags);
    assert_true(g->res.error_kind == QMC_ERROR_ESTIMATE);
    assert_true(g->res.ci_low <= want && want <= g->res.ci_high);
}

static void test_gk_smooth(void **state)
{
    (void)state;
    /* cos(30x) integrates to -0.033 while |f| integrates to 0.64: QUADPACK's
     * roundoff floor 50 eps int|f| rules out 1e-13 relative, so it gets an
     * absolute tolerance. */
    const struct { int kind; double p, tol_abs, tol_rel; } cases[] = {
        {F_EXP, 0.0, 0.0, 1e-13},
        {F_COS, 30.0, 1e-13, 0.0},
        {F_POW, 0.5, 0.0, 1e-13},
    };
    const double want[] = {E_MINUS_1, sin(30.0) / 30.0, 2.0 / 3.0};
    for (int i = 0; i < 3; i++) {
        for (uint32_t k = 15; k <= 21; k += 6) {
            gk_run g = run_gk(cases[i].kind, cases[i].p, cases[i].tol_abs,
                              cases[i].tol_rel, 200, k, UINT64_MAX);
            assert_int_equal(g.rc, 0);
            if (g.res.flags != 0)
                fail_msg("case %d K%u: flags %#x", i, k, g.res.flags);
            double tol = fmax(cases[i].tol_abs, cases[i].tol_rel * fabs(want[i]));
            assert_true(g.res.error <= tol * 1.0000001);
            assert_true(fabs(g.res.estimate - want[i]) <= tol);
            check_honest(&g, want[i], "smooth");
            assert_true(g.seen.min_x > 0.0 && g.seen.max_x < 1.0);
        }
    }
}

static void test_gk_endpoint_singular(void **state)
{
    (void)state;
    gk_run g = run_gk(F_RSQRT, 0.0, 0.0, 1e-10, 200, 21, UINT64_MAX);
    assert_int_equal(g.rc, 0);
    assert_int_equal(g.res.flags, 0);
    assert_true(rel_err(g.res.estimate, 2.0) < 1e-10);
    check_honest(&g, 2.0, "x^-1/2");
    assert_true(g.seen.min_x > 0.0); /* never at the endpoint */

    g = run_gk(F_LOG, 0.0, 0.0, 1e-10, 200, 15, UINT64_MAX);
    assert_int_equal(g.rc, 0);
    assert_int_equal(g.res.flags, 0);
    assert_true(rel_err(g.res.estimate, -1.0) < 1e-10);
    check_honest(&g, -1.0, "log x");
    assert_true(g.seen.min_x > 0.0);
}

/* f by Gauss-Kronrod with the default options; fails the test on an error. */
static qmc_result gk_default(const qmc_integrand *f)
{
    qmc_quad_gk_opts o;
    qmc_quad_gk_opts_init(&o);
    size_t bytes = qmc_quad_gk_workspace_bytes(o.max_subdiv);
    void *ws = malloc(bytes);
    assert_non_null(ws);
    qmc_result r;
    assert_int_equal(qmc_quad_gk(f, &o, ws, bytes, &r), 0);
    free(ws);
    return r;
}

/* |x - 1/3|^-0.99: 3^0.01 (1 + 2^0.01) / 0.01 = 198.5... */
static void interior_pole_eval(const void *ctx, const double *x, size_t n, uint32_t dims,
                               double *out)
{
    (void)ctx, (void)dims;
    for (size_t i = 0; i < n; i++)
        out[i] = pow(fabs(x[i] - 1.0 / 3.0), -0.99);
}

/* x^-p near p = 1, declared singular: each bisection toward 0 leaves the
 * interval [0, h] whose Kronrod estimate is h^(1-p) times the one on
 * [0, 1], missing the same share of its mass at every level, so the run
 * exhausts its subdivisions, and QUADPACK's estimate of that interval
 * never sees the spike: at p = 0.99, 200 intervals reported 76.7 +- 2.2
 * against 100.  A declared singularity that stops short of the tolerance
 * is flagged error_unreliable; x^-1/2, which converges, is not (above). */
static void test_gk_strong_singularity(void **state)
{
    (void)state;
    const double p[] = {0.95, 0.99};
    for (int i = 0; i < 2; i++) {
        probe seen;
        probe_init(&seen);
        fn_ctx c = {F_POW, -p[i], &seen};
        qmc_integrand f = make_fn(&c, 1);
        f.smoothness = QMC_SMOOTH_SINGULAR;
        qmc_result r = gk_default(&f);
        const double truth = 1.0 / (1.0 - p[i]);
        assert_true(r.flags & QMC_FLAG_MAX_SUBDIV);
        assert_true(r.flags & QMC_FLAG_NOT_CONVERGED);
        assert_true(r.flags & QMC_FLAG_ERROR_UNRELIABLE);
        assert_true(r.estimate < truth); /* the spike's mass is missing */
        /* declared analytic (the same values), the flag is not raised */
        probe_init(&seen);
        f.smoothness = QMC_SMOOTH_ANALYTIC;
        qmc_result a = gk_default(&f);
        assert_false(a.flags & QMC_FLAG_ERROR_UNRELIABLE);
        if (p[i] == 0.99)
            assert_true(fabs(a.estimate - truth) > 3.0 * a.error); /* the flag was needed */
    }
    /* an interior pole, where QUADPACK's roundoff tests stop the run long
     * before the intervals run out (60.5 +- 5.6 against 198.5) */
    qmc_integrand f = {.eval = interior_pole_eval, .dims = 1,
                       .smoothness = QMC_SMOOTH_SINGULAR, .name = "interior-pole"};
    qmc_result r = gk_default(&f);
    const double truth = pow(3.0, 0.01) * (1.0 + pow(2.0, 0.01)) / 0.01;
    assert_true(r.flags & QMC_FLAG_NOT_CONVERGED);
    assert_true(r.flags & QMC_FLAG_ERROR_UNRELIABLE);
    assert_true(fabs(r.estimate - truth) > 3.0 * r.error);
}

static void test_gk_step(void **state)
{
    (void)state;
    /* Few intervals: not converged, flagged, and the error bar still holds
     * the truth; at a dozen step positions, with both rules. */
    for (int i = 1; i <= 12; i++) {
        double s = i / 13.0 + 0.001 * sqrt((double)i);
        for (uint32_t k = 15; k <= 21; k += 6) {
            gk_run g = run_gk(F_STEP, s, 0.0, 1e-12, 10, k, UINT64_MAX);
            assert_int_equal(g.rc, 0);
            assert_true(g.res.flags & QMC_FLAG_NOT_CONVERGED);
            assert_true(g.res.flags & QMC_FLAG_MAX_SUBDIV);
            assert_int_equal(g.res.n, 10);
            assert_int_equal(g.res.evals, k * 19u); /* 1 + 2*9 rules */
            check_honest(&g, s, "step, 10 intervals");
            /* with room, bisection isolates the jump */
            g = run_gk(F_STEP, s, 1e-9, 0.0, 500, k, UINT64_MAX);
            assert_int_equal(g.rc, 0);
            check_honest(&g, s, "step, 500 intervals");
            assert_true(fabs(g.res.estimate - s) < 1e-9);
        }
    }
}

static void test_gk_roundoff(void **state)
{
    (void)state;
    /* A tolerance below what doubles can resolve. */
    gk_run g = run_gk(F_EXP, 0.0, 0.0, 1e-20, 200, 21, UINT64_MAX);
    assert_int_equal(g.rc, 0);
    assert_true(g.res.flags & QMC_FLAG_ROUNDOFF);
    assert_true(g.res.flags & QMC_FLAG_NOT_CONVERGED);
    assert_true(rel_err(g.res.estimate, E_MINUS_1) < 1e-15);
    check_honest(&g, E_MINUS_1, "roundoff");
    /* and an oscillating integrand pushed past roundoff */
    g = run_gk(F_COS, 200.0, 0.0, 1e-17, 1000, 15, UINT64_MAX);
    assert_int_equal(g.rc, 0);
    assert_true(g.res.flags & QMC_FLAG_ROUNDOFF);
    check_honest(&g, sin(200.0) / 200.0, "roundoff cos");
}

static void test_gk_budget_and_errors(void **state)
{
    (void)state;
    gk_run g = run_gk(F_STEP, 1.0 / 3.0, 0.0, 1e-12, 1000, 21, 21 * 11);
    assert_int_equal(g.rc, 0);
    assert_int_equal(g.res.flags & (QMC_FLAG_BUDGET | QMC_FLAG_NOT_CONVERGED),
                     QMC_FLAG_BUDGET | QMC_FLAG_NOT_CONVERGED);
    assert_int_equal(g.res.evals, 21 * 11);
    check_honest(&g, 1.0 / 3.0, "budget");

    g = run_gk(F_EXP, 0.0, 0.0, 1e-10, 10, 21, 20);
    assert_int_equal(g.rc, QMC_EBUDGET);
    assert_int_equal(g.seen.calls, 0);
    assert_int_equal(g.res.evals, 0);

    /* a NaN inside: counted, flagged, stopped */
    g = run_gk(F_NAN_AT, 0.9, 0.0, 1e-10, 100, 21, UINT64_MAX);
    assert_int_equal(g.rc, 0);
    assert_true(g.res.flags & QMC_FLAG_NONFINITE);
    assert_true(g.res.flags & QMC_FLAG_NOT_CONVERGED);
    assert_true(g.res.nonfinite > 0);

    probe seen;
    probe_init(&seen);
    fn_ctx c = {F_EXP, 0.0, &seen};
    qmc_integrand f = make_fn(&c, 1);
    qmc_quad_gk_opts o;
    qmc_quad_gk_opts_init(&o);
    double ws[64];
    qmc_result res;
    res.evals = 99;
    assert_int_equal(qmc_quad_gk(&f, &o, ws, sizeof ws, &res), QMC_EINVAL);
    assert_int_equal(res.evals, 0); /* filled on every path */
    assert_true(qmc_quad_gk_workspace_bytes(o.max_subdiv) > sizeof ws);
    o.max_subdiv = 2;
    o.kronrod_points = 17;
    assert_int_equal(qmc_quad_gk(&f, &o, ws, sizeof ws, &res), QMC_EINVAL);
    o.kronrod_points = 15;
    o.tol_rel = 0.0;
    assert_int_equal(qmc_quad_gk(&f, &o, ws, sizeof ws, &res), QMC_EINVAL);
    o.tol_rel = NAN;
    assert_int_equal(qmc_quad_gk(&f, &o, ws, sizeof ws, &res), QMC_EINVAL);
    o.tol_rel = 1e-8;
    f.dims = 2;
    assert_int_equal(qmc_quad_gk(&f, &o, ws, sizeof ws, &res), QMC_EDIMS);
    f.dims = 1;
    assert_int_equal(qmc_quad_gk(&f, &o, ws, sizeof ws, &res), 0);
    assert_int_equal(seen.calls, res.evals);
    assert_int_equal(qmc_quad_gk(&f, &o, ws, sizeof ws, NULL), QMC_EINVAL);
}

/* ---- tensor products --------------------------------------------------------- */

/* With a test hook firing on call fire_at (h NULL: no hook). */
static qmc_result run_tensor_hook(int kind, double p, uint32_t dims, qmc_rule1d rule,
                                  uint32_t n, uint64_t max_evals, int *rc, probe *seen,
                                  char *why, size_t why_bytes, test_hook *h,
                                  uint64_t fire_at)
{
    probe_init(seen);
    fn_ctx c = {kind, p, seen};
    qmc_integrand f = make_fn(&c, dims);
    /* Exactly the rule's own size, so that the sanitizer build catches a
     * rule writing past it. */
    size_t bytes = qmc_quad_tensor_rule_workspace_bytes(rule, n, dims);
    void *ws = malloc(bytes);
    assert_non_null(ws);
    qmc_result res;
    qmc_interrupt hook;
    if (h)
        hook = test_hook_init(h, fire_at, &seen->calls);
    *rc = qmc_quad_tensor(&f, rule, n, max_evals, h ? &hook : NULL, ws, bytes, &res, why,
                          why_bytes);
    free(ws);
    return res;
}

static qmc_result run_tensor(int kind, double p, uint32_t dims, qmc_rule1d rule,
                             uint32_t n, uint64_t max_evals, int *rc, probe *seen,
                             char *why, size_t why_bytes)
{
    return run_tensor_hook(kind, p, dims, rule, n, max_evals, rc, seen, why, why_bytes, NULL,
                           0);
}

/* Only Gauss-Legendre from 8 nodes an axis keeps the marginals for its
 * Legendre-decay test, (dims + 1) n doubles; the other rules run in the
 * smaller workspace and refuse one byte less. */
static void test_tensor_workspace_per_rule(void **state)
{
    (void)state;
    const uint32_t n = 1024, d = 2;
    size_t gl = qmc_quad_tensor_rule_workspace_bytes(QMC_RULE1D_GAUSS_LEGENDRE, n, d);
    size_t mid = qmc_quad_tensor_rule_workspace_bytes(QMC_RULE1D_MIDPOINT, n, d);
    assert_int_equal(gl - mid, (d + 1) * n * sizeof(double));
    assert_int_equal(qmc_quad_tensor_workspace_bytes(n, d), gl);
    assert_int_equal(qmc_quad_tensor_rule_workspace_bytes(QMC_RULE1D_GAUSS_LEGENDRE, 4, d),
                     qmc_quad_tensor_rule_workspace_bytes(QMC_RULE1D_MIDPOINT, 4, d));
    probe seen;
    probe_init(&seen);
    fn_ctx c = {F_POW, 2.0, &seen};
    qmc_integrand f = make_fn(&c, d);
    void *ws = malloc(mid);
    assert_non_null(ws);
    qmc_result res;
    char why[160];
    assert_int_equal(qmc_quad_tensor(&f, QMC_RULE1D_MIDPOINT, 64, UINT64_MAX, NULL, ws, mid,
                                     &res, why, sizeof why), 0);
    assert_int_equal(qmc_quad_tensor(&f, QMC_RULE1D_MIDPOINT, n, UINT64_MAX, NULL, ws, mid - 1,
                                     &res, why, sizeof why), QMC_EINVAL);
    free(ws);
}

static void test_tensor_accuracy(void **state)
{
    (void)state;
    probe seen;
    char why[160];
    int rc;
    /* prod exp(x_j) over [0,1]^3 by Gauss-Legendre 8: full precision */
    qmc_result r = run_tensor(F_EXP, 0.0, 3, QMC_RULE1D_GAUSS_LEGENDRE, 8,
                              1000000, &rc, &seen, why, sizeof why);
    double want = E_MINUS_1 * E_MINUS_1 * E_MINUS_1;
    assert_int_equal(rc, 0);
    assert_int_equal(r.flags, 0);
    assert_int_equal(r.n, 512);
    /* the levels 8 and 4, the check's siblings 5 and 6, its 32 probes */
    assert_int_equal(r.evals, 512 + 64 + 125 + 216 + 32);
    assert_int_equal(seen.calls, r.evals);
    assert_int_equal(r.dims, 3);
    assert_true(r.error_kind == QMC_ERROR_ESTIMATE);
    assert_true(rel_err(r.estimate, want) < 1e-14);
    assert_true(fabs(r.estimate - want) <= r.error);

    /* every rule, d = 2: error estimate holds the truth; nodes stay < 1 */
    const struct { qmc_rule1d rule; uint32_t n; } cases[] = {
        {QMC_RULE1D_MIDPOINT, 40}, {QMC_RULE1D_TRAPEZOID, 41},
        {QMC_RULE1D_SIMPSON, 41}, {QMC_RULE1D_GAUSS_LEGENDRE, 6}};
    for (int i = 0; i < 4; i++) {
        r = run_tensor(F_COS, 2.0, 2, cases[i].rule, cases[i].n, 100000, &rc,
                       &seen, why, sizeof why);
        want = (sin(2.0) / 2.0) * (sin(2.0) / 2.0);
        assert_int_equal(rc, 0);
        if (!(fabs(r.estimate - want) <= r.error))
            fail_msg("%s: error %.3g above estimate %.3g",
                     qmc_rule1d_name(cases[i].rule), fabs(r.estimate - want), r.error);
        assert_true(seen.max_x < 1.0 && seen.min_x >= 0.0);
    }
    /* Simpson is exact for a product of cubics */
    r = run_tensor(F_POW, 3.0, 4, QMC_RULE1D_SIMPSON, 5, 100000, &rc, &seen,
                   why, sizeof why);
    assert_int_equal(rc, 0);
    assert_true(rel_err(r.estimate, 1.0 / 256.0) < 1e-14);
    /* no coarser rule below the minimum n: the error is flagged */
    r = run_tensor(F_EXP, 0.0, 2, QMC_RULE1D_MIDPOINT, 1, 100, &rc, &seen, why,
                   sizeof why);
    assert_int_equal(rc, 0);
    assert_true(r.flags & QMC_FLAG_ERROR_UNRELIABLE);
    assert_int_equal(r.evals, 1);
}

static void test_tensor_budget(void **state)
{
    (void)state;
    probe seen;
    char why[160];
    int rc;
    qmc_result r = run_tensor(F_EXP, 0.0, 6, QMC_RULE1D_GAUSS_LEGENDRE, 64,
                              10000000, &rc, &seen, why, sizeof why);
    assert_int_equal(rc, QMC_EBUDGET);
    assert_string_equal(why, "tensor gauss-legendre: 64^6 + 32^6 = 69793218560 "
                             "evaluations exceed the budget of 10000000");
    assert_int_equal(seen.calls, 0); /* refused before evaluating */
    assert_int_equal(r.evals, 0);
    assert_true(r.error_kind == QMC_ERROR_ESTIMATE);

    r = run_tensor(F_EXP, 0.0, 30, QMC_RULE1D_TRAPEZOID, 1000, UINT64_MAX, &rc,
                   &seen, why, sizeof why);
    assert_int_equal(rc, QMC_EBUDGET);
    assert_string_equal(why, "tensor trapezoid: 1000^30 + 500^30 > "
                             "18446744073709551615 evaluations exceed the "
                             "budget of 18446744073709551615");
    assert_int_equal(seen.calls, 0);

    /* exactly at the budget is allowed */
    r = run_tensor(F_EXP, 0.0, 2, QMC_RULE1D_GAUSS_LEGENDRE, 10, 125, &rc, &seen,
                   why, sizeof why);
    assert_int_equal(rc, 0);
    assert_int_equal(r.evals, 125);
    r = run_tensor(F_EXP, 0.0, 2, QMC_RULE1D_GAUSS_LEGENDRE, 10, 124, &rc, &seen,
                   why, sizeof why);
    assert_int_equal(rc, QMC_EBUDGET);

    r = run_tensor(F_EXP, 0.0, 2, QMC_RULE1D_SIMPSON, 4, 1000, &rc, &seen, why,
                   sizeof why);
    assert_int_equal(rc, QMC_ECOUNT);
    assert_string_equal(why, "simpson needs an odd n >= 3, got 4");
    r = run_tensor(F_EXP, 0.0, 0, QMC_RULE1D_SIMPSON, 5, 1000, &rc, &seen, why,
                   sizeof why);
    assert_int_equal(rc, QMC_EDIMS);
}

/* ---- the interrupt hook -------------------------------------------------------- */

/* A run stopped by the hook: no estimate, nothing evaluated after the
 * firing call, and the evaluations it did reported. */
static void check_stopped(int rc, const qmc_result *res, const probe *seen,
                          const test_hook *h, uint64_t k)
{
    if (rc != QMC_ECANCELED)
        fail_msg("hook firing on call %llu: rc %d", (unsigned long long)k, rc);
    assert_int_equal(h->calls, k); /* not called again once it fired */
    assert_true(res->estimate == 0.0 && res->error == 0.0 && res->n == 0);
    assert_int_equal(res->evals, seen->calls);
    assert_int_equal(seen->calls, h->evals_at_fire);
}

static void test_gk_interrupt(void **state)
{
    (void)state;
    /* cos(5000 x) to 1e-13: 846 bisections, nine hook calls. */
    const uint64_t batch = 2 * 21; /* one bisection */
    gk_run plain = run_gk(F_COS, 5000.0, 1e-13, 0.0, 5000, 21, UINT64_MAX);
    assert_int_equal(plain.rc, 0);
    test_hook h;
    gk_run never = run_gk_hook(F_COS, 5000.0, 1e-13, 0.0, 5000, 21, UINT64_MAX, &h, 0);
    assert_int_equal(never.rc, 0);
    assert_true(test_same_result(&plain.res, &never.res));
    const uint64_t calls = h.calls;
    assert_true(calls >= 4);
    assert_true(calls <= 2 + plain.res.evals / QMC_INTERRUPT_EVALS);
    assert_true(h.max_gap <= QMC_INTERRUPT_EVALS + batch);
    for (uint64_t k = 1; k <= calls; k++) {
        gk_run g = run_gk_hook(F_COS, 5000.0, 1e-13, 0.0, 5000, 21, UINT64_MAX, &h, k);
        check_stopped(g.rc, &g.res, &g.seen, &h, k);
        assert_true(g.res.evals <= (k - 1) * (QMC_INTERRUPT_EVALS + batch));
        assert_true(k > 1 || g.res.evals == 0); /* the first call comes first */
    }
    /* One call more than a full run makes: it never fires. */
    gk_run last = run_gk_hook(F_COS, 5000.0, 1e-13, 0.0, 5000, 21, UINT64_MAX, &h, calls + 1);
    assert_int_equal(last.rc, 0);
    assert_true(test_same_result(&plain.res, &last.res));
}

static void test_tensor_interrupt(void **state)
{
    (void)state;
    probe seen;
    char why[160];
    int rc;
    test_hook h;
    const uint64_t batch = 256; /* the tensor rule's chunk */
    /* Every rule, 40^3 + 20^3 points: identical bits with a silent hook,
     * stopped on call K for a few K. */
    const struct { qmc_rule1d rule; uint32_t n; } cases[] = {
        {QMC_RULE1D_MIDPOINT, 40}, {QMC_RULE1D_TRAPEZOID, 41},
        {QMC_RULE1D_SIMPSON, 41}, {QMC_RULE1D_GAUSS_LEGENDRE, 40}};
    for (int i = 0; i < 4; i++) {
        qmc_result plain = run_tensor(F_COS, 2.0, 3, cases[i].rule, cases[i].n, 1000000,
                                      &rc, &seen, why, sizeof why);
        assert_int_equal(rc, 0);
        qmc_result never = run_tensor_hook(F_COS, 2.0, 3, cases[i].rule, cases[i].n,
                                           1000000, &rc, &seen, why, sizeof why, &h, 0);
        assert_int_equal(rc, 0);
        assert_true(test_same_result(&plain, &never));
        assert_true(h.calls >= 1 + plain.evals / (QMC_INTERRUPT_EVALS + batch));
        assert_true(h.max_gap <= QMC_INTERRUPT_EVALS + batch);
        const uint64_t calls = h.calls;
        const uint64_t ks[] = {1, 2, calls / 2, calls};
        for (int j = 0; j < 4; j++) {
            qmc_result r = run_tensor_hook(F_COS, 2.0, 3, cases[i].rule, cases[i].n,
                                           1000000, &rc, &seen, why, sizeof why, &h, ks[j]);
            check_stopped(rc, &r, &seen, &h, ks[j]);
            assert_non_null(strstr(why, "stopped by the interrupt hook"));
            assert_true(r.evals < plain.evals);
        }
    }
    /* Gauss-Legendre nodes for n = 4000 (and 2000 for the error) take
     * tens of millions of recurrence steps before the first evaluation:
     * the hook stops them there. */
    qmc_result r = run_tensor_hook(F_EXP, 0.0, 1, QMC_RULE1D_GAUSS_LEGENDRE, 4000, 1000000,
                                   &rc, &seen, why, sizeof why, &h, 0);
    assert_int_equal(rc, 0);
    assert_int_equal(r.evals, 4000 + 2000 + 2001 + 2002 + 32); /* levels, check */
    assert_true(h.calls > 1000); /* the nodes polled it, not just the points */
    r = run_tensor_hook(F_EXP, 0.0, 1, QMC_RULE1D_GAUSS_LEGENDRE, 4000, 1000000, &rc, &seen,
                        why, sizeof why, &h, 100);
    check_stopped(rc, &r, &seen, &h, 100);
    assert_int_equal(seen.calls, 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rule_names),
        cmocka_unit_test(test_degree_of_exactness),
        cmocka_unit_test(test_convergence_orders),
        cmocka_unit_test(test_gauss_legendre_exponential),
        cmocka_unit_test(test_gauss_legendre_vectors),
        cmocka_unit_test(test_gk_kronrod_degree),
        cmocka_unit_test(test_gk_smooth),
        cmocka_unit_test(test_gk_endpoint_singular),
        cmocka_unit_test(test_gk_strong_singularity),
        cmocka_unit_test(test_gk_step),
        cmocka_unit_test(test_gk_roundoff),
        cmocka_unit_test(test_gk_budget_and_errors),
        cmocka_unit_test(test_tensor_workspace_per_rule),
        cmocka_unit_test(test_tensor_accuracy),
        cmocka_unit_test(test_tensor_budget),
        cmocka_unit_test(test_gk_interrupt),
        cmocka_unit_test(test_tensor_interrupt),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
