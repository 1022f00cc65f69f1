/*
 * seq_fill_check.h - the checks test_seq.c and test_seq_fast_owen.c make
 * of a sequence's batch fill: it writes nothing past its end and equals
 * random access in every format, and every instruction set's build of
 * the Sobol kernels gives the baseline's bytes.  Included after cmocka.h
 * and sobol_impl.h; static inline, so the Makefile's UNIT_HELPER wildcard
 * (every .c in tests/unit/ but the tests) does not link it into every
 * other unit test.
 */
#ifndef QMC_TEST_SEQ_FILL_CHECK_H
#define QMC_TEST_SEQ_FILL_CHECK_H

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "qmc/seq.h"
#include "sobol_impl.h"

/* Fills [start, start + count) in format fmt into a buffer followed by
 * guard bytes: nothing may be written past the end, and every value must
 * equal at() in that format. */
static inline void seq_assert_fill_matches_at(const qmc_seq *s, uint32_t dims, uint64_t start,
                                              uint64_t count, qmc_format fmt)
{
    enum { GUARD = 64 };
    const size_t value = qmc_format_bytes(fmt);
    const size_t used = (size_t)count * dims * value;
    uint8_t *buf = malloc(used + GUARD);
    assert_non_null(buf);
    memset(buf, 0x5a, used + GUARD);
    assert_int_equal(qmc_seq_fill(s, start, count, fmt, buf), 0);
    const char *scr = qmc_scramble_name(qmc_seq_get_spec(s)->scramble);
    for (size_t g = 0; g < GUARD; g++)
        if (buf[used + g] != 0x5a)
            fail_msg("%s %s d=%u start=%llu count=%llu: byte %zu past the end written", scr,
                     qmc_format_name(fmt), dims, (unsigned long long)start,
                     (unsigned long long)count, g);
    for (uint64_t p = 0; p < count; p++)
        for (uint32_t j = 0; j < dims; j++) {
            double x = -1;
            assert_int_equal(qmc_seq_at(s, start + p, j, &x), 0);
            const uint32_t y = (uint32_t)(x * 0x1p32);
            const size_t i = (size_t)p * dims + j;
            int same;
            if (fmt == QMC_FORMAT_F64) {
                same = memcmp(&x, buf + 8 * i, 8) == 0;
            } else if (fmt == QMC_FORMAT_U32) {
                uint32_t u;
                memcpy(&u, buf + 4 * i, 4);
                same = u == y;
            } else {
                float v;
                memcpy(&v, buf + 4 * i, 4);
                same = v == (float)(y >> 8) * 0x1p-24f;
            }
            if (!same)
                fail_msg("%s %s d=%u start=%llu count=%llu: point %llu dim %u differs from "
                         "at()", scr, qmc_format_name(fmt), dims, (unsigned long long)start,
                         (unsigned long long)count, (unsigned long long)(start + p), j);
        }
    free(buf);
}

/* Fills [start, start + count) of the Sobol sequence s (dims wide) in
 * every format with the baseline build, each instruction set's build the
 * CPU runs and the public entry point: the same bytes.  Returns how many
 * instruction-set builds it compared. */
static inline int seq_assert_sobol_builds_agree(const qmc_seq *s, uint32_t dims, uint64_t start,
                                                uint64_t count)
{
    const qmc_format fmts[] = {QMC_FORMAT_F64, QMC_FORMAT_F32, QMC_FORMAT_U32};
    const size_t bytes = (size_t)count * dims * 8;
    uint8_t *want = malloc(bytes), *got = malloc(bytes);
    assert_true(want && got);
    int variants_run = 0;
    for (size_t f = 0; f < 3; f++) {
        const size_t used = (size_t)count * dims * qmc_format_bytes(fmts[f]);
        qmc__sobol_fill_generic(s, start, count, fmts[f], want);
#ifdef QMC__SOBOL_AVX2
        if (__builtin_cpu_supports("avx2")) {
            memset(got, 0xa5, bytes);
            qmc__sobol_fill_avx2(s, start, count, fmts[f], got);
            assert_memory_equal(want, got, used);
            variants_run++;
        }
        if (qmc__sobol_has_avx512()) {
            memset(got, 0xa5, bytes);
            qmc__sobol_fill_avx512(s, start, count, fmts[f], got);
            assert_memory_equal(want, got, used);
            variants_run++;
        }
#endif
        /* And the public entry point agrees with the baseline build. */
        assert_int_equal(qmc_seq_fill(s, start, count, fmts[f], got), 0);
        assert_memory_equal(want, got, used);
    }
    free(want);
    free(got);
    return variants_run;
}

#endif
