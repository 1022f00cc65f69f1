/*
 * session.h - integration sessions in the daemon (PROTOCOL.md section
 * 6.21, docs/SESSIONS.md), shared by their four files:
 *
 *   session.c        the requests (SESSION_OPEN, _VALUES, _RESUME, _CLOSE)
 *                    and the producer kind that answers on a connection;
 *   session_store.c  the server-wide registry: ids, tokens, identities,
 *                    the caps, parking and expiry, the STATS gauges;
 *   session_step.c   moving the integrator on (qmc_session_new, _tell) on
 *                    the worker pool or, when cheap, on the loop thread;
 *   session_part.c   a part session's answer: its block sums (version 6).
 *   session_send.c   the batches and reports on the way out (inline, ring
 *                    slots).
 *
 * A session (sess) lives in the registry from SESSION_OPEN until it ends,
 * is closed or expires.  While a connection serves it, an attachment - a
 * producer of that connection (producer.h) - points at it; when the
 * connection goes, the attachment goes and the session is parked, with
 * its batch, until a SESSION_RESUME from the same identity attaches it
 * again or session-idle-timeout-ms passes.  A session waiting for its
 * caller's values holds no thread: only its memory (qmc_session_memory_bytes,
 * reserved against the session caps and max-jobs-memory-total).
 *
 * Private to these files: the rest of the daemon reaches sessions only
 * through the module's rows (modules.h).
 */
#ifndef QMCD_SESSION_H
#define QMCD_SESSION_H

#include <stdatomic.h>
#include <stdint.h>

#include "conn_services.h"
#include "pool.h"
#include "producer.h"
#include "qmc/proto.h"
#include "qmc/session.h"

typedef struct qmcd_sess qmcd_sess;

/* A connection's handle on a session: the producer that answers under
 * the SESSION_OPEN's (or SESSION_RESUME's) request id.  s NULL: the
 * session went elsewhere (closed, taken over); its pump then ends it. */
typedef struct qmcd_sess_attach {
    qmcd_producer p;              /* first: the connection's handle */
    qmcd_sess *s;
    qmcd_conn *c;                 /* the connection it is a producer of */
} qmcd_sess_attach;

/* Why a step must stop (sess.cancel). */
enum { SESS_GO = 0, SESS_CANCEL_CLOSE, SESS_CANCEL_TIMEOUT, SESS_CANCEL_SHUTDOWN };

/* A ring piece of the batch on its way: its points, its slot, and which
 * hand-out of the ring it was (ring.h: still the client's while
 * released_total < handed). */
typedef struct qmcd_sess_piece {
    uint64_t first;
    uint32_t points, slot;
    uint64_t handed;
} qmcd_sess_piece;

struct qmcd_sess {
    qmcd_pool_task task;          /* first: the pool hands &s->task back */
    qmcd_sess *next;              /* the registry's list */
    qmcd_server *srv;
    qmcd_sess_attach *a;          /* the attachment serving it, or NULL: parked */
    uint64_t id;
    uint8_t token[QMC_PROTO_SESSION_TOKEN_BYTES];
    qmcd_identity who;
    qmc_session_spec spec;        /* as asked, with the server's caps applied */
    qmc_session *core;            /* NULL until the opening step made it */
    uint64_t mem_bytes;           /* counted against the session caps */
    uint64_t pool_bytes;          /* kept against max-jobs-memory-total */
    uint64_t max_batch;           /* the most points a batch may hold */
    uint64_t engine_batch;        /* the most a batch of whole blocks holds */
    qmc_points_transport transport; /* what the attached client asked for */

    /* Steps: one at a time, on the pool or the loop. */
    int stepping;                 /* a step is queued or running */
    int opening;                  /* the step is the opening one */
    atomic_int cancel;            /* SESS_CANCEL_*: the interrupt hook reads it */
    int on_pool;                  /* the running step holds a pool slot */
    unsigned polls;               /* hook calls in this step */
    int64_t step_start_ms;
    int64_t step_limit_ms;        /* job-time-limit-ms, copied on the loop */
    int64_t last_step_us;         /* the last step's CPU time: cheap ones stay on the loop */
    double compute_s;             /* the steps' time, for SESSION_RESULT */
    int err;                      /* the opening's refusal, or the end's error */
    char why[512];
    qmc_integrate_report rep;     /* the end's answer */

    /* The batch handed out, and the values coming back. */
    int have_batch;               /* batch holds the waiting batch */
    qmc_session_batch batch;
    uint64_t sent;                /* its points sent so far (pieces) */
    int ring;                     /* this batch goes through the ring */
    qmcd_sess_piece pieces[QMC_PROTO_SHM_MAX_SLOTS];
    unsigned n_pieces;
    double *vals;                 /* values received, vals_cap of room */
    uint64_t vals_cap, got;

    /* What the attachment still owes its client, in this order. */
    int owe_opened, owe_report;
    int finished;                 /* the integrator ended: the result is owed */
    int part_head_sent;           /* a part's SESSION_PART went out, and */
    uint64_t part_sent;           /* this many of its block sums */
    int announced;                /* SESSION_OPENED went out: its client holds
                                     the token, so it is kept when parked */
    int64_t parked_ms;            /* when it was parked, 0 while attached */
    int orphan;                   /* freed at exit while a step ran: the pool
                                     hands it back to free (free_fn) */
};

