/*
 * session.c - integration sessions over a connection (PROTOCOL.md section
 * 6.21): open and resume, the batches as they arrive (inline pieces, or
 * ring slots), the values sent back (from the caller's buffer, or written
 * into the batch's slot), the reports, a part's sums (session_part.c
 * gathers them), the result, close; and the callback convenience built
 * from them.
 *
 * Frames for a session may arrive while the client waits for something
 * else (a PONG, a job's result): every frame goes through
 * qmc__client_file_session, which moves the session's state on, so the
 * calls here only read frames until the state they wait for is reached.
 * A batch through the ring stays in its slots (pinned: conn.c releases
 * nothing while any is) until the server has taken its values, so the
 * caller can read the points and write the values in place.
 *
 * Must not: trust a frame's sizes before checking them against the
 * session (dims, the OPENED max_batch, the ring), keep a pointer into the
 * ring once the connection is gone, or print.
 */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "client_impl.h"

enum { ST_OPENING, ST_WAITING, ST_READY, ST_TELLING, ST_DONE };

/* A piece of a batch that came through a ring slot. */
typedef struct piece {
    uint64_t first;
    uint32_t points;
    uint32_t slot;
} piece;

struct qmc_client_session {
    qmc_client *c;                 /* NULL once its client is closed */
    qmc_client_session *next;      /* c->sessions */
    int abandoned;                 /* freed by the caller, its request still open */
    int state;                     /* ST_* */
    uint64_t request_id;           /* its SESSION_OPEN's or SESSION_RESUME's */
    uint64_t session_id;
    uint8_t token[QMC_PROTO_SESSION_TOKEN_BYTES];
    uint32_t dims;
    uint64_t max_batch;
    /* The batch arriving or waiting. */
    uint64_t seq, count, got;
    int ring;                      /* its pieces are in ring slots */
    piece pieces[QMC_PROTO_SHM_MAX_SLOTS];
    unsigned n_pieces;
    uint32_t pinned;               /* of c's ring slots, this session's */
    double *points, *values;       /* own buffers, cap points */
    uint64_t cap;
    const double *view_points;     /* what next hands out */
    double *view_values;
    int have_batch_seq;            /* a batch arrived: the next must follow it */
    uint64_t last_seq;
    /* The values of the last tell: request ids [v_lo, v_hi]. */
    uint64_t v_lo, v_hi;
    int refusal;                   /* the first refusal's code, or 0 */
    uint64_t refusals;             /* refusals still to come */
    char refusal_msg[QMC_PROTO_MAX_MESSAGE + 1];
    uint64_t reports;              /* SESSION_REPORTs received */
    qmc_session_report report;
    qmc__client_part part;         /* a part's block sums (session_part.c) */
    /* The end. */
    int err;
    char message[QMC_PROTO_MAX_MESSAGE + 1];
    qmc_client_result result;
};

static int host_le(void)
{
    const uint16_t probe = 1;
    return *(const uint8_t *)&probe == 1;
}

/* n doubles from little-endian bytes. */
static void from_le(double *dst, const uint8_t *src, size_t n)
{
    if (host_le()) {
        memcpy(dst, src, n * sizeof *dst);
        return;
    }
    for (size_t i = 0; i < n; i++) {
        uint64_t b = 0;
        for (int k = 7; k >= 0; k--)
            b = b << 8 | src[8 * i + (size_t)k];
        memcpy(&dst[i], &b, 8);
    }
}

/* n doubles as little-endian bytes. */
static void to_le(uint8_t *dst, const double *src, size_t n)
{
    if (host_le()) {
        memmove(dst, src, n * sizeof *src);
        return;
    }
    for (size_t i = 0; i < n; i++) {
        uint64_t b;
        memcpy(&b, &src[i], 8);
        for (int k = 0; k < 8; k++)
            dst[8 * i + (size_t)k] = (uint8_t)(b >> (8 * k));
    }
}

/* ---- the handle and its slots --------------------------------------------------- */

static void unpin(qmc_client_session *s)
{
    if (s->c && s->pinned) {
        s->c->ring.pinned -= s->pinned < s->c->ring.pinned ? s->pinned : s->c->ring.pinned;
    }
    s->pinned = 0;
    s->view_points = NULL;
    s->view_values = NULL;
}

