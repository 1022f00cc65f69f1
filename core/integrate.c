/*
 * integrate.c - one entry point for every method, and how `auto` runs
 * what it chose (auto_choice.c chooses; see qmc/integrate.h).
 *
 * Workspaces for the deterministic rules are allocated here, once per
 * call, and sized from the spec (so a request states its memory up front);
 * nothing is allocated per evaluation.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "auto_choice.h"
#include "integrate_memory.h"
#include "interrupt.h"
#include "msg.h"
#include "quad_impl.h"
#include "rule_confirm.h"
#include "rule_pilot.h"
#include "rule_evidence.h"
#include "vegas_map.h"
#include "qmc/integrate.h"
#include "qmc/quad.h"
#include "qmc/sampling.h"

void qmc_integrate_spec_init(qmc_integrate_spec *spec)
{
    memset(spec, 0, sizeof *spec);
    spec->method = QMC_METHOD_AUTO;
    qmc_sampling_spec_init(&spec->sampling, QMC_SAMPLER_MC);
    spec->max_evals = 100000000;
    spec->max_memory = 64u << 20;
}

void qmc_sampling_describe(const qmc_sampling_spec *s, char *buf, size_t bytes)
{
    qmc__msg m;
    qmc__msg_init(&m, buf, bytes);
    if (s->sampler == QMC_SAMPLER_QMC || s->sampler == QMC_SAMPLER_RQMC) {
        qmc__msg_str(&m, qmc_seq_kind_name(s->seq));
        qmc__msg_str(&m, " ");
        qmc__msg_str(&m, qmc_scramble_name(s->scramble));
        if (s->seq_flags & QMC_SEQ_SHUFFLE)
            qmc__msg_str(&m, " shuffled");
        qmc__msg_str(&m, ", ");
    }
    qmc__msg_u64(&m, s->reps);
    qmc__msg_str(&m, " x ");
    qmc__msg_u64(&m, s->n);
    qmc__msg_str(&m, s->split_net ? " points, split from one net" : " points");
}

static qmc_sampler sampler_of(qmc_method m)
{
    switch (m) {
    case QMC_METHOD_STRATIFIED:
        return QMC_SAMPLER_STRATIFIED;
    case QMC_METHOD_LHS:
        return QMC_SAMPLER_LHS;
    case QMC_METHOD_QMC:
        return QMC_SAMPLER_QMC;
    case QMC_METHOD_RQMC:
        return QMC_SAMPLER_RQMC;
    default:
        return QMC_SAMPLER_MC;
    }
}

static int is_sampling(qmc_method m)
{
    return m == QMC_METHOD_MC || m == QMC_METHOD_STRATIFIED || m == QMC_METHOD_LHS ||
           m == QMC_METHOD_QMC || m == QMC_METHOD_RQMC;
}

/* The largest k^d <= n (at least 1). */
static uint64_t stratified_count(uint64_t n, uint32_t d)
{
    uint64_t best = 1;
    for (uint64_t k = 2;; k++) {
        uint64_t p = 1;
        for (uint32_t j = 0; j < d && p <= n; j++)
            p *= k;
        if (p > n)
            return best;
        best = p;
    }
}

/* A fixed n's cost (per_point evaluations a point) within the budget:
 * QMC_EBUDGET otherwise, refused before anything is evaluated. */
static int fixed_budget(const qmc_integrate_spec *spec, const qmc_sampling_spec *s,
                        uint64_t per_point, qmc__msg *why)
{
    uint64_t cost = s->n * s->reps * per_point; /* n <= 2^32, reps <= 4096 */
    if (s->n == 0 || s->n > QMC_SEQ_MAX_INDEX || s->reps == 0 ||
        s->reps > QMC_SAMPLING_MAX_REPS || cost > spec->max_evals) {
        qmc__msg_set(why, "", s->reps, " replicates x ");
        qmc__msg_u64(why, s->n);
        qmc__msg_str(why, " points = ");
        qmc__msg_u64(why, cost);
        qmc__msg_str(why, " evaluations exceed the budget of ");
        qmc__msg_u64(why, spec->max_evals);
        return QMC_EBUDGET;
    }
    return 0;
}

