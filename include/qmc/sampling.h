/*
 * qmc/sampling.h - sampling integrators: Monte Carlo, stratified, Latin
 * hypercube, quasi-Monte Carlo and randomized QMC, with control variates,
 * honest error bars and diagnostics.
 *
 * Determinism by construction: a job's index range is cut into fixed
 * blocks (replicate-major, QMC_SAMPLING_BLOCK points each).  Any caller -
 * one thread, a pool, or machines each running a --part of the blocks -
 * computes block sums independently; qmc_sampling_finish combines them in
 * block order with compensated (Neumaier) sums.  The result is therefore
 * bit-identical for any thread count or partition.  Core runs no threads:
 * the daemon and the CLI own them.
 */
#ifndef QMC_SAMPLING_H
#define QMC_SAMPLING_H

#include <stddef.h>
#include <stdint.h>

#include "qmc/error.h"
#include "qmc/integrand.h"
#include "qmc/result.h"
#include "qmc/seq.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Samplers: X(enum suffix, CLI name). */
#define QMC_SAMPLER_MAP(X)          \
    X(MC, "mc")                     \
    X(STRATIFIED, "stratified")     \
    X(LHS, "lhs")                   \
    X(QMC, "qmc")                   \
    X(RQMC, "rqmc")

typedef enum qmc_sampler {
#define QMC__SAMPLER_ENUM(name, text) QMC_SAMPLER_##name,
    QMC_SAMPLER_MAP(QMC__SAMPLER_ENUM)
#undef QMC__SAMPLER_ENUM
} qmc_sampler;

enum {
    QMC_SAMPLING_BLOCK = 4096, /* points per block */
    QMC_SAMPLING_TOP = 64      /* largest |f| kept per block (tail check) */
};

/* Below this many nonzero values a bar is flagged QMC_FLAG_FEW_NONZERO (and
 * the tail test, which needs one more, QMC_FLAG_TAIL_UNTESTED): with 8 the
 * relative spread of a count is about 1/sqrt(8), and below it one point
 * more or less moves the estimate past its own bar. */
#define QMC_SAMPLING_MIN_NONZERO 8
/* Below this many replicates an RQMC interval is flagged QMC_FLAG_FEW_REPS. */
#define QMC_SAMPLING_MIN_REPS 8u
/* Each replicate keeps its own sequence tables (about 264 bytes a
 * dimension for Sobol), so replicates times dimensions is capped; and so
 * is a job's block count (one sums record of about 600 bytes each). */
#define QMC_SAMPLING_MAX_REPS 4096u
#define QMC_SAMPLING_MAX_REP_DIMS (1u << 22)
#define QMC_SAMPLING_MAX_BLOCKS (1u << 20)
/* Unscrambled Halton/Hammersley beyond this many dimensions is flagged
 * QMC_FLAG_DIMS_PAST_GOOD: radical inverses in nearby large prime bases are
 * strongly correlated for the first base^2 points (Morokoff & Caflisch 1994;
 * Braaten & Weller 1979). */
#define QMC_SAMPLING_HALTON_GOOD_DIMS 10u

typedef struct qmc_sampling_spec {
    qmc_sampler sampler;
    qmc_seq_kind seq;        /* qmc, rqmc: the sequence (sobol by default) */
    qmc_scramble scramble;   /* rqmc: owen, fast-owen or shift (sobol), owen
                                or faure (halton); qmc: none or a fixed
                                scramble */
    uint32_t seq_flags;      /* QMC_SEQ_SHUFFLE */
    uint64_t seed;
    uint64_t n;              /* points per replicate, >= 1 */
    uint32_t reps;           /* independent replicates R; rqmc needs >= 2 */
    double confidence;       /* two-sided interval level in (0, 1) */
    /* rqmc over an infinite sequence: 0 (default) gives each replicate its
     * own scramble.  1 splits one scrambled sequence instead: replicate r
     * is its points [r n, (r+1) n), so the estimate is that of one net of
     * R n points.  Where a net's error falls only like 1/N (integrands
     * with jumps) independent replicates cost sqrt(R) in accuracy; split,
     * the blocks' spread overstates the error by about that much instead
     * (the blocks of one net are negatively correlated: a conservative
     * bar, which the coverage tests check, not an exact one). */
    int split_net;
} qmc_sampling_spec;

/* Spec defaults: sobol, owen for rqmc, n = 4096, reps 1 (rqmc 16),
 * confidence 0.95. */
void qmc_sampling_spec_init(qmc_sampling_spec *spec, qmc_sampler sampler);

/*
 * Per-block sums.  A plain value: the CLI writes them exactly (hex floats)
 * for --part, and qmc merge reads them back.  Each sum is kept as a
 * Neumaier pair (value, compensation).
 */
typedef struct qmc_sampling_sums {
    uint64_t block;          /* block index within the job */
    uint64_t count;          /* points evaluated */
    uint64_t nonfinite;      /* of which non-finite (left out of all sums) */
    double f[2], absf[2], g[2];   /* Neumaier sums of f, |f|, g */
    /* Moments of the finite points (per chunk two-pass, merged in index
     * order and across blocks with Chan's update): stable where
     * sum f^2 - (sum f)^2 / n cancels. */
    double mean_f, mean_g, m2_f, m2_g, c_fg;
    double top[QMC_SAMPLING_TOP];  /* largest |f|, descending, 0-padded */
} qmc_sampling_sums;