static void unlink_session(qmc_client_session *s)
{
    if (!s->c)
        return;
    for (qmc_client_session **l = &s->c->sessions; *l; l = &(*l)->next)
        if (*l == s) {
            *l = s->next;
            break;
        }
    s->c = NULL;
}

static void destroy(qmc_client_session *s)
{
    unpin(s);
    unlink_session(s);
    qmc__client_part_free(&s->part);
    free(s->points);
    free(s->values);
    free(s);
}

void qmc__client_sessions_detach(qmc_client *c)
{
    while (c->sessions) {
        qmc_client_session *s = c->sessions;
        c->sessions = s->next;
        s->next = NULL;
        s->pinned = 0; /* the ring goes with the client */
        s->view_points = NULL;
        s->view_values = NULL;
        s->c = NULL;
        if (s->abandoned)
            destroy(s);
    }
}

/* Room in the own buffers for count points of the session's dims. */
static int reserve(qmc_client_session *s, uint64_t count)
{
    if (count <= s->cap)
        return 0;
    if (count > SIZE_MAX / sizeof(double) / (s->dims + 1ull))
        return QMC_ENOMEM;
    double *p = realloc(s->points, (size_t)count * s->dims * sizeof *p);
    if (!p)
        return QMC_ENOMEM;
    s->points = p;
    double *v = realloc(s->values, (size_t)count * sizeof *v);
    if (!v)
        return QMC_ENOMEM;
    s->values = v;
    s->cap = count;
    return 0;
}

/* ---- filing the frames ------------------------------------------------------------ */

static int bad(qmc_client *c, const qmc_client_session *s, const char *what)
{
    return qmc__client_break(c, QMC_EPROTO, "protocol error: session %llu: %s",
                             (unsigned long long)s->session_id, what);
}

static void end_with(qmc_client_session *s, int err, qmc_str msg)
{
    s->err = err;
    qmc__client_copy_str(s->message, sizeof s->message, msg);
    if (s->message[0] == '\0' && err)
        snprintf(s->message, sizeof s->message, "%s", qmc_strerror(err));
    s->state = ST_DONE;
    unpin(s);
}

/* A SESSION_BATCH piece: checked, then copied or left in its slot. */
static int file_batch(qmc_client *c, qmc_client_session *s, const qmc_msg_session_batch *b)
{
    if (s->state != ST_WAITING)
        return bad(c, s, "a batch while none was expected");
    if (b->dims != s->dims)
        return bad(c, s, "a batch of other dims than the session's");
    const int ring = b->transport == QMC_TRANSPORT_SHM;
    if (s->got == 0) {
        if (b->first != 0 || b->count == 0 || b->count > s->max_batch ||
            (s->have_batch_seq && b->seq != s->last_seq && b->seq != s->last_seq + 1))
            return bad(c, s, "a batch that does not follow the last one, or larger than its "
                             "max_batch");
        s->seq = b->seq;
        s->count = b->count;
        s->ring = ring;
        s->n_pieces = 0;
        s->view_points = NULL;
        s->view_values = NULL;
    } else if (b->seq != s->seq || b->count != s->count || b->first != s->got ||
               ring != s->ring) {
        return bad(c, s, "a batch piece out of order");
    }
    if (b->points > s->count - s->got)
        return bad(c, s, "a batch piece past its batch");
    const int whole = ring && b->first == 0 && b->points == s->count && host_le();
    if (!whole) {
        int err = reserve(s, s->count);
        if (err)
            return qmc__client_break(c, err, "session %llu: out of memory for a batch of %llu "
                                     "points", (unsigned long long)s->session_id,
                                     (unsigned long long)s->count);
    }
    const uint8_t *data = b->data;
    if (ring) {
        qmc__client_ring *r = &c->ring;
        if (!r->base || b->slot != r->next || r->held >= r->slots ||
            (uint64_t)b->data_len + 8ull * b->points > r->slot_bytes ||
            s->n_pieces >= QMC_PROTO_SHM_MAX_SLOTS)
            return bad(c, s, "a batch piece in a ring slot that is not the next one, or "
                             "larger than a slot");
        r->next = b->slot + 1 == r->slots ? 0 : b->slot + 1;
        r->held++;
        r->pinned++;
        s->pinned++;
        s->pieces[s->n_pieces++] = (piece){b->first, b->points, b->slot};
        data = r->base + (size_t)b->slot * r->slot_bytes;
        if (whole) {
            s->view_points = (const double *)(const void *)data;
            s->view_values = (double *)(void *)(r->base + (size_t)b->slot * r->slot_bytes +
                                                b->data_len);
        }
    }
    if (!whole)
        from_le(s->points + s->got * s->dims, data, (size_t)b->points * s->dims);
    s->got += b->points;
    if (s->got == s->count) {
        s->state = ST_READY;
        s->have_batch_seq = 1;
        s->last_seq = s->seq;
        if (!whole) {
            s->view_points = s->points;
            s->view_values = s->values;
        }
    }
    return 1;
}

