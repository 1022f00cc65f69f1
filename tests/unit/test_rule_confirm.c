/*
 * test_rule_confirm.c - a deterministic rule's bar on an integrand that
 * declares a kink or a jump carries error_unreliable unless evidence that
 * is not the rule's confirms it (core/rule_confirm.c), through
 * qmc_integrate.
 *
 * Closed forms written here: a step 1 for x < u integrates to u;
 * genz-continuous exp(-sum a |x - u|) to prod (2 - e^(-a u) - e^(-a (1 -
 * u))) / a.
 *
 *   case                                              must
 *   step at 0.7071, declared, midpoint, trapezoid,   cover, no flag; the
 *     Simpson, Gauss-Legendre with room for the check   check's evaluations
 *                                                       counted
 *   the same step by cubature (5e-9 under a bar of     flagged
 *     5e-9: 17 bars off)
 *   step at 1 - 1e-9, declared, midpoint              flagged (GK sees the
 *     (1 +- 1e-16 before)                               step the nodes miss)
 *   step at 0.7071, no budget left for the check      flagged
 *   genz-continuous 2D, a kink 0.005 from the edge,   flagged (22 bars off,
 *     trapezoid, no room for a pilot; 3D by cubature    the siblings agreeing),
 *                                                       or covered
 *   a jump with no breaks given, midpoint, no room    flagged
 *   x^-1/2 (singular) by Gauss-Legendre               flagged
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <float.h>
#include <math.h>
#include <string.h>

#include "qmc/integrate.h"
#include "qmc/quad.h"
#include "qmc/testfn.h"
#include "rule_run.h"

static void assert_covers(const rule_outcome *o)
{
    if (!rule_covers(o))
        fail_msg("%.17g +- %.3g against %.17g (flags 0x%x)", o->res.estimate, o->res.error,
                 o->truth, o->res.flags);
}

static void test_declared_step_confirmed(void **state)
{
    (void)state;
    const double u[] = {0.7071};
    const qmc_method m[] = {QMC_METHOD_MIDPOINT, QMC_METHOD_TRAPEZOID, QMC_METHOD_SIMPSON,
                            QMC_METHOD_GAUSS_LEGENDRE};
    const uint32_t n[] = {4096, 4097, 4097, 512};
    for (int i = 0; i < 4; i++) {
        rule_outcome o = rule_run("step", 1, NULL, u, m[i], n[i], 0);
        assert_true(fabs(o.truth - u[0]) <= DBL_EPSILON); /* the closed form */
        assert_covers(&o);
        if (o.res.flags & QMC_FLAG_ERROR_UNRELIABLE)
            fail_msg("%s: flags 0x%x on %.17g +- %.3g", qmc_method_name(m[i]), o.res.flags,
                     o.res.estimate, o.res.error);
    }
    /* cubature straddles the step: 0.70709991 +- 5e-9, 17 bars off; GK
     * from the break disagrees, and the flag stays unless the pilot that
     * follows (rule_pilot.h, test_rule_pilot.c) raised the bar to cover */
    rule_outcome c = rule_run("step", 1, NULL, u, QMC_METHOD_CUBATURE, 0, 0);
    if (fabs(c.res.estimate - c.truth) > 3 * c.res.error)
        assert_true(c.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
    /* the check is counted: midpoint's levels and siblings are 4096 +
     * 2048 + 2049 + 2050 + 32, the check two Kronrod rules */
    rule_outcome o = rule_run("step", 1, NULL, u, QMC_METHOD_MIDPOINT, 4096, 0);
    uint64_t rule = 4096 + 2048 + qmc_quad_tensor_check_evals(QMC_RULE1D_MIDPOINT, 4096, 1);
    assert_int_equal(o.res.evals, rule + 42);
}

