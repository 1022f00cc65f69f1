/*
 * qmc/session.h - integration sessions: the caller evaluates f, libqmc
 * keeps the estimate, the error bar, the flags and the stopping rule
 * ("reverse communication", as in NAG's d01ra, or ask/tell as in Optuna).
 *
 * A session is opened with what qmc_integrate takes minus the integrand:
 * the integrate spec (method - auto included -, tolerances, budget,
 * confidence, seed, n, reps) and what the caller declares about f (its
 * dimension, its smoothness, its exact value when known).  Then, in a
 * loop, qmc_session_ask hands out a batch of points and qmc_session_tell
 * takes f at those points, until ask says the session is done; the result
 * is then bit for bit the one qmc_integrate would have returned for an
 * integrand giving the same values (docs/SESSIONS.md says how).
 *
 *     qmc_session *s;
 *     if (qmc_session_new(&spec, &s, why, sizeof why) != 0) ...
 *     for (;;) {
 *         qmc_session_batch b;
 *         (void)qmc_session_ask(s, &b);
 *         if (b.count == 0) break;                   // done
 *         for (size_t i = 0; i < b.count; i++)
 *             vals[i] = my_f(b.points + i * b.dims);
 *         if (qmc_session_tell(s, b.seq, vals, b.count, why, sizeof why) != 0) ...
 *     }
 *     qmc_session_result(s, &rep, why, sizeof why);  // as qmc_integrate's
 *     qmc_session_free(s);
 *
 * The callback API is qmc_integrate itself with a qmc_integrand whose eval
 * is the caller's function (qmc/integrate.h): it runs without a session's
 * switches and gives the same bytes.  A session is for callers who cannot
 * be called back: another process, another machine, a device.
 *
 * A session waiting for its caller holds no thread, only memory (at most
 * qmc_session_memory_bytes).  It is not thread-safe: one call at a time,
 * but successive calls may come from different threads.
 */
#ifndef QMC_SESSION_H
#define QMC_SESSION_H

#include <stddef.h>
#include <stdint.h>

#include "qmc/error.h"
#include "qmc/integrand.h"
#include "qmc/integrate.h"
#include "qmc/result.h"
#include "qmc/sampling.h"

