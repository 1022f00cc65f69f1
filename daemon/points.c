/*
 * points.c - POINTS: validation, streaming under backpressure, the
 * shared-memory ring a Unix-socket client may attach, and a cache of
 * sequence instances.
 *
 * A stream never runs ahead of its reader.  Inline (POINTS_CHUNK), a chunk
 * is generated only when the connection's output buffer has room for the
 * whole frame plus the reserve for small answers, and generation happens
 * in place - the frame prefix is encoded, then qmc_seq_fill writes the
 * points straight into the output buffer at a 64-byte aligned address.  So
 * a reader that stops costs at most out-buffer-bytes, and a PING on the
 * same connection is answered between two chunks (frames are never split).
 *
 * Through the ring (POINTS_SHM_CHUNK, PROTOCOL.md section 10), qmc_seq_fill
 * writes into the next free slot of the client's memfd (ring.h), and
 * only a 48-byte frame naming the slot is queued.  A slot is free again
 * when SHM_RELEASE hands it back (oldest first), so the ring is the bound:
 * a client that never releases stalls its own shm streams and nothing
 * else, and costs no memory beyond its own ring.  Attaching the ring is
 * shm.c, what keeps its pages the client's ring.c.
 *
 * Streams of one connection take turns with its other producers, one
 * frame each (producer.c); a stream waiting for a slot lets the others
 * pass.
 *
 * Sequence instances are immutable and can be large (Sobol at 21201
 * dimensions is about 5 MB and takes milliseconds to build), so streams
 * share them through a small cache keyed by spec, reference-counted;
 * at most CACHE_IDLE unused instances are kept.
 *
 * On its connection a stream is a producer (producer.h) of the bulk kind;
 * POINTS reaches it through the row of qmcd_points_module, and it reaches
 * the connection only through conn_services.h.
 *
 * This file must not read sockets or decide connection policy (conn.c).
 */
#define _GNU_SOURCE
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "conn_services.h"
#include "log.h"
#include "modules.h"
#include "ring.h"

#define CACHE_IDLE 8

typedef struct seq_entry {
    struct seq_entry *next;
    qmc_seq_spec spec;
    qmc_seq *seq;
    unsigned refs;
    uint64_t used;               /* LRU stamp */
    uint64_t bytes;              /* seq_bytes(&spec) */
} seq_entry;

struct qmcd_seqcache {
    seq_entry *entries;
    uint64_t clock;
    uint64_t bytes;              /* estimated table bytes of all entries */
};

/* A POINTS stream: one producer (producer.h) of the connection. */
typedef struct stream {
    qmcd_producer p;             /* first: the connection's list holds &s->p */
    seq_entry *seq;
    qmc_format format;
    uint64_t next_index, end;
    uint64_t points_sent, bytes_sent;
    size_t row_bytes;            /* dims * coordinate bytes */
    uint32_t chunk_points;       /* whole points per chunk */
    int shm;                     /* 1: through the connection's ring */
    int64_t t0_us;
} stream;

static const qmcd_producer_kind stream_kind;

/* The cache lives with the server (the module's open and close). */
static int points_open(qmcd_server *srv)
{
    srv->seqs = calloc(1, sizeof *srv->seqs);
    return srv->seqs ? 0 : -ENOMEM;
}

static void points_close(qmcd_server *srv)
{
    qmcd_seqcache *cache = srv->seqs;
    srv->seqs = NULL;
    if (!cache)
        return;
    while (cache->entries) {
        seq_entry *e = cache->entries;
        cache->entries = e->next;
        qmc_seq_free(e->seq);
        free(e);
    }
    free(cache);
}

static int same_spec(const qmc_seq_spec *a, const qmc_seq_spec *b)
{
    return a->kind == b->kind && a->dims == b->dims && a->scramble == b->scramble &&
           a->flags == b->flags && a->seed == b->seed && a->set_size == b->set_size;
}

/* Frees every idle entry (under memory pressure). */
static void cache_trim_all_idle(qmcd_seqcache *cache)
{
    for (seq_entry **link = &cache->entries; *link;) {
        seq_entry *e = *link;
        if (e->refs) {
            link = &e->next;
            continue;
        }
        *link = e->next;
        cache->bytes -= e->bytes;
        qmc_seq_free(e->seq);
        free(e);
    }
}