/* A frame of the session's own request. */
static int file_own(qmc_client *c, qmc_client_session *s, const qmc_msg *m)
{
    switch (m->type) {
    case QMC_MSG_SESSION_OPENED: {
        const qmc_msg_session_opened *o = &m->u.session_opened;
        if (s->state != ST_OPENING || o->dims == 0 || o->max_batch == 0 ||
            (s->dims && o->dims != s->dims))
            return bad(c, s, "SESSION_OPENED out of turn, or for other dims");
        s->session_id = o->session_id;
        memcpy(s->token, o->token, sizeof s->token);
        s->dims = o->dims;
        s->max_batch = o->max_batch;
        s->state = ST_WAITING;
        return 1;
    }
    case QMC_MSG_SESSION_BATCH:
        return file_batch(c, s, &m->u.session_batch);
    case QMC_MSG_SESSION_REPORT:
        if (s->state == ST_OPENING || m->u.session_report.session_id != s->session_id)
            return bad(c, s, "a report out of turn");
        s->report = m->u.session_report.report;
        s->reports++;
        if (s->state == ST_TELLING) {
            /* The values are in: the batch's slots may go back. */
            unpin(s);
            s->got = 0;
            s->state = ST_WAITING;
            /* And go back now, once they are half the ring: a server that
             * tells ahead sends the next batch right behind this report,
             * so the buffer is never found empty with nothing pinned (when
             * conn.c releases), and without this the ring would fill and
             * every few batches wait for a release, and a copy, in turn.
             * Every slot held is handled: this batch's and older ones (the
             * next batch's frames come after this report). */
            if (c->ring.held > c->ring.slots / 2 && !c->ring.pinned) {
                int err = qmc__client_shm_release(c);
                if (err)
                    return err;
            }
        }
        return 1;
    case QMC_MSG_SESSION_PART:
    case QMC_MSG_SESSION_PART_SUMS: {
        /* After the last report, with no batch on its way. */
        char why[128];
        int err = s->state == ST_WAITING && s->got == 0
                      ? qmc__client_part_file(&s->part, s->session_id, m, why, sizeof why)
                      : (snprintf(why, sizeof why, "a part's sums while the session runs"),
                         QMC_EPROTO);
        if (err)
            return qmc__client_break(c, err, "%ssession %llu: %s",
                                     err == QMC_EPROTO ? "protocol error: " : "",
                                     (unsigned long long)s->session_id, why);
        return 1;
    }
    case QMC_MSG_SESSION_RESULT: {
        char why[128];
        if (s->state == ST_OPENING || m->u.result.job_id != s->session_id)
            return bad(c, s, "a result out of turn");
        if (qmc__client_part_end(&s->part, why, sizeof why) != 0)
            return bad(c, s, why);
        qmc__client_copy_result(&s->result, &m->u.result);
        end_with(s, 0, (qmc_str){NULL, 0});
        return 1;
    }
    case QMC_MSG_ERROR:
        end_with(s, m->u.error.code < 0 ? m->u.error.code : QMC_EPROTO, m->u.error.message);
        return 1;
    default:
        return bad(c, s, "a frame that is not a session's");
    }
}

int qmc__client_file_session(qmc_client *c, const qmc_msg *m)
{
    for (qmc_client_session *s = c->sessions; s; s = s->next) {
        if (m->request_id == s->request_id && s->state != ST_DONE) {
            int r = file_own(c, s, m);
            if (r > 0 && s->abandoned && s->state == ST_DONE)
                destroy(s); /* its request ended: nothing more comes for it */
            return r;
        }
        if (m->type == QMC_MSG_ERROR && s->v_hi && m->request_id >= s->v_lo &&
            m->request_id <= s->v_hi) {
            /* A refusal of values we sent: the first says why, and every
             * later frame of the same tell is refused too (the batch
             * waits for its values from the start again). */
            if (!s->refusal) {
                s->refusal = m->u.error.code < 0 ? m->u.error.code : QMC_EPROTO;
                qmc__client_copy_str(s->refusal_msg, sizeof s->refusal_msg, m->u.error.message);
                s->refusals = s->v_hi - m->request_id + 1;
            }
            if (s->refusals)
                s->refusals--;
            return 1;
        }
    }
    return 0;
}

