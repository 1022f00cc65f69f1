/*
 * test_stability.c - the stability suite: every way a method can fail
 * must raise its flag or return its error, through qmc_integrate (what
 * the CLI and the daemon run), and a well-posed control case must raise
 * nothing.
 *
 *   failure mode                                   must produce
 *   non-finite integrand values                    nonfinite + error_unreliable
 *   infinite variance (x^-1/2 by plain MC)         heavy_tail + error_unreliable
 *   a net with N not a power of two                not_pow2
 *   plain Halton past its known-good dimensions    dims_past_good
 *   too few RQMC randomizations                    few_reps
 *   quadrature that cannot reach its tolerance     not_converged (+ max_subdiv
 *                                                  or roundoff or budget)
 *   adaptive sampling out of budget                budget + not_converged
 *   cubature out of region memory                  memory_bound + not_converged
 *   a tensor rule whose cost exceeds the budget    QMC_EBUDGET, refused first
 *   gauss-kronrod on a 2D integrand                QMC_EDIMS
 *   a rule's bar across a kink or a jump           error_unreliable
 * and the silent failures of issue 13's audit, each with the audit's own
 * parameters (--max-evals 2e7 --seed 12345) and some of ours; every case
 * also checks that the interval covers an independent closed form or is
 * flagged:
 *   1. every node of a rule misses a narrow peak    unresolved (auto: rqmc
 *                                                  with the rest, covering)
 *   2. every sample zero, a spread of exactly 0     few_nonzero, zero_spread
 *                                                  (adaptive: keeps going)
 *   3. n below the heavy-tail test's minimum        tail_untested
 *   4. a MIS technique that never samples its share mis_undersampled
 *   5. stratified at d >= 13; sums that overflow    refused; nonfinite
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
#include "qmc/scene.h"
#include "qmc/testfn.h"

typedef struct run_out {
    int err;
    qmc_integrate_report rep;
    char why[256];
} run_out;

static run_out run(const char *name, uint32_t dims, qmc_method method,
                   void (*tweak)(qmc_integrate_spec *))
{
    qmc_testfn *fn = NULL;
    char why[256];
    if (qmc_testfn_new(name, dims, NULL, 0, NULL, 0, &fn, why, sizeof why) != 0)
        fail_msg("%s", why);
    qmc_integrate_spec s;
    qmc_integrate_spec_init(&s);
    s.method = method;
    if (method == QMC_METHOD_RQMC) {
        qmc_sampling_spec_init(&s.sampling, QMC_SAMPLER_RQMC);
    }
    if (tweak)
        tweak(&s);
    run_out o;
    memset(&o, 0, sizeof o);
    o.err = qmc_integrate(&s, qmc_testfn_integrand(fn), NULL, NULL, NULL, &o.rep, o.why,
                          sizeof o.why);
    qmc_testfn_free(fn);
    return o;
}

static void n_100000(qmc_integrate_spec *s) { s->sampling.n = 100000, s->n_given = 1; }
static void n_1000(qmc_integrate_spec *s) { s->sampling.n = 1000, s->n_given = 1; }
static void halton_plain(qmc_integrate_spec *s)
{
    s->sampling.seq = QMC_SEQ_HALTON;
    s->sampling.n = 1024;
    s->n_given = 1;
}
static void four_reps(qmc_integrate_spec *s) { s->sampling.reps = 4; }
static void tight_small_budget(qmc_integrate_spec *s)
{
    s->tol_rel = 1e-15;
    s->max_evals = 2000;
}
static void tol_1e12_budget_1e5(qmc_integrate_spec *s)
{
    s->tol_rel = 1e-12;
    s->max_evals = 100000;
    s->sampling.n = 1024;
    s->n_given = 1;
}
static void tiny_heap(qmc_integrate_spec *s)
{
    s->tol_rel = 1e-14;
    s->max_memory = 65536;
}
static void n_axis_64(qmc_integrate_spec *s) { s->n_axis = 64; }

#define ASSERT_FLAGS(o, want)                                                   \
    do {                                                                        \
        if ((o).err)                                                            \
            fail_msg("unexpected error %d: %s", (o).err, (o).why);              \
        if (((o).rep.res.flags & (want)) != (want))                             \
            fail_msg("flags 0x%x lack 0x%x", (o).rep.res.flags, (unsigned)(want)); \
    } while (0)

static void test_nonfinite(void **state)
{
    (void)state;
    /* Plain Sobol's first point is the origin, where log x = -inf. */
    run_out o = run("log", 1, QMC_METHOD_QMC, n_1000);
    ASSERT_FLAGS(o, QMC_FLAG_NONFINITE | QMC_FLAG_ERROR_UNRELIABLE);
    assert_int_equal(o.rep.res.nonfinite, 1);
}

static void test_heavy_tail(void **state)
{
    (void)state;
    run_out o = run("inv-sqrt", 1, QMC_METHOD_MC, n_100000);
    ASSERT_FLAGS(o, QMC_FLAG_HEAVY_TAIL | QMC_FLAG_ERROR_UNRELIABLE);
}

static void test_not_pow2(void **state)
{
    (void)state;
    run_out o = run("genz-gaussian", 3, QMC_METHOD_QMC, n_1000);
    ASSERT_FLAGS(o, QMC_FLAG_NOT_POW2);
    assert_int_equal(o.rep.res.error_kind, QMC_ERROR_NONE);
}

static void test_dims_past_good(void **state)
{
    (void)state;
    run_out o = run("genz-gaussian", 12, QMC_METHOD_QMC, halton_plain);
    ASSERT_FLAGS(o, QMC_FLAG_DIMS_PAST_GOOD);
}

