/*
 * pixels.c - PIXELS (protocol version 4): a tile of a pixel sampler
 * (qmc/pixel.h), a producer kind (producer.h) whose answer is a bulk
 * stream (bulk.h) of the tile's samples in qmc_pixels_fill's order.
 *
 * The request is checked before anything is allocated past the sampler:
 * the core's one-line reasons (qmc_pixel_spec_check, qmc_pixels_tile_check)
 * go back in an ERROR as they are, so a renderer sees the same line as
 * `qmc pixels` in-process; then the limits - max-points samples a request
 * (a client splits a larger tile, as libqmcclient does), a sample no larger
 * than a chunk or a ring slot, and max-seq-memory for the sampler tables
 * the open tiles hold (the sobol sampler's take about 212 bytes a dimension;
 * zsobol's and padded-sobol's almost nothing).  A chunk is filled piece by
 * piece (qmc_pixel_tile_piece), so it may begin and end anywhere in a
 * pixel's samples.
 *
 * Must not: read sockets, reach into a connection (conn_services.h is the
 * door), or compute a value itself (the core does).
 */
#include <stdlib.h>

#include "bulk.h"
#include "producer.h"
#include "qmc/pixel.h"

typedef struct tile {
    qmcd_producer p;              /* first: the connection's handle */
    qmcd_bulk bulk;
    qmc_pixels *px;
    qmc_pixel_tile tile;
    qmc_format format;
    uint64_t table_bytes;         /* charged to srv->pixel_table_bytes */
    qmcd_server *srv;
} tile;

/* What a sampler's tables take, as the core lays them out (pixel_sobol.c:
 * 52 columns of 32 bits and a seed a dimension, at least 2 dimensions; the
 * others a few words) and the instance's header.  An estimate, but one that
 * scales right: it is what lets max-seq-memory bound what open tiles pin. */
static uint64_t sampler_bytes(const qmc_pixel_spec *s)
{
    const uint64_t header = 4096;
    if (s->sampler != QMC_PIXEL_SOBOL)
        return header;
    const uint64_t dims = s->dims < 2 ? 2 : s->dims;
    return header + dims * (52u * 4u + 4u);
}

/* The bulk stream's fill: samples [first, first + n) of the tile, in its
 * output order, as pieces of it. */
static int fill_samples(void *ctx, uint64_t first, uint32_t n, uint8_t *dst)
{
    const tile *t = ctx;
    const size_t row = t->bulk.row_bytes;
    uint64_t done = 0;
    while (done < n) {
        qmc_pixel_tile piece;
        int err = qmc_pixel_tile_piece(&t->tile, first + done, n - done, &piece);
        if (err == 0)
            err = qmc_pixels_fill(t->px, &piece, t->format, dst + done * row);
        if (err)
            return err;
        done += (uint64_t)piece.width * piece.height * piece.sample_count;
    }
    return 0;
}

static int tile_pump(qmcd_conn *c, qmcd_producer *p)
{
    return qmcd_bulk_pump(c, &((tile *)p)->bulk);
}

static qmcd_wait tile_waiting(const qmcd_conn *c, const qmcd_producer *p)
{
    return qmcd_bulk_waiting(c, &((const tile *)p)->bulk);
}

static void tile_free(tile *t)
{
    t->srv->pixel_table_bytes -= t->table_bytes;
    qmc_pixels_free(t->px);
    free(t);
}

static void tile_release(qmcd_conn *c, qmcd_producer *p, qmcd_end why)
{
    (void)c, (void)why; /* END or ERROR went out already, or none is due */
    tile_free((tile *)p);
}

static const qmcd_producer_kind tile_kind = {
    .name = "pixels",
    .flags = QMCD_PRODUCER_BULK,
    .pump = tile_pump,
    .waiting = tile_waiting,
    .shutdown = qmcd_bulk_shutdown,
    .release = tile_release,
};

/* The request's checks that need no sampler: version, spec.  Returns 0,
 * or -1 after the ERROR. */
