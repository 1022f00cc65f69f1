/*
 * points.c - POINTS requests: the stream of POINTS_CHUNK frames (or, with
 * a ring attached, POINTS_SHM_CHUNK frames naming ring slots) and its END,
 * checked chunk by chunk.  The stream of one request is
 * qmc__client_stream_one, which PIXELS (pixels.c) shares: its answer is
 * the same frames.
 *
 * A chunk must start where the previous one ended, hold a whole number of
 * points, and not run past the request; a ring chunk must name the slot
 * that comes next and fit in it; END must count what arrived.  Anything
 * else is a protocol error and closes the connection.  On a Unix socket a
 * request of more than one chunk first attaches a ring (shm.c) if none is
 * and the server takes it.
 *
 * A request for more points than the server's max_points (HELLO_OK) is
 * sent as several POINTS requests of at most max_points each, one after
 * the other, so remote output equals in-process output whatever the
 * daemon's limit; the caller sees one stream.  When the connection is
 * lost halfway, the message says how far the stream got ("the daemon
 * closed the connection after N of M points").  Must not: hold more than
 * one chunk (the receive buffer's, or the ring's slots), or print.
 */
#include <errno.h>
#include <stdio.h>
#include <string.h>

#include "client_impl.h"

/* err, with c->message saying how far the stream got when the connection
 * was lost (any error that closed it; a server ERROR keeps it open and
 * speaks for itself). */
static int lost_at(qmc_client *c, int err, const qmc__client_progress *pr)
{
    if (c->fd >= 0)
        return err;
    char was[QMC_CLIENT_MESSAGE_BYTES];
    memcpy(was, c->message, sizeof was);
    if (err == -ECONNRESET || err == -EPIPE || err == -ECONNABORTED)
        snprintf(c->message, sizeof c->message, "the daemon closed the connection after "
                 "%llu of %llu %s", (unsigned long long)pr->done,
                 (unsigned long long)pr->total, pr->noun);
    else
        snprintf(c->message, sizeof c->message, "%.*s (after %llu of %llu %s)",
                 (int)(sizeof c->message - 64), was, (unsigned long long)pr->done,
                 (unsigned long long)pr->total, pr->noun);
    return err;
}

int qmc__client_stream_one(qmc_client *c, qmc_msg *req, qmc_points_transport *transport,
                           uint64_t start, uint64_t count, uint64_t row_bytes,
                           qmc_client_chunk_fn on_chunk, void *ctx, qmc__client_progress *pr)
{
    int err;
    /* More than one chunk's worth: worth a ring, if there is none yet. */
    if (count > QMC__CLIENT_AUTO_SLOT_BYTES / (row_bytes ? row_bytes : 1) &&
        (err = qmc__client_shm_auto(c)) != 0)
        return err;
    /* Not while a session's batch holds slots: release is oldest first,
     * so the stream's slots could not go back until that batch is
     * answered, and the stream would stall on a full ring. */
    const int shm = c->ring.base != NULL && !c->ring.pinned && row_bytes <= c->ring.slot_bytes;
    *transport = shm ? QMC_TRANSPORT_SHM : QMC_TRANSPORT_INLINE;
    qmc_msg m = *req;
    uint64_t id;
    if ((err = qmc__client_send(c, &m, &id)) != 0)
        return lost_at(c, err, pr);
    uint64_t got = 0, bytes = 0;
    for (;;) {
        /* Each wait for the next frame gets the full timeout: a stream
         * may run long, but the server must keep it moving. */
        err = qmc__client_await(c, id, qmc__client_deadline(c), 0, &m);
        if (err)
            return lost_at(c, err, pr);
        if (m.type == QMC_MSG_ERROR) {
            /* Slots of chunks already handled go back first. */
            if ((err = qmc__client_shm_release(c)) != 0)
                return lost_at(c, err, pr);
            return qmc__client_server_error(c, &m);
        }
        if (m.type == QMC_MSG_END) {
            if (m.u.end.points != got || got != count || m.u.end.bytes != bytes)
                return qmc__client_break(c, QMC_EPROTO, "protocol error: END says %llu "
                                         "points in %llu bytes; %llu of %llu points in "
                                         "%llu bytes arrived",
                                         (unsigned long long)m.u.end.points,
                                         (unsigned long long)m.u.end.bytes,
                                         (unsigned long long)got, (unsigned long long)count,
                                         (unsigned long long)bytes);
            if ((err = qmc__client_shm_release(c)) != 0)
                return lost_at(c, err, pr);
            c->message[0] = '\0';
            return 0;
        }
        uint64_t first;
        uint32_t points, data_len;
        const uint8_t *data;
        if (m.type == QMC_MSG_POINTS_CHUNK && !shm) {
            first = m.u.chunk.first;
            points = m.u.chunk.points;
            data_len = m.u.chunk.data_len;
            data = m.u.chunk.data;
        } else if (m.type == QMC_MSG_POINTS_SHM_CHUNK && shm) {
            const qmc_msg_shm_chunk *sc = &m.u.shm_chunk;
            qmc__client_ring *ring = &c->ring;
            if (sc->slot != ring->next || sc->data_len > ring->slot_bytes ||
                ring->held >= ring->slots)
                return qmc__client_break(c, QMC_EPROTO, "protocol error: a chunk of %u bytes "
                                         "in ring slot %u; expected slot %u, at most %u "
                                         "bytes, with %u of %u slots held", sc->data_len,
                                         sc->slot, ring->next, ring->slot_bytes, ring->held,
                                         ring->slots);
            ring->next = sc->slot + 1 == ring->slots ? 0 : sc->slot + 1;
            ring->held++; /* released once handled: see conn.c */
            first = sc->first;
            points = sc->points;
            data_len = sc->data_len;
            data = ring->base + (size_t)sc->slot * ring->slot_bytes;
        } else {
            return qmc__client_break(c, QMC_EPROTO, "protocol error: %s in a points "
                                     "stream (%s transport)", qmc_msg_type_name(m.type),
                                     shm ? "shm" : "inline");
        }
        if (first != start + got || points == 0 || points > count - got ||
            row_bytes == 0 || data_len % row_bytes != 0 || data_len / row_bytes != points)
            return qmc__client_break(c, QMC_EPROTO, "protocol error: chunk of %u points "
                                     "(%u bytes) at index %llu; expected index %llu, "
                                     "%llu bytes a point, at most %llu points",
                                     points, data_len, (unsigned long long)first,
                                     (unsigned long long)(start + got),
                                     (unsigned long long)row_bytes,
                                     (unsigned long long)(count - got));
        got += points;
        bytes += data_len;
        int r = on_chunk(ctx, first, points, data, data_len);
        if (r)
            return qmc__client_break(c, r, "%s: the stream was stopped at index %llu; "
                                     "the connection is closed", pr->what,
                                     (unsigned long long)(start + got));
        pr->done += points;
    }
}

