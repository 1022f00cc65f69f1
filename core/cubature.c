/*
 * cubature.c - adaptive cubature over [0,1]^d with the Genz-Malik rule
 * (see qmc/quad.h).
 *
 * The rule: A. C. Genz and A. A. Malik, "Remarks on algorithm 006: An
 * adaptive algorithm for numerical integration over an N-dimensional
 * rectangular region", J. Comput. Appl. Math. 6 (1980) 295-302; the same
 * rule opens J. Berntsen, T. O. Espelid and A. Genz, "An adaptive
 * algorithm for the approximate calculation of multiple integrals", ACM
 * TOMS 17 (1991) (DCUHRE).  On a region with center c and half-widths h it
 * evaluates f at
 *
 *     c;  c +- l2 h_i e_i;  c +- l4 h_i e_i;  c +- l4 h_i e_i +- l4 h_j e_j
 *     (i < j);  and the 2^d corners c +- l5 h,
 *
 * l2 = sqrt(9/70), l4 = sqrt(9/10), l5 = sqrt(9/19): 2^d + 2d^2 + 2d + 1
 * points.  With weights summing to 1 (times the volume) it integrates
 * polynomials of degree 7 exactly; an embedded rule on the first four
 * groups is exact for degree 5, and |R7 - R5| is the region's error.  The
 * region is split in half along the axis with the largest fourth divided
 * difference |f(c-l2)+f(c+l2)-2f(c) - (l2/l4)^2 (f(c-l4)+f(c+l4)-2f(c))|
 * (ties go to the widest axis).
 *
 * Regions live in the caller's workspace with a max-heap of their indices
 * keyed by error; the workspace's size bounds how many there can be, and a
 * full workspace stops the run (QMC_FLAG_MEMORY_BOUND) rather than growing.
 * Points are generated and evaluated in chunks, so that even one region of
 * 2^30 corners needs no more memory than a chunk; the region's cost is
 * checked against the budget before anything is evaluated.  Nothing here
 * allocates, prints or keeps state.
 *
 * The caller's interrupt hook is polled before the first region and after
 * every chunk, counting evaluations (see interrupt.h): at low d that is
 * every few hundred region splits, at high d several times inside one
 * region, whose 2^d corners could otherwise run for seconds.  A hook that
 * fires abandons the region half evaluated and returns QMC_ECANCELED.
 */
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "err_heap.h"
#include "interrupt.h"
#include "msg.h"
#include "qmc/quad.h"

#define CUB_CHUNK 256u
#define CUB_ONE_MINUS 0x1.fffffffffffffp-1

/* Tags for a point in the chunk: >= 0 an axis point (index into the axis
 * values), else one of these. */
enum { TAG_CENTER = -1, TAG_PAIR = -2, TAG_CORNER = -3 };

/* A compensated (Neumaier) sum. */
typedef struct cub_sum {
    double s, c;
} cub_sum;

static void sum_add(cub_sum *a, double v)
{
    double t = a->s + v;
    a->c += fabs(a->s) >= fabs(v) ? (a->s - t) + v : (v - t) + a->s;
    a->s = t;
}

/* Bins of log10(measured / estimated error) at splits: 0.25 decades
 * each from 1e-8, the first and last open-ended (shortfall_factor). */
enum { CHECK_BINS = 64, CHECK_MIN_SPLITS = 32 };
#define CHECK_LOG_LO (-8.0)
#define CHECK_BIN_WIDTH 0.25

/* Everything one run needs, pointing into the caller's workspace. */
typedef struct cub_state {
    const qmc_integrand *f;
    uint32_t d;
    double *px;       /* CUB_CHUNK x d points */
    double *pf;       /* CUB_CHUNK values */
    int32_t *tag;     /* CUB_CHUNK tags */
    double *axis;     /* 4d axis values of the region being evaluated */
    double *corner_pick; /* its corners' two coordinates per axis, 2d */
    double *pool;     /* max_regions records of (2 + 2d) doubles */
    double *rule_bar; /* each region's bar as its rule gave it (mark_suspects) */
    uint32_t *split;  /* axis to split each region along */
    uint32_t *heap;   /* region indices, max-heap on error */
    uint32_t count, max_regions;
    size_t fill;      /* points in the chunk */
    double val0;
    cub_sum pairs, corners;
    uint64_t evals, nonfinite;
    qmc__poll poll;
    int stopped;      /* the hook fired: stop at once */
    uint32_t checks[CHECK_BINS]; /* what splits measured (shortfall_factor) */
    uint32_t check_count;
    double est_at_pow2[33]; /* the estimate when the count reached 2^k (richardson_bar) */
    double blind_move; /* the largest move a region's bar missed (note_blind) */
    uint64_t suspect_splits; /* splits the blind evidence asked for */
} cub_state;

