/*
 * vegas_map.c - the VEGAS map and its training (see vegas_map.h).
 *
 * Training: up to MAX_ROUNDS rounds of owen-scrambled Sobol points over u
 * (as many as the pilot affords at MIN_DIM_POINTS points per dimension,
 * at least MIN_ROUNDS).  Round 0
 * uses the identity map; after each round but the last, every axis
 * accumulates (f J)^2 per bin of u, and the bins are redrawn so that each
 * holds an equal share of the smoothed, damped sums (Lepage 2021, section
 * 2: smoothing (d[i-1] + 6 d[i] + d[i+1]) / 8, damping ((1 - d) / ln(1/d))
 * ^ ALPHA).  The last round only measures: its map is the one returned,
 * and its variance is the one reported, so the decision to use the map is
 * made on the map itself.  A map that has not halved the variance after
 * EARLY_ROUND rounds stops there (a flat integrand such as the oscillatory
 * family never gains, and the rest of its pilot would be wasted).  Every
 * bin keeps at least FLOOR of the mean
 * share, so the density never vanishes where the pilot saw f = 0 (a zero
 * density there would make the estimate biased for an f that is not zero
 * somewhere the pilot missed).
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "bits.h"
#include "interrupt.h"
#include "qmc/error.h"
#include "qmc/seq.h"
#include "vegas_map.h"

enum {
    MAX_ROUNDS = 12,
    MIN_ROUNDS = 4,
    EARLY_ROUND = 3,      /* the round that must show EARLY_GAIN */
    EARLY_GAIN = 2,
    MAX_BINS = 64,
    MIN_BIN_POINTS = 8,   /* pilot points per bin per round, at least */
    MIN_DIM_POINTS = 48,  /* pilot points per round per dimension, at least:
                             with 28 (d = 30, 833 a round) maps of the
                             corner-peak family passed every check and still
                             missed 60% of the integral */
    STACK_DOUBLES = 2048  /* the mapped eval's buffer: 16 KiB of x, + J */
};
static const double ALPHA = 1.0;  /* damping: 0 freezes the grid */
static const double FLOOR = 0.02; /* least share of a bin, of the mean */
static const uint64_t TAG_VMAP = 0x766d6170; /* "vmap" */

struct qmc__vmap {
    const qmc_integrand *f;
    qmc_integrand mapped;
    uint32_t dims, bins;
    double *edges;     /* dims x (bins + 1) */
    double *widths;    /* dims x bins */
    double *jacobians; /* dims x bins: bins x width, the axis's dx/du */
};

/* Maps n points u (n x d) to x, with the Jacobian of each: axis by axis,
 * so that the products of the points' Jacobians are independent chains
 * (point by point they were one chain of d dependent multiplies, and
 * mapping took 46% of an RQMC run at d = 30).  Each point's product still
 * runs over the axes in order: the bits do not depend on the batch. */
static void map_points(const qmc__vmap *m, const double *u, size_t n, double *x, double *jac)
{
    const uint32_t d = m->dims, b = m->bins;
    const double top = (double)b, below_one = 0x1.fffffffffffffp-1;
    for (size_t p = 0; p < n; p++)
        jac[p] = 1.0;
    for (uint32_t i = 0; i < d; i++) {
        const double *e = m->edges + (size_t)i * (b + 1), *w = m->widths + (size_t)i * b,
                     *jw = m->jacobians + (size_t)i * b;
        for (size_t p = 0; p < n; p++) {
            const double t = u[p * d + i] * top;
            const uint32_t k = t >= top ? b - 1 : (uint32_t)t;
            const double xi = e[k] + w[k] * (t - (double)k);
            /* Rounding may land on 1; the integrand's domain is [0,1). */
            x[p * d + i] = xi < 1.0 ? xi : below_one;
            jac[p] *= jw[k];
        }
    }
}

static void mapped_eval(const void *ctx, const double *u, size_t n, uint32_t dims, double *out)
{
    const qmc__vmap *m = ctx;
    double x[STACK_DOUBLES], jac[STACK_DOUBLES];
    const size_t step = STACK_DOUBLES / dims; /* >= 16: dims <= QMC__VMAP_MAX_DIMS */
    for (size_t p0 = 0; p0 < n; p0 += step) {
        size_t k = n - p0 < step ? n - p0 : step;
        map_points(m, u + p0 * dims, k, x, jac);
        m->f->eval(m->f->ctx, x, k, dims, out + p0);
        for (size_t p = 0; p < k; p++)
            out[p0 + p] *= jac[p];
    }
}