static int run_sampling(const qmc_integrate_spec *spec, qmc_sampling_spec s,
                        const qmc_integrand *f, const qmc_integrand *g, qmc_block_runner runner,
                        void *ctx, qmc_integrate_report *rep, qmc__msg *why)
{
    int err;
    qmc__guard guard = {runner, ctx, spec->interrupt};
    if (spec->interrupt.fn) {
        runner = qmc__guard_run;
        ctx = &guard;
    }
    if (spec->tol_abs > 0 || spec->tol_rel > 0) {
        uint64_t n_final = 0;
        err = qmc_sampling_adaptive(&s, f, g, spec->tol_abs, spec->tol_rel, spec->max_evals,
                                    runner, ctx, &rep->res, &rep->cv, &n_final, why->buf,
                                    why->cap);
        if (err)
            return err;
        s.n = n_final;
    } else {
        err = fixed_budget(spec, &s, g ? 2 : 1, why);
        if (err)
            return err;
        qmc_sampling_job *job = NULL;
        err = qmc_sampling_job_new(&s, f, g, &job, why->buf, why->cap);
        if (err)
            return err;
        err = qmc_sampling_run(job, runner, ctx, &rep->res, &rep->cv);
        qmc_sampling_job_free(job);
        if (err) {
            qmc__msg_str(why, qmc_strerror(err));
            return err;
        }
    }
    rep->sampling = s;
    qmc_sampling_describe(&s, rep->detail, sizeof rep->detail);
    return 0;
}

static int run_tensor(const qmc_integrate_spec *spec, qmc_rule1d rule, const qmc_integrand *f,
                      qmc_integrate_report *rep, qmc__msg *why)
{
    uint32_t n = spec->n_axis ? spec->n_axis : (rule == QMC_RULE1D_SIMPSON ? 17 : 16);
    /* Refuse before allocating the workspace (which grows with n): a bad
     * n, or n^d points over the budget. */
    int bad = qmc_rule1d_check(rule, n, why->buf, why->cap);
    if (bad)
        return bad;
    uint64_t cost = 1;
    for (uint32_t j = 0; j < f->dims && cost <= spec->max_evals; j++)
        cost = cost > UINT64_MAX / n ? UINT64_MAX : cost * n;
    if (cost > spec->max_evals) {
        qmc__msg_set(why, "tensor rule: ", n, "^");
        qmc__msg_u64(why, f->dims);
        qmc__msg_str(why, " evaluations exceed the budget of ");
        qmc__msg_u64(why, spec->max_evals);
        return QMC_EBUDGET;
    }
    size_t bytes = qmc_quad_tensor_rule_workspace_bytes(rule, n, f->dims);
    void *ws = malloc(bytes ? bytes : 1);
    if (!ws) {
        qmc__msg_str(why, "out of memory for the tensor rule's workspace");
        return QMC_ENOMEM;
    }
    int err = qmc_quad_tensor(f, rule, n, spec->max_evals, &spec->interrupt, ws, bytes,
                              &rep->res, why->buf, why->cap);
    free(ws);
    if (err)
        return err;
    qmc__msg_init(why, why->buf, why->cap); /* no reason on success */
    qmc__msg m;
    qmc__msg_init(&m, rep->detail, sizeof rep->detail);
    qmc__msg_u64(&m, n);
    qmc__msg_str(&m, " points per axis, ");
    qmc__msg_u64(&m, f->dims);
    qmc__msg_str(&m, " dims");
    return 0;
}

static int run_gk(const qmc_integrate_spec *spec, const qmc_integrand *f,
                  qmc_integrate_report *rep, qmc__msg *why)
{
    if (f->dims != 1) {
        qmc__msg_set(why, "gauss-kronrod integrates in 1D; this integrand has ", f->dims,
                     " dims (try cubature or rqmc)");
        return QMC_EDIMS;
    }
    qmc_quad_gk_opts g;
    qmc_quad_gk_opts_init(&g);
    if (spec->tol_abs > 0 || spec->tol_rel > 0) {
        g.tol_abs = spec->tol_abs;
        g.tol_rel = spec->tol_rel;
    }
    g.max_evals = spec->max_evals;
    g.interrupt = spec->interrupt;
    size_t bytes = qmc_quad_gk_workspace_bytes(g.max_subdiv);
    void *ws = malloc(bytes);
    if (!ws) {
        qmc__msg_str(why, "out of memory for the Gauss-Kronrod workspace");
        return QMC_ENOMEM;
    }
    int err = qmc_quad_gk(f, &g, ws, bytes, &rep->res);
    free(ws);
    if (err) {
        qmc__msg_str(why, qmc_strerror(err));
        return err;
    }
    qmc__msg m;
    qmc__msg_init(&m, rep->detail, sizeof rep->detail);
    qmc__msg_set(&m, g.kronrod_points == 15 ? "G7-K15, up to " : "G10-K21, up to ",
                 g.max_subdiv, " subintervals");
    return 0;
}