/* Evicts least recently used idle entries beyond CACHE_IDLE. */
static void cache_trim(qmcd_seqcache *cache)
{
    for (;;) {
        unsigned idle = 0;
        seq_entry *oldest = NULL, **oldest_link = NULL;
        for (seq_entry **link = &cache->entries; *link; link = &(*link)->next) {
            seq_entry *e = *link;
            if (e->refs)
                continue;
            idle++;
            if (!oldest || e->used < oldest->used)
                oldest = e, oldest_link = link;
        }
        if (idle <= CACHE_IDLE)
            return;
        *oldest_link = oldest->next;
        cache->bytes -= oldest->bytes;
        qmc_seq_free(oldest->seq);
        free(oldest);
    }
}

/*
 * What an instance's precomputed tables take, as seq_sobol.c and
 * seq_halton.c lay them out: Sobol about 528 bytes a dimension (direction
 * numbers, prefix XORs in 32 and 64 bits, seeds) plus, below 32
 * dimensions, under 5 KiB of packed-fill steps, Halton 48 a dimension
 * plus its small-base tables; the other kinds almost nothing.  An
 * estimate (the library does not say), but one that scales right: it is
 * what lets max-seq-memory bound the instances open streams pin.
 */
static uint64_t seq_bytes(const qmc_seq_spec *spec)
{
    switch (spec->kind) {
    case QMC_SEQ_SOBOL:
        return 528ull * spec->dims + 8192;
    case QMC_SEQ_HALTON:
    case QMC_SEQ_HAMMERSLEY:
        return 48ull * spec->dims + 16384;
    default:
        return 4096;
    }
}

static int cache_get(qmcd_seqcache *cache, const qmc_seq_spec *spec, uint64_t max_bytes,
                     seq_entry **out)
{
    *out = NULL;
    for (seq_entry *e = cache->entries; e; e = e->next)
        if (same_spec(&e->spec, spec)) {
            e->refs++;
            e->used = ++cache->clock;
            *out = e;
            return 0;
        }
    const uint64_t bytes = seq_bytes(spec);
    if (cache->bytes + bytes > max_bytes) {
        cache_trim_all_idle(cache); /* make room from unused instances first */
        if (cache->bytes + bytes > max_bytes)
            return QMC_ETOOBIG;
    }
    seq_entry *e = calloc(1, sizeof *e);
    if (!e)
        return QMC_ENOMEM;
    int err = qmc_seq_new(spec, &e->seq);
    if (err) {
        free(e);
        return err;
    }
    e->spec = *spec;
    e->bytes = bytes;
    cache->bytes += bytes;
    e->refs = 1;
    e->used = ++cache->clock;
    e->next = cache->entries;
    cache->entries = e;
    *out = e;
    return 0;
}

static void cache_put(qmcd_seqcache *cache, seq_entry *e)
{
    e->refs--;
    cache_trim(cache);
}

/* The frame bytes before a chunk's data: fixed by the protocol, so
 * measured once (by encoding a dummy prefix) rather than per request. */
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

/* A POINTS_SHM_CHUNK frame: header and its fixed 24-byte payload. */
#define SHM_CHUNK_FRAME_BYTES (QMC_PROTO_HEADER_BYTES + 24u)

/*
 * A request of one chunk, with no other stream of the connection waiting
 * and room for its chunk and END: answered on the spot from a stream on
 * the stack, with no allocation and no turn in the pump.  Most POINTS on
 * a render farm are small, and pipelined 1-point requests spent a
 * visible share of their server time in the stream's calloc, queueing
 * and free.  Returns 1 when it answered (e is released), else 0.
 */
static int produce_inline(qmcd_conn *c, stream *s, uint32_t pts);
static int send_end(qmcd_conn *c, stream *s);

