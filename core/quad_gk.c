/*
 * quad_gk.c - adaptive Gauss-Kronrod quadrature on [0,1] (see qmc/quad.h).
 *
 * QUADPACK's QAG (R. Piessens, E. de Doncker-Kapenga, C. W. Ueberhuber and
 * D. K. Kahaner, "QUADPACK: A Subroutine Package for Automatic
 * Integration", Springer 1983, routines DQAGE, DQK15, DQK21), rewritten:
 * each interval gets the Kronrod rule with its embedded Gauss rule, and
 * the interval with the largest error estimate is bisected until the sum
 * of the errors meets the tolerance.  Intervals live in the caller's
 * workspace with a max-heap of their indices keyed by error; nothing is
 * allocated.  The two halves of a bisection are evaluated in one batch.
 *
 * The error estimate of one interval is QUADPACK's
 *     err = resasc * min(1, (200 |K - G| / resasc)^1.5),
 * with resasc the rule's integral of |f - mean f|, floored at
 * 50 eps resabs (resabs the integral of |f|) so that it never claims more
 * than roundoff allows.  Roundoff detection follows DQAGE: a bisection that
 * barely changes the integral yet keeps the error (iroff1 >= 6), or that
 * raises the error after ten intervals (iroff2 >= 20), or an interval too
 * small to halve in doubles, stops the run with QMC_FLAG_ROUNDOFF.
 *
 * The caller's interrupt hook is polled before the first interval and
 * then after bisections, counting evaluations (see interrupt.h), so about
 * every hundred bisections; when it fires the run stops with
 * QMC_ECANCELED and no estimate.
 *
 * This file does not evaluate endpoints, print, or allocate.
 */
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "err_heap.h"
#include "interrupt.h"
#include "quad_impl.h"
#include "qmc/quad.h"

#define GK_MAX_HALF 10                 /* Kronrod nodes on one side, K21 */
#define GK_MAX_POINTS (2 * GK_MAX_HALF + 1)
#define GK_ONE_MINUS 0x1.fffffffffffffp-1

/* A Kronrod rule on [-1,1]: half non-center abscissae descending, then the
 * center 0; Kronrod weights; Gauss weights at the same positions (0 where
 * a node is Kronrod-only).  Constants from QUADPACK's DQK15 and DQK21. */
typedef struct gk_rule {
    uint32_t half;
    double xgk[GK_MAX_HALF + 1];
    double wgk[GK_MAX_HALF + 1];
    double wg[GK_MAX_HALF + 1];
} gk_rule;

static const gk_rule gk15 = {
    7,
    {0.991455371120812639206854697526329, 0.949107912342758524526189684047851,
     0.864864423359769072789712788640926, 0.741531185599394439863864773280788,
     0.586087235467691130294144845693013, 0.405845151377397166906606412076961,
     0.207784955007898467600689403773245, 0.0},
    {0.022935322010529224963732008058970, 0.063092092629978553290700663189204,
     0.104790010322250183839876322541518, 0.140653259715525918745189590510238,
     0.169004726639267902826583426598550, 0.190350578064785409913256402421014,
     0.204432940075298892414161999234649, 0.209482141084727828012999174891714},
    {0.0, 0.129484966168869693270611432679082, 0.0,
     0.279705391489276667901467771423780, 0.0,
     0.381830050505118944950369775488975, 0.0,
     0.417959183673469387755102040816327},
};

static const gk_rule gk21 = {
    10,
    {0.995657163025808080735527280689003, 0.973906528517171720077964012084452,
     0.930157491355708226001207180059508, 0.865063366688984510732096688423493,
     0.780817726586416897063717578345042, 0.679409568299024406234327365114874,
     0.562757134668604683339000099272694, 0.433395394129247190799265943165784,
     0.294392862701460198131126603103866, 0.148874338981631210884826001129720,
     0.0},
    {0.011694638867371874278064396062192, 0.032558162307964727478818972459390,
     0.054755896574351996031381300244580, 0.075039674810919952767043140916190,
     0.093125454583697605535065465083366, 0.109387158802297641899210590325805,
     0.123491976262065851077208977449306, 0.134709217311473325928054001771707,
     0.142775938577060080797094273138717, 0.147739104901338491374841515972068,
     0.149445554002916905664936468389821},
    {0.0, 0.066671344308688137593568809893332, 0.0,
     0.149451349150580593145776339657697, 0.0,
     0.219086362515982043995534934228163, 0.0,
     0.269266719309996355091226921569469, 0.0,
     0.295524224714752870173892994651338, 0.0},
};