static int check_spec(qmcd_conn *c, const qmc_msg *m)
{
    const qmc_msg_pixels *q = &m->u.pixels;
    const unsigned version = qmcd_conn_version(c);
    if (version < QMC_PROTO_VERSION_PIXELS) {
        qmcd_conn_error(c, m->request_id, QMC_ENOTSUP,
                        "PIXELS needs protocol version %u; this connection chose %u (offer "
                        "%u in HELLO)", QMC_PROTO_VERSION_PIXELS, version,
                        QMC_PROTO_VERSION_PIXELS);
        return -1;
    }
    char why[256] = "";
    int err = qmc_pixel_spec_check(&q->spec, why, sizeof why);
    if (err) {
        qmcd_conn_error(c, m->request_id, err, "%s", why[0] ? why : qmc_strerror(err));
        return -1;
    }
    return 0;
}

/* The tile's checks: inside the image and the sampler's samples (the
 * core's reason), at most max-points samples.  Returns 0 or -1. */
static int check_tile(qmcd_conn *c, const qmc_msg *m, const qmc_pixels *px, uint64_t *samples)
{
    const qmc_msg_pixels *q = &m->u.pixels;
    const qmcd_server *srv = qmcd_conn_server(c);
    char why[256] = "";
    uint64_t values;
    int err = qmc_pixels_tile_check(px, &q->tile, &values, why, sizeof why);
    if (err) {
        qmcd_conn_error(c, m->request_id, err, "%s", why[0] ? why : qmc_strerror(err));
        return -1;
    }
    *samples = values / q->spec.dims;
    if (*samples > srv->cfg.max_points) {
        qmcd_conn_error(c, m->request_id, QMC_ETOOBIG,
                        "max-points: a tile of %llu samples (%ux%u pixels x %llu) is more "
                        "than the %llu a request may have: ask for it in parts",
                        (unsigned long long)*samples, q->tile.width, q->tile.height,
                        (unsigned long long)q->tile.sample_count,
                        (unsigned long long)srv->cfg.max_points);
        return -1;
    }
    return 0;
}

static void on_pixels(qmcd_conn *c, const qmc_msg *m, int fd, int64_t t0_us)
{
    (void)fd; /* only QMCD_ROUTE_FD rows get one */
    qmcd_server *srv = qmcd_conn_server(c);
    const qmc_msg_pixels *q = &m->u.pixels;
    if (check_spec(c, m) != 0)
        return;
    const uint64_t bytes = sampler_bytes(&q->spec);
    if (srv->pixel_table_bytes + bytes > srv->cfg.max_seq_memory) {
        qmcd_conn_error(c, m->request_id, QMC_ETOOBIG,
                        "max-seq-memory: the samplers open tiles use fill the %llu-byte limit; "
                        "try again later", (unsigned long long)srv->cfg.max_seq_memory);
        return;
    }
    tile *t = calloc(1, sizeof *t);
    int err = t ? qmc_pixels_new(&q->spec, &t->px) : QMC_ENOMEM;
    if (err) {
        free(t);
        qmcd_conn_error(c, m->request_id, err, "creating the sampler: %s", qmc_strerror(err));
        return;
    }
    t->srv = srv;
    t->table_bytes = bytes;
    srv->pixel_table_bytes += bytes;
    t->tile = q->tile;
    t->format = q->format;
    uint64_t samples;
    const size_t value_bytes = qmc_format_bytes(q->format);
    if (check_tile(c, m, t->px, &samples) != 0 ||
        qmcd_bulk_init(c, &t->bulk, m->request_id, "PIXELS", "sample", q->transport,
                       (size_t)q->spec.dims * value_bytes, value_bytes, 0, samples,
                       t0_us) != 0) {
        tile_free(t);
        return;
    }
    t->bulk.fill = fill_samples;
    t->bulk.ctx = t;
    t->bulk.counter = &srv->stats.pixel_samples_sent;
    qmcd_producer_attach(c, &t->p, &tile_kind, m->request_id);
}

const qmcd_module qmcd_pixels_module = {
    .name = "pixels",
    .routes = (const qmcd_route[]){
        {QMC_MSG_PIXELS, QMCD_ROUTE_REQUEST | QMCD_ROUTE_STARTS, on_pixels},
        {0, 0, NULL},
    },
};