/* Genz-Malik cubature, or (cc) the tensor Clenshaw-Curtis rule, in a
 * workspace of at most spec->max_memory bytes and never more than the
 * budget can fill. */
static int run_cubature(const qmc_integrate_spec *spec, const qmc_integrand *f, int cc,
                        qmc_integrate_report *rep, qmc__msg *why)
{
    qmc_cubature_opts c = {.tol_abs = spec->tol_abs, .tol_rel = spec->tol_rel,
                           .max_evals = spec->max_evals, .interrupt = spec->interrupt};
    if (c.tol_abs == 0 && c.tol_rel == 0)
        c.tol_rel = QMC__CUBATURE_TOL_REL;
    /* integrate_memory.c bounds a call by the same function. */
    size_t bytes = qmc__cubature_bytes(spec, f->dims, cc);
    void *ws = malloc(bytes ? bytes : 1);
    if (!ws) {
        qmc__msg_set(why, "out of memory for ", spec->max_memory,
                     cc ? " bytes of Clenshaw-Curtis grid" : " bytes of cubature regions");
        return QMC_ENOMEM;
    }
    int err = cc ? qmc_cubature_cc(f, &c, ws, bytes, &rep->res, why->buf, why->cap)
                 : qmc_cubature(f, &c, ws, bytes, &rep->res, why->buf, why->cap);
    free(ws);
    if (err)
        return err;
    qmc__msg m;
    qmc__msg_init(&m, rep->detail, sizeof rep->detail);
    if (cc)
        qmc__msg_set(&m, "p-adaptive tensor Clenshaw-Curtis, ", rep->res.n, " grid points");
    else
        qmc__msg_set(&m, "Genz-Malik 7/5, ", spec->max_memory, "-byte region heap");
    return 0;
}

/*
 * auto's RQMC may run over a VEGAS map (vegas_map.h): a pilot trains it
 * (pilot_evals: a tenth of the budget or what the RQMC rounds would leave
 * unspent, at most AUTO_PILOT_MAX evaluations, 12 rounds of about 11000
 * points, which trains a map at d = 30 as well as 1e6 did and keeps a
 * tolerance-driven job with the default budget of 1e8 from spending a
 * million evaluations on its pilot; only for budgets of
 * AUTO_PILOT_MIN_BUDGET or more), and RQMC integrates f J over
 * the map when the pilot's variance under the map is AUTO_MAP_GAIN times
 * below plain f's.  The gain must be large because the map's bin edges
 * are jumps in f J, which cost QMC part of its edge on smooth integrands;
 * peaks, corners and support confined to a box gain far more than that.
 * The pilot's evaluations count against the budget either way.  Not for
 * integrands that declare jumps: the bin that straddles a jump is wide on
 * its zero side, so the rare points that land there with f != 0 carry
 * large weights (the heavy-tail test fired on 6 of 12 draws of the
 * discontinuous Genz family at d = 20), and over 8 draws the error was
 * 1.4x worse than plain RQMC's.
 */
enum { AUTO_PILOT_SHARE = 10, AUTO_MAP_GAIN = 16, AUTO_MAP_AGREE = 3 };
/* (integrate_memory.h's QMC__AUTO_MAP_MIN_BUDGET must equal it.) */
#define AUTO_PILOT_MIN_BUDGET 10000u
_Static_assert(AUTO_PILOT_MIN_BUDGET == QMC__AUTO_MAP_MIN_BUDGET, "the bound's map budget");
#define AUTO_PILOT_MAX (1u << 17)

