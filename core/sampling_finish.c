/*
 * sampling_finish.c - from block sums to an honest result.
 *
 * Blocks are combined in block order (so any partition of the work gives
 * the same bits).  Error bars:
 *  - replicated methods (rqmc, and any sampler with reps >= 2): the spread
 *    of the R replicate means, with a Student-t interval on R-1 degrees of
 *    freedom - valid for any sampler whose replicates are independent and
 *    unbiased;
 *  - one replicate of mc: the sample standard error (Student-t, n-1);
 *  - one replicate of stratified or lhs: the same formula, which
 *    overestimates their variance (stratification never raises it; for
 *    LHS, Owen 1997: at most n/(n-1) times the MC variance): conservative;
 *  - qmc: no error bar at all (error_kind NONE), since one deterministic
 *    point set carries no information about its own error.
 * Diagnostics raise flags instead of hiding trouble (qmc/result.h).
 * Running blocks lives here too: serially, or through the caller's runner,
 * optionally behind an interrupt hook (qmc__guard_run, see interrupt.h).
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "interrupt.h"
#include "neumaier.h"
#include "sampling_impl.h"

/*
 * Hill's estimator of the tail index alpha from the largest |f| values:
 * alpha = k / sum_{i<k} ln(x_i / x_k).  P(|f| > t) ~ t^-alpha, so the
 * variance is infinite for alpha <= 2.  Under a Pareto tail of index 2,
 * alpha_hat = 2k / G with G ~ Gamma(k, 1), so "alpha_hat >= 2k / G_p(k)"
 * rules out an infinite variance at the 1 - p level (heavy_tail_threshold).
 * k is at most n / share, at most the QMC_SAMPLING_TOP - 1 = 63 values
 * kept, and at most the nonzero values less one (x_k must be positive),
 * so sparse integrands are still tested.
 *
 * Two settings (tail_test).  An integrand that declares no singularity is
 * bounded, so its variance is finite and a flag there is a false alarm
 * about skew: it keeps the test it had, 95% and k <= n / 20, which
 * catches x^-1/2 almost always and leaves bounded integrands mostly
 * alone.  One that declares a singularity gets 99% and k <= n / 10.
 * Measured by simulation (3000 runs each) and on the program (200 seeds,
 * bench/scans/tail_scan.py): at 95% and n / 20, plain MC on x^-1/2 missed
 * by more than 3 reported errors unflagged in 1-2% of runs at n = 256-4096
 * (one run in 20 passes a 95% test, and the runs that pass are those
 * whose sample lacks the large values, so they miss), against 0.4-1.2%
 * for finite-variance x^-1/4.  At 99% and n / 10: 0-0.8%, while x^-1/4
 * is flagged in 16% of runs at n = 256 (27% before: k = 25 instead of 12
 * buys the power), 0.5% at 512 and none from 1024.  The cost is alpha
 * near 3 (x^-1/3: finite variance, no finite fourth moment), flagged in
 * 21% of runs from n = 1024 (6-12% before): 63 values cannot tell alpha 3
 * from 2 more sharply.  On bounded Genz families the 99% test at n / 10
 * flagged 2-4 times as many correct answers at n = 256, hence the split.
 * Returns NAN when k < 8: too few values to say (QMC_FLAG_TAIL_UNTESTED),
 * which is not the same as "not heavy".
 */
typedef struct tail_test {
    uint64_t share; /* k <= n / share */
    double z;       /* the standard normal's p point */
} tail_test;

static const tail_test tail_bounded = {20, -1.6448536269514722};  /* 95% */
static const tail_test tail_singular = {10, -2.3263478740408408}; /* 99% */

static double hill_alpha(const double *top, uint64_t n, int nonzero, uint64_t share,
                         int *k_used)
{
    int k = QMC_SAMPLING_TOP - 1;
    if (n < share * (uint64_t)QMC_SAMPLING_TOP)
        k = (int)(n / share);
    if (k > nonzero - 1)
        k = nonzero - 1;
    *k_used = k;
    if (k < QMC_SAMPLING_MIN_NONZERO)
        return NAN;
    double s = 0.0;
    for (int i = 0; i < k; i++)
        s += log(top[i] / top[k]);
    return s > 0.0 ? k / s : INFINITY;
}

