/*
 * sampling_adaptive.c - adaptive stopping: double n until the confidence
 * interval is narrow enough or the evaluation budget runs out.
 *
 * For mc, qmc and rqmc over infinite sequences the points of a round are a
 * prefix of the next round's (same sequences, same seeds), so when the old
 * n filled whole blocks, those blocks' sums are reused as they are: the
 * answer equals a fixed-n run at the final n, bit for bit.  (A split net's
 * old round is the first half of the new one's replicates.)  Finite sets
 * (stratified, lhs, hammersley) change with n, so each round starts afresh
 * (and stratified grows to the next k^d).
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "msg.h"
#include "sampling_impl.h"

/* Flags that say the round's bar rests on no evidence (qmc/result.h). */
#define CANNOT_TELL (QMC_FLAG_FEW_NONZERO | QMC_FLAG_ZERO_SPREAD | QMC_FLAG_TAIL_UNTESTED)

/* The next n: double it; stratified needs the next k^d at or above. */
static uint64_t next_n(const qmc_sampling_spec *s, uint32_t dims)
{
    uint64_t want = 2 * s->n;
    if (s->sampler != QMC_SAMPLER_STRATIFIED)
        return want;
    for (uint64_t k = 2;; k++) {
        uint64_t p = 1;
        for (uint32_t j = 0; j < dims && p <= want; j++)
            p *= k;
        if (p >= want)
            return p;
    }
}

/* Whether a round's points are a prefix of the next round's: not for the
 * finite sets (stratified, lhs, hammersley), which change with n. */
static int extendable(const qmc_sampling_spec *s)
{
    if (s->sampler == QMC_SAMPLER_MC)
        return 1;
    return (s->sampler == QMC_SAMPLER_QMC || s->sampler == QMC_SAMPLER_RQMC) &&
           s->seq != QMC_SEQ_HAMMERSLEY;
}

/* How many leading blocks of replicate r (bpr blocks of s->n points) the
 * last round (n_old points a replicate, whole blocks) computed already.
 * Independent replicates extend their own sequences: all of the old
 * blocks.  A split net's round covers indices [0, R n_old) of the one
 * sequence, which the longer replicates now cut differently. */
static uint64_t reused_blocks(const qmc_sampling_spec *s, uint32_t r, uint64_t n_old,
                              uint64_t bpr)
{
    if (!s->split_net)
        return n_old / QMC_SAMPLING_BLOCK;
    const uint64_t done = (uint64_t)s->reps * n_old, start = (uint64_t)r * s->n;
    if (done <= start)
        return 0;
    uint64_t b = (done - start) / QMC_SAMPLING_BLOCK;
    return b < bpr ? b : bpr;
}

/* The last round's index of the block that is block b of replicate r now. */
static uint64_t old_block(const qmc_sampling_spec *s, uint32_t r, uint64_t b, uint64_t n_old,
                          uint64_t bpr_old)
{
    if (!s->split_net)
        return r * bpr_old + b;
    const uint64_t at = (uint64_t)r * s->n + b * QMC_SAMPLING_BLOCK;
    return at / n_old * bpr_old + at % n_old / QMC_SAMPLING_BLOCK;
}

int qmc_sampling_adaptive(const qmc_sampling_spec *spec, const qmc_integrand *f,
                          const qmc_integrand *control, double tol_abs, double tol_rel,
                          uint64_t max_evals, qmc_block_runner runner, void *runner_ctx,
                          qmc_result *res, qmc_cv_report *cv, uint64_t *final_n,
                          char *why, size_t why_bytes)
{
    qmc__msg m;
    qmc__msg_init(&m, why, why_bytes);
    qmc_result_init(res);
    *final_n = 0;
    if (spec->sampler == QMC_SAMPLER_QMC) {
        qmc__msg_str(&m, "adaptive stopping needs an error bar, which qmc does not have: use rqmc");
        return QMC_EINVAL;
    }
    if (!(tol_abs >= 0.0) || !(tol_rel >= 0.0) || (tol_abs == 0.0 && tol_rel == 0.0)) {
        qmc__msg_str(&m, "give a positive --tol-abs or --tol-rel");
        return QMC_EINVAL;
    }
    const uint64_t per_point = control ? 2 : 1;
    qmc_sampling_spec s = *spec;
    if (s.n * s.reps * per_point > max_evals) {
        qmc__msg_set(&m, "the first round alone needs ", s.n * s.reps * per_point,
                     " evaluations, over the budget of ");
        qmc__msg_u64(&m, max_evals);
        return QMC_EBUDGET;
    }
    qmc_sampling_sums *prev = NULL;
    uint64_t prev_bpr = 0, prev_n = 0, evals = 0;
    int err = 0;
    for (;;) {
        qmc_sampling_job *job = NULL;
        err = qmc_sampling_job_new(&s, f, control, &job, why, why_bytes);
        if (err)
            break;
        const uint64_t nb = qmc_sampling_blocks(job), bpr = job->blocks_per_rep;
        qmc_sampling_sums *sums = calloc(nb, sizeof *sums);
        if (!sums) {
            qmc_sampling_job_free(job);
            err = QMC_ENOMEM;
            break;
        }
        const int reuse = prev && extendable(&s) && prev_n % QMC_SAMPLING_BLOCK == 0;
        for (uint32_t r = 0; r < s.reps && !err; r++) {
            uint64_t have = reuse ? reused_blocks(&s, r, prev_n, bpr) : 0;
            for (uint64_t b = 0; b < have; b++) {
                sums[r * bpr + b] = prev[old_block(&s, r, b, prev_n, prev_bpr)];
                sums[r * bpr + b].block = r * bpr + b;
            }
            err = qmc__sampling_run_blocks(job, runner, runner_ctx, r * bpr + have, bpr - have,
                                           sums + r * bpr + have);
            for (uint64_t b = have; b < bpr && !err; b++)
                evals += sums[r * bpr + b].count * per_point;
        }
        if (!err)
            err = qmc_sampling_finish(job, sums, nb, res, cv);
        qmc_sampling_job_free(job);
        free(prev);
        prev = sums;
        prev_bpr = bpr;
        prev_n = s.n;
        if (err)
            break;
        *final_n = s.n;
        res->evals = evals;
        double half = res->ci_high - res->estimate;
        double target = fmax(tol_abs, tol_rel * fabs(res->estimate));
        /* A round whose bar cannot see its failure (no nonzero values, a
         * spread of exactly 0, a tail too thin to test) meets no
         * tolerance: 0 +- 0 <= tol * |0| is no evidence, so n grows until
         * the points find the mass or the budget ends (and the flags stay).
         * An estimate the sums overflowed will not improve with n. */
        if (!isfinite(res->estimate))
            break;
        if (half <= target && !(res->flags & CANNOT_TELL))
            break;
        uint64_t n2 = next_n(&s, f->dims);
        uint64_t cost = (extendable(&s) && s.n % QMC_SAMPLING_BLOCK == 0 ? n2 - s.n : n2) *
                        s.reps * per_point;
        if (n2 > QMC_SEQ_MAX_INDEX || evals + cost > max_evals) {
            res->flags |= QMC_FLAG_BUDGET | QMC_FLAG_NOT_CONVERGED;
            break;
        }
        s.n = n2;
    }
    free(prev);
    if (err) { /* no earlier round's estimate passed off as the answer */
        qmc_result_init(res);
        res->evals = evals;
    }
    return err;
}