static void test_few_reps(void **state)
{
    (void)state;
    run_out o = run("genz-gaussian", 3, QMC_METHOD_RQMC, four_reps);
    ASSERT_FLAGS(o, QMC_FLAG_FEW_REPS);
}

static void test_quadrature_not_converged(void **state)
{
    (void)state;
    run_out o = run("step", 1, QMC_METHOD_GAUSS_KRONROD, tight_small_budget);
    ASSERT_FLAGS(o, QMC_FLAG_NOT_CONVERGED);
    /* The best estimate is still there, with an error estimate that covers
     * the true error. */
    assert_true(isfinite(o.rep.res.estimate));
    assert_true(fabs(o.rep.res.estimate - 0.3) <= o.rep.res.error);
}

static void test_sampling_budget(void **state)
{
    (void)state;
    run_out o = run("genz-gaussian", 4, QMC_METHOD_RQMC, tol_1e12_budget_1e5);
    ASSERT_FLAGS(o, QMC_FLAG_BUDGET | QMC_FLAG_NOT_CONVERGED);
    assert_true(o.rep.res.evals <= 100000);
}

static void test_cubature_memory_bound(void **state)
{
    (void)state;
    run_out o = run("genz-corner-peak", 6, QMC_METHOD_CUBATURE, tiny_heap);
    ASSERT_FLAGS(o, QMC_FLAG_MEMORY_BOUND | QMC_FLAG_NOT_CONVERGED);
    assert_true(isfinite(o.rep.res.estimate));
}

static void test_refusals(void **state)
{
    (void)state;
    run_out o = run("genz-gaussian", 8, QMC_METHOD_GAUSS_LEGENDRE, n_axis_64);
    assert_int_equal(o.err, QMC_EBUDGET);
    assert_int_equal(o.rep.res.evals, 0); /* refused before evaluating */
    assert_non_null(strstr(o.why, "64^8"));
    o = run("genz-gaussian", 2, QMC_METHOD_GAUSS_KRONROD, NULL);
    assert_int_equal(o.err, QMC_EDIMS);
    assert_non_null(strstr(o.why, "1D"));
}

/* Two polynomial rules can agree across a kink while both are wrong:
 * the bar of an integrand declared continuous (Genz continuous) is
 * flagged, that of an analytic one (Genz gaussian) is not. */