typedef struct gk_interval {
    double a, b;      /* the interval */
    double r, e;      /* Kronrod estimate and its error (>= floor) */
    double resasc;    /* integral of |f - mean|, for the roundoff test */
    double floor;     /* error inherited from an inconsistent bisection */
    uint32_t suspect; /* SUSPECT_LEFT or _RIGHT: that end may hide a jump */
    uint32_t depth;   /* bisections the floor is still passed down */
} gk_interval;

enum { SUSPECT_NONE = 0, SUSPECT_LEFT = 1, SUSPECT_RIGHT = 2 };

/* The Kronrod nodes leave a gap of (1 - xgk[0]) / 2 of the width at each
 * end, 2^-7.9 for K15 and 2^-8.9 for K21; a jump hidden in that gap
 * becomes visible after at most 9 bisections of the interval holding it. */
#define GK_SUSPECT_DEPTH 10u

/* The safety factor on a floor for integrands with kinks or jumps (see
 * qmc_quad_gk's loop). */
#define GK_KINK_MARGIN 16.0

/* Everything one run needs, pointing into the caller's workspace. */
typedef struct gk_state {
    const qmc_integrand *f;
    const gk_rule *rule;
    gk_interval *iv;
    uint32_t *heap;   /* indices into iv, max-heap on iv[].e */
    uint32_t count;
    uint64_t evals;
    uint64_t nonfinite;
    int hunt_ends;    /* jumps declared, not where: bound the end gaps */
    double max_abs;   /* the largest finite |f| seen so far */
} gk_state;

/* The share of an interval's width beyond its outermost Kronrod node, at
 * each end: (1 - xgk[0]) / 2. */
static double end_gap(const gk_rule *g)
{
    return 0.5 * (1.0 - g->xgk[0]);
}

int qmc__gk_breaks_usable(const qmc_integrand *f)
{
    if (!f || f->dims != 1 || f->n_breaks == 0 || !f->breaks ||
        f->n_breaks > QMC_INTEGRAND_MAX_BREAKS)
        return 0;
    for (uint32_t i = 0; i < f->n_breaks; i++) {
        double b = f->breaks[i];
        if (!(b > 0.0 && b < 1.0) || (i > 0 && !(b > f->breaks[i - 1])))
            return 0;
    }
    return 1;
}

void qmc_quad_gk_opts_init(qmc_quad_gk_opts *opts)
{
    if (!opts)
        return;
    opts->tol_abs = 0.0;
    opts->tol_rel = 1e-10;
    opts->max_subdiv = 200;
    opts->kronrod_points = 21;
    opts->max_evals = UINT64_MAX;
    opts->interrupt.fn = NULL;
    opts->interrupt.ctx = NULL;
}

size_t qmc_quad_gk_workspace_bytes(uint32_t max_subdiv)
{
    size_t per = sizeof(gk_interval) + sizeof(uint32_t);
    if (max_subdiv > SIZE_MAX / per)
        return 0;
    return (size_t)max_subdiv * per;
}

/* ---- the heap ------------------------------------------------------------ */

/* The heap's key: an interval's error estimate. */
static double interval_error(const void *ctx, uint32_t item)
{
    const gk_state *s = ctx;
    return s->iv[item].e;
}

static void heap_up(gk_state *s, uint32_t i)
{
    qmc__heap_up(s->heap, i, interval_error, s);
}

static void heap_down(gk_state *s, uint32_t i)
{
    qmc__heap_down(s->heap, s->count, i, interval_error, s);
}

/* ---- the rule ------------------------------------------------------------ */

/* Writes the rule's nodes on [a,b] to x (center first, then +- pairs),
 * clamped into [0,1) as the integrand contract requires. */