/* 2k / G_p(k), G ~ Gamma(k, 1), by the Wilson-Hilferty cube (within 1%
 * of the exact quantile at k >= 8): the smallest Hill estimate that still
 * rules out alpha <= 2 at the 1 - p level. */
static double heavy_tail_threshold(int k, double z)
{
    double c = 1.0 - 1.0 / (9.0 * k) + z / (3.0 * sqrt((double)k));
    return 2.0 / (c * c * c);
}

/* Nonzero |f| among the pooled top values: the count of nonzero values
 * seen, up to QMC_SAMPLING_TOP (all the tests below need). */
static int top_nonzero(const double *top)
{
    int k = 0;
    while (k < QMC_SAMPLING_TOP && top[k] > 0.0)
        k++;
    return k;
}

static int is_base2_net(qmc_seq_kind kind)
{
    return kind == QMC_SEQ_SOBOL;
}

double qmc__variance_rse(const qmc_sampling_sums *sums, uint64_t count)
{
    uint64_t blocks = 0, points = 0;
    double m2 = 0.0;
    for (uint64_t i = 0; i < count; i++) {
        const uint64_t m = sums[i].count - sums[i].nonfinite;
        if (m < 2)
            continue;
        blocks++;
        points += m;
        m2 += sums[i].m2_f;
    }
    if (blocks < QMC__RSE_MIN_BLOCKS || !(m2 > 0.0) || !isfinite(m2))
        return NAN;
    const double v = m2 / (double)points;
    double spread = 0.0;
    for (uint64_t i = 0; i < count; i++) {
        const uint64_t m = sums[i].count - sums[i].nonfinite;
        if (m < 2)
            continue;
        const double dv = sums[i].m2_f / (double)m - v;
        spread += (double)m * dv * dv;
    }
    return sqrt(spread / (double)blocks / (double)points) / v;
}

/*
 * The same relative standard error from the pooled sample instead of the
 * blocks, for samplers whose blocks are not exchangeable: stratified
 * sampling numbers its strata in order, so a block is a slab of the cube,
 * and a narrow peak lies in one or two of them - their variances then
 * disagree by the peak's whole weight however well the sample resolves
 * it (the stability run's 2D Gaussian of width 1/400: flagged in 5 of 5
 * runs whose bars were 70 times the error).  The fourth central moment is
 * not kept, so it is bounded from above by the largest values: each top
 * value contributes at most (|f| + |mean|)^4, and every other value at
 * most (top[63] + |mean|)^2 times its square, whose sum is at most m2
 * less what the top values surely hold.  An upper bound on the sample's
 * kurtosis gives an upper bound on the estimate, so the test is at least
 * as strict as the sample itself allows.  The fourth powers are taken at
 * the scale of the largest magnitude, so they neither overflow nor
 * underflow; m2 arrives at the values' own scale, where rounding in the
 * subnormal range can inflate it, but a bar there is 0 and flagged
 * zero_spread anyway.  NAN when the variance is 0 or not finite.
 */
double qmc__pooled_variance_rse(const double *top, uint64_t finite, double mean, double m2)
{
    const double am = fabs(mean);
    const double scale = top[0] > am ? top[0] : am;
    if (finite < 2 || !(m2 > 0.0) || !isfinite(m2) || !(scale > 0.0) || !isfinite(scale))
        return NAN;
    const double mu = am / scale, v = m2 / scale / scale;
    if (!(v > 1e-150))
        return NAN; /* its square would underflow: a variance below rounding */
    double s4 = 0.0, held = 0.0;
    int k = 0;
    for (; k < QMC_SAMPLING_TOP && top[k] > 0.0; k++) {
        /* |f - mean| lies between ||f| - |mean|| and |f| + |mean| */
        const double t = top[k] / scale, hi = t + mu, lo = t - mu;
        s4 += hi * hi * hi * hi;
        held += lo * lo;
    }
    /* the values below the kept ones: at most the smallest kept, or 0 */
    const double below = (k == QMC_SAMPLING_TOP ? top[k - 1] / scale : 0.0) + mu;
    const double rest = v > held ? v - held : 0.0;
    s4 += below * below * rest;
    const double kurt = (double)finite * s4 / (v * v);
    return kurt > 1.0 ? sqrt((kurt - 1.0) / (double)finite) : 0.0;
}

