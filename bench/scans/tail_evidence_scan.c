/*
 * tail_evidence_scan.c - heavy_tail before and after the block evidence
 * (docs/FLAGS.md, "Flags cut by better evidence"), on random narrow peaks.
 *
 * Draws RUNS peaks of FAMILY (genz-gaussian, genz-product-peak): d = 2..4,
 * a log-uniform (20..600 in 2D, 8..200 in 3D, 8..80 in 4D), u in
 * [0.1, 0.9], n = 2^16 or 2^18, seed i for run i.  Each run is judged as
 * `qmc stability` judges (within 3 bars plus 64 ulps of the exact value),
 * with error_unreliable from Hill's test alone ("before", the evidence
 * given no block statistic) and with the block evidence at threshold THR
 * (<= 0.25, the library's; "after").  Prints the counts, and each run that
 * lost a flag it needed.  A measuring tool: it must not be built into
 * anything, and it reads the library's private evidence functions.
 *
 * Build and run (from the tree, after make):
 *   cc -O2 -Iinclude -Icore bench/scans/tail_evidence_scan.c build/libqmc.a \
 *      -lm -lsodium -pthread -o /tmp/tail_evidence_scan
 *   /tmp/tail_evidence_scan RUNS SAMPLER FAMILY SEED THR
 * SAMPLER: 0 mc, 1 stratified (the largest k^d <= n strata; the pooled
 * statistic, qmc__pooled_variance_rse), 2 lhs, 4 rqmc (16 replicates of n / 16).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "sampling_impl.h"
#include "qmc/sampling.h"
#include "qmc/testfn.h"

#include "scan_rng.h"

/* the pooled statistic from all blocks, merged as the library does */
static double pooled_rse(const qmc_sampling_sums *sums, uint64_t nb, const double *top,
                         uint64_t n)
{
    qmc_sampling_sums all = {0};
    for (uint64_t b = 0; b < nb; b++) {
        qmc__moments_merge(&all, &sums[b]); /* reads the counts merged so far */
        all.count += sums[b].count;
        all.nonfinite += sums[b].nonfinite;
    }
    return qmc__pooled_variance_rse(top, n, all.mean_f, all.m2_f);
}

/* error_unreliable from the evidence alone, given the block statistic */
static int judged(const double *top, uint64_t n, double rse)
{
    qmc_result h;
    qmc_result_init(&h);
    h.estimate = 1.0;
    h.error = 1.0;
    qmc__sampling_evidence(&h, top, n, 1, 0, rse);
    return (h.flags & QMC_FLAG_ERROR_UNRELIABLE) != 0;
}

int main(int argc, char **argv)
{
    if (argc != 6) {
        fprintf(stderr, "usage: %s RUNS SAMPLER FAMILY SEED THR\n", argv[0]);
        return 2;
    }
    const int runs = atoi(argv[1]), sampler = atoi(argv[2]);
    const char *family = argv[3];
    state = strtoull(argv[4], NULL, 10);
    const double thr = atof(argv[5]);
    int correct = 0, wrong = 0, fa_before = 0, fa_after = 0, fw_before = 0, fw_after = 0;
    for (int r = 0; r < runs; r++) {
        const int d = 2 + (int)(u01() * 3);
        const double lo = log(d == 2 ? 20 : 8), hi = log(d == 2 ? 600 : d == 3 ? 200 : 80);
        double a[4], u[4];
        for (int j = 0; j < d; j++) {
            a[j] = exp(lo + (hi - lo) * u01());
            u[j] = 0.1 + 0.8 * u01();
        }
        uint64_t n = u01() < 0.5 ? 1u << 16 : 1u << 18;
        if (sampler == QMC_SAMPLER_STRATIFIED) { /* k^d strata: the largest k^d <= n */
            uint64_t k = (uint64_t)floor(pow((double)n, 1.0 / d) + 1e-9), p = 1;
            for (int j = 0; j < d; j++)
                p *= k;
            n = p;
        }
        qmc_testfn *fn;
        if (qmc_testfn_new(family, (uint32_t)d, a, (size_t)d, u, (size_t)d, &fn, NULL, 0))
            return 2;
        const qmc_integrand *f = qmc_testfn_integrand(fn);
        qmc_sampling_spec sp;
        qmc_sampling_spec_init(&sp, (qmc_sampler)sampler);
        sp.seed = (uint64_t)r + 1;
        sp.n = sampler == QMC_SAMPLER_RQMC ? n / 16 : n;
        qmc_sampling_job *job;
        if (qmc_sampling_job_new(&sp, f, NULL, &job, NULL, 0))
            return 3;
        const uint64_t nb = qmc_sampling_blocks(job);
        qmc_sampling_sums *sums = calloc(nb, sizeof *sums);
        const size_t wb = qmc_sampling_workspace_bytes(job);
        void *ws = malloc(wb);
        double top[QMC_SAMPLING_TOP] = {0};
        qmc_result res;
        if (!sums || !ws)
            return 4;
        for (uint64_t b = 0; b < nb; b++) {
            if (qmc_sampling_run_block(job, b, ws, wb, &sums[b]))
                return 4;
            qmc__top_merge(top, sums[b].top);
        }
        if (qmc_sampling_finish(job, sums, nb, &res, NULL))
            return 5;
        /* stratified's blocks are slabs: the pooled bound is its statistic */
        const double rse = sp.reps >= 2 ? NAN
                           : sampler == QMC_SAMPLER_STRATIFIED
                               ? pooled_rse(sums, nb, top, n)
                               : qmc__variance_rse(sums, nb);
        const int before = judged(top, n, NAN), after = judged(top, n, rse <= thr ? rse : NAN);
        const double miss = fabs(res.estimate - f->exact);
        if (miss <= 3 * res.error + 64 * 2.220446049250313e-16 * f->exact) {
            correct++;
            fa_before += before;
            fa_after += after;
        } else {
            wrong++;
            fw_before += before;
            fw_after += after;
            if (before && !after)
                printf("  lost: d %d a1 %.4g n %llu, %.2f bars off, rse %.3f\n", d, a[0],
                       (unsigned long long)n, miss / res.error, rse);
        }
        free(sums);
        free(ws);
        qmc_sampling_job_free(job);
        qmc_testfn_free(fn);
    }
    printf("%s sampler %d, %d runs: %d correct, %d wrong; error_unreliable on correct "
           "%d -> %d, on wrong %d -> %d; silent %d -> %d\n",
           family, sampler, runs, correct, wrong, fa_before, fa_after, fw_before, fw_after,
           wrong - fw_before, wrong - fw_after);
    return 0;
}
