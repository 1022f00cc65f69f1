/*
 * test_pixel.c - pixel samplers: random access == tile fills in every
 * format, shape and range; every limit refused with its code and a reason
 * that names the fix; names.  Properties (nets, frames, the distributed
 * split) are in test_pixel_props.c, pbrt-v4's values in test_pixel_pbrt.c.
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <stdlib.h>
#include <string.h>

#include "pixel_impl.h"
#include "pixel_test.h"
#include "qmc/pixel.h"

static const qmc_pixel_sampler all[] = {QMC_PIXEL_ZSOBOL, QMC_PIXEL_PADDED_SOBOL,
                                        QMC_PIXEL_SOBOL};

static uint32_t at(const qmc_pixels *p, uint32_t x, uint32_t y, uint64_t i, uint32_t d)
{
    uint32_t v = 1;
    assert_int_equal(qmc_pixels_at(p, x, y, i, d, &v), 0);
    return v;
}

/*
 * Fills the tile in all three formats and compares every element with
 * at() under pixel.h's conventions: u32 is v, f64 is v / 2^32, f32 is
 * floor(v / 2^8) / 2^24 (computed here in double, independently of the
 * library's float path).
 */
static void check_tile(const qmc_pixels *p, qmc_pixel_tile t)
{
    const uint32_t dims = qmc_pixels_get_spec(p)->dims;
    uint64_t n = 0;
    char why[256] = "";
    int err = qmc_pixels_tile_check(p, &t, &n, why, sizeof why);
    if (err)
        print_error("tile refused: %s\n", why);
    assert_int_equal(err, 0);
    assert_int_equal(n, (uint64_t)t.width * t.height * t.sample_count * dims);
    uint32_t *u = malloc(n * sizeof *u);
    float *f = malloc(n * sizeof *f);
    double *g = malloc(n * sizeof *g);
    assert_true(u && f && g);
    assert_int_equal(qmc_pixels_fill(p, &t, QMC_FORMAT_U32, u), 0);
    assert_int_equal(qmc_pixels_fill(p, &t, QMC_FORMAT_F32, f), 0);
    assert_int_equal(qmc_pixels_fill(p, &t, QMC_FORMAT_F64, g), 0);
    size_t k = 0;
    for (uint32_t y = t.y; y < t.y + t.height; y++)
        for (uint32_t x = t.x; x < t.x + t.width; x++)
            for (uint64_t i = t.sample_start; i < t.sample_start + t.sample_count; i++)
                for (uint32_t d = 0; d < dims; d++, k++) {
                    uint32_t v = at(p, x, y, i, d);
                    if (u[k] != v)
                        print_error("pixel (%u,%u) sample %llu dim %u: fill %u, at %u\n", x,
                                    y, (unsigned long long)i, d, u[k], v);
                    assert_int_equal(u[k], v);
                    assert_true(g[k] == (double)v / 4294967296.0);
                    assert_true((double)f[k] == (double)(v >> 8) / 16777216.0);
                }
    assert_int_equal(k, n);
    free(u);
    free(f);
    free(g);
}

static qmc_pixel_tile tile(uint32_t x, uint32_t y, uint32_t w, uint32_t h, uint64_t s0,
                           uint64_t n)
{
    qmc_pixel_tile t = {.x = x, .y = y, .width = w, .height = h, .sample_start = s0,
                        .sample_count = n};
    return t;
}

/* Whole small images, every sample, many dims counts (odd ones too). */
static void test_fill_equals_at_small(void **state)
{
    (void)state;
    static const uint32_t dims[] = {1, 2, 3, 5, 8, 13};
    static const uint64_t spps[] = {1, 2, 4, 8, 16, 32, 64};
    for (size_t s = 0; s < 3; s++)
        for (size_t j = 0; j < sizeof dims / sizeof dims[0]; j++)
            for (size_t q = 0; q < sizeof spps / sizeof spps[0]; q++) {
                qmc_pixels *p = pixel_make(all[s], 7, 5, spps[q], (uint32_t)(q * 977 + j), 0, dims[j]);
                check_tile(p, tile(0, 0, 7, 5, 0, spps[q]));
                qmc_pixels_free(p);
            }
}