/* Reads one frame and files it wherever it belongs. */
static int pump(qmc_client *c, uint64_t waiting_for)
{
    qmc_msg m;
    int err = qmc__client_read(c, qmc__client_deadline(c), 0, &m);
    if (err)
        return err;
    return qmc__client_other(c, &m, waiting_for);
}

/* ---- opening ------------------------------------------------------------------------ */

static int usable(qmc_client *c)
{
    int err = qmc__client_ready(c);
    if (err)
        return err;
    if (c->version < QMC_PROTO_VERSION_SESSIONS)
        return qmc__client_fail(c, QMC_ENOTSUP, "sessions: the server speaks protocol version "
                                "%u; sessions need %u", c->version,
                                QMC_PROTO_VERSION_SESSIONS);
    return 0;
}

/* The ring a session's batches fit in whole: the largest batch the
 * sampling engine assembles (as core/session.c sizes it), points and
 * values, in one slot when it can, three slots (one in use, one being
 * filled, one spare). */
static void ring_for(const qmc_session_spec *spec, uint32_t *slots, uint32_t *slot_bytes)
{
    const uint64_t row = ((uint64_t)spec->dims + 1) * sizeof(double);
    uint64_t pts = spec->max_batch;
    if (!pts) {
        uint64_t fit = QMC_SESSION_BATCH_BYTES / row;
        pts = fit < QMC_SESSION_MAX_BATCH ? (fit ? fit : 1) : QMC_SESSION_MAX_BATCH;
    }
    uint64_t bytes = pts > UINT64_MAX / row ? UINT64_MAX : pts * row;
    uint64_t slot = bytes < QMC_PROTO_SHM_MIN_SLOT_BYTES ? QMC_PROTO_SHM_MIN_SLOT_BYTES : bytes;
    if (slot > QMC_PROTO_SHM_MAX_SLOT_BYTES)
        slot = QMC_PROTO_SHM_MAX_SLOT_BYTES;
    slot = (slot + QMC_PROTO_SHM_SLOT_ALIGN - 1) / QMC_PROTO_SHM_SLOT_ALIGN *
           QMC_PROTO_SHM_SLOT_ALIGN;
    uint64_t n = bytes > slot ? (bytes + slot - 1) / slot + 1 : 3;
    *slots = n > QMC_PROTO_SHM_MAX_SLOTS ? QMC_PROTO_SHM_MAX_SLOTS : (uint32_t)n;
    *slot_bytes = (uint32_t)slot;
}

static int is_sampling_or_auto(qmc_method m)
{
    return m == QMC_METHOD_AUTO || m == QMC_METHOD_MC || m == QMC_METHOD_STRATIFIED ||
           m == QMC_METHOD_LHS || m == QMC_METHOD_QMC || m == QMC_METHOD_RQMC;
}

/* Sends m (SESSION_OPEN or SESSION_RESUME) as a new session's request and
 * reads until SESSION_OPENED (0, *out) or its refusal. */
static int start(qmc_client *c, qmc_msg *m, uint32_t dims, qmc_client_session **out)
{
    qmc_client_session *s = calloc(1, sizeof *s);
    if (!s)
        return qmc__client_fail(c, QMC_ENOMEM, "sessions: out of memory");
    s->dims = dims;
    int err = qmc__client_send(c, m, &s->request_id);
    if (err) {
        free(s);
        return err;
    }
    s->c = c;
    s->state = ST_OPENING;
    s->next = c->sessions;
    c->sessions = s;
    while (s->state == ST_OPENING && err == 0)
        err = pump(c, s->request_id);
    if (!err && s->state == ST_DONE) {
        err = s->err;
        qmc__client_fail(c, err, "%s", s->message);
    }
    if (err) {
        destroy(s);
        return err;
    }
    c->message[0] = '\0';
    *out = s;
    return 0;
}

