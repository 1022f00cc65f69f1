/*
 * sampling_impl.h - the sampling job shared by sampling*.c (private).
 */
#ifndef QMC_SAMPLING_IMPL_H
#define QMC_SAMPLING_IMPL_H

#include "qmc/sampling.h"

struct qmc_sampling_job {
    qmc_sampling_spec spec;
    const qmc_integrand *f;
    const qmc_integrand *g;      /* control variate, or NULL */
    uint32_t dims;
    uint64_t blocks_per_rep;
    uint32_t chunk;              /* points per integrand call */
    qmc_seq **seqs;              /* one per replicate */
};

/* Points per integrand call of a job on dims dimensions (job->chunk), and
 * the block workspace of such a job: what qmc_sampling_workspace_bytes
 * returns, before the job exists (a session's memory bound). */
uint32_t qmc__sampling_chunk(uint32_t dims);
size_t qmc__sampling_workspace_bytes_for(uint32_t dims);

/* What qmc_sampling_job_new allocates for spec on dims, besides the block
 * sums the caller brings: the job and its replicates' sequences. */
uint64_t qmc__sampling_job_bytes(const qmc_sampling_spec *spec, uint32_t dims);

/* The points of block `block` (at most QMC_SAMPLING_BLOCK; the last block
 * of a replicate holds what is left of n). */
uint64_t qmc__sampling_block_points(const qmc_sampling_job *job, uint64_t block);

/* Calls the integrands on block `block`'s points exactly as
 * qmc_sampling_run_block does - same chunks, same order - but sums
 * nothing: a session's collect pass (session_run.c), which only needs the
 * points.  Errors as qmc_sampling_run_block. */
int qmc__sampling_eval_block(const qmc_sampling_job *job, uint64_t block, void *workspace,
                             size_t workspace_bytes);

/* The points block_pass hands f for block `block` (its
 * qmc__sampling_block_points of them, row-major), written at dst in one
 * fill: a session's collect pass when f is its own (session_run.c).
 * QMC_ERANGE for a block past the job's, or the sequence's error. */
int qmc__sampling_block_fill(const qmc_sampling_job *job, uint64_t block, double *dst);

/* Block `block`'s sums from f's values at its points, given in order
 * (values[0 .. block points)): the bytes qmc_sampling_run_block gives
 * when f returns those values, without making a point or calling f - a
 * session's replay.  QMC_EINVAL for a job with a control variate (its g
 * values are not given); else as qmc_sampling_run_block. */
int qmc__sampling_sum_block(const qmc_sampling_job *job, uint64_t block, const double *values,
                            void *workspace, size_t workspace_bytes, qmc_sampling_sums *out);

/*
 * The estimate from the first `done` blocks of a job still running
 * (sums[i].block == i): the job's own estimator on the work complete so
 * far.  With reps >= 2, the replicates complete (from 2 on); with one
 * replicate of mc or an infinite qmc sequence, the points so far; none
 * for a prefix of a finite set (stratified, lhs, hammersley), which is
 * not such a set.  Returns 1 with *res filled, or 0 when there is none
 * yet.  No control variate (the estimate is the plain mean).
 */
int qmc__sampling_running(const qmc_sampling_job *job, const qmc_sampling_sums *sums,
                          uint64_t done, qmc_result *res);

/* Welford/Chan combination of moments: b into a (see qmc_sampling_sums). */
void qmc__moments_merge(qmc_sampling_sums *a, const qmc_sampling_sums *b);

/* Runs blocks [first, first + count) with runner, or serially when NULL.
 * Its callers (qmc_sampling_run, qmc_sampling_adaptive) keep one promise
 * a session's runner relies on for its running estimate (session_run.c):
 * out is &sums[first] of the job's whole array of block sums, and
 * sums[0 .. first) are complete when it is called. */
int qmc__sampling_run_blocks(const qmc_sampling_job *job, qmc_block_runner runner,
                             void *ctx, uint64_t first, uint64_t count,
                             qmc_sampling_sums *out);

/* Keeps the QMC_SAMPLING_TOP largest of a's and b's top values in a. */
void qmc__top_merge(double *a, const double *b);

/*
 * The relative standard error of the pooled within-block variance of f,
 * from how much the blocks' own variances v_b (m2_f / points) disagree:
 * for independent points Var(v_b) = (mu4 - sigma^4) / m_b to first order,
 * so kurt - 1 = sum m_b (v_b - v)^2 / (B v^2), and the pooled variance's
 * relative standard error is sqrt((kurt - 1) / N).  For a spike hit H
 * times in all, kurt ~ N / H and the result ~ 1 / sqrt(H): it counts the
 * values that carry the variance.  NAN when fewer than
 * QMC__RSE_MIN_BLOCKS blocks hold two finite points or the variance is 0
 * or not finite.  Blocks of a net (lhs, a scrambled net's replicate) are
 * less random than independent points, so their variances agree better
 * and the result is smaller: it is used only to clear a bounded integrand
 * of Hill's flag, where the net's estimate is as much better.  A
 * stratified sample's blocks are slabs of the cube, not exchangeable at
 * all: it takes qmc__pooled_variance_rse instead.
 */
#define QMC__RSE_MIN_BLOCKS 16u
#define QMC__RSE_BOUNDED 0.25
double qmc__variance_rse(const qmc_sampling_sums *sums, uint64_t count);

/* The same from the pooled sample (mean and central sum of squares m2 of
 * `finite` points, their top values), for samplers whose blocks are not
 * exchangeable (stratified): an upper bound, from the largest values, on
 * what the sample's own fourth moment would give (sampling_finish.c). */
double qmc__pooled_variance_rse(const double *top, uint64_t finite, double mean, double m2);

/* The evidence flags of a finished sampling result (sampling_finish.c):
 * heavy_tail from the pooled top values of `finite` finite points (for an
 * integrand that declares no singularity, only while variance_rse, from
 * qmc__variance_rse or for stratified samples qmc__pooled_variance_rse,
 * is above QMC__RSE_BOUNDED or NAN - NAN for a replicated bar - or the
 * top values follow a power law), and the "cannot
 * tell" flags - few_nonzero, tail_untested, zero_spread and an infinite
 * bar - which mark a bar resting on evidence that cannot see the failure;
 * has_bar is 0 for plain qmc, which claims no bar; singular is whether
 * the integrand declares a singularity (the stronger tail test). */
void qmc__sampling_evidence(qmc_result *res, const double *top, uint64_t finite, int has_bar,
                            int singular, double variance_rse);

#endif
