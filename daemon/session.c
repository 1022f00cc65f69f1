/*
 * session.c - integration sessions on a connection (PROTOCOL.md section
 * 6.21; session.h): SESSION_OPEN, SESSION_VALUES, SESSION_RESUME and
 * SESSION_CLOSE, and the producer kind that answers a session's request -
 * SESSION_OPENED, each batch in pieces (inline, or through the client's
 * ring), a SESSION_REPORT after each batch's values, a part's block sums
 * (session_part.c), SESSION_RESULT or ERROR at the end.
 *
 * The producer (an attachment) points at the session; the session lives
 * in the registry (session_store.c) and outlives it: when the connection
 * goes the session is parked, when a SESSION_RESUME of the same identity
 * and token comes it is attached again and the batch it waits for is sent
 * again whole.  While it waits for values the producer says
 * QMCD_WAIT_WORK and the session holds no thread; the values' handler
 * starts the next step (session_step.c), whose end kicks the connection.
 *
 * Values are checked before anything is taken: the session must be this
 * connection's, waiting for values of that batch from that point, the
 * count within the batch, a ring piece exactly one the server sent and
 * still held by the client.  A refusal is one ERROR under the values'
 * own request id, and drops the values of the batch received so far (the
 * batch waits for all of them again); the session goes on.
 *
 * Must not: read sockets, reach into a connection's fields (conn_services.h
 * is the door), or run an integrator (session_step.c does).
 */
#define _GNU_SOURCE
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "log.h"
#include "modules.h"
#include "result_msg.h"
#include "ring.h"
#include "session.h"

static const qmcd_producer_kind sess_kind;
static void step_done(qmcd_sess *s, int kick);

static qmcd_sess_attach *attach_of(qmcd_producer *p)
{
    return (qmcd_sess_attach *)(void *)p;
}

/* ---- sizes --------------------------------------------------------------------------- */

static uint64_t sat_add(uint64_t a, uint64_t b)
{
    return a > UINT64_MAX - b ? UINT64_MAX : a + b;
}

static uint64_t sat_mul(uint64_t a, uint64_t b)
{
    return b && a > UINT64_MAX / b ? UINT64_MAX : a * b;
}

/* Genz and Malik's degree-7 rule: 2^d + 2d^2 + 2d + 1 points, saturating. */
static uint64_t cubature_points(uint32_t d)
{
    if (d >= 63)
        return UINT64_MAX;
    return sat_add((1ull << d), 2ull * d * d + 2ull * d + 1);
}

/* The most points a batch of whole blocks holds: spec's max_batch, or the
 * default the core takes (qmc/session.h: 65536, fewer past 63 dims). */
static uint64_t engine_batch(const qmc_session_spec *spec)
{
    if (spec->max_batch)
        return spec->max_batch;
    uint64_t fit = QMC_SESSION_BATCH_BYTES / (((uint64_t)spec->dims + 1) * sizeof(double));
    return fit < QMC_SESSION_MAX_BATCH ? (fit ? fit : 1) : QMC_SESSION_MAX_BATCH;
}

/* The most points one batch of this session may hold (SESSION_OPENED's
 * max_batch): the sampling engine's batches (docs/SESSIONS.md), 65536
 * points for auto's VEGAS pilot, 256 for the tensor and Clenshaw-Curtis
 * grids, a cubature region's rule. */
static uint64_t largest_batch(const qmc_session_spec *spec)
{
    const uint64_t pts = engine_batch(spec);
    uint64_t most = pts > 65536 ? pts : 65536;
    qmc_method m = spec->integrate.method;
    if (m == QMC_METHOD_CUBATURE || m == QMC_METHOD_AUTO) {
        uint64_t rule = cubature_points(spec->dims);
        if (rule > most)
            most = rule;
    }
    return most;
}

/* ---- answers --------------------------------------------------------------------------- */