/* The pilot's evaluations out of a budget.  RQMC's rounds double n, so
 * once they reuse each other (8 x 4096 points and up) they end at the
 * largest 8 x 2^k that fits and leave the rest unspent - a third of a
 * budget of 1e5.  The pilot takes that rest rather than a tenth: at
 * d = 30 a pilot of 1e4 evaluations never trained a map that helped the
 * corner peak, one of 3.4e4 did in half the draws (the error over 50-200
 * draws fell 13-21x), at no cost in RQMC points; where no map helps
 * (the oscillatory family) the pilot stops after 4 of its rounds, which
 * at d = 20 costs 0.8 ms more than the smaller pilot did. */
static uint64_t pilot_evals(uint64_t budget)
{
    uint64_t evals = budget / AUTO_PILOT_SHARE;
    uint64_t main_run = (uint64_t)QMC_SAMPLING_MIN_REPS * QMC_SAMPLING_BLOCK;
    if (main_run <= budget - evals) {
        while (2 * main_run <= budget - evals)
            main_run *= 2;
        evals = budget - main_run;
    }
    return evals > AUTO_PILOT_MAX ? AUTO_PILOT_MAX : evals;
}

/* Appends to auto's reason without cutting what is there. */
static void reason_append(char *reason, size_t bytes, const char *a, uint64_t v, const char *b)
{
    qmc__msg m;
    size_t len = strlen(reason);
    qmc__msg_init(&m, reason + len, bytes - len);
    qmc__msg_set(&m, a, v, b);
}

static int auto_map(const qmc_integrate_spec *spec, const qmc_integrand *f, qmc__vmap **map,
                    uint64_t *pilot, char *reason, size_t bytes)
{
    *map = NULL;
    *pilot = 0;
    if (f->dims > QMC__VMAP_MAX_DIMS || spec->max_evals < AUTO_PILOT_MIN_BUDGET ||
        f->smoothness >= QMC_SMOOTH_DISCONTINUOUS)
        return 0;
    const uint64_t evals = pilot_evals(spec->max_evals);
    qmc__vmap_report vr;
    qmc__vmap *m = NULL;
    int err = qmc__vmap_train(f, evals, spec->sampling.seed, &spec->interrupt, &m, &vr);
    *pilot = vr.evals;
    if (err == QMC_EBUDGET || err == QMC_EDIMS)
        return 0;
    if (err)
        return err;
    if (!m)
        return 0; /* non-finite values: plain RQMC counts and flags them */
    /* Both rounds estimate the same integral: a map whose round disagrees
     * with the plain one by more than AUTO_MAP_AGREE standard errors has
     * missed mass that its own variance cannot show (rare points of huge
     * weight, the failure of a product of per-axis Jacobians when the
     * pilot was too thin for the dimension). */
    const double n = (double)vr.round_points;
    const double spread = sqrt(vr.var_plain / n + vr.var_mapped / n);
    const int agree = fabs(vr.mean_mapped - vr.mean_plain) <= AUTO_MAP_AGREE * spread;
    if (agree && vr.var_mapped * AUTO_MAP_GAIN <= vr.var_plain) {
        *map = m;
        double gain = vr.var_mapped > 0 ? vr.var_plain / vr.var_mapped : 1e6;
        reason_append(reason, bytes, "; over a VEGAS map (a pilot of ", vr.evals,
                      " evaluations cut the variance ");
        reason_append(reason, bytes, "", (uint64_t)(gain > 1e6 ? 1e6 : gain), "x)");
    } else {
        qmc__vmap_free(m);
        reason_append(reason, bytes, "; a VEGAS map's pilot (", vr.evals,
                      agree ? " evaluations) did not cut the variance 16x"
                            : " evaluations) disagreed with the plain round");
    }
    return 0;
}

