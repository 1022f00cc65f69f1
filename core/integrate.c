/*
 * integrate.c - one entry point for every method, and how `auto` runs
 * what it chose (auto_choice.c chooses; see qmc/integrate.h).
 *
 * Workspaces for the deterministic rules are allocated here, once per
 * call, and sized from the spec (so a request states its memory up front);
 * nothing is allocated per evaluation.
 */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "auto_choice.h"
#include "auto_rqmc.h"
#include "integrate_memory.h"
#include "interrupt.h"
#include "msg.h"
#include "quad_impl.h"
#include "rule_confirm.h"
#include "rule_pilot.h"
#include "rule_evidence.h"
#include "scaled_integrand.h"
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

/* Below this budget RQMC's half is too thin to vouch for cubature on a
 * kink (3D at 2000 and 3000 evaluations: the flag stayed, and the rule's
 * error with half the budget was 1.6x larger), so the rule has it all.
 * At 1e4 in 3D the half vouched for 67 of 100 random kink positions. */
#define AUTO_WITNESS_MIN_BUDGET 10000u

/* Whether auto may hand the rest of the budget to RQMC after a rule that
 * spent `spent`: half of it or more left, and room for RQMC's smallest
 * round (a rule that spent most of it keeps its flagged answer rather than
 * trade it for a thinner one). */
static int auto_budget_left(const qmc_integrate_spec *spec, uint64_t spent)
{
    return spec->method == QMC_METHOD_AUTO && spent <= spec->max_evals / 2 &&
           spec->max_evals - spent >= (uint64_t)QMC_SAMPLING_MIN_REPS * 16;
}

/* Whether a caller's n (spec->n_given) lets auto's RQMC make a witness
 * within `budget`: a power of two (anything else is no net, not_pow2),
 * whose 8 replicates fit.  Always, when auto sizes n itself. */
static int auto_witness_n_fits(const qmc_integrate_spec *spec, uint64_t budget)
{
    const uint64_t n = spec->sampling.n;
    if (!spec->n_given)
        return 1;
    return n != 0 && (n & (n - 1)) == 0 && n <= budget / QMC_SAMPLING_MIN_REPS;
}

/*
 * auto's rule whose bar is still in doubt after every check it had
 * (error_unreliable: a declared kink or jump that neither Gauss-Kronrod
 * from declared breaks nor the pilot could confirm, or a bar Gauss-Kronrod
 * refuted), with the budget left: RQMC with the rest, whose replicates
 * need no smoothness for their bar, vouches for it or replaces it
 * (auto_witness).  The rule's flag was no false alarm:
 * over 100 random kink positions of the matrix's genz-continuous in 3D,
 * auto's cubature missed by more than 3 bars 26 times, every time flagged,
 * and carried the flag on the 74 others (rule_need_scan).  Not on a
 * declared singularity, where RQMC's variance may be infinite and
 * Gauss-Kronrod's flagged answer is the better one, nor on non-finite
 * values (the singularity hand-off above handles Gauss-Kronrod's).
 */
static int auto_replaces_doubt(const qmc_integrate_spec *spec, const qmc_integrand *f,
                               const qmc_result *res)
{
    return (res->flags & QMC_FLAG_ERROR_UNRELIABLE) && !(res->flags & QMC_FLAG_NONFINITE) &&
           f->smoothness < QMC_SMOOTH_SINGULAR && auto_witness_n_fits(spec, spec->max_evals) &&
           auto_budget_left(spec, res->evals);
}

/* lead, the evaluations spent, what they showed, and the hand-off, onto
 * auto's reason. */
static void auto_reason_handoff(char *reason, size_t bytes, const char *lead, uint64_t spent,
                                const char *what)
{
    qmc__auto_reason_append(reason, bytes, lead, spent, what);
    const size_t len = strlen(reason);
    qmc__msg m;
    qmc__msg_init(&m, reason + len, bytes - len);
    qmc__msg_str(&m, ": rqmc with the rest of the budget");
}

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

/* auto's rule result in rep, replaced by RQMC on f with the rest of
 * spec's budget (s: the rule's spec, becomes RQMC's); every evaluation
 * counted, on every return (a cancelled VEGAS pilot's too), and the
 * rule's non-finite values too (they are left out of the answer: said). */
