/*
 * test_pixel_oracle.c - the pixel samplers against an independent
 * reference written from docs/SEQUENCES.md, frames included.
 *
 * tests/vectors/pixels_oracle.txt comes from
 * tests/vectors/gen_pixel_oracle.py (Python, exact integers, the sobol
 * index found by search rather than by solving), so a value the page does
 * not define completely, or that the C code computes otherwise, fails
 * here.  pbrt-v4's own values cover frame 0 (test_pixel_pbrt.c); this
 * covers the frames pbrt has not.  Run from the repository root.
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

#define VECTORS "tests/vectors/pixels_oracle.txt"

static void test_oracle_vectors(void **state)
{
    (void)state;
    FILE *f = pixel_vectors_open(VECTORS);
    char line[512];
    unsigned n = 0, bad = 0, framed = 0, per[4] = {0};
    while (pixel_vectors_next(f, line, sizeof line)) {
        char name[32];
        unsigned long long spp, sample;
        unsigned w, h, seed, frame, x, y, dim, want;
        assert_int_equal(sscanf(line, "%31s %llu %u %u %u %u %u %u %llu %u %u", name, &spp, &w,
                                &h, &seed, &frame, &x, &y, &sample, &dim, &want),
                         11);
        qmc_pixel_sampler s;
        assert_int_equal(qmc_pixel_sampler_parse(name, &s), 0);
        qmc_pixels *p = pixel_make(s, w, h, spp, seed, frame, dim + 1);
        uint32_t have = 0;
        assert_int_equal(qmc_pixels_at(p, x, y, sample, dim, &have), 0);
        /* And through a one-pixel fill: the last value of its row. */
        uint32_t *row = pixel_fill_u32(p, x, y, 1, 1, sample, 1);
        if (have != want || row[dim] != want) {
            if (bad < 10)
                print_error("%s: at %u, fill %u, oracle %u\n", strtok(line, "\n"), have,
                            row[dim], want);
            bad++;
        }
        free(row);
        qmc_pixels_free(p);
        per[s]++;
        framed += frame != 0;
        n++;
    }
    fclose(f);
    assert_int_equal(bad, 0);
    assert_true(per[QMC_PIXEL_ZSOBOL] >= 50 && per[QMC_PIXEL_PADDED_SOBOL] >= 50 &&
                per[QMC_PIXEL_SOBOL] >= 50 && framed >= n / 2);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_oracle_vectors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
