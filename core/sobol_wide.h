/*
 * sobol_wide.h - Sobol' generator matrices with 64 index columns and
 * 32-bit outputs (private to core/).
 *
 * The global sequence (seq_sobol.c) stops at index 2^32, so 32 columns
 * do; the pixel samplers index one Sobol' sequence with up to 64 bits
 * (zsobol's Morton index, sobol's whole-image index).  Column c is the top
 * 32 bits of the Joe-Kuo direction number v_(c+1) taken to 64 bits of
 * precision, which is what pbrt-v4's SobolMatrices32 holds for c < 52.
 * Nothing here keeps state or allocates.
 */
#ifndef QMC_SOBOL_WIDE_H
#define QMC_SOBOL_WIDE_H

#include <stdint.h>

#define QMC__SOBOL_WIDE_COLS 64

/* Columns 0..63 of dimension dim (0-based, below the table's 21201). */
void qmc__sobol_wide_columns(uint32_t dim, uint32_t cols[QMC__SOBOL_WIDE_COLS]);

/* XOR of cols[c] over the set bits c of index: the Sobol' value. */
static inline uint32_t qmc__sobol_wide_gather(const uint32_t *cols, uint64_t index)
{
    uint32_t v = 0;
    for (int c = 0; index != 0; index >>= 1, c++)
        if (index & 1u)
            v ^= cols[c];
    return v;
}

/*
 * Dimension 1 (Joe-Kuo's second, the Pascal matrix mod 2) in the
 * bit-reversed domain, without a table: column c has output bit 31 - r set
 * exactly when binomial(c, r) is odd, that is when r's bits are a subset of
 * c's (Lucas), so bit r of the reversed value is the XOR of the index bits
 * c that contain r: a superset-sum transform, one step per index bit.
 */
static inline uint32_t qmc__sobol_dim1_reversed(uint64_t index)
{
    uint64_t x = index;
    x ^= (x >> 1) & 0x5555555555555555ull;
    x ^= (x >> 2) & 0x3333333333333333ull;
    x ^= (x >> 4) & 0x0f0f0f0f0f0f0f0full;
    x ^= (x >> 8) & 0x00ff00ff00ff00ffull;
    x ^= (x >> 16) & 0x0000ffff0000ffffull;
    x ^= (x >> 32) & 0x00000000ffffffffull;
    return (uint32_t)x;
}

/* The same for an index below 2^32 (five steps, 32-bit lanes); the steps
 * are a macro on an lvalue so the pixel kernels (pixel_kernel.h) run them
 * on vector lanes too. */
#define QMC__SOBOL_DIM1_REVERSED32_STEPS(x) \
    do {                                    \
        (x) ^= ((x) >> 1) & 0x55555555u;    \
        (x) ^= ((x) >> 2) & 0x33333333u;    \
        (x) ^= ((x) >> 4) & 0x0f0f0f0fu;    \
        (x) ^= ((x) >> 8) & 0x00ff00ffu;    \
        (x) ^= ((x) >> 16) & 0x0000ffffu;   \
    } while (0)

static inline uint32_t qmc__sobol_dim1_reversed32(uint32_t x)
{
    QMC__SOBOL_DIM1_REVERSED32_STEPS(x);
    return x;
}

#endif