int qmc_client_session_open(qmc_client *c, const qmc_session_spec *spec,
                            qmc_client_session **out)
{
    *out = NULL;
    int err = usable(c);
    if (err)
        return err;
    if (!spec)
        return qmc__client_fail(c, QMC_EINVAL, "sessions: no spec");
    /* Sampling batches are large: through a ring sized for them, on a
     * Unix socket, if the client has none yet and the server takes it. */
    if (is_sampling_or_auto(spec->integrate.method) && spec->dims) {
        uint32_t slots, slot_bytes;
        ring_for(spec, &slots, &slot_bytes);
        if ((err = qmc__client_shm_attach_sized(c, slots, slot_bytes)) != 0)
            return err;
    }
    qmc_msg m;
    memset(&m, 0, sizeof m);
    m.type = QMC_MSG_SESSION_OPEN;
    m.u.session_open.spec = *spec;
    memset(&m.u.session_open.spec.integrate.interrupt, 0,
           sizeof m.u.session_open.spec.integrate.interrupt);
    m.u.session_open.transport = c->ring.base ? QMC_TRANSPORT_SHM : QMC_TRANSPORT_INLINE;
    err = start(c, &m, spec->dims, out);
    if (err == 0) {
        /* Its sums come after its last report, long after OPENED. */
        (*out)->part.part_k = spec->part_k;
        (*out)->part.part_p = spec->part_p;
    }
    return err;
}

int qmc_client_session_resume(qmc_client *c, const qmc_client_session_ticket *t,
                              qmc_client_session **out)
{
    *out = NULL;
    int err = usable(c);
    if (err)
        return err;
    if (!t)
        return qmc__client_fail(c, QMC_EINVAL, "sessions: no ticket");
    qmc_msg m;
    memset(&m, 0, sizeof m);
    m.type = QMC_MSG_SESSION_RESUME;
    m.u.session_ref.session_id = t->session_id;
    memcpy(m.u.session_ref.token, t->token, sizeof m.u.session_ref.token);
    m.u.session_ref.transport = c->ring.base ? QMC_TRANSPORT_SHM : QMC_TRANSPORT_INLINE;
    return start(c, &m, 0, out);
}

void qmc_client_session_ticket_get(const qmc_client_session *s, qmc_client_session_ticket *out)
{
    memset(out, 0, sizeof *out);
    if (!s)
        return;
    out->session_id = s->session_id;
    memcpy(out->token, s->token, sizeof out->token);
}

/* ---- batches and values --------------------------------------------------------------- */

static int connected(qmc_client_session *s)
{
    if (!s || !s->c)
        return -ENOTCONN;
    if (s->c->fd < 0) {
        /* The connection broke under it: its slots went with the ring. */
        s->pinned = 0;
        s->view_points = NULL;
        s->view_values = NULL;
        return qmc__client_fail(s->c, -ENOTCONN, "session %llu: the connection is gone; "
                                "resume the session on a new one",
                                (unsigned long long)s->session_id);
    }
    s->c->message[0] = '\0';
    return 0;
}

int qmc_client_session_next(qmc_client_session *s, qmc_session_batch *batch)
{
    memset(batch, 0, sizeof *batch);
    int err = connected(s);
    if (err)
        return err;
    batch->dims = s->dims;
    while (err == 0 && s->state != ST_READY && s->state != ST_DONE)
        err = pump(s->c, s->request_id);
    if (err)
        return err;
    if (s->state == ST_DONE) {
        /* Ended by the server's answer; an ERROR that ends it running
         * (closed elsewhere, shut down) is a failure to the caller. */
        batch->end = s->err && s->report.end == QMC_SESSION_RUNNING ? QMC_SESSION_FAILED
                                                                     : s->report.end;
        return 0;
    }
    batch->seq = s->seq;
    batch->count = (size_t)s->count;
    batch->points = s->view_points;
    batch->end = QMC_SESSION_RUNNING;
    return 0;
}

double *qmc_client_session_values(qmc_client_session *s)
{
    return s && s->c && s->c->fd >= 0 && s->state == ST_READY ? s->view_values : NULL;
}

/* The values through the ring: into each piece's slot, after its points,
 * then one SESSION_VALUES per piece. */