static int answer_now(qmcd_conn *c, uint64_t request_id, seq_entry *e,
                      const qmc_msg_points *p, size_t row, int64_t t0_us)
{
    qmcd_server *srv = qmcd_conn_server(c); /* c may be closed below; the server stays */
    const size_t data = (size_t)p->count * row;
    const size_t room =
        qmcd_conn_client_max_frame(c) - (chunk_prefix_bytes() - QMC_PROTO_HEADER_BYTES);
    if (qmcd_producer_count(c, &stream_kind) || p->count == 0 ||
        data > QMC_PROTO_CHUNK_BYTES || data > room ||
        qmcd_conn_out_room(c) < chunk_prefix_bytes() + data + QMCD_OUT_RESERVE)
        return 0;
    stream s = {.p = {.request_id = request_id}, .seq = e, .format = p->format,
                .next_index = p->start, .end = p->start + p->count, .row_bytes = row,
                .chunk_points = (uint32_t)p->count, .t0_us = t0_us};
    int rc = produce_inline(c, &s, (uint32_t)p->count);
    if (rc > 0) /* no buffer memory now: the pump tries again later */
        return 0;
    if (rc == 0 && !qmcd_conn_gone(c)) {
        s.points_sent = p->count;
        s.bytes_sent = data;
        srv->stats.points_sent += p->count;
        /* END fits: the reserve checked above holds it. */
        (void)send_end(c, &s);
    }
    /* The stack stream is on no list, so a close did not release it. */
    cache_put(srv->seqs, e);
    return 1;
}

/* POINTS: validates the request and starts its stream (or answers a
 * one-chunk request on the spot), or answers ERROR. */
static void on_points(qmcd_conn *c, const qmc_msg *m, int fd, int64_t t0_us)
{
    (void)fd;
    qmcd_server *srv = qmcd_conn_server(c);
    const qmc_msg_points *p = &m->u.points;
    const int shm = p->transport == QMC_TRANSPORT_SHM;
    const qmcd_ring *ring = qmcd_conn_ring(c);
    char why[256] = "";
    if (shm && !ring) {
        if (qmcd_conn_is_unix(c))
            qmcd_conn_error(c, m->request_id, QMC_EINVAL,
                            "POINTS transport 1 (shm) needs a ring: send SHM_ATTACH first");
        else
            qmcd_conn_error(c, m->request_id, QMC_ENOTSUP,
                            "POINTS transport 1 (shm) needs a Unix-socket connection");
        return;
    }
    int err = qmc_seq_spec_check(&p->seq, why, sizeof why);
    if (err) {
        qmcd_conn_error(c, m->request_id, err, "%s", why[0] ? why : qmc_strerror(err));
        return;
    }
    if (p->count > srv->cfg.max_points) {
        qmcd_conn_error(c, m->request_id, QMC_ETOOBIG,
                        "max-points: %llu points requested, the limit is %llu per request",
                        (unsigned long long)p->count, (unsigned long long)srv->cfg.max_points);
        return;
    }
    size_t coord = qmc_format_bytes(p->format);
    size_t row = (size_t)p->seq.dims * coord;
    size_t prefix = chunk_prefix_bytes();
    size_t room;
    if (shm) {
        room = ring->slot_bytes;
    } else {
        room = qmcd_conn_client_max_frame(c) - (prefix - QMC_PROTO_HEADER_BYTES);
        if (room > QMC_PROTO_CHUNK_BYTES)
            room = QMC_PROTO_CHUNK_BYTES;
    }
    if (coord == 0 || prefix == 0 || row > room) {
        if (shm)
            qmcd_conn_error(c, m->request_id, QMC_ETOOBIG,
                            "one point is %zu bytes, more than a ring slot holds (%zu bytes)",
                            row, room);
        else
            qmcd_conn_error(c, m->request_id, QMC_ETOOBIG,
                            "one point is %zu bytes, more than a chunk may carry under your "
                            "max_frame (%zu bytes of data)", row, room);
        return;
    }
    seq_entry *e;
    err = cache_get(srv->seqs, &p->seq, srv->cfg.max_seq_memory, &e);
    if (err == QMC_ETOOBIG) {
        qmcd_conn_error(c, m->request_id, err,
                        "max-seq-memory: the sequences open streams use fill the %llu-byte "
                        "limit; try again later",
                        (unsigned long long)srv->cfg.max_seq_memory);
        return;
    }
    if (err) {
        qmcd_conn_error(c, m->request_id, err, "creating the sequence: %s", qmc_strerror(err));
        return;
    }
    err = qmc_seq_range_check(e->seq, p->start, p->count, why, sizeof why);
    if (err) {
        cache_put(srv->seqs, e);
        qmcd_conn_error(c, m->request_id, err, "%s", why[0] ? why : qmc_strerror(err));
        return;
    }
    if (!shm && answer_now(c, m->request_id, e, p, row, t0_us))
        return;
    stream *s = calloc(1, sizeof *s);
    if (!s) {
        cache_put(srv->seqs, e);
        qmcd_conn_error(c, m->request_id, QMC_ENOMEM, "out of memory");
        return;
    }
    s->seq = e;
    s->format = p->format;
    s->next_index = p->start;
    s->end = p->start + p->count;
    s->row_bytes = row;
    s->chunk_points = (uint32_t)(room / row);
    s->shm = shm;
    s->t0_us = t0_us;
    qmcd_producer_attach(c, &s->p, &stream_kind, m->request_id);
}

