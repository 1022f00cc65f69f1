/*
 * stability_cases.h - what the stability suite's files share: one call of
 * qmc_integrate on a named test function (run, or run_au under the audit's
 * budget 2e7 and seed 12345 with parameters a and u), the assertions on
 * its flags and interval, and closed forms written apart from the
 * library's.  The suite is split by failure class:
 *   test_stability.c          flags of the engine (nonfinite, heavy tail,
 *                             not_pow2, budgets, refusals, auto's choice)
 *   test_stability_rules.c    class 1: rules whose nodes miss a peak
 *   test_stability_samples.c  classes 2-3: zero spreads, untested tails
 *   test_stability_scenes.c   classes 4-5: MIS, tiny lights and budgets,
 *                             overflow, stratified past its strata
 */
#ifndef QMC_TESTS_STABILITY_CASES_H
#define QMC_TESTS_STABILITY_CASES_H

#include <stdint.h>

#include "qmc/integrate.h"

typedef struct run_out {
    int err;
    qmc_integrate_report rep;
    char why[256];
} run_out;

/* name on [0,1]^dims with its default parameters, by method, after tweak. */
run_out run(const char *name, uint32_t dims, qmc_method method,
            void (*tweak)(qmc_integrate_spec *));

/* name with parameters a and u (dims values each, or NULL for the
 * defaults) under the audit's budget and seed, then tweak. */
run_out run_au(const char *name, uint32_t dims, const double *a, const double *u,
               qmc_method method, void (*tweak)(qmc_integrate_spec *));

/* The Genz Gaussian exp(-sum a^2 (x - u)^2) integrates to prod sqrt(pi) /
 * (2a) (erf(a(1-u)) + erf(a u)); the discontinuous family exp(sum a x) on
 * x1 < u1, x2 < u2 (0 elsewhere) to prod_{j<2} (e^{a u} - 1) / a times
 * prod_{j>=2} (e^a - 1) / a. */
double gaussian_truth(uint32_t d, const double *a, const double *u);
double discontinuous_truth(uint32_t d, const double *a, const double *u);

#define ASSERT_FLAGS(o, want)                                                   \
    do {                                                                        \
        if ((o).err)                                                            \
            fail_msg("unexpected error %d: %s", (o).err, (o).why);              \
        if (((o).rep.res.flags & (want)) != (want))                             \
            fail_msg("flags 0x%x lack 0x%x", (o).rep.res.flags, (unsigned)(want)); \
    } while (0)

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

#endif