/*
 * Whether the largest values bunch toward a maximum, as a bounded
 * integrand's do once the sample has found its peak, rather than follow a
 * power law: Hill's estimate from the top 8 values is above what a Pareto
 * tail of the index fitted to the top 63 gives at the 99.9% level (8 / G,
 * G ~ Gamma(8, 1), Wilson-Hilferty: 4.16 times the fitted index).  On
 * x^-1/2 this passed 2 of 4000 simulated runs of 2^16 points; on narrow
 * Gaussian peaks that the sample hit 20 or more times (peak-gauss-2d at
 * 2^20 points, a = 60 and 100 at 2^16) the ratio was 6 to 15.  Needs 64
 * nonzero values.
 */
static int bound_seen(const double *top)
{
    const int k_small = QMC_SAMPLING_MIN_NONZERO, k_large = QMC_SAMPLING_TOP - 1;
    if (!(top[k_large] > 0.0))
        return 0;
    double s_small = 0.0, s_large = 0.0;
    for (int i = 0; i < k_large; i++) {
        double l = log(top[i] / top[k_large]);
        s_large += l;
        if (i < k_small)
            s_small += log(top[i] / top[k_small]);
    }
    if (!(s_large > 0.0))
        return 1; /* the top 64 are equal: a plateau, the bound itself */
    if (!(s_small > 0.0))
        return 1;
    const double a_small = k_small / s_small, a_large = k_large / s_large;
    const double c = 1.0 - 1.0 / (9.0 * k_small) - 3.0902323061678132 / (3.0 * sqrt(k_small));
    return a_small >= a_large / (c * c * c);
}

void qmc__sampling_evidence(qmc_result *res, const double *top, uint64_t finite, int has_bar,
                            int singular, double variance_rse)
{
    const int nonzero = top_nonzero(top);
    const tail_test *t = singular ? &tail_singular : &tail_bounded;
    int k = 0;
    const double alpha = hill_alpha(top, finite, nonzero, t->share, &k);
    /* A bounded integrand has a finite variance; Hill's test then only
     * says that the largest values are spread over decades, which a narrow
     * peak's values are however often the sample hit it.  What matters for
     * the bar is whether the sample variance rests on enough values: where
     * the blocks' variances agree so well that the pooled variance's
     * relative standard error is at most QMC__RSE_BOUNDED, and the largest
     * values bunch toward a maximum (bound_seen), the tail is no reason to
     * distrust the bar.  Both are needed: x^-1/2 (infinite variance) gave
     * block variances that agree to 0.1 in half its runs at 2^16 and 2^20
     * points, since each block holds its own scale-free share.  A declared
     * singularity keeps Hill's verdict, and so does a replicated bar
     * (rqmc): it rests on R replicate means, not on the sample variance
     * this judges, and 16 replicates sharing 16 hits are skewed however
     * well the variance is known (random peaks, 1000 runs: 5 more silent
     * misses when rqmc was cleared too; none for mc and lhs). */
    const int well_estimated = !singular && variance_rse <= QMC__RSE_BOUNDED &&
                               bound_seen(top);
    if (alpha < heavy_tail_threshold(k, t->z) && !well_estimated)
        res->flags |= QMC_FLAG_HEAVY_TAIL | QMC_FLAG_ERROR_UNRELIABLE;
    /* Fewer than QMC_SAMPLING_MIN_NONZERO nonzero values (none at all, when
     * every point missed a small support or light): the spread describes
     * the points that saw nothing, not the mass between them.  0 +- 0 is
     * the extreme case. */
    if (nonzero < QMC_SAMPLING_MIN_NONZERO)
        res->flags |= QMC_FLAG_FEW_NONZERO | (has_bar ? QMC_FLAG_ERROR_UNRELIABLE : 0u);
    if (!has_bar)
        return;
    if (isnan(alpha))
        res->flags |= QMC_FLAG_TAIL_UNTESTED;
    /* A bar of exactly 0 from a randomized method: every sample (or every
     * replicate mean) came out equal - the split replicates of a piecewise
     * constant function can - which no random error does; and an infinite
     * bar (one point, one live replicate) says nothing either. */
    if (res->error == 0.0 && isfinite(res->estimate))
        res->flags |= QMC_FLAG_ZERO_SPREAD | QMC_FLAG_ERROR_UNRELIABLE;
    if (isinf(res->error))
        res->flags |= QMC_FLAG_ERROR_UNRELIABLE;
}

