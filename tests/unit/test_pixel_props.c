/*
 * test_pixel_props.c - what the pixel samplers promise beyond single
 * values: each pixel's samples form (0, m, 2)-nets (every elementary
 * interval shape), frames decorrelate the image without aliasing sample
 * indices, a distributed split concatenates to one fill, and the sobol
 * sampler's pixel-to-index map agrees with the global Sobol' sequence.
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pixel_test.h"
#include "qmc/pixel.h"

static const qmc_pixel_sampler all[] = {QMC_PIXEL_ZSOBOL, QMC_PIXEL_PADDED_SOBOL,
                                        QMC_PIXEL_SOBOL};

/* Top b bits of a 32-bit value (b in 0..32). */
static uint32_t topbits(uint32_t v, uint32_t b)
{
    return b == 0 ? 0 : v >> (32 - b);
}

/*
 * Whether n = 2^m points (x[k * stride], y[k * stride]) form a (0, m,
 * 2)-net in base 2: every elementary interval of area 2^-m, of every
 * shape 2^-a x 2^-(m-a), holds exactly one point.
 */
static int is_net(const uint32_t *xy, size_t stride, uint32_t m)
{
    const size_t n = (size_t)1 << m;
    unsigned char *seen = calloc(n, 1);
    assert_non_null(seen);
    int ok = 1;
    for (uint32_t a = 0; a <= m && ok; a++) {
        memset(seen, 0, n);
        for (size_t k = 0; k < n; k++) {
            const size_t box = ((size_t)topbits(xy[k * stride], a) << (m - a)) |
                               topbits(xy[k * stride + 1], m - a);
            if (seen[box]++) {
                ok = 0;
                break;
            }
        }
    }
    free(seen);
    return ok;
}

/* All spp = 2^L samples of a pixel, per dimension pair, for every L up
 * to 10: a (0, L, 2)-net, at several pixels, seeds and frames. */
static void test_pixel_samples_are_nets(void **state)
{
    (void)state;
    static const uint32_t px[][2] = {{0, 0}, {5, 3}, {63, 62}, {17, 40}};
    for (size_t s = 0; s < 2; s++)
        for (uint32_t L = 0; L <= 10; L++)
            for (uint32_t seed = 0; seed < 2; seed++) {
                const uint32_t dims = 7, frame = seed * 3;
                qmc_pixels *p = pixel_make(all[s], 64, 64, 1ull << L, seed * 977, frame, dims);
                for (size_t q = 0; q < 4; q++) {
                    uint32_t *v = pixel_fill_u32(p, px[q][0], px[q][1], 1, 1, 0, 1ull << L);
                    for (uint32_t k = 0; k + 1 < dims; k += 2)
                        assert_true(is_net(v + k, dims, L));
                    free(v);
                }
                qmc_pixels_free(p);
            }
}

/*
 * zsobol's digit tree: any aligned run of 2^m samples of a pixel is a
 * (0, m, 2)-net when m has log2(spp)'s parity (its base-4 digits are whole
 * there).  For the other parity it is not in general, and padded-sobol's
 * shuffled prefixes are not either: docs/SEQUENCES.md says so, and these
 * counts keep the claim honest.
 */