/* A region record: [estimate, error, c[d], h[d]]. */
static double *region(const cub_state *s, uint32_t i)
{
    return s->pool + (size_t)i * (2 + 2 * (size_t)s->d);
}

uint64_t qmc_cubature_region_evals(uint32_t dims)
{
    if (dims >= 64)
        return UINT64_MAX;
    uint64_t d = dims;
    uint64_t poly = 2 * d * d + 2 * d + 1;
    uint64_t corners = (uint64_t)1 << d;
    return corners > UINT64_MAX - poly ? UINT64_MAX : corners + poly;
}

/* Bytes that do not depend on the number of regions, and per region. */
static int layout(uint32_t dims, size_t *fixed, size_t *per)
{
    size_t d = dims;
    if (d == 0 || d > (SIZE_MAX / sizeof(double) - CUB_CHUNK) / (CUB_CHUNK + 8))
        return -1;
    *fixed = ((size_t)CUB_CHUNK * d + CUB_CHUNK + 6 * d) * sizeof(double)
             + CUB_CHUNK * sizeof(int32_t);
    *per = (3 + 2 * d) * sizeof(double) + 2 * sizeof(uint32_t);
    return 0;
}

size_t qmc_cubature_workspace_bytes(uint32_t dims, uint32_t max_regions)
{
    size_t fixed, per;
    if (layout(dims, &fixed, &per) < 0 || max_regions > (SIZE_MAX - fixed) / per)
        return 0;
    return fixed + (size_t)max_regions * per;
}

/* ---- the heap ------------------------------------------------------------ */

/* The heap's key: a region's error estimate. */
static double region_error(const void *ctx, uint32_t item)
{
    const cub_state *s = ctx;
    return region(s, item)[1];
}

static void heap_up(cub_state *s, uint32_t i)
{
    qmc__heap_up(s->heap, i, region_error, s);
}

static void heap_down(cub_state *s, uint32_t i)
{
    qmc__heap_down(s->heap, s->count, i, region_error, s);
}

/* ---- the rule ------------------------------------------------------------ */

/* Evaluates the chunk and files each value by its tag; once stopped, drops
 * it unevaluated. */
static void flush(cub_state *s)
{
    if (s->fill == 0 || s->stopped) {
        s->fill = 0;
        return;
    }
    s->f->eval(s->f->ctx, s->px, s->fill, s->d, s->pf);
    s->evals += s->fill;
    /* The sums in locals: through s, every axis store could alias them
     * and they would make a memory round trip per point. */
    cub_sum pairs = s->pairs, corners = s->corners;
    uint64_t nonfinite = 0;
    for (size_t i = 0; i < s->fill; i++) {
        double v = s->pf[i];
        nonfinite += !isfinite(v);
        switch (s->tag[i]) {
        case TAG_CENTER:
            s->val0 = v;
            break;
        case TAG_PAIR:
            sum_add(&pairs, v);
            break;
        case TAG_CORNER:
            sum_add(&corners, v);
            break;
        default:
            s->axis[s->tag[i]] = v;
            break;
        }
    }
    s->pairs = pairs;
    s->corners = corners;
    s->nonfinite += nonfinite;
    if (qmc__poll_work(&s->poll, s->fill))
        s->stopped = 1;
    s->fill = 0;
}

/* A fresh chunk row, its coordinates the caller's to write. */
static double *next_row(cub_state *s, int32_t tag)
{
    if (s->fill == CUB_CHUNK)
        flush(s);
    double *x = s->px + s->fill * s->d;
    s->tag[s->fill++] = tag;
    return x;
}

/* A fresh chunk row holding the center c, to be moved along some axes. */
static double *next_point(cub_state *s, const double *c, int32_t tag)
{
    double *x = next_row(s, tag);
    memcpy(x, c, s->d * sizeof(double));
    return x;
}

static double clamp01(double v)
{
    return v < 0.0 ? 0.0 : (v >= 1.0 ? CUB_ONE_MINUS : v);
}

/*
 * The region's error estimate.  |R7 - R5| measures the degree-5 rule's
 * error while R7 is what we report, so taken bare it is pessimistic by
 * orders of magnitude on smooth integrands (the benchmark measured a
 * median of 1e2-1e3 times the actual error).  For a smooth integrand on a
 * region of size h the two errors scale as h^6 and h^8, so the degree-7
 * error behaves like the degree-5 error to the power 4/3, relative to the
 * region's integral: e7 ~ e5 (e5 / |R7|)^(1/3).  That asymptotic regime
 * starts only once the region is well resolved, so the factor is taken
 * relative to 1/30: (30 e5 / |R7|)^(1/3), and only when below 1; coarse
 * regions and integrals near zero keep the bare |R7 - R5|.  Measured on
 * the smooth Genz families at d = 2..8, tolerances 1e-4..1e-10: reported /
 * actual error has median 25 and 10th percentile 1.7 (bare: median 1300).
 * A threshold of 1/10 already lets the error exceed a 1e-4 tolerance in
 * test_cubature's Gaussian peak, so 1/30 is the honest compromise.
 * Only for integrands declared analytic: across a kink the asymptotic
 * scaling does not hold, and the sharpened bar of the continuous Genz
 * family at d = 2 fell below the actual error in 62% of the benchmark's
 * runs (median 0.05 of it).  Integrands that declare jumps or
 * singularities get QMC_FLAG_ERROR_UNRELIABLE from qmc_integrate, since no
 * rule-difference estimate holds there.
 */
