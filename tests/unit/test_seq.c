/*
 * test_seq.c - sequences: known answers, SciPy vectors, random access ==
 * batch, net and stratification properties, limits and errors.
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "bits.h"
#include "qmc/seq.h"
#include "seq_fill_check.h"
#include "sobol_impl.h"
#include "sobol_table.h"
#include "../vectors/seq_vectors.h"

static qmc_seq *make(qmc_seq_kind kind, uint32_t dims, qmc_scramble scr,
                     uint64_t seed, uint64_t set_size)
{
    qmc_seq_spec spec = {.kind = kind, .dims = dims, .scramble = scr,
                         .seed = seed, .set_size = set_size};
    qmc_seq *s = NULL;
    assert_int_equal(qmc_seq_new(&spec, &s), 0);
    assert_non_null(s);
    return s;
}

static double at(const qmc_seq *s, uint64_t i, uint32_t j)
{
    double x = -1;
    assert_int_equal(qmc_seq_at(s, i, j, &x), 0);
    return x;
}

/* Joe & Kuo's reference points, dims 1-3, natural order (data/README.md). */
static void test_sobol_known_points(void **state)
{
    (void)state;
    static const double want[8][3] = {
        {0, 0, 0},           {.5, .5, .5},         {.25, .75, .75},
        {.75, .25, .25},     {.125, .625, .375},   {.625, .125, .875},
        {.375, .375, .625},  {.875, .875, .125}};
    qmc_seq *s = make(QMC_SEQ_SOBOL, 3, QMC_SCRAMBLE_NONE, 0, 0);
    double buf[24];
    assert_int_equal(qmc_seq_fill(s, 0, 8, QMC_FORMAT_F64, buf), 0);
    for (int i = 0; i < 8; i++)
        for (int j = 0; j < 3; j++) {
            assert_true(at(s, (uint64_t)i, (uint32_t)j) == want[i][j]);
            assert_true(buf[i * 3 + j] == want[i][j]);
        }
    qmc_seq_free(s);
}

/* SciPy's step i is natural point gray(i); compare all 32 bits. */
static void test_sobol_matches_scipy(void **state)
{
    (void)state;
    qmc_seq *s = make(QMC_SEQ_SOBOL, QMC_SOBOL_MAX_DIMS, QMC_SCRAMBLE_NONE, 0, 0);
    for (uint32_t i = 0; i < SCIPY_SOBOL_POINTS; i++)
        for (int k = 0; k < SCIPY_SOBOL_NDIMS; k++) {
            double x = at(s, i ^ (i >> 1), scipy_sobol_dims[k]);
            assert_int_equal((uint32_t)(x * 0x1p32), scipy_sobol_u32[i][k]);
        }
    qmc_seq_free(s);
}

static void test_sobol_table_shape(void **state)
{
    (void)state;
    assert_int_equal(qmc__sobol_table_dims, QMC_SOBOL_MAX_DIMS);
    /* Last line of new-joe-kuo-6.21201: d=21201, s=18. */
    assert_int_equal(qmc__sobol_polys[QMC_SOBOL_MAX_DIMS - 1].degree, 18);
    assert_true(qmc_sobol_table_hash() != 0);
    assert_true(qmc_sobol_table_hash() == qmc_sobol_table_hash());
}

/* Radical inverses in bases 2 and 3, by hand. */
static void test_halton_known_answers(void **state)
{
    (void)state;
    qmc_seq *s = make(QMC_SEQ_HALTON, 2, QMC_SCRAMBLE_NONE, 0, 0);
    static const double base2[] = {0, .5, .25, .75, .125, .625, .375, .875};
    static const double base3[] = {0, 1. / 3, 2. / 3, 1. / 9, 4. / 9, 7. / 9, 2. / 9, 5. / 9};
    for (int i = 0; i < 8; i++) {
        assert_true(at(s, (uint64_t)i, 0) == base2[i]);
        assert_true(at(s, (uint64_t)i, 1) == base3[i]);
    }
    /* 3^20 - 1 reverses to 1 - 3^-20: its nearest double. */
    assert_true(at(s, 3486784400ull, 1) == 1.0 - 1.0 / 3486784401.0);
    qmc_seq_free(s);
}

