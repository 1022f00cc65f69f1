/*
 * cubature_cc.c - p-adaptive tensor-product Clenshaw-Curtis cubature over
 * [0,1]^d (see qmc/quad.h).
 *
 * Why: on analytic integrands a fixed-degree rule refined by splitting
 * (cubature.c) converges only algebraically, like N^(-8/d); raising the
 * degree converges exponentially.  At d = 5 and 1e6-1e7 evaluations the
 * Genz-Malik rule stopped at 1e-11..1e-13 of the integral where a
 * degree-adaptive rule (the peer pcubature) reached rounding.
 *
 * The rule: axis j carries the nested Clenshaw-Curtis rule of level m_j,
 * 2^m_j + 1 points x_i = (1 - cos(pi i / 2^m_j)) / 2 (level 0: the
 * midpoint), so raising a level keeps every old point.  The estimate
 * Q(m) is the tensor product.  For each axis k the same points also give
 * Q(m - e_k), axis k one level lower, and E_k = |Q(m) - Q(m - e_k)| says
 * how much axis k still changes the answer.  The axis with the largest E_k
 * is raised, at a cost of about N more points, until the estimated error
 * meets the tolerance or the next level would pass the evaluation budget
 * or the workspace.  Axes start at level 2 (5 points) when 5^d fits an
 * eighth of the budget, else at level 1: an axis whose two lowest rules
 * agree by chance would otherwise never be raised.  While every node
 * returns 0 the axes are raised in turn, lowest level first, within a
 * quarter of the budget: a search for mass between the nodes (a narrow
 * peak), since levels agreeing at 0 are no evidence of anything.
 *
 * The error: E_k is the error of the lower rule along k, far above the
 * error of Q(m) once the levels converge (each level roughly squares the
 * error).  We report sum_k E_k r_k, with r_k the geometric mean of axis k's last
 * two ratios E_k / (E_k one level earlier) when both are below 1, else 1
 * (see extrapolation()) - a geometric, not super-geometric, extrapolation,
 * so still pessimistic once it applies - and at least the rounding floor
 * (see rounding_floor()), which grows with the integrand's slope.  Integrands with kinks or jumps break the premise:
 * qmc_integrate flags the estimate there (QMC_FLAG_ERROR_UNRELIABLE).
 *
 * Sums: Q(m) and the d lower rules come from contracting the value grid
 * one axis at a time with each axis's weights (Neumaier sums along each
 * axis), so all d + 1 cost about two passes over the grid.
 *
 * Memory: the workspace holds the 1D tables, two value grids (the old one
 * is copied into the refined one; the spare one holds the first
 * contractions) and a scratch a quarter that size; its size bounds the
 * grid (QMC_FLAG_MEMORY_BOUND).  Nothing here
 * allocates.  Points are evaluated in chunks of CC_CHUNK, polling the
 * interrupt hook after each.
 */
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "interrupt.h"
#include "msg.h"
#include "qmc/quad.h"

#define CC_CHUNK 256u
/* At most 2^12 + 1 points on an axis: a rule that an analytic integrand
 * needs more of is better served by splitting (cubature.c), and the
 * weights of level m cost 2^(2m - 1) multiply-adds (no FFT here). */
#define CC_MAX_LEVEL 12
#define CC_ONE_MINUS 0x1.fffffffffffffp-1
#define CC_PI 3.14159265358979323846

/* Points on an axis at level m. */
static uint64_t level_points(uint32_t m)
{
    return m == 0 ? 1 : ((uint64_t)1 << m) + 1;
}

/* ---- the 1D tables ----------------------------------------------------------
 * For each level m filled so far: nodes x[i], weights w[i] and the weights
 * of level m - 1 placed on level m's points (zero on the new ones), c[i].
 * Level m's three arrays start at offset 3 * (sum of the lower levels'
 * points). */
typedef struct cc_tables {
    double *base;
    uint32_t ready;                /* highest level filled so far */
    size_t at[CC_MAX_LEVEL + 1];   /* offset of level m's arrays */
} cc_tables;