/* Tiles on the image's edges, sample runs not starting at 0, frames. */
static void test_fill_equals_at_edges(void **state)
{
    (void)state;
    for (size_t s = 0; s < 3; s++)
        for (uint32_t frame = 0; frame < 3; frame++) {
            qmc_pixels *p = pixel_make(all[s], 100, 37, 256, 12345 + frame, frame * 7919, 9);
            check_tile(p, tile(96, 0, 4, 3, 0, 256));     /* right edge */
            check_tile(p, tile(0, 34, 5, 3, 100, 37));    /* bottom edge */
            check_tile(p, tile(99, 36, 1, 1, 255, 1));    /* last pixel, last sample */
            check_tile(p, tile(31, 17, 6, 2, 3, 250));    /* unaligned run */
            check_tile(p, tile(64, 16, 3, 3, 128, 64));   /* aligned half */
            qmc_pixels_free(p);
        }
}

/* The fast paths' block boundaries: long sample runs, many dims. */
static void test_fill_equals_at_blocks(void **state)
{
    (void)state;
    static const uint32_t dims[] = {2, 7, 40, 515, 4099};
    for (size_t s = 0; s < 3; s++)
        for (size_t j = 0; j < sizeof dims / sizeof dims[0]; j++) {
            uint64_t spp = dims[j] > 100 ? 8 : 4096;
            qmc_pixels *p = pixel_make(all[s], 64, 64, spp, 99, 1, dims[j]);
            check_tile(p, tile(60, 61, 2, 2, spp > 8 ? 1000 : 3, spp > 8 ? 3000 : 5));
            qmc_pixels_free(p);
        }
    /* One value per sample: the longest blocks, and zsobol's odd log2 spp
     * has a tree node per 2 samples at the bottom. */
    for (size_t s = 0; s < 3; s++) {
        qmc_pixels *p = pixel_make(all[s], 3, 3, 1u << 13, 5, 2, 1);
        check_tile(p, tile(1, 1, 2, 1, 0, 1u << 13));
        qmc_pixels_free(p);
    }
    /* padded-sobol's spp need not be a power of two (cycle walking). */
    qmc_pixels *p = pixel_make(QMC_PIXEL_PADDED_SOBOL, 33, 9, 1000, 5, 0, 6);
    check_tile(p, tile(30, 4, 3, 5, 0, 1000));
    check_tile(p, tile(0, 0, 2, 2, 999, 1));
    qmc_pixels_free(p);
}