int qmc_sampling_finish(const qmc_sampling_job *job, const qmc_sampling_sums *sums,
                        uint64_t count, qmc_result *res, qmc_cv_report *cv)
{
    qmc_result_init(res);
    if (cv)
        memset(cv, 0, sizeof *cv);
    const qmc_sampling_spec *s = &job->spec;
    const uint64_t nb = qmc_sampling_blocks(job);
    if (count != nb)
        return QMC_EINVAL;
    for (uint64_t i = 0; i < nb; i++)
        if (sums[i].block != i)
            return QMC_EINVAL;

    /* Pooled moments (all points, block order) for the control variate
     * coefficient and the tail check. */
    qmc_sampling_sums all;
    memset(&all, 0, sizeof all);
    for (uint64_t i = 0; i < nb; i++) {
        qmc__moments_merge(&all, &sums[i]);
        all.count += sums[i].count;
        all.nonfinite += sums[i].nonfinite;
        qmc__sum_merge(all.f, sums[i].f);
        qmc__sum_merge(all.absf, sums[i].absf);
        qmc__sum_merge(all.g, sums[i].g);
        qmc__top_merge(all.top, sums[i].top);
    }
    const uint64_t finite = all.count - all.nonfinite;
    double beta = 0.0;
    if (job->g && all.m2_g > 0.0)
        beta = all.c_fg / all.m2_g;
    if (cv && job->g) {
        cv->used = 1;
        cv->beta = beta;
        double resid = all.m2_f - 2.0 * beta * all.c_fg + beta * beta * all.m2_g;
        cv->variance_ratio = all.m2_f > 0.0 ? resid / all.m2_f : 0.0;
    }

    /* Replicate estimates: mean of f - beta (g - E g) over the replicate's
     * finite points (g is stored already centred by its exact integral). */
    double est[2] = {0.0, 0.0};
    double rep_mean = 0.0, rep_m2 = 0.0;
    uint32_t reps_ok = 0;
    for (uint32_t r = 0; r < s->reps; r++) {
        double fsum[2] = {0.0, 0.0}, gsum[2] = {0.0, 0.0};
        uint64_t n_r = 0;
        for (uint64_t b = 0; b < job->blocks_per_rep; b++) {
            const qmc_sampling_sums *x = &sums[r * job->blocks_per_rep + b];
            qmc__sum_merge(fsum, x->f);
            qmc__sum_merge(gsum, x->g);
            n_r += x->count - x->nonfinite;
        }
        if (n_r == 0)
            continue;
        double m = (qmc__sum_value(fsum) - beta * qmc__sum_value(gsum)) / (double)n_r;
        /* Welford over replicate means, in replicate order. */
        reps_ok++;
        double delta = m - rep_mean;
        rep_mean += delta / reps_ok;
        rep_m2 += delta * (m - rep_mean);
        qmc__sum_add(est, m);
    }

    res->n = s->n;
    res->evals = all.count * (job->g ? 2 : 1);
    res->dims = job->dims;
    res->nonfinite = all.nonfinite;
    res->abs_integral = finite ? qmc__sum_value(all.absf) / (double)finite : 0.0;
    res->estimate = reps_ok ? qmc__sum_value(est) / reps_ok : NAN;

    if (s->sampler == QMC_SAMPLER_QMC) {
        res->error_kind = QMC_ERROR_NONE;
        res->error = 0.0;
        res->ci_low = res->ci_high = res->estimate;
    } else {
        double se, df;
        if (s->reps >= 2) {
            se = reps_ok >= 2 ? sqrt(rep_m2 / (reps_ok - 1) / reps_ok) : INFINITY;
            df = reps_ok >= 2 ? reps_ok - 1 : 1;
        } else {
            double resid = all.m2_f - 2.0 * beta * all.c_fg + beta * beta * all.m2_g;
            if (resid < 0.0)
                resid = 0.0; /* rounding of an exactly zero variance */
            /* A fitted control coefficient costs one more degree of
             * freedom (the regression's slope). */
            const uint64_t fitted = job->g ? 2 : 1;
            se = finite > fitted ? sqrt(resid / (double)(finite - fitted) / (double)finite)
                                 : INFINITY;
            df = finite > fitted ? (double)(finite - fitted) : 1;
        }
        double t = qmc_student_t_quantile(s->confidence, df);
        res->error_kind = QMC_ERROR_STDERR;
        res->error = se;
        res->ci_low = res->estimate - t * se;
        res->ci_high = res->estimate + t * se;
    }

    /* Diagnostics. */
    if (all.nonfinite)
        res->flags |= QMC_FLAG_NONFINITE | QMC_FLAG_ERROR_UNRELIABLE;
    /* Finite values whose sums overflowed (radiance near DBL_MAX): the
     * estimate or its spread is inf or NaN with no value to blame. */
    if (!isfinite(res->estimate) ||
        (res->error_kind == QMC_ERROR_STDERR && isnan(res->error)))
        res->flags |= QMC_FLAG_NONFINITE | QMC_FLAG_ERROR_UNRELIABLE;
    /* How well the sample variance is known: none for a replicated bar
     * (it rests on replicate means), from the pooled sample for
     * stratified (its blocks are slabs), else from the blocks. */
    double variance_rse = NAN;
    if (s->reps < 2)
        variance_rse = s->sampler == QMC_SAMPLER_STRATIFIED
                           ? qmc__pooled_variance_rse(all.top, finite, all.mean_f, all.m2_f)
                           : qmc__variance_rse(sums, nb);
    qmc__sampling_evidence(res, all.top, finite, s->sampler != QMC_SAMPLER_QMC,
                           job->f->smoothness >= QMC_SMOOTH_SINGULAR, variance_rse);
    /* A replicated bar on a declared singularity: a net puts one point in
     * each small stratum, so a replicate's error is dominated by its point
     * nearest the singularity, and the replicate means are skewed by a
     * tail that 16 of them rarely show.  log x (a light tail: Hill's test
     * is silent) by 16 Owen-scrambled Sobol replicates of 2^16 missed by
     * more than 3 bars in 7 of 100 seeds, unflagged; plain MC's bar over
     * all points missed in none (bench/scans/flag_need.py). */
    if (s->reps >= 2 && job->f->smoothness >= QMC_SMOOTH_SINGULAR &&
        res->error_kind == QMC_ERROR_STDERR)
        res->flags |= QMC_FLAG_ERROR_UNRELIABLE;
    if ((s->sampler == QMC_SAMPLER_QMC || s->sampler == QMC_SAMPLER_RQMC) &&
        is_base2_net(s->seq) && (s->n & (s->n - 1)) != 0)
        res->flags |= QMC_FLAG_NOT_POW2;
    if ((s->sampler == QMC_SAMPLER_QMC || s->sampler == QMC_SAMPLER_RQMC) &&
        (s->seq == QMC_SEQ_HALTON || s->seq == QMC_SEQ_HAMMERSLEY) &&
        s->scramble == QMC_SCRAMBLE_NONE && job->dims > QMC_SAMPLING_HALTON_GOOD_DIMS)
        res->flags |= QMC_FLAG_DIMS_PAST_GOOD;
    if (s->reps >= 2 && s->reps < QMC_SAMPLING_MIN_REPS)
        res->flags |= QMC_FLAG_FEW_REPS;
    if (reps_ok == 0 || (s->reps >= 2 && reps_ok < 2))
        res->flags |= QMC_FLAG_ERROR_UNRELIABLE;
    return 0;
}

