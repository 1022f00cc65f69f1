/*
 * test_seq_fast_owen.c - the fast-owen scramble of Sobol: pbrt-v4's own
 * values (tests/vectors/pbrt_sobol_fast_owen.h), random access == batch
 * in every format and kernel, nets and t-values kept, seeds that differ,
 * and the kinds that refuse it.
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <stdlib.h>
#include <string.h>

#include "bits.h"
#include "qmc/quality.h"
#include "qmc/seq.h"
#include "seq_fill_check.h"
#include "sobol_impl.h"
#include "../vectors/pbrt_sobol_fast_owen.h"

static qmc_seq *make(uint32_t dims, qmc_scramble scr, uint32_t flags, uint64_t seed)
{
    qmc_seq_spec spec = {.kind = QMC_SEQ_SOBOL, .dims = dims, .scramble = scr,
                         .flags = flags, .seed = seed};
    qmc_seq *s = NULL;
    assert_int_equal(qmc_seq_new(&spec, &s), 0);
    assert_non_null(s);
    return s;
}

static uint32_t bits_at(const qmc_seq *s, uint64_t i, uint32_t j)
{
    double x = -1;
    assert_int_equal(qmc_seq_at(s, i, j, &x), 0);
    assert_true(x >= 0.0 && x < 1.0);
    return (uint32_t)(x * 0x1p32);
}

/* Every pbrt-v4 case, by random access and by a fill of the point (one
 * point takes the gather path, so the fill is of three points around it
 * where the index allows). */
static void test_matches_pbrt(void **state)
{
    (void)state;
    const size_t n = sizeof pbrt_fast_owen_cases / sizeof pbrt_fast_owen_cases[0];
    assert_true(n >= 300);
    uint32_t row[3 * 1024];
    for (size_t c = 0; c < n; c++) {
        const pbrt_fast_owen_case *k = &pbrt_fast_owen_cases[c];
        qmc_seq *s = make(k->dim + 1, QMC_SCRAMBLE_FAST_OWEN, 0, k->seed);
        if (bits_at(s, k->index, k->dim) != k->v)
            fail_msg("seed %u index %llu dim %u: qmc %08x, pbrt-v4 %08x", k->seed,
                     (unsigned long long)k->index, k->dim, bits_at(s, k->index, k->dim),
                     k->v);
        const uint64_t first = k->index == 0 ? 0 : k->index + 3 > QMC_SEQ_MAX_INDEX
                                                       ? k->index - 2
                                                       : k->index - 1;
        assert_int_equal(qmc_seq_fill(s, first, 3, QMC_FORMAT_U32, row), 0);
        assert_int_equal(row[(k->index - first) * (k->dim + 1) + k->dim], k->v);
        qmc_seq_free(s);
    }
}

/* Random access == batch for every format, at widths that take each fill
 * path (packed below 32 dims, tail vectors, a second pass of 256 dims),
 * from aligned and unaligned starts, around 2^31 and at the very end. */
static void test_at_equals_fill(void **state)
{
    (void)state;
    const uint32_t dims[] = {1, 2, 3, 5, 7, 8, 9, 15, 16, 17, 21, 30, 31, 32, 33, 64, 263};
    const uint64_t high = (1ull << 31) - 8 * 100;
    const uint64_t ranges[][2] = {{0, 1},        {0, 2},          {0, 3},
                                  {0, 1000},     {5, 777},        {977, 65},
                                  {high, 8 * 300}, {high + 3, 8 * 40 + 5},
                                  {QMC_SEQ_MAX_INDEX - 8 * 64, 8 * 64},
                                  {QMC_SEQ_MAX_INDEX - 13, 13}};
    const qmc_format fmts[] = {QMC_FORMAT_F64, QMC_FORMAT_F32, QMC_FORMAT_U32};
    for (size_t b = 0; b < sizeof dims / sizeof dims[0]; b++) {
        qmc_seq *s = make(dims[b], QMC_SCRAMBLE_FAST_OWEN, 0, 31 + b);
        for (size_t r = 0; r < sizeof ranges / sizeof ranges[0]; r++)
            for (size_t f = 0; f < 3; f++) {
                /* The widest rows only over short ranges: at() is slow. */
                uint64_t count = ranges[r][1];
                if (dims[b] > 64 && count > 100)
                    count = 100;
                seq_assert_fill_matches_at(s, dims[b], ranges[r][0], count, fmts[f]);
            }
        qmc_seq_free(s);
    }
    /* Index shuffling goes point by point; it must agree too. */
    qmc_seq *s = make(6, QMC_SCRAMBLE_FAST_OWEN, QMC_SEQ_SHUFFLE, 5);
    for (size_t f = 0; f < 3; f++)
        seq_assert_fill_matches_at(s, 6, 1000, 300, fmts[f]);
    qmc_seq_free(s);
}