static void test_halton_matches_scipy(void **state)
{
    (void)state;
    qmc_seq *s = make(QMC_SEQ_HALTON, SCIPY_HALTON_DIMS, QMC_SCRAMBLE_NONE, 0, 0);
    for (uint32_t i = 0; i < SCIPY_HALTON_POINTS; i++)
        for (uint32_t j = 0; j < SCIPY_HALTON_DIMS; j++)
            /* SciPy sums digit terms in floating point and drifts by an
             * ulp or two (0.6000000000000001); ours is correctly rounded,
             * which the known-answer test checks exactly. */
            assert_true(fabs(at(s, i, j) - scipy_halton[i][j]) <= 1e-15);
    qmc_seq_free(s);
}

/* Faure's sigma_5 = (0 3 2 1 4) and sigma_7 = (0 2 5 3 1 4 6) on one digit. */
static void test_faure_permutations(void **state)
{
    (void)state;
    qmc_seq *s = make(QMC_SEQ_HALTON, 4, QMC_SCRAMBLE_FAURE, 0, 0);
    static const int sigma5[5] = {0, 3, 2, 1, 4}, sigma7[7] = {0, 2, 5, 3, 1, 4, 6};
    for (int d = 0; d < 5; d++)
        assert_true(fabs(at(s, (uint64_t)d, 2) - sigma5[d] / 5.0) < 1e-15);
    for (int d = 0; d < 7; d++)
        assert_true(fabs(at(s, (uint64_t)d, 3) - sigma7[d] / 7.0) < 1e-15);
    assert_true(at(s, 0, 3) == 0.0);
    qmc_seq_free(s);
}

typedef struct kind_case {
    qmc_seq_kind kind;
    qmc_scramble scr;
    uint32_t flags;
    uint32_t dims;
    uint64_t set_size;
} kind_case;

static const kind_case every_kind[] = {
    {QMC_SEQ_SOBOL, QMC_SCRAMBLE_NONE, 0, 7, 0},
    {QMC_SEQ_SOBOL, QMC_SCRAMBLE_SHIFT, 0, 5, 0},
    {QMC_SEQ_SOBOL, QMC_SCRAMBLE_OWEN, 0, 300, 0},
    {QMC_SEQ_SOBOL, QMC_SCRAMBLE_OWEN, QMC_SEQ_SHUFFLE, 4, 0},
    {QMC_SEQ_SOBOL, QMC_SCRAMBLE_NONE, QMC_SEQ_SHUFFLE, 3, 0},
    {QMC_SEQ_HALTON, QMC_SCRAMBLE_NONE, 0, 70, 0},
    {QMC_SEQ_HALTON, QMC_SCRAMBLE_FAURE, 0, 9, 0},
    {QMC_SEQ_HALTON, QMC_SCRAMBLE_OWEN, 0, 9, 0},
    {QMC_SEQ_HAMMERSLEY, QMC_SCRAMBLE_NONE, 0, 6, 1000003},
    {QMC_SEQ_HAMMERSLEY, QMC_SCRAMBLE_OWEN, 0, 3, 4096},
    {QMC_SEQ_RANDOM, QMC_SCRAMBLE_NONE, 0, 5, 0},
    {QMC_SEQ_STRATIFIED, QMC_SCRAMBLE_NONE, 0, 3, 27000},
    {QMC_SEQ_LHS, QMC_SCRAMBLE_NONE, 0, 4, 100003},
};

/* Random access == batch, bit for bit, in every format, at random starts;
 * and a fill split into pieces equals the whole (any partition, any thread
 * count, same bytes). */
