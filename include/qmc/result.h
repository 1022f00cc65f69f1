/*
 * qmc/result.h - what every integrator returns: the estimate, its error,
 * the work done, and flags that say when the numbers cannot be trusted.
 *
 * Integrators always fill a result, even when they fail to reach a
 * tolerance (QUADPACK's habit: best estimate plus status).  A flag is
 * raised, never silently absorbed; an error bar that is not trustworthy
 * carries QMC_FLAG_ERROR_UNRELIABLE and is not to be printed bare.
 */
#ifndef QMC_RESULT_H
#define QMC_RESULT_H

#include <stdint.h>

#include "qmc/error.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Flags: X(name, bit, short name for JSON, one-line meaning). */
#define QMC_FLAG_MAP(X)                                                              \
    X(NONFINITE, 0, "nonfinite", "non-finite integrand values (estimate invalid)")   \
    X(HEAVY_TAIL, 1, "heavy_tail", "heavy tails: the variance may be infinite")      \
    X(NOT_POW2, 2, "not_pow2", "N is not a power of two: the net property is lost")  \
    X(DIMS_PAST_GOOD, 3, "dims_past_good",                                           \
      "dimensions past the sequence's known-good range")                             \
    X(NOT_CONVERGED, 4, "not_converged", "the tolerance was not reached")            \
    X(BUDGET, 5, "budget", "the evaluation budget ran out")                          \
    X(ROUNDOFF, 6, "roundoff", "roundoff error limits the attainable accuracy")      \
    X(MAX_SUBDIV, 7, "max_subdiv", "the maximum number of subdivisions was reached") \
    X(MEMORY_BOUND, 8, "memory_bound", "the region memory bound was reached")        \
    X(FEW_REPS, 9, "few_reps", "too few randomizations for a reliable interval")     \
    X(ERROR_UNRELIABLE, 10, "error_unreliable", "the error estimate is not trustworthy") \
    X(ZERO_PDF, 11, "zero_pdf", "the sampling pdf vanishes where the integrand does not") \
    X(FEW_NONZERO, 12, "few_nonzero",                                                \
      "too few nonzero values: the bar cannot see mass the points missed")           \
    X(ZERO_SPREAD, 13, "zero_spread",                                                \
      "samples or replicates agree exactly: a spread of 0 is not exactness")         \
    X(TAIL_UNTESTED, 14, "tail_untested",                                            \
      "too few nonzero values to test for heavy tails: infinite variance not ruled out") \
    X(UNRESOLVED, 15, "unresolved",                                                  \
      "the rule does not resolve the integrand: its nodes missed mass, or its bar is " \
      "a tenth of the estimate or more")                                             \
    X(MIS_UNDERSAMPLED, 16, "mis_undersampled",                                      \
      "a sampling technique owns mass it almost never sampled")

enum {
#define QMC__FLAG_ENUM(name, bit, key, text) QMC_FLAG_##name = 1u << (bit),
    QMC_FLAG_MAP(QMC__FLAG_ENUM)
#undef QMC__FLAG_ENUM
};

/* What the error field means. */
typedef enum qmc_error_kind {
    QMC_ERROR_NONE = 0,      /* no error estimate (a single QMC run) */
    QMC_ERROR_STDERR = 1,    /* standard error of a randomized estimate */
    QMC_ERROR_ESTIMATE = 2   /* a deterministic rule's error estimate */
} qmc_error_kind;

typedef struct qmc_result {
    double estimate;     /* best estimate of the integral */
    double error;        /* standard error or error estimate (error_kind) */
    double ci_low;       /* confidence interval (95% by default); equal to */
    double ci_high;      /*   estimate +- error when no CI is defined */
    qmc_error_kind error_kind;
    uint64_t n;          /* sample points (or rule points) per estimate */
    uint64_t evals;      /* integrand evaluations in all */
    uint32_t dims;       /* dimensions used */
    uint32_t flags;      /* QMC_FLAG_* bits */
    uint64_t nonfinite;  /* count of non-finite integrand values seen */
    double abs_integral; /* estimate of the integral of |f|, so errors of
                            near-zero integrals can be read relative to it;
                            0 when the integrator does not provide one */
} qmc_result;

/* Short key ("heavy_tail") and meaning of one flag bit; "" for others. */
const char *qmc_flag_key(uint32_t flag);
const char *qmc_flag_text(uint32_t flag);

/* Initializes a result to zeros (no estimate yet). */
void qmc_result_init(qmc_result *r);

#ifdef __cplusplus
}
#endif
#endif /* QMC_RESULT_H */