/* One POINTS request of at most max_points. */
static int stream_one(qmc_client *c, const qmc_seq_spec *spec, uint64_t start,
                      uint64_t count, qmc_format fmt, uint64_t row_bytes,
                      qmc_client_chunk_fn on_chunk, void *ctx, qmc__client_progress *pr)
{
    qmc_msg m;
    memset(&m, 0, sizeof m);
    m.type = QMC_MSG_POINTS;
    m.u.points.seq = *spec;
    m.u.points.format = fmt;
    m.u.points.start = start;
    m.u.points.count = count;
    return qmc__client_stream_one(c, &m, &m.u.points.transport, start, count, row_bytes,
                                  on_chunk, ctx, pr);
}

int qmc_client_points_stream(qmc_client *c, const qmc_seq_spec *spec, uint64_t start,
                             uint64_t count, qmc_format fmt, qmc_client_chunk_fn on_chunk,
                             void *ctx)
{
    int err = qmc__client_ready(c);
    if (err)
        return err;
    if (!spec || !on_chunk)
        return qmc__client_fail(c, QMC_EINVAL, "points: no sequence spec or no callback");
    const size_t value_bytes = qmc_format_bytes(fmt);
    if (value_bytes == 0)
        return qmc__client_fail(c, QMC_EFORMAT, "points: unknown output format %d", (int)fmt);
    /* dims is checked by the server; here it only sizes rows, and
     * dims x 8 cannot overflow 64 bits. */
    const uint64_t row_bytes = (uint64_t)spec->dims * value_bytes;
    /* A server that names no limit (0) takes the request whole. */
    const uint64_t per_request = c->max_points ? c->max_points : count;
    qmc__client_progress pr = {0, count, "points", "points"};
    uint64_t done = 0;
    do {
        uint64_t n = count - done < per_request ? count - done : per_request;
        err = stream_one(c, spec, start + done, n, fmt, row_bytes, on_chunk, ctx, &pr);
        done += n;
    } while (err == 0 && done < count);
    return err;
}

int qmc__client_copy_chunk(void *ctx, uint64_t first, uint32_t points, const void *data,
                           size_t bytes)
{
    const qmc__client_copy *k = ctx;
    uint8_t *dst = k->out + (size_t)(first - k->start) * k->row_bytes;
    memcpy(dst, data, bytes);
    (void)points;
    /* The wire is little-endian; hand back host order. */
    const uint16_t probe = 1;
    if (*(const uint8_t *)&probe != 1) {
        for (size_t v = 0; v < bytes; v += k->value_bytes)
            for (size_t i = 0; i < k->value_bytes / 2; i++) {
                uint8_t t = dst[v + i];
                dst[v + i] = dst[v + k->value_bytes - 1 - i];
                dst[v + k->value_bytes - 1 - i] = t;
            }
    }
    return 0;
}

int qmc_client_points(qmc_client *c, const qmc_seq_spec *spec, uint64_t start,
                      uint64_t count, qmc_format fmt, void *out, size_t out_bytes)
{
    int err = qmc__client_ready(c);
    if (err)
        return err;
    const size_t value_bytes = qmc_format_bytes(fmt);
    if (!spec || !out || value_bytes == 0)
        return qmc__client_fail(c, QMC_EINVAL, "points: no spec, no buffer or an "
                                "unknown format");
    const uint64_t row_bytes = (uint64_t)spec->dims * value_bytes;
    if (row_bytes == 0 || count > out_bytes / row_bytes)
        return qmc__client_fail(c, QMC_EINVAL, "points: %llu points of %u dims do not "
                                "fit in %zu bytes", (unsigned long long)count,
                                spec->dims, out_bytes);
    qmc__client_copy k = {out, start, (size_t)row_bytes, value_bytes};
    return qmc_client_points_stream(c, spec, start, count, fmt, qmc__client_copy_chunk, &k);
}