enum { SHARPEN_FROM = 30 }; /* relative errors below 1/30 */

static double sharpen(double e5, double r7)
{
    double rel = fabs(r7) > 0.0 ? e5 / fabs(r7) * SHARPEN_FROM : 1.0;
    if (!(rel < 1.0))
        return e5;
    return e5 * cbrt(rel);
}

/* Applies the rule to region r: writes its estimate, error and split
 * axis; returns early, leaving them unset, once s->stopped. */
static void apply_rule(cub_state *s, uint32_t r)
{
    static const double l2 = 0.35856858280031809199; /* sqrt(9/70) */
    static const double l4 = 0.94868329805051379960; /* sqrt(9/10) */
    static const double l5 = 0.68824720161168529772; /* sqrt(9/19) */
    uint32_t d = s->d;
    double *rec = region(s, r), *c = rec + 2, *h = rec + 2 + d;
    s->pairs = (cub_sum){0.0, 0.0};
    s->corners = (cub_sum){0.0, 0.0};
    s->val0 = 0.0;

    next_point(s, c, TAG_CENTER);
    for (uint32_t i = 0; i < d; i++) {
        const double off[4] = {-l2, l2, -l4, l4};
        for (int k = 0; k < 4; k++) {
            double *x = next_point(s, c, (int32_t)(4 * i + (uint32_t)k));
            x[i] = clamp01(c[i] + off[k] * h[i]);
        }
    }
    for (uint32_t i = 0; i < d && !s->stopped; i++) {
        for (uint32_t j = i + 1; j < d; j++) {
            for (int k = 0; k < 4; k++) {
                double *x = next_point(s, c, TAG_PAIR);
                x[i] = clamp01(c[i] + (k & 1 ? l4 : -l4) * h[i]);
                x[j] = clamp01(c[j] + (k & 2 ? l4 : -l4) * h[j]);
            }
        }
    }
    /* d < 64 here: the caller checked 2^d against the budget.  Each
     * corner picks, axis by axis, one of two coordinates worked out once
     * (the same values clamp01 gave point by point). */
    double *pick = s->corner_pick; /* axis j: low 2j, high 2j + 1 */
    for (uint32_t j = 0; j < d; j++) {
        pick[2 * j] = clamp01(c[j] - l5 * h[j]);
        pick[2 * j + 1] = clamp01(c[j] + l5 * h[j]);
    }
    uint64_t ncorner = (uint64_t)1 << d;
    for (uint64_t k = 0; k < ncorner && !s->stopped; k++) {
        double *x = next_row(s, TAG_CORNER);
        for (uint32_t j = 0; j < d; j++)
            x[j] = pick[2 * j + ((k >> j) & 1)];
    }
    flush(s);
    if (s->stopped)
        return;

    /* Genz and Malik's weights for the unit-volume cube. */
    double dd = (double)d;
    double w1 = (12824.0 - 9120.0 * dd + 400.0 * dd * dd) / 19683.0;
    double w2 = 980.0 / 6561.0;
    double w3 = (1820.0 - 400.0 * dd) / 19683.0;
    double w4 = 200.0 / 19683.0;
    double w5 = 6859.0 / 19683.0 / ldexp(1.0, (int)d);
    double e1 = (729.0 - 950.0 * dd + 50.0 * dd * dd) / 729.0;
    double e2 = 245.0 / 486.0;
    double e3 = (265.0 - 100.0 * dd) / 1458.0;
    double e4 = 25.0 / 729.0;
    const double ratio = (l2 * l2) / (l4 * l4); /* 1/7 */

    double sum2 = 0.0, sum3 = 0.0, vol = 1.0, maxdiff = -1.0;
    uint32_t axis = 0;
    for (uint32_t i = 0; i < d; i++) {
        double a2 = s->axis[4 * i] + s->axis[4 * i + 1];
        double a4 = s->axis[4 * i + 2] + s->axis[4 * i + 3];
        sum2 += a2;
        sum3 += a4;
        vol *= 2.0 * h[i];
        double diff = fabs(a2 - 2.0 * s->val0 - ratio * (a4 - 2.0 * s->val0));
        if (maxdiff >= 0.0 && fabs(diff - maxdiff) <= 1e-14 * maxdiff) {
            if (h[i] > h[axis])
                axis = i;
        } else if (diff > maxdiff) {
            maxdiff = diff;
            axis = i;
        }
    }
    double sum4 = s->pairs.s + s->pairs.c, sum5 = s->corners.s + s->corners.c;
    double r7 = vol * (w1 * s->val0 + w2 * sum2 + w3 * sum3 + w4 * sum4
                       + w5 * sum5);
    double r5 = vol * (e1 * s->val0 + e2 * sum2 + e3 * sum3 + e4 * sum4);
    rec[0] = r7;
    rec[1] = s->f->smoothness == QMC_SMOOTH_ANALYTIC ? sharpen(fabs(r7 - r5), r7)
                                                    : fabs(r7 - r5);
    s->rule_bar[r] = rec[1];
    s->split[r] = axis;
}