static int send_opened(qmcd_conn *c, qmcd_sess_attach *a)
{
    qmcd_sess *s = a->s;
    qmc_msg r = {.type = QMC_MSG_SESSION_OPENED, .request_id = a->p.request_id};
    qmc_msg_session_opened *o = &r.u.session_opened;
    o->session_id = s->id;
    memcpy(o->token, s->token, sizeof o->token);
    o->dims = s->spec.dims;
    o->max_batch = s->max_batch;
    o->memory_bytes = s->mem_bytes;
    o->park_ms = qmcd_conn_server(c)->cfg.session_idle_timeout_ms;
    return qmcd_conn_send(c, &r);
}

/* The end: SESSION_RESULT, or ERROR with the integrator's reason. */
static int send_end(qmcd_conn *c, qmcd_sess_attach *a)
{
    qmcd_sess *s = a->s;
    qmcd_server *srv = qmcd_conn_server(c);
    const int cancel = atomic_load(&s->cancel);
    if (s->err || !s->core) {
        srv->stats.sessions_failed++;
        if (cancel == SESS_CANCEL_TIMEOUT)
            return qmcd_conn_error(c, a->p.request_id, -ETIMEDOUT,
                                   "job-time-limit-ms: session %llu's integrator ran past %lld "
                                   "ms in one step and was stopped",
                                   (unsigned long long)s->id, (long long)s->step_limit_ms);
        if (cancel == SESS_CANCEL_SHUTDOWN)
            return qmcd_conn_error(c, a->p.request_id, -ESHUTDOWN,
                                   "session %llu stopped: the server is shutting down",
                                   (unsigned long long)s->id);
        return qmcd_conn_error(c, a->p.request_id, s->err ? s->err : QMC_ENOMEM, "%s",
                               s->why[0] ? s->why : qmc_strerror(s->err));
    }
    srv->stats.sessions_done++;
    qmc_msg r = {.type = QMC_MSG_SESSION_RESULT, .request_id = a->p.request_id};
    qmc_msg_job_result *res = &r.u.result;
    qmcd_result_of(res, s->id, &s->rep);
    res->seconds = s->compute_s;
    res->reference_kind = s->spec.has_exact ? 1 : 0;
    res->reference = s->spec.has_exact ? s->spec.exact : 0;
    /* The caller's f: nothing is known of |f| in closed form. */
    res->has_known_abs = 0;
    res->known_abs = 0;
    return qmcd_conn_send(c, &r);
}

/* ---- the producer ----------------------------------------------------------------------- */

static int sess_pump(qmcd_conn *c, qmcd_producer *p)
{
    qmcd_sess_attach *a = attach_of(p);
    qmcd_sess *s = a->s;
    if (!s)
        return QMCD_PUMP_FAILED; /* closed or taken over: its ERROR is sent */
    if (s->stepping)
        return QMCD_PUMP_WAIT; /* the step's end kicks the connection */
    const int small_room = qmcd_conn_out_room(c) >= QMCD_OUT_RESERVE / 2;
    if (!s->core) {
        /* The opening was refused: its reason ends the request. */
        if (!small_room)
            return QMCD_PUMP_NO_ROOM;
        (void)send_end(c, a);
        return QMCD_PUMP_FAILED;
    }
    if (s->owe_opened || s->owe_report) {
        if (!small_room)
            return QMCD_PUMP_NO_ROOM;
        qmc_msg r;
        int err;
        if (s->owe_opened) {
            s->owe_opened = 0;
            s->announced = 1;
            err = send_opened(c, a);
        } else {
            s->owe_report = 0;
            qmcd__sess_report_of(s, &r, a->p.request_id);
            err = qmcd_conn_send(c, &r);
        }
        return err ? QMCD_PUMP_FAILED : QMCD_PUMP_SENT;
    }
    if (s->finished) {
        if (qmcd__sess_part_owed(s))
            return qmcd__sess_part_pump(c, a); /* session_part.c */
        if (!small_room)
            return QMCD_PUMP_NO_ROOM;
        return send_end(c, a) == 0 ? QMCD_PUMP_DONE : QMCD_PUMP_FAILED;
    }
    if (atomic_load(&s->cancel) == SESS_CANCEL_SHUTDOWN) {
        if (!small_room)
            return QMCD_PUMP_NO_ROOM;
        (void)qmcd_conn_error(c, a->p.request_id, -ESHUTDOWN,
                              "session %llu stopped: the server is shutting down",
                              (unsigned long long)s->id);
        return QMCD_PUMP_FAILED;
    }
    if (s->have_batch && s->sent < s->batch.count)
        return qmcd__sess_send_piece(c, a);
    return QMCD_PUMP_WAIT; /* for the values: their handler steps and kicks */
}