/* The protocol is little-endian; qmc_seq_fill writes host order. */
static void to_little_endian(uint8_t *data, size_t bytes, size_t coord)
{
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
    for (size_t i = 0; i + coord <= bytes; i += coord)
        for (size_t a = 0, b = coord - 1; a < b; a++, b--) {
            uint8_t t = data[i + a];
            data[i + a] = data[i + b];
            data[i + b] = t;
        }
#else
    (void)data, (void)bytes, (void)coord;
#endif
}

/* Queues the END frame of a finished stream.  Returns 0, or -1 without
 * room (tried again on the next pump). */
static int send_end(qmcd_conn *c, stream *s)
{
    qmc_msg m = {.type = QMC_MSG_END, .request_id = s->p.request_id};
    m.u.end.points = s->points_sent;
    m.u.end.bytes = s->bytes_sent;
    if (qmcd_conn_out_room(c) < QMCD_OUT_RESERVE / 2 || qmcd_conn_send(c, &m) != 0)
        return -1;
    qmcd_answered(qmcd_conn_server(c), s->t0_us);
    return 0;
}

static uint32_t next_chunk_points(const stream *s)
{
    uint64_t left = s->end - s->next_index;
    return left < s->chunk_points ? (uint32_t)left : s->chunk_points;
}

/* 1 when the stream's next chunk waits for a ring slot to come back. */
static int waits_for_slot(const qmcd_conn *c, const stream *s)
{
    return s->shm && s->next_index < s->end && qmcd_ring_full(qmcd_conn_ring(c));
}

/* 1 when the output buffer has room for the stream's next frame and the
 * reserve for small answers. */
static int has_room(const qmcd_conn *c, const stream *s)
{
    size_t room = qmcd_conn_out_room(c);
    if (s->next_index == s->end)
        return room >= QMCD_OUT_RESERVE / 2; /* its END */
    if (s->shm)
        return room >= SHM_CHUNK_FRAME_BYTES + QMCD_OUT_RESERVE;
    size_t frame = chunk_prefix_bytes() + (size_t)next_chunk_points(s) * s->row_bytes;
    return room >= frame + QMCD_OUT_RESERVE;
}

/* Logs and answers a generation failure (a bug: the range was checked at
 * the start, so this is not input). */
static void fill_failed(qmcd_conn *c, const stream *s, uint32_t pts, int err)
{
    qmcd_err("conn %llu: request %llu: generating points %llu..+%u failed: %s",
             (unsigned long long)qmcd_conn_id(c), (unsigned long long)s->p.request_id,
             (unsigned long long)s->next_index, pts, qmc_strerror(err));
    qmcd_conn_error(c, s->p.request_id, err ? err : QMC_EINVAL, "generating points failed");
}

/* One POINTS_CHUNK, generated in place in the output buffer.  Returns 0,
 * or -1 after an ERROR (the stream is over; the connection may be too). */
static int produce_inline(qmcd_conn *c, stream *s, uint32_t pts)
{
    size_t data = (size_t)pts * s->row_bytes;
    size_t prefix = chunk_prefix_bytes();
    size_t frame = prefix + data;
    uint8_t *buf = qmcd_conn_out_reserve(c, frame, prefix);
    if (!buf)
        return 1; /* no memory for the buffer now: try again later */
    int n = qmc_proto_encode_chunk_prefix(s->p.request_id, s->next_index, pts, (uint32_t)data,
                                          buf, frame);
    int err = n < 0 ? n : qmc_seq_fill(s->seq->seq, s->next_index, pts, s->format, buf + n);
    if (err || (size_t)n != prefix) {
        fill_failed(c, s, pts, err);
        return -1;
    }
    to_little_endian(buf + n, data, qmc_format_bytes(s->format));
    qmcd_conn_out_commit(c, frame);
    return 0;
}

