/*
 * pixel_kernel_avx512.c - the pixel kernels (pixel_kernel.h) built with
 * AVX-512 (F, VL, BW, DQ; the Makefile sets the flags for this file on
 * x86-64), 16 lanes.  pixel_kernel.c calls them only when the CPU reports
 * those extensions; the bits equal the baseline build's.
 *
 * Must not: be called on a CPU without AVX-512 F, VL, BW and DQ (pixel_kernel.c asks the
 * CPU first), or differ from the baseline build in one bit.
 */
#if defined(__x86_64__) && defined(__GNUC__) && defined(__AVX512BW__)
#include <immintrin.h>

#define PK_VW 16
#define PK_LANES ((pk_u){0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15})
#include "pixel_kernel.h"

/* Bytes reversed by one shuffle, then each byte's bits by looking up both
 * nibbles in a 16-entry table, as the AVX2 build does on 64 bytes. */
static inline pk_u pk_reverse(pk_u x)
{
    const __m512i bswap = _mm512_set_epi64(
        0x0c0d0e0f08090a0bll, 0x0405060700010203ll, 0x0c0d0e0f08090a0bll,
        0x0405060700010203ll, 0x0c0d0e0f08090a0bll, 0x0405060700010203ll,
        0x0c0d0e0f08090a0bll, 0x0405060700010203ll);
    /* Byte n of each 16: the 4 bits of n reversed, in the high nibble. */
    const __m512i rev_hi = _mm512_set4_epi32((int)0xf070b030, (int)0xd0509010,
                                             (int)0xe060a020, (int)0xc0408000);
    const __m512i rev_lo = _mm512_srli_epi16(rev_hi, 4);
    const __m512i nib = _mm512_set1_epi8(0x0f);
    __m512i v = _mm512_shuffle_epi8((__m512i)x, bswap);
    __m512i low = _mm512_and_si512(v, nib);
    __m512i high = _mm512_and_si512(_mm512_srli_epi16(v, 4), nib);
    return (pk_u)_mm512_or_si512(_mm512_shuffle_epi8(rev_hi, low),
                                 _mm512_shuffle_epi8(rev_lo, high));
}

static inline pk_u pk_permute(pk_u x, pk_u idx)
{
    return (pk_u)_mm512_permutexvar_epi32((__m512i)idx, (__m512i)x);
}

void qmc__pixel_emit_avx512(const qmc__pixel_pattern *pt, const uint32_t *in, uint64_t row_start,
                          uint32_t w, uint32_t rows, qmc_format fmt, void *out, size_t stride,
                          void *scratch);

void qmc__pixel_emit_avx512(const qmc__pixel_pattern *pt, const uint32_t *in, uint64_t row_start,
                          uint32_t w, uint32_t rows, qmc_format fmt, void *out, size_t stride,
                          void *scratch)
{
    pk_emit(pt, in, row_start, w, rows, fmt, out, stride, scratch);
}

void qmc__pixel_nodes_avx512(uint64_t key0, uint64_t salt, uint32_t n, int bit, uint8_t *out);

void qmc__pixel_nodes_avx512(uint64_t key0, uint64_t salt, uint32_t n, int bit, uint8_t *out)
{
    pk_nodes(key0, salt, n, bit, out);
}
#endif