static qmcd_wait sess_waiting(const qmcd_conn *c, const qmcd_producer *p)
{
    const qmcd_sess *s = ((const qmcd_sess_attach *)(const void *)p)->s;
    if (!s)
        return QMCD_WAIT_NONE;
    if (s->stepping)
        return QMCD_WAIT_WORK;
    if (!s->core || s->owe_opened || s->owe_report || s->finished ||
        atomic_load(&s->cancel) == SESS_CANCEL_SHUTDOWN)
        return QMCD_WAIT_NONE;
    if (s->have_batch && s->sent < s->batch.count) {
        qmcd_ring *r = qmcd_conn_ring(c);
        const int ring = s->sent ? s->ring : qmcd__sess_uses_ring(c, s);
        return ring && qmcd_ring_full(r) ? QMCD_WAIT_RING : QMCD_WAIT_NONE;
    }
    return QMCD_WAIT_WORK; /* the client's values */
}

/* The shutdown deadline: a step stops at its next poll and the session
 * answers ERROR when it is back (0); one waiting for its client's values
 * has nothing that would wake it, so its connection is cut (1). */
static int sess_shutdown(qmcd_conn *c, qmcd_producer *p)
{
    (void)c;
    qmcd_sess *s = attach_of(p)->s;
    if (!s)
        return 0;
    int go = SESS_GO;
    atomic_compare_exchange_strong(&s->cancel, &go, SESS_CANCEL_SHUTDOWN);
    if (s->stepping) {
        qmcd_pool_cancelled(qmcd_conn_server(c)->pool);
        return 0;
    }
    return 1;
}

/* A waiting batch assembled in a ring slot (send_in_slot) moves into the
 * session's own buffer, before the ring it sits in goes or changes hands. */
static void home_batch(qmcd_sess *s)
{
    if (s->stepping || !s->core)
        return;
    qmc_session_own_batch(s->core);
    if (s->have_batch && qmc_session_ask(s->core, &s->batch) != 0)
        s->have_batch = 0; /* only for NULL arguments */
}

/* Forgets the batch's pieces and values on the way: the next connection
 * is sent the batch again whole (and a part's sums all again). */
static void rewind_batch(qmcd_sess *s)
{
    s->part_head_sent = 0;
    s->part_sent = 0;
    s->sent = 0;
    s->got = 0;
    s->n_pieces = 0;
}

static void sess_release(qmcd_conn *c, qmcd_producer *p, qmcd_end why)
{
    (void)c;
    qmcd_sess_attach *a = attach_of(p);
    qmcd_sess *s = a->s;
    free(a);
    if (!s)
        return;
    s->a = NULL;
    home_batch(s); /* out of the connection's ring, which goes with it */
    if (why == QMCD_END_DONE || why == QMCD_END_FAILED || !s->announced) {
        /* Answered to its end - or never announced to its client, who
         * holds no token to resume it with. */
        qmcd__sessions_drop(s);
        return;
    }
    /* The connection went (or the request id was reused): kept, resumable. */
    rewind_batch(s);
    qmcd__sessions_park(s);
}

/* The pool's done callback for a session's step. */
static void task_done(qmcd_server *srv, qmcd_pool_task *task)
{
    (void)srv;
    step_done((qmcd_sess *)task, 1);
}

static const qmcd_producer_kind sess_kind = {
    .name = "session",
    .flags = QMCD_PRODUCER_BULK,
    .pump = sess_pump,
    .waiting = sess_waiting,
    .shutdown = sess_shutdown,
    .release = sess_release,
};