int qmc__sampling_running(const qmc_sampling_job *job, const qmc_sampling_sums *sums,
                          uint64_t done, qmc_result *res)
{
    /* The same estimator on a job cut down to the work complete: a copy
     * of the job (finish reads only its spec, sizes and integrands) with
     * fewer replicates, or one replicate of fewer points. */
    qmc_sampling_job part = *job;
    const qmc_sampling_spec *s = &job->spec;
    const uint64_t bpr = job->blocks_per_rep;
    if (done >= qmc_sampling_blocks(job))
        return qmc_sampling_finish(job, sums, qmc_sampling_blocks(job), res, NULL) == 0;
    if (job->g)
        return 0;
    if (s->reps >= 2) {
        const uint64_t r = done / bpr;
        if (r < 2)
            return 0;
        part.spec.reps = (uint32_t)r;
        return qmc_sampling_finish(&part, sums, r * bpr, res, NULL) == 0;
    }
    const int finite_set = s->sampler == QMC_SAMPLER_STRATIFIED ||
                           s->sampler == QMC_SAMPLER_LHS ||
                           (s->sampler == QMC_SAMPLER_QMC && s->seq == QMC_SEQ_HAMMERSLEY);
    if (done == 0 || finite_set)
        return 0;
    part.blocks_per_rep = done;
    part.spec.n = done * QMC_SAMPLING_BLOCK; /* whole blocks: only the last is short */
    return qmc_sampling_finish(&part, sums, done, res, NULL) == 0;
}