static void test_declared_step_at_the_end_flagged(void **state)
{
    (void)state;
    /* every level and sibling of midpoint reads 1 at its last node: the
     * bar is 1e-16 and the truth 1e-9 below; GK from the break disagrees */
    const double u[] = {0.999999999};
    rule_outcome o = rule_run("step", 1, NULL, u, QMC_METHOD_MIDPOINT, 4096, 0);
    assert_true(fabs(o.res.estimate - o.truth) > 3 * o.res.error);
    assert_true(o.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
}

static void test_no_room_for_the_check(void **state)
{
    (void)state;
    const double u[] = {0.7071};
    uint64_t rule = 4096 + 2048 + qmc_quad_tensor_check_evals(QMC_RULE1D_MIDPOINT, 4096, 1);
    rule_outcome o = rule_run("step", 1, NULL, u, QMC_METHOD_MIDPOINT, 4096, rule);
    assert_int_equal(o.res.evals, rule);
    assert_true(o.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
}

static double continuous_truth(uint32_t d, const double *a, const double *u)
{
    double p = 1.0;
    for (uint32_t j = 0; j < d; j++)
        p *= (2.0 - exp(-a[j] * u[j]) - exp(-a[j] * (1.0 - u[j]))) / a[j];
    return p;
}

static void test_kinks_stay_flagged(void **state)
{
    (void)state;
    /* a kink 0.005 from the edge: trapezoid at 65 an axis, its levels and
     * siblings agree within 6.7e-5 of 0.00952, 22 bars from the truth;
     * only the declared kink's flag marks it (found by a scan of 4000
     * random genz-continuous runs, 7 like it) */
    const double a[] = {1.4617339774306408, 84.397495008916607},
                 u[] = {0.33021200091982683, 0.99500782653259678};
    /* no room left for the pilot (rule_pilot.h): the rule's evaluations */
    const uint64_t rule = 65 * 65 + 33 * 33 + qmc_quad_tensor_check_evals(QMC_RULE1D_TRAPEZOID,
                                                                         65, 2);
    rule_outcome o = rule_run("genz-continuous", 2, a, u, QMC_METHOD_TRAPEZOID, 65, rule);
    assert_int_equal(o.res.evals, rule);
    assert_true(fabs(o.truth - continuous_truth(2, a, u)) <= 1e-14 * o.truth);
    assert_true(fabs(o.res.estimate - o.truth) > 20 * o.res.error);
    assert_true(o.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
    /* cubature, whose bar across kinks fell short in 8-38% of the
     * benchmark's runs, likewise: flagged, or covered by a pilot's bar */
    const double a3[] = {5, 3, 7}, u3[] = {0.31, 0.62, 0.47};
    o = rule_run("genz-continuous", 3, a3, u3, QMC_METHOD_CUBATURE, 0, 0);
    if (!(o.res.flags & QMC_FLAG_ERROR_UNRELIABLE))
        assert_covers(&o);
}

static void test_unplaced_jump_and_singularity_flagged(void **state)
{
    (void)state;
    /* genz-discontinuous in 2D declares its jumps but cannot place them
     * (breaks are 1D), and siblings cannot confirm a jump */
    const double a[] = {1, 1}, u[] = {0.3, 0.6};
    const uint64_t rule = 64 * 64 + 32 * 32 + qmc_quad_tensor_check_evals(QMC_RULE1D_MIDPOINT,
                                                                         64, 2);
    rule_outcome o = rule_run("genz-discontinuous", 2, a, u, QMC_METHOD_MIDPOINT, 64, rule);
    assert_true(o.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
    o = rule_run("inv-sqrt", 1, NULL, NULL, QMC_METHOD_GAUSS_LEGENDRE, 64, 0);
    assert_true(o.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_declared_step_confirmed),
        cmocka_unit_test(test_declared_step_at_the_end_flagged),
        cmocka_unit_test(test_no_room_for_the_check),
        cmocka_unit_test(test_kinks_stay_flagged),
        cmocka_unit_test(test_unplaced_jump_and_singularity_flagged),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