/* Non-square and huge images, pixels past 65535, 64-bit sample runs. */
static void test_fill_equals_at_huge(void **state)
{
    (void)state;
    const uint32_t big = 4294967295u;
    /* zsobol: a 2^32-wide image leaves no bits for samples beyond 1. */
    qmc_pixels *p = pixel_make(QMC_PIXEL_ZSOBOL, big, 3, 1, 7, 0, 4);
    check_tile(p, tile(big - 3, 0, 3, 3, 0, 1));
    qmc_pixels_free(p);
    p = pixel_make(QMC_PIXEL_ZSOBOL, 70000, 3, 1u << 20, 7, 2, 5);
    check_tile(p, tile(69998, 1, 2, 2, (1u << 20) - 40, 40));
    qmc_pixels_free(p);
    /* zsobol with a 1x1 image: 2^63 samples, the index is all sample. */
    p = pixel_make(QMC_PIXEL_ZSOBOL, 1, 1, 1ull << 63, 3, 0, 3);
    check_tile(p, tile(0, 0, 1, 1, (1ull << 63) - 100, 100));
    check_tile(p, tile(0, 0, 1, 1, 0xfffffffeull, 5));
    qmc_pixels_free(p);
    /* zsobol's fast path at its edge: sample parts of 32 and 31 bits. */
    p = pixel_make(QMC_PIXEL_ZSOBOL, 2, 2, 1ull << 32, 9, 3, 5);
    check_tile(p, tile(0, 1, 2, 1, (1ull << 32) - 37, 37));
    check_tile(p, tile(1, 0, 1, 1, (1ull << 31) - 9, 20));
    qmc_pixels_free(p);
    p = pixel_make(QMC_PIXEL_ZSOBOL, 3, 2, 1ull << 31, 9, 0, 2);
    check_tile(p, tile(2, 1, 1, 1, (1ull << 31) - 45, 45));
    qmc_pixels_free(p);
    /* padded-sobol: spp 2^32, the largest its shuffle takes. */
    p = pixel_make(QMC_PIXEL_PADDED_SOBOL, 3, big, 1ull << 32, 11, 0, 4);
    check_tile(p, tile(0, big - 2, 3, 2, (1ull << 32) - 20, 20));
    qmc_pixels_free(p);
    /* sobol: 64-bit indices past 2^32 and 2^52 (pbrt's 52 columns). */
    p = pixel_make(QMC_PIXEL_SOBOL, 3, 70000, 1, 13, 0, 6);
    assert_int_equal(qmc_pixels_sample_end(p), 1ull << (64 - 2 * 17));
    check_tile(p, tile(0, 69990, 3, 10, (1ull << 30) - 7, 7));
    qmc_pixels_free(p);
    p = pixel_make(QMC_PIXEL_SOBOL, 1, 1, 1, 13, 1, 21201);
    assert_int_equal(qmc_pixels_sample_end(p), UINT64_MAX);
    check_tile(p, tile(0, 0, 1, 1, (1ull << 60) + 12345, 2));
    qmc_pixels_free(p);
    p = pixel_make(QMC_PIXEL_SOBOL, big, big, 1, 13, 0, 3);
    assert_int_equal(qmc_pixels_sample_end(p), 1);
    check_tile(p, tile(big - 2, big - 2, 2, 2, 0, 1));
    qmc_pixels_free(p);
}

/* Every kernel build this CPU runs (baseline, AVX2, AVX-512) gives the
 * same bits as at(), over passes of every shape (nc <= 16 with lane
 * patterns of period up to 240, multiples of 16, a remainder) and both
 * staged and index-mode padded-sobol. */
static void test_instruction_sets_agree(void **state)
{
    (void)state;
    static const uint32_t dims[] = {3, 8, 15, 16, 37, 70};
    const int best = qmc__pixel_isa();
    int runs = 0;
    for (int isa = 0; isa <= best; isa++)
        for (size_t s = 0; s < 3; s++)
            for (size_t j = 0; j < sizeof dims / sizeof dims[0]; j++) {
                const uint64_t spp = all[s] == QMC_PIXEL_PADDED_SOBOL && j % 2 ? 24 : 32;
                qmc_pixels *p = pixel_make(all[s], 20, 12, spp, 77, (uint32_t)j % 2, dims[j]);
                p->isa = isa;
                check_tile(p, tile(17, 9, 3, 3, 5, spp - 5));
                qmc_pixels_free(p);
                runs++;
            }
    print_message("kernel builds compared: %d of 3 (runs %d)\n", best + 1, runs);
}

/* zsobol's vector node hashes (MixBits, then mod 24 through a double)
 * against the scalar definition, in every kernel build, over keys whose
 * hashes reach every residue and the extremes of h >> 24. */
