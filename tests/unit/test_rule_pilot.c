/*
 * test_rule_pilot.c - a deterministic rule's bar still in doubt is checked
 * by a randomized pilot off the rule's nodes (core/rule_pilot.c), through
 * qmc_integrate.
 *
 * Closed forms written here: genz-continuous exp(-sum a |x - u|)
 * integrates to prod (2 - e^(-a u) - e^(-a (1 - u))) / a;
 * genz-discontinuous exp(sum a x) on x_j <= u_j to prod (e^(a u) - 1) / a.
 * "No room" runs give the rule exactly the evaluations it spends, so no
 * pilot fits: the rule's own result, to compare with.
 *
 *   case                                          must
 *   3D kink, midpoint at 8                         bar as it was, no flag,
 *                                                  2048 more evaluations
 *   3D kink, Gauss-Legendre at 16                  bar raised, no flag, covers
 *   the kink times 2^1000 and 2^-1000              the unscaled results
 *     (midpoint, Gauss-Legendre)                     times 2^e, to the bit
 *   cos(100 x), Simpson at 17 (unresolved)         unresolved only, covers
 *   2D jumps, midpoint at 128 (plain MC pilot)     bar raised, covers, no flag
 *   2D kink 0.005 from the edge, trapezoid at 65   flagged, bar as it was
 *     (22 bars off)                                  (the pilot does not vouch)
 *   a narrow peak; a step at 1 - 1e-9              flagged (the pilot itself
 *                                                    carries a flag)
 *   a 1D jump GK from the break refutes            flagged, no pilot run
 *   cubature on the kink, default tolerance 1e-8   flagged, bar as it was;
 *                                                    only the 256-point probe
 *   x^-1/2 by Gauss-Legendre                       flagged, no pilot run
 *   too little budget left                         flagged, no pilot run
 *   the same request twice                         the same bits
 *   the hook firing inside the pilot               QMC_ECANCELED
 *   qmc_integrate_memory_bytes                     covers the pilot's sums,
 *                                                    workspace, sequences
 *   auto on the kink at 2e7: cubature, the bar     rqmc with the rest vouches:
 *     in doubt                                       cubature's estimate, no
 *                                                    flag, tolerance met, covers
 *   the same where cubature is 88 bars off         rqmc's answer instead, no
 *                                                    flag, covers
 *   the same at 3e5 and 1e4                        cubature within half the
 *                                                    budget, then rqmc; no flag
 *   a 4D kink at 1e4, rqmc flagged itself          the rule's flagged answer
 *   the caller's n: a refused round; n too big   the rule's flagged answer;
 *     for half the budget or not 2^k                 no cap, no witness
 *   NaN on a slab only rqmc's points reach         counted, nonfinite raised
 *   NaN on a band only the pilot's points reach    counted, nonfinite raised
 *   a caller's tol_abs at 2^600                    the result at 2^0 times 2^600
 *   auto on x^-0.99 (Gauss-Kronrod flagged)        the rule's answer, no rqmc
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "hook.h"
#include "rule_run.h"
#include "rule_pilot.h"
#include "qmc/integrate.h"
#include "qmc/quad.h"

static double continuous_truth(uint32_t d, const double *a, const double *u)
{
    double p = 1.0;
    for (uint32_t j = 0; j < d; j++)
        p *= (2.0 - exp(-a[j] * u[j]) - exp(-a[j] * (1.0 - u[j]))) / a[j];
    return p;
}

static const double a3[] = {5, 3, 7}, u3[] = {0.31, 0.62, 0.47};

/* The rule's own evaluations on a tensor grid, with its check. */
static uint64_t tensor_evals(qmc_rule1d rule, uint32_t n, uint32_t d)
{
    uint64_t fine = 1, coarse = 1, nc = (n + 1) / 2;
    for (uint32_t j = 0; j < d; j++) {
        fine *= n;
        coarse *= nc;
    }
    return fine + coarse + qmc_quad_tensor_check_evals(rule, n, d);
}