static void test_at_equals_fill(void **state)
{
    (void)state;
    uint64_t rng = 12345;
    for (size_t c = 0; c < sizeof every_kind / sizeof every_kind[0]; c++) {
        const kind_case *k = &every_kind[c];
        qmc_seq_spec spec = {.kind = k->kind, .dims = k->dims, .scramble = k->scr,
                             .flags = k->flags, .seed = 99, .set_size = k->set_size};
        qmc_seq *s = NULL;
        assert_int_equal(qmc_seq_new(&spec, &s), 0);
        const uint64_t end = qmc_seq_end(s);
        for (int trial = 0; trial < 6; trial++) {
            const uint64_t count = 37;
            rng = qmc__mix64(rng + 1);
            uint64_t start = trial == 0 ? 0 : trial == 1 ? end - count : rng % (end - count);
            size_t n = (size_t)count * k->dims;
            double *f64 = malloc(n * sizeof *f64), *parts = malloc(n * sizeof *parts);
            float *f32 = malloc(n * sizeof *f32);
            uint32_t *u32 = malloc(n * sizeof *u32);
            assert_int_equal(qmc_seq_fill(s, start, count, QMC_FORMAT_F64, f64), 0);
            assert_int_equal(qmc_seq_fill(s, start, count, QMC_FORMAT_F32, f32), 0);
            assert_int_equal(qmc_seq_fill(s, start, count, QMC_FORMAT_U32, u32), 0);
            assert_int_equal(qmc_seq_fill(s, start, 10, QMC_FORMAT_F64, parts), 0);
            assert_int_equal(qmc_seq_fill(s, start + 10, count - 10, QMC_FORMAT_F64,
                                          parts + 10 * k->dims), 0);
            assert_memory_equal(f64, parts, n * sizeof *f64);
            for (uint64_t p = 0; p < count; p++)
                for (uint32_t j = 0; j < k->dims; j++) {
                    size_t i = (size_t)p * k->dims + j;
                    double x = at(s, start + p, j);
                    assert_memory_equal(&x, &f64[i], sizeof x);
                    assert_true(x >= 0.0 && x < 1.0);
                    assert_int_equal(u32[i], (uint32_t)(x * 0x1p32));
                    assert_true(f32[i] == (float)(floor(x * 0x1p24) * 0x1p-24));
                    assert_true(f32[i] < 1.0f);
                }
            free(f64), free(parts), free(f32), free(u32);
        }
        qmc_seq_free(s);
    }
}

/* Long fills cross every kind of carry of the incremental Halton and
 * Hammersley paths (digit 0 into 1, 1 into 2 for bases up to 199, the
 * table rows of the small bases): compare every coordinate with at(). */
static void test_long_fill_matches_at(void **state)
{
    (void)state;
    const qmc_seq_kind kinds[] = {QMC_SEQ_HALTON, QMC_SEQ_HAMMERSLEY};
    const uint64_t starts[] = {0, 1000000 - 17, 4294967296ull - 40000};
    const uint32_t dims = 46, count = 40000;
    double *buf = malloc(sizeof(double) * dims * count);
    for (size_t k = 0; k < 2; k++)
        for (size_t s0 = 0; s0 < 3; s0++) {
            qmc_seq *s = make(kinds[k], dims, QMC_SCRAMBLE_NONE, 0,
                              kinds[k] == QMC_SEQ_HAMMERSLEY ? QMC_SEQ_MAX_INDEX : 0);
            assert_int_equal(qmc_seq_fill(s, starts[s0], count, QMC_FORMAT_F64, buf), 0);
            for (uint32_t p = 0; p < count; p++)
                for (uint32_t j = 0; j < dims; j++) {
                    double x = at(s, starts[s0] + p, j);
                    if (memcmp(&x, &buf[(size_t)p * dims + j], sizeof x) != 0)
                        fail_msg("%s point %llu dim %u: fill %.17g, at %.17g",
                                 qmc_seq_kind_name(kinds[k]),
                                 (unsigned long long)(starts[s0] + p), j,
                                 buf[(size_t)p * dims + j], x);
                }
            qmc_seq_free(s);
        }
    free(buf);
}

/* Sobol fills larger than the cache write rows in order (a different loop
 * schedule, sobol_fill.h); they too must equal at() everywhere, in every
 * format.  40 dims x 20000 points x 8 bytes = 6.4 MB. */