/* One POINTS_SHM_CHUNK: the points go into the next free slot of the
 * ring, the frame saying so into the output buffer.  Returns 0 when it
 * queued the chunk (and *flush says whether to send now), else as
 * produce_inline. */
static int produce_shm(qmcd_conn *c, stream *s, uint32_t pts, int *flush)
{
    qmcd_ring *r = qmcd_conn_ring(c);
    size_t data = (size_t)pts * s->row_bytes;
    uint32_t slot;
    uint8_t *dst = qmcd_ring_next(r, &slot);
    int err = qmc_seq_fill(s->seq->seq, s->next_index, pts, s->format, dst);
    if (err) {
        fill_failed(c, s, pts, err);
        return -1;
    }
    to_little_endian(dst, data, qmc_format_bytes(s->format));
    qmc_msg m = {.type = QMC_MSG_POINTS_SHM_CHUNK, .request_id = s->p.request_id};
    m.u.shm_chunk.first = s->next_index;
    m.u.shm_chunk.points = pts;
    m.u.shm_chunk.data_len = (uint32_t)data;
    m.u.shm_chunk.slot = slot;
    if (qmcd_conn_send(c, &m) != 0)
        return -1; /* the connection is closed: r and s are gone */
    *flush = qmcd_ring_hand_out(r);
    return 0;
}

/* The producer's pump: at most one chunk (or the END) of this stream. */
static int stream_pump(qmcd_conn *c, qmcd_producer *p)
{
    stream *s = (stream *)p;
    if (waits_for_slot(c, s))
        return QMCD_PUMP_WAIT; /* SHM_RELEASE brings it back */
    if (!has_room(c, s))
        return QMCD_PUMP_NO_ROOM;
    if (s->next_index == s->end) {
        if (send_end(c, s) != 0)
            return qmcd_conn_gone(c) ? QMCD_PUMP_FAILED : QMCD_PUMP_NO_ROOM;
        return QMCD_PUMP_DONE;
    }
    uint32_t pts = next_chunk_points(s);
    int flush = 0;
    int rc = s->shm ? produce_shm(c, s, pts, &flush) : produce_inline(c, s, pts);
    if (rc > 0)
        return QMCD_PUMP_NO_ROOM; /* no buffer memory now: try again later */
    if (rc < 0)
        return QMCD_PUMP_FAILED;  /* its ERROR is queued, or the connection is gone */
    size_t data = (size_t)pts * s->row_bytes;
    s->next_index += pts;
    s->points_sent += pts;
    s->bytes_sent += data;
    qmcd_conn_server(c)->stats.points_sent += pts;
    flush = flush ? QMCD_PUMP_FLUSH : 0;
    /* The last chunk: its END goes right behind it when it fits, so a
     * small request costs one turn, not two. */
    if (s->next_index == s->end) {
        if (send_end(c, s) == 0)
            return QMCD_PUMP_DONE | flush;
        if (qmcd_conn_gone(c)) /* a failed send closed the connection and released s */
            return QMCD_PUMP_FAILED;
    }
    return QMCD_PUMP_SENT | flush;
}

static qmcd_wait stream_waiting(const qmcd_conn *c, const qmcd_producer *p)
{
    return waits_for_slot(c, (const stream *)p) ? QMCD_WAIT_RING : QMCD_WAIT_NONE;
}

/* A stream has no early end a client could wait for: at the shutdown
 * deadline its connection is cut. */
static int stream_shutdown(qmcd_conn *c, qmcd_producer *p)
{
    (void)c, (void)p;
    return 1;
}

static void stream_release(qmcd_conn *c, qmcd_producer *p, qmcd_end why)
{
    (void)why;
    stream *s = (stream *)p;
    cache_put(qmcd_conn_server(c)->seqs, s->seq);
    free(s);
}

static const qmcd_producer_kind stream_kind = {
    .name = "points",
    .flags = QMCD_PRODUCER_BULK,
    .pump = stream_pump,
    .waiting = stream_waiting,
    .shutdown = stream_shutdown,
    .release = stream_release,
};

const qmcd_module qmcd_points_module = {
    .name = "points",
    .routes = (const qmcd_route[]){
        {QMC_MSG_POINTS, QMCD_ROUTE_REQUEST | QMCD_ROUTE_STARTS, on_points},
        {0, 0, NULL},
    },
    .open = points_open,
    .close = points_close,
};
