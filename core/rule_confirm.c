/*
 * rule_confirm.c - a rule's bar on a declared kink or jump, confirmed by
 * evidence that is not the rule's (see rule_confirm.h for the rules and
 * for what it must not do).
 */
#include <float.h>
#include <math.h>
#include <stdlib.h>

#include "quad_impl.h"
#include "rule_confirm.h"
#include "qmc/quad.h"

/* Gauss-Kronrod under g into *r: 1 when it ran and came out clean (no
 * flag that doubts its bar, finite estimate and bar), else 0.  Its
 * evaluations are added to res's when it ran. */
static int gk_clean_run(const qmc_integrand *f, const qmc_quad_gk_opts *g, qmc_result *res,
                        qmc_result *r)
{
    size_t bytes = qmc_quad_gk_workspace_bytes(g->max_subdiv);
    void *ws = malloc(bytes);
    if (!ws)
        return 0;
    int err = qmc_quad_gk(f, g, ws, bytes, r);
    free(ws);
    if (err)
        return 0; /* no room, cancelled: nothing to go by */
    res->evals += r->evals;
    const uint32_t doubt = QMC_FLAG_ERROR_UNRELIABLE | QMC_FLAG_NONFINITE | QMC_FLAG_ROUNDOFF |
                           QMC_FLAG_MAX_SUBDIV | QMC_FLAG_BUDGET | QMC_FLAG_NOT_CONVERGED;
    return !(r->flags & doubt) && isfinite(r->estimate) && isfinite(r->error);
}

/* Gauss-Kronrod from the declared breaks, within `left` evaluations: 1
 * when it confirms the bar, -1 when it refutes it (GK ran clean and
 * disagrees), 0 when it cannot tell. */
static int gk_confirms(const qmc_integrate_spec *s, const qmc_integrand *f, qmc_result *res,
                       uint64_t left)
{
    qmc_quad_gk_opts g;
    qmc_quad_gk_opts_init(&g);
    const double scale = fmax(fabs(res->estimate), res->abs_integral);
    const double slack = 32.0 * DBL_EPSILON * scale;
    g.tol_abs = fmax(0.25 * res->error, slack);
    g.tol_rel = 0.0;
    if (!(g.tol_abs > 0.0))
        g.tol_abs = DBL_MIN;
    g.max_evals = left < QMC_INTEGRATE_CONFIRM_EVALS ? left : QMC_INTEGRATE_CONFIRM_EVALS;
    g.interrupt = s->interrupt;
    qmc_result r;
    if (!gk_clean_run(f, &g, res, &r))
        return 0;
    return fabs(res->estimate - r.estimate) + r.error <= 2.0 * res->error + slack ? 1 : -1;
}

/*
 * Gauss-Kronrod's converged bar on a declared singularity, checked by a
 * second run at a sixteenth of its tolerance within what the budget left:
 * confirmed when that run converged clean and |first - second| + its bar
 * is at most twice the first bar.  Bisection toward a power singularity
 * x^-p repeats itself at every level, so each run's bar misses the same
 * share of the end interval's error; the difference between the two runs
 * is most of the first run's actual error, which its own bar cannot show
 * (x^-0.97 at a relative tolerance of 1e-2 converged to 32.28 +- 0.32
 * against 33.33, unflagged).  x^-1/2 and log x confirm in a few hundred
 * evaluations more.
 */
static int gk_singular_confirmed(const qmc_integrate_spec *s, const qmc_integrand *f,
                                 qmc_result *res)
{
    qmc_quad_gk_opts g;
    qmc_quad_gk_opts_init(&g);
    if (s->tol_abs > 0 || s->tol_rel > 0) {
        g.tol_abs = s->tol_abs;
        g.tol_rel = s->tol_rel;
    }
    g.tol_abs /= 16.0;
    g.tol_rel /= 16.0;
    g.max_evals = s->max_evals > res->evals ? s->max_evals - res->evals : 0;
    g.interrupt = s->interrupt;
    qmc_result r;
    if (!gk_clean_run(f, &g, res, &r))
        return 0;
    const double slack = 32.0 * DBL_EPSILON * fmax(fabs(res->estimate), fabs(r.estimate));
    return fabs(res->estimate - r.estimate) + r.error <= 2.0 * res->error + slack;
}

uint32_t qmc__rule_smoothness_flags(const qmc_integrate_spec *s, const qmc_integrand *f,
                                    qmc_result *res, int *refuted)
{
    *refuted = 0;
    if (s->method == QMC_METHOD_GAUSS_KRONROD) {
        /* its floors judge kinks and jumps (integrate.c); a declared
         * singularity that did not converge is flagged already */
        if (f->smoothness < QMC_SMOOTH_SINGULAR || (res->flags & QMC_FLAG_ERROR_UNRELIABLE) ||
            !isfinite(res->estimate) || !isfinite(res->error))
            return 0;
        return gk_singular_confirmed(s, f, res) ? 0 : QMC_FLAG_ERROR_UNRELIABLE;
    }
    if (f->smoothness < QMC_SMOOTH_CONTINUOUS)
        return 0;
    const uint32_t doubt = QMC_FLAG_ERROR_UNRELIABLE;
    if (f->smoothness >= QMC_SMOOTH_SINGULAR || (res->flags & QMC_FLAG_ERROR_UNRELIABLE) ||
        !isfinite(res->estimate) || !isfinite(res->error))
        return doubt; /* flagged already, or nothing to confirm */
    if (!qmc__gk_breaks_usable(f))
        return doubt;
    uint64_t left = s->max_evals > res->evals ? s->max_evals - res->evals : 0;
    const int verdict = gk_confirms(s, f, res, left);
    *refuted = verdict < 0;
    return verdict > 0 ? 0 : doubt;
}
