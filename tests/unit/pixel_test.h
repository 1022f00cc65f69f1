/*
 * pixel_test.h - what the pixel samplers' unit tests (test_pixel*.c)
 * share: making a sampler that must be valid, a u32 fill of a tile, and
 * reading a vector file.  Included after cmocka.h; static inline, so an
 * unused helper costs nothing and the Makefile's UNIT_HELPER wildcard
 * (every .c in tests/unit/ but the tests) does not link these into every
 * other unit test.
 */
#ifndef QMC_TEST_PIXEL_TEST_H
#define QMC_TEST_PIXEL_TEST_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include "qmc/pixel.h"

/* The sampler of that spec, which must be valid: the library's reason is
 * printed before the test fails. */
static inline qmc_pixels *pixel_make(qmc_pixel_sampler s, uint32_t w, uint32_t h, uint64_t spp,
                                     uint32_t seed, uint32_t frame, uint32_t dims)
{
    qmc_pixel_spec spec = {.sampler = s, .width = w, .height = h, .spp = spp,
                           .seed = seed, .frame = frame, .dims = dims};
    char why[256] = "";
    int err = qmc_pixel_spec_check(&spec, why, sizeof why);
    if (err)
        print_error("%s: %s\n", qmc_pixel_sampler_name(s), why);
    assert_int_equal(err, 0);
    qmc_pixels *p = NULL;
    assert_int_equal(qmc_pixels_new(&spec, &p), 0);
    assert_non_null(p);
    return p;
}

/* The tile [x, x + w) x [y, y + h), samples s0 .. s0 + n - 1, filled as
 * u32 in a new buffer (the caller frees it). */
static inline uint32_t *pixel_fill_u32(const qmc_pixels *p, uint32_t x, uint32_t y, uint32_t w,
                                       uint32_t h, uint64_t s0, uint64_t n)
{
    qmc_pixel_tile t = {.x = x, .y = y, .width = w, .height = h, .sample_start = s0,
                        .sample_count = n};
    uint64_t values = 0;
    assert_int_equal(qmc_pixels_tile_check(p, &t, &values, NULL, 0), 0);
    uint32_t *buf = malloc(values * sizeof *buf);
    assert_non_null(buf);
    assert_int_equal(qmc_pixels_fill(p, &t, QMC_FORMAT_U32, buf), 0);
    return buf;
}

/* A vector file of tests/vectors/, opened from the repository root (as
 * make test runs). */
static inline FILE *pixel_vectors_open(const char *path)
{
    FILE *f = fopen(path, "r");
    if (!f)
        print_error("cannot open %s (run from the repository root)\n", path);
    assert_non_null(f);
    return f;
}

/* The file's next vector line into line, past comments (#) and blank
 * lines; 0 at its end. */
static inline int pixel_vectors_next(FILE *f, char *line, int bytes)
{
    while (fgets(line, bytes, f))
        if (line[0] != '#' && line[0] != '\n')
            return 1;
    return 0;
}

#endif
