/*
 * session_send.c - how a session's batches and reports go out on its
 * connection (session.h): a batch in pieces, inline or through the
 * client's ring, and a batch assembled straight into a ring slot.
 *
 * Must not: read sockets, reach into a connection's fields
 * (conn_services.h is the door), take values, or call into session.c
 * (which calls here).
 */
#define _GNU_SOURCE
#include <stdint.h>
#include <string.h>

#include "ring.h"
#include "session.h"

/* Whole points in one inline piece: a chunk's bytes and the client's
 * max_frame bound it (0: not even one point fits). */
uint64_t qmcd__sess_inline_points(const qmcd_conn *c, uint32_t dims)
{
    uint64_t room = qmcd_conn_client_max_frame(c);
    room = room > 44 ? room - 44 : 0; /* SESSION_BATCH's fixed fields */
    if (room > QMC_PROTO_CHUNK_BYTES)
        room = QMC_PROTO_CHUNK_BYTES;
    return room / ((uint64_t)dims * 8);
}

void qmcd__sess_report_of(const qmcd_sess *s, qmc_msg *r, uint64_t request_id)
{
    memset(r, 0, sizeof *r);
    r->type = QMC_MSG_SESSION_REPORT;
    r->request_id = request_id;
    r->u.session_report.session_id = s->id;
    if (s->core) {
        qmc_session_status(s->core, &r->u.session_report.report);
    } else {
        qmc_result_init(&r->u.session_report.report.running);
        r->u.session_report.report.running.dims = s->spec.dims;
    }
}

/* How the waiting batch travels, decided at its first piece: the ring
 * when the client asked for it, has one, and the batch's pieces (points
 * and their values) fit in it at once - the client needs every point
 * before it answers, and holds the slots until then. */
int qmcd__sess_uses_ring(const qmcd_conn *c, const qmcd_sess *s)
{
    const qmcd_ring *r = qmcd_conn_ring(c);
    if (s->transport != QMC_TRANSPORT_SHM || !r)
        return 0;
    const uint64_t per = r->slot_bytes / (((uint64_t)s->spec.dims + 1) * 8);
    return per > 0 && (s->batch.count + per - 1) / per <= r->slots;
}

/* The next piece of the waiting batch: a QMCD_PUMP_* status. */
int qmcd__sess_send_piece(qmcd_conn *c, qmcd_sess_attach *a)
{
    qmcd_sess *s = a->s;
    const uint32_t dims = s->spec.dims;
    if (s->sent == 0)
        s->ring = qmcd__sess_uses_ring(c, s);
    qmc_msg r = {.type = QMC_MSG_SESSION_BATCH, .request_id = a->p.request_id};
    qmc_msg_session_batch *b = &r.u.session_batch;
    b->seq = s->batch.seq;
    b->count = s->batch.count;
    b->first = s->sent;
    b->dims = dims;
    const double *points = s->batch.points + s->sent * dims;
    const uint64_t left = s->batch.count - s->sent;
    if (s->ring) {
        qmcd_ring *ring = qmcd_conn_ring(c);
        if (qmcd_ring_full(ring))
            return QMCD_PUMP_WAIT; /* the client still holds every slot */
        if (qmcd_conn_out_room(c) < QMCD_OUT_RESERVE)
            return QMCD_PUMP_NO_ROOM;
        const uint64_t per = ring->slot_bytes / (((uint64_t)dims + 1) * 8);
        const uint64_t n = left < per ? left : per;
        uint32_t slot;
        uint8_t *dst = qmcd_ring_next(ring, &slot);
        /* Host order is the wire's little-endian order (as POINTS data). */
        memcpy(dst, points, (size_t)n * dims * 8);
        b->points = (uint32_t)n;
        b->transport = QMC_TRANSPORT_SHM;
        b->slot = slot;
        b->data_len = (uint32_t)(n * dims * 8);
        if (qmcd_conn_send(c, &r) != 0)
            return QMCD_PUMP_FAILED;
        int flush = qmcd_ring_hand_out(ring);
        s->pieces[s->n_pieces++] =
            (qmcd_sess_piece){s->sent, (uint32_t)n, slot, ring->handed_total};
        s->sent += n;
        return QMCD_PUMP_SENT | (flush || s->sent == s->batch.count ? QMCD_PUMP_FLUSH : 0);
    }
    const uint64_t per = qmcd__sess_inline_points(c, dims);
    const uint64_t n = left < per ? left : per;
    const size_t frame = QMC_PROTO_HEADER_BYTES + 44 + (size_t)n * dims * 8;
    if (qmcd_conn_out_room(c) < frame + QMCD_OUT_RESERVE)
        return QMCD_PUMP_NO_ROOM;
    b->points = (uint32_t)n;
    b->transport = QMC_TRANSPORT_INLINE;
    b->data_len = (uint32_t)(n * dims * 8);
    b->data = (const uint8_t *)(const void *)points;
    if (qmcd_conn_send(c, &r) != 0)
        return QMCD_PUMP_FAILED;
    s->sent += n;
    return QMCD_PUMP_SENT | (s->sent == s->batch.count ? QMCD_PUMP_FLUSH : 0);
}

/* The ring's next free slot, as room for a whole batch of the sampling
 * engine's and its values (*slot, *points), when the client takes batches
 * through its ring and the answer to the batch fits the output buffer;
 * else NULL. */
double *qmcd__sess_next_slot(qmcd_conn *c, const qmcd_sess *s, uint32_t *slot, size_t *points)
{
    qmcd_ring *r = qmcd_conn_ring(c);
    const uint64_t row = ((uint64_t)s->spec.dims + 1) * 8;
    if (s->transport != QMC_TRANSPORT_SHM || !r || qmcd_ring_full(r) ||
        s->engine_batch > r->slot_bytes / row || qmcd_conn_out_room(c) < QMCD_OUT_RESERVE)
        return NULL;
    *points = r->slot_bytes / row;
    return (double *)(void *)qmcd_ring_next(r, slot);
}

/* The step just assembled the batch in ring slot `slot`: the report, and
 * the batch as one piece naming that slot, now. */
void qmcd__sess_send_in_slot(qmcd_conn *c, qmcd_sess_attach *a, uint32_t slot)
{
    qmcd_sess *s = a->s;
    qmcd_ring *r = qmcd_conn_ring(c);
    qmc_msg m;
    if (s->owe_report) {
        s->owe_report = 0;
        qmcd__sess_report_of(s, &m, a->p.request_id);
        if (qmcd_conn_send(c, &m) != 0)
            return;
    }
    memset(&m, 0, sizeof m);
    m.type = QMC_MSG_SESSION_BATCH;
    m.request_id = a->p.request_id;
    qmc_msg_session_batch *b = &m.u.session_batch;
    b->seq = s->batch.seq;
    b->count = b->points = (uint32_t)s->batch.count;
    b->dims = s->spec.dims;
    b->transport = QMC_TRANSPORT_SHM;
    b->slot = slot;
    b->data_len = (uint32_t)(s->batch.count * s->spec.dims * 8);
    if (qmcd_conn_send(c, &m) != 0)
        return;
    (void)qmcd_ring_hand_out(r);
    s->ring = 1;
    s->n_pieces = 0;
    s->pieces[s->n_pieces++] = (qmcd_sess_piece){0, (uint32_t)s->batch.count, slot,
                                                 r->handed_total};
    s->sent = s->batch.count;
}