static int auto_rqmc_rest(const qmc_integrate_spec *spec, qmc_integrate_spec *s,
                          const qmc_integrand *f, const qmc_integrand *g,
                          qmc_block_runner runner, void *runner_ctx, qmc_integrate_report *rep,
                          qmc__msg *m)
{
    const uint64_t spent = rep->res.evals, nonfinite_spent = rep->res.nonfinite;
    s->method = QMC_METHOD_RQMC;
    s->max_evals = spec->max_evals - spent;
    s->sampling = spec->sampling;
    s->n_given = spec->n_given;
    memset(&rep->res, 0, sizeof rep->res);
    rep->detail[0] = '\0';
    rep->method_used = QMC_METHOD_RQMC;
    qmc__vmap *map = NULL;
    uint64_t pilot = 0;
    int err = qmc__auto_rqmc_setup(s, &f, g, rep, &map, &pilot, m);
    if (err) {
        qmc__cancelled(&rep->res, f->dims, spent + pilot);
        return err;
    }
    err = run_sampling_method(s, f, g, runner, runner_ctx, rep, m);
    rep->res.evals += pilot + spent;
    rep->res.nonfinite += nonfinite_spent;
    qmc__vmap_free(map);
    return err;
}

/*
 * auto's rule whose bar stayed in doubt, then RQMC with the rest of the
 * budget as a witness that shares none of its nodes: when RQMC vouches
 * for the rule's bar by the pilot's test (rule_pilot.h: the truth within
 * 2 bars whenever RQMC's 99% interval holds; the bar raised to what RQMC
 * resolves when that is coarser), the rule's estimate stands, without the
 * flag - on the 2D kinks of bench_integrate it was 4e-13 of int |f| where
 * RQMC's own was 2e-8.  When RQMC is off the rule by more than its noise,
 * or Gauss-Kronrod refuted the bar, RQMC's answer replaces the rule's.  A
 * witness with a flag of its own neither vouches nor replaces: the rule's
 * flagged answer stays (on 4D kinks at 1e4 the thin RQMC was the worse
 * answer, 5 misses in 100 against the rule's 0).  A witness that fell
 * short of the tolerance itself (not_converged) vouches at its own
 * resolution, and the answer carries its shortfall.
 */