static size_t tables_doubles(uint32_t top)
{
    size_t n = 0;
    for (uint32_t m = 0; m <= top; m++)
        n += 3 * level_points(m);
    return n;
}

static const double *nodes(const cc_tables *t, uint32_t m)
{
    return t->base + t->at[m];
}

static const double *weights(const cc_tables *t, uint32_t m)
{
    return t->base + t->at[m] + level_points(m);
}

static const double *lower(const cc_tables *t, uint32_t m)
{
    return t->base + t->at[m] + 2 * level_points(m);
}

/* Clenshaw-Curtis weights on [0,1] for N = 2^m intervals (N + 1 points):
 * w_i = c_i / N (1 - sum_{k=1}^{N/2} b_k cos(2 k i pi / N) / (4 k^2 - 1)) / 2,
 * c_0 = c_N = 1 else 2, b_{N/2} = 1 else 2 (Waldvogel 2006, eq. 2.4).  The
 * cosines come from one table of cos(2 pi j / N), indexed by k i mod N,
 * so a level costs N^2 / 2 multiply-adds and no more cosines. */
static void cc_weights(uint64_t N, double *w, double *cosines)
{
    for (uint64_t j = 0; j < N; j++)
        cosines[j] = cos(2.0 * CC_PI * (double)j / (double)N);
    for (uint64_t i = 0; i <= N; i++) {
        double s = 0.0;
        for (uint64_t k = 1; k <= N / 2; k++) {
            double b = k == N / 2 ? 1.0 : 2.0;
            s += b * cosines[(k * i) % N] / (4.0 * (double)k * (double)k - 1.0);
        }
        double c = i == 0 || i == N ? 1.0 : 2.0;
        w[i] = 0.5 * c / (double)N * (1.0 - s);
    }
}

/* Fills level m (levels below it are filled); scratch holds 2^m doubles.
 * Levels are filled as the first axis reaches them. */
static void level_fill(cc_tables *t, uint32_t m, double *scratch)
{
    t->at[m] = m == 0 ? 0 : t->at[m - 1] + 3 * level_points(m - 1);
    uint64_t n = level_points(m);
    double *x = t->base + t->at[m], *w = x + n, *c = w + n;
    if (m == 0) {
        x[0] = 0.5;
        w[0] = 1.0;
        c[0] = 0.0; /* below level 0: no rule */
    } else {
        uint64_t N = n - 1;
        for (uint64_t i = 0; i <= N; i++) {
            /* 1 - cos(pi i / N) = 2 sin^2(pi i / 2N): no cancellation */
            double sn = sin(CC_PI * (double)i / (2.0 * (double)N));
            x[i] = fmin(sn * sn, CC_ONE_MINUS);
        }
        cc_weights(N, w, scratch);
        const double *wl = weights(t, m - 1);
        for (uint64_t i = 0; i <= N; i++)
            c[i] = m == 1 ? (i == 1 ? wl[0] : 0.0) : (i % 2 ? 0.0 : wl[i / 2]);
    }
    t->ready = m;
}

/* Fills the levels up to m not filled yet. */
static void levels_upto(cc_tables *t, uint32_t m, double *scratch)
{
    while (t->ready < m)
        level_fill(t, t->ready + 1, scratch);
}

/* ---- the grid ------------------------------------------------------------- */

typedef struct cc_state {
    const qmc_integrand *f;
    uint32_t d;
    cc_tables tab;
    uint32_t level[QMC_CC_MAX_DIMS];
    uint64_t npts[QMC_CC_MAX_DIMS];
    uint64_t size;           /* grid points, prod npts */
    double *grid, *spare;    /* values, axis 0 fastest; the next grid */
    double *scratch;         /* later contractions, max_points / 4 */
    uint64_t max_points;     /* room in grid and in spare */
    double *px, *pf;         /* a chunk of points and their values */
    uint64_t *slot;          /* where each chunk value goes */
    size_t fill;
    uint64_t evals, nonfinite;
    qmc__poll poll;
    int stopped;
} cc_state;