static void test_kink_bar_confirmed(void **state)
{
    (void)state;
    /* midpoint at 8 an axis: a bar of 0.004 that the MC pilot's 2048
     * points (the integrand declares kinks) can check as it stands */
    const uint64_t rule = tensor_evals(QMC_RULE1D_MIDPOINT, 8, 3);
    rule_outcome own = rule_run("genz-continuous", 3, a3, u3, QMC_METHOD_MIDPOINT, 8, rule);
    rule_outcome o = rule_run("genz-continuous", 3, a3, u3, QMC_METHOD_MIDPOINT, 8, 0);
    assert_true(fabs(o.truth - continuous_truth(3, a3, u3)) <= 1e-14 * o.truth);
    assert_int_equal(own.res.evals, rule);
    assert_true(own.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
    assert_int_equal(o.res.flags, 0);
    assert_true(o.res.estimate == own.res.estimate && o.res.error == own.res.error);
    assert_int_equal(o.res.evals, rule + QMC_INTEGRATE_CONFIRM_EVALS);
    assert_true(rule_covers(&o));
}

static void test_kink_bar_raised(void **state)
{
    (void)state;
    /* Gauss-Legendre at 16 claims more than the pilot can check: its bar
     * becomes the pilot's, and covers */
    const uint64_t rule = tensor_evals(QMC_RULE1D_GAUSS_LEGENDRE, 16, 3);
    rule_outcome own = rule_run("genz-continuous", 3, a3, u3, QMC_METHOD_GAUSS_LEGENDRE, 16, rule);
    rule_outcome o = rule_run("genz-continuous", 3, a3, u3, QMC_METHOD_GAUSS_LEGENDRE, 16, 0);
    assert_true(own.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
    assert_int_equal(o.res.flags, 0);
    assert_true(o.res.estimate == own.res.estimate && o.res.error > own.res.error);
    assert_true(rule_covers(&o));
}

static void test_scaled_values(void **state)
{
    (void)state;
    /* The same integrand times 2^1000 and 2^-1000: the pilot's sums of
     * squares overflow (underflow) unless it scales f back, and then it
     * found a nonfinite (zero) spread and vouched for nothing.  Scaling by
     * a power of two is exact, so the results must be the unscaled ones
     * times 2^e to the bit, flags and all. */
    const qmc_method methods[] = {QMC_METHOD_MIDPOINT, QMC_METHOD_GAUSS_LEGENDRE};
    const uint32_t n_axis[] = {8, 16};
    const int exps[] = {1000, -1000};
    for (int m = 0; m < 2; m++) {
        rule_outcome o = rule_run("genz-continuous", 3, a3, u3, methods[m], n_axis[m], 0);
        assert_int_equal(o.res.flags, 0);
        for (int k = 0; k < 2; k++) {
            rule_outcome x = rule_run_scaled("genz-continuous", 3, a3, u3, methods[m],
                                             n_axis[m], exps[k]);
            assert_int_equal(x.res.flags, o.res.flags);
            assert_true(x.res.estimate == ldexp(o.res.estimate, exps[k]));
            assert_true(x.res.error == ldexp(o.res.error, exps[k]));
            assert_int_equal(x.res.evals, o.res.evals);
            assert_true(rule_covers(&x));
        }
    }
}

static void test_unresolved_stays(void **state)
{
    (void)state;
    /* Simpson at 17 on cos(100 x), declared analytic (an RQMC pilot):
     * 0.95 +- 0.98 against -0.005, unresolved by the book; the pilot
     * vouches for the bar, not for the rule */
    const double a[] = {100};
    rule_outcome o = rule_run("cos", 1, a, NULL, QMC_METHOD_SIMPSON, 17, 0);
    assert_true(fabs(o.truth - sin(100.0) / 100.0) <= 1e-15);
    assert_int_equal(o.res.flags, QMC_FLAG_UNRESOLVED);
    assert_true(rule_covers(&o));
}

static void test_jump_bar_raised(void **state)
{
    (void)state;
    const double a[] = {3, 2}, u[] = {0.3, 0.6};
    const uint64_t rule = tensor_evals(QMC_RULE1D_MIDPOINT, 128, 2);
    rule_outcome own = rule_run("genz-discontinuous", 2, a, u, QMC_METHOD_MIDPOINT, 128, rule);
    rule_outcome o = rule_run("genz-discontinuous", 2, a, u, QMC_METHOD_MIDPOINT, 128, 0);
    const double truth = (exp(0.9) - 1) / 3 * (exp(1.2) - 1) / 2;
    assert_true(fabs(o.truth - truth) <= 1e-14 * truth);
    assert_true(own.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
    assert_int_equal(o.res.flags, 0);
    assert_true(o.res.estimate == own.res.estimate);
    assert_true(o.res.error > own.res.error);
    assert_true(o.res.ci_low == o.res.estimate - o.res.error &&
                o.res.ci_high == o.res.estimate + o.res.error);
    assert_true(rule_covers(&o));
}

static void test_disagreement_keeps_the_flag(void **state)
{
    (void)state;
    const double a[] = {1.4617339774306408, 84.397495008916607},
                 u[] = {0.33021200091982683, 0.99500782653259678};
    const uint64_t rule = tensor_evals(QMC_RULE1D_TRAPEZOID, 65, 2);
    rule_outcome own = rule_run("genz-continuous", 2, a, u, QMC_METHOD_TRAPEZOID, 65, rule);
    rule_outcome o = rule_run("genz-continuous", 2, a, u, QMC_METHOD_TRAPEZOID, 65, 0);
    assert_true(fabs(o.res.estimate - o.truth) > 20 * o.res.error);
    assert_true(o.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
    assert_true(o.res.error == own.res.error);
    assert_true(o.res.evals > own.res.evals); /* the pilot ran, and is counted */
}

static void test_pilot_in_doubt_confirms_nothing(void **state)
{
    (void)state;
    /* a peak of width 1/400: the pilot's few hits raise its own flags */
    const double ga[] = {400, 400}, gu[] = {0.5, 0.5};
    rule_outcome o = rule_run("genz-gaussian", 2, ga, gu, QMC_METHOD_MIDPOINT, 64, 0);
    assert_true(o.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
    assert_true(o.res.flags & QMC_FLAG_UNRESOLVED);
    assert_int_equal(o.res.evals, tensor_evals(QMC_RULE1D_MIDPOINT, 64, 2) + 2048);
    /* the step beyond every node and every pilot point: all values 1;
     * Gauss-Kronrod from the break (42) cannot reach a bar of 0, the
     * pilot (2048) sees no spread */
    const double su[] = {0.999999999};
    o = rule_run("step", 1, NULL, su, QMC_METHOD_MIDPOINT, 4096, 0);
    assert_false(rule_covers(&o));
    assert_true(o.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
    assert_int_equal(o.res.evals, tensor_evals(QMC_RULE1D_MIDPOINT, 4096, 1) + 42 + 2048);
}

/* Found by rule_confirm_scan 1d: midpoint at 1024 nodes 4.3 bars off a
 * jump at 0.98410.  Gauss-Kronrod from the break (exact here) refutes the
 * bar, so no pilot runs to vouch for it: an RQMC pilot did, its 16
 * replicates agreeing on a mean 6.8 of their standard errors off. */
static void test_refuted_by_gauss_kronrod(void **state)
{
    (void)state;
    const double a[] = {1.4777539996433788}, u[] = {0.98409960445674594};
    rule_outcome o = rule_run("genz-discontinuous", 1, a, u, QMC_METHOD_MIDPOINT, 1024, 0);
    const double truth = (exp(a[0] * u[0]) - 1) / a[0];
    assert_true(fabs(o.truth - truth) <= 1e-15 * truth);
    assert_true(fabs(o.res.estimate - truth) > 4 * o.res.error);
    assert_true(o.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
    assert_int_equal(o.res.evals, tensor_evals(QMC_RULE1D_MIDPOINT, 1024, 1) + 42);
}

static void test_tolerance_not_claimed(void **state)
{
    (void)state;
    /* cubature stops on 1e-8 relative; a pilot of thousands of points
     * cannot vouch for that, and a raised bar would break the tolerance */
    rule_outcome o = rule_run("genz-continuous", 3, a3, u3, QMC_METHOD_CUBATURE, 0, 0);
    assert_true(o.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
    assert_false(o.res.flags & QMC_FLAG_NOT_CONVERGED);
    assert_true(o.res.error <= 1e-8 * fabs(o.res.estimate));
    /* a 256-point probe showed the pilot hopeless, so only the probe
     * ran: the same run with 256 evaluations less has no room for it */
    rule_outcome own = rule_run("genz-continuous", 3, a3, u3, QMC_METHOD_CUBATURE, 0,
                                o.res.evals - 256);
    assert_int_equal(own.res.evals, o.res.evals - 256);
    assert_true(own.res.estimate == o.res.estimate && own.res.error == o.res.error &&
                own.res.flags == o.res.flags);
}

static void test_no_pilot(void **state)
{
    (void)state;
    /* a declared singularity is never confirmed: the rule's 195 only */
    rule_outcome o = rule_run("inv-sqrt", 1, NULL, NULL, QMC_METHOD_GAUSS_LEGENDRE, 64, 0);
    assert_true(o.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
    assert_int_equal(o.res.evals, tensor_evals(QMC_RULE1D_GAUSS_LEGENDRE, 64, 1));
    /* less than 16 x 16 evaluations left */
    const uint64_t rule = tensor_evals(QMC_RULE1D_GAUSS_LEGENDRE, 16, 3);
    o = rule_run("genz-continuous", 3, a3, u3, QMC_METHOD_GAUSS_LEGENDRE, 16, rule + 255);
    assert_true(o.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
    assert_int_equal(o.res.evals, rule);
    assert_int_equal(qmc__rule_pilot_evals(rule, 255), 0);
    assert_int_equal(qmc__rule_pilot_evals(rule, 256), 256);
    assert_int_equal(qmc__rule_pilot_evals(1000000, 1u << 30), 65536); /* an eighth, 2^k */
    assert_int_equal(qmc__rule_pilot_evals(UINT64_C(1) << 40, UINT64_C(1) << 40), 1u << 20);
}

static void test_deterministic(void **state)
{
    (void)state;
    const double a[] = {3, 2}, u[] = {0.3, 0.6};
    rule_outcome x = rule_run("genz-discontinuous", 2, a, u, QMC_METHOD_SIMPSON, 65, 0);
    rule_outcome y = rule_run("genz-discontinuous", 2, a, u, QMC_METHOD_SIMPSON, 65, 0);
    assert_true(test_same_result(&x.res, &y.res));
}

static void test_cancelled_in_the_pilot(void **state)
{
    (void)state;
    const uint64_t rule = tensor_evals(QMC_RULE1D_GAUSS_LEGENDRE, 16, 3);
    qmc_integrate_spec s;
    qmc_integrate_spec_init(&s);
    s.method = QMC_METHOD_GAUSS_LEGENDRE;
    s.n_axis = 16;
    s.n_given = 1;
    s.max_evals = rule; /* the rule alone: how often it polls */
    test_hook h;
    s.interrupt = test_hook_init(&h, 0, NULL);
    rule_outcome o = rule_run_spec("genz-continuous", 3, a3, u3, &s);
    assert_int_equal(o.err, 0);
    const uint64_t rule_calls = h.calls;
    qmc_integrate_spec_init(&s);
    s.method = QMC_METHOD_GAUSS_LEGENDRE;
    s.n_axis = 16;
    s.n_given = 1;
    s.interrupt = test_hook_init(&h, rule_calls + 1, NULL);
    o = rule_run_spec("genz-continuous", 3, a3, u3, &s);
    assert_int_equal(o.err, QMC_ECANCELED);
    assert_true(o.res.estimate == 0.0 && o.res.error == 0.0);
    assert_true(o.res.evals >= rule);
}

/* The bound against the sampling methods' own bound for the same pilot,
 * run as a job of its own (whose runner workspace and sequences that bound
 * leaves out), at a small and at the largest pilot. */
static void test_memory_covers_the_pilot(void **state)
{
    (void)state;
    const uint64_t budgets[] = {4096, UINT64_C(1) << 30};
    const uint32_t dims[] = {1, 3, 4000};
    for (int b = 0; b < 2; b++)
        for (int d = 0; d < 3; d++) {
            const uint64_t pilot = qmc__rule_pilot_evals(budgets[b], budgets[b]);
            qmc_integrate_spec r;
            qmc_integrate_spec_init(&r);
            r.method = QMC_METHOD_RQMC;
            qmc_sampling_spec_init(&r.sampling, QMC_SAMPLER_RQMC);
            r.sampling.reps = QMC_INTEGRATE_PILOT_REPS;
            r.sampling.n = pilot / QMC_INTEGRATE_PILOT_REPS;
            r.n_given = 1;
            r.max_evals = pilot;
            qmc_integrate_spec m = r;
            m.method = QMC_METHOD_MC;
            qmc_sampling_spec_init(&m.sampling, QMC_SAMPLER_MC);
            m.sampling.n = pilot;
            const uint64_t sums = qmc_integrate_memory_bytes(&r, dims[d]) >
                                          qmc_integrate_memory_bytes(&m, dims[d])
                                      ? qmc_integrate_memory_bytes(&r, dims[d])
                                      : qmc_integrate_memory_bytes(&m, dims[d]);
            const uint64_t bound = qmc__rule_pilot_bytes(budgets[b], dims[d]);
            /* the block sums, and more: workspace and sequences */
            assert_true(bound > sums);
            /* the serial workspace of a wide point is most of it */
            if (dims[d] == 4000)
                assert_true(bound > 100 * sums);
            qmc_integrate_spec t;
            qmc_integrate_spec_init(&t);
            t.method = QMC_METHOD_MIDPOINT;
            t.n_axis = 1;
            t.max_evals = budgets[b];
            assert_true(qmc_integrate_memory_bytes(&t, dims[d]) >= bound);
        }
}

/* auto on f with seed 7 within budget (its own tolerance, 1e-6). */
static rule_outcome auto_run(const char *name, uint32_t d, const double *a, const double *u,
                             uint64_t budget)
{
    qmc_integrate_spec s;
    qmc_integrate_spec_init(&s);
    s.method = QMC_METHOD_AUTO;
    s.max_evals = budget;
    s.sampling.seed = 7;
    rule_outcome o = rule_run_spec(name, d, a, u, &s);
    assert_int_equal(o.err, 0);
    return o;
}

/* cubature alone on the kink at auto's tolerance, 1e-6: a bar no pilot
 * can reach, flagged */
static rule_outcome cubature_at_auto_tol(const double *a, const double *u)
{
    qmc_integrate_spec c;
    qmc_integrate_spec_init(&c);
    c.method = QMC_METHOD_CUBATURE;
    c.tol_rel = 1e-6;
    c.max_evals = 20000000;
    c.sampling.seed = 7;
    rule_outcome rule = rule_run_spec("genz-continuous", 3, a, u, &c);
    assert_int_equal(rule.err, 0);
    assert_true(rule.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
    return rule;
}

/* auto's reason after that rule, and the RQMC that followed it */
static void assert_handed_on(const rule_outcome *o, const rule_outcome *rule)
{
    assert_true(strncmp(o->auto_reason, "cubature: ", 10) == 0);
    char after[96];
    snprintf(after, sizeof after, "; after %llu evaluations nothing off its nodes",
             (unsigned long long)rule->res.evals);
    assert_non_null(strstr(o->auto_reason, after));
    assert_non_null(strstr(o->auto_reason, "rqmc with the rest of the budget"));
    assert_int_equal(o->res.flags, 0);
    assert_true(rule_covers(o));
    assert_true(o->res.evals > rule->res.evals && o->res.evals <= 20000000);
}

static void test_auto_rqmc_vouches_for_the_rule(void **state)
{
    (void)state;
    rule_outcome rule = cubature_at_auto_tol(a3, u3);
    /* auto chose that rule and, with nearly all the budget left, ran
     * RQMC with the rest, which agreed: the rule's answer, unflagged */
    rule_outcome o = auto_run("genz-continuous", 3, a3, u3, 20000000);
    assert_true(fabs(o.truth - continuous_truth(3, a3, u3)) <= 1e-14 * o.truth);
    assert_handed_on(&o, &rule);
    assert_int_equal(o.method_used, QMC_METHOD_CUBATURE);
    assert_non_null(strstr(o.auto_reason, "; rqmc vouched for the rule's bar"));
    assert_true(o.res.estimate == rule.res.estimate);
    assert_true(o.res.error >= rule.res.error && o.res.error <= 1e-6 * fabs(o.res.estimate));
    /* the same request, the same bits */
    rule_outcome again = auto_run("genz-continuous", 3, a3, u3, 20000000);
    assert_true(test_same_result(&o.res, &again.res));
}

static void test_auto_rqmc_replaces_a_wrong_rule(void **state)
{
    (void)state;
    /* here cubature is 88 of its bars off, flagged */
    const double a[] = {5, 3, 7}, u[] = {0.5487, 0.7505, 0.7473};
    rule_outcome rule = cubature_at_auto_tol(a, u);
    assert_true(fabs(rule.truth - continuous_truth(3, a, u)) <= 1e-14 * rule.truth);
    assert_true(fabs(rule.res.estimate - rule.truth) > 50 * rule.res.error);
    /* RQMC disagrees beyond its noise: its answer replaces the rule's */
    rule_outcome o = auto_run("genz-continuous", 3, a, u, 20000000);
    assert_handed_on(&o, &rule);
    assert_int_equal(o.method_used, QMC_METHOD_RQMC);
    assert_null(strstr(o.auto_reason, "vouched"));
    assert_int_equal(o.res.error_kind, QMC_ERROR_STDERR);
    assert_true(o.res.ci_high - o.res.estimate <= 1e-6 * fabs(o.res.estimate));
}

static void test_auto_cubature_keeps_half_for_rqmc(void **state)
{
    (void)state;
    /* cubature meets auto's tolerance on the kink in some 180000
     * evaluations; of a budget of 3e5 auto gives it half, and RQMC the
     * rest: no flag either way; at 1e4 as well */
    const uint64_t budgets[] = {300000, 10000};
    for (size_t i = 0; i < 2; i++) {
        rule_outcome o = auto_run("genz-continuous", 3, a3, u3, budgets[i]);
        const char *after = strstr(o.auto_reason, "; after ");
        assert_non_null(after);
        unsigned long long spent = 0;
        assert_int_equal(sscanf(after, "; after %llu evaluations", &spent), 1);
        assert_true(spent > 0 && spent <= budgets[i] / 2);
        assert_non_null(strstr(o.auto_reason, "rqmc with the rest of the budget"));
        assert_false(o.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
        assert_true(rule_covers(&o));
        assert_true(o.res.evals > spent && o.res.evals <= budgets[i]);
    }
}

static void test_auto_witness_in_doubt_vouches_for_nothing(void **state)
{
    (void)state;
    /* a 4D kink at 1e4: RQMC's 2048 points with the rest carry flags of
     * their own; the rule's flagged answer stays (over 100 positions the
     * thin RQMC missed 5 times where the rule missed none) */
    const double a[] = {5, 5, 5, 5}, u[] = {0.4, 0.4, 0.4, 0.4};
    rule_outcome o = auto_run("genz-continuous", 4, a, u, 10000);
    assert_int_equal(o.method_used, QMC_METHOD_CUBATURE);
    assert_non_null(strstr(o.auto_reason, "rqmc carried flags of its own"));
    assert_true(o.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
    unsigned long long spent = 0;
    assert_int_equal(sscanf(strstr(o.auto_reason, "; after "), "; after %llu", &spent), 1);
    assert_true(o.res.evals > spent && o.res.evals <= 10000);
}

static void test_auto_witness_refused_keeps_the_rule(void **state)
{
    (void)state;
    /* The caller's n = 2^14: its 8 replicates fit half of 2^18, so
     * cubature gets that half, and spends it; the VEGAS pilot then leaves
     * 65536 of the rest, and RQMC's round is refused.  The rule's flagged
     * answer stays (it was an error), every evaluation counted. */
    qmc_integrate_spec s;
    qmc_integrate_spec_init(&s);
    s.method = QMC_METHOD_AUTO;
    s.max_evals = UINT64_C(1) << 18;
    s.sampling.seed = 7;
    s.sampling.n = UINT64_C(1) << 14;
    s.n_given = 1;
    rule_outcome o = rule_run_spec("genz-continuous", 3, a3, u3, &s);
    assert_int_equal(o.err, 0);
    assert_int_equal(o.method_used, QMC_METHOD_CUBATURE);
    assert_non_null(strstr(o.auto_reason, "rqmc could not run on the rest"));
    assert_true(o.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
    unsigned long long spent = 0;
    assert_int_equal(sscanf(strstr(o.auto_reason, "; after "), "; after %llu", &spent), 1);
    assert_true(spent <= s.max_evals / 2);
    assert_true(o.res.evals > spent && o.res.evals <= s.max_evals);
    /* an n whose replicates do not fit half the budget, or that is no
     * power of two (no net): no cap and no witness, the rule's own run */
    qmc_integrate_spec c = s;
    c.method = QMC_METHOD_CUBATURE;
    c.tol_rel = 1e-6;
    rule_outcome rule = rule_run_spec("genz-continuous", 3, a3, u3, &c);
    const uint64_t ns[] = {UINT64_C(1) << 15, 3000};
    for (size_t i = 0; i < 2; i++) {
        s.sampling.n = ns[i];
        o = rule_run_spec("genz-continuous", 3, a3, u3, &s);
        assert_int_equal(o.err, 0);
        assert_null(strstr(o.auto_reason, "rest of the budget"));
        assert_true(o.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
        assert_true(test_same_result(&o.res, &rule.res));
    }
}

/* The kink of a3, u3 in 2D, NaN where x0 lies in the band [lo, hi). */
typedef struct nan_band {
    double lo, hi;
} nan_band;

static void kink_with_nan(const void *ctx, const double *x, size_t n, uint32_t dims, double *out)
{
    const nan_band *b = ctx;
    for (size_t i = 0; i < n; i++) {
        const double *p = x + i * dims;
        out[i] = p[0] >= b->lo && p[0] < b->hi
                     ? NAN
                     : exp(-a3[0] * fabs(p[0] - u3[0]) - a3[1] * fabs(p[1] - u3[1]));
    }
}

/* That integrand, declared continuous, by method m (budget: its default
 * when 0), seed 7. */
static qmc_integrate_report kink_with_nan_run(const nan_band *band, qmc_method m,
                                              uint64_t max_evals)
{
    qmc_integrand f = {.eval = kink_with_nan, .ctx = band, .dims = 2,
                       .smoothness = QMC_SMOOTH_CONTINUOUS, .name = "kink with a NaN band"};
    qmc_integrate_spec s;
    qmc_integrate_spec_init(&s);
    s.method = m;
    s.n_axis = 8;
    if (max_evals)
        s.max_evals = max_evals;
    s.sampling.seed = 7;
    qmc_integrate_report rep;
    char why[256];
    assert_int_equal(qmc_integrate(&s, &f, NULL, NULL, NULL, &rep, why, sizeof why), 0);
    return rep;
}

static void test_auto_witness_counts_its_nonfinite(void **state)
{
    (void)state;
    /* a slab that cubature's nodes miss and RQMC's points do not */
    const nan_band slab = {0.3141592, 0.3142592};
    qmc_integrate_report rep = kink_with_nan_run(&slab, QMC_METHOD_AUTO, 200000);
    /* whichever answer stands, the witness's NaNs are counted and said */
    assert_non_null(strstr(rep.auto_reason, "rqmc with the rest of the budget"));
    assert_true(rep.res.nonfinite > 0);
    assert_true(rep.res.flags & QMC_FLAG_NONFINITE);
}

static void test_auto_witness_scales_the_tolerance(void **state)
{
    (void)state;
    /* a caller's absolute tolerance on f times 2^600 is the same request
     * as on f: the same flags, the bar times 2^600 */
    qmc_integrate_spec s;
    qmc_integrate_spec_init(&s);
    s.method = QMC_METHOD_AUTO;
    s.max_evals = 200000;
    s.sampling.seed = 7;
    s.tol_abs = 2e-9;
    rule_outcome o = rule_run_spec_scaled("genz-continuous", 3, a3, u3, &s, 0);
    s.tol_abs = ldexp(2e-9, 600);
    rule_outcome x = rule_run_spec_scaled("genz-continuous", 3, a3, u3, &s, 600);
    assert_int_equal(o.err, 0);
    assert_int_equal(x.err, 0);
    assert_non_null(strstr(o.auto_reason, "rqmc with the rest of the budget"));
    assert_int_equal(x.res.flags, o.res.flags);
    assert_int_equal(x.method_used, o.method_used);
    assert_true(x.res.estimate == ldexp(o.res.estimate, 600));
    assert_true(x.res.error == ldexp(o.res.error, 600));
    assert_int_equal(x.res.evals, o.res.evals);
    /* at 2^996 a tolerance of 1e-30 scales below the smallest double: it
     * stays the least tolerance there is, never none (one round, no
     * not_converged) */
    s.tol_abs = 1e-30;
    x = rule_run_spec_scaled("genz-continuous", 3, a3, u3, &s, 996);
    assert_int_equal(x.err, 0);
    assert_true(x.res.flags & QMC_FLAG_NOT_CONVERGED);
}

static void test_pilot_counts_its_nonfinite(void **state)
{
    (void)state;
    /* a band that none of the midpoint rule's nodes at 8 an axis, nor
     * its check's, meet; its pilot's 2048 points meet some 20: they are
     * counted and said, and the pilot vouches for nothing */
    const nan_band band = {0.32, 0.33};
    qmc_integrate_report rep = kink_with_nan_run(&band, QMC_METHOD_MIDPOINT, 0);
    assert_int_equal(rep.res.evals, 173 + 2048); /* the rule's, the pilot's */
    assert_true(rep.res.nonfinite > 0 && rep.res.nonfinite < 100);
    assert_true(rep.res.flags & QMC_FLAG_NONFINITE);
    assert_true(rep.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
    assert_true(isfinite(rep.res.estimate));
}

/* x^-0.99 on (0,1], declared singular: 100 in all. */
static void pow_099(const void *ctx, const double *x, size_t n, uint32_t dims, double *out)
{
    (void)ctx;
    (void)dims;
    for (size_t i = 0; i < n; i++)
        out[i] = pow(x[i], -0.99);
}

static void test_auto_keeps_a_singular_rule(void **state)
{
    (void)state;
    /* Gauss-Kronrod does not converge on x^-0.99 and is flagged; RQMC's
     * variance there is infinite, so auto keeps the rule's answer */
    qmc_integrand f = {.eval = pow_099, .dims = 1, .smoothness = QMC_SMOOTH_SINGULAR,
                       .has_exact = 1, .exact = 100.0, .name = "x^-0.99"};
    qmc_integrate_spec s;
    qmc_integrate_spec_init(&s);
    s.method = QMC_METHOD_AUTO;
    s.max_evals = 1000000;
    qmc_integrate_report rep;
    char why[256];
    assert_int_equal(qmc_integrate(&s, &f, NULL, NULL, NULL, &rep, why, sizeof why), 0);
    assert_int_equal(rep.method_used, QMC_METHOD_GAUSS_KRONROD);
    assert_true(rep.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
    assert_true(rep.res.evals <= 500000);
    assert_null(strstr(rep.auto_reason, "rest of the budget"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_kink_bar_confirmed),
        cmocka_unit_test(test_kink_bar_raised),
        cmocka_unit_test(test_scaled_values),
        cmocka_unit_test(test_unresolved_stays),
        cmocka_unit_test(test_jump_bar_raised),
        cmocka_unit_test(test_disagreement_keeps_the_flag),
        cmocka_unit_test(test_pilot_in_doubt_confirms_nothing),
        cmocka_unit_test(test_refuted_by_gauss_kronrod),
        cmocka_unit_test(test_tolerance_not_claimed),
        cmocka_unit_test(test_no_pilot),
        cmocka_unit_test(test_deterministic),
        cmocka_unit_test(test_cancelled_in_the_pilot),
        cmocka_unit_test(test_memory_covers_the_pilot),
        cmocka_unit_test(test_auto_rqmc_vouches_for_the_rule),
        cmocka_unit_test(test_auto_rqmc_replaces_a_wrong_rule),
        cmocka_unit_test(test_auto_cubature_keeps_half_for_rqmc),
        cmocka_unit_test(test_auto_witness_in_doubt_vouches_for_nothing),
        cmocka_unit_test(test_auto_witness_refused_keeps_the_rule),
        cmocka_unit_test(test_auto_witness_counts_its_nonfinite),
        cmocka_unit_test(test_auto_witness_scales_the_tolerance),
        cmocka_unit_test(test_pilot_counts_its_nonfinite),
        cmocka_unit_test(test_auto_keeps_a_singular_rule),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
