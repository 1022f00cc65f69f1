/*
 * qmc/integrate.h - one entry point for every integration method, and the
 * `auto` choice: what `qmc integrate` runs in-process and what the daemon
 * runs for an INTEGRATE request.
 *
 * Threads stay outside: sampling methods run their blocks through the
 * caller's qmc_block_runner (NULL: serially, here).  Cancellation is
 * cooperative, through the spec's interrupt hook (qmc/integrand.h).
 */
#ifndef QMC_INTEGRATE_H
#define QMC_INTEGRATE_H

#include <stddef.h>
#include <stdint.h>

#include "qmc/integrand.h"
#include "qmc/result.h"
#include "qmc/sampling.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Methods: X(enum suffix, name). */
#define QMC_METHOD_MAP(X)                  \
    X(AUTO, "auto")                        \
    X(MC, "mc")                            \
    X(STRATIFIED, "stratified")            \
    X(LHS, "lhs")                          \
    X(QMC, "qmc")                          \
    X(RQMC, "rqmc")                        \
    X(MIDPOINT, "midpoint")                \
    X(TRAPEZOID, "trapezoid")              \
    X(SIMPSON, "simpson")                  \
    X(GAUSS_LEGENDRE, "gauss-legendre")    \
    X(GAUSS_KRONROD, "gauss-kronrod")      \
    X(CUBATURE, "cubature")                \
    X(CLENSHAW_CURTIS, "clenshaw-curtis")

typedef enum qmc_method {
#define QMC__METHOD_ENUM(name, text) QMC_METHOD_##name,
    QMC_METHOD_MAP(QMC__METHOD_ENUM)
#undef QMC__METHOD_ENUM
} qmc_method;

/* auto uses Gauss-Kronrod for smooth 1D integrands (and 1D ones declaring
 * where their jumps are, or a singularity); the tensor Clenshaw-Curtis
 * rule for analytic ones when the budget buys 17 points an axis; adaptive
 * cubature up to this many dimensions for integrands declared analytic
 * once the budget buys one region (4 dimensions and 50 regions for
 * continuous ones); RQMC otherwise (core/auto_choice.c).  A rule that
 * leaves half the budget or more with its bar unresolved, or in doubt
 * after every check off its nodes (a declared kink or jump), is followed
 * by RQMC with the rest, which vouches for the rule's bar or replaces its
 * answer (docs/FLAGS.md, issue 23 round seven); the reason says which. */
#define QMC_AUTO_CUBATURE_MAX_DIMS 10u

/* A deterministic rule's bar on a 1D integrand that declares where its
 * kinks and jumps are (qmc_integrand.breaks) is confirmed by Gauss-Kronrod
 * from those breaks, in at most this many evaluations of the budget the
 * rule leaves; unconfirmed, it carries QMC_FLAG_ERROR_UNRELIABLE
 * (docs/FLAGS.md).  A caller that fits a 1D rule to a budget leaves room. */
#define QMC_INTEGRATE_CONFIRM_EVALS 2048u

/* A deterministic rule's bar that still carries QMC_FLAG_ERROR_UNRELIABLE
 * after that (a kink or jump nothing confirmed, an unresolved rule, no
 * coarse level) is checked by an RQMC pilot of this many Owen-scrambled
 * Sobol replicates, run on what the rule left of the budget: at most the
 * larger of QMC_INTEGRATE_CONFIRM_EVALS and an eighth of the rule's
 * evaluations (never more than 2^20), at least 16 points a replicate.  The flag is cleared when
 * the pilot, flagless itself, puts the truth within two bars of the rule's
 * estimate (docs/FLAGS.md); `unresolved` stays.  A declared singularity is
 * never confirmed. */
#define QMC_INTEGRATE_PILOT_REPS 16u

