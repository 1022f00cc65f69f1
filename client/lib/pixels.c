/*
 * pixels.c - PIXELS requests (protocol version 4): a tile of a pixel
 * sampler, streamed in the chunks and END of a POINTS answer and checked
 * by the same code (qmc__client_stream_one in points.c).
 *
 * The answer's points are the tile's samples in output order (pixel rows
 * y, then x; each pixel's samples; each sample's dims values), numbered
 * from 0.  A tile of more samples than the server's max_points is asked
 * for in several requests, each a piece of the tile whose output is one
 * contiguous run of the whole tile's output (qmc_pixel_tile_piece: whole
 * rows where a row fits, else whole pixels of one row, else part of one
 * pixel's samples), so the caller sees one stream, the same bytes as one
 * request (and as qmc_pixels_fill in-process), whatever the daemon's
 * limit.
 *
 * Must not: hold more than one chunk, print, or send PIXELS to a server
 * that did not choose version 4 (an older one closes the connection on
 * an unknown type).
 */
#include <string.h>

#include "client_impl.h"

/* Passes each chunk on with its index in the whole tile's output: a
 * piece's points are numbered from 0, and it starts at `base`. */
typedef struct piece_ctx {
    qmc_client_chunk_fn on_chunk;
    void *ctx;
    uint64_t base;
} piece_ctx;

static int piece_chunk(void *ctx, uint64_t first, uint32_t points, const void *data,
                       size_t bytes)
{
    const piece_ctx *k = ctx;
    return k->on_chunk(k->ctx, k->base + first, points, data, bytes);
}

/* The tile's samples, or QMC_ERANGE when they do not fit in 64 bits. */
static int tile_samples(const qmc_pixel_tile *t, uint64_t *samples)
{
    const uint64_t pixels = (uint64_t)t->width * t->height;
    *samples = 0;
    if (pixels && t->sample_count > UINT64_MAX / pixels)
        return QMC_ERANGE;
    *samples = pixels * t->sample_count;
    return 0;
}

int qmc_client_pixels_stream(qmc_client *c, const qmc_pixel_spec *spec,
                             const qmc_pixel_tile *tile, qmc_format fmt,
                             qmc_client_chunk_fn on_chunk, void *ctx)
{
    int err = qmc__client_ready(c);
    if (err)
        return err;
    if (!spec || !tile || !on_chunk)
        return qmc__client_fail(c, QMC_EINVAL, "pixels: no spec, no tile or no callback");
    const size_t value_bytes = qmc_format_bytes(fmt);
    if (value_bytes == 0)
        return qmc__client_fail(c, QMC_EFORMAT, "pixels: unknown output format %d", (int)fmt);
    if (c->version < QMC_PROTO_VERSION_PIXELS)
        return qmc__client_fail(c, QMC_ENOTSUP, "pixels: the server speaks protocol version "
                                "%u; PIXELS needs %u (a newer qmcd)", c->version,
                                QMC_PROTO_VERSION_PIXELS);
    uint64_t total;
    if (tile_samples(tile, &total) != 0)
        return qmc__client_fail(c, QMC_ERANGE, "pixels: a tile of %u x %u pixels of %llu "
                                "samples each is more than 2^64 samples", tile->width,
                                tile->height, (unsigned long long)tile->sample_count);
    /* The server checks spec and tile (its reasons come back as they
     * are); dims here only sizes rows, and dims x 8 fits 64 bits. */
    const uint64_t row_bytes = (uint64_t)spec->dims * value_bytes;
    qmc__client_progress pr = {0, total, "samples", "pixels"};
    qmc_msg m;
    memset(&m, 0, sizeof m);
    m.type = QMC_MSG_PIXELS;
    m.u.pixels.spec = *spec;
    m.u.pixels.format = fmt;
    if (total == 0) {
        /* An empty tile: the server says what is wrong with it. */
        m.u.pixels.tile = *tile;
        return qmc__client_stream_one(c, &m, &m.u.pixels.transport, 0, 0, row_bytes,
                                      on_chunk, ctx, &pr);
    }
    /* A server that names no limit (0) takes the tile whole. */
    const uint64_t max = c->max_points ? c->max_points : total;
    uint64_t done = 0;
    do {
        qmc_pixel_tile piece;
        if (qmc_pixel_tile_piece(tile, done, max, &piece) != 0) /* cannot: done < total */
            return qmc__client_fail(c, QMC_EINVAL, "pixels: cutting the tile failed");
        const uint64_t n = (uint64_t)piece.width * piece.height * piece.sample_count;
        piece_ctx k = {on_chunk, ctx, done};
        m.u.pixels.tile = piece;
        err = qmc__client_stream_one(c, &m, &m.u.pixels.transport, 0, n, row_bytes,
                                     piece_chunk, &k, &pr);
        done += n;
    } while (err == 0 && done < total);
    return err;
}

int qmc_client_pixels(qmc_client *c, const qmc_pixel_spec *spec, const qmc_pixel_tile *tile,
                      qmc_format fmt, void *out, size_t out_bytes)
{
    int err = qmc__client_ready(c);
    if (err)
        return err;
    const size_t value_bytes = qmc_format_bytes(fmt);
    if (!spec || !tile || !out || value_bytes == 0)
        return qmc__client_fail(c, QMC_EINVAL, "pixels: no spec, no tile, no buffer or an "
                                "unknown format");
    const uint64_t row_bytes = (uint64_t)spec->dims * value_bytes;
    uint64_t total;
    if (row_bytes == 0 || tile_samples(tile, &total) != 0 || total > out_bytes / row_bytes)
        return qmc__client_fail(c, QMC_EINVAL, "pixels: a tile of %u x %u pixels of %llu "
                                "samples of %u dims does not fit in %zu bytes", tile->width,
                                tile->height, (unsigned long long)tile->sample_count,
                                spec->dims, out_bytes);
    qmc__client_copy k = {out, 0, (size_t)row_bytes, value_bytes};
    return qmc_client_pixels_stream(c, spec, tile, fmt, qmc__client_copy_chunk, &k);
}