/* auto's RQMC: 8 replicates (the fewest that keep the interval reliable,
 * QMC_SAMPLING_MIN_REPS; the coverage test checks them), and a first round
 * sized from the budget - at most 4096 points, so later rounds reuse it
 * whole, and at least what leaves room for doubling.  (Under 4096 points a
 * round is not reused, so a budget of 1e4 ends after one round of 8 x 512
 * points.  Spending it all, 8 x 1024, was measured: the error fell 1.5-2x
 * and the time doubled, which at d >= 20 let GSL's Sobol at 1e4 finish
 * first and beat it - 7 (family, d) pairs lost the equal-time target for
 * one gained.)
 *
 * The replicates split one net (qmc_sampling_spec.split_net): replicate r
 * is points [r n, (r+1) n) of one scrambled sequence, so the estimate is
 * that of one net of 8 n points, and the spread of the blocks - each a net
 * of n - overstates its error.  With jumps a net's error falls like 1/N,
 * so 8 independent nets of N/8 were sqrt(8) = 2.8x less accurate than one
 * of N (bench_integrate, the discontinuous family, every d).  Smooth
 * integrands gain more (N^-3/2): over 200 draws at budgets 1e5 and 1e6,
 * 2-6x on the Gaussian, product-peak, oscillatory and continuous families
 * at d = 5-30, and 1.1-2.3x on the corner peak, with the interval
 * covering 93-100% of the time against 92-98% for independent nets.  But
 * the blocks share the sequence's scramble, and the part of the error that
 * comes from it is the same in every block, out of sight of their spread:
 * at 8 x 512 points the corner peak at d = 30 covered 88.5% and lost 1.2x.
 * So smooth integrands split only from AUTO_SPLIT_MIN_N points a
 * replicate; integrands with jumps always (test_coverage). */
#define AUTO_SPLIT_MIN_N QMC_SAMPLING_BLOCK

enum { AUTO_MIN_FIRST_N = 16 };

uint64_t qmc__auto_first_n(uint64_t budget, int control)
{
    const uint64_t per_point = (uint64_t)QMC_SAMPLING_MIN_REPS * (control ? 2 : 1);
    uint64_t n = QMC_SAMPLING_BLOCK;
    while (n > AUTO_MIN_FIRST_N && n * per_point * 2 > budget)
        n /= 2;
    return n;
}

uint64_t qmc__auto_min_first_n(void)
{
    return AUTO_MIN_FIRST_N;
}

static qmc_sampling_spec auto_rqmc(const qmc_integrate_spec *spec, const qmc_integrand *f,
                                   const qmc_integrand *g, char *reason, size_t bytes)
{
    qmc_sampling_spec r;
    qmc_sampling_spec_init(&r, QMC_SAMPLER_RQMC);
    r.seed = spec->sampling.seed;
    r.confidence = spec->sampling.confidence;
    r.reps = QMC_SAMPLING_MIN_REPS; /* qmc__auto_first_n assumes it */
    r.n = spec->n_given ? spec->sampling.n : qmc__auto_first_n(spec->max_evals, g != NULL);
    const int jumps = f->smoothness >= QMC_SMOOTH_DISCONTINUOUS;
    if (jumps || r.n >= AUTO_SPLIT_MIN_N) {
        r.split_net = 1;
        reason_append(reason, bytes, "; its ", r.reps,
                      jumps ? " replicates split one net (more accurate with jumps; a "
                              "conservative bar)"
                            : " replicates split one net (more accurate than independent "
                              "nets; a conservative bar)");
    }
    return r;
}

/* auto's RQMC: a VEGAS map when its pilot pays (no control variate), then
 * the replicates; *f becomes f over the map, *map is the caller's to free,
 * and the pilot's evaluations leave s->max_evals. */
static int auto_rqmc_setup(qmc_integrate_spec *s, const qmc_integrand **f,
                           const qmc_integrand *g, qmc_integrate_report *rep, qmc__vmap **map,
                           uint64_t *pilot, qmc__msg *why)
{
    *map = NULL;
    *pilot = 0;
    if (!g) {
        int err = auto_map(s, *f, map, pilot, rep->auto_reason, sizeof rep->auto_reason);
        if (err) {
            qmc__msg_str(why, err == QMC_ECANCELED ? "interrupted"
                                                   : "out of memory for the VEGAS map");
            return err;
        }
        s->max_evals -= *pilot;
    }
    /* f's own smoothness: f J over a map declares the jumps at its bin
     * edges, but they are not what the split is for. */
    s->sampling = auto_rqmc(s, *f, g, rep->auto_reason, sizeof rep->auto_reason);
    if (*map)
        *f = qmc__vmap_integrand(*map);
    s->n_given = 1;
    return 0;
}

/* Below 2 strata an axis "stratified" is one stratum of one point at best
 * (k = 1: the largest k^d <= n at d >= 13 for the default 4096 points):
 * an infinite bar that looked like a result.  Refused instead. */