static void flush(cc_state *s, double *dst)
{
    if (s->fill == 0 || s->stopped) {
        s->fill = 0;
        return;
    }
    s->f->eval(s->f->ctx, s->px, s->fill, s->d, s->pf);
    s->evals += s->fill;
    for (size_t i = 0; i < s->fill; i++) {
        s->nonfinite += !isfinite(s->pf[i]);
        dst[s->slot[i]] = s->pf[i];
    }
    if (qmc__poll_work(&s->poll, s->fill))
        s->stopped = 1;
    s->fill = 0;
}

/* Queues the point of multi-index idx at levels lv, for slot at of dst. */
static void queue_point(cc_state *s, const uint64_t *idx, const uint32_t *lv, uint64_t at,
                        double *dst)
{
    if (s->fill == CC_CHUNK)
        flush(s, dst);
    double *x = s->px + s->fill * s->d;
    for (uint32_t j = 0; j < s->d; j++)
        x[j] = nodes(&s->tab, lv[j])[idx[j]];
    s->slot[s->fill++] = at;
}

/* Steps the multi-index idx (axis 0 fastest) through a grid of np points
 * per axis. */
static void step(uint64_t *idx, const uint64_t *np, uint32_t d)
{
    for (uint32_t j = 0; j < d && ++idx[j] == np[j]; j++)
        idx[j] = 0;
}

/* Evaluates the whole grid at s->level. */
static void first_grid(cc_state *s)
{
    uint64_t idx[QMC_CC_MAX_DIMS] = {0};
    for (uint64_t at = 0; at < s->size && !s->stopped; at++) {
        queue_point(s, idx, s->level, at, s->grid);
        step(idx, s->npts, s->d);
    }
    flush(s, s->grid);
}

/* Raises axis k (at level >= 1) one level: the old values move to their
 * places in the spare grid (even indices along k), the new points (odd
 * indices) are evaluated into it, and the grids swap. */
static void refine(cc_state *s, uint32_t k)
{
    const uint32_t d = s->d;
    uint32_t lv[QMC_CC_MAX_DIMS];
    uint64_t np[QMC_CC_MAX_DIMS], stride[QMC_CC_MAX_DIMS], size = 1;
    memcpy(lv, s->level, sizeof lv);
    lv[k]++;
    for (uint32_t j = 0; j < d; j++) {
        np[j] = level_points(lv[j]);
        stride[j] = j == 0 ? 1 : stride[j - 1] * s->npts[j - 1]; /* old grid's */
        size *= np[j];
    }
    uint64_t idx[QMC_CC_MAX_DIMS] = {0};
    for (uint64_t at = 0; at < size && !s->stopped; at++) {
        if (idx[k] % 2 == 1) {
            queue_point(s, idx, lv, at, s->spare);
        } else {
            uint64_t old = 0;
            for (uint32_t j = 0; j < d; j++)
                old += (j == k ? idx[k] / 2 : idx[j]) * stride[j];
            s->spare[at] = s->grid[old];
        }
        step(idx, np, d);
    }
    flush(s, s->spare);
    double *t = s->grid;
    s->grid = s->spare;
    s->spare = t;
    memcpy(s->level, lv, sizeof lv);
    memcpy(s->npts, np, sizeof np);
    s->size = size;
}

/* out[o] = sum_i w[i] in[i + n o] for o < count (magnitudes of in when
 * absolute), each a Neumaier sum.  out may be in: out[o] is written after
 * in[n o ..] is read, and n >= 2 keeps it behind what is still to read. */
static void contract(const double *in, uint64_t n, uint64_t count, const double *w,
                     int absolute, double *out)
{
    for (uint64_t o = 0; o < count; o++) {
        const double *v = in + o * n;
        double sum = 0.0, comp = 0.0;
        for (uint64_t i = 0; i < n; i++) {
            double x = w[i] * (absolute ? fabs(v[i]) : v[i]), t = sum + x;
            comp += fabs(sum) >= fabs(x) ? (sum - t) + x : (x - t) + sum;
            sum = t;
        }
        out[o] = sum + comp;
    }
}

