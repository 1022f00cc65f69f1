/*
 * qmc/integrand.h - the integrand interface every integrator takes.
 *
 * An integrand is a pure function on the unit cube [0,1)^dims, evaluated
 * in batches so that call overhead does not dominate cheap integrands.  It
 * may be called from several threads at once: eval must not write to ctx.
 */
#ifndef QMC_INTEGRAND_H
#define QMC_INTEGRAND_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

struct qmc_result; /* qmc/result.h */

/* What an integrand declares about itself, for `auto` and diagnostics. */
typedef enum qmc_smoothness {
    QMC_SMOOTH_ANALYTIC = 0,       /* smooth everywhere (Genz oscillatory...) */
    QMC_SMOOTH_CONTINUOUS = 1,     /* continuous, kinks (Genz continuous) */
    QMC_SMOOTH_DISCONTINUOUS = 2,  /* jumps (Genz discontinuous, a step) */
    QMC_SMOOTH_SINGULAR = 3        /* unbounded somewhere (x^-1/2, log x) */
} qmc_smoothness;

typedef struct qmc_integrand {
    /* Writes f(x_i) to out[i] for the n points x (row-major, n x dims, each
     * coordinate in [0,1)).  Non-finite values are allowed: integrators
     * count and flag them. */
    void (*eval)(const void *ctx, const double *x, size_t n, uint32_t dims,
                 double *out);
    const void *ctx;           /* owned by whoever made the integrand */
    uint32_t dims;
    qmc_smoothness smoothness;
    int has_exact;             /* 1 when exact holds the true integral */
    double exact;
    int has_abs_integral;      /* 1 when abs_integral holds int |f| */
    double abs_integral;
    const char *name;          /* static string, e.g. "genz-gaussian" */
    /* Optional (NULL: none): flags from evidence only the integrand can
     * gather, given its finished result - a scene's MIS techniques, whose
     * separate shares the one sum hides.  qmc_integrate calls it once per
     * successful run with the result it returns; it must be
     * deterministic (the same result gives the same flags) and cheap. */
    uint32_t (*audit)(const void *ctx, const struct qmc_result *res);
    /* Optional (NULL, 0: not known), for 1-dimensional integrands only:
     * where in (0,1) the kinks and jumps that the smoothness declares lie -
     * every one of them, strictly ascending, at most
     * QMC_INTEGRAND_MAX_BREAKS.  Between two breaks the integrand is as
     * smooth as an analytic one.  Gauss-Kronrod starts from these as
     * interval ends, so that no rule straddles a jump (the step at 1 - 1e-9
     * sat in the gap beyond its last node); `auto` then prefers it for a
     * 1D integrand with jumps.  The test functions set them (step,
     * genz-continuous and genz-discontinuous in 1D). */
    const double *breaks;
    uint32_t n_breaks;
} qmc_integrand;

#define QMC_INTEGRAND_MAX_BREAKS 64u

/*
 * Cooperative cancellation: an optional hook the caller hands to an
 * integrator (qmc_integrate_spec, the quadrature and cubature options).
 * The integrator calls fn(ctx) before it starts evaluating and then
 * whenever QMC_INTERRUPT_EVALS evaluations have passed since the last
 * call, at the next point where it can stop cleanly: after the current
 * batch of at most a few hundred points (quadrature, cubature), before
 * the next block of QMC_SAMPLING_BLOCK points (sampling methods run
 * serially), or, while a tensor rule computes Gauss-Legendre nodes, after
 * max(QMC_INTERRUPT_EVALS, n) steps of the Legendre recurrence.  When fn
 * returns non-zero the integrator stops and returns QMC_ECANCELED, with no
 * estimate in its result.  fn NULL (a zeroed struct) means never.  The
 * hook only decides whether to go on: with one that never fires, the
 * results are bit for bit those without it.  fn runs on the integrator's
 * thread, must be cheap and thread-safe as its ctx requires, and must not
 * call back into the integrator.  Core keeps no clock: a deadline is the
 * hook's to check.
 */
typedef struct qmc_interrupt {
    int (*fn)(void *ctx);
    void *ctx;
} qmc_interrupt;

/* Evaluations between two calls of the hook (the sampling engine's block
 * size, so every method answers a cancel after comparable work). */
#define QMC_INTERRUPT_EVALS 4096u

#ifdef __cplusplus
}
#endif
#endif /* QMC_INTEGRAND_H */
