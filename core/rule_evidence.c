/*
 * rule_evidence.c - watching a rule's nodes for mass it cannot see (see
 * rule_evidence.h for why and for what it must not do).
 */
#include <float.h>
#include <math.h>
#include <string.h>

#include "rule_evidence.h"

static void watched_eval(const void *ctx, const double *x, size_t n, uint32_t dims,
                         double *out)
{
    const qmc__node_watch *w = ctx;
    w->inner->eval(w->inner->ctx, x, n, dims, out);
    /* Branch-free, in locals, so the watch costs a pass over values the
     * rule has just written (cubature's cheap integrands notice a branch
     * per value). */
    uint64_t nonzero = 0, positive = 0;
    double sum_abs = 0.0;
    for (size_t i = 0; i < n; i++) {
        double a = fabs(out[i]);
        int live = a > 0.0 && a <= DBL_MAX; /* finite and not 0; NaN fails both */
        nonzero += (uint64_t)live;
        positive += (uint64_t)(live & (out[i] > 0.0));
        sum_abs += live ? a : 0.0;
    }
    qmc__node_stats *st = w->stats;
    st->evals += n;
    st->nonzero += nonzero;
    st->positive += positive;
    st->sum_abs += sum_abs;
}

void qmc__node_watch_init(qmc__node_watch *w, const qmc_integrand *f, qmc__node_stats *stats)
{
    memset(stats, 0, sizeof *stats);
    w->view = *f;
    w->view.eval = watched_eval;
    w->view.ctx = w;
    w->inner = f;
    w->stats = stats;
}

uint32_t qmc__rule_evidence_flags(const qmc_result *res, const qmc__node_stats *stats)
{
    if (stats->evals == 0 || !isfinite(res->estimate))
        return 0; /* cancelled, or nonfinite already says it */
    const uint32_t blind = QMC_FLAG_UNRESOLVED | QMC_FLAG_ERROR_UNRELIABLE;
    /* No node saw mass, or some did, all of one sign, and the rule's answer
     * kept none of it: cubature's root saw 7e-22 in the tail of a 1D peak
     * (a = 2371), its halves saw 0, and it reported 0 +- 0 against 7.5e-4.
     * Values of both signs can cancel to 0 honestly (an odd polynomial
     * about the centre, the stability suite's zero-poly case). */
    const int one_sign = stats->positive == 0 || stats->positive == stats->nonzero;
    if (stats->nonzero == 0 || (res->estimate == 0.0 && one_sign))
        return blind;
    const double abs_int = res->abs_integral > 0 ? res->abs_integral
                                                 : stats->sum_abs / (double)stats->evals;
    const double mass = fmax(fabs(res->estimate), abs_int);
    if (!(res->error < QMC__UNRESOLVED_SHARE * mass))
        return blind;
    return 0;
}