static int auto_witness(const qmc_integrate_spec *spec, qmc_integrate_spec *s,
                        const qmc_integrand *f, const qmc_integrand *g, qmc_block_runner runner,
                        void *runner_ctx, int refuted, qmc_integrate_report *rep, qmc__msg *m)
{
    const qmc_integrate_report kept = *rep; /* the rule's answer, reason aside */
    qmc_result rule = kept.res;
    const double tol = qmc__rule_tolerance(s, &rule);
    /* At the rule's scale, so that its sums hold wherever the rule's did
     * (scaled_integrand.h), the caller's absolute tolerance with it; its
     * answer, if it replaces the rule's, in f's units. */
    qmc__scaled_integrand sf;
    qmc__scaled_integrand_init(&sf, f, &rule);
    if (s->tol_abs > 0.0) /* one that underflows would mean no tolerance */
        s->tol_abs = fmax(ldexp(s->tol_abs, -sf.e), DBL_TRUE_MIN);
    int err = auto_rqmc_rest(spec, s, &sf.g, g, runner, runner_ctx, rep, m);
    qmc__unscale_result(&rep->res, sf.e);
    const qmc_result *w = &rep->res;
    if (err == QMC_ECANCELED)
        return err;
    /* Gauss-Kronrod showed the rule's bar wrong: RQMC's answer, flagged
     * or not, is the better one. */
    if (refuted && !err)
        return 0;
    const uint32_t short_of_tol = QMC_FLAG_NOT_CONVERGED | QMC_FLAG_BUDGET;
    const int clean = !err && !(w->flags & ~short_of_tol) && w->error_kind == QMC_ERROR_STDERR &&
                      isfinite(w->estimate) && isfinite(w->error);
    const double t = qmc_student_t_quantile(0.99, (double)s->sampling.reps - 1.0);
    const double bar = rule.error;
    const char *said;
    int keep = 1; /* the rule's answer */
    if (err) {
        said = "; rqmc could not run on the rest (a refused round): the rule's flagged answer";
    } else if (!clean) {
        said = "; rqmc carried flags of its own and vouched for nothing: the rule's flagged "
               "answer";
    } else if (qmc__rule_bar_vouched(&rule, w, t,
                                     (w->flags & QMC_FLAG_NOT_CONVERGED) ? INFINITY : tol)) {
        said = rule.error != bar ? "; rqmc vouched for the rule's bar raised to its own "
                                   "resolution: the rule's answer"
                                 : "; rqmc vouched for the rule's bar: the rule's answer";
        rule.flags &= ~QMC_FLAG_ERROR_UNRELIABLE;
        if (!(rule.error <= tol))
            rule.flags |= w->flags & short_of_tol;
    } else {
        /* off the rule by more than its noise, or vouching only for a bar
         * coarser than the tolerance: its answer */
        said = "; rqmc did not vouch for the rule's bar: rqmc's answer";
        keep = 0;
    }
    if (keep) {
        /* with every evaluation and non-finite value the witness met */
        rule.evals = w->evals;
        rule.nonfinite += w->nonfinite;
        rule.flags |= w->flags & QMC_FLAG_NONFINITE;
        rep->res = rule;
        rep->method_used = kept.method_used;
        rep->sampling = kept.sampling;
        rep->cv = kept.cv;
        memcpy(rep->detail, kept.detail, sizeof rep->detail);
    }
    const size_t len = strlen(rep->auto_reason);
    qmc__msg r;
    qmc__msg_init(&r, rep->auto_reason + len, sizeof rep->auto_reason - len);
    qmc__msg_str(&r, said);
    return 0;
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
            int err = qmc__auto_rqmc_setup(&s, &f, g, rep, &map, &pilot, &m);
            if (err)
                return err;
        }
        /* Cubature's bar on a declared kink rests on its own nodes, and
         * only RQMC with the rest can vouch for it at auto's tolerance
         * (auto_witness): half the budget is kept for that, from
         * AUTO_WITNESS_MIN_BUDGET on. */
        if (s.method == QMC_METHOD_CUBATURE && f->smoothness != QMC_SMOOTH_ANALYTIC &&
            spec->max_evals >= AUTO_WITNESS_MIN_BUDGET &&
            auto_witness_n_fits(spec, spec->max_evals / 2))
            s.max_evals = spec->max_evals / 2;
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
    const uint32_t got = rep->res.flags;
    const int unresolved = (got & QMC_FLAG_UNRESOLVED) && !(got & QMC_FLAG_NONFINITE);
    /* auto's Gauss-Kronrod on a declared singularity that evaluated f on
     * it (a midpoint at 1/2, say): RQMC's points miss it. */
    const int on_singularity = (got & QMC_FLAG_NONFINITE) &&
                               s.method == QMC_METHOD_GAUSS_KRONROD &&
                               f->smoothness == QMC_SMOOTH_SINGULAR;
    if ((unresolved || on_singularity) && auto_budget_left(spec, rep->res.evals)) {
        auto_reason_handoff(rep->auto_reason, sizeof rep->auto_reason, "; its ",
                            rep->res.evals,
                            on_singularity ? " nodes included the singularity (a non-finite "
                                             "value)"
                                           : " nodes left the integrand unresolved (levels "
                                             "agreeing near zero)");
        return auto_rqmc_rest(spec, &s, f, g, runner, runner_ctx, rep, &m);
    }
    /* A bar still in doubt, kept: checked by points off every node of the
     * rule (rule_pilot.h).  Not when Gauss-Kronrod has shown it wrong. */
    if (!refuted) {
        err = qmc__rule_pilot(&s, f, &rep->res, why, why_bytes);
        if (err)
            return err;
    }
    /* auto: RQMC with the rest, to vouch for the bar or replace it */
    if (!auto_replaces_doubt(spec, f, &rep->res))
        return 0;
    auto_reason_handoff(rep->auto_reason, sizeof rep->auto_reason, "; after ", rep->res.evals,
                        refuted ? " evaluations Gauss-Kronrod from the declared breaks showed "
                                  "its bar wrong"
                                : " evaluations nothing off its nodes had confirmed its bar");
    return auto_witness(spec, &s, f, g, runner, runner_ctx, refuted, rep, &m);
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
