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

/* Welford/Chan combination of moments: b into a (see qmc_sampling_sums). */
void qmc__moments_merge(qmc_sampling_sums *a, const qmc_sampling_sums *b);

/* Runs blocks [first, first + count) with runner, or serially when NULL. */
int qmc__sampling_run_blocks(const qmc_sampling_job *job, qmc_block_runner runner,
                             void *ctx, uint64_t first, uint64_t count,
                             qmc_sampling_sums *out);

/* Keeps the QMC_SAMPLING_TOP largest of a's and b's top values in a. */
void qmc__top_merge(double *a, const double *b);

/* The evidence flags of a finished sampling result (sampling_finish.c):
 * heavy_tail from the pooled top values of `finite` finite points, and
 * the "cannot tell" flags - few_nonzero, tail_untested, zero_spread and an
 * infinite bar - which mark a bar resting on evidence that cannot see the
 * failure; has_bar is 0 for plain qmc, which claims no bar; singular is
 * whether the integrand declares a singularity (the stronger tail test). */
void qmc__sampling_evidence(qmc_result *res, const double *top, uint64_t finite, int has_bar,
                            int singular);

#endif