static uint32_t rule_nodes(const gk_rule *g, double a, double b, double *x)
{
    double c = 0.5 * (a + b), h = 0.5 * (b - a);
    uint32_t m = 0;
    x[m++] = c;
    for (uint32_t j = 0; j < g->half; j++) {
        double d = h * g->xgk[j];
        x[m++] = c - d;
        x[m++] = c + d;
    }
    for (uint32_t i = 0; i < m; i++)
        x[i] = x[i] < 0.0 ? 0.0 : (x[i] >= 1.0 ? GK_ONE_MINUS : x[i]);
    return m;
}

/* DQK15/DQK21 on [a,b] from the values fx laid out as rule_nodes wrote
 * them.  Returns resabs (the integral of |f|) for the initial roundoff
 * test. */
static double rule_apply(const gk_rule *g, double a, double b,
                         const double *fx, gk_interval *out)
{
    double h = 0.5 * (b - a), dh = fabs(h);
    uint32_t c = g->half;
    double fc = fx[0];
    double resk = g->wgk[c] * fc, resg = g->wg[c] * fc;
    double resabs = fabs(resk);
    for (uint32_t j = 0; j < g->half; j++) {
        double f1 = fx[1 + 2 * j], f2 = fx[2 + 2 * j];
        resk += g->wgk[j] * (f1 + f2);
        resg += g->wg[j] * (f1 + f2);
        resabs += g->wgk[j] * (fabs(f1) + fabs(f2));
    }
    double reskh = 0.5 * resk;
    double resasc = g->wgk[c] * fabs(fc - reskh);
    for (uint32_t j = 0; j < g->half; j++)
        resasc += g->wgk[j] * (fabs(fx[1 + 2 * j] - reskh)
                               + fabs(fx[2 + 2 * j] - reskh));
    resabs *= dh;
    resasc *= dh;
    double err = fabs((resk - resg) * h);
    if (resasc != 0.0 && err != 0.0)
        err = resasc * fmin(1.0, pow(200.0 * err / resasc, 1.5));
    if (resabs > DBL_MIN / (50.0 * DBL_EPSILON))
        err = fmax(50.0 * DBL_EPSILON * resabs, err);
    out->a = a;
    out->b = b;
    out->r = resk * h;
    out->e = err;
    out->resasc = resasc;
    return resabs;
}

/* Evaluates f at the nodes of `count` intervals (at most 2) in one batch
 * and fills them.  Returns 1 when a value was not finite. */
static int eval_intervals(gk_state *s, gk_interval *ivs, uint32_t count,
                          double *resabs)
{
    double x[2 * GK_MAX_POINTS], fx[2 * GK_MAX_POINTS];
    uint32_t m = 0;
    for (uint32_t i = 0; i < count; i++)
        m += rule_nodes(s->rule, ivs[i].a, ivs[i].b, x + m);
    s->f->eval(s->f->ctx, x, m, 1, fx);
    s->evals += m;
    uint64_t bad = 0;
    for (uint32_t i = 0; i < m; i++) {
        bad += !isfinite(fx[i]);
        if (isfinite(fx[i]))
            s->max_abs = fmax(s->max_abs, fabs(fx[i]));
    }
    s->nonfinite += bad;
    uint32_t per = m / count;
    for (uint32_t i = 0; i < count; i++) {
        double ra = rule_apply(s->rule, ivs[i].a, ivs[i].b, fx + i * per,
                               &ivs[i]);
        if (resabs)
            resabs[i] = ra;
        /* An end of [0,1] is the one place no parent ever saw: a jump in
         * the gap beyond an end interval's last node (the step at 1 -
         * 1e-9) changes the integral by up to gap x |f| without any rule
         * noticing.  Where jumps are declared but not where they are, that
         * is a floor on the interval's error, so the end intervals are
         * bisected until the gap can hold no more than the tolerance (the
         * values seen bound what a jump to 0, or between them, hides). */
        int ends = (ivs[i].a == 0.0) + (ivs[i].b == 1.0);
        if (s->hunt_ends && ends)
            ivs[i].e = fmax(ivs[i].e,
                            ends * end_gap(s->rule) * (ivs[i].b - ivs[i].a) * s->max_abs);
    }
    return bad != 0;
}

