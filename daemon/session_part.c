/*
 * session_part.c - the answer of a part session (part_p != 0; protocol
 * version 6, PROTOCOL.md section 6.22): once its integrator finished,
 * SESSION_PART (the part's place in its job) and its block sums in
 * SESSION_PART_SUMS frames, in block order, one frame a pump, before
 * session.c sends SESSION_RESULT.
 *
 * The sums are sent from the session's own (qmc_session_part: they are
 * counted in qmc_session_memory_bytes, which the session reserved when it
 * opened), so nothing is allocated here; each frame waits for output room
 * like a batch's piece, so a part of many blocks streams at the client's
 * pace.  A session resumed after a lost connection sends them again from
 * the start (session.c's rewind).
 *
 * Must not: read sockets, reach into a connection's fields, or run an
 * integrator.
 */
#include <string.h>

#include "session.h"

/* Blocks in one SESSION_PART_SUMS: a chunk's bytes and the client's
 * max_frame bound it (at least 65536: over 100 blocks). */
static uint64_t sums_per_frame(const qmcd_conn *c)
{
    uint64_t room = qmcd_conn_client_max_frame(c);
    room = room > 24 ? room - 24 : 0; /* SESSION_PART_SUMS's fixed fields */
    uint64_t n = room / QMC_PROTO_PART_SUMS_BYTES;
    return n < QMC_PROTO_PART_MAX_SUMS ? n : QMC_PROTO_PART_MAX_SUMS;
}

int qmcd__sess_part_owed(const qmcd_sess *s)
{
    if (!s->spec.part_p || !s->core || s->err)
        return 0;
    qmc_session_part_sums ps;
    if (qmc_session_part(s->core, &ps) != 0)
        return 0;
    return !s->part_head_sent || s->part_sent < ps.count;
}

int qmcd__sess_part_pump(qmcd_conn *c, qmcd_sess_attach *a)
{
    qmcd_sess *s = a->s;
    qmc_session_part_sums ps;
    if (qmc_session_part(s->core, &ps) != 0)
        return QMCD_PUMP_FAILED; /* part_owed said otherwise: never seen */
    qmc_msg m;
    memset(&m, 0, sizeof m);
    m.request_id = a->p.request_id;
    if (!s->part_head_sent) {
        if (qmcd_conn_out_room(c) < QMCD_OUT_RESERVE / 2)
            return QMCD_PUMP_NO_ROOM;
        m.type = QMC_MSG_SESSION_PART;
        qmc_msg_session_part *p = &m.u.session_part;
        p->session_id = s->id;
        p->fingerprint = ps.fingerprint;
        p->blocks = ps.blocks;
        p->first = ps.first;
        p->count = ps.count;
        p->part_k = s->spec.part_k;
        p->part_p = s->spec.part_p;
        p->sampling = ps.sampling;
        if (qmcd_conn_send(c, &m) != 0)
            return QMCD_PUMP_FAILED;
        s->part_head_sent = 1;
        return QMCD_PUMP_SENT;
    }
    const uint64_t per = sums_per_frame(c), left = ps.count - s->part_sent;
    const uint64_t n = left < per ? left : per;
    const size_t frame = QMC_PROTO_HEADER_BYTES + 24 + (size_t)n * QMC_PROTO_PART_SUMS_BYTES;
    if (qmcd_conn_out_room(c) < frame + QMCD_OUT_RESERVE)
        return QMCD_PUMP_NO_ROOM;
    m.type = QMC_MSG_SESSION_PART_SUMS;
    m.u.part_sums.session_id = s->id;
    m.u.part_sums.first = ps.first + s->part_sent;
    m.u.part_sums.n = (uint32_t)n;
    m.u.part_sums.sums = ps.sums + s->part_sent;
    if (qmcd_conn_send(c, &m) != 0)
        return QMCD_PUMP_FAILED;
    s->part_sent += n;
    return QMCD_PUMP_SENT | (s->part_sent == ps.count ? QMCD_PUMP_FLUSH : 0);
}
