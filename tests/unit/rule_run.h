/*
 * rule_run.h - one integration of a named test function, for the unit
 * tests of the checks on a rule's bar (test_rule_confirm.c,
 * test_rule_pilot.c): the result and the function's closed-form truth.
 */
#ifndef QMC_TEST_RULE_RUN_H
#define QMC_TEST_RULE_RUN_H

#include <stdint.h>

#include "qmc/integrate.h"
#include "qmc/result.h"

typedef struct rule_outcome {
    int err;         /* qmc_integrate's return */
    qmc_result res;
    double truth;    /* the test function's exact integral */
    qmc_method method_used;                  /* auto's choice, else the method */
    char auto_reason[QMC_AUTO_REASON_BYTES]; /* why, for auto */
} rule_outcome;

/* name on dims (a, u: dims parameters each, or NULL) by spec s. */
rule_outcome rule_run_spec(const char *name, uint32_t dims, const double *a, const double *u,
                           const qmc_integrate_spec *s);

/* The same by method at n_axis points an axis (0: the method's default)
 * within max_evals (0: the default budget); fails the test on an error. */
rule_outcome rule_run(const char *name, uint32_t dims, const double *a, const double *u,
                      qmc_method method, uint32_t n_axis, uint64_t max_evals);

/* The same on the function times 2^e (its truth scaled with it): a
 * power of two, so that every exact scale-invariant computation must come
 * out as the unscaled one times 2^e. */
rule_outcome rule_run_spec_scaled(const char *name, uint32_t dims, const double *a,
                                  const double *u, const qmc_integrate_spec *s, int e);

/* The same as rule_run with the default budget, on the function times
 * 2^e (its truth scaled with it). */
rule_outcome rule_run_scaled(const char *name, uint32_t dims, const double *a, const double *u,
                             qmc_method method, uint32_t n_axis, int e);

/* |estimate - truth| <= 3 bars + 64 ulps of the truth, as qmc stability
 * judges. */
int rule_covers(const rule_outcome *o);

#endif
