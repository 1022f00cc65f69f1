/*
 * rule_confirm.h - whether a deterministic rule's bar on an integrand that
 * declares a kink or a jump is confirmed by evidence independent of the
 * rule's own levels (private to core/).
 *
 * A polynomial rule's bar assumes the integrand is smooth where it samples;
 * across a jump two levels can agree while both are wrong, and across a
 * kink they often do.  Every rule's bar on such an integrand used to carry
 * error_unreliable, right or wrong: on `qmc stability` that was a third of
 * the flags on correct answers.  The flag now stays unless this confirms
 * the bar:
 *  - 1D, breaks declared (qmc_integrand.breaks): Gauss-Kronrod started from
 *    the breaks, so that each piece is smooth and its bar QUADPACK's own,
 *    run to a quarter of the rule's bar within QMC_INTEGRATE_CONFIRM_EVALS and
 *    the budget the rule left.  Confirmed when |rule - GK| + GK's bar is at
 *    most twice the rule's bar (plus 32 ulps of the integral of |f|), so
 *    the truth lies within 3 bars whenever GK's bar holds.  Its
 *    evaluations are added to the result's.
 * Failing that, an RQMC pilot may (rule_pilot.h).  Not a tensor rule's
 * siblings: on kinks they
 * agree with the estimate by phase as the levels do (genz-continuous, d =
 * 2-3, 4000 random runs of the four tensor rules at 16-65 nodes an axis:
 * 7 wrong by 3.5 to 22 bars with the siblings agreeing), and a jump next
 * to an end point or a narrow spike of a scene's MIS weight sits beyond
 * every level's and every sibling's nodes (jump-step-end-1d,
 * tiny-light/mis-balance in `qmc stability`: wrong under bars of 1e-17
 * that only this flag marked).  A declared singularity is never
 * confirmed for the other rules.  Gauss-Kronrod is judged by its own
 * floors (integrate.c) on kinks and jumps; on a declared singularity its
 * converged bar is checked here by a second run at a sixteenth of the
 * tolerance (rule_confirm.c says why), and flagged unless that agrees.
 * Must not: change the estimate or the bar.
 */
#ifndef QMC_RULE_CONFIRM_H
#define QMC_RULE_CONFIRM_H

#include "qmc/integrate.h"
#include "qmc/result.h"

/* The flags the declared smoothness adds to rule s->method's finished
 * result res on f (QMC_FLAG_ERROR_UNRELIABLE or 0); adds the check's
 * evaluations to res->evals.  *refuted is 1 when Gauss-Kronrod ran clean
 * and disagrees with the bar: then nothing may vouch for it later
 * (rule_pilot.h).  f is the integrand itself, not a watched view: the
 * check's nodes are not the rule's. */
uint32_t qmc__rule_smoothness_flags(const qmc_integrate_spec *s, const qmc_integrand *f,
                                    qmc_result *res, int *refuted);

#endif