static void totals(const cub_state *s, double *est, double *err)
{
    cub_sum e = {0.0, 0.0};
    double se = 0.0;
    for (uint32_t i = 0; i < s->count; i++) {
        sum_add(&e, region(s, i)[0]);
        se += region(s, i)[1];
    }
    *est = e.s + e.c;
    *err = se;
}

static double tolerance(const qmc_cubature_opts *o, double est)
{
    return fmax(o->tol_abs, o->tol_rel * fabs(est));
}

/*
 * A safety net under the sharpened bar.  A split measures the error of
 * the region it replaces: its halves' degree-7 estimates are far more
 * accurate, so |R7(parent) - R7(halves)| is close to the parent's actual
 * error (or to the part of it along the split axis), to set against the
 * estimate the parent carried.  When the run's splits show the estimates
 * falling short - the 90th percentile of measured / estimated above 1,
 * over CHECK_MIN_SPLITS splits or more - the final bar is multiplied by
 * it.  It never lowers the bar (a split along one of ten axes measures
 * only that axis's share: lowering by it was tried, and at d = 10 the bar
 * fell below the error in 75% of corner-peak runs), and neither the
 * regions nor the estimate change.  It exists because the sharpened bar
 * of the corner peak at d = 3 fell below the actual error in 93% of runs
 * (budgets 3e3-3e6; 0% with the net, median 2.6x the error).
 */
static void record_check(cub_state *s, double measured, double estimated)
{
    if (s->f->smoothness != QMC_SMOOTH_ANALYTIC || !(estimated > 0.0) || !isfinite(measured))
        return;
    double bin = (log10(fmax(measured / estimated, 1e-300)) - CHECK_LOG_LO) / CHECK_BIN_WIDTH;
    uint32_t b = bin < 0.0 ? 0 : bin >= CHECK_BINS - 1 ? CHECK_BINS - 1 : (uint32_t)bin;
    s->checks[b]++;
    s->check_count++;
}

static double shortfall_factor(const cub_state *s)
{
    if (s->check_count < CHECK_MIN_SPLITS)
        return 1.0;
    uint64_t want = (uint64_t)ceil(0.9 * s->check_count), seen = 0;
    for (uint32_t b = 0; b < CHECK_BINS; b++) {
        seen += s->checks[b];
        if (seen >= want) /* the bin's upper edge */
            return fmax(1.0, pow(10.0, CHECK_LOG_LO + CHECK_BIN_WIDTH * (b + 1)));
    }
    return 1.0;
}

/*
 * A second bar for analytic integrands at d >= 3, from how the whole
 * estimate moved rather than from the regions.  Summing the regions'
 * |R7 - R5| ignores that their errors cancel: the oscillatory family's
 * regional bar was 250 times its actual error at d = 5, and across the
 * four analytic families at d = 3, 5, 8, 10 the medians ran from 2 to 250
 * (11 of the 16 (family, d) cells above 10).  The estimate I_n after n regions converges like
 * n^-p, p = 8/d (a degree-7 rule on regions of width n^(-1/d)), so with
 * I at the last counts 2^a <= n/2 and 2^(a-1), 2^(a-2) (est_at_pow2):
 *   g1 = |I_n - I_a| / (r^p - 1),             r = n / 2^a,
 *   g2 = |I_a - I_(a-1)| (2r)^-p / (1 - 2^-p), g3 likewise one step back,
 * each the error of I_n if the rate holds.  The bar is RICHARDSON_SAFETY
 * times their largest (a difference that crossed zero by chance is
 * outvoted), and it only ever lowers the regional bar.  Chosen on the
 * four analytic Genz families at d = 3, 5, 8, 10, budgets 1e4-1e7, draws
 * 1-8; checked on draws 9-24 at d = 3, 4, 6, 7, 10: the median of
 * reported / actual error went 17.8 -> 6.1, the share of bars below the
 * error 2.0% -> 3.4% (safety 3: 4.9 and 4.3%; 5: 7.2 and 2.9%).  Not at
 * d = 2, where runs reach rounding and the differences vanish with it
 * (below the error in 78-84% of the corner peak's and oscillatory
 * family's runs), nor across kinks or jumps, where the rate does not
 * hold.  Nor once the blind evidence has asked for splits (mark_suspects):
 * they add regions in tails that leave the estimate where it was, so the
 * count grows without the error shrinking and the rate's premise is gone
 * (on the peak scan that bar fell to a tenth of the actual error).
 */
