/*
 * bulk.c - a bulk stream (bulk.h): the chunks and END of a points answer,
 * for any producer whose answer is whole points of a fixed size (POINTS
 * streams, PIXELS tiles).
 *
 * A stream never runs ahead of its reader.  Inline (POINTS_CHUNK), a
 * chunk is generated only when the output buffer has room for the whole
 * frame and the reserve for small answers, and in place: the frame prefix
 * is encoded, then the fill writes the points straight into the output
 * buffer at a 64-byte aligned address.  So a reader that stops costs at
 * most out-buffer-bytes, and a PING on the same connection is answered
 * between two chunks (frames are never split).
 *
 * Through the ring (POINTS_SHM_CHUNK, PROTOCOL.md section 10), the fill
 * writes into the next free slot of the client's memfd (ring.h) and only
 * the small frame naming the slot is queued.  A slot is free again when
 * SHM_RELEASE hands it back (oldest first), so the ring is the bound: a
 * client that never releases stalls its own ring streams (they wait,
 * QMCD_WAIT_RING, and cost nothing more) and nothing else.
 *
 * Must not: read sockets, decide a connection's lifetime, or know what the
 * points are (the fill does).
 */
#include <string.h>

#include "bulk.h"
#include "log.h"
#include "ring.h"

/* A POINTS_SHM_CHUNK frame: header and its fixed 24-byte payload. */
#define SHM_CHUNK_FRAME_BYTES (QMC_PROTO_HEADER_BYTES + 24u)

/* The frame bytes before a chunk's data: fixed by the protocol, so
 * measured once (by encoding a dummy prefix) rather than per request (a
 * render farm's many one-point POINTS would pay for it each time); 0 if
 * the codec refuses. */
static size_t chunk_prefix_bytes(void)
{
    static size_t bytes; /* written once on the loop thread, then read */
    if (bytes == 0) {
        uint8_t tmp[64];
        int n = qmc_proto_encode_chunk_prefix(0, 0, 1, 8, tmp, sizeof tmp);
        bytes = n > 0 ? (size_t)n : 0;
    }
    return bytes;
}

int qmcd_bulk_check_transport(qmcd_conn *c, uint64_t request_id, const char *what,
                              qmc_points_transport transport)
{
    if (transport != QMC_TRANSPORT_SHM || qmcd_conn_ring(c))
        return 0;
    if (qmcd_conn_is_unix(c))
        qmcd_conn_error(c, request_id, QMC_EINVAL,
                        "%s transport 1 (shm) needs a ring: send SHM_ATTACH first", what);
    else
        qmcd_conn_error(c, request_id, QMC_ENOTSUP,
                        "%s transport 1 (shm) needs a Unix-socket connection", what);
    return -1;
}

int qmcd_bulk_init(qmcd_conn *c, qmcd_bulk *b, uint64_t request_id, const char *what,
                   const char *point, qmc_points_transport transport, size_t row_bytes,
                   size_t value_bytes, uint64_t first, uint64_t count, int64_t t0_us)
{
    memset(b, 0, sizeof *b);
    const int shm = transport == QMC_TRANSPORT_SHM;
    const qmcd_ring *ring = qmcd_conn_ring(c);
    if (qmcd_bulk_check_transport(c, request_id, what, transport) != 0)
        return -1;
    const size_t prefix = chunk_prefix_bytes();
    size_t room;
    if (shm) {
        room = ring->slot_bytes;
    } else {
        const size_t data_max =
            (size_t)qmcd_conn_client_max_frame(c) - (prefix - QMC_PROTO_HEADER_BYTES);
        room = data_max < QMC_PROTO_CHUNK_BYTES ? data_max : QMC_PROTO_CHUNK_BYTES;
    }
    if (prefix == 0 || row_bytes == 0 || row_bytes > room) {
        if (shm)
            qmcd_conn_error(c, request_id, QMC_ETOOBIG,
                            "one %s is %zu bytes, more than a ring slot holds (%zu bytes)",
                            point, row_bytes, room);
        else
            qmcd_conn_error(c, request_id, QMC_ETOOBIG,
                            "one %s is %zu bytes, more than a chunk may carry under your "
                            "max_frame (%zu bytes of data)", point, row_bytes, room);
        return -1;
    }
    b->request_id = request_id;
    b->next = first;
    b->end = first + count;
    b->row_bytes = row_bytes;
    b->value_bytes = value_bytes;
    b->prefix_bytes = prefix;
    b->chunk_points = (uint32_t)(room / row_bytes);
    b->shm = shm;
    b->t0_us = t0_us;
    return 0;
}

qmcd_wait qmcd_bulk_waiting(const qmcd_conn *c, const qmcd_bulk *b)
{
    if (b->shm && b->next < b->end && qmcd_ring_full(qmcd_conn_ring(c)))
        return QMCD_WAIT_RING;
    return QMCD_WAIT_NONE;
}

int qmcd_bulk_shutdown(qmcd_conn *c, qmcd_producer *p)
{
    (void)c, (void)p;
    return 1;
}