/* A step came back (loop thread): answer on the attachment (kicking its
 * connection when kick is set: from the pool; a step run inside a
 * request's handler is pumped after it), or leave the session parked, or
 * free it. */
static void step_done(qmcd_sess *s, int kick)
{
    s->stepping = 0;
    if (s->orphan) {
        qmcd__sessions_free(s); /* dropped while the step ran */
        return;
    }
    const int opening = s->opening;
    qmcd__sess_settle(s);
    if (!opening)
        s->owe_report = 1;
    if (!s->a) {
        /* Parked while it ran: what it owes waits for a resume.  One its
         * client never heard of can never be resumed. */
        if (!s->announced || !s->core)
            qmcd__sessions_drop(s);
        return;
    }
    if (kick)
        qmcd_conn_kick(s->a->c);
}

/* ---- requests ------------------------------------------------------------------------------ */

static int version_ok(qmcd_conn *c, uint64_t request_id, const char *what)
{
    unsigned v = qmcd_conn_version(c);
    if (v >= QMC_PROTO_VERSION_SESSIONS)
        return 1;
    qmcd_conn_error(c, request_id, QMC_ENOTSUP,
                    "%s needs protocol version %u; this connection chose %u (offer %u in "
                    "HELLO)", what, QMC_PROTO_VERSION_SESSIONS, v, QMC_PROTO_VERSION_SESSIONS);
    return 0;
}

/* The transport a client asks for: the ring needs one attached. */
static int transport_ok(qmcd_conn *c, uint64_t request_id, qmc_points_transport t)
{
    if (t != QMC_TRANSPORT_SHM || qmcd_conn_ring(c))
        return 1;
    if (!qmcd_conn_is_unix(c))
        qmcd_conn_error(c, request_id, QMC_ENOTSUP,
                        "transport 1 (the shared-memory ring) needs a Unix-socket connection");
    else
        qmcd_conn_error(c, request_id, QMC_EINVAL,
                        "transport 1 (the shared-memory ring) without a ring: send SHM_ATTACH "
                        "first");
    return 0;
}

/* A point must fit an inline piece: a batch may always come inline. */
static int point_fits(qmcd_conn *c, uint64_t request_id, uint32_t dims)
{
    if (dims == 0 || qmcd__sess_inline_points(c, dims) > 0)
        return 1;
    qmcd_conn_error(c, request_id, QMC_ETOOBIG,
                    "a point of %u dims (%llu bytes) does not fit the client's max_frame of %u",
                    dims, (unsigned long long)dims * 8, qmcd_conn_client_max_frame(c));
    return 0;
}

/* The session a SESSION_RESUME or SESSION_CLOSE names, if it is this
 * client's (same identity, same token); else NULL, with the one answer for
 * an unknown id, another identity and a wrong token already sent. */
static qmcd_sess *named_session(qmcd_conn *c, const qmc_msg *m)
{
    const qmc_msg_session_ref *ref = &m->u.session_ref;
    qmcd_identity who;
    qmcd_conn_identity(c, &who);
    qmcd_sess *s = qmcd__sessions_find(qmcd_conn_server(c), ref->session_id, &who, ref->token);
    if (s)
        return s;
    char peer[96];
    qmcd_peer_key_name(&who.peer, peer, sizeof peer);
    qmcd_conn_error(c, m->request_id, -ENOENT,
                    "no session %llu for %s with that token (never opened, ended, expired "
                    "after session-idle-timeout-ms, or another's)",
                    (unsigned long long)ref->session_id, peer);
    return NULL;
}

static qmcd_sess_attach *attach_new(qmcd_conn *c, qmcd_sess *s, uint64_t request_id)
{
    qmcd_sess_attach *a = calloc(1, sizeof *a);
    if (!a)
        return NULL;
    a->s = s;
    a->c = c;
    s->a = a;
    qmcd_producer_attach(c, &a->p, &sess_kind, request_id);
    return a;
}