/* Q(m) into *q, Q(m - e_k) into lowq[k], and sum |w f| into *absq,
 * contracting axis 0, then 1, ...: after axis j each array holds
 * prod_{l > j} npts[l] values.  "all" uses every axis's weights, "low k"
 * the lower weights on axis k (built from "all" just before axis k is
 * contracted).  Axis 0's three arrays fill at most the spare grid (every
 * axis has 3 points or more); the later "low" arrays, at most 1/6 of the
 * grid together, go in the scratch. */
static void rules(cc_state *s, double *q, double *lowq, double *absq)
{
    const uint32_t d = s->d;
    uint64_t count = s->size / s->npts[0];
    double *all = s->spare, *mag = s->spare + 2 * count, *low[QMC_CC_MAX_DIMS];
    low[0] = s->spare + count;
    contract(s->grid, s->npts[0], count, weights(&s->tab, s->level[0]), 0, all);
    contract(s->grid, s->npts[0], count, lower(&s->tab, s->level[0]), 0, low[0]);
    contract(s->grid, s->npts[0], count, weights(&s->tab, s->level[0]), 1, mag);
    double *next = s->scratch;
    for (uint32_t j = 1; j < d; j++) {
        const uint64_t n = s->npts[j], c2 = count / n;
        const double *w = weights(&s->tab, s->level[j]);
        low[j] = next;
        next += c2;
        contract(all, n, c2, lower(&s->tab, s->level[j]), 0, low[j]);
        contract(all, n, c2, w, 0, all);
        for (uint32_t k = 0; k < j; k++)
            contract(low[k], n, c2, w, 0, low[k]);
        contract(mag, n, c2, w, 0, mag);
        count = c2;
    }
    *q = all[0];
    *absq = mag[0];
    for (uint32_t k = 0; k < d; k++)
        lowq[k] = low[k][0];
}

/* The rounding floor: the level below which |Q(m) - Q(m - e_k)| is noise,
 * so that two levels agreeing there say nothing more.  Two sources:
 *  - the sums: Neumaier sums along each axis lose a few eps of
 *    sum |w f| in all, whatever the number of terms (16 eps sum |w f|);
 *  - the values: f is evaluated at nodes that are themselves rounded
 *    (x_i = sin^2(..) carries an error up to eps |x_i| <= eps), so each
 *    value is off by about eps |grad f| (the 1-norm over the axes); an
 *    integrand computed from x, such as exp(-a^2 (x - u)^2), loses no
 *    more than that in its own arithmetic (there eps a^2 (x - u)^2 f <=
 *    eps |x - u| |f'| / 2).  On a peak of width 1/a that is a times
 *    eps |f| per value: a 1D Gaussian with a = 1358 was off by 360 eps of
 *    its integral while the floor 16 eps sum |w f| claimed 16.  The slope
 *    along axis j is the difference quotient to the next node (the one
 *    before, on an axis's last node), and the bound adds them linearly:
 *    pessimistic by the square root of the number of values on the peak
 *    when their errors are independent, which we cannot check.
 * The result is 16 eps sum |w f| + eps sum_i w_i sum_j |df/dx_j|_i, the
 * second contracted like the rule itself; it overwrites the spare grid. */
static double rounding_floor(cc_state *s, double absq)
{
    const uint32_t d = s->d;
    uint64_t idx[QMC_CC_MAX_DIMS] = {0}, stride[QMC_CC_MAX_DIMS];
    for (uint32_t j = 0; j < d; j++)
        stride[j] = j == 0 ? 1 : stride[j - 1] * s->npts[j - 1];
    for (uint64_t at = 0; at < s->size; at++) {
        double slope = 0.0;
        for (uint32_t j = 0; j < d; j++) {
            const uint64_t n = s->npts[j];
            if (n < 2)
                continue;
            const double *x = nodes(&s->tab, s->level[j]);
            uint64_t i = idx[j], k = i + 1 < n ? i + 1 : i - 1;
            uint64_t other = k > i ? at + stride[j] : at - stride[j];
            slope += fabs(s->grid[other] - s->grid[at]) / fabs(x[k] - x[i]);
        }
        s->spare[at] = slope;
        step(idx, s->npts, d);
    }
    uint64_t count = s->size;
    for (uint32_t j = 0; j < d; j++) {
        count /= s->npts[j];
        contract(s->spare, s->npts[j], count, weights(&s->tab, s->level[j]), 0, s->spare);
    }
    return DBL_EPSILON * (16.0 * absq + s->spare[0]);
}