static void test_prefix_nets(void **state)
{
    (void)state;
    for (uint32_t L = 2; L <= 9; L++) {
        qmc_pixels *z = pixel_make(QMC_PIXEL_ZSOBOL, 32, 32, 1ull << L, 11, 0, 4);
        qmc_pixels *pd = pixel_make(QMC_PIXEL_PADDED_SOBOL, 32, 32, 1ull << L, 11, 0, 4);
        unsigned z_other = 0, z_other_bad = 0, pd_bad = 0, pd_n = 0;
        for (uint32_t y = 0; y < 32; y += 7)
            for (uint32_t x = 0; x < 32; x += 5) {
                uint32_t *v = pixel_fill_u32(z, x, y, 1, 1, 0, 1ull << L);
                uint32_t *w = pixel_fill_u32(pd, x, y, 1, 1, 0, 1ull << L);
                for (uint32_t m = 1; m < L; m++)
                    for (uint64_t q = 0; q < (1ull << (L - m)); q++)
                        for (uint32_t k = 0; k < 4; k += 2) {
                            const uint32_t *blk = v + ((q << m) * 4) + k;
                            if ((L - m) % 2 == 0) {
                                assert_true(is_net(blk, 4, m));
                            } else {
                                z_other++;
                                z_other_bad += !is_net(blk, 4, m);
                            }
                            if (q == 0) {
                                pd_n++;
                                pd_bad += !is_net(w + k, 4, m);
                            }
                        }
                free(v);
                free(w);
            }
        if (L >= 3) {
            assert_true(z_other_bad > 0 && z_other_bad < z_other);
            assert_true(pd_bad > 0 && pd_bad < pd_n);
        }
        qmc_pixels_free(z);
        qmc_pixels_free(pd);
    }
}