static void on_open(qmcd_conn *c, const qmc_msg *m, int fd, int64_t t0_us)
{
    (void)fd, (void)t0_us;
    qmcd_server *srv = qmcd_conn_server(c);
    const qmc_msg_session_open *o = &m->u.session_open;
    if (!version_ok(c, m->request_id, "SESSION_OPEN") ||
        !transport_ok(c, m->request_id, o->transport) ||
        !point_fits(c, m->request_id, o->spec.dims))
        return;
    qmc_session_spec spec = o->spec;
    if ((spec.part_p || spec.part_k) && qmcd_conn_version(c) < QMC_PROTO_VERSION_PARTS) {
        /* Its block sums have a message only from version 6 on. */
        qmcd_conn_error(c, m->request_id, QMC_ENOTSUP,
                        "a session of a part (%u/%u) needs protocol version %u; this "
                        "connection chose %u (offer %u in HELLO)", spec.part_k, spec.part_p,
                        QMC_PROTO_VERSION_PARTS, qmcd_conn_version(c), QMC_PROTO_VERSION_PARTS);
        return;
    }
    if (spec.dims == 0 || spec.dims > QMC_SESSION_MAX_DIMS) {
        qmcd_conn_error(c, m->request_id, spec.dims ? QMC_EDIMS : QMC_EINVAL,
                        "a session needs dims in 1..%u, not %u", QMC_SESSION_MAX_DIMS,
                        spec.dims);
        return;
    }
    /* As for INTEGRATE: the client states its budget, the server caps it. */
    if (spec.integrate.max_evals > srv->cfg.max_job_evals)
        spec.integrate.max_evals = srv->cfg.max_job_evals;
    if (spec.integrate.max_memory > srv->cfg.max_job_memory)
        spec.integrate.max_memory = srv->cfg.max_job_memory;
    memset(&spec.integrate.interrupt, 0, sizeof spec.integrate.interrupt);
    const uint64_t max_batch = largest_batch(&spec);
    /* The core's bound, and the values buffer kept here. */
    const uint64_t bytes =
        sat_add(sat_add(qmc_session_memory_bytes(&spec), sat_mul(max_batch, 8)),
                sizeof(qmcd_sess));
    qmcd_identity who;
    qmcd_conn_identity(c, &who);
    char why[512];
    int err = qmcd__sessions_admit(srv, &who, bytes, why, sizeof why);
    if (err) {
        qmcd_conn_error(c, m->request_id, err, "%s", why);
        return;
    }
    qmcd_pool_tenant *tenant;
    qmcd_sess *s = NULL;
    if (qmcd_conn_tenant(c, &tenant) != 0 || !(s = qmcd__sessions_add(srv, &who, bytes)) ||
        !attach_new(c, s, m->request_id)) {
        if (s)
            qmcd__sessions_drop(s);
        qmcd_conn_error(c, m->request_id, QMC_ENOMEM, "out of memory for a session");
        return;
    }
    s->spec = spec;
    s->task.done = task_done;
    s->max_batch = max_batch;
    s->engine_batch = engine_batch(&spec);
    s->transport = o->transport;
    s->owe_opened = 1;
    qmcd_debug("conn %llu: session %llu opening (%s, %u dims, %llu bytes)",
               (unsigned long long)qmcd_conn_id(c), (unsigned long long)s->id,
               qmc_method_name(spec.integrate.method), spec.dims, (unsigned long long)bytes);
    qmcd__sess_start_open(s, tenant);
}

/* The session of session_id attached to c, or NULL. */
static qmcd_sess *on_conn(qmcd_conn *c, uint64_t session_id)
{
    for (qmcd_producer *p = qmcd_producer_first(c); p; p = p->next)
        if (p->kind == &sess_kind && attach_of(p)->s && attach_of(p)->s->id == session_id)
            return attach_of(p)->s;
    return NULL;
}

/* Refuses a SESSION_VALUES (the session, if any, goes on; its batch's
 * values so far are dropped). */