enum { RICHARDSON_SAFETY = 4, RICHARDSON_MIN_REGIONS = 16 };

/* Nor does it cut the regional bar more than 100-fold.  An estimate can
 * stall across three checkpoints while a peak waits undiscovered in one
 * region, and then all three differences are near zero; the regional bar
 * at least saw that region's R7 and R5 disagree.  (It only raises bars:
 * the median ratio went 8.5 -> 8.6 on draws 1-8 and 6.14 -> 6.18 on
 * draws 9-24, the bars below the error stayed as they were.) */
#define RICHARDSON_MAX_CUT 100.0

static double richardson_bar(const cub_state *s, double est)
{
    const uint32_t n = s->count;
    if (s->f->smoothness != QMC_SMOOTH_ANALYTIC || s->d < 3 || n < RICHARDSON_MIN_REGIONS ||
        s->nonfinite || !isfinite(est) || s->suspect_splits)
        return HUGE_VAL;
    const double p = 8.0 / s->d, shrink = 1.0 - pow(2.0, -p);
    const int a = 31 - __builtin_clz(n / 2); /* 2^a <= n/2 < 2^(a+1), a >= 3 */
    const double r = (double)n / ldexp(1.0, a);
    const double *at = s->est_at_pow2;
    double g = fabs(est - at[a]) / (pow(r, p) - 1.0);
    g = fmax(g, fabs(at[a] - at[a - 1]) * pow(2.0 * r, -p) / shrink);
    g = fmax(g, fabs(at[a - 1] - at[a - 2]) * pow(4.0 * r, -p) / shrink);
    return RICHARDSON_SAFETY * g;
}

/*
 * Evidence that the regions' bars cannot see the integrand, and the work
 * it buys.  A split whose halves move the estimate by more than
 * BLIND_RATIO times the bar its region carried found mass the region's
 * nodes had missed: a peak between them, where R7 and R5 agree because
 * both see only its tail.  Coarse regions do that on ordinary integrands
 * (the root of a smooth product peak, whose two rules agree by chance),
 * and refinement goes on past them.  What the final bar cannot vouch for
 * is a region left unresolved - its bar a thousandth of its estimate or
 * more, so its nodes see a tail, not a shape - once a split has proved a
 * bar blind at a scale above the final bar and a thousandth of the
 * estimate.  In a scan of genz-gaussian (a 30-3000, d = 1..3, 180 runs)
 * 9 silent misses were such regions: long along the peak's narrow axis,
 * beside the resolved peak, every node in its tail (8.9e-6 +- 8.7e-14
 * against 1.02e-5: one region held 1.6e-6 under a bar of 6e-19).  Each
 * such region is split once more (mark_suspects); if the budget runs out
 * first, the run raises QMC_FLAG_UNRESOLVED.  100 is far from the
 * shortfall net's factors (a few) on smooth integrands, and the move must
 * matter (a thousandth of the estimate) so that rounding-level moves deep
 * in a smooth integrand's tails at d = 4, 5 buy no work.
 */
#define BLIND_RATIO 100.0
#define BLIND_REGION_SHARE 1e-3
#define BLIND_MOVE_SHARE 1e-3

/*
 * How a suspect is cleared.  One split along its longest axis was not
 * enough: on the 240-run scan (bench/scans/peak_scan.py, seed 1) 8 runs
 * stayed silent, each holding a region that had been "verified" so.
 * Their nodes were all in the tail of a peak that sat near one face
 * (19% of the integral behind a bar of 3e-59, the peak 1/489 wide along
 * an axis that was not the longest), and the test of a find compared the
 * halves' move with the blind move - the run's largest, 1e-4 - rather
 * than with the region's own bar.  So now a suspect is split along every
 * axis in turn (longest first, SPLIT_TRIED counting), each split judged
 * against the bar the rule gave the region it splits (rule_bar): a move
 * past CHASE_RATIO times that bar is a find, and its halves are plain
 * regions, suspected afresh while unresolved; only d splits in a row
 * that find nothing clear it (SPLIT_VERIFIED).  CHASE_RATIO: at 100 one
 * run of the scan kept a region whose splits moved 10-20 times its bar
 * each and 135 times over three axes (1.9e-13 under a bar of 1.2e-15);
 * at 50 none did, for 8x the scan's evaluations (20 and 30, tried
 * without DECAY_FLOOR, cost 17x and 11x, and 20 flagged correct answers
 * whose budget ran out first); ordinary
 * (testpack) integrands spend the same as before, since nothing there
 * proves a bar blind.  A finite chase proves no absence: a peak within
 * 1/20 of a region's width from its face hides from every node until
 * the region is split along that axis several more times (one run in 240
 * of seed 2 is still silent so).
 */