/* ---- the driver ----------------------------------------------------------- */

/* Bytes that do not depend on the grid (tables up to level top, a chunk),
 * and per grid point (two grids and a quarter for the scratch). */
static size_t fixed_bytes(uint32_t dims, uint32_t top)
{
    return tables_doubles(top) * sizeof(double) +
           (size_t)CC_CHUNK * (dims + 1) * sizeof(double) + CC_CHUNK * sizeof(uint64_t);
}
#define CC_BYTES_PER_POINT (2 * sizeof(double) + sizeof(double) / 4)

/* The first level of every axis: 2 (5 points) when 5^d fits an eighth of
 * the budget, else 1 (3 points). */
static uint32_t start_level(uint32_t dims, uint64_t max_evals)
{
    uint64_t p = 1;
    for (uint32_t j = 0; j < dims && p <= max_evals / 8; j++)
        p *= 5;
    return p <= max_evals / 8 ? 2 : 1;
}

/* The highest level one axis can reach within max_points, the other axes
 * at level l0. */
static uint32_t top_level(uint32_t dims, uint32_t l0, uint64_t max_points)
{
    uint64_t rest = 1;
    for (uint32_t j = 1; j < dims && rest <= max_points; j++)
        rest *= level_points(l0);
    uint32_t top = l0;
    while (top < CC_MAX_LEVEL && rest <= max_points / level_points(top + 1))
        top++;
    return top;
}

size_t qmc_cubature_cc_workspace_bytes(uint32_t dims, uint64_t max_points)
{
    if (dims == 0 || dims > QMC_CC_MAX_DIMS || max_points > SIZE_MAX / 16)
        return 0;
    uint32_t top = top_level(dims, 1, max_points);
    return fixed_bytes(dims, top) + (size_t)max_points * CC_BYTES_PER_POINT + 64;
}

static double tolerance(const qmc_cubature_opts *o, double est)
{
    return fmax(o->tol_abs, o->tol_rel * fabs(est));
}

/* e / prev when the indicator fell, else 1 (prev < 0: not measured). */
static double ratio(double e, double prev)
{
    return prev > 0.0 && e < prev ? e / prev : 1.0;
}

/* How far axis k's indicator e may be scaled down to estimate the error
 * of the finer rule: by its last two ratios (see below), and only when
 * both exist and both are below 1.  One ratio is no evidence of a
 * convergence rate: before a rule resolves a peak its levels jump
 * erratically, and a single lucky drop (a corner peak's axis going from
 * 1e-5 to 5.6e-9 between 5 and 9 points, while that rule's error was
 * 1.6e-8) extrapolated to a bar 5000x too small.  Demanding the drop twice
 * in a row is the minimum refinement an axis needs before its bar is
 * allowed below its indicator.  The scale is the geometric mean of the
 * two ratios: the current one alone trusted a 100x acceleration in full
 * (a 3D product peak claimed 3.9e-4 where the error was 1.2e-3), the
 * larger one ignored that convergence here is super-geometric and cost a
 * whole level an axis (a 4D Gaussian then ran out of a 1e7 budget). */
static double extrapolation(double e, double prev_e, double prev_r)
{
    double r = ratio(e, prev_e);
    return r < 1.0 && prev_r < 1.0 ? sqrt(r * prev_r) : 1.0;
}