/*
 * Keeps a bisection from hiding a jump.  A jump just beside the parent's
 * midpoint sits in the nodes' end gap of both halves: the parent saw it,
 * the halves see constants and claim no error, and their sum differs from
 * the parent's estimate by more than they claim (QUADPACK would believe
 * them: a step at a random place then "converges" with an error bar a
 * million times too small).  So when |parent - halves| exceeds the halves'
 * errors, each half takes that difference as a floor on its error, marked
 * at the end it shares with the other; a marked interval passes the floor
 * on to its half at that end for GK_SUSPECT_DEPTH bisections, by which
 * time any hidden jump is in plain view of the nodes.  Smooth integrands
 * almost never trip the test, so this costs them nothing.
 */
static void inherit_floor(const gk_interval *parent, gk_interval *halves,
                          int inconsistent, double margin)
{
    for (int i = 0; i < 2; i++) {
        halves[i].floor = 0.0;
        halves[i].suspect = SUSPECT_NONE;
        halves[i].depth = 0;
    }
    if (inconsistent) {
        double d = margin * fabs(parent->r - (halves[0].r + halves[1].r));
        halves[0].suspect = SUSPECT_RIGHT;
        halves[1].suspect = SUSPECT_LEFT;
        for (int i = 0; i < 2; i++) {
            halves[i].floor = d;
            halves[i].depth = GK_SUSPECT_DEPTH;
        }
    } else if (parent->suspect != SUSPECT_NONE && parent->depth > 1) {
        gk_interval *h = &halves[parent->suspect == SUSPECT_LEFT ? 0 : 1];
        h->suspect = parent->suspect;
        h->floor = parent->floor;
        h->depth = parent->depth - 1;
    }
    for (int i = 0; i < 2; i++)
        halves[i].e = fmax(halves[i].e, halves[i].floor);
}

/* Sums of estimates and errors over all intervals, compensated
 * (Neumaier), so the reported totals do not carry the running update's
 * drift. */
static void totals(const gk_state *s, double *area, double *err)
{
    double sa = 0.0, ca = 0.0, se = 0.0;
    for (uint32_t i = 0; i < s->count; i++) {
        double v = s->iv[i].r, t = sa + v;
        ca += fabs(sa) >= fabs(v) ? (sa - t) + v : (v - t) + sa;
        sa = t;
        se += s->iv[i].e;
    }
    *area = sa + ca;
    *err = se;
}

static double tolerance(const qmc_quad_gk_opts *o, double area)
{
    return fmax(o->tol_abs, o->tol_rel * fabs(area));
}

/* The interrupt hook fired: no estimate, only the evaluations spent. */
static int cancelled(const gk_state *s, qmc_result *res)
{
    return qmc__cancelled(res, 1, s->evals);
}