static void test_rule_bar_across_kink(void **state)
{
    (void)state;
    run_out o = run("genz-continuous", 3, QMC_METHOD_CUBATURE, NULL);
    assert_int_equal(o.err, 0);
    ASSERT_FLAGS(o, QMC_FLAG_ERROR_UNRELIABLE);
    o = run("genz-gaussian", 3, QMC_METHOD_CUBATURE, NULL);
    assert_int_equal(o.err, 0);
    assert_false(o.rep.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
}

/* The control: a smooth integrand by RQMC raises no flag at all. */
static void test_clean_run_raises_nothing(void **state)
{
    (void)state;
    run_out o = run("genz-gaussian", 5, QMC_METHOD_RQMC, NULL);
    assert_int_equal(o.err, 0);
    assert_int_equal(o.rep.res.flags, 0);
    o = run("genz-oscillatory", 3, QMC_METHOD_AUTO, NULL);
    assert_int_equal(o.err, 0);
    assert_int_equal(o.rep.res.flags, 0);
    assert_int_equal(o.rep.method_used, QMC_METHOD_CLENSHAW_CURTIS);
}

/* auto follows the crossovers measured in core/integrate.c: tensor
 * Clenshaw-Curtis for analytic integrands once the budget buys 17^d
 * points, cubature for the others up to 10 dims once it buys one region, for
 * continuous ones up to 4 dims (50 regions), RQMC otherwise. */
static uint64_t auto_budget;

static void set_auto_budget(qmc_integrate_spec *s)
{
    s->max_evals = auto_budget;
    s->tol_rel = 1e-3;
}

static qmc_method auto_picks(const char *name, uint32_t dims, uint64_t budget)
{
    auto_budget = budget;
    run_out o = run(name, dims, QMC_METHOD_AUTO, set_auto_budget);
    assert_int_equal(o.err, 0);
    return o.rep.method_used;
}

static void test_auto_choice(void **state)
{
    (void)state;
    const uint64_t region10 = qmc_cubature_region_evals(10);
    assert_int_equal(region10, 1245);
    assert_int_equal(auto_picks("genz-gaussian", 10, region10), QMC_METHOD_CUBATURE);
    assert_int_equal(auto_picks("genz-gaussian", 4, 83521), QMC_METHOD_CLENSHAW_CURTIS);
    assert_int_equal(auto_picks("genz-gaussian", 4, 83520), QMC_METHOD_CUBATURE);
    assert_int_equal(auto_picks("genz-oscillatory", 2, 10000), QMC_METHOD_CLENSHAW_CURTIS);
    assert_int_equal(auto_picks("genz-continuous", 2, 10000), QMC_METHOD_CUBATURE);
    assert_int_equal(auto_picks("genz-gaussian", 10, region10 - 1), QMC_METHOD_RQMC);
    assert_int_equal(auto_picks("genz-oscillatory", 11, 100000000), QMC_METHOD_RQMC);
    assert_int_equal(auto_picks("genz-continuous", 4, 1000000), QMC_METHOD_CUBATURE);
    assert_int_equal(auto_picks("genz-continuous", 4,
                                50 * qmc_cubature_region_evals(4) - 1), QMC_METHOD_RQMC);
    assert_int_equal(auto_picks("genz-continuous", 5, 1000000), QMC_METHOD_RQMC);
    assert_int_equal(auto_picks("genz-discontinuous", 2, 1000000), QMC_METHOD_RQMC);
    assert_int_equal(auto_picks("exp", 1, 1000), QMC_METHOD_GAUSS_KRONROD);
}


/* ---- issue 13: the audit's silent failures ------------------------------------------ */

/* Runs a test function with parameters a and u (n values each, or none)
 * under the audit's budget and seed, then tweak. */
static run_out run_au(const char *name, uint32_t dims, const double *a, const double *u,
                      qmc_method method, void (*tweak)(qmc_integrate_spec *))
{
    qmc_testfn *fn = NULL;
    char why[256];
    if (qmc_testfn_new(name, dims, a, a ? dims : 0, u, u ? dims : 0, &fn, why, sizeof why) != 0)
        fail_msg("%s", why);
    qmc_integrate_spec s;
    qmc_integrate_spec_init(&s);
    s.method = method;
    if (method == QMC_METHOD_RQMC)
        qmc_sampling_spec_init(&s.sampling, QMC_SAMPLER_RQMC);
    s.max_evals = 20000000;
    s.sampling.seed = 12345;
    if (tweak)
        tweak(&s);
    run_out o;
    memset(&o, 0, sizeof o);
    o.err = qmc_integrate(&s, qmc_testfn_integrand(fn), NULL, NULL, NULL, &o.rep, o.why,
                          sizeof o.why);
    qmc_testfn_free(fn);
    return o;
}

/* Each reported interval covers the truth, or its bar is flagged as one
 * that cannot be trusted: the two outcomes the issue accepts. */
#define ASSERT_COVERS_OR_FLAGGED(o, truth)                                            \
    do {                                                                              \
        const qmc_result *r_ = &(o).rep.res;                                          \
        int covers_ = r_->ci_low <= (truth) && (truth) <= r_->ci_high;                \
        if (!covers_ && !(r_->flags & QMC_FLAG_ERROR_UNRELIABLE))                     \
            fail_msg("%.17g not in [%.17g, %.17g] and flags 0x%x", (double)(truth),   \
                     r_->ci_low, r_->ci_high, r_->flags);                             \
    } while (0)

/* Closed forms written here, apart from the library's: the Genz Gaussian
 * exp(-sum a^2 (x - u)^2) integrates to prod sqrt(pi) / (2a) (erf(a(1-u))
 * + erf(a u)); the discontinuous family exp(sum a x) on x1 < u1, x2 < u2
 * (0 elsewhere) to prod_{j<2} (e^{a u} - 1) / a times prod_{j>=2}
 * (e^a - 1) / a. */
static double gaussian_truth(uint32_t d, const double *a, const double *u)
{
    double p = 1.0;
    for (uint32_t j = 0; j < d; j++)
        p *= sqrt(3.14159265358979323846) / (2.0 * a[j]) * (erf(a[j] * (1.0 - u[j])) + erf(a[j] * u[j]));
    return p;
}

static double discontinuous_truth(uint32_t d, const double *a, const double *u)
{
    double p = 1.0;
    for (uint32_t j = 0; j < d; j++)
        p *= j < 2 ? expm1(a[j] * u[j]) / a[j] : expm1(a[j]) / a[j];
    return p;
}

static const qmc_method rules[] = {
    QMC_METHOD_CLENSHAW_CURTIS, QMC_METHOD_CUBATURE, QMC_METHOD_GAUSS_LEGENDRE,
    QMC_METHOD_MIDPOINT,        QMC_METHOD_TRAPEZOID, QMC_METHOD_SIMPSON,
};

/* Class 1: the peak a = 400 is 1/400 wide; Clenshaw-Curtis's 5 x 5 nodes,
 * cubature's 17 and the tensor rules' 16^2 all miss it, and their two
 * levels agree at (near) zero. */
static void test_rules_miss_narrow_peak(void **state)
{
    (void)state;
    const double a2[] = {400, 400}, u2[] = {0.123, 0.777};
    const double truth = gaussian_truth(2, a2, u2);
    assert_true(fabs(truth - 1.96349540849362e-05) < 1e-15);
    for (size_t i = 0; i < sizeof rules / sizeof rules[0]; i++) {
        run_out o = run_au("genz-gaussian", 2, a2, u2, rules[i], NULL);
        ASSERT_FLAGS(o, QMC_FLAG_UNRESOLVED | QMC_FLAG_ERROR_UNRELIABLE);
        assert_true(o.rep.res.ci_high < truth); /* wrong: the flag is what saves it */
    }
    /* Gauss-Legendre in 1D: 2.5e-6 +- 2.5e-6 where the truth is 5.9e-3. */
    const double a1[] = {300}, u1[] = {0.37};
    run_out o = run_au("genz-gaussian", 1, a1, u1, QMC_METHOD_GAUSS_LEGENDRE, NULL);
    ASSERT_FLAGS(o, QMC_FLAG_UNRESOLVED | QMC_FLAG_ERROR_UNRELIABLE);
    ASSERT_COVERS_OR_FLAGGED(o, gaussian_truth(1, a1, u1));
}

static void budget_2e6(qmc_integrate_spec *s) { s->max_evals = 2000000; }

/* auto does more work instead: its rule saw nothing, so it spends the rest
 * of the budget on RQMC, which finds the peak and covers the truth. */
static void test_auto_finds_missed_peak(void **state)
{
    (void)state;
    const double a2[] = {400, 400}, u2[] = {0.123, 0.777};
    run_out o = run_au("genz-gaussian", 2, a2, u2, QMC_METHOD_AUTO, NULL);
    assert_int_equal(o.err, 0);
    assert_int_equal(o.rep.method_used, QMC_METHOD_RQMC);
    assert_non_null(strstr(o.rep.auto_reason, "left the integrand unresolved"));
    assert_false(o.rep.res.flags & QMC_FLAG_UNRESOLVED);
    double truth = gaussian_truth(2, a2, u2);
    assert_true(o.rep.res.ci_low <= truth && truth <= o.rep.res.ci_high);
    assert_true(o.rep.res.estimate > 0.5 * truth);
    /* Ours: a 3D peak (cubature, then Clenshaw-Curtis's choice) and a 1D
     * one that Gauss-Kronrod's 21 nodes miss, on a smaller budget. */
    const double a3[] = {200, 200, 200}, u3[] = {0.37, 0.61, 0.29};
    o = run_au("genz-gaussian", 3, a3, u3, QMC_METHOD_AUTO, budget_2e6);
    assert_int_equal(o.rep.method_used, QMC_METHOD_RQMC);
    ASSERT_COVERS_OR_FLAGGED(o, gaussian_truth(3, a3, u3));
    const double a1[] = {30000}, u1[] = {0.37};
    o = run_au("genz-gaussian", 1, a1, u1, QMC_METHOD_AUTO, budget_2e6);
    assert_int_equal(o.rep.method_used, QMC_METHOD_RQMC);
    ASSERT_COVERS_OR_FLAGGED(o, gaussian_truth(1, a1, u1));
    assert_true(o.rep.res.estimate > 0.0);
}

/* Class 1, partly resolved: explicit cubature found most of a narrow 2D
 * peak and refined it, while two regions beside it, long along the axis
 * where the peak is 1/125 wide, kept every node in its tail: 8.56e-6 +-
 * 8.5e-14 against 1.02e-5.  Now the splits that proved a bar blind make
 * such regions suspects that are split once more along their longest
 * axis (cubature.c, mark_suspects), and the run finds the mass: the
 * interval covers the truth, unflagged.  A 1D peak whose root saw 7e-22
 * and whose halves saw 0 reported 0 +- 0, unflagged; it is unresolved
 * now.  The control: a wide Gaussian the rule resolves stays unflagged. */
static void test_cubature_partial_peak(void **state)
{
    (void)state;
    const double a2[] = {124.8, 2465}, u2[] = {0.7062, 0.5042};
    run_out o = run_au("genz-gaussian", 2, a2, u2, QMC_METHOD_CUBATURE, NULL);
    double truth = gaussian_truth(2, a2, u2);
    assert_int_equal(o.err, 0);
    assert_true(fabs(o.rep.res.estimate - truth) <= 3 * o.rep.res.error);
    ASSERT_COVERS_OR_FLAGGED(o, truth);
    const double a1[] = {2371}, u1[] = {0.9714};
    o = run_au("genz-gaussian", 1, a1, u1, QMC_METHOD_CUBATURE, NULL);
    assert_true(o.rep.res.estimate == 0.0);
    ASSERT_FLAGS(o, QMC_FLAG_UNRESOLVED | QMC_FLAG_ERROR_UNRELIABLE);
    ASSERT_COVERS_OR_FLAGGED(o, gaussian_truth(1, a1, u1));
    const double a3[] = {12, 9, 15}, u3[] = {0.31, 0.62, 0.47};
    o = run_au("genz-gaussian", 3, a3, u3, QMC_METHOD_CUBATURE, NULL);
    assert_int_equal(o.rep.res.flags, 0);
    truth = gaussian_truth(3, a3, u3);
    assert_true(fabs(o.rep.res.estimate - truth) <= 3 * o.rep.res.error);
}

/* The control: a peak the rules resolve (a = 50) raises no unresolved. */
static void test_resolved_peak_not_flagged(void **state)
{
    (void)state;
    const double a2[] = {50, 50}, u2[] = {0.37, 0.37};
    run_out o = run_au("genz-gaussian", 2, a2, u2, QMC_METHOD_CUBATURE, NULL);
    assert_int_equal(o.err, 0);
    assert_int_equal(o.rep.res.flags, 0);
    double truth = gaussian_truth(2, a2, u2);
    assert_true(fabs(o.rep.res.estimate - truth) <= 3 * o.rep.res.error + 1e-15);
    o = run_au("genz-gaussian", 2, a2, u2, QMC_METHOD_AUTO, NULL);
    assert_int_equal(o.rep.method_used, QMC_METHOD_CLENSHAW_CURTIS);
    assert_int_equal(o.rep.res.flags, 0);
}

/* Class 2: a support of 6e-6 that 4096 points all miss: 0 +- 0. */
static void test_zero_samples_flagged(void **state)
{
    (void)state;
    const double a[] = {1, 1}, u[] = {0.003, 0.002};
    const double truth = discontinuous_truth(2, a, u);
    const qmc_method m[] = {QMC_METHOD_MC, QMC_METHOD_STRATIFIED, QMC_METHOD_LHS,
                            QMC_METHOD_RQMC};
    for (size_t i = 0; i < sizeof m / sizeof m[0]; i++) {
        run_out o = run_au("genz-discontinuous", 2, a, u, m[i], NULL);
        ASSERT_FLAGS(o, QMC_FLAG_FEW_NONZERO | QMC_FLAG_ERROR_UNRELIABLE);
        ASSERT_COVERS_OR_FLAGGED(o, truth);
    }
    run_out o = run_au("genz-discontinuous", 2, a, u, QMC_METHOD_MC, NULL);
    assert_true(o.rep.res.estimate == 0.0 && o.rep.res.error == 0.0);
    ASSERT_FLAGS(o, QMC_FLAG_ZERO_SPREAD);
    /* Ours: the same support in 4 dims by LHS. */
    const double a4[] = {1, 1, 1, 1}, u4[] = {0.003, 0.002, 0.5, 0.5};
    o = run_au("genz-discontinuous", 4, a4, u4, QMC_METHOD_LHS, NULL);
    ASSERT_FLAGS(o, QMC_FLAG_FEW_NONZERO | QMC_FLAG_ERROR_UNRELIABLE);
    ASSERT_COVERS_OR_FLAGGED(o, discontinuous_truth(4, a4, u4));
}

static void tol_rel_1e3(qmc_integrate_spec *s) { s->tol_rel = 1e-3; }

/* ... and 0 +- 0 no longer meets a tolerance: the adaptive loop (auto's
 * and any sampler's) keeps doubling until the points find the support. */
static void test_zero_spread_not_tolerance_met(void **state)
{
    (void)state;
    const double a[] = {1, 1}, u[] = {0.003, 0.002};
    const double truth = discontinuous_truth(2, a, u);
    run_out o = run_au("genz-discontinuous", 2, a, u, QMC_METHOD_AUTO, NULL);
    assert_int_equal(o.err, 0);
    assert_true(o.rep.res.estimate > 0.0);
    assert_true(o.rep.res.ci_low <= truth && truth <= o.rep.res.ci_high);
    assert_false(o.rep.res.flags & QMC_FLAG_FEW_NONZERO);
    o = run_au("genz-discontinuous", 2, a, u, QMC_METHOD_MC, tol_rel_1e3);
    assert_true(o.rep.res.evals > 4096);
    ASSERT_COVERS_OR_FLAGGED(o, truth);
}

static void split_8x131072(qmc_integrate_spec *s)
{
    s->sampling.reps = 8;
    s->sampling.n = 131072;
    s->sampling.split_net = 1;
    s->n_given = 1;
}

/* Class 2, split nets: the step at 0.7071 by 8 blocks of one scrambled
 * 1D net - each block a (0, 17, 1)-net, so each holds floor or ceil of
 * 0.7071 n points below the step, and here all 8 hold the same count:
 * the means agree exactly (what auto reported as 0.70709991 +- 0). */
static void test_split_net_zero_spread(void **state)
{
    (void)state;
    const double u[] = {0.7071};
    run_out o = run_au("step", 1, NULL, u, QMC_METHOD_RQMC, split_8x131072);
    ASSERT_FLAGS(o, QMC_FLAG_ZERO_SPREAD | QMC_FLAG_ERROR_UNRELIABLE);
    assert_true(o.rep.res.error == 0.0);
    ASSERT_COVERS_OR_FLAGGED(o, 0.7071);
    /* auto (split nets, adaptive) no longer stops on that spread. */
    o = run_au("step", 1, NULL, u, QMC_METHOD_AUTO, NULL);
    assert_int_equal(o.err, 0);
    assert_true(o.rep.res.error > 0.0);
    ASSERT_COVERS_OR_FLAGGED(o, 0.7071);
}

static void n_16(qmc_integrate_spec *s) { s->sampling.n = 16, s->n_given = 1; }
static void n_64(qmc_integrate_spec *s) { s->sampling.n = 64, s->n_given = 1; }

/* Class 3: below 80 points for a declared singularity (160 for a bounded
 * integrand), or 9 nonzero values, the tail test cannot run; x^-1/2 by
 * MC at n = 16 gave 1.37 +- 0.085 against 2 with no flag. */
static void test_tail_untested_small_n(void **state)
{
    (void)state;
    run_out o = run_au("inv-sqrt", 1, NULL, NULL, QMC_METHOD_MC, n_16);
    ASSERT_FLAGS(o, QMC_FLAG_TAIL_UNTESTED);
    o = run_au("inv-sqrt", 1, NULL, NULL, QMC_METHOD_LHS, n_64);
    ASSERT_FLAGS(o, QMC_FLAG_TAIL_UNTESTED);
    /* Over seeds at n <= 128 every run is flagged one way or the other:
     * none misses silently. */
    for (uint64_t seed = 1; seed <= 40; seed++) {
        qmc_testfn *fn = NULL;
        char why[128];
        assert_int_equal(qmc_testfn_new("inv-sqrt", 1, NULL, 0, NULL, 0, &fn, why, sizeof why),
                         0);
        qmc_integrate_spec s;
        qmc_integrate_spec_init(&s);
        s.method = QMC_METHOD_MC;
        s.sampling.seed = seed;
        s.sampling.n = 16 << (seed % 4); /* 16 .. 128 */
        s.n_given = 1;
        qmc_integrate_report rep;
        assert_int_equal(qmc_integrate(&s, qmc_testfn_integrand(fn), NULL, NULL, NULL, &rep, why,
                                       sizeof why), 0);
        assert_true(rep.res.flags & (QMC_FLAG_TAIL_UNTESTED | QMC_FLAG_HEAVY_TAIL));
        qmc_testfn_free(fn);
    }
    /* The tail test itself now runs on sparse integrands: the Genz
     * Gaussian with n = 4096 has all values nonzero and a light tail. */
    o = run("genz-gaussian", 3, QMC_METHOD_MC, NULL);
    assert_false(o.rep.res.flags & (QMC_FLAG_TAIL_UNTESTED | QMC_FLAG_HEAVY_TAIL));
}

/* One plain-MC run of a 1D test function at n points: whether it missed
 * its closed form by more than 3 reported errors, and its flags. */
static uint32_t mc_run(const char *name, uint64_t seed, uint64_t n, int *missed)
{
    qmc_testfn *fn = NULL;
    char why[128];
    assert_int_equal(qmc_testfn_new(name, 1, NULL, 0, NULL, 0, &fn, why, sizeof why), 0);
    qmc_integrate_spec s;
    qmc_integrate_spec_init(&s);
    s.method = QMC_METHOD_MC;
    s.sampling.seed = seed;
    s.sampling.n = n;
    s.n_given = 1;
    qmc_integrate_report rep;
    assert_int_equal(qmc_integrate(&s, qmc_testfn_integrand(fn), NULL, NULL, NULL, &rep, why,
                                   sizeof why), 0);
    /* Closed forms: int x^-1/2 = 2, int ln x = -1. */
    const double truth = strcmp(name, "inv-sqrt") == 0 ? 2.0 : -1.0;
    *missed = !(fabs(rep.res.estimate - truth) <= 3.0 * rep.res.error);
    qmc_testfn_free(fn);
    return rep.res.flags;
}

/* Class 3, the test's power: the heavy-tail test for a declared
 * singularity runs at 99% on up to n / 10 values (sampling_finish.c).
 * Over 100 seeds at n = 128 plain MC on x^-1/2 missed by more than 3
 * reported errors without error_unreliable 6 times before (tail_untested
 * alone does not make a bar unreliable, and a 95% test passes one run in
 * 20, the runs that lack the large values); now at most 2.  The control:
 * ln x, singular but with every moment finite, stays mostly unflagged at
 * n = 1024 (2 of 100 flagged). */
static void test_heavy_tail_power(void **state)
{
    (void)state;
    int silent = 0, flagged = 0;
    for (uint64_t seed = 1; seed <= 100; seed++) {
        int missed;
        uint32_t fl = mc_run("inv-sqrt", seed, 128, &missed);
        silent += missed && !(fl & QMC_FLAG_ERROR_UNRELIABLE);
    }
    assert_true(silent <= 2);
    for (uint64_t seed = 1; seed <= 100; seed++) {
        int missed;
        flagged += (mc_run("log", seed, 1024, &missed) & QMC_FLAG_HEAVY_TAIL) != 0;
    }
    assert_true(flagged <= 10);
}

/* ---- scenes ---- */

typedef struct scene_out {
    int err;
    qmc_integrate_report rep;
    char why[256];
    double truth;
} scene_out;

/* The audit's budget unless a case lowers it (seconds, not minutes). */
static uint64_t scene_budget = 20000000;

static scene_out run_scene(const char *text, qmc_scene_strategy st, double beta,
                           qmc_method method, uint64_t n)
{
    qmc_scene sc;
    qmc_scene_job job;
    char why[256];
    if (qmc_scene_parse(text, strlen(text), &sc, why, sizeof why) != 0)
        fail_msg("%s", why);
    if (qmc_scene_integrand(&sc, st, beta, 1, 1, &job, why, sizeof why) != 0)
        fail_msg("%s", why);
    scene_out o;
    memset(&o, 0, sizeof o);
    /* No closed form (a Phong lobe under a rect): NAN, which no interval
     * covers, so a case on such a scene must be flagged. */
    if (qmc_scene_exact(&sc, &o.truth) != 0)
        o.truth = NAN;
    qmc_integrate_spec s;
    qmc_integrate_spec_init(&s);
    s.method = method;
    if (method == QMC_METHOD_RQMC)
        qmc_sampling_spec_init(&s.sampling, QMC_SAMPLER_RQMC);
    s.max_evals = scene_budget;
    s.sampling.seed = 12345;
    if (n) {
        s.sampling.n = n;
        s.n_given = 1;
    }
    o.err = qmc_integrate(&s, &job.integrand, NULL, NULL, NULL, &o.rep, o.why, sizeof o.why);
    return o;
}

/* Class 5, zero_pdf: reachable, by one floating-point gap in the model's
 * argument (scene_eval.c) that the audit exists to catch.  With kd = 0
 * the BRDF density is the power-cosine lobe alone, (n + 1) / (2 pi)
 * cos^n(alpha); for n < 2.14 that factor is below 1/2, so where cos^n
 * rounds to the smallest subnormal the density rounds to 0, while the
 * shade, ks (n + 2) / (2 pi) > 1/2 times the same power, keeps it and a
 * radiance of 1e300 lifts it to 4e-24.  cos(alpha) must then be about
 * 2e-162 at a light direction: the normal along x and the view (1, 1,
 * -4.4e-162) make r = (0.71, -0.71, 2.2e-162), and the rect's grid row
 * with x = y (exact in binary) makes the first two products of w . r
 * cancel exactly, leaving w_z r_z.  The mass lost is 1e-300 of the
 * integral, but it is mass the brdf estimator can never draw, and the
 * flag says so; uniform sampling, positive there, is not flagged. */
static const char zero_pdf_scene[] =
    "point 0 0 0\nnormal 1 0 0\nview 1 1 -4.4e-162\n"
    "brdf phong kd 0 ks 1 exponent 2\n"
    "light rect corner 0.25 0.7578125 1 edge1 0.5 0.5 0 edge2 1 0 0 radiance 1e300\n";

static void test_zero_pdf_reachable(void **state)
{
    (void)state;
    scene_out o = run_scene(zero_pdf_scene, QMC_SCENE_BRDF, 0, QMC_METHOD_MC, 4096);
    assert_int_equal(o.err, 0);
    ASSERT_FLAGS(o, QMC_FLAG_ZERO_PDF | QMC_FLAG_ERROR_UNRELIABLE);
    ASSERT_COVERS_OR_FLAGGED(o, o.truth);
    assert_true(isnan(o.truth)); /* so the line above demanded the flag */
    o = run_scene(zero_pdf_scene, QMC_SCENE_UNIFORM, 0, QMC_METHOD_MC, 4096);
    assert_int_equal(o.err, 0);
    assert_false(o.rep.res.flags & QMC_FLAG_ZERO_PDF);
}

/* Lambert under a sphere light of radius 0.005 at distance 5.1: 1e-6 of
 * the hemisphere.  Closed form albedo L sin^2(alpha) cos(theta). */
static const char tiny_light[] = "point 0 0 0\nnormal 0 0 1\nbrdf lambert 0.8\n"
                                 "light sphere center 1 0.5 5 radius 0.005 radiance 10\n";

static double tiny_light_truth(void)
{
    double dist = sqrt(1.0 + 0.25 + 25.0), s = 0.005 / dist;
    return 0.8 * 10.0 * s * s * (5.0 / dist);
}

/* Class 2, scenes: uniform and BRDF sampling never reach the tiny light in
 * 4096 points: 0 +- 0. */
static void test_tiny_light_zero_flagged(void **state)
{
    (void)state;
    const qmc_scene_strategy st[] = {QMC_SCENE_UNIFORM, QMC_SCENE_BRDF};
    for (size_t i = 0; i < 2; i++) {
        scene_out o = run_scene(tiny_light, st[i], 0, QMC_METHOD_MC, 0);
        assert_true(fabs(o.truth - tiny_light_truth()) < 1e-12 * o.truth);
        ASSERT_FLAGS(o, QMC_FLAG_FEW_NONZERO | QMC_FLAG_ERROR_UNRELIABLE);
        ASSERT_COVERS_OR_FLAGGED(o, o.truth);
        /* auto keeps going until it finds the light or the budget ends. */
        scene_budget = 4000000;
        o = run_scene(tiny_light, st[i], 0, QMC_METHOD_AUTO, 0);
        scene_budget = 20000000;
        assert_true(o.rep.res.evals > 2000000); /* it did not stop at 0 +- 0 */
        ASSERT_COVERS_OR_FLAGGED(o, o.truth);
    }
}

/* Class 4: the balance heuristic gives the BRDF technique 1e-6 of the tiny
 * light, which its samples (one in 10^6 reaches the light) never see;
 * mis-power at beta 0.05 gives it 35% (33% low).  The default power
 * heuristic (beta 2) leaves it 1e-12 of the integral: not flagged. */
static void test_mis_undersampled(void **state)
{
    (void)state;
    scene_out o = run_scene(tiny_light, QMC_SCENE_MIS_BALANCE, 0, QMC_METHOD_AUTO, 0);
    ASSERT_FLAGS(o, QMC_FLAG_MIS_UNDERSAMPLED | QMC_FLAG_ERROR_UNRELIABLE);
    ASSERT_COVERS_OR_FLAGGED(o, o.truth);
    assert_false(o.rep.res.ci_low <= o.truth && o.truth <= o.rep.res.ci_high);
    o = run_scene(tiny_light, QMC_SCENE_MIS_POWER, 0.05, QMC_METHOD_AUTO, 0);
    ASSERT_FLAGS(o, QMC_FLAG_MIS_UNDERSAMPLED | QMC_FLAG_ERROR_UNRELIABLE);
    assert_true(o.rep.res.ci_high < 0.8 * o.truth);
    o = run_scene(tiny_light, QMC_SCENE_MIS_POWER, 0.05, QMC_METHOD_RQMC, 0);
    ASSERT_FLAGS(o, QMC_FLAG_MIS_UNDERSAMPLED);
    o = run_scene(tiny_light, QMC_SCENE_MIS_POWER, 0, QMC_METHOD_AUTO, 0);
    assert_false(o.rep.res.flags & QMC_FLAG_MIS_UNDERSAMPLED);
    assert_true(o.rep.res.ci_low <= o.truth && o.truth <= o.rep.res.ci_high);
    /* Ours: a large light, where BRDF samples reach it all the time. */
    static const char big[] = "point 0 0 0\nnormal 0 0 1\nbrdf lambert 0.8\n"
                              "light sphere center 1 0.5 5 radius 0.6 radiance 10\n";
    o = run_scene(big, QMC_SCENE_MIS_BALANCE, 0, QMC_METHOD_AUTO, 0);
    assert_int_equal(o.rep.res.flags & (QMC_FLAG_MIS_UNDERSAMPLED | QMC_FLAG_ZERO_PDF), 0);
}

/* Class 4, tiny budgets: a Phong lobe of exponent 5000 at n = 16. */
static void test_tiny_budget_flagged(void **state)
{
    (void)state;
    static const char phong[] = "point 0 0 0\nnormal 0 0 1\nview 0.6 0 0.8\n"
                                "brdf phong kd 0 ks 0.6 exponent 5000\n"
                                "light sphere center -2 0 2.6667 radius 0.8 radiance 8\n";
    qmc_scene sc;
    char why[256];
    assert_int_equal(qmc_scene_parse(phong, strlen(phong), &sc, why, sizeof why), 0);
    double ref = 0, ref_err = 0;
    int exact = 0;
    assert_int_equal(qmc_scene_reference(&sc, &ref, &ref_err, &exact), 0);
    const qmc_method m[] = {QMC_METHOD_MC, QMC_METHOD_LHS};
    const qmc_scene_strategy st[] = {QMC_SCENE_BRDF, QMC_SCENE_LIGHT, QMC_SCENE_MIS_POWER};
    for (size_t i = 0; i < 2; i++)
        for (size_t j = 0; j < 3; j++) {
            qmc_scene_job job;
            assert_int_equal(qmc_scene_integrand(&sc, st[j], 0, 1, 1, &job, why, sizeof why),
                             0);
            qmc_integrate_spec s;
            qmc_integrate_spec_init(&s);
            s.method = m[i];
            s.sampling.seed = 12345;
            s.sampling.n = 16;
            s.n_given = 1;
            qmc_integrate_report rep;
            assert_int_equal(qmc_integrate(&s, &job.integrand, NULL, NULL, NULL, &rep, why,
                                           sizeof why), 0);
            assert_true(rep.res.flags & QMC_FLAG_TAIL_UNTESTED);
        }
}

/* Light sampling of a light 3e-4 rad wide: the cone's 1 - cos is 4.5e-8,
 * and taken from cos it kept 2.5e-9 relative error, a bias 1000x the
 * RQMC bar (the stability matrix's tiny-light/light cell).  Now the
 * interval covers the closed form albedo L (r / D)^2 cos(theta). */
static void test_tiny_cone_no_roundoff_bias(void **state)
{
    (void)state;
    static const char tiny[] = "point 0 0 0\nnormal 0 0 1\nbrdf lambert albedo 0.8\n"
                               "light sphere center 0.3 0.2 10 radius 0.003 radiance 1e6\n";
    scene_out o = run_scene(tiny, QMC_SCENE_LIGHT, 0, QMC_METHOD_RQMC, 4096);
    double dist = sqrt(0.09 + 0.04 + 100.0), s = 0.003 / dist;
    double truth = 0.8 * 1e6 * s * s * (10.0 / dist);
    assert_true(fabs(o.truth - truth) <= 1e-14 * truth);
    assert_int_equal(o.err, 0);
    assert_int_equal(o.rep.res.flags, 0);
    assert_true(o.rep.res.ci_low <= truth && truth <= o.rep.res.ci_high);
}

/* Class 5: a radiance of 1e308 overflows the sums of finite values. */
static void test_overflow_nonfinite(void **state)
{
    (void)state;
    static const char hot[] = "point 0 0 0\nnormal 0 0 1\nbrdf lambert 0.8\n"
                              "light sphere center 1 0.5 5 radius 0.6 radiance 1e308\n";
    const qmc_method m[] = {QMC_METHOD_AUTO, QMC_METHOD_MC, QMC_METHOD_RQMC};
    for (size_t i = 0; i < 3; i++) {
        scene_out o = run_scene(hot, QMC_SCENE_MIS_POWER, 0, m[i], 0);
        assert_true(isfinite(o.truth));
        ASSERT_FLAGS(o, QMC_FLAG_NONFINITE | QMC_FLAG_ERROR_UNRELIABLE);
        if (m[i] == QMC_METHOD_AUTO) /* stops: more points will not help */
            assert_true(o.rep.res.evals <= 100000);
    }
}

/* Class 5: stratified at d >= 13 had one stratum of one point. */
static void test_stratified_refused_past_2_per_axis(void **state)
{
    (void)state;
    run_out o = run("genz-gaussian", 13, QMC_METHOD_STRATIFIED, NULL);
    assert_int_equal(o.err, QMC_ECOUNT);
    assert_non_null(strstr(o.why, "8192"));
    assert_int_equal(o.rep.res.evals, 0);
    o = run("genz-gaussian", 12, QMC_METHOD_STRATIFIED, NULL); /* 2^12 = 4096 fits */
    assert_int_equal(o.err, 0);
    assert_true(isfinite(o.rep.res.error));
}

/* Flags stay meaningful: a clean run per family of ordinary parameters
 * gains none of the new flags. */
static void test_new_flags_quiet_on_clean_runs(void **state)
{
    (void)state;
    const uint32_t fresh = QMC_FLAG_FEW_NONZERO | QMC_FLAG_ZERO_SPREAD | QMC_FLAG_TAIL_UNTESTED |
                           QMC_FLAG_UNRESOLVED | QMC_FLAG_MIS_UNDERSAMPLED | QMC_FLAG_ZERO_PDF;
    const char *fam[] = {"genz-oscillatory", "genz-product-peak", "genz-corner-peak",
                         "genz-gaussian",    "genz-continuous",   "genz-discontinuous"};
    const qmc_method m[] = {QMC_METHOD_AUTO, QMC_METHOD_MC, QMC_METHOD_RQMC,
                            QMC_METHOD_CUBATURE, QMC_METHOD_GAUSS_LEGENDRE};
    for (size_t i = 0; i < 6; i++)
        for (size_t j = 0; j < sizeof m / sizeof m[0]; j++) {
            run_out o = run(fam[i], 3, m[j], NULL);
            assert_int_equal(o.err, 0);
            if (o.rep.res.flags & fresh)
                fail_msg("%s by %s: flags 0x%x", fam[i], qmc_method_name(m[j]),
                         o.rep.res.flags);
        }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_nonfinite),
        cmocka_unit_test(test_heavy_tail),
        cmocka_unit_test(test_not_pow2),
        cmocka_unit_test(test_dims_past_good),
        cmocka_unit_test(test_few_reps),
        cmocka_unit_test(test_quadrature_not_converged),
        cmocka_unit_test(test_sampling_budget),
        cmocka_unit_test(test_cubature_memory_bound),
        cmocka_unit_test(test_refusals),
        cmocka_unit_test(test_rule_bar_across_kink),
        cmocka_unit_test(test_clean_run_raises_nothing),
        cmocka_unit_test(test_auto_choice),
        cmocka_unit_test(test_rules_miss_narrow_peak),
        cmocka_unit_test(test_auto_finds_missed_peak),
        cmocka_unit_test(test_resolved_peak_not_flagged),
        cmocka_unit_test(test_cubature_partial_peak),
        cmocka_unit_test(test_zero_samples_flagged),
        cmocka_unit_test(test_zero_spread_not_tolerance_met),
        cmocka_unit_test(test_split_net_zero_spread),
        cmocka_unit_test(test_tail_untested_small_n),
        cmocka_unit_test(test_heavy_tail_power),
        cmocka_unit_test(test_zero_pdf_reachable),
        cmocka_unit_test(test_tiny_light_zero_flagged),
        cmocka_unit_test(test_mis_undersampled),
        cmocka_unit_test(test_tiny_budget_flagged),
        cmocka_unit_test(test_overflow_nonfinite),
        cmocka_unit_test(test_tiny_cone_no_roundoff_bias),
        cmocka_unit_test(test_stratified_refused_past_2_per_axis),
        cmocka_unit_test(test_new_flags_quiet_on_clean_runs),
    };
    return cmocka_run_group_tests_name("stability", tests, NULL, NULL);
}
