/*
 * test_pixel_pbrt.c - the pixel samplers against pbrt-v4's own values.
 *
 * tests/vectors/pixels_pbrt.txt was made by compiling pbrt-v4's unchanged
 * samplers outside this tree (its header says how); every line is checked
 * here with qmc_pixels_at at frame 0, and a sample of lines again through
 * qmc_pixels_fill.  Also: our 64-column Sobol' matrices against entries of
 * pbrt-v4's SobolMatrices32 (util/sobolmatrices.cpp), copied as numbers.
 * Run from the repository root (as make test does).
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pixel_test.h"
#include "qmc/pixel.h"
#include "sobol_wide.h"

#define VECTORS "tests/vectors/pixels_pbrt.txt"

/* Every vector, by random access; every 7th again by a one-pixel fill. */
static void test_pbrt_vectors(void **state)
{
    (void)state;
    FILE *f = pixel_vectors_open(VECTORS);
    char line[512];
    unsigned n = 0, bad = 0, per[4] = {0};
    while (pixel_vectors_next(f, line, sizeof line)) {
        char name[32];
        unsigned long long spp, sample;
        unsigned w, h, seed, x, y, dim, v0, v1;
        int got = sscanf(line, "%31s %llu %u %u %u %u %u %llu %u %u %u", name, &spp, &w, &h,
                         &seed, &x, &y, &sample, &dim, &v0, &v1);
        qmc_pixel_sampler s;
        assert_int_equal(qmc_pixel_sampler_parse(name, &s), 0);
        const int pair = s != QMC_PIXEL_SOBOL;
        assert_int_equal(got, pair ? 11 : 10);
        const uint32_t dims = dim + (pair ? 2 : 1);
        qmc_pixels *p = pixel_make(s, w, h, spp, seed, 0, dims);
        uint32_t want[2] = {v0, v1}, have[2] = {0, 0};
        for (int k = 0; k < 1 + pair; k++) {
            assert_int_equal(qmc_pixels_at(p, x, y, sample, dim + (uint32_t)k, &have[k]), 0);
            if (have[k] != want[k]) {
                if (bad < 10)
                    print_error("%s value %d: ours %u, pbrt %u\n", strtok(line, "\n"), k,
                                have[k], want[k]);
                bad++;
            }
        }
        if (n % 7 == 0) {
            uint32_t *buf = pixel_fill_u32(p, x, y, 1, 1, sample, 1);
            for (int k = 0; k < 1 + pair; k++)
                assert_int_equal(buf[dim + (uint32_t)k], want[k]);
            free(buf);
        }
        per[s]++;
        n++;
        qmc_pixels_free(p);
    }
    fclose(f);
    assert_int_equal(bad, 0);
    /* The file covers all three samplers, thousands of vectors. */
    assert_true(per[QMC_PIXEL_ZSOBOL] > 1000 && per[QMC_PIXEL_PADDED_SOBOL] > 1000 &&
                per[QMC_PIXEL_SOBOL] > 1000);
}

/* pbrt-v4's SobolMatrices32[dim * 52 + col], read from its sobolmatrices.cpp. */
static void test_sobol_matrices_match_pbrt(void **state)
{
    (void)state;
    static const struct {
        uint32_t dim, col, value;
    } pbrt[] = {
        {0, 0, 0x80000000u},    {0, 31, 0x00000001u},   {0, 32, 0x00000000u},
        {1, 0, 0x80000000u},    {1, 4, 0x88000000u},    {1, 31, 0xffffffffu},
        {1, 32, 0x80000000u},   {1, 33, 0xc0000000u},   {1, 51, 0xf000f000u},
        {2, 2, 0x60000000u},    {2, 9, 0x9cc00000u},    {2, 40, 0xe880e880u},
        {7, 17, 0x491b4000u},   {500, 3, 0x10000000u},  {500, 45, 0x0696302du},
        {1023, 0, 0x80000000u}, {1023, 30, 0xb41fd1beu}, {1023, 51, 0x1397876eu},
    };
    uint32_t cols[QMC__SOBOL_WIDE_COLS];
    for (size_t k = 0; k < sizeof pbrt / sizeof pbrt[0]; k++) {
        qmc__sobol_wide_columns(pbrt[k].dim, cols);
        assert_int_equal(cols[pbrt[k].col], pbrt[k].value);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_pbrt_vectors),
        cmocka_unit_test(test_sobol_matrices_match_pbrt),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