static int stratified_refuse(uint64_t n, uint32_t d, qmc__msg *why)
{
    uint64_t need = 1;
    for (uint32_t j = 0; j < d && need <= QMC_SEQ_MAX_INDEX; j++)
        need *= 2;
    if (n >= need)
        return 0;
    qmc__msg_set(why, "stratified: 2 strata an axis in ", d, " dims need 2^d = ");
    if (need <= QMC_SEQ_MAX_INDEX)
        qmc__msg_u64(why, need);
    else
        qmc__msg_str(why, "more than 2^32");
    qmc__msg_str(why, " points; n = ");
    qmc__msg_u64(why, n);
    qmc__msg_str(why, " gives 1 stratum an axis and no error bar: use lhs or rqmc, or raise "
                      "--n");
    return QMC_ECOUNT;
}

/* The sampling spec a sampling method s->method runs (before adaptive
 * rounds change its n). */
static int method_sampling(const qmc_integrate_spec *s, uint32_t dims, qmc_sampling_spec *q,
                           qmc__msg *why)
{
    *q = s->sampling;
    q->sampler = sampler_of(s->method);
    if (q->n == 0 || q->n > QMC_SEQ_MAX_INDEX) {
        qmc__msg_set(why, "n = ", q->n, " points is outside 1..2^32");
        return QMC_ECOUNT;
    }
    if (q->sampler == QMC_SAMPLER_STRATIFIED) {
        if (!s->n_given)
            q->n = stratified_count(q->n, dims);
        return stratified_refuse(q->n, dims, why);
    }
    return 0;
}

int qmc__fixed_sampling_spec(const qmc_integrate_spec *s, uint32_t dims, qmc_sampling_spec *q,
                             char *why, size_t why_bytes)
{
    qmc__msg m;
    qmc__msg_init(&m, why, why_bytes);
    if (!is_sampling(s->method) || s->tol_abs > 0 || s->tol_rel > 0) {
        qmc__msg_str(&m, "a part needs a sampling method (mc, stratified, lhs, qmc, rqmc) "
                         "with a fixed n: no tolerance");
        return QMC_EINVAL;
    }
    int err = method_sampling(s, dims, q, &m);
    return err ? err : fixed_budget(s, q, 1, &m);
}

static int run_sampling_method(const qmc_integrate_spec *s, const qmc_integrand *f,
                               const qmc_integrand *g, qmc_block_runner runner,
                               void *runner_ctx, qmc_integrate_report *rep, qmc__msg *why)
{
    qmc_sampling_spec q;
    int err = method_sampling(s, f->dims, &q, why);
    return err ? err : run_sampling(s, q, f, g, runner, runner_ctx, rep, why);
}

static int run_rule(const qmc_integrate_spec *s, const qmc_integrand *f,
                    qmc_integrate_report *rep, qmc__msg *why);

static int integrate_once(const qmc_integrate_spec *spec, const qmc_integrand *f,
                          const qmc_integrand *g, qmc_block_runner runner, void *runner_ctx,
                          qmc_integrate_report *rep, char *why, size_t why_bytes);

/* Every method, then the integrand's own audit of the result (evidence
 * only it can gather: a scene's MIS shares). */
int qmc_integrate(const qmc_integrate_spec *spec, const qmc_integrand *f,
                  const qmc_integrand *g, qmc_block_runner runner, void *runner_ctx,
                  qmc_integrate_report *rep, char *why, size_t why_bytes)
{
    int err = integrate_once(spec, f, g, runner, runner_ctx, rep, why, why_bytes);
    if (err == 0 && f->audit)
        rep->res.flags |= f->audit(f->ctx, &rep->res);
    return err;
}