static void test_large_sobol_fill_matches_at(void **state)
{
    (void)state;
    const qmc_scramble scr[] = {QMC_SCRAMBLE_NONE, QMC_SCRAMBLE_SHIFT, QMC_SCRAMBLE_OWEN};
    const qmc_format fmts[] = {QMC_FORMAT_F64, QMC_FORMAT_U32};
    const uint32_t dims = 40, count = 20000;
    const uint64_t start = 123456789;
    void *buf = malloc(sizeof(double) * dims * count);
    for (size_t k = 0; k < 3; k++)
        for (size_t f = 0; f < 2; f++) {
            qmc_seq *s = make(QMC_SEQ_SOBOL, dims, scr[k], 77, 0);
            assert_int_equal(qmc_seq_fill(s, start, count, fmts[f], buf), 0);
            for (uint32_t p = 0; p < count; p++)
                for (uint32_t j = 0; j < dims; j++) {
                    double x = at(s, start + p, j);
                    size_t i = (size_t)p * dims + j;
                    int same = fmts[f] == QMC_FORMAT_F64
                                   ? memcmp(&x, (double *)buf + i, sizeof x) == 0
                                   : ((uint32_t *)buf)[i] == (uint32_t)(x * 0x1p32);
                    if (!same)
                        fail_msg("%s %s point %u dim %u differs from at()",
                                 qmc_scramble_name(scr[k]), qmc_format_name(fmts[f]),
                                 p, j);
                }
            qmc_seq_free(s);
        }
    free(buf);
}

/* Every elementary interval of area 2^-m holds exactly one of the points
 * [block * 2^m, (block+1) * 2^m): the (0,m,2)-net property of Sobol dims
 * 1-2, for every shape 2^-a x 2^-(m-a). */
static void assert_zero_m_net(const uint32_t *u, uint32_t m)
{
    const uint32_t n = 1u << m;
    uint8_t *seen = calloc(n, 1);
    for (uint32_t a = 0; a <= m; a++) {
        memset(seen, 0, n);
        for (uint32_t i = 0; i < n; i++) {
            uint32_t bx = a ? u[2 * i] >> (32 - a) : 0;
            uint32_t by = m - a ? u[2 * i + 1] >> (32 - (m - a)) : 0;
            uint32_t cell = (bx << (m - a)) | by;
            assert_int_equal(seen[cell], 0);
            seen[cell] = 1;
        }
    }
    free(seen);
}

static void test_sobol_is_zero_m_two_net(void **state)
{
    (void)state;
    const qmc_scramble scr[] = {QMC_SCRAMBLE_NONE, QMC_SCRAMBLE_SHIFT, QMC_SCRAMBLE_OWEN};
    uint32_t *u = malloc(sizeof(uint32_t) * 2 * (1u << 16));
    for (int flags = 0; flags <= 1; flags++)
        for (size_t k = 0; k < 3; k++) {
            qmc_seq_spec spec = {.kind = QMC_SEQ_SOBOL, .dims = 2, .scramble = scr[k],
                                 .flags = flags ? QMC_SEQ_SHUFFLE : 0, .seed = 7 + k};
            qmc_seq *s = NULL;
            assert_int_equal(qmc_seq_new(&spec, &s), 0);
            for (uint32_t m = 1; m <= 16; m++) {
                uint64_t start = (uint64_t)(m % 3) << m; /* aligned blocks too */
                assert_int_equal(qmc_seq_fill(s, start, 1u << m, QMC_FORMAT_U32, u), 0);
                assert_zero_m_net(u, m);
            }
            qmc_seq_free(s);
        }
    free(u);
}

/* The check above must be able to fail: random points are no net. */
static void test_net_check_rejects_random(void **state)
{
    (void)state;
    qmc_seq *s = make(QMC_SEQ_RANDOM, 2, QMC_SCRAMBLE_NONE, 1, 0);
    uint32_t u[2 * 64];
    assert_int_equal(qmc_seq_fill(s, 0, 64, QMC_FORMAT_U32, u), 0);
    int collisions = 0;
    for (int i = 0; i < 64 && !collisions; i++)
        for (int j = 0; j < i; j++)
            if (u[2 * i] >> 26 == u[2 * j] >> 26)
                collisions = 1;
    assert_true(collisions); /* 64 random points in 64 columns collide */
    qmc_seq_free(s);
}