static int send_ring(qmc_client_session *s, const double *values)
{
    qmc_client *c = s->c;
    for (unsigned i = 0; i < s->n_pieces; i++) {
        const piece *p = &s->pieces[i];
        uint8_t *dst = c->ring.base + (size_t)p->slot * c->ring.slot_bytes +
                       (size_t)p->points * s->dims * 8;
        if ((const void *)dst != (const void *)(values + p->first))
            to_le(dst, values + p->first, p->points);
        qmc_msg m;
        memset(&m, 0, sizeof m);
        m.type = QMC_MSG_SESSION_VALUES;
        m.request_id = c->next_request_id++;
        m.u.session_values.session_id = s->session_id;
        m.u.session_values.seq = s->seq;
        m.u.session_values.first = p->first;
        m.u.session_values.count = p->points;
        m.u.session_values.transport = QMC_TRANSPORT_SHM;
        m.u.session_values.slot = p->slot;
        if (i == 0)
            s->v_lo = m.request_id;
        s->v_hi = m.request_id;
        int err = qmc__client_send_frame(c, &m, -1);
        if (err)
            return err;
    }
    return 0;
}

/* The values inline, in frames the server's max_frame takes, each sent
 * from where the values are (a zero-copy prefix and the data). */
static int send_inline(qmc_client_session *s, const double *values)
{
    qmc_client *c = s->c;
    const uint8_t *data = (const uint8_t *)values;
    if (!host_le()) {
        to_le((uint8_t *)s->values, values, (size_t)s->count);
        data = (const uint8_t *)s->values;
    }
    uint64_t per = ((uint64_t)c->max_frame - 40) / 8;
    if (per > QMC_PROTO_SESSION_MAX_VALUES)
        per = QMC_PROTO_SESSION_MAX_VALUES;
    if (per == 0)
        return qmc__client_break(c, QMC_EPROTO, "the server's max_frame (%u) holds no value",
                                 c->max_frame);
    for (uint64_t at = 0; at < s->count; at += per) {
        qmc_msg_session_values v;
        memset(&v, 0, sizeof v);
        v.session_id = s->session_id;
        v.seq = s->seq;
        v.first = at;
        v.count = (uint32_t)(s->count - at < per ? s->count - at : per);
        v.transport = QMC_TRANSPORT_INLINE;
        v.data_len = v.count * 8;
        const uint64_t id = c->next_request_id++;
        uint8_t head[QMC_PROTO_HEADER_BYTES + 64];
        int n = qmc_proto_encode_session_values_prefix(id, &v, head, sizeof head);
        if (n < 0)
            return qmc__client_fail(c, n, "session %llu: cannot encode values: %s",
                                    (unsigned long long)s->session_id, qmc_strerror(n));
        if (at == 0)
            s->v_lo = id;
        s->v_hi = id;
        int err = qmc__client_send_parts(c, head, (size_t)n, data + 8 * at, v.data_len,
                                         "SESSION_VALUES");
        if (err)
            return err;
    }
    return 0;
}

int qmc_client_session_tell(qmc_client_session *s, uint64_t seq, const double *values,
                            size_t count)
{
    int err = connected(s);
    if (err)
        return err;
    qmc_client *c = s->c;
    if (s->state != ST_READY)
        return qmc__client_fail(c, QMC_EINVAL, "session %llu: no batch is waiting for values "
                                "(ask for it with qmc_client_session_next)",
                                (unsigned long long)s->session_id);
    if (seq != s->seq || count != s->count || !values)
        return qmc__client_fail(c, QMC_EINVAL, "session %llu: batch %llu of %llu points is "
                                "waiting; got %zu values for batch %llu",
                                (unsigned long long)s->session_id, (unsigned long long)s->seq,
                                (unsigned long long)s->count, count, (unsigned long long)seq);
    s->refusal = 0;
    s->refusals = 0;
    const uint64_t reports = s->reports;
    err = s->ring ? send_ring(s, values) : send_inline(s, values);
    if (err)
        return err;
    s->state = ST_TELLING;
    /* Until the report on these values, or every refusal of them. */
    while (err == 0 && s->state == ST_TELLING && s->reports == reports &&
           !(s->refusal && s->refusals == 0))
        err = pump(c, s->request_id);
    s->v_lo = s->v_hi = 0;
    if (err)
        return err;
    if (s->state == ST_TELLING) {
        /* Refused: the batch still waits, in the same slots. */
        s->state = ST_READY;
        return qmc__client_fail(c, s->refusal, "%s", s->refusal_msg);
    }
    if (s->state == ST_DONE && s->err && s->reports == reports)
        return qmc__client_fail(c, s->err, "%s", s->message);
    return 0;
}