typedef struct qmc_integrate_spec {
    qmc_method method;
    qmc_sampling_spec sampling;  /* sampling methods (n, reps, seq, ...) */
    int n_given;                 /* 0: method defaults for n (and stratified k^d) */
    uint32_t n_axis;             /* tensor rules: points per axis (0: 16) */
    double tol_abs, tol_rel;     /* 0, 0: fixed n (sampling), defaults
                                    elsewhere; auto always stops adaptively */
    uint64_t max_evals;          /* evaluation budget */
    uint64_t max_memory;         /* bytes for cubature regions */
    /* Optional, in-process only (never sent over the wire): polled about
     * every QMC_INTERRUPT_EVALS evaluations by every method; when it fires
     * qmc_integrate returns QMC_ECANCELED.  Sampling methods poll it
     * before every block when they run serially (runner NULL); with a
     * runner, before each batch of blocks they hand it, so a runner that
     * takes large batches checks its own cancellation between blocks (as
     * the daemon's does). */
    qmc_interrupt interrupt;
} qmc_integrate_spec;

/* Defaults: auto, n 4096 (sampling), 16 per axis, no tolerance, budget
 * 1e8 evaluations, 64 MiB of cubature regions, no interrupt hook. */
void qmc_integrate_spec_init(qmc_integrate_spec *spec);

/* Room for auto's reason, terminator included (the wire allows 1024 bytes;
 * a fallback from a rule to rqmc, with a VEGAS pilot, needs about 400). */
#define QMC_AUTO_REASON_BYTES 512

typedef struct qmc_integrate_report {
    qmc_result res;
    qmc_cv_report cv;
    qmc_method method_used;      /* auto's choice, else method */
    qmc_sampling_spec sampling;  /* sampling methods: the spec run (final n) */
    char detail[160];            /* "sobol owen, 16 x 4096 points" */
    char auto_reason[QMC_AUTO_REASON_BYTES]; /* why auto chose method_used; "" else */
} qmc_integrate_report;

/*
 * Integrates f (with control variate g, sampling methods only) as spec
 * says.  Fills *rep on every return path.  Errors (with a one-line reason
 * in why): QMC_EINVAL, QMC_EDIMS, QMC_ECOUNT, QMC_ESCRAMBLE, QMC_EBUDGET
 * (a request whose cost exceeds max_evals is refused before evaluating),
 * QMC_ENOMEM, QMC_ECANCELED (spec->interrupt fired: rep->res holds no
 * estimate).  A runner's own error (e.g. the daemon's -ECANCELED) is
 * passed on as it is.
 */
QMC_MUST_CHECK int qmc_integrate(const qmc_integrate_spec *spec,
                                 const qmc_integrand *f,
                                 const qmc_integrand *g,
                                 qmc_block_runner runner, void *runner_ctx,
                                 qmc_integrate_report *rep, char *why,
                                 size_t why_bytes);

/*
 * An upper bound on the bytes one qmc_integrate(spec, f, ...) call with
 * f->dims == dims allocates: a rule's workspace, the sampling methods'
 * block sums, auto's VEGAS map, whichever the method can use.  Leaves out
 * the integrand itself and a runner's own block workspaces.  A server
 * reserves it before running a job; saturates at UINT64_MAX.
 */
uint64_t qmc_integrate_memory_bytes(const qmc_integrate_spec *spec, uint32_t dims);

/*
 * The same bound for this integrand f and control variate g (NULL: none):
 * for method auto it counts only the rule auto picks for f (from its
 * dims, its declared smoothness and g) and the RQMC that may follow or
 * replace it, so it is never larger than qmc_integrate_memory_bytes(spec,
 * f->dims) and often far smaller (an integrand with jumps gets no
 * cubature regions).  Other methods: qmc_integrate_memory_bytes.
 */
uint64_t qmc_integrate_memory_bytes_for(const qmc_integrate_spec *spec, const qmc_integrand *f,
                                        const qmc_integrand *g);

/* "sobol owen, 16 x 4096 points" for a sampling spec, into buf. */
void qmc_sampling_describe(const qmc_sampling_spec *s, char *buf, size_t bytes);

const char *qmc_method_name(qmc_method m);
QMC_MUST_CHECK int qmc_method_parse(const char *name, qmc_method *out);

#ifdef __cplusplus
}
#endif
#endif /* QMC_INTEGRATE_H */
