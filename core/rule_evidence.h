/*
 * rule_evidence.h - what a deterministic rule's nodes saw (private).
 *
 * A polynomial rule's bar is |fine - coarse|: two levels of the same rule.
 * When every node misses a narrow peak, both levels agree at (near) zero
 * and the bar says "exact".  The nodes' own values are the only evidence
 * of that, so qmc_integrate watches them: it wraps the integrand, counts
 * the nonzero values and sums |f|, and after the rule returns raises
 * QMC_FLAG_UNRESOLVED (with QMC_FLAG_ERROR_UNRELIABLE) when
 *  - no node returned a nonzero finite value (0 +- 0: the rule cannot tell
 *    a zero integrand from a peak between its nodes), or some did, all of
 *    one sign, and the estimate is exactly 0 (the nodes that saw mass were
 *    refined away), or
 *  - the bar is at least QMC__UNRESOLVED_SHARE (a tenth) of the mass
 *    scale max(|estimate|, the rule's own integral of |f|; without one,
 *    mean |f| over the nodes): |fine - coarse| is
 *    an error estimate only once the rule is in its asymptotic regime,
 *    and a bar that large says it is not (the tensor rules' miss of a
 *    peak reports 7.7e-64 +- 7.7e-64 where the truth is 2e-5; Simpson on
 *    a 3D peak 4.6e-10 +- 1.7e-10 where it is 1.6e-6).  The rule's
 *    weighted sum of |f| (qmc_result.abs_integral), not the nodes' plain
 *    mean, where the rule keeps one: Gauss-Legendre's end nodes carry small
 *    weights, and a corner peak's large values there made the mean |f|
 *    hundreds of times the integral (genz-product-peak, a = 1e4 at a
 *    corner: a bar 93% of the estimate passed).
 * Must not: change a value (the wrapper passes them through, so results
 * are bit for bit those without it), or be used where several threads
 * evaluate at once (the counters are plain; the rules run on the caller's
 * thread).
 */
#ifndef QMC_RULE_EVIDENCE_H
#define QMC_RULE_EVIDENCE_H

#include <stdint.h>

#include "qmc/integrand.h"
#include "qmc/result.h"

#define QMC__UNRESOLVED_SHARE 0.1

typedef struct qmc__node_stats {
    uint64_t evals;    /* node values seen */
    uint64_t nonzero;  /* of which finite and not 0 */
    uint64_t positive; /* of those, > 0 */
    double sum_abs;    /* sum of |f| over those */
} qmc__node_stats;

typedef struct qmc__node_watch {
    qmc_integrand view;       /* what the rule integrates: f, watched */
    const qmc_integrand *inner;
    qmc__node_stats *stats;   /* the caller's; zeroed by init */
} qmc__node_watch;

/* Makes w->view an integrand equal to f that counts into *stats. */
void qmc__node_watch_init(qmc__node_watch *w, const qmc_integrand *f, qmc__node_stats *stats);

/* The flags the nodes' evidence adds to a rule's finished result. */
uint32_t qmc__rule_evidence_flags(const qmc_result *res, const qmc__node_stats *stats);

#endif