int qmc_quad_gk(const qmc_integrand *f, const qmc_quad_gk_opts *opts,
                void *workspace, size_t workspace_bytes, qmc_result *res)
{
    if (!res)
        return QMC_EINVAL;
    qmc_result_init(res);
    res->error_kind = QMC_ERROR_ESTIMATE;
    res->dims = 1;
    if (!f || !f->eval || !opts || !workspace)
        return QMC_EINVAL;
    if (f->dims != 1)
        return QMC_EDIMS;
    if (!(opts->tol_abs >= 0.0) || !(opts->tol_rel >= 0.0)
        || !(opts->tol_abs > 0.0 || opts->tol_rel > 0.0)
        || opts->max_subdiv == 0
        || (opts->kronrod_points != 15 && opts->kronrod_points != 21))
        return QMC_EINVAL;
    size_t need = qmc_quad_gk_workspace_bytes(opts->max_subdiv);
    if (need == 0 || workspace_bytes < need
        || (uintptr_t)workspace % _Alignof(double) != 0)
        return QMC_EINVAL;
    gk_state s;
    s.f = f;
    s.rule = opts->kronrod_points == 15 ? &gk15 : &gk21;
    s.iv = workspace;
    s.heap = (uint32_t *)(s.iv + opts->max_subdiv);
    s.count = 0;
    s.evals = 0;
    s.nonfinite = 0;
    /* A declared set of breaks (qmc_integrand.breaks) makes the opening
     * intervals: each piece is smooth, so no rule straddles a jump or a
     * kink, and the pieces' bars are QUADPACK's own.  A declared jump
     * whose place is not given makes the ends suspect instead. */
    const int split = qmc__gk_breaks_usable(f);
    if (f->n_breaks && !split)
        return QMC_EINVAL;
    const uint32_t pieces = split ? f->n_breaks + 1 : 1;
    s.hunt_ends = !split && f->smoothness == QMC_SMOOTH_DISCONTINUOUS;
    s.max_abs = 0.0;
    uint32_t k = 2 * s.rule->half + 1;
    if (opts->max_evals / k < pieces || pieces > opts->max_subdiv)
        return pieces > opts->max_subdiv ? QMC_EINVAL : QMC_EBUDGET;
    qmc__poll poll;
    qmc__poll_init(&poll, &opts->interrupt);
    if (qmc__poll_now(&poll))
        return cancelled(&s, res);

    /* The pieces first (DQAGE's opening tests, over all of them). */
    uint32_t flags = 0;
    double resabs = 0.0;
    int bad = 0, saturated = 0;
    for (uint32_t i = 0; i < pieces; i++) {
        gk_interval *iv = &s.iv[i];
        iv->a = i == 0 ? 0.0 : f->breaks[i - 1];
        iv->b = i + 1 == pieces ? 1.0 : f->breaks[i];
        iv->floor = 0.0;
        iv->suspect = SUSPECT_NONE;
        iv->depth = 0;
    }
    for (uint32_t i = 0; i < pieces; i += 2) {
        uint32_t batch = pieces - i < 2 ? pieces - i : 2;
        double ra[2];
        bad |= eval_intervals(&s, &s.iv[i], batch, ra);
        for (uint32_t j = 0; j < batch; j++)
            resabs += ra[j];
        if (qmc__poll_work(&poll, batch * (uint64_t)k))
            return cancelled(&s, res);
    }
    double area = 0.0, errsum = 0.0;
    for (uint32_t i = 0; i < pieces; i++) {
        s.heap[i] = i;
        s.count = i + 1;
        heap_up(&s, i);
        saturated |= s.iv[i].e == s.iv[i].resasc && s.iv[i].e != 0.0;
    }
    totals(&s, &area, &errsum);
    double errbnd = tolerance(opts, area);
    int done = 0;
    if (bad) {
        flags |= QMC_FLAG_NONFINITE | QMC_FLAG_ERROR_UNRELIABLE;
        done = 1;
    } else if (errsum <= 50.0 * DBL_EPSILON * resabs && errsum > errbnd) {
        flags |= QMC_FLAG_ROUNDOFF;
        done = 1;
    } else if ((errsum <= errbnd && !saturated) || errsum == 0.0) {
        done = 1;
    }

    /* The floor |parent - halves| measures the parent's error, and it
     * bounds the halves' where bisecting shrinks the error, as it does
     * across a jump in the end gap.  Across a kink it need not: the
     * error goes as width^2 times a factor that swings with where the
     * kink falls among the nodes, so a half can keep most of its
     * parent's error (testpack genz-continuous, d = 1, seed 1046: a
     * half 1.3e-9 off under a floor of 1.3e-10).  An integrand that
     * declares a kink or worse takes GK_KINK_MARGIN times the
     * difference; the interval holding the kink is bisected two or three
     * times more, about a hundred evaluations. */
    const int smooth_pieces = f->smoothness == QMC_SMOOTH_ANALYTIC ||
                              (split && f->smoothness <= QMC_SMOOTH_DISCONTINUOUS);
    const double margin = smooth_pieces ? 1.0 : GK_KINK_MARGIN;
    uint32_t iroff1 = 0, iroff2 = 0;
    while (!done) {
        uint32_t top = s.heap[0];
        gk_interval parent = s.iv[top];
        if (s.count >= opts->max_subdiv) {
            flags |= QMC_FLAG_MAX_SUBDIV;
            break;
        }
        if (s.evals > opts->max_evals || opts->max_evals - s.evals < 2 * (uint64_t)k) {
            flags |= QMC_FLAG_BUDGET;
            break;
        }
        double mid = 0.5 * (parent.a + parent.b);
        /* DQAGE's test for an interval too small to split in doubles. */
        if (fmax(fabs(parent.a), fabs(parent.b))
                <= (1.0 + 100.0 * DBL_EPSILON) * (fabs(mid) + 1000.0 * DBL_MIN)
            || mid <= parent.a || mid >= parent.b) {
            flags |= QMC_FLAG_ROUNDOFF;
            break;
        }
        gk_interval halves[2];
        halves[0].a = parent.a;
        halves[0].b = mid;
        halves[1].a = mid;
        halves[1].b = parent.b;
        bad = eval_intervals(&s, halves, 2, NULL);
        if (qmc__poll_work(&poll, 2 * (uint64_t)k))
            return cancelled(&s, res);
        double area12 = halves[0].r + halves[1].r;
        double erro12 = halves[0].e + halves[1].e;
        if (halves[0].resasc != halves[0].e && halves[1].resasc != halves[1].e) {
            if (fabs(parent.r - area12) <= 1e-5 * fabs(area12)
                && erro12 >= 0.99 * parent.e)
                iroff1++;
            if (s.count > 10 && erro12 > parent.e)
                iroff2++;
        }
        inherit_floor(&parent, halves, fabs(parent.r - area12) > erro12, margin);
        erro12 = halves[0].e + halves[1].e;
        errsum += erro12 - parent.e;
        area += area12 - parent.r;
        s.iv[top] = halves[0];
        heap_down(&s, 0);
        s.iv[s.count] = halves[1];
        s.heap[s.count] = s.count;
        s.count++;
        heap_up(&s, s.count - 1);
        if (bad) {
            flags |= QMC_FLAG_NONFINITE | QMC_FLAG_ERROR_UNRELIABLE;
            break;
        }
        if (errsum <= tolerance(opts, area)) {
            /* Confirm on exact sums: the running ones drift. */
            totals(&s, &area, &errsum);
            if (errsum <= tolerance(opts, area))
                break;
        }
        if (iroff1 >= 6 || iroff2 >= 20) {
            flags |= QMC_FLAG_ROUNDOFF;
            break;
        }
    }

    totals(&s, &area, &errsum);
    if (!(errsum <= tolerance(opts, area)) || (flags & QMC_FLAG_NONFINITE))
        flags |= QMC_FLAG_NOT_CONVERGED;
    else
        flags &= ~(uint32_t)(QMC_FLAG_MAX_SUBDIV | QMC_FLAG_BUDGET);
    /* A declared singularity short of the tolerance, whatever stopped it
     * (the intervals, the budget, QUADPACK's roundoff tests): bisection
     * toward a power singularity x^-p leaves [0, h] with the same relative
     * error at every level (the rule on it is h^(1-p) times the rule on
     * [0, 1]), and QUADPACK's estimate of that interval never sees the
     * spike; near p = 1 the bar falls short: x^-0.99 gave 76.7 +- 2.2
     * against 100 at 200 intervals, and |x - 1/3|^-0.99 60.5 +- 5.6
     * against 198.5 when the roundoff tests stopped it after 1953
     * evaluations.  A run that converged keeps its bar here; through
     * qmc_integrate a second run checks even that one (rule_confirm.c). */
    if (f->smoothness >= QMC_SMOOTH_SINGULAR && (flags & QMC_FLAG_NOT_CONVERGED))
        flags |= QMC_FLAG_ERROR_UNRELIABLE;
    res->estimate = area;
    res->error = errsum;
    res->ci_low = area - errsum;
    res->ci_high = area + errsum;
    res->n = s.count;
    res->evals = s.evals;
    res->nonfinite = s.nonfinite;
    res->flags = flags;
    return 0;
}
