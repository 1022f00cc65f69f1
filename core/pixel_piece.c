/*
 * pixel_piece.c - cutting a tile into bounded pieces whose outputs follow
 * each other (qmc_pixel_tile_piece, qmc/pixel.h): what lets the CLI fill a
 * tile of any size in blocks, and the client library ask for a tile of
 * more samples than the daemon's max-points in several requests, both
 * writing the same bytes as one fill.
 *
 * Pure arithmetic on the tile: no sampler, no I/O, no state.
 */
#include <string.h>

#include "qmc/pixel.h"

/* The tile's samples, or 0 when empty or past 2^64 - 1. */
static uint64_t tile_samples(const qmc_pixel_tile *t)
{
    const uint64_t pixels = (uint64_t)t->width * t->height;
    if (pixels == 0 || t->sample_count > UINT64_MAX / pixels)
        return 0;
    return pixels * t->sample_count;
}

int qmc_pixel_tile_piece(const qmc_pixel_tile *tile, uint64_t done, uint64_t max_samples,
                         qmc_pixel_tile *piece)
{
    if (piece)
        memset(piece, 0, sizeof *piece);
    if (!tile || !piece || max_samples == 0 || done >= tile_samples(tile))
        return QMC_EINVAL;
    const uint64_t n = tile->sample_count, w = tile->width;
    const uint64_t pixel = done / n, s = done % n;
    const uint32_t row = (uint32_t)(pixel / w), col = (uint32_t)(pixel % w);
    qmc_pixel_tile p = {.x = tile->x + col, .y = tile->y + row, .width = 1, .height = 1,
                        .sample_start = tile->sample_start + s, .sample_count = n - s};
    if (s == 0 && col == 0 && n <= max_samples / w) {
        /* Whole rows: a row's w * n samples fit. */
        uint64_t rows = max_samples / (w * n);
        if (rows > tile->height - row)
            rows = tile->height - row;
        p.width = tile->width;
        p.height = (uint32_t)rows;
    } else if (s == 0 && n <= max_samples) {
        /* Whole pixels of this row. */
        uint64_t pixels = max_samples / n;
        if (pixels > w - col)
            pixels = w - col;
        p.width = (uint32_t)pixels;
    } else if (p.sample_count > max_samples) {
        /* Part of one pixel's samples. */
        p.sample_count = max_samples;
    }
    *piece = p;
    return 0;
}
