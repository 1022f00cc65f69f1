/*
 * stability.c - classifies integration results against independent
 * references (qmc/stability.h).  Pure: no method runs here, nothing is
 * printed; the CLI's `qmc stability` and `qmc compare` call it.
 */
#include <float.h>
#include <math.h>

#include "qmc/stability.h"

qmc_stab_verdict qmc_stab_classify(int refused, const qmc_result *r,
                                   const qmc_stab_truth *truth)
{
    qmc_stab_verdict v = {QMC_STAB_REFUSED, 0, 0, NAN, NAN};
    if (refused || !r)
        return v;
    v.bar_usable = r->error_kind != QMC_ERROR_NONE && isfinite(r->error) && r->error >= 0;
    if (truth->defined && isfinite(truth->value) && isfinite(r->estimate)) {
        v.abs_error = fabs(r->estimate - truth->value);
        v.ratio = r->error > 0 ? v.abs_error / r->error : (v.abs_error > 0 ? INFINITY : 0);
        /* the slack scales with the integral of |f|: the truth's when known,
         * else the method's own estimate of it (rounding only) */
        double scale = fmax(fabs(truth->value), fmax(truth->scale, r->abs_integral));
        double slack = QMC_STAB_ROUNDING_ULPS * DBL_EPSILON * scale;
        double allowed = QMC_STAB_COVER_FACTOR * r->error + truth->abs_error + slack;
        v.covered = v.bar_usable && v.abs_error <= allowed;
    }
    if (v.covered)
        v.cls = QMC_STAB_OK;
    else if (r->flags != 0 || r->error_kind == QMC_ERROR_NONE)
        v.cls = QMC_STAB_FLAGGED;
    else
        v.cls = QMC_STAB_SILENT;
    return v;
}

/* log of the binomial coefficient, through lgamma (exact enough here: the
 * threshold only needs the tail to about a percent). */
static double log_choose(uint32_t n, uint32_t k)
{
    return lgamma((double)n + 1) - lgamma((double)k + 1) - lgamma((double)(n - k) + 1);
}

uint32_t qmc_stab_silent_threshold(uint32_t runs, double p_chance, double alpha)
{
    if (runs <= 1 || !(p_chance > 0 && p_chance < 1))
        return 1;
    /* tail[s] = P(X >= s), summed from the top down */
    double tail = 0;
    uint32_t best = runs + 1;
    for (uint32_t s = runs + 1; s-- > 1;) {
        tail += exp(log_choose(runs, s) + s * log(p_chance) + (runs - s) * log1p(-p_chance));
        if (tail < alpha)
            best = s;
        else
            break;
    }
    return best > runs ? runs : best;
}

uint32_t qmc_stab_silent_needed(uint32_t runs, int randomized)
{
    if (!randomized)
        return 1;
    return qmc_stab_silent_threshold(runs, QMC_STAB_CHANCE_MISS, QMC_STAB_SILENT_ALPHA);
}

void qmc_stab_flag_tally_add(qmc_stab_flag_tally *t, int refused, const qmc_stab_verdict *v,
                             const qmc_result *r)
{
    if (refused || !r || r->error_kind == QMC_ERROR_NONE)
        return;
    const int ok = v->covered;
    uint32_t *on = ok ? t->on_correct : t->on_wrong;
    *(ok ? &t->correct : &t->wrong) += 1;
    if (r->flags)
        *(ok ? &t->correct_flagged : &t->wrong_flagged) += 1;
    for (int b = 0; b < 32; b++)
        on[b] += (r->flags >> b) & 1u;
}

void qmc_stab_flag_tally_merge(qmc_stab_flag_tally *into, const qmc_stab_flag_tally *from)
{
    into->correct += from->correct;
    into->wrong += from->wrong;
    into->correct_flagged += from->correct_flagged;
    into->wrong_flagged += from->wrong_flagged;
    for (int b = 0; b < 32; b++) {
        into->on_correct[b] += from->on_correct[b];
        into->on_wrong[b] += from->on_wrong[b];
    }
}

void qmc_stab_tally_add(qmc_stab_tally *t, const qmc_stab_verdict *v, const qmc_result *r)
{
    t->runs++;
    switch (v->cls) {
    case QMC_STAB_OK:
        t->ok++;
        if (r && r->flags)
            t->ok_flagged++;
        break;
    case QMC_STAB_FLAGGED: t->flagged++; break;
    case QMC_STAB_REFUSED: t->refused++; break;
    case QMC_STAB_SILENT: t->silent++; break;
    }
}

qmc_stab_class qmc_stab_tally_class(const qmc_stab_tally *t, uint32_t threshold)
{
    if (t->runs == 0)
        return QMC_STAB_REFUSED;
    if (t->silent >= (threshold ? threshold : 1))
        return QMC_STAB_SILENT;
    if (t->refused == t->runs)
        return QMC_STAB_REFUSED;
    if (2 * (t->flagged + t->silent) >= t->runs - t->refused)
        return QMC_STAB_FLAGGED;
    return QMC_STAB_OK;
}

const char *qmc_stab_class_name(qmc_stab_class c)
{
    switch (c) {
#define QMC__STAB_NAME(name, value, text) case QMC_STAB_##name: return text;
    QMC_STAB_CLASS_MAP(QMC__STAB_NAME)
#undef QMC__STAB_NAME
    }
    return "";
}