/* ---- session_store.c -------------------------------------------------------------- */

/* The module's server-wide state: registry and expiry timer.  0 or -errno. */
int qmcd__sessions_open(qmcd_server *srv);
void qmcd__sessions_close(qmcd_server *srv);

/* Checks the caps for one more session of who reserving bytes; 0, or
 * QMC_ETOOBIG with one line in why (and STATS refused_sessions). */
int qmcd__sessions_admit(qmcd_server *srv, const qmcd_identity *who, uint64_t bytes,
                         char *why, size_t why_bytes);
/* A new session in the registry (id, token from libsodium's generator),
 * counted against the caps; NULL when out of memory. */
qmcd_sess *qmcd__sessions_add(qmcd_server *srv, const qmcd_identity *who, uint64_t bytes);
/* The session of this id, identity and token, or NULL (one answer for an
 * unknown id, another identity and a wrong token: compared in constant
 * time, both checked). */
qmcd_sess *qmcd__sessions_find(qmcd_server *srv, uint64_t id, const qmcd_identity *who,
                               const uint8_t *token);
/* Parks s (its attachment is gone): the expiry clock starts. */
void qmcd__sessions_park(qmcd_sess *s);
/* s is attached again (SESSION_RESUME). */
void qmcd__sessions_unpark(qmcd_sess *s);
/* Takes s out of the registry and frees it, or, while a step runs, marks
 * it an orphan, to be freed when the step comes back. */
void qmcd__sessions_drop(qmcd_sess *s);
/* Frees a session out of the registry whose step is over (an orphan
 * back; drop's own end). */
void qmcd__sessions_free(qmcd_sess *s);

/* ---- session_step.c --------------------------------------------------------------- */

/* Starts the opening step (qmc_session_new) on the pool under tenant;
 * the session's memory waits for max-jobs-memory-total there like a job's.
 * s->task.done (the caller's) takes the step back on the loop. */
void qmcd__sess_start_open(qmcd_sess *s, qmcd_pool_tenant *tenant);
/* 1 when the next step runs at once, on the loop thread (the last one was
 * cheap): its values may then be read where they arrived. */
int qmcd__sess_tell_now(const qmcd_sess *s);
/* All the batch's values are in: the next step (qmc_session_tell), on the
 * loop when the last steps were cheap (from values when not NULL, else
 * s->vals; and assembling the next batch at next, room for next_points
 * points, when not NULL: a free ring slot), else on the pool under tenant
 * (from s->vals, in the session's own buffer). */
/* Returns 1 when the step ran at once (the caller ends it), 0 when it was
 * submitted (s->task.done ends it). */
int qmcd__sess_start_tell(qmcd_sess *s, qmcd_pool_tenant *tenant, const double *values,
                          double *next, size_t next_points);
/* After a step (or the opening): takes the next batch (ask) and whether
 * the session finished. */
void qmcd__sess_settle(qmcd_sess *s);

/* ---- session_part.c ---------------------------------------------------------------- */

/* 1 while a finished part session (no error) still owes its SESSION_PART
 * or block sums. */
int qmcd__sess_part_owed(const qmcd_sess *s);
/* Queues the next of them on a's connection: a QMCD_PUMP_* status. */
int qmcd__sess_part_pump(qmcd_conn *c, qmcd_sess_attach *a);

/* ---- session_send.c ----------------------------------------------------------------- */

/* Whole points of dims in one inline piece: a chunk's bytes and the
 * client's max_frame bound it (0: not even one point fits). */
uint64_t qmcd__sess_inline_points(const qmcd_conn *c, uint32_t dims);
/* The SESSION_REPORT of s's state, under request_id, into *r. */
void qmcd__sess_report_of(const qmcd_sess *s, qmc_msg *r, uint64_t request_id);
/* 1 when the waiting batch goes through the client's ring: it asked, has
 * one, and the batch's pieces (points and values) fit in it at once. */
int qmcd__sess_uses_ring(const qmcd_conn *c, const qmcd_sess *s);
/* The next piece of the waiting batch: a QMCD_PUMP_* status. */
int qmcd__sess_send_piece(qmcd_conn *c, qmcd_sess_attach *a);
/* The ring's next free slot as room for a whole batch of the engine's and
 * its values (*slot, *points), or NULL (no ring, full, too small, or no
 * room for the answer). */
double *qmcd__sess_next_slot(qmcd_conn *c, const qmcd_sess *s, uint32_t *slot, size_t *points);
/* The step assembled the batch in ring slot `slot`: the report, and the
 * batch as one piece naming that slot, now. */
void qmcd__sess_send_in_slot(qmcd_conn *c, qmcd_sess_attach *a, uint32_t slot);

/* ---- session.c ---------------------------------------------------------------------- */

/* (session.c's step_done takes a step back on the loop: answers on the
 * attachment, leaves the session parked, or frees it.) */

#endif