/* Radical inverses stratify 1D: the first b^k points of base b fall one per
 * interval of length b^-k, scrambled or not. */
static void test_halton_scrambles_stratify(void **state)
{
    (void)state;
    const qmc_scramble scr[] = {QMC_SCRAMBLE_NONE, QMC_SCRAMBLE_FAURE, QMC_SCRAMBLE_OWEN};
    for (size_t k = 0; k < 3; k++) {
        qmc_seq *s = make(QMC_SEQ_HALTON, 5, scr[k], 3, 0);
        static const uint32_t base[5] = {2, 3, 5, 7, 11};
        for (uint32_t j = 0; j < 5; j++) {
            uint32_t n = base[j] * base[j];
            uint8_t seen[121] = {0};
            for (uint32_t i = 0; i < n; i++) {
                /* Unscrambled points sit exactly on cell edges c/n, which
                 * the nearest double may miss from below: allow for it. */
                uint32_t cell = (uint32_t)(at(s, i, j) * n + 1e-9);
                assert_int_equal(seen[cell], 0);
                seen[cell] = 1;
            }
        }
        qmc_seq_free(s);
    }
}

/* Latin hypercube: in every dimension, one point per stratum. */
static void test_lhs_one_point_per_stratum(void **state)
{
    (void)state;
    const uint64_t sizes[] = {1, 2, 7, 64, 1000, 4099};
    for (size_t k = 0; k < sizeof sizes / sizeof sizes[0]; k++) {
        uint64_t n = sizes[k];
        qmc_seq *s = make(QMC_SEQ_LHS, 5, QMC_SCRAMBLE_NONE, 11 + k, n);
        uint8_t *seen = calloc(n, 1);
        for (uint32_t j = 0; j < 5; j++) {
            memset(seen, 0, n);
            for (uint64_t i = 0; i < n; i++) {
                uint64_t cell = (uint64_t)(at(s, i, j) * (double)n);
                assert_true(cell < n);
                assert_int_equal(seen[cell], 0);
                seen[cell] = 1;
            }
        }
        free(seen);
        qmc_seq_free(s);
    }
}

/* Jittered: one point per cell of the k^d grid. */
static void test_stratified_one_point_per_cell(void **state)
{
    (void)state;
    qmc_seq *s = make(QMC_SEQ_STRATIFIED, 3, QMC_SCRAMBLE_NONE, 5, 1000);
    uint8_t seen[1000] = {0};
    for (uint64_t i = 0; i < 1000; i++) {
        uint32_t c = 0;
        for (uint32_t j = 3; j-- > 0;)
            c = c * 10 + (uint32_t)(at(s, i, j) * 10);
        assert_int_equal(seen[c], 0);
        seen[c] = 1;
    }
    qmc_seq_free(s);
}

static void test_stratified_count_error_names_valid_counts(void **state)
{
    (void)state;
    qmc_seq_spec spec = {.kind = QMC_SEQ_STRATIFIED, .dims = 2, .set_size = 10};
    char why[200];
    assert_int_equal(qmc_seq_spec_check(&spec, why, sizeof why), QMC_ECOUNT);
    assert_non_null(strstr(why, "9 and 16"));
    spec.dims = 3;
    spec.set_size = 100;
    assert_int_equal(qmc_seq_spec_check(&spec, why, sizeof why), QMC_ECOUNT);
    assert_non_null(strstr(why, "64 and 125"));
}

/* Kensler's permutation is a bijection for every size. */
static void test_permutation_is_bijective(void **state)
{
    (void)state;
    const uint64_t sizes[] = {1, 2, 3, 5, 17, 100, 1000, 65537};
    for (size_t k = 0; k < sizeof sizes / sizeof sizes[0]; k++) {
        uint64_t n = sizes[k];
        uint8_t *seen = calloc(n, 1);
        for (uint64_t i = 0; i < n; i++) {
            uint64_t p = qmc__permute(i, n, 0x1234567 + k);
            assert_true(p < n);
            assert_int_equal(seen[p], 0);
            seen[p] = 1;
        }
        free(seen);
    }
}