/* The serial runner: every block here, one workspace; the hook (NULL:
 * none) is polled before each block. */
static int run_serial(const qmc_sampling_job *job, uint64_t first, uint64_t count,
                      qmc_sampling_sums *out, const qmc_interrupt *hook)
{
    size_t bytes = qmc_sampling_workspace_bytes(job);
    double *ws = malloc(bytes);
    if (!ws)
        return QMC_ENOMEM;
    int err = 0;
    for (uint64_t i = 0; i < count && !err; i++) {
        if (hook && hook->fn && hook->fn(hook->ctx))
            err = QMC_ECANCELED;
        else
            err = qmc_sampling_run_block(job, first + i, ws, bytes, &out[i]);
    }
    free(ws);
    return err;
}

int qmc__sampling_run_blocks(const qmc_sampling_job *job, qmc_block_runner runner,
                             void *ctx, uint64_t first, uint64_t count,
                             qmc_sampling_sums *out)
{
    return runner ? runner(ctx, job, first, count, out)
                  : run_serial(job, first, count, out, NULL);
}

int qmc__guard_run(void *guard, const qmc_sampling_job *job, uint64_t first, uint64_t count,
                   qmc_sampling_sums *out)
{
    const qmc__guard *g = guard;
    if (!g->runner)
        return run_serial(job, first, count, out, &g->hook);
    if (g->hook.fn && g->hook.fn(g->hook.ctx))
        return QMC_ECANCELED;
    return g->runner(g->runner_ctx, job, first, count, out);
}

int qmc_sampling_run(const qmc_sampling_job *job, qmc_block_runner runner, void *runner_ctx,
                     qmc_result *res, qmc_cv_report *cv)
{
    qmc_result_init(res);
    const uint64_t nb = qmc_sampling_blocks(job);
    qmc_sampling_sums *sums = calloc(nb, sizeof *sums);
    if (!sums)
        return QMC_ENOMEM;
    int err = qmc__sampling_run_blocks(job, runner, runner_ctx, 0, nb, sums);
    if (!err)
        err = qmc_sampling_finish(job, sums, nb, res, cv);
    free(sums);
    return err;
}