typedef struct qmc_sampling_job qmc_sampling_job;

/*
 * Creates a job integrating f (and, when control is not NULL, using it as a
 * control variate with its known integral: control->has_exact must be set
 * and control->dims must equal f->dims).  Both integrands must outlive the
 * job.  Errors: QMC_EINVAL (with a reason), QMC_EDIMS, QMC_ESCRAMBLE,
 * QMC_ECOUNT (e.g. stratified n not k^d), QMC_ENOMEM.
 */
QMC_MUST_CHECK int qmc_sampling_job_new(const qmc_sampling_spec *spec,
                                        const qmc_integrand *f,
                                        const qmc_integrand *control,
                                        qmc_sampling_job **out, char *why,
                                        size_t why_bytes);
void qmc_sampling_job_free(qmc_sampling_job *job);

/* Number of blocks: reps * ceil(n / QMC_SAMPLING_BLOCK). */
uint64_t qmc_sampling_blocks(const qmc_sampling_job *job);

/* Bytes of workspace one qmc_sampling_run_block call needs; each
 * concurrent caller needs its own. */
size_t qmc_sampling_workspace_bytes(const qmc_sampling_job *job);

/* A fingerprint of the job: its spec, the integrand's name, dims and exact
 * value, and the integrand's (and control's) values at a few fixed points
 * - which stand in for parameters this layer cannot see (Genz a and u, a
 * scene's geometry) - so partial results of different jobs are not
 * merged.  Evaluates each integrand at 4 points. */
uint64_t qmc_sampling_fingerprint(const qmc_sampling_job *job);

/*
 * Computes block `block` into *out.  Safe to call concurrently for
 * different blocks with different workspaces.  Errors: QMC_ERANGE (block),
 * QMC_EINVAL (workspace too small).
 */
QMC_MUST_CHECK int qmc_sampling_run_block(const qmc_sampling_job *job,
                                          uint64_t block, void *workspace,
                                          size_t workspace_bytes,
                                          qmc_sampling_sums *out);

/* What the control variate did. */
typedef struct qmc_cv_report {
    int used;
    double beta;             /* regression coefficient Cov(f,g)/Var(g) */
    double variance_ratio;   /* Var(f - beta g) / Var(f), pooled points */
} qmc_cv_report;

/*
 * Combines all blocks (sums[i].block == i, every block present) into *res
 * and, when cv is not NULL, *cv.  Flags: nonfinite (also when finite
 * values overflow the sums), heavy_tail, not_pow2, dims_past_good,
 * few_reps, few_nonzero, zero_spread, tail_untested, error_unreliable.  Errors: QMC_EINVAL (missing
 * or misordered blocks); *res is still initialised.
 */
QMC_MUST_CHECK int qmc_sampling_finish(const qmc_sampling_job *job,
                                       const qmc_sampling_sums *sums,
                                       uint64_t count, qmc_result *res,
                                       qmc_cv_report *cv);

/*
 * How callers run blocks: compute blocks [first, first + count) into
 * out[0 .. count).  The CLI and daemon pass a thread pool; NULL means
 * "one thread, here".  Returns 0 or a QMC_E* code.
 */
typedef int (*qmc_block_runner)(void *ctx, const qmc_sampling_job *job,
                                uint64_t first, uint64_t count,
                                qmc_sampling_sums *out);

/* Runs every block with runner (or serially) and finishes. */
QMC_MUST_CHECK int qmc_sampling_run(const qmc_sampling_job *job,
                                    qmc_block_runner runner, void *runner_ctx,
                                    qmc_result *res, qmc_cv_report *cv);

/*
 * Adaptive stopping: starting from spec->n points per replicate, doubles n
 * until the confidence interval's half-width is <= max(tol_abs,
 * tol_rel * |estimate|) or the next round would exceed max_evals.  Sums of
 * blocks already computed are reused when n grows (same indices, same
 * numbers).  Raises QMC_FLAG_BUDGET and QMC_FLAG_NOT_CONVERGED when the
 * budget runs out first; *final_n is the n of the reported result.
 */
QMC_MUST_CHECK int qmc_sampling_adaptive(const qmc_sampling_spec *spec,
                                         const qmc_integrand *f,
                                         const qmc_integrand *control,
                                         double tol_abs, double tol_rel,
                                         uint64_t max_evals,
                                         qmc_block_runner runner,
                                         void *runner_ctx, qmc_result *res,
                                         qmc_cv_report *cv, uint64_t *final_n,
                                         char *why, size_t why_bytes);

/* Two-sided Student-t quantile: t such that P(|T_df| <= t) = level. */
double qmc_student_t_quantile(double level, double df);

const char *qmc_sampler_name(qmc_sampler s);
QMC_MUST_CHECK int qmc_sampler_parse(const char *name, qmc_sampler *out);

#ifdef __cplusplus
}
#endif
#endif /* QMC_SAMPLING_H */