static void test_node_hashes(void **state)
{
    (void)state;
    enum { N = 4096 };
    uint8_t got[N + 16];
    uint64_t key = 0x0123456789abcdefull;
    for (int isa = 0; isa <= qmc__pixel_isa(); isa++)
        for (int round = 0; round < 64;
             round++, key = key * 6364136223846793005ull + 1442695040888963407ull)
            for (int bit = 0; bit < 2; bit++) {
                const uint64_t salt = key >> 7;
                qmc__pixel_nodes(isa, key, salt, N, bit, got);
                for (uint32_t j = 0; j < N; j++) {
                    const uint64_t h = qmc__mix_bits((key + j) ^ salt);
                    assert_int_equal(got[j], bit ? h & 1u : (h >> 24) % 24);
                }
            }
    /* The largest x = h >> 24 and the multiples of 24 around it: through
     * the same double arithmetic, checked by brute force on the scalar
     * mirror of the kernel's steps. */
    for (uint64_t x = (1ull << 40) - 1; x > (1ull << 40) - 100000; x--) {
        const double d = (double)x;
        const double z = (d * (1.0 / 24) - 11.5 / 24) + 0x1.8p52;
        uint64_t q;
        memcpy(&q, &z, sizeof q);
        q -= 0x4338000000000000ull;
        assert_int_equal(x - 24 * q, x % 24);
    }
}

/* An odd dims count ends with the first value of the next pair, and the
 * dims count never changes a value. */
static void test_odd_dims_and_prefixes(void **state)
{
    (void)state;
    for (size_t s = 0; s < 3; s++) {
        qmc_pixels *a = pixel_make(all[s], 16, 16, 16, 4, 0, 5);
        qmc_pixels *b = pixel_make(all[s], 16, 16, 16, 4, 0, 12);
        for (uint32_t y = 0; y < 16; y += 5)
            for (uint32_t x = 0; x < 16; x += 3)
                for (uint64_t i = 0; i < 16; i++)
                    for (uint32_t d = 0; d < 5; d++)
                        assert_int_equal(at(a, x, y, i, d), at(b, x, y, i, d));
        qmc_pixels_free(a);
        qmc_pixels_free(b);
    }
}

static void expect_spec(qmc_pixel_sampler s, uint32_t w, uint32_t h, uint64_t spp, uint32_t dims,
                        int code, const char *k1, const char *k2)
{
    qmc_pixel_spec spec = {.sampler = s, .width = w, .height = h, .spp = spp, .dims = dims};
    char why[256] = "";
    assert_int_equal(qmc_pixel_spec_check(&spec, why, sizeof why), code);
    if (!strstr(why, k1) || (k2 && !strstr(why, k2)))
        print_error("reason \"%s\" lacks \"%s\" / \"%s\"\n", why, k1, k2 ? k2 : "");
    assert_non_null(strstr(why, k1));
    if (k2)
        assert_non_null(strstr(why, k2));
    assert_null(strchr(why, '\n'));
    qmc_pixels *p = (qmc_pixels *)&spec;
    assert_int_equal(qmc_pixels_new(&spec, &p), code);
    assert_null(p);
}

