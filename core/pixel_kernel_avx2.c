/*
 * pixel_kernel_avx2.c - the pixel kernels (pixel_kernel.h) built with
 * -mavx2, 8 lanes (the Makefile sets the flag for this file on x86-64).
 * pixel_kernel.c calls them only when the CPU reports AVX2; -mavx2 does
 * not enable FMA and the build uses -ffp-contract=off, so the bits equal
 * the baseline's.
 *
 * Must not: be called on a CPU without AVX2 (pixel_kernel.c asks the
 * CPU first), or differ from the baseline build in one bit.
 */
#if defined(__x86_64__) && defined(__GNUC__) && defined(__AVX2__)
#include <immintrin.h>

#define PK_VW 8
#define PK_LANES ((pk_u){0, 1, 2, 3, 4, 5, 6, 7})
#include "pixel_kernel.h"

/* Bytes reversed by one shuffle, then each byte's bits by looking up both
 * nibbles in a 16-entry table (two vpshufb). */
static inline pk_u pk_reverse(pk_u x)
{
    const __m256i bswap = _mm256_setr_epi8(3, 2, 1, 0, 7, 6, 5, 4, 11, 10, 9, 8, 15, 14, 13, 12,
                                           3, 2, 1, 0, 7, 6, 5, 4, 11, 10, 9, 8, 15, 14, 13, 12);
    /* rev_hi[n]: the 4 bits of n reversed, in the high nibble. */
    const __m256i rev_hi = _mm256_setr_epi8(
        0x00, (char)0x80, 0x40, (char)0xc0, 0x20, (char)0xa0, 0x60, (char)0xe0, 0x10,
        (char)0x90, 0x50, (char)0xd0, 0x30, (char)0xb0, 0x70, (char)0xf0, 0x00, (char)0x80,
        0x40, (char)0xc0, 0x20, (char)0xa0, 0x60, (char)0xe0, 0x10, (char)0x90, 0x50,
        (char)0xd0, 0x30, (char)0xb0, 0x70, (char)0xf0);
    const __m256i rev_lo = _mm256_srli_epi16(rev_hi, 4);
    const __m256i nib = _mm256_set1_epi8(0x0f);
    __m256i v = _mm256_shuffle_epi8((__m256i)x, bswap);
    __m256i low = _mm256_and_si256(v, nib);
    __m256i high = _mm256_and_si256(_mm256_srli_epi16(v, 4), nib);
    return (pk_u)_mm256_or_si256(_mm256_shuffle_epi8(rev_hi, low),
                                 _mm256_shuffle_epi8(rev_lo, high));
}

static inline pk_u pk_permute(pk_u x, pk_u idx)
{
    return (pk_u)_mm256_permutevar8x32_epi32((__m256i)x, (__m256i)idx);
}

void qmc__pixel_emit_avx2(const qmc__pixel_pattern *pt, const uint32_t *in, uint64_t row_start,
                          uint32_t w, uint32_t rows, qmc_format fmt, void *out, size_t stride,
                          void *scratch);

void qmc__pixel_emit_avx2(const qmc__pixel_pattern *pt, const uint32_t *in, uint64_t row_start,
                          uint32_t w, uint32_t rows, qmc_format fmt, void *out, size_t stride,
                          void *scratch)
{
    pk_emit(pt, in, row_start, w, rows, fmt, out, stride, scratch);
}

void qmc__pixel_nodes_avx2(uint64_t key0, uint64_t salt, uint32_t n, int bit, uint8_t *out);

void qmc__pixel_nodes_avx2(uint64_t key0, uint64_t salt, uint32_t n, int bit, uint8_t *out)
{
    pk_nodes(key0, salt, n, bit, out);
}
#endif