static void set_widths(qmc__vmap *m, uint32_t axis)
{
    const double *e = m->edges + (size_t)axis * (m->bins + 1);
    double *w = m->widths + (size_t)axis * m->bins;
    double *jw = m->jacobians + (size_t)axis * m->bins;
    for (uint32_t k = 0; k < m->bins; k++) {
        w[k] = e[k + 1] - e[k];
        jw[k] = (double)m->bins * w[k];
    }
}

/* Redraws axis `axis` from its per-bin sums d (Lepage 2021, eq. 22-23);
 * tmp holds 2 * (bins + 1) doubles. */
static void refine_axis(qmc__vmap *m, uint32_t axis, const double *d, double *tmp)
{
    const uint32_t b = m->bins;
    double *e = m->edges + (size_t)axis * (b + 1);
    double *s = tmp, *ne = tmp + b + 1;
    double total = 0;
    for (uint32_t k = 0; k < b; k++) {
        double left = k ? d[k - 1] : d[k], right = k + 1 < b ? d[k + 1] : d[k];
        s[k] = (left + 6.0 * d[k] + right) / 8.0;
        total += s[k];
    }
    if (!(total > 0.0) || !isfinite(total))
        return; /* f was 0 everywhere the pilot looked: nothing to learn */
    double sum = 0;
    for (uint32_t k = 0; k < b; k++) {
        double r = s[k] / total;
        s[k] = r <= 0.0 ? 0.0 : r >= 1.0 ? 1.0 : pow((1.0 - r) / -log(r), ALPHA);
        sum += s[k];
    }
    const double least = FLOOR * sum / (double)b;
    sum = 0;
    for (uint32_t k = 0; k < b; k++) {
        s[k] = s[k] < least ? least : s[k];
        sum += s[k];
    }
    /* New edges: equal shares of s, linear within an old bin. */
    const double share = sum / (double)b;
    double acc = 0;
    uint32_t j = 0;
    ne[0] = 0.0;
    for (uint32_t k = 1; k < b; k++) {
        const double target = share * (double)k;
        while (j + 1 < b && acc + s[j] < target)
            acc += s[j++];
        double f = (target - acc) / s[j];
        f = f < 0.0 ? 0.0 : f > 1.0 ? 1.0 : f;
        ne[k] = e[j] + f * (e[j + 1] - e[j]);
    }
    ne[b] = 1.0;
    memcpy(e, ne, (b + 1) * sizeof *e);
    set_widths(m, axis);
}

void qmc__vmap_free(qmc__vmap *m)
{
    if (!m)
        return;
    free(m->edges);
    free(m);
}

const qmc_integrand *qmc__vmap_integrand(const qmc__vmap *m)
{
    return &m->mapped;
}

const double *qmc__vmap_edges(const qmc__vmap *m, uint32_t axis)
{
    return m->edges + (size_t)axis * (m->bins + 1);
}

/* Mirrors vmap_new and qmc__vmap_train's buffer at MAX_BINS (bins only
 * shrink for thin pilots). */
void qmc__vmap_bytes(uint32_t dims, uint64_t *map_bytes, uint64_t *train_bytes)
{
    *map_bytes = *train_bytes = 0;
    if (dims == 0 || dims > QMC__VMAP_MAX_DIMS)
        return;
    const uint64_t d = dims, bins = MAX_BINS, chunk = 65536 / d;
    *map_bytes = sizeof(qmc__vmap) + (d * (bins + 1) + 2 * d * bins) * sizeof(double);
    *train_bytes = (2 * chunk * d + 3 * chunk + d * bins + 2 * (bins + 1)) * sizeof(double);
}

static qmc__vmap *vmap_new(const qmc_integrand *f, uint32_t bins)
{
    qmc__vmap *m = calloc(1, sizeof *m);
    const size_t d = f->dims;
    if (!m)
        return NULL;
    m->edges = malloc((d * (bins + 1) + 2 * d * bins) * sizeof *m->edges);
    if (!m->edges) {
        free(m);
        return NULL;
    }
    m->widths = m->edges + d * (bins + 1);
    m->jacobians = m->widths + d * bins;
    m->f = f;
    m->dims = f->dims;
    m->bins = bins;
    for (uint32_t i = 0; i < m->dims; i++) {
        double *e = m->edges + (size_t)i * (bins + 1);
        for (uint32_t k = 0; k <= bins; k++)
            e[k] = (double)k / (double)bins;
        set_widths(m, i);
    }
    m->mapped = *f;
    m->mapped.eval = mapped_eval;
    m->mapped.ctx = m;
    /* the map moves f's kinks and jumps: its own breaks are not f's */
    m->mapped.breaks = NULL;
    m->mapped.n_breaks = 0;
    /* f J has jumps at the bin edges, whatever f is. */
    if (m->mapped.smoothness < QMC_SMOOTH_DISCONTINUOUS)
        m->mapped.smoothness = QMC_SMOOTH_DISCONTINUOUS;
    return m;
}