/* Each instruction set's build of the kernels gives the baseline's bytes. */
static void test_instruction_sets_agree(void **state)
{
    (void)state;
    const uint32_t dims[] = {1, 3, 8, 21, 40, 300};
    int variants_run = 0;
    for (size_t b = 0; b < sizeof dims / sizeof dims[0]; b++) {
        qmc_seq *s = make(dims[b], QMC_SCRAMBLE_FAST_OWEN, 0, 5);
        variants_run += seq_assert_sobol_builds_agree(s, dims[b], 1000003, 405);
        qmc_seq_free(s);
    }
    print_message("instruction-set variants compared: %d\n", variants_run);
}

/* A nested uniform scramble keeps every elementary interval's count: the
 * first 2^m points of dims (0, 1) stay a (0,m,2)-net, and aligned blocks
 * of 2^m points too (with and without index shuffling). */
static void test_zero_m_two_net(void **state)
{
    (void)state;
    uint32_t *u = malloc(sizeof(uint32_t) * 2 * (1u << 16));
    uint32_t *work = malloc(sizeof(uint32_t) * (1u << 16));
    const uint64_t seeds[] = {0, 7, 0xffffffffull, 0x123456789abcdefull};
    for (int flags = 0; flags <= 1; flags++)
        for (size_t k = 0; k < sizeof seeds / sizeof seeds[0]; k++) {
            qmc_seq *s = make(2, QMC_SCRAMBLE_FAST_OWEN, flags ? QMC_SEQ_SHUFFLE : 0, seeds[k]);
            for (uint32_t m = 1; m <= 16; m++) {
                const uint64_t start = (uint64_t)(m % 3) << m;
                assert_int_equal(qmc_seq_fill(s, start, 1u << m, QMC_FORMAT_U32, u), 0);
                uint32_t t = 99;
                assert_int_equal(qmc_tvalue_compute(u, (size_t)1 << m, 2, 0, 1, work, &t), 0);
                assert_int_equal(t, 0);
            }
            qmc_seq_free(s);
        }
    free(u);
    free(work);
}

/* And every 2D projection keeps its t-value: the scrambled pairs of dims
 * 0..11 have exactly the t of the unscrambled Sobol pairs, for 2^12
 * points, while the values themselves all moved. */
static void test_t_values_kept(void **state)
{
    (void)state;
    enum { D = 12, M = 12, N = 1 << M };
    uint32_t *plain = malloc(sizeof(uint32_t) * D * N);
    uint32_t *scr = malloc(sizeof(uint32_t) * D * N);
    uint32_t *work = malloc(sizeof(uint32_t) * N);
    qmc_seq *a = make(D, QMC_SCRAMBLE_NONE, 0, 0);
    qmc_seq *b = make(D, QMC_SCRAMBLE_FAST_OWEN, 0, 2024);
    assert_int_equal(qmc_seq_fill(a, 0, N, QMC_FORMAT_U32, plain), 0);
    assert_int_equal(qmc_seq_fill(b, 0, N, QMC_FORMAT_U32, scr), 0);
    size_t moved = 0;
    for (size_t i = 0; i < (size_t)D * N; i++)
        moved += plain[i] != scr[i];
    assert_true(moved > (size_t)D * N * 99 / 100);
    uint32_t max_t = 0;
    for (uint32_t p = 0; p < D; p++)
        for (uint32_t q = p + 1; q < D; q++) {
            uint32_t t0 = 99, t1 = 98;
            assert_int_equal(qmc_tvalue_compute(plain, N, D, p, q, work, &t0), 0);
            assert_int_equal(qmc_tvalue_compute(scr, N, D, p, q, work, &t1), 0);
            if (t0 != t1)
                fail_msg("dims (%u, %u): t %u unscrambled, %u with fast-owen", p, q, t0, t1);
            max_t = t0 > max_t ? t0 : max_t;
        }
    assert_true(max_t > 0); /* some pair is not a (0,m,2)-net: t is tested */
    qmc_seq_free(a);
    qmc_seq_free(b);
    free(plain);
    free(scr);
    free(work);
}