#ifdef __cplusplus
extern "C" {
#endif

enum {
    QMC_SESSION_NAME_BYTES = 32,     /* f's name, terminator included */
    QMC_SESSION_MAX_DIMS = 21201,    /* the most any sequence takes (sobol) */
    /* Default points in a batch the session assembles (sampling methods),
     * lowered so that points and values stay within
     * QMC_SESSION_BATCH_BYTES at high dimension. */
    QMC_SESSION_MAX_BATCH = 65536
};
#define QMC_SESSION_BATCH_BYTES (32u << 20)

typedef struct qmc_session_spec {
    /* What the caller declares about f. */
    uint32_t dims;                /* 1 .. QMC_SESSION_MAX_DIMS */
    qmc_smoothness smoothness;    /* for auto and the flags; default continuous */
    int has_exact;                /* 1: exact is f's true integral (tests) */
    double exact;
    char name[QMC_SESSION_NAME_BYTES]; /* "" or f's name: enters a part's fingerprint */
    /* How: as for qmc_integrate (interrupt, when set, is polled too). */
    qmc_integrate_spec integrate;
    /* Sampling methods: the most points in one batch the session assembles
     * from whole blocks (0: the default above).  A block of
     * QMC_SAMPLING_BLOCK points larger than this is handed out in the
     * engine's own chunks of 256 points instead. */
    uint64_t max_batch;
    /* A part of a fixed-n sampling job (mc, stratified, lhs, qmc, rqmc
     * without a tolerance): blocks [nb (k-1) / p, nb k / p) of its nb, as
     * `qmc integrate --part k/p` computes them.  0, 0: the whole job. */
    uint32_t part_k, part_p;
} qmc_session_spec;

/* Defaults: qmc_integrate_spec_init, dims 0 (the caller must set it),
 * smoothness QMC_SMOOTH_CONTINUOUS (a function nothing is known about may
 * have kinks: rule bars are then flagged error_unreliable; declare
 * QMC_SMOOTH_ANALYTIC when f is smooth), no exact value, no name, the
 * default batch, the whole job. */
void qmc_session_spec_init(qmc_session_spec *spec);

typedef struct qmc_session qmc_session;

/*
 * Opens a session and runs the integrator up to its first batch, so that a
 * request qmc_integrate would refuse is refused here, with its reason.
 * Errors, with a one-line reason: QMC_EINVAL (dims 0, smoothness, name
 * without its terminator, has_exact, part not k/p or not of a fixed-n
 * sampling job; or as qmc_integrate), QMC_EDIMS (dims past
 * QMC_SESSION_MAX_DIMS, or as qmc_integrate), QMC_ECOUNT, QMC_ESCRAMBLE,
 * QMC_EBUDGET, QMC_ETOOBIG (as qmc_integrate), QMC_ENOMEM (also a
 * max_batch too large to allocate).  There is no control variate: the
 * session's integrand is the caller's only.  The spec is copied; *out is
 * the caller's to free (NULL on failure).
 */
QMC_MUST_CHECK int qmc_session_new(const qmc_session_spec *spec, qmc_session **out,
                                   char *why, size_t why_bytes);

/* Closes a session at any time, freeing everything it holds (a suspended
 * integrator is unwound through its interrupt hook first).  NULL is a
 * no-op.  Batch pointers from ask die with it. */
void qmc_session_free(qmc_session *s);

/* Why a session ended.  X(enum suffix, key, meaning). */
#define QMC_SESSION_END_MAP(X)                                                         \
    X(RUNNING, "running", "points are still wanted")                                   \
    X(CONVERGED, "converged", "the tolerance was met")                                 \
    X(COMPLETE, "complete", "every point of the fixed rule or fixed n was evaluated")  \
    X(BUDGET, "budget",                                                                \
      "a limit (evaluations, subdivisions, memory) ran out before the tolerance was met") \
    X(CANNOT_TELL, "cannot_tell",                                                      \
      "finished, but the error bar cannot be trusted (see the flags)")                 \
    X(FAILED, "failed", "the integrator stopped with an error")

typedef enum qmc_session_end {
#define QMC__SESSION_END_ENUM(name, key, text) QMC_SESSION_##name,
    QMC_SESSION_END_MAP(QMC__SESSION_END_ENUM)
#undef QMC__SESSION_END_ENUM
} qmc_session_end;

const char *qmc_session_end_key(qmc_session_end e);  /* "converged"; "" for others */
const char *qmc_session_end_text(qmc_session_end e);

typedef struct qmc_session_batch {
    uint64_t seq;           /* the batch's number: 0, 1, 2, ... */
    const double *points;   /* count x dims coordinates in [0,1), row-major;
                               the session's, valid until the next tell or free */
    size_t count;           /* 0: the session is done (qmc_session_result) */
    uint32_t dims;
    qmc_session_end end;    /* RUNNING while count > 0; then why it ended */
} qmc_session_batch;

/*
 * The batch the session waits for, or count 0 when it is done (end says
 * why).  Asking again before telling returns the same batch (a retry never
 * loses work).  Returns 0, or QMC_EINVAL for NULL arguments.
 */
QMC_MUST_CHECK int qmc_session_ask(qmc_session *s, qmc_session_batch *batch);

/*
 * f at the points of batch seq, in order: values[0 .. count).  The values
 * are read before tell returns and not kept; NaN and infinities are taken as they are, counted, and
 * flagged by the integrator as for any integrand (QMC_FLAG_NONFINITE).
 * The integrator then runs on to its next batch (or to its end) before
 * tell returns.  Errors, with a reason, leaving the session as it was (the
 * same batch is still waiting): QMC_EINVAL for a batch not handed out by
 * ask (no ask yet, an old seq, a future one), a count that is not the
 * batch's, values NULL, or a session that is done.
 */
QMC_MUST_CHECK int qmc_session_tell(qmc_session *s, uint64_t seq, const double *values,
                                    size_t count, char *why, size_t why_bytes);

/*
 * As qmc_session_tell, and the batches of whole blocks the integrator
 * assembles next (sampling methods, auto's RQMC) are written at next -
 * room for next_points points of dims coordinates, at least the session's
 * max_batch - instead of the session's own buffer (NULL: its own).  For a
 * server that hands batches out through memory it shares with its client
 * (qmcd's ring slots): the points go there once, not through a copy.  The
 * session only writes next, never reads the points back (it makes them
 * again to take the values), so what anyone else writes there changes only
 * what ask hands out.  next must stay valid while the batch assembled there
 * waits (until the next tell), or be given up first with
 * qmc_session_own_batch.  Errors as qmc_session_tell, and QMC_EINVAL for a
 * next of fewer points than max_batch or a session that assembles no
 * batches (before anything is taken).
 */
QMC_MUST_CHECK int qmc_session_tell_to(qmc_session *s, uint64_t seq, const double *values,
                                       size_t count, double *next, size_t next_points,
                                       char *why, size_t why_bytes);

/*
 * As qmc_session_tell_to, but it may return as soon as the next batch is
 * assembled, before this batch's values are summed: when the integrator
 * knows its next batch already (the next group of blocks of a sampling
 * run: a fixed n's whole run, an adaptive round's replicate), it collects
 * that batch, hands it out and returns with the session *behind*; the
 * values are summed by qmc_session_catch_up, which the next tell, own_batch
 * and free also do first.  So a server hands the next batch to its client
 * first and sums this one while the client evaluates (docs/SESSIONS.md,
 * "Telling ahead").  Only batches the integrator would ask for anyway are
 * handed out early, and the result is the same bytes.  While behind, ask
 * hands out the next batch, status counts the values told (its running
 * estimate rests on the batches summed), and values is read: it must stay
 * valid and unchanged until the catch-up.  Otherwise (a rule, the last
 * group of a run) it is qmc_session_tell_to.  Errors as qmc_session_tell_to.
 */
QMC_MUST_CHECK int qmc_session_tell_ahead(qmc_session *s, uint64_t seq, const double *values,
                                          size_t count, double *next, size_t next_points,
                                          char *why, size_t why_bytes);

/* 1 while values told ahead wait to be summed (0 for NULL). */
int qmc_session_behind(const qmc_session *s);

/* Sums the values a qmc_session_tell_ahead left, running the integrator on
 * to where it waits for the next batch's values (or to its end, should
 * the sums fail); a no-op when not behind (NULL too). */
void qmc_session_catch_up(qmc_session *s);

/* A waiting batch assembled in a caller's buffer (qmc_session_tell_to) is
 * copied into the session's own, which ask then hands out, so that buffer
 * may go; later batches are assembled in the session's own too.  Catches
 * up first (values told ahead may lie in that buffer).  No-op otherwise
 * (NULL too). */
void qmc_session_own_batch(qmc_session *s);

typedef struct qmc_session_report {
    qmc_session_end end;    /* QMC_SESSION_RUNNING until done */
    int err;                /* QMC_SESSION_FAILED: the integrator's QMC_E* code */
    uint64_t batches;       /* batches answered */
    uint64_t evals;         /* values received */
    uint64_t nonfinite;     /* of which NaN or infinite */
    /* 1 when running holds an estimate: at the end the final result (as
     * qmc_session_result's); before, the sampling methods' estimate from
     * the work done so far - every replicate completed (reps >= 2, from
     * two on), or the points so far (one replicate of mc or qmc; a prefix
     * of a stratified, lhs or hammersley set is not such a set, so none)
     * - with the flags that estimate earns (few_reps, not_pow2, ...).
     * The rules (quadrature, cubature) keep theirs inside until the end.
     * Whatever the case, running.evals is the values received so far and
     * QMC_FLAG_NONFINITE is raised as soon as one was not finite. */
    int has_estimate;
    qmc_result running;
} qmc_session_report;

/* The session's state after the last tell (or open). */
void qmc_session_status(const qmc_session *s, qmc_session_report *out);

/*
 * The final answer, once ask says done: *rep is what qmc_integrate fills
 * (result, method used, auto's reason, detail), and the return value is
 * its return value (0, or the QMC_E* code with the reason in why).
 * QMC_EAGAIN while the session is running; *rep is then zeroed.  A part
 * session (part_p != 0) returns 0 with no estimate: its answer is its
 * block sums (qmc_session_part).
 */
QMC_MUST_CHECK int qmc_session_result(const qmc_session *s, qmc_integrate_report *rep,
                                      char *why, size_t why_bytes);

/* A part session's answer: what `qmc integrate --part` writes. */
typedef struct qmc_session_part_sums {
    uint64_t fingerprint;    /* qmc_sampling_fingerprint of the whole job */
    uint64_t blocks;         /* the whole job's blocks */
    uint64_t first, count;   /* this part's: blocks [first, first + count) */
    const qmc_sampling_sums *sums; /* count sums, the session's (valid until free) */
    qmc_sampling_spec sampling;    /* the job's sampling spec (n, reps as run) */
} qmc_session_part_sums;

/* Fills *out once a part session is done.  QMC_EAGAIN while running,
 * QMC_EINVAL for a session that is not a part, the integrator's error if
 * it failed. */
QMC_MUST_CHECK int qmc_session_part(const qmc_session *s, qmc_session_part_sums *out);

/*
 * An upper bound on the bytes a session opened with spec holds at any
 * time: the session and the stack its integrator runs on (128 KiB; 512
 * KiB in a sanitized build), the batch buffer (max_batch x (dims + 1)
 * doubles, sampling methods and auto), one block's workspace, a part's
 * sums, and qmc_integrate_memory_bytes_for for the integrator's own.
 * Leaves out what that bound leaves out (a few sequence instances).
 * Saturates at UINT64_MAX.  A server reserves it before opening.
 */
uint64_t qmc_session_memory_bytes(const qmc_session_spec *spec);

#ifdef __cplusplus
}
#endif
#endif /* QMC_SESSION_H */
