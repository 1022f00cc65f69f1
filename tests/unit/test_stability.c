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
 * The silent failures of issue 13's audit, each with the audit's own
 * parameters (--max-evals 2e7 --seed 12345) and some of ours, are in the
 * files listed in stability_cases.h, one per failure class; every such
 * case also checks that the interval covers an independent closed form or
 * is flagged.
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

#include "stability_cases.h"

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

/* The method auto chose first: its reason's first word.  (The method it
 * ended with may be RQMC after the rule, with the rest of the budget.) */
static qmc_method auto_picks(const char *name, uint32_t dims, uint64_t budget)
{
    auto_budget = budget;
    run_out o = run(name, dims, QMC_METHOD_AUTO, set_auto_budget);
    assert_int_equal(o.err, 0);
    char first[32];
    const size_t len = strcspn(o.rep.auto_reason, ": ");
    assert_true(len < sizeof first);
    memcpy(first, o.rep.auto_reason, len);
    first[len] = '\0';
    qmc_method m;
    assert_int_equal(qmc_method_parse(first, &m), 0);
    if (m != QMC_METHOD_RQMC && o.rep.method_used == QMC_METHOD_RQMC)
        assert_non_null(strstr(o.rep.auto_reason, "rqmc with the rest of the budget"));
    else
        assert_int_equal(o.rep.method_used, m);
    return m;
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
            /* Not a clean run: Gauss-Legendre at 16 nodes across a jump
             * is 10% off (0.4436 against 0.4040), and the check's
             * siblings at 9 and 10 nodes scatter by 0.168, a bar 38% of
             * the estimate, which is unresolved by the book.  A plain MC
             * pilot (rule_pilot.h) puts the truth within two such bars, so
             * the bar itself is not in doubt. */
            if (m[j] == QMC_METHOD_GAUSS_LEGENDRE && i == 5) {
                assert_true(o.rep.res.flags & QMC_FLAG_UNRESOLVED);
                assert_false(o.rep.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
                assert_true(fabs(o.rep.res.estimate - 0.40404589877239888) <=
                            3 * o.rep.res.error);
                continue;
            }
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
        cmocka_unit_test(test_new_flags_quiet_on_clean_runs),
    };
    return cmocka_run_group_tests_name("stability", tests, NULL, NULL);
}