/* The last Sobol index and extreme scrambles stay inside [0, 1). */
static void test_values_below_one_at_the_end(void **state)
{
    (void)state;
    const qmc_scramble scr[] = {QMC_SCRAMBLE_NONE, QMC_SCRAMBLE_SHIFT, QMC_SCRAMBLE_OWEN};
    for (size_t k = 0; k < 3; k++) {
        qmc_seq *s = make(QMC_SEQ_SOBOL, 64, scr[k], 0xffffffffffffffffull, 0);
        float f[64 * 4];
        assert_int_equal(qmc_seq_fill(s, QMC_SEQ_MAX_INDEX - 4, 4, QMC_FORMAT_F32, f), 0);
        for (int i = 0; i < 64 * 4; i++)
            assert_true(f[i] >= 0.0f && f[i] < 1.0f);
        qmc_seq_free(s);
    }
    /* Dim 1 at 2^32 - 1 is 1 - 2^-32: the largest Sobol coordinate. */
    qmc_seq *s = make(QMC_SEQ_SOBOL, 1, QMC_SCRAMBLE_NONE, 0, 0);
    assert_true(at(s, QMC_SEQ_MAX_INDEX - 1, 0) == 1.0 - 0x1p-32);
    qmc_seq_free(s);
}

/* Scrambles: seeds matter, the origin moves, and the mean stays 1/2. */
static void test_scrambles_randomize(void **state)
{
    (void)state;
    qmc_seq *a = make(QMC_SEQ_SOBOL, 8, QMC_SCRAMBLE_OWEN, 1, 0);
    qmc_seq *b = make(QMC_SEQ_SOBOL, 8, QMC_SCRAMBLE_OWEN, 2, 0);
    assert_true(at(a, 0, 0) != 0.0);
    assert_true(at(a, 5, 3) != at(b, 5, 3));
    double mean = 0;
    for (uint64_t i = 0; i < 4096; i++)
        for (uint32_t j = 0; j < 8; j++)
            mean += at(a, i, j);
    mean /= 4096 * 8;
    assert_true(fabs(mean - 0.5) < 1e-3);
    qmc_seq_free(a);
    qmc_seq_free(b);
}

static const qmc_scramble sobol_scrambles[] = {QMC_SCRAMBLE_NONE, QMC_SCRAMBLE_SHIFT,
                                               QMC_SCRAMBLE_OWEN};
static const qmc_format all_formats[] = {QMC_FORMAT_F64, QMC_FORMAT_F32, QMC_FORMAT_U32};

/* The last group of 1..7 dimensions is computed as a whole vector whose
 * spare lanes are stored over the next points' first dimensions
 * (sobol_fill.h): every value must still equal at(), in every format, and
 * nothing may be written past the end of the output (guard bytes), for
 * short fills, widths around a multiple of 8, and a second CHUNK pass. */
static void test_sobol_fill_tail_group(void **state)
{
    (void)state;
    const uint32_t dims[] = {1, 2, 3, 7, 9, 15, 30, 263};
    const uint64_t counts[] = {1, 2, 3, 5, 64, 65, 200};
    for (size_t a = 0; a < 3; a++)
        for (size_t b = 0; b < sizeof dims / sizeof dims[0]; b++) {
            qmc_seq *s = make(QMC_SEQ_SOBOL, dims[b], sobol_scrambles[a], 11, 0);
            for (size_t c = 0; c < sizeof counts / sizeof counts[0]; c++)
                for (size_t f = 0; f < 3; f++)
                    seq_assert_fill_matches_at(s, dims[b], 1 + 977 * c, counts[c], all_formats[f]);
            qmc_seq_free(s);
        }
}

/* Below 32 dimensions (not a multiple of 8) the whole blocks of 8 points
 * go packed, d vectors per block, each lane stepping by the row ctz(block)
 * of its own dimension (sobol_fill.h).  Every row must be right: blocks
 * from 0, and around 2^31 where the block number crosses 2^28 (row 28, the
 * last); with unaligned heads and tails, in every format and scramble, at
 * widths 1..31 with and without a packed part (fewer than d blocks). */
