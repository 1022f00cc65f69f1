/*
 * session_impl.h - the integration session shared by session.c (the
 * caller's side: open, ask, tell, close) and session_run.c (the fiber's
 * side: the integrator, its integrand and block runner) (private).
 */
#ifndef QMC_SESSION_IMPL_H
#define QMC_SESSION_IMPL_H

#include "fiber.h"
#include "sampling_impl.h"
#include "qmc/session.h"

/* How the session's integrand answers an integrator's call (session_run.c). */
typedef enum session_mode {
    MODE_DIRECT,   /* hand the caller this call's points and wait */
    MODE_COLLECT,  /* copy the points into the batch, answer 0 (first pass) */
    MODE_REPLAY    /* answer from the caller's values, in order (second pass) */
} session_mode;

struct qmc_session {
    qmc_session_spec spec;
    qmc_integrand f;              /* eval: the session's; ctx: the session */
    qmc_integrate_spec ispec;     /* spec.integrate with the session's hook */
    qmc__fiber *fiber;

    /* The batch the fiber waits for (valid while pending). */
    int pending;                  /* the fiber is suspended on a batch */
    int served;                   /* ask has handed it out */
    uint64_t seq;                 /* its number */
    const double *points;         /* count x dims */
    size_t count;
    double *out;                  /* where its values go (MODE_DIRECT) */
    int collected;                /* a group of whole blocks: its values are
                                     replayed from src, not copied to out */
    const double *src;            /* a collected batch's values: the caller's
                                     (tell), or vals when they overlap a buffer
                                     the session writes */

    /* Telling ahead (qmc_session_tell_ahead, docs/SESSIONS.md): the next
     * group is collected and handed out before this one is replayed. */
    int early;                    /* the tell that resumed the fiber may
                                     return before the replay */
    int behind;                   /* it did: the fiber waits in the runner
                                     to replay the told group (catch_up) */

    /* Batches assembled from whole blocks (sampling methods). */
    session_mode mode;
    uint64_t max_batch;           /* points */
    double *buf;                  /* max_batch x dims points */
    double *collect;              /* where batches are assembled: buf, or the
                                     caller's buffer of qmc_session_tell_to */
    double *vals;                 /* max_batch values (src when the caller's
                                     overlap the collect buffer) */
    size_t fill;                  /* points collected */
    size_t cursor;                /* values replayed */
    int overrun;                  /* a pass did not match the batch: a bug */
    void *ws;                     /* one block's workspace */
    size_t ws_bytes;

    int closing;                  /* free: unwind the integrator */
    int finished;                 /* the fiber's work is over */

    /* Progress and the answer. */
    uint64_t batches, evals, nonfinite;
    int has_estimate;
    qmc_result running;
    const qmc_sampling_job *run_job; /* the job running was last taken from */
    uint64_t run_key, run_done;      /* its n, and the blocks it rested on */
    int err;                      /* the integrator's return value */
    qmc_integrate_report rep;
    char why[512];

    /* A part session's answer. */
    qmc_session_part_sums part;
    qmc_sampling_sums *part_sums;
};

/* The fiber's entry: runs the integrator (or the part) to its end,
 * yielding for every batch; sets err, rep, why (session_run.c). */
void qmc__session_main(void *arg);

/* Opens with a painted fiber stack (tests measure its high-water mark
 * with qmc__session_stack_used); qmc_session_new is this with paint 0. */
int qmc__session_new(const qmc_session_spec *spec, int paint, qmc_session **out, char *why,
                     size_t why_bytes);
size_t qmc__session_stack_used(const qmc_session *s);

#endif
