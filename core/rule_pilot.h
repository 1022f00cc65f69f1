/*
 * rule_pilot.h - a deterministic rule's doubtful bar, checked by a small
 * randomized pilot that shares none of the rule's nodes (private to core/).
 *
 * A rule's bar comes from its own nodes: two levels, their siblings, a
 * rounding probe.  When those nodes cannot be trusted to see the integrand
 * - a declared kink or jump that Gauss-Kronrod from declared breaks could
 * not confirm (rule_confirm.h), a rule that does not resolve the integrand
 * (rule_evidence.h, a tensor rule's marginals, cubature's suspects), a rule
 * with no coarse level - the result carries error_unreliable.  Issue 23's
 * remedy is evidence from elsewhere: a pilot run through qmc_integrate, so
 * that every piece of sampling evidence (heavy_tail, few_nonzero,
 * zero_spread, tail_untested, nonfinite) and the integrand's audit (a
 * scene's mis_undersampled and zero_pdf) judges the pilot too.  On an
 * integrand declared analytic it is QMC_INTEGRATE_PILOT_REPS Owen-scrambled
 * Sobol replicates of m points (m a power of two, at least 16); on any
 * other, plain MC of as many points (rule_pilot.c says why).
 *
 * With the pilot's estimate P, its standard error se and t the two-sided
 * 99% Student-t quantile:
 *  - |rule - P| + t se <= 2 b + 32 ulps of the integral of |f|: the bar b
 *    stands, and the flag goes (whenever the pilot's interval holds, the
 *    truth lies within 2 bars; the stability matrix's yardstick is 3);
 *  - else |rule - P| <= t se: the pilot agrees within its own noise, which
 *    is coarser than the rule's claim; the bar is raised to (|rule - P| +
 *    t se) / 2, the same guarantee at the pilot's resolution, and the flag
 *    goes - for a tensor grid, or for an adaptive rule while the raised
 *    bar still meets the tolerance it stopped on (never claim a tolerance
 *    the evidence does not support); a raised bar of a tenth of the mass
 *    or more is `unresolved`, as rule_evidence.h would have it;
 *  - else bar and flag stay.
 * A pilot that carries any flag of its own (a peak it hit a few times, a
 * tiny light) vouches for nothing.
 *
 * Budget: at most what the rule left, and no more than the larger of
 * QMC_INTEGRATE_CONFIRM_EVALS and an eighth of the rule's evaluations,
 * nor 2^20, rounded down to 16 x a power of two; nothing below
 * QMC_INTEGRATE_PILOT_REPS x 16.  A caller that fits a rule to a budget
 * keeps a sixteenth for it (client/cli/method_spec.c).  The pilot's
 * evaluations are added to the result's.  Its seed is the request's
 * sampling seed, so the result stays a pure function of the request.
 *
 * Not for: a declared singularity (never confirmed), nonfinite results, a
 * bar Gauss-Kronrod refuted (the caller skips the pilot then).
 * Must not: change the estimate; lower the bar; clear any flag but
 * error_unreliable (unresolved stays, to say the rule did not resolve).
 */
#ifndef QMC_RULE_PILOT_H
#define QMC_RULE_PILOT_H

#include "qmc/integrate.h"
#include <stddef.h>

#include "qmc/result.h"

/* The relative tolerance cubature and Clenshaw-Curtis stop on when the
 * caller gives none (integrate.c); a raised bar must still meet it. */
#define QMC__CUBATURE_TOL_REL 1e-8

/* Checks the bar of rule s->method's finished result res on f: clears
 * QMC_FLAG_ERROR_UNRELIABLE (and may raise the bar) when a pilot vouches
 * for it, and adds the pilot's evaluations to res->evals.  0, or
 * QMC_ECANCELED when s->interrupt stopped the pilot: res is then the
 * cancelled result (estimate and bar 0; the rule's evaluations kept, the
 * cut-short pilot's not counted, as a cancelled sampling run reports
 * none) and why says so. */
int qmc__rule_pilot(const qmc_integrate_spec *s, const qmc_integrand *f, qmc_result *res,
                    char *why, size_t why_bytes);

/* The tolerance rule s->method stopped on with result res: the caller's,
 * else cubature's and Clenshaw-Curtis's QMC__CUBATURE_TOL_REL and
 * Gauss-Kronrod's default, relative to |res->estimate|; INFINITY for a
 * tensor grid, which has none. */
double qmc__rule_tolerance(const qmc_integrate_spec *s, const qmc_result *res);

/* The test above, of rule result res against a witness r that shares none
 * of its nodes (a clean randomized result: estimate, standard error) with
 * t the quantile for r's interval and tol the tolerance the rule stopped
 * on (INFINITY: none).  1 when r vouches for res's bar - res->error may
 * then have been raised, and QMC_FLAG_UNRESOLVED set - else 0, res as it
 * was.  Touches no other flag. */
int qmc__rule_bar_vouched(qmc_result *res, const qmc_result *r, double t, double tol);

/* The evaluations of the pilot after a rule that spent rule_evals and
 * left `left` (0: none fits). */
uint64_t qmc__rule_pilot_evals(uint64_t rule_evals, uint64_t left);

/* An upper bound on what any pilot within max_evals allocates on dims
 * dimensions (the rule's workspace is freed before the pilot runs;
 * integrate_memory.c). */
uint64_t qmc__rule_pilot_bytes(uint64_t max_evals, uint32_t dims);

#endif