/* Seeds that differ give other points: small ones, the two sides of 2^32
 * (where the seed goes from 4 bytes to 8 in the hash), and seeds whose low
 * 32 bits agree.  And fast-owen is not owen under another name. */
static void test_seeds_differ(void **state)
{
    (void)state;
    const uint64_t seeds[] = {0, 1, 2, 0xffffffffull, 1ull << 32, (1ull << 32) + 1,
                              (7ull << 32) | 1, UINT64_MAX};
    enum { NS = sizeof seeds / sizeof seeds[0], DIMS = 4, PTS = 8 };
    uint32_t v[NS][PTS * DIMS];
    for (size_t k = 0; k < NS; k++) {
        qmc_seq *s = make(DIMS, QMC_SCRAMBLE_FAST_OWEN, 0, seeds[k]);
        assert_int_equal(qmc_seq_fill(s, 100, PTS, QMC_FORMAT_U32, v[k]), 0);
        qmc_seq_free(s);
    }
    for (size_t a = 0; a < NS; a++)
        for (size_t b = a + 1; b < NS; b++) {
            size_t same = 0;
            for (size_t i = 0; i < PTS * DIMS; i++)
                same += v[a][i] == v[b][i];
            if (same > 0)
                fail_msg("seeds %llx and %llx share %zu of %d values",
                         (unsigned long long)seeds[a], (unsigned long long)seeds[b], same,
                         PTS * DIMS);
        }
    qmc_seq *o = make(DIMS, QMC_SCRAMBLE_OWEN, 0, 7), *f = make(DIMS, QMC_SCRAMBLE_FAST_OWEN, 0, 7);
    for (uint32_t j = 0; j < DIMS; j++)
        assert_true(bits_at(o, 3, j) != bits_at(f, 3, j));
    qmc_seq_free(o);
    qmc_seq_free(f);
}

/* fast-owen is a base-2 scramble: every other kind refuses it, with a
 * reason that says so; the name round-trips. */
static void test_refused_elsewhere(void **state)
{
    (void)state;
    const qmc_seq_kind kinds[] = {QMC_SEQ_HALTON, QMC_SEQ_HAMMERSLEY, QMC_SEQ_RANDOM,
                                  QMC_SEQ_STRATIFIED, QMC_SEQ_LHS};
    for (size_t k = 0; k < sizeof kinds / sizeof kinds[0]; k++) {
        const int finite = kinds[k] == QMC_SEQ_HAMMERSLEY || kinds[k] == QMC_SEQ_STRATIFIED ||
                           kinds[k] == QMC_SEQ_LHS;
        qmc_seq_spec spec = {.kind = kinds[k], .dims = 2, .scramble = QMC_SCRAMBLE_FAST_OWEN,
                             .set_size = finite ? 16 : 0};
        char why[200];
        qmc_seq *s = (qmc_seq *)&spec;
        assert_int_equal(qmc_seq_spec_check(&spec, why, sizeof why), QMC_ESCRAMBLE);
        assert_non_null(strstr(why, "fast-owen"));
        assert_non_null(strstr(why, "sobol only"));
        assert_null(strchr(why, '\n'));
        assert_int_equal(qmc_seq_new(&spec, &s), QMC_ESCRAMBLE);
        assert_null(s);
    }
    qmc_scramble sc = QMC_SCRAMBLE_NONE;
    assert_int_equal(qmc_scramble_parse("fast-owen", &sc), 0);
    assert_int_equal(sc, QMC_SCRAMBLE_FAST_OWEN);
    assert_int_equal((int)sc, 4);
    assert_string_equal(qmc_scramble_name(QMC_SCRAMBLE_FAST_OWEN), "fast-owen");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_matches_pbrt),
        cmocka_unit_test(test_at_equals_fill),
        cmocka_unit_test(test_instruction_sets_agree),
        cmocka_unit_test(test_zero_m_two_net),
        cmocka_unit_test(test_t_values_kept),
        cmocka_unit_test(test_seeds_differ),
        cmocka_unit_test(test_refused_elsewhere),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
