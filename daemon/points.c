/*
 * points.c - POINTS: validation, streaming under backpressure, the
 * shared-memory ring a Unix-socket client may attach, and a cache of
 * sequence instances.
 *
 * A stream is a bulk stream (bulk.h): bulk.c frames its chunks, inline or
 * through the shared-memory ring a Unix-socket client attaches (shm.c),
 * under backpressure, and sends its END; this file validates the request
 * and fills the points with qmc_seq_fill.  Streams of one connection take
 * turns with its other producers, one frame each (producer.c).
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
#include <errno.h>
#include <stdlib.h>

#include "bulk.h"
#include "conn_services.h"
#include "modules.h"

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
    qmcd_bulk bulk;              /* its chunks and END; bulk.ctx is the stream */
    seq_entry *seq;
    qmc_format format;
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

/* The bulk stream's fill: points [first, first + n) of the sequence. */
static int fill_points(void *ctx, uint64_t first, uint32_t n, uint8_t *dst)
{
    const stream *s = ctx;
    return qmc_seq_fill(s->seq->seq, first, n, s->format, dst);
}

/*
 * A request of one chunk, with no other stream of the connection waiting
 * and room for its chunk and END: answered on the spot from the stream on
 * the stack, with no allocation and no turn in the pump.  Most POINTS on
 * a render farm are small, and pipelined 1-point requests spent a
 * visible share of their server time in the stream's calloc, queueing
 * and free.  Returns 1 when it answered (s->seq is released), else 0.
 */
static int answer_now(qmcd_conn *c, stream *s)
{
    qmcd_server *srv = qmcd_conn_server(c); /* c may be closed below; the server stays */
    const uint64_t count = s->bulk.end - s->bulk.next;
    if (qmcd_producer_count(c, &stream_kind) || count == 0 || count > s->bulk.chunk_points)
        return 0;
    /* One pump sends the chunk and, since the reserve it leaves holds it,
     * the END; without room for the chunk the stream is queued instead. */
    if (qmcd_bulk_pump(c, &s->bulk) == QMCD_PUMP_NO_ROOM)
        return 0;
    /* The stack stream is on no list, so a close did not release it. */
    cache_put(srv->seqs, s->seq);
    return 1;
}

/* POINTS: validates the request and starts its stream (or answers a
 * one-chunk request on the spot), or answers ERROR. */
static void on_points(qmcd_conn *c, const qmc_msg *m, int fd, int64_t t0_us)
{
    (void)fd;
    qmcd_server *srv = qmcd_conn_server(c);
    const qmc_msg_points *p = &m->u.points;
    char why[256] = "";
    if (qmcd_bulk_check_transport(c, m->request_id, "POINTS", p->transport) != 0)
        return;
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
    const size_t coord = qmc_format_bytes(p->format);
    stream now = {.p = {.request_id = m->request_id}, .format = p->format};
    if (qmcd_bulk_init(c, &now.bulk, m->request_id, "POINTS", "point", p->transport,
                       (size_t)p->seq.dims * coord, coord, p->start, p->count, t0_us) != 0)
        return;
    now.bulk.fill = fill_points;
    now.bulk.ctx = &now;
    now.bulk.counter = &srv->stats.points_sent;
    now.bulk.end_follows = 1;
    err = cache_get(srv->seqs, &p->seq, srv->cfg.max_seq_memory, &now.seq);
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
    err = qmc_seq_range_check(now.seq->seq, p->start, p->count, why, sizeof why);
    if (err) {
        cache_put(srv->seqs, now.seq);
        qmcd_conn_error(c, m->request_id, err, "%s", why[0] ? why : qmc_strerror(err));
        return;
    }
    if (!now.bulk.shm && answer_now(c, &now))
        return;
    stream *s = calloc(1, sizeof *s);
    if (!s) {
        cache_put(srv->seqs, now.seq);
        qmcd_conn_error(c, m->request_id, QMC_ENOMEM, "out of memory");
        return;
    }
    *s = now;
    s->bulk.ctx = s;
    qmcd_producer_attach(c, &s->p, &stream_kind, m->request_id);
}

/* The producer's pump: at most one chunk (or the END) of this stream;
 * its last chunk takes the END along when it fits (end_follows). */
static int stream_pump(qmcd_conn *c, qmcd_producer *p)
{
    return qmcd_bulk_pump(c, &((stream *)p)->bulk);
}

static qmcd_wait stream_waiting(const qmcd_conn *c, const qmcd_producer *p)
{
    return qmcd_bulk_waiting(c, &((const stream *)p)->bulk);
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
    .shutdown = qmcd_bulk_shutdown,
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