#define CHASE_RATIO 50.0

static void note_blind(cub_state *s, double measured, double estimated)
{
    if (measured > BLIND_RATIO * estimated && measured > s->blind_move)
        s->blind_move = measured;
}

/* Bits above the split axis in s->split: a suspect (mark_suspects) and a
 * region whose ancestor was one, which is not suspected again. */
#define SPLIT_SUSPECT 0x80000000u
#define SPLIT_VERIFIED 0x40000000u
#define SPLIT_TRIED 0x3f000000u /* a suspect's axes split so far (d < 64) */
#define SPLIT_TRIED_SHIFT 24
#define SPLIT_AXIS 0x00ffffffu

/* Suspects region r, to be split along axis after tried axes: its bar
 * becomes the blind move, which puts it at the heap's top (its own stays
 * in rule_bar). */
static void suspect(cub_state *s, uint32_t r, uint32_t axis, uint32_t tried)
{
    s->split[r] = axis | SPLIT_SUSPECT | tried << SPLIT_TRIED_SHIFT;
    region(s, r)[1] = s->blind_move;
}

/* Whether region r is unresolved and not yet cleared (see above). */
static int is_suspect(const cub_state *s, uint32_t r)
{
    const double *rec = region(s, r);
    return !(s->split[r] & (SPLIT_VERIFIED | SPLIT_SUSPECT)) &&
           !(rec[1] < BLIND_REGION_SHARE * fabs(rec[0]));
}

/* Whether a blind move passed the scale at which it matters.  At d = 1
 * too: it used to be left out because all 4 flags of a first version of
 * the check there, in a testpack Gaussian scan, were on correct answers,
 * but the chase now clears such a far side of a resolved peak, a 1D
 * region beside a peak can hide its tail (a = 126.8, u = 0.5236: one
 * region's bar 1.1e-11 against its error 1.6e-7; a = 265.6, u = 0.236:
 * 7.9 bars off in all), and a 1D split is 7 evaluations. */
static int blind_seen(const cub_state *s, double est, double err)
{
    /* An estimate of 0 is rule_evidence's to judge: against a tolerance of
     * 0 the suspects' bars would keep the loop going to the budget. */
    return est != 0.0 && s->blind_move > fmax(err, BLIND_MOVE_SHARE * fabs(est));
}

/*
 * More work rather than a flag: each suspect region is given the largest
 * blind move as its bar, so the loop splits it next, along its longest
 * axis (the one its nodes are sparsest along: the missed region above was
 * 0.5 by 0.004, the peak hiding along the 0.5), and its halves,
 * re-estimated, are trusted by what they show (CHASE_RATIO).  A suspect
 * that was the far side of a resolved peak comes back as small as before
 * along every axis, and its pieces are not suspected again
 * (SPLIT_VERIFIED).  Returns how many were
 * marked; the caller's running error is raised to match.
 */
static uint32_t mark_suspects(cub_state *s, double est, double *err)
{
    if (!blind_seen(s, est, *err))
        return 0;
    uint32_t marked = 0;
    for (uint32_t i = 0; i < s->count; i++) {
        if (!is_suspect(s, i))
            continue;
        double *rec = region(s, i), *h = rec + 2 + s->d;
        uint32_t longest = 0;
        for (uint32_t j = 1; j < s->d; j++)
            if (h[j] > h[longest])
                longest = j;
        *err += s->blind_move - rec[1];
        suspect(s, i, longest, 0);
        marked++;
    }
    for (uint32_t i = s->count / 2; marked && i-- > 0;)
        heap_down(s, i); /* keys rose: rebuild the heap */
    return marked;
}

/* Whether a region the blind evidence suspects is left unsplit (the
 * budget or the heap ran out first). */
static int suspects_left(const cub_state *s, double est, double err)
{
    if (!blind_seen(s, est, err))
        return 0;
    for (uint32_t i = 0; i < s->count; i++)
        if ((s->split[i] & SPLIT_SUSPECT) || is_suspect(s, i))
            return 1;
    return 0;
}