static void test_sobol_packed_fill_matches_at(void **state)
{
    (void)state;
    const uint32_t dims[] = {1, 2, 3, 4, 5, 7, 9, 13, 15, 17, 20, 30, 31};
    const uint64_t high = (1ull << 31) - 8 * 300;
    /* {16, 35}: 4 whole blocks, fewer than d from d = 5 on: no packed part */
    const uint64_t ranges[][2] = {{0, 2048}, {5, 1500}, {high, 8 * 600}, {high + 3, 8 * 40 + 5},
                                  {QMC_SEQ_MAX_INDEX - 8 * 64, 8 * 64}, {16, 35}};
    for (size_t a = 0; a < 3; a++)
        for (size_t b = 0; b < sizeof dims / sizeof dims[0]; b++) {
            qmc_seq *s = make(QMC_SEQ_SOBOL, dims[b], sobol_scrambles[a], 23, 0);
            for (size_t r = 0; r < sizeof ranges / sizeof ranges[0]; r++)
                for (size_t f = 0; f < 3; f++)
                    seq_assert_fill_matches_at(s, dims[b], ranges[r][0], ranges[r][1],
                                           all_formats[f]);
            qmc_seq_free(s);
        }
}

/* The fill kernels built for each instruction set give the same bytes as
 * the baseline build, for every format and scramble, including chunk and
 * group tails (dims 300 = one full chunk of 256 + 44; 44 = 5 groups + 4). */
static void test_instruction_sets_agree(void **state)
{
    (void)state;
    const qmc_scramble scr[] = {QMC_SCRAMBLE_NONE, QMC_SCRAMBLE_SHIFT, QMC_SCRAMBLE_OWEN};
    const uint32_t dims[] = {1, 3, 8, 21, 300};
    int variants_run = 0;
    for (size_t a = 0; a < 3; a++)
        for (size_t b = 0; b < sizeof dims / sizeof dims[0]; b++) {
            qmc_seq *s = make(QMC_SEQ_SOBOL, dims[b], scr[a], 5, 0);
            /* count: d = 21 too has whole blocks packed (at least 21) */
            variants_run += seq_assert_sobol_builds_agree(s, dims[b], 1000003, 405);
            qmc_seq_free(s);
        }
    print_message("instruction-set variants compared: %d\n", variants_run);
}

static void test_limits_and_errors(void **state)
{
    (void)state;
    char why[200];
    qmc_seq *s = NULL;
    qmc_seq_spec spec = {.kind = QMC_SEQ_SOBOL, .dims = QMC_SOBOL_MAX_DIMS + 1};
    assert_int_equal(qmc_seq_new(&spec, &s), QMC_EDIMS);
    assert_null(s);
    assert_int_equal(qmc_seq_spec_check(&spec, why, sizeof why), QMC_EDIMS);
    assert_non_null(strstr(why, "21202 dims"));
    spec.dims = 0;
    assert_int_equal(qmc_seq_new(&spec, &s), QMC_EDIMS);
    spec.dims = 2;
    spec.scramble = QMC_SCRAMBLE_FAURE;
    assert_int_equal(qmc_seq_spec_check(&spec, why, sizeof why), QMC_ESCRAMBLE);
    assert_non_null(strstr(why, "none shift owen"));
    spec.scramble = QMC_SCRAMBLE_NONE;
    spec.set_size = 5;
    assert_int_equal(qmc_seq_new(&spec, &s), QMC_ECOUNT);
    spec.set_size = 0;
    spec.kind = (qmc_seq_kind)99;
    assert_int_equal(qmc_seq_new(&spec, &s), QMC_EKIND);
    spec.kind = QMC_SEQ_HALTON;
    spec.flags = QMC_SEQ_SHUFFLE;
    assert_int_equal(qmc_seq_new(&spec, &s), QMC_EINVAL);
    spec.kind = QMC_SEQ_HAMMERSLEY;
    spec.flags = 0;
    assert_int_equal(qmc_seq_new(&spec, &s), QMC_ECOUNT); /* no set size */
    spec.dims = QMC_HALTON_MAX_DIMS + 1;
    spec.set_size = 8;
    assert_int_equal(qmc_seq_new(&spec, &s), QMC_EDIMS);

    s = make(QMC_SEQ_SOBOL, 2, QMC_SCRAMBLE_NONE, 0, 0);
    double x = 42, buf[4];
    assert_int_equal(qmc_seq_at(s, QMC_SEQ_MAX_INDEX, 0, &x), QMC_ERANGE);
    assert_true(x == 0.0);
    assert_int_equal(qmc_seq_at(s, 0, 2, &x), QMC_EDIMS);
    assert_int_equal(qmc_seq_fill(s, QMC_SEQ_MAX_INDEX - 1, 2, QMC_FORMAT_F64, buf), QMC_ERANGE);
    assert_int_equal(qmc_seq_fill(s, UINT64_MAX, 2, QMC_FORMAT_F64, buf), QMC_ERANGE);
    assert_int_equal(qmc_seq_fill(s, 0, 1, (qmc_format)9, buf), QMC_EFORMAT);
    assert_int_equal(qmc_seq_range_check(s, 1ull << 32, 1, why, sizeof why), QMC_ERANGE);
    assert_non_null(strstr(why, "4294967296 points"));
    assert_int_equal(qmc_seq_fill(s, QMC_SEQ_MAX_INDEX - 2, 2, QMC_FORMAT_F64, buf), 0);
    qmc_seq_free(s);
    qmc_seq_free(NULL);

    s = make(QMC_SEQ_LHS, 2, QMC_SCRAMBLE_NONE, 0, 10);
    assert_int_equal(qmc_seq_at(s, 10, 0, &x), QMC_ERANGE);
    assert_int_equal(qmc_seq_fill(s, 5, 6, QMC_FORMAT_F64, buf), QMC_ERANGE);
    qmc_seq_free(s);
}

