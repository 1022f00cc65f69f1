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

/* Gauss-Kronrod from the declared breaks, within `left` evaluations. */
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
    size_t bytes = qmc_quad_gk_workspace_bytes(g.max_subdiv);
    void *ws = malloc(bytes);
    if (!ws)
        return 0;
    qmc_result r;
    int err = qmc_quad_gk(f, &g, ws, bytes, &r);
    free(ws);
    if (err)
        return 0; /* over budget, cancelled: nothing confirmed */
    res->evals += r.evals;
    const uint32_t doubt = QMC_FLAG_ERROR_UNRELIABLE | QMC_FLAG_NONFINITE | QMC_FLAG_ROUNDOFF |
                           QMC_FLAG_MAX_SUBDIV | QMC_FLAG_BUDGET | QMC_FLAG_NOT_CONVERGED;
    if ((r.flags & doubt) || !isfinite(r.estimate) || !isfinite(r.error))
        return 0;
    return fabs(res->estimate - r.estimate) + r.error <= 2.0 * res->error + slack;
}

static int is_tensor(qmc_method m, qmc_rule1d *rule)
{
    switch (m) {
    case QMC_METHOD_MIDPOINT: *rule = QMC_RULE1D_MIDPOINT; return 1;
    case QMC_METHOD_TRAPEZOID: *rule = QMC_RULE1D_TRAPEZOID; return 1;
    case QMC_METHOD_SIMPSON: *rule = QMC_RULE1D_SIMPSON; return 1;
    case QMC_METHOD_GAUSS_LEGENDRE: *rule = QMC_RULE1D_GAUSS_LEGENDRE; return 1;
    default: return 0;
    }
}

/* Whether qmc_quad_tensor ran its coarse level, both siblings and the
 * probe: it runs them only within the budget, and the result does not
 * say, but its evaluations do (n^d fine, at least 1 coarse, and the
 * check's own). */
static int tensor_checked(const qmc_integrate_spec *s, qmc_rule1d rule, const qmc_integrand *f,
                          const qmc_result *res)
{
    uint32_t n = s->n_axis ? s->n_axis : (rule == QMC_RULE1D_SIMPSON ? 17 : 16);
    uint64_t check = qmc_quad_tensor_check_evals(rule, n, f->dims);
    return check != UINT64_MAX && res->n <= UINT64_MAX - check - 1 &&
           res->evals >= res->n + check + 1;
}

uint32_t qmc__rule_smoothness_flags(const qmc_integrate_spec *s, const qmc_integrand *f,
                                    qmc_result *res)
{
    if (f->smoothness < QMC_SMOOTH_CONTINUOUS || s->method == QMC_METHOD_GAUSS_KRONROD)
        return 0;
    const uint32_t doubt = QMC_FLAG_ERROR_UNRELIABLE;
    if (f->smoothness >= QMC_SMOOTH_SINGULAR || (res->flags & QMC_FLAG_ERROR_UNRELIABLE) ||
        !isfinite(res->estimate) || !isfinite(res->error))
        return doubt; /* flagged already, or nothing to confirm */
    if (qmc__gk_breaks_usable(f)) {
        uint64_t left = s->max_evals > res->evals ? s->max_evals - res->evals : 0;
        return gk_confirms(s, f, res, left) ? 0 : doubt;
    }
    qmc_rule1d rule;
    if (f->smoothness == QMC_SMOOTH_CONTINUOUS && is_tensor(s->method, &rule) &&
        tensor_checked(s, rule, f, res))
        return 0;
    return doubt;
}