/*
 * A bar that falls faster than the rule converges.  A split halves one
 * axis; where the rule is in its asymptotic regime the degree-7 error of
 * each half is at least 2^-9 of its parent's (2^-8 from h^8 along the
 * split axis, 2^-1 from the halved volume), and more when other axes
 * carry error.  A half whose bar claims less has its R7 and R5 agreeing
 * by accident: Genz-Malik has one degree-5 null rule, and no second one
 * of the same degree to outvote it as DCUHRE's pairs of null rules do
 * (Berntsen, Espelid and Genz 1991).  So each half's bar is at least
 * DECAY_FLOOR times its parent's.  On the peak scan regions at a narrow
 * peak's shoulder carried bars 50-250 times below their actual error
 * (a = 64.6, 229.7: a region of 1.86e-8 with a bar of 2.4e-14 and an
 * error of 6e-12); with the floor the scan's correct answers went 92 ->
 * 98 of 240, and the testpack families spend 0-1% more.  The floor fades
 * by 2^-9 a generation, so a polynomial the rule integrates exactly still
 * reaches its tolerance.
 */
#define DECAY_FLOOR 0x1p-9

/* Whether a region's R7 and R5 agree to the last bit on a nonzero
 * integral: a polynomial the rules integrate exactly (the stability
 * suite's zero-poly case, an odd cubic whose integral is 0, so that only
 * a bar of exactly 0 meets its relative tolerance), not an accident,
 * which leaves a rounding-level difference.  The floor is kept off it.
 * Both 0 is no such evidence: every node may have missed a peak. */
static int exact_agreement(const double *rec)
{
    return rec[1] == 0.0 && rec[0] != 0.0;
}

/* The interrupt hook fired: no estimate, only the evaluations spent. */
static int cancelled(const cub_state *s, qmc__msg *m, qmc_result *res)
{
    qmc__msg_set(m, "cubature: stopped by the interrupt hook after ", s->evals,
                 " evaluations");
    return qmc__cancelled(res, s->d, s->evals);
}