__attribute__((format(printf, 5, 6))) static void refuse_values(qmcd_conn *c, qmcd_sess *s,
                                                               uint64_t request_id, int code,
                                                               const char *fmt, ...)
{
    char text[QMC_PROTO_MAX_MESSAGE];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    if (s)
        s->got = 0;
    qmcd_conn_server(c)->stats.session_values_refused++;
    qmcd_conn_error(c, request_id, code, "%s", text);
}

/* The ring piece v answers, still held by the client, or NULL with the
 * reason in why. */
static const qmcd_sess_piece *ring_piece(qmcd_conn *c, const qmcd_sess *s,
                                         const qmc_msg_session_values *v, char *why, size_t n)
{
    const qmcd_ring *r = qmcd_conn_ring(c);
    for (unsigned i = 0; s->ring && r && i < s->n_pieces; i++) {
        const qmcd_sess_piece *p = &s->pieces[i];
        if (p->first != v->first)
            continue;
        if (p->points != v->count || p->slot != v->slot) {
            snprintf(why, n, "the piece of batch %llu at point %llu is %u points in ring slot "
                     "%u, not %u in slot %u", (unsigned long long)s->batch.seq,
                     (unsigned long long)p->first, p->points, p->slot, v->count, v->slot);
            return NULL;
        }
        if (r->released_total >= p->handed) {
            snprintf(why, n, "ring slot %u was released (SHM_RELEASE) before its values were "
                     "sent: send SESSION_VALUES first", p->slot);
            return NULL;
        }
        return p;
    }
    snprintf(why, n, "no piece of batch %llu starts at point %llu in the ring",
             (unsigned long long)s->batch.seq, (unsigned long long)v->first);
    return NULL;
}