static void test_spec_limits(void **state)
{
    (void)state;
    expect_spec((qmc_pixel_sampler)9, 8, 8, 4, 2, QMC_EKIND, "unknown pixel sampler 9",
                "zsobol, padded-sobol or sobol");
    for (size_t s = 0; s < 3; s++) {
        expect_spec(all[s], 0, 8, 4, 2, QMC_EINVAL, "0x8", "at least 1");
        expect_spec(all[s], 8, 0, 4, 2, QMC_EINVAL, "8x0", "at least 1");
        expect_spec(all[s], 8, 8, 4, 0, QMC_EDIMS, "dims 0", "at least 1");
        expect_spec(all[s], 8, 8, 0, 2, QMC_ECOUNT, "spp 0", "at least 1");
    }
    /* zsobol: powers of two only, and the nearest two are named. */
    expect_spec(QMC_PIXEL_ZSOBOL, 8, 8, 300, 2, QMC_ECOUNT, "not a power of two", "256 or 512");
    expect_spec(QMC_PIXEL_ZSOBOL, 8, 8, 3, 2, QMC_ECOUNT, "spp 3", "2 or 4");
    /* zsobol: the Morton index must fit 64 bits: 2 * 20 + 25 = 65. */
    expect_spec(QMC_PIXEL_ZSOBOL, 1u << 20, 5, 1u << 25, 2, QMC_ERANGE, "65 bits",
                "spp <= 16777216");
    expect_spec(QMC_PIXEL_ZSOBOL, 4294967295u, 1, 2, 2, QMC_ERANGE, "65 bits",
                "2147483648 pixels on a side");
    /* padded-sobol: any spp up to 2^32. */
    expect_spec(QMC_PIXEL_PADDED_SOBOL, 8, 8, (1ull << 32) + 1, 2, QMC_ECOUNT, "4294967297",
                "spp <= 4294967296");
    /* sobol: the Joe-Kuo table's 21201 dimensions, and the index space. */
    expect_spec(QMC_PIXEL_SOBOL, 8, 8, 4, 21202, QMC_EDIMS, "dims 21202", "dims <= 21201");
    expect_spec(QMC_PIXEL_SOBOL, 70000, 2, 1ull << 31, 2, QMC_ECOUNT, "spp 2147483648",
                "1073741824");
    /* Accepted edges. */
    qmc_pixels *p = pixel_make(QMC_PIXEL_ZSOBOL, 1u << 20, 5, 1u << 24, 1, 0, 4294967295u);
    assert_int_equal(qmc_pixels_sample_end(p), 1u << 24);
    uint32_t v = 0;
    /* The largest dimension: pbrt's int dimension + 2 wraps to 0 mod 2^32. */
    assert_int_equal(qmc_pixels_at(p, (1u << 20) - 1, 4, (1u << 24) - 1, 4294967294u, &v), 0);
    qmc_pixels_free(p);
    p = pixel_make(QMC_PIXEL_SOBOL, 8, 8, 4, 0, 0, 21201);
    assert_int_equal(qmc_pixels_at(p, 7, 7, 1000, 21200, &v), 0);
    qmc_pixels_free(p);
}

static void expect_tile(const qmc_pixels *p, qmc_pixel_tile t, int code, const char *k1,
                        const char *k2)
{
    char why[256] = "";
    uint64_t n = 77;
    assert_int_equal(qmc_pixels_tile_check(p, &t, &n, why, sizeof why), code);
    if (!strstr(why, k1) || (k2 && !strstr(why, k2)))
        print_error("reason \"%s\" lacks \"%s\" / \"%s\"\n", why, k1, k2 ? k2 : "");
    assert_non_null(strstr(why, k1));
    if (k2)
        assert_non_null(strstr(why, k2));
    /* A refused fill writes nothing. */
    uint32_t canary[4] = {1, 2, 3, 4};
    assert_int_equal(qmc_pixels_fill(p, &t, QMC_FORMAT_U32, canary), code);
    assert_int_equal(canary[0], 1);
    assert_int_equal(canary[3], 4);
}