int qmc_cubature_cc(const qmc_integrand *f, const qmc_cubature_opts *opts, void *workspace,
                    size_t workspace_bytes, qmc_result *res, char *why, size_t why_bytes)
{
    qmc__msg m;
    qmc__msg_init(&m, why, why_bytes);
    if (!f || !f->eval || !opts || !res || !workspace) {
        qmc__msg_str(&m, "clenshaw-curtis: missing argument");
        return QMC_EINVAL;
    }
    qmc_result_init(res);
    const uint32_t d = f->dims;
    if (d == 0 || d > QMC_CC_MAX_DIMS) {
        qmc__msg_set(&m, "clenshaw-curtis: ", d, " dimensions; the tensor rule takes 1..");
        qmc__msg_u64(&m, QMC_CC_MAX_DIMS);
        return QMC_EDIMS;
    }
    if (!(opts->tol_abs >= 0.0) || !(opts->tol_rel >= 0.0) ||
        (opts->tol_abs == 0.0 && opts->tol_rel == 0.0)) {
        qmc__msg_str(&m, "clenshaw-curtis: give a tolerance (absolute or relative) above 0");
        return QMC_EINVAL;
    }
    if ((uintptr_t)workspace % _Alignof(double) != 0) {
        qmc__msg_str(&m, "clenshaw-curtis: misaligned workspace");
        return QMC_EINVAL;
    }
    const uint32_t l0 = start_level(d, opts->max_evals);
    uint64_t first = 1;
    for (uint32_t j = 0; j < d; j++)
        first = first > UINT64_MAX / level_points(l0) ? UINT64_MAX : first * level_points(l0);
    if (first > opts->max_evals) {
        qmc__msg_set(&m, "clenshaw-curtis: the first grid (3 points an axis) in ", d,
                     " dimensions needs ");
        qmc__msg_u64(&m, first);
        qmc__msg_str(&m, " evaluations, over the budget of ");
        qmc__msg_u64(&m, opts->max_evals);
        return QMC_EBUDGET;
    }
    /* The grid can hold at most the budget; the tables go up to the level
     * that grid allows; the rest of the workspace is grid. */
    uint64_t cap = workspace_bytes / CC_BYTES_PER_POINT;
    uint32_t top = top_level(d, l0, cap < opts->max_evals ? cap : opts->max_evals);
    size_t fixed = fixed_bytes(d, top);
    uint64_t max_points = workspace_bytes > fixed
                              ? (uint64_t)((workspace_bytes - fixed) / CC_BYTES_PER_POINT)
                              : 0;
    if (max_points > opts->max_evals)
        max_points = opts->max_evals;
    while (top > l0 && ((uint64_t)1 << top) > max_points) /* cosines use the spare grid */
        top--;
    if (max_points < first || max_points < 4) {
        qmc__msg_set(&m, "clenshaw-curtis: a workspace of ", workspace_bytes,
                     " bytes cannot hold the first grid of ");
        qmc__msg_u64(&m, first);
        qmc__msg_str(&m, " points");
        return QMC_EINVAL;
    }

    cc_state s;
    memset(&s, 0, sizeof s);
    s.f = f;
    s.d = d;
    double *base = workspace;
    s.tab.base = base;
    base += tables_doubles(top);
    s.px = base;
    base += (size_t)CC_CHUNK * d;
    s.pf = base;
    base += CC_CHUNK;
    s.slot = (uint64_t *)base;
    base += CC_CHUNK;
    s.max_points = max_points;
    s.grid = base;
    s.spare = s.grid + max_points;
    s.scratch = s.spare + max_points;
    level_fill(&s.tab, 0, s.spare);
    levels_upto(&s.tab, l0, s.spare);
    s.size = first;
    for (uint32_t j = 0; j < d; j++) {
        s.level[j] = l0;
        s.npts[j] = level_points(l0);
    }
    qmc__poll_init(&s.poll, &opts->interrupt);
    s.stopped = qmc__poll_now(&s.poll);
    if (!s.stopped)
        first_grid(&s);

    /* Axis k's indicator one level earlier (-1: none) and the ratio it
     * had then to the level before it (1: none, or no decrease). */
    double prev_e[QMC_CC_MAX_DIMS], prev_r[QMC_CC_MAX_DIMS];
    for (uint32_t j = 0; j < d; j++) {
        prev_e[j] = -1.0;
        prev_r[j] = 1.0;
    }
    double q = 0.0, absq = 0.0, err = INFINITY;
    uint64_t budget = opts->max_evals; /* halved by a search for mass */
    uint32_t flags = 0;
    while (!s.stopped) {
        if (s.nonfinite) {
            flags |= QMC_FLAG_NONFINITE | QMC_FLAG_ERROR_UNRELIABLE;
            break;
        }
        double lowq[QMC_CC_MAX_DIMS], e[QMC_CC_MAX_DIMS];
        rules(&s, &q, lowq, &absq);
        err = 0.0;
        uint32_t worst = 0;
        for (uint32_t j = 0; j < d; j++) {
            e[j] = fabs(q - lowq[j]);
            err += e[j] * extrapolation(e[j], prev_e[j], prev_r[j]);
            if (e[j] > e[worst] || (e[j] == e[worst] && s.level[j] < s.level[worst]))
                worst = j;
        }
        /* Every node returned 0: the levels agree at 0 and say nothing (a
         * peak between the nodes, or a zero integrand).  Look for mass
         * first - raise the axes in turn, the lowest level first - within
         * a quarter of the budget, so that auto keeps the rest for RQMC
         * when the search fails (the result is then flagged unresolved by
         * qmc_integrate's node watch).  A 2D Gaussian peak a = 400 that 25
         * nodes missed (the 0 +- 0) is found and resolved.  A run that had to search
         * keeps to half the budget in all: if what it found stays
         * unresolved, auto still has half for RQMC (integrate.c). */
        if (absq == 0.0) {
            budget = opts->max_evals / 2;
            uint32_t low = 0;
            for (uint32_t j = 1; j < d; j++)
                if (s.level[j] < s.level[low])
                    low = j;
            uint64_t next = s.size / s.npts[low] * level_points(s.level[low] + 1);
            if (s.level[low] + 1 > top || next > max_points || next > opts->max_evals / 4)
                break;
            prev_e[low] = 0.0; /* no history: agreeing at 0 is no rate */
            levels_upto(&s.tab, s.level[low] + 1, s.spare);
            refine(&s, low);
            continue;
        }
        /* The slope pass costs about a contraction; it is needed only
         * near a stop (the floor is rarely 2^20 x its summing part). */
        double floor = 16.0 * DBL_EPSILON * absq;
        if (err <= fmax(tolerance(opts, q), 0x1p20 * floor))
            floor = rounding_floor(&s, absq);
        if (err <= floor) { /* every axis has settled to rounding */
            err = floor;
            if (err > tolerance(opts, q))
                flags |= QMC_FLAG_ROUNDOFF | QMC_FLAG_NOT_CONVERGED;
            break;
        }
        if (err <= tolerance(opts, q))
            break;
        uint64_t next = s.size / s.npts[worst] * level_points(s.level[worst] + 1);
        if (s.level[worst] + 1 > top || next > max_points) {
            flags |= next > opts->max_evals ? QMC_FLAG_BUDGET : QMC_FLAG_MEMORY_BOUND;
            flags |= QMC_FLAG_NOT_CONVERGED;
            break;
        }
        if (s.evals + (next - s.size) > budget) {
            flags |= QMC_FLAG_BUDGET | QMC_FLAG_NOT_CONVERGED;
            break;
        }
        prev_r[worst] = ratio(e[worst], prev_e[worst]);
        prev_e[worst] = e[worst];
        levels_upto(&s.tab, s.level[worst] + 1, s.spare); /* before refine fills spare */
        refine(&s, worst);
    }
    if (s.stopped) {
        qmc__msg_set(&m, "clenshaw-curtis: stopped by the interrupt hook after ", s.evals,
                     " evaluations");
        return qmc__cancelled(res, d, s.evals);
    }
    if (flags & QMC_FLAG_NONFINITE)
        flags |= QMC_FLAG_NOT_CONVERGED;
    res->estimate = q;
    res->error = err;
    res->ci_low = q - err;
    res->ci_high = q + err;
    res->error_kind = QMC_ERROR_ESTIMATE;
    res->n = s.size;
    res->evals = s.evals;
    res->dims = d;
    res->flags = flags;
    res->nonfinite = s.nonfinite;
    res->abs_integral = absq;
    return 0;
}