/* Frame f != 0 changes (nearly) every value; a frame is deterministic. */
static void test_frames_differ_and_repeat(void **state)
{
    (void)state;
    static const uint32_t frames[] = {1, 2, 1000, 0xffffffffu};
    const uint32_t dims = 6, n = 16 * 16 * 16 * dims;
    for (size_t s = 0; s < 3; s++) {
        qmc_pixels *p0 = pixel_make(all[s], 40, 30, 16, 5, 0, dims);
        uint32_t *a = pixel_fill_u32(p0, 20, 10, 16, 16, 0, 16);
        for (size_t f = 0; f < 4; f++) {
            qmc_pixels *p1 = pixel_make(all[s], 40, 30, 16, 5, frames[f], dims);
            qmc_pixels *p2 = pixel_make(all[s], 40, 30, 16, 5, frames[f], dims);
            uint32_t *b = pixel_fill_u32(p1, 20, 10, 16, 16, 0, 16);
            uint32_t *c = pixel_fill_u32(p2, 20, 10, 16, 16, 0, 16);
            assert_memory_equal(b, c, (size_t)n * sizeof *b);
            unsigned same = 0;
            for (uint32_t k = 0; k < n; k++)
                same += a[k] == b[k];
            /* Independent 32-bit values agree with probability 2^-32. */
            assert_true(same <= 2);
            free(b);
            free(c);
            qmc_pixels_free(p1);
            qmc_pixels_free(p2);
        }
        free(a);
        qmc_pixels_free(p0);
    }
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

/* Frame and sample index never alias: no (value 2, value 3) pair of frame
 * 1 appears among any sample of frame 0 of the same pixel (OpenQMC folds
 * index bits into the frame, so there some do). */
static void test_frames_do_not_alias_samples(void **state)
{
    (void)state;
    const uint32_t dims = 4, spp = 256;
    for (size_t s = 0; s < 3; s++) {
        qmc_pixels *p0 = pixel_make(all[s], 8, 8, spp, 3, 0, dims);
        qmc_pixels *p1 = pixel_make(all[s], 8, 8, spp, 3, 1, dims);
        for (uint32_t y = 0; y < 8; y += 3)
            for (uint32_t x = 0; x < 8; x += 3) {
                uint32_t *a = pixel_fill_u32(p0, x, y, 1, 1, 0, spp);
                uint32_t *b = pixel_fill_u32(p1, x, y, 1, 1, 0, spp);
                uint64_t pa[256], pb[256];
                for (uint32_t i = 0; i < spp; i++) {
                    pa[i] = (uint64_t)a[i * dims + 2] << 32 | a[i * dims + 3];
                    pb[i] = (uint64_t)b[i * dims + 2] << 32 | b[i * dims + 3];
                }
                qsort(pa, spp, sizeof pa[0], cmp_u64);
                for (uint32_t i = 0; i < spp; i++)
                    assert_null(bsearch(&pb[i], pa, spp, sizeof pa[0], cmp_u64));
                free(a);
                free(b);
            }
        qmc_pixels_free(p0);
        qmc_pixels_free(p1);
    }
}

/* Per-pixel error of a disk's area (radius 0.4 about the centre) from
 * the pair (k, k + 1), over a 64x64 image at spp 16. */
static void disk_errors(const qmc_pixels *p, uint32_t k, double *err)
{
    const uint32_t dims = qmc_pixels_get_spec(p)->dims, spp = 16;
    uint32_t *v = pixel_fill_u32(p, 0, 0, 64, 64, 0, spp);
    const double truth = 3.14159265358979323846 * 0.16;
    for (size_t px = 0; px < 64 * 64; px++) {
        unsigned in = 0;
        for (uint32_t i = 0; i < spp; i++) {
            const uint32_t *s = v + (px * spp + i) * dims + k;
            double u = s[0] * 0x1p-32 - 0.5, w = s[1] * 0x1p-32 - 0.5;
            in += u * u + w * w < 0.16;
        }
        err[px] = (double)in / spp - truth;
    }
    free(v);
}

static double correlation(const double *a, const double *b, size_t n)
{
    double ma = 0, mb = 0, sab = 0, saa = 0, sbb = 0;
    for (size_t i = 0; i < n; i++) {
        ma += a[i];
        mb += b[i];
    }
    ma /= (double)n;
    mb /= (double)n;
    for (size_t i = 0; i < n; i++) {
        sab += (a[i] - ma) * (b[i] - mb);
        saa += (a[i] - ma) * (a[i] - ma);
        sbb += (b[i] - mb) * (b[i] - mb);
    }
    assert_true(saa > 0 && sbb > 0);
    return sab / sqrt(saa * sbb);
}

/*
 * Frames decorrelate the image: the per-pixel errors of frame 0 and frame
 * f are uncorrelated.  For N = 4096 independent pairs the sample
 * correlation has standard deviation about 1/sqrt(N) = 0.0156; the bound
 * 0.0625 is four of them (a false alarm about 6e-5 per comparison).  The
 * same frame twice correlates fully, so the measure can see correlation.
 */
static void test_frames_decorrelate_errors(void **state)
{
    (void)state;
    const size_t n = 64 * 64;
    double *e0 = malloc(n * sizeof *e0), *e1 = malloc(n * sizeof *e1);
    assert_true(e0 && e1);
    static const uint32_t frames[] = {1, 2, 77};
    for (size_t s = 0; s < 3; s++) {
        qmc_pixels *p0 = pixel_make(all[s], 64, 64, 16, 42, 0, 4);
        for (uint32_t k = 0; k < 4; k += 2) {
            disk_errors(p0, k, e0);
            disk_errors(p0, k, e1);
            assert_true(correlation(e0, e1, n) > 0.999);
            for (size_t f = 0; f < 3; f++) {
                qmc_pixels *p1 = pixel_make(all[s], 64, 64, 16, 42, frames[f], 4);
                disk_errors(p1, k, e1);
                double r = correlation(e0, e1, n);
                if (getenv("PIXEL_SHOW_R") || fabs(r) >= 0.0625)
                    print_error("%s pair %u frame %u: r = %g\n",
                                qmc_pixel_sampler_name(all[s]), k, frames[f], r);
                assert_true(fabs(r) < 0.0625);
                qmc_pixels_free(p1);
            }
        }
        qmc_pixels_free(p0);
    }
    free(e0);
    free(e1);
}

/* Node k of K fills samples [k spp / K, (k + 1) spp / K); per pixel, the
 * nodes' outputs in order are one fill of all spp. */
static void test_distributed_split(void **state)
{
    (void)state;
    const uint32_t dims = 5, w = 6, h = 4;
    static const uint32_t nodes[] = {2, 3, 7};
    for (size_t s = 0; s < 3; s++) {
        const uint64_t spp = all[s] == QMC_PIXEL_PADDED_SOBOL ? 100 : 256;
        qmc_pixels *p = pixel_make(all[s], 30, 20, spp, 8, 4, dims);
        uint32_t *whole = pixel_fill_u32(p, 20, 10, w, h, 0, spp);
        uint32_t *joined = calloc((size_t)w * h * spp * dims, sizeof *joined);
        assert_non_null(joined);
        for (size_t q = 0; q < 3; q++) {
            const uint32_t K = nodes[q];
            memset(joined, 0, (size_t)w * h * spp * dims * sizeof *joined);
            for (uint32_t k = 0; k < K; k++) {
                const uint64_t a = k * spp / K, b = (k + 1) * spp / K;
                uint32_t *part = pixel_fill_u32(p, 20, 10, w, h, a, b - a);
                for (size_t px = 0; px < (size_t)w * h; px++)
                    memcpy(joined + (px * spp + a) * dims, part + px * (b - a) * dims,
                           (size_t)(b - a) * dims * sizeof *part);
                free(part);
            }
            assert_memory_equal(joined, whole, (size_t)w * h * spp * dims * sizeof *whole);
        }
        free(joined);
        free(whole);
        qmc_pixels_free(p);
    }
}

/*
 * The sobol sampler's map, against the global sequence (seq_sobol.c, its
 * own direction-number code): over all pixels of a 2^m x 2^m image,
 * sample f's first two coordinates in image space, x 2^(32-m) + u0 / 2^m,
 * are exactly points f 4^m .. (f + 1) 4^m - 1 of the unscrambled Sobol'
 * sequence.
 */
static void test_sobol_map_matches_sequence(void **state)
{
    (void)state;
    static const uint64_t fs[] = {0, 1, 7, 1000};
    for (uint32_t m = 1; m <= 4; m++) {
        const uint32_t side = 1u << m, n = side * side;
        qmc_pixels *p = pixel_make(QMC_PIXEL_SOBOL, side, side, 4096, 0, 0, 2);
        qmc_seq_spec ss = {.kind = QMC_SEQ_SOBOL, .dims = 2, .scramble = QMC_SCRAMBLE_NONE};
        qmc_seq *seq = NULL;
        assert_int_equal(qmc_seq_new(&ss, &seq), 0);
        for (size_t q = 0; q < 4; q++) {
            uint64_t *ours = malloc(n * sizeof *ours), *want = malloc(n * sizeof *want);
            uint32_t *pts = malloc(2 * n * sizeof *pts);
            assert_true(ours && want && pts);
            uint32_t *v = pixel_fill_u32(p, 0, 0, side, side, fs[q], 1);
            for (uint32_t k = 0; k < n; k++) {
                const uint32_t x = k % side, y = k / side;
                const uint32_t d0 = x << (32 - m) | v[2 * k] >> m;
                const uint32_t d1 = y << (32 - m) | v[2 * k + 1] >> m;
                /* u * scale - pixel is exact: its low m bits are 0. */
                assert_int_equal(v[2 * k] & (side - 1), 0);
                ours[k] = (uint64_t)d0 << 32 | d1;
            }
            assert_int_equal(qmc_seq_fill(seq, fs[q] * n, n, QMC_FORMAT_U32, pts), 0);
            for (uint32_t k = 0; k < n; k++)
                want[k] = (uint64_t)pts[2 * k] << 32 | pts[2 * k + 1];
            qsort(ours, n, sizeof *ours, cmp_u64);
            qsort(want, n, sizeof *want, cmp_u64);
            assert_memory_equal(ours, want, n * sizeof *ours);
            free(v);
            free(ours);
            free(want);
            free(pts);
        }
        qmc_seq_free(seq);
        qmc_pixels_free(p);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_pixel_samples_are_nets),
        cmocka_unit_test(test_prefix_nets),
        cmocka_unit_test(test_frames_differ_and_repeat),
        cmocka_unit_test(test_frames_do_not_alias_samples),
        cmocka_unit_test(test_frames_decorrelate_errors),
        cmocka_unit_test(test_distributed_split),
        cmocka_unit_test(test_sobol_map_matches_sequence),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
