/*
 * sobol_impl.h - what the Sobol kind's files share (private to core/).
 *
 * seq_sobol.c owns the tables, random access and dispatch; the batch-fill
 * kernels in sobol_fill.h are compiled for the baseline instruction set
 * (seq_sobol_fill.c) and, on x86-64, with AVX2 (seq_sobol_avx2.c) and
 * AVX-512 (seq_sobol_avx512.c).
 * Both use only integer operations and exact conversions, so they give the
 * same bits; the CPU only changes the speed.
 */
#ifndef QMC_SOBOL_IMPL_H
#define QMC_SOBOL_IMPL_H

#include <string.h>

#include "bits.h"
#include "render_hash.h"
#include "seq_impl.h"

enum { BITS = 32 };

/* Table layout inside seq->tables:
 *   V[dims][32]    u32: direction numbers (bit-reversed for owen and
 *                  fast-owen), for at()
 *   W[33][dims]    u32: prefix XORs of V, transposed so a fill step reads
 *                  one contiguous row; row 32 is all zero (see fill_blocks)
 *   seed[dims+2]   u32: per-dimension scramble seeds, the shuffle seed, pad
 *   W64[33][dims]  u64: W << 20, only for scrambles none and shift: the f64
 *                  fill keeps its state pre-shifted into the mantissa
 *                  position, so a coordinate costs one XOR, one OR and one
 *                  subtraction (see fill_f64_blocks).
 *   P[30][dims+8]  u32: only when has_packed() (below), the steps of the
 *                  packed fill (fill_packed in sobol_fill.h), which walks
 *                  8 points at a time: the 8*dims coordinates of points
 *                  8M..8M+7, in output order, are dims vectors of 8 lanes.
 *                  From 8(M-1)+k to 8M+k the index bits 3..3+r flip, r =
 *                  ctz(M), whatever k is, so every lane takes the same step
 *                  W_(3+r) ^ W_2 of its own dimension q % dims.  Row r holds
 *                  the step of dimensions 0..dims-1 and then again of
 *                  0..7, so the 8 lanes from q on are the 8 words from
 *                  q % dims on; row 29 is all zero. */
typedef struct sobol_view {
    const uint32_t *v;
    const uint32_t *w;
    const uint32_t *seed;
    const uint64_t *w64; /* NULL for owen */
    const uint32_t *packed; /* NULL unless has_packed() */
} sobol_view;

/*
 * The kernels know one hash-based Owen scramble: fast-owen is owen's hash
 * (the same lk_hash below) with other per-dimension seeds (seq_sobol.c),
 * so everything past the seed table treats the two alike.
 */
static inline qmc_scramble kernel_scramble(qmc_scramble scr)
{
    return scr == QMC_SCRAMBLE_FAST_OWEN ? QMC_SCRAMBLE_OWEN : scr;
}

static inline int has_w64(const qmc_seq_spec *spec)
{
    return kernel_scramble(spec->scramble) != QMC_SCRAMBLE_OWEN;
}

/*
 * A point at a time leaves lanes idle unless d is a multiple of 8 (d = 2:
 * 6 of 8; d = 30: 2 of 32); packing 8 points into d vectors fills them
 * all.  Measured (owen, f64, fills of 4096): 4.0 -> 0.9 ns a point at
 * d = 2, 4.1 -> 2.1 at d = 5, 10.4 -> 8.1 at d = 20, 13.9 -> 12.5 at
 * d = 30.  At a multiple of 8 no lane idles, but the packed walk still
 * pays for one row step per 8 points instead of one per point, which
 * matters when the per-coordinate work is small next to it, as for the
 * Owen scrambles: owen f64 at d = 8, 16, 24 went from 2.9, 3.3, 3.4 to
 * 4.0, 4.1, 4.1 billion coordinates a second (AVX-512 build; AVX2 1.8,
 * 2.1, 2.1 -> 2.2, 2.3, 2.3); none and shift there keep their f64 fast
 * path (fill_f64_blocks).  Rows: ctz(M) for M < 2^29 (indices below
 * 2^32), and the zero row.
 */
enum { QMC__SOBOL_PACK_DIMS = 32, QMC__SOBOL_PACK_ROWS = 30 };

static inline int has_packed(const qmc_seq_spec *spec)
{
    return spec->dims < QMC__SOBOL_PACK_DIMS &&
           (spec->dims % 8 != 0 || kernel_scramble(spec->scramble) == QMC_SCRAMBLE_OWEN);
}

static inline size_t packed_row_words(size_t d)
{
    return d + 8;
}

/* Zero words after the seeds, so that the last group of dimensions can be
 * computed as a whole vector of 8 (sobol_fill.h): its loads may run up to
 * 7 words past the end of the last prefix row or of the seeds. */
enum { QMC__SOBOL_PAD = 8 };

static inline size_t u32_words(size_t d)
{
    /* even: W64 is 8-aligned */
    return (2 * (size_t)BITS + 1) * d + d + 2 + QMC__SOBOL_PAD;
}