int qmc__vmap_train(const qmc_integrand *f, uint64_t pilot_evals, uint64_t seed,
                    const qmc_interrupt *hook, qmc__vmap **out, qmc__vmap_report *rep)
{
    *out = NULL;
    memset(rep, 0, sizeof *rep);
    if (f->dims == 0 || f->dims > QMC__VMAP_MAX_DIMS)
        return QMC_EDIMS;
    uint64_t least = (uint64_t)MIN_DIM_POINTS * f->dims;
    if (least < 2 * MIN_BIN_POINTS)
        least = 2 * MIN_BIN_POINTS;
    const uint64_t affordable = pilot_evals / least;
    if (affordable < MIN_ROUNDS)
        return QMC_EBUDGET;
    const uint32_t rounds = affordable < MAX_ROUNDS ? (uint32_t)affordable : MAX_ROUNDS;
    const uint64_t per_round = pilot_evals / rounds;
    uint32_t bins = MAX_BINS;
    while (bins > 2 && per_round < (uint64_t)bins * MIN_BIN_POINTS)
        bins /= 2;
    const uint32_t d = f->dims;
    const size_t chunk = 65536 / d; /* points per batch: 512 KiB of u */
    qmc__vmap *m = vmap_new(f, bins);
    double *buf = malloc((2 * chunk * d + 3 * chunk + (size_t)d * bins + 2 * (bins + 1)) *
                         sizeof *buf);
    if (!m || !buf) {
        qmc__vmap_free(m);
        free(buf);
        return QMC_ENOMEM;
    }
    double *u = buf, *x = u + chunk * d, *jac = x + chunk * d, *fx = jac + chunk,
           *sums = fx + chunk, *tmp = sums + (size_t)d * bins;
    rep->bins = bins;
    rep->round_points = per_round;
    qmc__poll poll;
    qmc__poll_init(&poll, hook);
    int err = qmc__poll_now(&poll) ? QMC_ECANCELED : 0;
    for (uint32_t round = 0; round < rounds && !err && !rep->nonfinite; round++) {
        const int last = round + 1 == rounds;
        qmc_seq_spec spec = {.kind = QMC_SEQ_SOBOL, .dims = d, .scramble = QMC_SCRAMBLE_OWEN,
                             .seed = qmc__hash3(seed, round, TAG_VMAP)};
        qmc_seq *seq = NULL;
        if ((err = qmc_seq_new(&spec, &seq)) != 0)
            break;
        memset(sums, 0, (size_t)d * bins * sizeof *sums);
        double mean = 0, m2 = 0;
        for (uint64_t i0 = 0; i0 < per_round && !err; i0 += chunk) {
            size_t n = per_round - i0 < chunk ? (size_t)(per_round - i0) : chunk;
            if ((err = qmc_seq_fill(seq, i0, n, QMC_FORMAT_F64, u)) != 0)
                break;
            map_points(m, u, n, x, jac);
            f->eval(f->ctx, x, n, d, fx);
            for (size_t p = 0; p < n; p++) {
                double y = fx[p] * jac[p];
                if (!isfinite(y)) {
                    rep->nonfinite = 1;
                    break;
                }
                /* Welford, in point order: deterministic. */
                double k = (double)(i0 + p + 1), dy = y - mean;
                mean += dy / k;
                m2 += dy * (y - mean);
                if (last)
                    continue;
                for (uint32_t a = 0; a < d; a++) {
                    double t = u[p * d + a] * (double)bins;
                    uint32_t bin = t >= (double)bins ? bins - 1 : (uint32_t)t;
                    sums[(size_t)a * bins + bin] += y * y;
                }
            }
            rep->evals += n;
            if (rep->nonfinite)
                break;
            if (qmc__poll_work(&poll, n))
                err = QMC_ECANCELED;
        }
        qmc_seq_free(seq);
        if (err || rep->nonfinite)
            break;
        double var = m2 / (double)(per_round - 1);
        if (round == 0) {
            rep->var_plain = var;
            rep->mean_plain = mean;
        }
        rep->var_mapped = var;
        rep->mean_mapped = mean;
        rep->rounds = round + 1;
        if (round == EARLY_ROUND && var * EARLY_GAIN > rep->var_plain)
            break; /* no gain coming: this round's map is the answer */
        if (!last)
            for (uint32_t a = 0; a < d; a++)
                refine_axis(m, a, sums + (size_t)a * bins, tmp);
    }
    free(buf);
    if (err || rep->nonfinite) {
        qmc__vmap_free(m);
        return err;
    }
    *out = m;
    return 0;
}
