/*
 * test_stability_samples.c - classes 2 and 3 of issue 13's audit: every
 * sample zero or a replicate spread of exactly 0 (few_nonzero,
 * zero_spread; adaptive sampling keeps going), and n below the heavy-tail
 * test's minimum (tail_untested), with the test's power above it.
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
#include "qmc/sampling.h"
#include "qmc/scene.h"
#include "qmc/testfn.h"

#include "stability_cases.h"

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

/* 1 + 1000 exp(-(1e7 (x1 - 0.37))^2), declared analytic: every point of
 * every replicate sees 1, and the spike (1.77e-4 of mass) none. */
static void base_and_spike_eval(const void *ctx, const double *x, size_t n, uint32_t dims,
                                double *out)
{
    (void)ctx;
    for (size_t i = 0; i < n; i++) {
        double t = 1e7 * (x[i * dims] - 0.37);
        out[i] = 1.0 + 1e3 * exp(-t * t);
    }
}

/* ... and a zero spread on an integrand declared analytic is no better:
 * an unbiased replicate is continuous in its randomization, yet flat on
 * all of it but the measure n w that hits a spike of width w.  Round five
 * briefly gave bit-equal replicates of analytic integrands the rounding
 * floor as their bar (flagged roundoff only); this case, from its review,
 * then read 1 +- 1.4e-14 against 1.000177, and auto stopped on it after
 * one round instead of doubling until it found the spike (1.0019 +-
 * 0.0019 before and again now).  The change was withdrawn. */
static void test_zero_spread_on_an_analytic_integrand(void **state)
{
    (void)state;
    const double pi = 3.14159265358979323846;
    const double truth = 1.0 + 1e3 * sqrt(pi) / 1e7 * 0.5 *
                                   (erf(1e7 * 0.63) + erf(1e7 * 0.37));
    for (uint32_t d = 1; d <= 12; d += 11) {
        qmc_integrand f = {.eval = base_and_spike_eval, .dims = d,
                           .smoothness = QMC_SMOOTH_ANALYTIC, .name = "base-and-spike"};
        qmc_integrate_spec spec;
        qmc_integrate_spec_init(&spec);
        spec.method = QMC_METHOD_RQMC;
        qmc_sampling_spec_init(&spec.sampling, QMC_SAMPLER_RQMC);
        spec.sampling.reps = 16;
        spec.sampling.n = 4096;
        spec.n_given = 1;
        run_out o;
        memset(&o, 0, sizeof o);
        o.err = qmc_integrate(&spec, &f, NULL, NULL, NULL, &o.rep, o.why, sizeof o.why);
        ASSERT_FLAGS(o, QMC_FLAG_ZERO_SPREAD | QMC_FLAG_ERROR_UNRELIABLE);
        assert_true(o.rep.res.estimate == 1.0);
        if (d == 12) {
            spec.method = QMC_METHOD_AUTO;
            spec.n_given = 0;
            memset(&o, 0, sizeof o);
            o.err = qmc_integrate(&spec, &f, NULL, NULL, NULL, &o.rep, o.why, sizeof o.why);
            assert_int_equal(o.err, 0);
            ASSERT_COVERS_OR_FLAGGED(o, truth);
        }
    }
}

static void owen_16x65536(qmc_integrate_spec *s)
{
    s->sampling.reps = 16;
    s->sampling.n = 65536;
    s->n_given = 1;
}

/* A replicated bar on a declared singularity: each replicate's error is
 * dominated by its point nearest the singularity, so the means are skewed
 * (log x, 16 x 2^16 Owen-scrambled Sobol: 7 of 100 seeds missed by more
 * than 3 bars with no flag - Hill's test sees log's light tail).  Flagged;
 * plain MC's bar over all points, which missed in none, is not. */
static void test_replicated_bar_on_a_singularity(void **state)
{
    (void)state;
    run_out o = run_au("log", 1, NULL, NULL, QMC_METHOD_RQMC, owen_16x65536);
    ASSERT_FLAGS(o, QMC_FLAG_ERROR_UNRELIABLE);
    assert_false(o.rep.res.flags & QMC_FLAG_HEAVY_TAIL);
    ASSERT_COVERS_OR_FLAGGED(o, -1.0);
    o = run_au("log", 1, NULL, NULL, QMC_METHOD_MC, NULL);
    assert_int_equal(o.err, 0);
    assert_false(o.rep.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
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


int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_zero_samples_flagged),
        cmocka_unit_test(test_zero_spread_not_tolerance_met),
        cmocka_unit_test(test_split_net_zero_spread),
        cmocka_unit_test(test_zero_spread_on_an_analytic_integrand),
        cmocka_unit_test(test_replicated_bar_on_a_singularity),
        cmocka_unit_test(test_tail_untested_small_n),
        cmocka_unit_test(test_heavy_tail_power),
    };
    return cmocka_run_group_tests_name("stability-samples", tests, NULL, NULL);
}