void qmc_client_session_report(const qmc_client_session *s, qmc_session_report *out)
{
    memset(out, 0, sizeof *out);
    if (s)
        *out = s->report;
}

int qmc_client_session_result(const qmc_client_session *s, qmc_client_result *out)
{
    memset(out, 0, sizeof *out);
    if (!s)
        return QMC_EINVAL;
    if (s->state != ST_DONE)
        return QMC_EAGAIN;
    if (s->err) {
        if (s->c)
            qmc__client_fail(s->c, s->err, "%s", s->message);
        return s->err;
    }
    *out = s->result;
    return 0;
}

int qmc_client_session_part(const qmc_client_session *s, qmc_session_part_sums *out)
{
    memset(out, 0, sizeof *out);
    if (!s)
        return QMC_EINVAL;
    if (s->state != ST_DONE)
        return QMC_EAGAIN;
    if (s->err)
        return s->err;
    return qmc__client_part_get(&s->part, out);
}

/* ---- the end ------------------------------------------------------------------------- */

int qmc_client_session_close(qmc_client_session *s)
{
    if (!s)
        return 0;
    int err = 0;
    qmc_client *c = s->c;
    if (c && c->fd >= 0 && s->state != ST_DONE && s->state != ST_OPENING) {
        qmc_msg m;
        memset(&m, 0, sizeof m);
        m.type = QMC_MSG_SESSION_CLOSE;
        m.u.session_ref.session_id = s->session_id;
        memcpy(m.u.session_ref.token, s->token, sizeof s->token);
        uint64_t id;
        err = qmc__client_send(c, &m, &id);
        /* The session's own request ends (ERROR -ECANCELED, filed) before
         * the close is answered. */
        if (!err)
            err = qmc__client_await(c, id, qmc__client_deadline(c), 0, &m);
        if (!err && m.type == QMC_MSG_ERROR)
            err = qmc__client_server_error(c, &m);
        else if (!err && m.type != QMC_MSG_SESSION_REPORT)
            err = qmc__client_break(c, QMC_EPROTO, "protocol error: %s in answer to "
                                    "SESSION_CLOSE", qmc_msg_type_name(m.type));
    }
    destroy(s);
    return err;
}

void qmc_client_session_free(qmc_client_session *s)
{
    if (!s)
        return;
    if (s->c && s->c->fd >= 0 && s->state != ST_DONE) {
        /* Left to the server: frames still coming on its request are
         * dropped until the request ends, or the client closes. */
        unpin(s);
        free(s->points);
        free(s->values);
        s->points = s->values = NULL;
        s->cap = 0;
        s->abandoned = 1;
        return;
    }
    destroy(s);
}

int qmc_client_session_run(qmc_client *c, const qmc_session_spec *spec,
                           qmc_client_integrand_fn f, void *ctx, qmc_client_result *out)
{
    memset(out, 0, sizeof *out);
    if (!f)
        return qmc__client_fail(c, QMC_EINVAL, "sessions: no integrand");
    qmc_client_session *s;
    int err = qmc_client_session_open(c, spec, &s);
    if (err)
        return err;
    for (;;) {
        qmc_session_batch b;
        if ((err = qmc_client_session_next(s, &b)) != 0 || b.count == 0)
            break;
        double *v = qmc_client_session_values(s);
        int r = f(ctx, b.points, b.count, b.dims, v);
        if (r) {
            char text[QMC_CLIENT_MESSAGE_BYTES];
            snprintf(text, sizeof text, "session %llu: the integrand stopped it (%d) at "
                     "batch %llu", (unsigned long long)s->session_id, r,
                     (unsigned long long)b.seq);
            (void)qmc_client_session_close(s);
            return qmc__client_fail(c, r, "%s", text);
        }
        if ((err = qmc_client_session_tell(s, b.seq, v, b.count)) != 0)
            break;
    }
    if (err == 0)
        err = qmc_client_session_result(s, out);
    if (err) {
        char text[QMC_CLIENT_MESSAGE_BYTES];
        memcpy(text, c->message, sizeof text);
        qmc_client_session_free(s);
        return qmc__client_fail(c, err, "%s", text);
    }
    qmc_client_session_free(s);
    return 0;
}