int qmc_cubature(const qmc_integrand *f, const qmc_cubature_opts *opts,
                 void *workspace, size_t workspace_bytes, qmc_result *res,
                 char *why, size_t why_bytes)
{
    qmc__msg m;
    qmc__msg_init(&m, why, why_bytes);
    if (!res) {
        qmc__msg_str(&m, "cubature: no result");
        return QMC_EINVAL;
    }
    qmc_result_init(res);
    res->error_kind = QMC_ERROR_ESTIMATE;
    if (!f || !f->eval || !opts || !workspace) {
        qmc__msg_str(&m, "cubature: no integrand, options or workspace");
        return QMC_EINVAL;
    }
    uint32_t d = f->dims;
    res->dims = d;
    size_t fixed, per;
    if (d == 0 || layout(d, &fixed, &per) < 0) {
        qmc__msg_set(&m, "cubature: ", d, " dimensions are out of range");
        return QMC_EDIMS;
    }
    if (!(opts->tol_abs >= 0.0) || !(opts->tol_rel >= 0.0)
        || !(opts->tol_abs > 0.0 || opts->tol_rel > 0.0)) {
        qmc__msg_str(&m, "cubature: tolerances must be >= 0, one of them > 0");
        return QMC_EINVAL;
    }
    uint64_t npts = qmc_cubature_region_evals(d);
    if (npts == UINT64_MAX || npts > opts->max_evals) {
        qmc__msg_set(&m, "cubature: one genz-malik region in ", d,
                     " dimensions needs ");
        if (npts == UINT64_MAX)
            qmc__msg_str(&m, "more than 2^64");
        else
            qmc__msg_u64(&m, npts);
        qmc__msg_str(&m, " evaluations, over the budget of ");
        qmc__msg_u64(&m, opts->max_evals);
        return QMC_EBUDGET;
    }
    if ((uintptr_t)workspace % _Alignof(double) != 0
        || workspace_bytes < fixed + per) {
        qmc__msg_set(&m, "cubature: the workspace must be aligned and hold at "
                     "least ", fixed + per, " bytes (one region)");
        return QMC_EINVAL;
    }
    size_t maxr = (workspace_bytes - fixed) / per;

    cub_state s;
    s.f = f;
    s.d = d;
    s.max_regions = maxr > UINT32_MAX ? UINT32_MAX : (uint32_t)maxr;
    s.px = workspace;
    s.pf = s.px + (size_t)CUB_CHUNK * d;
    s.axis = s.pf + CUB_CHUNK;
    s.corner_pick = s.axis + 4 * (size_t)d;
    s.pool = s.corner_pick + 2 * (size_t)d;
    s.rule_bar = s.pool + (size_t)s.max_regions * (2 + 2 * (size_t)d);
    s.tag = (int32_t *)(s.rule_bar + s.max_regions);
    s.split = (uint32_t *)(s.tag + CUB_CHUNK);
    s.heap = s.split + s.max_regions;
    s.count = 0;
    s.fill = 0;
    s.evals = 0;
    s.nonfinite = 0;
    memset(s.checks, 0, sizeof s.checks);
    s.check_count = 0;
    s.blind_move = 0.0;
    s.suspect_splits = 0;
    qmc__poll_init(&s.poll, &opts->interrupt);
    s.stopped = qmc__poll_now(&s.poll);
    if (s.stopped)
        return cancelled(&s, &m, res);

    double *root = region(&s, 0);
    for (uint32_t j = 0; j < d; j++) {
        root[2 + j] = 0.5;
        root[2 + d + j] = 0.5;
    }
    apply_rule(&s, 0);
    if (s.stopped)
        return cancelled(&s, &m, res);
    s.heap[0] = 0;
    s.count = 1;
    double est = root[0], err = root[1];
    s.est_at_pow2[0] = est;
    uint32_t flags = 0;

    while (!s.nonfinite) {
        if (err <= tolerance(opts, est)) {
            totals(&s, &est, &err); /* the running sums drift */
            if (err <= tolerance(opts, est) && mark_suspects(&s, est, &err) == 0)
                break;
        }
        if (s.count >= s.max_regions) {
            flags |= QMC_FLAG_MEMORY_BOUND;
            break;
        }
        if (s.evals > opts->max_evals || opts->max_evals - s.evals < 2 * npts) {
            flags |= QMC_FLAG_BUDGET;
            break;
        }
        uint32_t top = s.heap[0], fresh = s.count;
        double *a = region(&s, top), *b = region(&s, fresh);
        double old_est = a[0], old_err = a[1], old_rule_bar = s.rule_bar[top];
        const uint32_t how = s.split[top], ax = how & SPLIT_AXIS;
        memcpy(b, a, (2 + 2 * (size_t)d) * sizeof(double));
        double half = 0.5 * a[2 + d + ax];
        a[2 + d + ax] = half;
        b[2 + d + ax] = half;
        a[2 + ax] -= half;
        b[2 + ax] += half;
        apply_rule(&s, top);
        apply_rule(&s, fresh);
        if (s.stopped)
            return cancelled(&s, &m, res);
        const double moved = fabs(old_est - (a[0] + b[0]));
        /* A suspect's bar was the blind move, not the rule's. */
        const double parent_bar = how & SPLIT_SUSPECT ? old_rule_bar : old_err;
        const double floor_bar = DECAY_FLOOR * parent_bar;
        if (a[1] < floor_bar && !exact_agreement(a)) /* not fmax: NaN stays NaN */
            a[1] = floor_bar;
        if (b[1] < floor_bar && !exact_agreement(b))
            b[1] = floor_bar;
        if (how & SPLIT_SUSPECT) {
            s.suspect_splits++;
            const uint32_t tried = ((how & SPLIT_TRIED) >> SPLIT_TRIED_SHIFT) + 1;
            note_blind(&s, moved, old_rule_bar);
            if (moved > CHASE_RATIO * old_rule_bar) {
                /* a find: the halves are plain, suspected afresh */
            } else if (tried < d) {
                suspect(&s, top, (ax + 1) % d, tried);
                suspect(&s, fresh, (ax + 1) % d, tried);
            } else {
                s.split[top] |= SPLIT_VERIFIED;
                s.split[fresh] |= SPLIT_VERIFIED;
            }
        } else {
            if (how & SPLIT_VERIFIED) {
                s.split[top] |= SPLIT_VERIFIED;
                s.split[fresh] |= SPLIT_VERIFIED;
            }
            record_check(&s, moved, old_err);
            note_blind(&s, moved, old_err);
        }
        est += a[0] + b[0] - old_est;
        err += a[1] + b[1] - old_err;
        heap_down(&s, 0);
        s.heap[s.count] = fresh;
        s.count++;
        heap_up(&s, s.count - 1);
        if ((s.count & (s.count - 1)) == 0)
            s.est_at_pow2[__builtin_ctz(s.count)] = est;
    }

    totals(&s, &est, &err);
    err *= shortfall_factor(&s);
    if (s.nonfinite)
        flags |= QMC_FLAG_NONFINITE | QMC_FLAG_ERROR_UNRELIABLE;
    /* Converged or not by the bar the loop stops on; the Richardson bar
     * only reports a sharper one (a run that ran out of budget stays
     * flagged so, whatever it reports). */
    if (s.nonfinite || !(err <= tolerance(opts, est)))
        flags |= QMC_FLAG_NOT_CONVERGED;
    else
        flags &= ~(uint32_t)(QMC_FLAG_MEMORY_BOUND | QMC_FLAG_BUDGET);
    const double sharper = fmax(richardson_bar(&s, est), err / RICHARDSON_MAX_CUT);
    if (sharper < err) /* false for a NaN err: it stays NaN */
        err = sharper;
    if (suspects_left(&s, est, err))
        flags |= QMC_FLAG_UNRESOLVED | QMC_FLAG_ERROR_UNRELIABLE;
    res->estimate = est;
    res->error = err;
    res->ci_low = est - err;
    res->ci_high = est + err;
    res->n = s.count;
    res->evals = s.evals;
    res->nonfinite = s.nonfinite;
    res->flags = flags;
    return 0;
}
