/*
 * test_scale_invariance.c - every deterministic rule, with the checks on
 * its bar (the tensor rules' siblings and rounding probe, Gauss-Kronrod
 * from declared breaks, the randomized pilot), gives for f times 2^e
 * exactly its result for f times 2^e: same flags, same evaluations.
 *
 * The oracle is arithmetic, not the code: multiplying by a power of two
 * is exact, and so is every sum, difference, product, quotient and square
 * root of scaled values while all of them stay normal doubles.  e = +-600
 * keeps the values normal (genz functions lie in [1e-7, 1] here) while
 * their squares leave the doubles: 2^1200 overflows, 2^-1200 is 0.  The
 * tensor rules' rounding probe squared its differences and reported a bar
 * of inf with `roundoff` at 2^600; the pilot's sums of squares overflowed
 * and it vouched for nothing.
 *
 * The sampling methods do not pass this: their sums of squares are the
 * protocol's part format (qmc_sampling_sums), so past about 2^+-500 their
 * bar is inf or 0.  What must hold for them is that such a bar is never
 * printed bare: error_unreliable is set (docs/FLAGS.md, "Values near the
 * ends of the doubles").
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <string.h>

#include "rule_run.h"
#include "qmc/integrate.h"
#include "qmc/sampling.h"

typedef struct scale_case {
    const char *name;
    uint32_t dims;
    double a[3], u[3];
} scale_case;

/* a kink (3D), a smooth peak (1D), jumps (2D), an oscillation (2D) */
static const scale_case cases[] = {
    {"genz-continuous", 3, {5, 3, 7}, {0.31, 0.62, 0.47}},
    {"genz-gaussian", 1, {30, 0, 0}, {0.37, 0, 0}},
    {"genz-discontinuous", 2, {3, 2, 0}, {0.3, 0.6, 0}},
    {"genz-oscillatory", 2, {3, 2, 0}, {0.3, 0.6, 0}},
};

static const int exps[] = {600, -600};

static void spec_for(qmc_method m, qmc_integrate_spec *s)
{
    qmc_integrate_spec_init(s);
    s->method = m;
    s->max_evals = UINT64_C(1) << 16;
    qmc_sampler smp = QMC_SAMPLER_MC;
    if (m == QMC_METHOD_LHS)
        smp = QMC_SAMPLER_LHS;
    else if (m == QMC_METHOD_RQMC)
        smp = QMC_SAMPLER_RQMC;
    qmc_sampling_spec_init(&s->sampling, smp);
    s->sampling.seed = 7;
    if (m == QMC_METHOD_MC || m == QMC_METHOD_LHS) {
        s->sampling.n = UINT64_C(1) << 16;
        s->sampling.reps = 1;
        s->n_given = 1;
    } else if (m == QMC_METHOD_RQMC) {
        s->sampling.n = 4096;
        s->sampling.reps = 16;
        s->n_given = 1;
    }
}

static void test_rules_scale_exactly(void **state)
{
    (void)state;
    const qmc_method rules[] = {QMC_METHOD_MIDPOINT,       QMC_METHOD_TRAPEZOID,
                                QMC_METHOD_SIMPSON,        QMC_METHOD_GAUSS_LEGENDRE,
                                QMC_METHOD_GAUSS_KRONROD,  QMC_METHOD_CUBATURE,
                                QMC_METHOD_CLENSHAW_CURTIS, QMC_METHOD_AUTO};
    int runs = 0, flagged = 0;
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++)
        for (size_t r = 0; r < sizeof rules / sizeof rules[0]; r++) {
            if (rules[r] == QMC_METHOD_GAUSS_KRONROD && cases[c].dims != 1)
                continue;
            qmc_integrate_spec s;
            spec_for(rules[r], &s);
            const scale_case *k = &cases[c];
            rule_outcome o = rule_run_spec_scaled(k->name, k->dims, k->a, k->u, &s, 0);
            assert_int_equal(o.err, 0);
            if (o.res.error_kind != QMC_ERROR_ESTIMATE) {
                /* auto chose a sampling method (RQMC on the 2D jumps) */
                assert_int_equal(rules[r], QMC_METHOD_AUTO);
                continue;
            }
            flagged += o.res.flags != 0;
            for (size_t e = 0; e < 2; e++) {
                rule_outcome x = rule_run_spec_scaled(k->name, k->dims, k->a, k->u, &s, exps[e]);
                if (x.err != 0 || x.res.flags != o.res.flags ||
                    x.res.estimate != ldexp(o.res.estimate, exps[e]) ||
                    x.res.error != ldexp(o.res.error, exps[e]) || x.res.evals != o.res.evals)
                    fail_msg("%s by %s at 2^%d: flags %#x (unscaled %#x), bar %.17g "
                             "(unscaled %.17g), evals %llu (%llu)",
                             k->name, qmc_method_name(rules[r]), exps[e], x.res.flags,
                             o.res.flags, ldexp(x.res.error, -exps[e]), o.res.error,
                             (unsigned long long)x.res.evals, (unsigned long long)o.res.evals);
                runs++;
            }
        }
    assert_true(runs >= 2 * (4 * 6 + 1 + 3)); /* auto chose a rule on 3 of 4 */
    /* the checks ran: some results carry flags (cubature on jumps), so the
     * comparison covers the pilot's and rule_evidence's paths too */
    assert_true(flagged > 0);
}

static void test_sampling_never_bare(void **state)
{
    (void)state;
    const qmc_method methods[] = {QMC_METHOD_MC, QMC_METHOD_LHS, QMC_METHOD_RQMC};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++)
        for (size_t m = 0; m < 3; m++)
            for (size_t e = 0; e < 2; e++) {
                qmc_integrate_spec s;
                spec_for(methods[m], &s);
                const scale_case *k = &cases[c];
                rule_outcome x = rule_run_spec_scaled(k->name, k->dims, k->a, k->u, &s, exps[e]);
                assert_int_equal(x.err, 0);
                /* a bar that is exact: scaled with the value; else flagged */
                rule_outcome o = rule_run_spec_scaled(k->name, k->dims, k->a, k->u, &s, 0);
                if (x.res.error != ldexp(o.res.error, exps[e]))
                    assert_true(x.res.flags & QMC_FLAG_ERROR_UNRELIABLE);
                assert_true(x.res.estimate == ldexp(o.res.estimate, exps[e]));
            }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rules_scale_exactly),
        cmocka_unit_test(test_sampling_never_bare),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