/* Words of the W64 table (0 when the scramble has none). */
static inline size_t w64_words(const qmc_seq_spec *spec)
{
    return has_w64(spec) ? 2 * ((size_t)BITS + 1) * spec->dims : 0;
}

static inline size_t packed_words(const qmc_seq_spec *spec)
{
    return has_packed(spec) ? QMC__SOBOL_PACK_ROWS * packed_row_words(spec->dims) : 0;
}

static inline sobol_view view(const qmc_seq *seq)
{
    const uint32_t *t = seq->tables;
    size_t d = seq->spec.dims;
    const uint32_t *p = t + u32_words(d) + w64_words(&seq->spec);
    sobol_view s = {t, t + (size_t)BITS * d, t + (2 * (size_t)BITS + 1) * d,
                    has_w64(&seq->spec) ? (const uint64_t *)(t + u32_words(d)) : NULL,
                    has_packed(&seq->spec) ? p : NULL};
    return s;
}
/*
 * The Laine-Karras-style hash in bit-reversed order (Vegdahl 2021).  Each
 * step changes bit k of x only by a function of bits below k - the defining
 * property of a nested uniform (Owen) scramble in reversed bit order.
 * Written once as a statement list (render_hash.h's, pbrt-v4's
 * FastOwenScrambler being this hash) so the scalar lk_hash, the vector
 * lk_hash8 (sobol_fill.h; vector extensions broadcast the constants) and
 * the pixel samplers' scramble are the same function by construction.
 */
#define QMC__LK_HASH_STEPS(x, seed) QMC__FAST_OWEN_STEPS(x, seed, ((seed) >> 16) | 1u)

static inline uint32_t lk_hash(uint32_t x, uint32_t seed)
{
    QMC__LK_HASH_STEPS(x, seed);
    return x;
}

static inline uint32_t nested_uniform_scramble(uint32_t x, uint32_t seed)
{
    return qmc__reverse32(lk_hash(qmc__reverse32(x), seed));
}

/* XOR of the direction numbers for the set bits of index. */
static inline uint32_t gather(const uint32_t *v_dim, uint32_t index)
{
    uint32_t x = 0;
    while (index) {
        x ^= v_dim[__builtin_ctz(index)];
        index &= index - 1;
    }
    return x;
}

/* From the state word (natural or reversed order) to the output bits. */
static inline __attribute__((always_inline)) uint32_t
finish(uint32_t state, uint32_t seed, qmc_scramble scr)
{
    switch (scr) {
    case QMC_SCRAMBLE_SHIFT:
        return state ^ seed;
    case QMC_SCRAMBLE_OWEN:
        return qmc__reverse32(lk_hash(state, seed));
    default:
        return state;
    }
}

/* y * 2^-32 exactly, without an int-to-double conversion instruction: the
 * double 1 + y * 2^-32 is assembled from bits (52-bit mantissa, y in its top
 * 32 bits), and subtracting 1 is exact.  The vector path below does the
 * same per lane, which is why both give identical bits. */
static inline double unit_from_bits(uint32_t y)
{
    uint64_t b = 0x3ff0000000000000ull | ((uint64_t)y << 20);
    double d;
    memcpy(&d, &b, sizeof d);
    return d - 1.0;
}

static inline __attribute__((always_inline)) void
store(void *out, size_t k, uint32_t y, qmc_format fmt)
{
    switch (fmt) {
    case QMC_FORMAT_F64:
        ((double *)out)[k] = unit_from_bits(y);
        break;
    case QMC_FORMAT_F32:
        ((float *)out)[k] = (float)(y >> 8) * 0x1p-24f;
        break;
    case QMC_FORMAT_U32:
        ((uint32_t *)out)[k] = y;
        break;
    }
}


/* Fill points [start, start + count), all dimensions, natural order (no
 * shuffle): the baseline build and the AVX2 build of the same kernels. */
void qmc__sobol_fill_generic(const qmc_seq *seq, uint64_t start,
                             uint64_t count, qmc_format fmt, void *out);
#if defined(__x86_64__) && defined(__GNUC__)
#define QMC__SOBOL_AVX2 1
void qmc__sobol_fill_avx2(const qmc_seq *seq, uint64_t start, uint64_t count,
                          qmc_format fmt, void *out);
void qmc__sobol_fill_avx512(const qmc_seq *seq, uint64_t start, uint64_t count,
                            qmc_format fmt, void *out);

/* May qmc__sobol_fill_avx512 run here?  It is built for AVX-512 F, VL, BW,
 * DQ and VBMI (byte permutes) and for GFNI (a one-instruction bit reversal
 * of every byte), which the Owen scrambles use per coordinate: Intel from
 * Ice Lake and AMD from Zen 4 have them all; older AVX-512 parts take the
 * AVX2 build.  Reads flags libgcc/compiler-rt set once at startup. */
static inline int qmc__sobol_has_avx512(void)
{
    return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
           __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512dq") &&
           __builtin_cpu_supports("avx512vbmi") && __builtin_cpu_supports("gfni");
}
#endif

#endif