static int integrate_once(const qmc_integrate_spec *spec, const qmc_integrand *f,
                          const qmc_integrand *g, qmc_block_runner runner, void *runner_ctx,
                          qmc_integrate_report *rep, char *why, size_t why_bytes)
{
    qmc__msg m;
    qmc__msg_init(&m, why, why_bytes);
    memset(rep, 0, sizeof *rep);
    qmc_result_init(&rep->res);
    rep->method_used = spec->method;
    if (!f || !f->eval || f->dims == 0) {
        qmc__msg_str(&m, "no integrand");
        return QMC_EINVAL;
    }
    if (qmc_method_name(spec->method)[0] == '\0') {
        qmc__msg_str(&m, "unknown method");
        return QMC_EINVAL;
    }
    if (g && !is_sampling(spec->method) && spec->method != QMC_METHOD_AUTO) {
        qmc__msg_str(&m, "a control variate works with the sampling methods (mc, stratified, "
                         "lhs, qmc, rqmc), not ");
        qmc__msg_str(&m, qmc_method_name(spec->method));
        return QMC_EINVAL;
    }
    if (!(spec->tol_abs >= 0.0) || !(spec->tol_rel >= 0.0) || !isfinite(spec->tol_abs) ||
        !isfinite(spec->tol_rel)) {
        qmc__msg_str(&m, "tolerances must be finite and >= 0");
        return QMC_EINVAL;
    }
    if (spec->max_evals == 0) {
        qmc__msg_str(&m, "the evaluation budget must be at least 1");
        return QMC_EBUDGET;
    }
    if (!(spec->sampling.confidence > 0.0 && spec->sampling.confidence < 1.0)) {
        qmc__msg_str(&m, "confidence must lie strictly between 0 and 1");
        return QMC_EINVAL;
    }
    qmc_integrate_spec s = *spec;
    qmc__vmap *map = NULL; /* auto's RQMC over a VEGAS map */
    uint64_t pilot = 0;
    if (s.method == QMC_METHOD_AUTO) {
        s.method = qmc__auto_choice(spec, f, g, rep->auto_reason, sizeof rep->auto_reason);
        rep->method_used = s.method;
        if (s.tol_abs == 0 && s.tol_rel == 0)
            s.tol_rel = 1e-6; /* auto always stops adaptively */
        if (s.method == QMC_METHOD_RQMC) {
            int err = auto_rqmc_setup(&s, &f, g, rep, &map, &pilot, &m);
            if (err)
                return err;
        }
    }
    if (is_sampling(s.method)) {
        int err = run_sampling_method(&s, f, g, runner, runner_ctx, rep, &m);
        rep->res.evals += pilot;
        qmc__vmap_free(map);
        return err;
    }
    /* The rule integrates f watched (rule_evidence.h): its nodes' values
     * are the only evidence of mass the rule stepped over. */
    qmc__node_stats nodes;
    qmc__node_watch watch;
    qmc__node_watch_init(&watch, f, &nodes);
    int err = run_rule(&s, &watch.view, rep, &m);
    if (err)
        return err;
    rep->res.flags |= qmc__rule_evidence_flags(&rep->res, &nodes);
    int refuted;
    rep->res.flags |= qmc__rule_smoothness_flags(&s, f, &rep->res, &refuted);
    /* auto chose the rule on what f declares, and the rule cannot see what
     * its nodes missed: more work, not a flag, while the budget lasts -
     * RQMC with what is left, whose points land between any grid's nodes
     * and whose adaptive rounds grow until they find the mass.  Only when
     * at least half the budget is left (a rule that saw nothing stops
     * after a few dozen nodes); a rule that spent most of it unresolved
     * keeps its flagged answer rather than trade it for a thinner one. */
    const uint64_t spent = rep->res.evals;
    const uint32_t got = rep->res.flags;
    const int unresolved = (got & QMC_FLAG_UNRESOLVED) && !(got & QMC_FLAG_NONFINITE);
    /* auto's Gauss-Kronrod on a declared singularity that evaluated f on
     * it (a midpoint at 1/2, say): RQMC's points miss it. */
    const int on_singularity = (got & QMC_FLAG_NONFINITE) &&
                               s.method == QMC_METHOD_GAUSS_KRONROD &&
                               f->smoothness == QMC_SMOOTH_SINGULAR;
    const int to_rqmc = spec->method == QMC_METHOD_AUTO && (unresolved || on_singularity) &&
                        spent <= spec->max_evals / 2 &&
                        spec->max_evals - spent >= (uint64_t)QMC_SAMPLING_MIN_REPS * 16;
    /* A bar still in doubt, kept: checked by points off every node of the
     * rule (rule_pilot.h).  Not when auto is about to replace it, nor
     * when Gauss-Kronrod has shown it wrong. */
    if (!to_rqmc)
        return refuted ? 0 : qmc__rule_pilot(&s, f, &rep->res, why, why_bytes);
    reason_append(rep->auto_reason, sizeof rep->auto_reason, "; its ", spent,
                  on_singularity ? " nodes included the singularity (a non-finite value): "
                                   "rqmc with the rest of the budget"
                                 : " nodes left the integrand unresolved (levels agreeing "
                                   "near zero): rqmc with the rest of the budget");
    s.method = QMC_METHOD_RQMC;
    s.max_evals = spec->max_evals - spent;
    s.sampling = spec->sampling;
    s.n_given = spec->n_given;
    /* the rule's non-finite values are left out of the answer too: said */
    const uint64_t nonfinite_spent = rep->res.nonfinite;
    memset(&rep->res, 0, sizeof rep->res);
    rep->detail[0] = '\0';
    rep->method_used = QMC_METHOD_RQMC;
    err = auto_rqmc_setup(&s, &f, g, rep, &map, &pilot, &m);
    if (err)
        return err;
    err = run_sampling_method(&s, f, g, runner, runner_ctx, rep, &m);
    rep->res.evals += pilot + spent;
    rep->res.nonfinite += nonfinite_spent;
    qmc__vmap_free(map);
    return err;
}

