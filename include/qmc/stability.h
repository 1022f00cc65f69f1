/*
 * qmc/stability.h - judging an integration result against a reference
 * computed independently of the method: the classification `qmc stability`
 * tabulates and `qmc compare` uses for its honesty figures.
 *
 * Pure computation: the caller supplies the result and the reference; no
 * method is run here.
 */
#ifndef QMC_STABILITY_H
#define QMC_STABILITY_H

#include <stdint.h>

#include "qmc/result.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Classes of one run (or of a cell of runs), best first.
 * X(enum suffix, value, name). */
#define QMC_STAB_CLASS_MAP(X)      \
    X(OK, 0, "OK")                 \
    X(FLAGGED, 1, "FLAGGED")       \
    X(REFUSED, 2, "REFUSED")       \
    X(SILENT, 3, "SILENT")

typedef enum qmc_stab_class {
#define QMC__STAB_ENUM(name, value, text) QMC_STAB_##name = (value),
    QMC_STAB_CLASS_MAP(QMC__STAB_ENUM)
#undef QMC__STAB_ENUM
} qmc_stab_class;

/* A result is "covered" when |estimate - truth| <= this many times the
 * reported error (plus the slack below). */
#define QMC_STAB_COVER_FACTOR 3.0
/* Rounding slack: differences below this many ulps of max(|truth|, the
 * integral of |f|) count as agreement, so an exact rule whose error
 * estimate is rounded to 0 is not called wrong. */
#define QMC_STAB_ROUNDING_ULPS 64.0

/* The reference a result is judged against. */
typedef struct qmc_stab_truth {
    double value;        /* may be +-inf: then only a flag or refusal is right */
    double abs_error;    /* the reference's own error bound (0 if exact) */
    double scale;        /* integral of |f| if known (rounding slack), else 0 */
    int defined;         /* 0: the integral does not exist as a finite number
                            (overflow, NaN): any finite unflagged answer is
                            silent */
} qmc_stab_truth;

/* What the classification saw, for printing. */
typedef struct qmc_stab_verdict {
    qmc_stab_class cls;
    int covered;         /* the bar covers the truth */
    int bar_usable;      /* error_kind != none and the error finite, >= 0 */
    double abs_error;    /* |estimate - truth| (NaN if undefined) */
    double ratio;        /* abs_error / reported error (inf for a zero bar) */
} qmc_stab_verdict;

/*
 * Classifies one run.  refused != 0: the method returned an error (r is
 * ignored) -> REFUSED.  Otherwise:
 *   - covered (bar usable and |est - truth| <= 3 err + truth.abs_error +
 *     rounding slack, truth defined, estimate finite) -> OK, whatever the
 *     flags (a flag on a covered result is a false alarm; callers count
 *     those separately);
 *   - not covered, any flag bit set -> FLAGGED;
 *   - not covered, error_kind none (the method says outright that it has
 *     no error bar, as plain QMC does) -> FLAGGED: the absence is declared;
 *   - not covered, no flag (this includes a NaN or infinite bar printed
 *     bare, and a finite answer to an integral that has none) -> SILENT.
 */
qmc_stab_verdict qmc_stab_classify(int refused, const qmc_result *r,
                                   const qmc_stab_truth *truth);

/*
 * How many of `runs` independent seeds must be SILENT before a cell of
 * randomized runs is called SILENT: the smallest s with
 * P(Binomial(runs, p_chance) >= s) < alpha, where p_chance is the rate at
 * which an honest bar misses by more than 3 errors by chance (about 1%
 * for Student-t intervals on 16 replicates).  1 for runs == 1.
 */
uint32_t qmc_stab_silent_threshold(uint32_t runs, double p_chance, double alpha);

/* The test's two numbers, the same wherever runs are judged: an honest
 * 3-sigma bar misses 1% of the time, and a set of runs is called SILENT
 * when that many misses would happen by chance less than once in 1000. */
#define QMC_STAB_CHANCE_MISS 0.01
#define QMC_STAB_SILENT_ALPHA 1e-3

/*
 * The one binomial test `qmc stability` applies to a cell and `qmc compare`
 * to a method's runs: how many SILENT runs out of `runs` make them SILENT.
 * Randomized runs: qmc_stab_silent_threshold(runs, QMC_STAB_CHANCE_MISS,
 * QMC_STAB_SILENT_ALPHA) (2 of 3, 3 of 5, 3 of 9, 4 of 64), since each
 * honest one misses by chance 1% of the time; deterministic ones: 1, since
 * a rule's miss repeats on every run and is no accident.
 */
uint32_t qmc_stab_silent_needed(uint32_t runs, int randomized);

/*
 * How often each flag fired on correct and on wrong answers, so that a
 * report can say what a flag is worth (a flag on most correct answers is
 * ignored, and then it protects nobody).  A run counts when it was not
 * refused and declares a bar (error_kind != none: plain QMC has no bar to
 * be right or wrong about); correct means covered (qmc_stab_classify),
 * wrong means not covered.  Bit b of the flags is counted in
 * on_correct[b] or on_wrong[b]; any flag at all in correct_flagged or
 * wrong_flagged.
 */
typedef struct qmc_stab_flag_tally {
    uint32_t correct, wrong;
    uint32_t correct_flagged, wrong_flagged;
    uint32_t on_correct[32], on_wrong[32];
} qmc_stab_flag_tally;

void qmc_stab_flag_tally_add(qmc_stab_flag_tally *t, int refused, const qmc_stab_verdict *v,
                             const qmc_result *r);
void qmc_stab_flag_tally_merge(qmc_stab_flag_tally *into, const qmc_stab_flag_tally *from);

/* Counts of each class over a cell's runs, and the cell's class:
 * SILENT when silent >= threshold; else REFUSED when every run was
 * refused; else FLAGGED when at least half the runs are wrong (flagged
 * or silent); else OK. */
typedef struct qmc_stab_tally {
    uint32_t runs, ok, ok_flagged, flagged, refused, silent;
} qmc_stab_tally;

void qmc_stab_tally_add(qmc_stab_tally *t, const qmc_stab_verdict *v,
                        const qmc_result *r);
qmc_stab_class qmc_stab_tally_class(const qmc_stab_tally *t, uint32_t threshold);

const char *qmc_stab_class_name(qmc_stab_class c);

#ifdef __cplusplus
}
#endif
#endif /* QMC_STABILITY_H */