static void test_tile_limits(void **state)
{
    (void)state;
    qmc_pixels *p = pixel_make(QMC_PIXEL_ZSOBOL, 64, 48, 256, 0, 0, 4);
    /* Past spp: refused, never another pixel's or an earlier sample. */
    expect_tile(p, tile(0, 0, 1, 1, 300, 1), QMC_ERANGE, "sample 300 is past spp 256",
                "ask for a larger spp (512 covers it)");
    expect_tile(p, tile(0, 0, 1, 1, 200, 57), QMC_ERANGE, "sample 256 is past spp 256", NULL);
    expect_tile(p, tile(0, 0, 1, 1, UINT64_MAX, 2), QMC_ERANGE, "run past 2^64", NULL);
    expect_tile(p, tile(60, 0, 5, 1, 0, 1), QMC_ERANGE, "tile 60,0,5,1", "64x48 image");
    expect_tile(p, tile(0, 48, 1, 1, 0, 1), QMC_ERANGE, "reaches past the 64x48 image", NULL);
    expect_tile(p, tile(0, 0, 0, 1, 0, 1), QMC_EINVAL, "empty tile", NULL);
    expect_tile(p, tile(0, 0, 1, 1, 0, 0), QMC_EINVAL, "empty tile", NULL);
    uint32_t v = 9;
    assert_int_equal(qmc_pixels_at(p, 0, 0, 256, 0, &v), QMC_ERANGE);
    assert_int_equal(v, 0);
    assert_int_equal(qmc_pixels_at(p, 64, 0, 0, 0, &v), QMC_ERANGE);
    assert_int_equal(qmc_pixels_at(p, 0, 48, 0, 0, &v), QMC_ERANGE);
    assert_int_equal(qmc_pixels_at(p, 0, 0, 0, 4, &v), QMC_EDIMS);
    qmc_pixel_tile ok = tile(0, 0, 1, 1, 0, 1);
    assert_int_equal(qmc_pixels_fill(p, &ok, (qmc_format)0, &v), QMC_EFORMAT);
    qmc_pixels_free(p);
    /* padded-sobol names the smallest spp that covers the sample. */
    p = pixel_make(QMC_PIXEL_PADDED_SOBOL, 8, 8, 100, 0, 0, 2);
    expect_tile(p, tile(1, 1, 1, 1, 90, 20), QMC_ERANGE, "sample 109 is past spp 100",
                "at least 110");
    qmc_pixels_free(p);
    /* sobol's end is its index space, not spp. */
    p = pixel_make(QMC_PIXEL_SOBOL, 70000, 70000, 4, 0, 0, 2);
    assert_int_equal(qmc_pixels_sample_end(p), 1u << 30);
    expect_tile(p, tile(0, 0, 1, 1, 1u << 30, 1), QMC_ERANGE, "sample 1073741824",
                "index space");
    check_tile(p, tile(69999, 69999, 1, 1, (1u << 30) - 2, 2));
    qmc_pixels_free(p);
    /* Value counts that overflow 64 bits (or f64 bytes) are refused. */
    p = pixel_make(QMC_PIXEL_ZSOBOL, 65536, 65536, 1ull << 32, 0, 0, 64);
    expect_tile(p, tile(0, 0, 65536, 65536, 0, 1ull << 32), QMC_ERANGE, "too many values",
                "split it");
    qmc_pixels_free(p);
}

static void test_names(void **state)
{
    (void)state;
    for (size_t s = 0; s < 3; s++) {
        qmc_pixel_sampler back = (qmc_pixel_sampler)0;
        assert_int_equal(qmc_pixel_sampler_parse(qmc_pixel_sampler_name(all[s]), &back), 0);
        assert_int_equal(back, all[s]);
    }
    assert_string_equal(qmc_pixel_sampler_name(QMC_PIXEL_PADDED_SOBOL), "padded-sobol");
    qmc_pixel_sampler back;
    assert_int_equal(qmc_pixel_sampler_parse("halton", &back), QMC_EKIND);
    assert_string_equal(qmc_pixel_sampler_name((qmc_pixel_sampler)42), "");
    qmc_pixels_free(NULL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fill_equals_at_small),
        cmocka_unit_test(test_fill_equals_at_edges),
        cmocka_unit_test(test_fill_equals_at_blocks),
        cmocka_unit_test(test_fill_equals_at_huge),
        cmocka_unit_test(test_instruction_sets_agree),
        cmocka_unit_test(test_node_hashes),
        cmocka_unit_test(test_odd_dims_and_prefixes),
        cmocka_unit_test(test_spec_limits),
        cmocka_unit_test(test_tile_limits),
        cmocka_unit_test(test_names),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