static void test_names_round_trip(void **state)
{
    (void)state;
    qmc_seq_kind k;
    qmc_scramble sc;
    qmc_format f;
    assert_int_equal(qmc_seq_kind_parse("lhs", &k), 0);
    assert_int_equal(k, QMC_SEQ_LHS);
    assert_string_equal(qmc_seq_kind_name(QMC_SEQ_HAMMERSLEY), "hammersley");
    assert_int_equal(qmc_seq_kind_parse("sobel", &k), QMC_EKIND);
    assert_int_equal(qmc_scramble_parse("faure", &sc), 0);
    assert_int_equal(sc, QMC_SCRAMBLE_FAURE);
    assert_int_equal(qmc_format_parse("u32", &f), 0);
    assert_int_equal(qmc_format_bytes(f), 4);
    assert_string_equal(qmc_strerror(QMC_EDIMS), "dimension count outside the kind's range");
    assert_string_equal(qmc_err_name(QMC_ERANGE), "QMC_ERANGE");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sobol_known_points),
        cmocka_unit_test(test_sobol_matches_scipy),
        cmocka_unit_test(test_sobol_table_shape),
        cmocka_unit_test(test_halton_known_answers),
        cmocka_unit_test(test_halton_matches_scipy),
        cmocka_unit_test(test_faure_permutations),
        cmocka_unit_test(test_at_equals_fill),
        cmocka_unit_test(test_long_fill_matches_at),
        cmocka_unit_test(test_large_sobol_fill_matches_at),
        cmocka_unit_test(test_sobol_is_zero_m_two_net),
        cmocka_unit_test(test_net_check_rejects_random),
        cmocka_unit_test(test_halton_scrambles_stratify),
        cmocka_unit_test(test_lhs_one_point_per_stratum),
        cmocka_unit_test(test_stratified_one_point_per_cell),
        cmocka_unit_test(test_stratified_count_error_names_valid_counts),
        cmocka_unit_test(test_permutation_is_bijective),
        cmocka_unit_test(test_values_below_one_at_the_end),
        cmocka_unit_test(test_scrambles_randomize),
        cmocka_unit_test(test_instruction_sets_agree),
        cmocka_unit_test(test_sobol_fill_tail_group),
        cmocka_unit_test(test_sobol_packed_fill_matches_at),
        cmocka_unit_test(test_limits_and_errors),
        cmocka_unit_test(test_names_round_trip),
    };
    return cmocka_run_group_tests_name("seq", tests, NULL, NULL);
}