/* A deterministic rule (s->method is one); a declared kink or jump is
 * judged after it (rule_confirm.h), Gauss-Kronrod's own case here. */
static int run_rule(const qmc_integrate_spec *s, const qmc_integrand *f,
                    qmc_integrate_report *rep, qmc__msg *why)
{
    int err;
    switch (s->method) {
    case QMC_METHOD_GAUSS_KRONROD:
        err = run_gk(s, f, rep, why);
        /* Its floors keep kinks and interior steps honest, and a jump at a
         * declared break is no jump to it.  A jump declared without its
         * place is a bar resting on the floors' guesses (an end gap holds
         * at most gap x the largest |f| seen; a jump to a value further
         * off is out of their sight): flagged, as FLAGS.md promises. */
        if (err == 0 && f->smoothness == QMC_SMOOTH_DISCONTINUOUS && !qmc__gk_breaks_usable(f))
            rep->res.flags |= QMC_FLAG_ERROR_UNRELIABLE;
        return err;
    case QMC_METHOD_CUBATURE:
    case QMC_METHOD_CLENSHAW_CURTIS:
        err = run_cubature(s, f, s->method == QMC_METHOD_CLENSHAW_CURTIS, rep, why);
        break;
    case QMC_METHOD_MIDPOINT:
        err = run_tensor(s, QMC_RULE1D_MIDPOINT, f, rep, why);
        break;
    case QMC_METHOD_TRAPEZOID:
        err = run_tensor(s, QMC_RULE1D_TRAPEZOID, f, rep, why);
        break;
    case QMC_METHOD_SIMPSON:
        err = run_tensor(s, QMC_RULE1D_SIMPSON, f, rep, why);
        break;
    case QMC_METHOD_GAUSS_LEGENDRE:
        err = run_tensor(s, QMC_RULE1D_GAUSS_LEGENDRE, f, rep, why);
        break;
    default:
        qmc__msg_str(why, "unknown method");
        return QMC_EINVAL;
    }
    /* A polynomial rule's error estimate assumes the integrand is smooth
     * where it samples: across a jump or a singularity two rules can agree
     * while both are wrong (the benchmark saw cubature claim 1e-14 on a
     * discontinuous Genz integrand whose error was 6e-4), and across a
     * kink they often do (cubature's bar on the continuous Genz family
     * fell short of the actual error in 8-38% of the benchmark's runs at
     * d = 2..10, and in 5 of test_cubature's 12 kink runs).  Such a bar is
     * flagged after the run unless evidence that is not the rule's
     * confirms it (integrate_once, rule_confirm.h). */
    return err;
}

const char *qmc_method_name(qmc_method m)
{
    switch (m) {
#define QMC__METHOD_TEXT(name, text) \
    case QMC_METHOD_##name:          \
        return text;
        QMC_METHOD_MAP(QMC__METHOD_TEXT)
#undef QMC__METHOD_TEXT
    }
    return "";
}

int qmc_method_parse(const char *name, qmc_method *out)
{
#define QMC__METHOD_PARSE(n, text)     \
    if (strcmp(name, text) == 0) {     \
        *out = QMC_METHOD_##n;         \
        return 0;                      \
    }
    QMC_METHOD_MAP(QMC__METHOD_PARSE)
#undef QMC__METHOD_PARSE
    return QMC_EINVAL;
}