/* The protocol is little-endian; fills write host order. */
static void to_little_endian(uint8_t *data, size_t bytes, size_t value)
{
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
    for (size_t i = 0; i + value <= bytes; i += value)
        for (size_t a = 0, z = value - 1; a < z; a++, z--) {
            uint8_t t = data[i + a];
            data[i + a] = data[i + z];
            data[i + z] = t;
        }
#else
    (void)data, (void)bytes, (void)value;
#endif
}

/* Logs and answers a fill that failed (a bug: the range was checked when
 * the stream began, so this is not input). */
static int fill_failed(qmcd_conn *c, const qmcd_bulk *b, uint32_t pts, int err)
{
    qmcd_err("conn %llu: request %llu: generating points %llu..+%u failed: %s",
             (unsigned long long)qmcd_conn_id(c), (unsigned long long)b->request_id,
             (unsigned long long)b->next, pts, qmc_strerror(err));
    qmcd_conn_error(c, b->request_id, err ? err : QMC_EINVAL, "generating points failed");
    return QMCD_PUMP_FAILED;
}

static int send_end(qmcd_conn *c, qmcd_bulk *b)
{
    if (qmcd_conn_out_room(c) < QMCD_OUT_RESERVE / 2)
        return QMCD_PUMP_NO_ROOM;
    qmc_msg m = {.type = QMC_MSG_END, .request_id = b->request_id};
    m.u.end.points = b->points_sent;
    m.u.end.bytes = b->bytes_sent;
    if (qmcd_conn_send(c, &m) != 0)
        return QMCD_PUMP_FAILED; /* the connection is closed */
    qmcd_answered(qmcd_conn_server(c), b->t0_us);
    return QMCD_PUMP_DONE;
}

/* One POINTS_CHUNK, generated in place in the output buffer. */
static int chunk_inline(qmcd_conn *c, qmcd_bulk *b, uint32_t pts)
{
    const size_t data = (size_t)pts * b->row_bytes;
    const size_t frame = b->prefix_bytes + data;
    if (qmcd_conn_out_room(c) < frame + QMCD_OUT_RESERVE)
        return QMCD_PUMP_NO_ROOM;
    uint8_t *buf = qmcd_conn_out_reserve(c, frame, b->prefix_bytes);
    if (!buf)
        return QMCD_PUMP_NO_ROOM; /* no memory for the buffer now */
    int n = qmc_proto_encode_chunk_prefix(b->request_id, b->next, pts, (uint32_t)data, buf,
                                          frame);
    int err = n < 0 ? n : b->fill(b->ctx, b->next, pts, buf + n);
    if (err || (size_t)n != b->prefix_bytes)
        return fill_failed(c, b, pts, err);
    to_little_endian(buf + n, data, b->value_bytes);
    qmcd_conn_out_commit(c, frame);
    return QMCD_PUMP_SENT;
}

/* One POINTS_SHM_CHUNK: the points in the next free slot, the frame
 * naming it in the output buffer. */
static int chunk_shm(qmcd_conn *c, qmcd_bulk *b, uint32_t pts)
{
    qmcd_ring *r = qmcd_conn_ring(c);
    if (qmcd_ring_full(r))
        return QMCD_PUMP_WAIT;
    if (qmcd_conn_out_room(c) < SHM_CHUNK_FRAME_BYTES + QMCD_OUT_RESERVE)
        return QMCD_PUMP_NO_ROOM;
    const size_t data = (size_t)pts * b->row_bytes;
    uint32_t slot;
    uint8_t *dst = qmcd_ring_next(r, &slot);
    int err = b->fill(b->ctx, b->next, pts, dst);
    if (err)
        return fill_failed(c, b, pts, err);
    to_little_endian(dst, data, b->value_bytes);
    qmc_msg m = {.type = QMC_MSG_POINTS_SHM_CHUNK, .request_id = b->request_id};
    m.u.shm_chunk.first = b->next;
    m.u.shm_chunk.points = pts;
    m.u.shm_chunk.data_len = (uint32_t)data;
    m.u.shm_chunk.slot = slot;
    if (qmcd_conn_send(c, &m) != 0)
        return QMCD_PUMP_FAILED; /* the connection is closed: r is gone */
    return QMCD_PUMP_SENT | (qmcd_ring_hand_out(r) ? QMCD_PUMP_FLUSH : 0);
}

int qmcd_bulk_pump(qmcd_conn *c, qmcd_bulk *b)
{
    if (b->next == b->end)
        return send_end(c, b);
    const uint64_t left = b->end - b->next;
    const uint32_t pts = left < b->chunk_points ? (uint32_t)left : b->chunk_points;
    const int rc = b->shm ? chunk_shm(c, b, pts) : chunk_inline(c, b, pts);
    if (QMCD_PUMP_STATUS(rc) != QMCD_PUMP_SENT)
        return rc;
    b->next += pts;
    b->points_sent += pts;
    b->bytes_sent += (uint64_t)pts * b->row_bytes;
    if (b->counter)
        *b->counter += pts;
    if (b->end_follows && b->next == b->end) {
        /* Without room now, END goes on a later pump; a failed send
         * closed the connection and released the stream. */
        const int end = send_end(c, b);
        if (end == QMCD_PUMP_DONE)
            return QMCD_PUMP_DONE | (rc & QMCD_PUMP_FLUSH);
        if (end == QMCD_PUMP_FAILED)
            return QMCD_PUMP_FAILED;
    }
    return rc;
}