static void on_values(qmcd_conn *c, const qmc_msg *m, int fd, int64_t t0_us)
{
    (void)fd, (void)t0_us; /* not a request: nothing answers it unless refused */
    qmcd_server *srv = qmcd_conn_server(c);
    const qmc_msg_session_values *v = &m->u.session_values;
    if (m->request_id == 0) {
        srv->stats.malformed++;
        qmcd_conn_fail(c, 0, QMC_EPROTO, "SESSION_VALUES needs a request id of its own, not 0 "
                       "(its refusal is answered under it)");
        return;
    }
    for (qmcd_producer *p = qmcd_producer_first(c); p; p = p->next)
        if (p->request_id == m->request_id) {
            srv->stats.malformed++;
            qmcd_conn_fail(c, 0, QMC_EPROTO, "SESSION_VALUES under request id %llu, which is "
                           "in flight: its refusal would end that request; use a fresh id",
                           (unsigned long long)m->request_id);
            return;
        }
    if (!version_ok(c, m->request_id, "SESSION_VALUES"))
        return;
    qmcd_sess *s = on_conn(c, v->session_id);
    if (!s) {
        refuse_values(c, NULL, m->request_id, -ENOENT,
                      "no session %llu on this connection (never opened here, ended, expired, "
                      "or resumed on another connection)", (unsigned long long)v->session_id);
        return;
    }
    const unsigned long long id = (unsigned long long)s->id;
    if (s->stepping || !s->have_batch) {
        refuse_values(c, s, m->request_id, QMC_EINVAL,
                      s->finished ? "session %llu is done: no batch waits for values"
                                  : "session %llu is computing its next batch: no batch waits "
                                    "for values yet", id);
        return;
    }
    const qmc_session_batch *b = &s->batch;
    if (v->seq != b->seq) {
        refuse_values(c, s, m->request_id, QMC_EINVAL,
                      v->seq < b->seq ? "session %llu: batch %llu was answered already; batch "
                                        "%llu is waiting"
                                      : "session %llu: batch %llu has not been handed out; "
                                        "batch %llu is waiting",
                      id, (unsigned long long)v->seq, (unsigned long long)b->seq);
        return;
    }
    if (s->sent < b->count) {
        refuse_values(c, s, m->request_id, QMC_EINVAL,
                      "session %llu: batch %llu has not been handed out whole yet (%llu of "
                      "%zu points sent)", id, (unsigned long long)b->seq,
                      (unsigned long long)s->sent, b->count);
        return;
    }
    if (v->first != s->got) {
        refuse_values(c, s, m->request_id, QMC_EINVAL,
                      "session %llu: values from point %llu, but batch %llu waits for values "
                      "from point %llu (its values so far are dropped: send them all again)",
                      id, (unsigned long long)v->first, (unsigned long long)b->seq,
                      (unsigned long long)s->got);
        return;
    }
    if (v->count > b->count - s->got) {
        refuse_values(c, s, m->request_id, QMC_EINVAL,
                      "session %llu: %u values from point %llu run past batch %llu's %zu "
                      "points", id, v->count, (unsigned long long)v->first,
                      (unsigned long long)b->seq, b->count);
        return;
    }
    const uint8_t *data = v->data;
    if (v->transport == QMC_TRANSPORT_SHM) {
        char why[256];
        const qmcd_sess_piece *p = ring_piece(c, s, v, why, sizeof why);
        if (!p) {
            refuse_values(c, s, m->request_id, QMC_EINVAL, "session %llu: %s", id, why);
            return;
        }
        const qmcd_ring *r = qmcd_conn_ring(c);
        data = r->base + (size_t)p->slot * r->slot_bytes + (size_t)p->points * s->spec.dims * 8;
    }
    qmcd_pool_tenant *tenant;
    if (qmcd_conn_tenant(c, &tenant) != 0) {
        refuse_values(c, s, m->request_id, QMC_ENOMEM, "session %llu: out of memory", id);
        return;
    }
    /* The whole batch's values in one frame, and a step that runs now,
     * here: it reads them where they are (the frame, or the ring slot -
     * which the client cannot get back before this handler returns).
     * Otherwise they are copied out now: the slot goes back to the client
     * as soon as it likes.  NaN or infinite values are counted, never
     * refused (the integrator flags them). */
    const double *in_place = NULL;
    if (v->count == b->count && qmcd__sess_tell_now(s) &&
        ((uintptr_t)data & (sizeof(double) - 1)) == 0)
        in_place = (const double *)(const void *)data;
    if (!in_place && s->vals_cap < b->count) {
        double *nv = realloc(s->vals, b->count * sizeof *nv);
        if (!nv) {
            refuse_values(c, s, m->request_id, QMC_ENOMEM, "session %llu: out of memory", id);
            return;
        }
        s->vals = nv;
        s->vals_cap = b->count;
    }
    const double *got = in_place;
    if (!got) {
        memcpy(s->vals + s->got, data, (size_t)v->count * 8);
        got = s->vals + s->got;
    }
    uint64_t nonfinite = 0;
    for (uint32_t i = 0; i < v->count; i++)
        nonfinite += !isfinite(got[i]);
    srv->stats.session_nonfinite += nonfinite;
    s->got += v->count;
    if (s->got < b->count)
        return;
    srv->stats.session_batches++;
    srv->stats.session_values += b->count;
    /* A step run here, for a client that takes batches through its ring:
     * the next batch is assembled straight into the ring's next free slot
     * (no copy of its points), and sent from here, before any other
     * producer of the connection could take that slot. */
    uint32_t slot = 0;
    size_t next_points = 0;
    double *next = in_place ? qmcd__sess_next_slot(c, s, &slot, &next_points) : NULL;
    if (!qmcd__sess_start_tell(s, tenant, in_place, next, next_points))
        return; /* on the pool: task_done */
    step_done(s, 0); /* the connection pumps after this request */
    if (next && s->a && !s->stepping && s->have_batch && s->batch.points == next)
        qmcd__sess_send_in_slot(c, s->a, slot);
}

