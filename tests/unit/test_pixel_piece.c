/*
 * test_pixel_piece.c - qmc_pixel_tile_piece: for many tiles and every
 * limit from 1 sample to past the whole tile, the pieces, taken in turn,
 * visit the tile's (x, y, sample) triples in exactly the order of
 * qmc_pixels_fill's output (the oracle: three nested loops written here),
 * each piece holds at most the limit, and the piece count is that of the
 * rule (whole rows, else whole pixels, else runs of samples) counted
 * independently; tiles near 2^32 pixels a side cut without overflow; bad
 * arguments are refused with the piece zeroed.
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <string.h>

#include "qmc/pixel.h"

static uint64_t ceil_div(uint64_t a, uint64_t b)
{
    return a / b + (a % b != 0);
}

/* The rule's piece count, by cases rather than by walking. */
static uint64_t expected_pieces(const qmc_pixel_tile *t, uint64_t max)
{
    const uint64_t w = t->width, h = t->height, n = t->sample_count;
    if (w * n <= max)
        return ceil_div(h, max / (w * n));
    if (n <= max)
        return h * ceil_div(w, max / n);
    return h * w * ceil_div(n, max);
}

/* Walks the tile piece by piece against the nested loops. */
static void walk(const qmc_pixel_tile *t, uint64_t max)
{
    const uint64_t total = (uint64_t)t->width * t->height * t->sample_count;
    uint32_t ox = t->x, oy = t->y;       /* the oracle's position */
    uint64_t os = t->sample_start;
    uint64_t done = 0, pieces = 0;
    while (done < total) {
        qmc_pixel_tile p;
        assert_int_equal(qmc_pixel_tile_piece(t, done, max, &p), 0);
        const uint64_t n = (uint64_t)p.width * p.height * p.sample_count;
        assert_true(n >= 1 && n <= max);
        for (uint32_t y = p.y; y < p.y + p.height; y++)
            for (uint32_t x = p.x; x < p.x + p.width; x++)
                for (uint64_t s = p.sample_start; s < p.sample_start + p.sample_count; s++) {
                    if (x != ox || y != oy || s != os)
                        fail_msg("tile %u,%u,%ux%u samples %llu+%llu, max %llu: piece %llu "
                                 "gives (%u,%u,%llu), the fill's order (%u,%u,%llu)",
                                 t->x, t->y, t->width, t->height,
                                 (unsigned long long)t->sample_start,
                                 (unsigned long long)t->sample_count, (unsigned long long)max,
                                 (unsigned long long)pieces, x, y, (unsigned long long)s, ox,
                                 oy, (unsigned long long)os);
                    /* Advance the oracle: samples, then x, then y. */
                    if (++os == t->sample_start + t->sample_count) {
                        os = t->sample_start;
                        if (++ox == t->x + t->width) {
                            ox = t->x;
                            oy++;
                        }
                    }
                }
        done += n;
        pieces++;
    }
    assert_true(done == total);
    assert_true(oy == t->y + t->height && ox == t->x && os == t->sample_start);
    assert_true(pieces == expected_pieces(t, max));
}

static void test_orders(void **state)
{
    (void)state;
    static const qmc_pixel_tile tiles[] = {
        {0, 0, 1, 1, 0, 1},  {2, 1, 5, 3, 3, 7},   {7, 9, 1, 6, 0, 4},
        {0, 5, 6, 1, 10, 3}, {3, 3, 4, 4, 0, 16},  {100, 200, 3, 2, 5, 1},
    };
    for (size_t i = 0; i < sizeof tiles / sizeof tiles[0]; i++) {
        const qmc_pixel_tile *t = &tiles[i];
        const uint64_t total = (uint64_t)t->width * t->height * t->sample_count;
        for (uint64_t max = 1; max <= total + 2; max++)
            walk(t, max);
        walk(t, UINT64_MAX);
    }
}

/* Tiles of up to 2^32 - 1 pixels a side: the arithmetic does not wrap. */
static void test_large(void **state)
{
    (void)state;
    const qmc_pixel_tile t = {1, 0, UINT32_MAX - 1, UINT32_MAX, 0, 1};
    qmc_pixel_tile p;
    /* The whole tile fits 2^64 - 1: one piece. */
    assert_int_equal(qmc_pixel_tile_piece(&t, 0, UINT64_MAX, &p), 0);
    assert_true(p.width == t.width && p.height == t.height && p.sample_count == 1);
    /* A limit of a row and a half: one row at a time. */
    const uint64_t row = t.width;
    assert_int_equal(qmc_pixel_tile_piece(&t, row * 7, row + row / 2, &p), 0);
    assert_true(p.x == 1 && p.y == 7 && p.width == t.width && p.height == 1);
    /* Half a row, from the middle of row 9: the rest of that half. */
    assert_int_equal(qmc_pixel_tile_piece(&t, row * 9 + 5, row / 2, &p), 0);
    assert_true(p.x == 6 && p.y == 9 && p.width == row / 2 && p.height == 1);
    /* The last pixel. */
    const uint64_t total = row * t.height;
    assert_int_equal(qmc_pixel_tile_piece(&t, total - 1, 3, &p), 0);
    assert_true(p.x == UINT32_MAX - 1 && p.y == UINT32_MAX - 1 && p.width == 1);
    /* Samples near 2^64: a pixel's run is cut to the limit. */
    const qmc_pixel_tile deep = {0, 0, 1, 1, 5, UINT64_MAX - 5};
    assert_int_equal(qmc_pixel_tile_piece(&deep, UINT64_MAX - 8, 100, &p), 0);
    assert_true(p.sample_start == UINT64_MAX - 3 && p.sample_count == 3);
}

static void test_refusals(void **state)
{
    (void)state;
    const qmc_pixel_tile t = {0, 0, 2, 2, 0, 4};
    qmc_pixel_tile p;
    memset(&p, 0xab, sizeof p);
    assert_int_equal(qmc_pixel_tile_piece(&t, 16, 4, &p), QMC_EINVAL); /* done past the end */
    assert_true(p.width == 0 && p.height == 0 && p.sample_count == 0);
    assert_int_equal(qmc_pixel_tile_piece(&t, 0, 0, &p), QMC_EINVAL);
    assert_int_equal(qmc_pixel_tile_piece(NULL, 0, 4, &p), QMC_EINVAL);
    assert_int_equal(qmc_pixel_tile_piece(&t, 0, 4, NULL), QMC_EINVAL);
    static const qmc_pixel_tile empty[] = {{0, 0, 0, 2, 0, 4}, {0, 0, 2, 0, 0, 4},
                                           {0, 0, 2, 2, 0, 0}};
    for (size_t i = 0; i < 3; i++)
        assert_int_equal(qmc_pixel_tile_piece(&empty[i], 0, 4, &p), QMC_EINVAL);
    /* More than 2^64 - 1 samples: not a tile one can cut. */
    const qmc_pixel_tile huge = {0, 0, UINT32_MAX, UINT32_MAX, 0, 1u << 20};
    assert_int_equal(qmc_pixel_tile_piece(&huge, 0, 4, &p), QMC_EINVAL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_orders),
        cmocka_unit_test(test_large),
        cmocka_unit_test(test_refusals),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
