/*
 * scaled_integrand.h - f seen at the scale of a rule's result, for the
 * checks that sample it (private to core/: the rule's pilot, and the RQMC
 * that auto runs after a rule).
 *
 * A check sees f scaled by 2^-e, e the binary exponent of the rule's
 * integral, when that lies beyond 2^+-QMC__SCALE_PAST: a radiance of
 * 1e308 (overflow-light) overflowed a sampling check's sums of values and
 * of squares, so its own nonfinite flag vouched for nothing, while the
 * rule's sums held.  Scaling by a power of two is exact, and so is every
 * sum, mean and spread of the scaled values, short of underflow: the
 * check's result, scaled back, is the one it would have given with room
 * for its sums.  The integrand's audit sees results scaled back.
 */
#ifndef QMC_SCALED_INTEGRAND_H
#define QMC_SCALED_INTEGRAND_H

#include "qmc/integrand.h"
#include "qmc/result.h"

#define QMC__SCALE_PAST 128

typedef struct qmc__scaled_integrand {
    qmc_integrand g;          /* f times 2^-e: what the check integrates */
    const qmc_integrand *f;
    int e;                    /* 0: g is f itself */
    double factor;            /* 2^-e, exact */
} qmc__scaled_integrand;

/* s->g becomes f seen at the scale of rule result res.  g points into s:
 * s must stay where it is while g is used. */
void qmc__scaled_integrand_init(qmc__scaled_integrand *s, const qmc_integrand *f,
                                const qmc_result *res);

/* r, a result on s->g (e from it), back in f's own units: every quantity
 * measured in them times 2^e (the standard error too; counts and flags
 * are unchanged).  Nothing when e is 0. */
void qmc__unscale_result(qmc_result *r, int e);

#endif