static void on_resume(qmcd_conn *c, const qmc_msg *m, int fd, int64_t t0_us)
{
    (void)fd, (void)t0_us;
    qmcd_server *srv = qmcd_conn_server(c);
    const qmc_msg_session_ref *ref = &m->u.session_ref;
    if (!version_ok(c, m->request_id, "SESSION_RESUME") ||
        !transport_ok(c, m->request_id, ref->transport))
        return;
    qmcd_sess *s = named_session(c, m);
    if (!s)
        return;
    if (!point_fits(c, m->request_id, s->spec.dims))
        return;
    if (s->spec.part_p && qmcd_conn_version(c) < QMC_PROTO_VERSION_PARTS) {
        /* Its answer, block sums, has no message before version 6. */
        qmcd_conn_error(c, m->request_id, QMC_ENOTSUP,
                        "session %llu is a part, whose answer needs protocol version %u; this "
                        "connection chose %u", (unsigned long long)s->id,
                        QMC_PROTO_VERSION_PARTS, qmcd_conn_version(c));
        return;
    }
    qmcd_sess_attach *old = s->a;
    if (old && old->c == c) {
        qmcd_conn_error(c, m->request_id, QMC_EINVAL,
                        "session %llu is served on this connection already (request %llu)",
                        (unsigned long long)s->id, (unsigned long long)old->p.request_id);
        return;
    }
    qmcd_sess_attach *a = calloc(1, sizeof *a);
    if (!a) {
        qmcd_conn_error(c, m->request_id, QMC_ENOMEM, "out of memory");
        return;
    }
    if (old) {
        /* Taken over: the old connection's request ends here. */
        (void)qmcd_conn_error(old->c, old->p.request_id, -ECANCELED,
                              "session %llu was resumed on another connection",
                              (unsigned long long)s->id);
        old->s = NULL;
        home_batch(s); /* out of the old connection's ring */
        qmcd_conn_kick(old->c); /* its pump lets the attachment go */
    } else {
        qmcd__sessions_unpark(s);
    }
    a->s = s;
    a->c = c;
    s->a = a;
    qmcd_producer_attach(c, &a->p, &sess_kind, m->request_id);
    rewind_batch(s);
    s->transport = ref->transport;
    s->owe_opened = 1;
    s->owe_report = 1;
    srv->stats.sessions_resumed++;
    qmcd_debug("conn %llu: session %llu resumed%s", (unsigned long long)qmcd_conn_id(c),
               (unsigned long long)s->id, old ? " (taken over)" : "");
}

static void on_close(qmcd_conn *c, const qmc_msg *m, int fd, int64_t t0_us)
{
    (void)fd;
    qmcd_server *srv = qmcd_conn_server(c);
    if (!version_ok(c, m->request_id, "SESSION_CLOSE"))
        return;
    qmcd_sess *s = named_session(c, m);
    if (!s)
        return;
    qmc_msg r;
    qmcd__sess_report_of(s, &r, m->request_id);
    qmcd_sess_attach *a = s->a;
    if (a) {
        /* Its own request ends first, so that a client reads it before the
         * answer to the close. */
        (void)qmcd_conn_error(a->c, a->p.request_id, -ECANCELED,
                              "session %llu closed by SESSION_CLOSE", (unsigned long long)s->id);
        a->s = NULL;
        if (a->c != c)
            qmcd_conn_kick(a->c);
    }
    srv->stats.sessions_closed++;
    qmcd__sessions_drop(s);
    if (qmcd_conn_send(c, &r) == 0)
        qmcd_answered(srv, t0_us);
}

static int sessions_open(qmcd_server *srv)
{
    return qmcd__sessions_open(srv);
}

static void sessions_close(qmcd_server *srv)
{
    qmcd__sessions_close(srv);
}

const qmcd_module qmcd_session_module = {
    .name = "session",
    .routes = (const qmcd_route[]){
        {QMC_MSG_SESSION_OPEN, QMCD_ROUTE_REQUEST | QMCD_ROUTE_STARTS, on_open},
        {QMC_MSG_SESSION_VALUES, 0, on_values},
        {QMC_MSG_SESSION_RESUME, QMCD_ROUTE_REQUEST | QMCD_ROUTE_STARTS, on_resume},
        {QMC_MSG_SESSION_CLOSE, QMCD_ROUTE_REQUEST, on_close},
        {0, 0, NULL},
    },
    .open = sessions_open,
    .close = sessions_close,
};
