/*
 * sobol_fill.h - the Sobol batch-fill kernels, as static inline functions
 * (private; included only by seq_sobol_fill.c, seq_sobol_avx2.c and
 * seq_sobol_avx512.c, which compile them for different instruction sets).
 *
 * From i to i+1 exactly bits 0..c flip, c = ctz(i+1), so each dimension's
 * state takes one XOR with the prefix XOR W_c of its direction numbers:
 * the same words at() XORs together, hence the same bits.
 */
#ifndef QMC_SOBOL_FILL_H
#define QMC_SOBOL_FILL_H

#include "sobol_impl.h"

/*
 * The vector path: 8 dimensions per group, written with the GCC/clang
 * vector extensions so that it is portable C and compiles to SSE2, AVX2 or
 * NEON alike.  Only integer operations and the exact conversion above are
 * used, so every instruction set gives the same bits (-ffp-contract=off
 * keeps the one subtraction unfused).
 */
/* These helpers are static and inlined, so no vector crosses an ABI
 * boundary; GCC warns about the AVX calling convention regardless. */
#if defined(__GNUC__)
#pragma GCC diagnostic ignored "-Wpsabi"
#endif
typedef uint32_t u32x8 __attribute__((vector_size(32)));
typedef uint64_t u64x4 __attribute__((vector_size(32)));
typedef uint8_t u8x32 __attribute__((vector_size(32)));
typedef double f64x4 __attribute__((vector_size(32)));
typedef float f32x8 __attribute__((vector_size(32)));
typedef int32_t i32x8 __attribute__((vector_size(32)));

static inline u32x8 load8(const uint32_t *p)
{
    u32x8 v;
    memcpy(&v, p, sizeof v);
    return v;
}

#ifdef __AVX2__
#include <immintrin.h>
#endif

/* Bit reversal of each lane: bytes reversed by a constant shuffle, then the
 * bits within each byte - with GFNI (the AVX-512 build) by one affine
 * transform over GF(2) whose matrix is the bit-reversal permutation
 * (vgf2p8affineqb: result bit i is the parity of x AND matrix byte 7 - i,
 * so the matrix 0x8040201008040201 makes it bit 7 - i of x), with AVX2 by
 * looking up both nibbles in a 16-entry table (two vpshufb), otherwise by
 * three swap steps.  Same bits every way; the unit tests compare the
 * builds. */
static inline u32x8 reverse8(u32x8 x)
{
    u8x32 b = (u8x32)x;
    b = __builtin_shufflevector(b, b, 3, 2, 1, 0, 7, 6, 5, 4, 11, 10, 9, 8, 15, 14,
                                13, 12, 19, 18, 17, 16, 23, 22, 21, 20, 27, 26, 25,
                                24, 31, 30, 29, 28);
#if defined(__GFNI__) && defined(__AVX__)
    return (u32x8)_mm256_gf2p8affine_epi64_epi8((__m256i)b,
                                                _mm256_set1_epi64x(0x8040201008040201ll), 0);
#elif defined(__AVX2__)
    /* rev_hi[n]: the 4 bits of n reversed, in the high nibble. */
    const __m256i rev_hi = _mm256_setr_epi8(
        0x00, (char)0x80, 0x40, (char)0xc0, 0x20, (char)0xa0, 0x60, (char)0xe0, 0x10,
        (char)0x90, 0x50, (char)0xd0, 0x30, (char)0xb0, 0x70, (char)0xf0, 0x00, (char)0x80,
        0x40, (char)0xc0, 0x20, (char)0xa0, 0x60, (char)0xe0, 0x10, (char)0x90, 0x50,
        (char)0xd0, 0x30, (char)0xb0, 0x70, (char)0xf0);
    const __m256i rev_lo = _mm256_srli_epi16(rev_hi, 4); /* in the low nibble */
    const __m256i nib = _mm256_set1_epi8(0x0f);
    __m256i v = (__m256i)b;
    __m256i low = _mm256_and_si256(v, nib);
    __m256i high = _mm256_and_si256(_mm256_srli_epi16(v, 4), nib);
    return (u32x8)_mm256_or_si256(_mm256_shuffle_epi8(rev_hi, low),
                                  _mm256_shuffle_epi8(rev_lo, high));
#else
    x = (u32x8)b;
    x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    return x;
#endif
}

static inline u32x8 lk_hash8(u32x8 x, u32x8 seed)
{
    QMC__LK_HASH_STEPS(x, seed);
    return x;
}

static inline __attribute__((always_inline)) u32x8
finish8(u32x8 state, u32x8 seed, qmc_scramble scr)
{
    switch (scr) {
    case QMC_SCRAMBLE_SHIFT:
        return state ^ seed;
    case QMC_SCRAMBLE_OWEN:
        return reverse8(lk_hash8(state, seed));
    default:
        return state;
    }
}

static inline __attribute__((always_inline)) void
store8(void *out, size_t k, u32x8 y, qmc_format fmt)
{
    switch (fmt) {
    case QMC_FORMAT_F64: {
#ifdef __AVX512F__
        /* One exact u32 -> f64 conversion (vcvtudq2pd) and an exact scaling
         * by 2^-32: the same bits as unit_from_bits. */
        __m512d d = _mm512_mul_pd(_mm512_cvtepu32_pd((__m256i)y), _mm512_set1_pd(0x1p-32));
        _mm512_storeu_pd((double *)out + k, d);
        break;
#endif
        /* The double 1 + y * 2^-32 has low word y << 20 and high word
         * 0x3ff00000 | y >> 12; build both words for 8 lanes and
         * interleave them (little-endian: low word first), cheaper than
         * widening y to 64 bits. */
        u32x8 lw = y << 20, hw = (y >> 12) | 0x3ff00000u;
        u32x8 b0 = __builtin_shufflevector(lw, hw, 0, 8, 1, 9, 2, 10, 3, 11);
        u32x8 b1 = __builtin_shufflevector(lw, hw, 4, 12, 5, 13, 6, 14, 7, 15);
        f64x4 dlo = (f64x4)b0 - 1.0;
        f64x4 dhi = (f64x4)b1 - 1.0;
        memcpy((double *)out + k, &dlo, sizeof dlo);
        memcpy((double *)out + k + 4, &dhi, sizeof dhi);
        break;
    }
    case QMC_FORMAT_F32: {
        /* y >> 8 < 2^24 converts to float exactly, as in store(). */
        f32x8 f = __builtin_convertvector((i32x8)(y >> 8), f32x8) * 0x1p-24f;
        memcpy((float *)out + k, &f, sizeof f);
        break;
    }
    case QMC_FORMAT_U32:
        memcpy((uint32_t *)out + k, &y, sizeof y);
        break;
    }
}

#ifdef __AVX512VBMI__
/*
 * Owen-scrambled f64 without a conversion instruction.  With y =
 * reverse32(h), the double 16 + y * 2^-32 has exponent 0x403 and mantissa
 * y << 16, which is byte-aligned: its 8 bytes, little-endian, are 0, 0,
 * y's four bytes, 0x30, 0x40.  Byte i of y is byte 3 - i of h with its
 * bits reversed, so one two-source byte permute (vpermt2b) lays out h's
 * bytes in that order beside constant bytes stored bit-reversed (0x0c,
 * 0x02), one GF(2) affine transform reverses the bits of every byte, and
 * subtracting 16 is exact: y * 2^-32, the same bits as store() of y.
 * Row 0 of the permute table takes lanes 0..7 of h, row 1 lanes 8..15;
 * indices 64.. pick the constant bytes (0x00, 0x0c, 0x02).
 */
static const uint8_t owen_f64_permute[2][64] = {
#define QMC__OWEN_F64_QWORD(l) 64, 64, 4 * (l) + 3, 4 * (l) + 2, 4 * (l) + 1, 4 * (l), 65, 66
    {QMC__OWEN_F64_QWORD(0), QMC__OWEN_F64_QWORD(1), QMC__OWEN_F64_QWORD(2),
     QMC__OWEN_F64_QWORD(3), QMC__OWEN_F64_QWORD(4), QMC__OWEN_F64_QWORD(5),
     QMC__OWEN_F64_QWORD(6), QMC__OWEN_F64_QWORD(7)},
    {QMC__OWEN_F64_QWORD(8), QMC__OWEN_F64_QWORD(9), QMC__OWEN_F64_QWORD(10),
     QMC__OWEN_F64_QWORD(11), QMC__OWEN_F64_QWORD(12), QMC__OWEN_F64_QWORD(13),
     QMC__OWEN_F64_QWORD(14), QMC__OWEN_F64_QWORD(15)},
#undef QMC__OWEN_F64_QWORD
};

/* 8 doubles from lanes 8 * half .. 8 * half + 7 of h (512 bits; only the
 * low 256 are read when half is 0). */
static inline __attribute__((always_inline)) void
owen_f64_store(double *o, __m512i h, int half)
{
    const __m512i idx = _mm512_loadu_si512(owen_f64_permute[half]);
    const __m512i bytes = _mm512_set_epi64(0, 0, 0, 0, 0, 0, 0, 0x020c00);
    __m512i b = _mm512_permutex2var_epi8(h, idx, bytes);
    b = _mm512_gf2p8affine_epi64_epi8(b, _mm512_set1_epi64(0x8040201008040201ll), 0);
    _mm512_storeu_pd(o, _mm512_sub_pd(_mm512_castsi512_pd(b), _mm512_set1_pd(16.0)));
}
#endif

/* The scramble and the store of 8 coordinates from their states: what
 * every fill loop does per vector. */
static inline __attribute__((always_inline)) void
emit8(void *out, size_t k, u32x8 state, u32x8 seed, qmc_scramble scr, qmc_format fmt)
{
#ifdef __AVX512VBMI__
    if (scr == QMC_SCRAMBLE_OWEN && fmt == QMC_FORMAT_F64) {
        owen_f64_store((double *)out + k, _mm512_castsi256_si512((__m256i)lk_hash8(state, seed)),
                       0);
        return;
    }
#endif
    store8(out, k, finish8(state, seed, scr), fmt);
}

#if defined(__AVX512BW__) && defined(__GFNI__)
/*
 * The AVX-512 build walks 16 dimensions per vector where it can: a 512-bit
 * instruction costs the front end and the scheduler what a 256-bit one
 * does, so the hash of 16 coordinates costs about what 8 did (measured,
 * owen f64 at d = 32: 16% more coordinates a second).  Same hash (the
 * statement list of QMC__LK_HASH_STEPS), same stores, same bits.
 */
#define QMC__SOBOL_WIDE 1
typedef uint32_t u32x16 __attribute__((vector_size(64)));

static inline u32x16 load16(const uint32_t *p)
{
    u32x16 v;
    memcpy(&v, p, sizeof v);
    return v;
}

static inline __attribute__((always_inline)) void
emit16(void *out, size_t k, u32x16 state, u32x16 seed, qmc_scramble scr, qmc_format fmt)
{
    u32x16 y = state;
    if (scr == QMC_SCRAMBLE_OWEN) {
        QMC__LK_HASH_STEPS(y, seed);
#ifdef __AVX512VBMI__
        if (fmt == QMC_FORMAT_F64) {
            owen_f64_store((double *)out + k, (__m512i)y, 0);
            owen_f64_store((double *)out + k + 8, (__m512i)y, 1);
            return;
        }
#endif
        /* reverse8's steps on 16 lanes: bytes within each lane, then bits */
        const __m512i bswap = _mm512_broadcast_i32x4(
            _mm_setr_epi8(3, 2, 1, 0, 7, 6, 5, 4, 11, 10, 9, 8, 15, 14, 13, 12));
        y = (u32x16)_mm512_gf2p8affine_epi64_epi8(_mm512_shuffle_epi8((__m512i)y, bswap),
                                                  _mm512_set1_epi64(0x8040201008040201ll), 0);
    } else if (scr == QMC_SCRAMBLE_SHIFT) {
        y ^= seed;
    }
    store8(out, k, __builtin_shufflevector(y, y, 0, 1, 2, 3, 4, 5, 6, 7), fmt);
    store8(out, k + 8, __builtin_shufflevector(y, y, 8, 9, 10, 11, 12, 13, 14, 15), fmt);
}
#endif

/*
 * Points per block.  When the whole output fits in cache, blocks of up to
 * 64 points whose rows for one chunk of dimensions (count x width x 8
 * bytes) stay within 16 KiB of L1: each row is revisited once per group of
 * dimensions.  When the output is larger than any cache, memory traffic
 * decides, and for rows wider than one pass of 16 dimensions, rows written
 * strictly in order (one point per block) keep the store stream
 * sequential: measured 2.1x faster there at d = 32, 20% slower in cache.
 * Only speed depends on this, never the bits.
 */
enum { BLOCK = 64 };
#define QMC__STREAM_BYTES (4u << 20)

static inline uint32_t block_points(uint32_t width, uint64_t count)
{
    if (width > 16 && count * width * sizeof(double) > QMC__STREAM_BYTES)
        return 1; /* (up to 16 dims a block's rows are one pass: in order) */
    uint32_t n = 2048 / width;
    return n < 8 ? 8 : n > BLOCK ? BLOCK : n;
}

/*
 * Fills points [start, start + count).  Points go in blocks; within a
 * block each group of 8 dimensions walks all the block's points with its
 * state in one register, reading row W_c of the transposed prefix table,
 * where c = ctz(index).  Point `start` itself reads the all-zero row 32.
 * Inlined once per (format, scramble) pair so inner loops have no branches.
 */
enum { CHUNK = 256 }; /* dimensions per pass: 1 KiB of state on the stack */

static inline __attribute__((always_inline)) void
fill_blocks(const qmc_seq *seq, uint64_t start, uint64_t count, qmc_format fmt,
            qmc_scramble scr, void *out, uint32_t j_begin, uint32_t j_end)
{
    const sobol_view s = view(seq);
    const uint32_t d = seq->spec.dims;
    const uint32_t d8 = j_begin + ((j_end - j_begin) & ~7u);
    /* state of dimension j at st[j - j_begin], + 8 spare lanes for the last vector */
    uint32_t st[CHUNK + 8];
    memset(st + (j_end - j_begin), 0, 8 * sizeof *st);
    for (uint32_t j = j_begin; j < j_end; j++)
        st[j - j_begin] = gather(s.v + (size_t)j * BITS, (uint32_t)start);
    const uint32_t block = block_points(j_end - j_begin, count);
    for (uint64_t p0 = 0; p0 < count; p0 += block) {
        const uint32_t n = count - p0 < block ? (uint32_t)(count - p0) : block;
        const uint32_t *row[BLOCK];
        for (uint32_t p = 0; p < n; p++) {
            uint64_t i = start + p0 + p;
            row[p] = s.w + (size_t)(i == start ? BITS : __builtin_ctz((uint32_t)i)) * d;
        }
        if (d8 < j_end) {
            /*
             * The last 1..7 dimensions as one vector too: the scalar hash
             * of a few trailing dimensions cost as much as the vectors of
             * all the others (d = 30: 6 scalar lanes against 24 vector
             * ones).  The loads run past the row ends into the next row,
             * the seeds or QMC__SOBOL_PAD zeros.  The store writes all 8
             * lanes: the spare ones land on the next points' first
             * dimensions, which are written afterwards (this group runs
             * first, and points and blocks go in order), so only stores
             * that would pass the end of the output, or of the dimensions
             * an earlier pass of CHUNK wrote, copy the t lanes alone.
             */
            const uint32_t t = j_end - d8;
            const size_t value = qmc_format_bytes(fmt), words = t * value / 4;
            const size_t limit = j_begin == 0 ? (size_t)count * d : 0;
            u32x8 x = load8(st + (d8 - j_begin)), seed = load8(s.seed + d8);
            for (uint32_t p = 0; p < n; p++) {
                const size_t at = (size_t)(p0 + p) * d + d8;
                x ^= load8(row[p] + d8);
                if (at + 8 <= limit) {
                    emit8(out, at, x, seed, scr, fmt);
                    continue;
                }
                uint32_t lanes[16];
                emit8(lanes, 0, x, seed, scr, fmt);
                char *o = (char *)out + at * value;
                for (size_t w = 0; w < words; w++)
                    memcpy(o + 4 * w, lanes + w, 4);
            }
            memcpy(st + (d8 - j_begin), &x, t * sizeof(uint32_t));
        }
        uint32_t j = j_begin;
#ifdef QMC__SOBOL_WIDE
        for (; j + 16 <= d8; j += 16) {
            u32x16 x = load16(st + (j - j_begin)), seed = load16(s.seed + j);
            for (uint32_t p = 0; p < n; p++) {
                x ^= load16(row[p] + j);
                emit16(out, (size_t)(p0 + p) * d + j, x, seed, scr, fmt);
            }
            memcpy(st + (j - j_begin), &x, sizeof x);
        }
#endif
        for (; j < d8; j += 8) {
            u32x8 x = load8(st + (j - j_begin)), seed = load8(s.seed + j);
            for (uint32_t p = 0; p < n; p++) {
                x ^= load8(row[p] + j);
                emit8(out, (size_t)(p0 + p) * d + j, x, seed, scr, fmt);
            }
            memcpy(st + (j - j_begin), &x, sizeof x);
        }
    }
}

/*
 * f64 output for scrambles none and shift: the state of each dimension is
 * kept as the 64-bit word (x ^ shift) << 20, so that OR-ing in the exponent
 * of 1.0 gives the double 1 + y * 2^-32 and subtracting 1 gives y * 2^-32
 * exactly - the same bits as store().  The shift seed is folded into the
 * starting state (XOR commutes), so the shift scramble costs nothing.
 */
static inline u64x4 load4(const uint64_t *p)
{
    u64x4 v;
    memcpy(&v, p, sizeof v);
    return v;
}

/* Four doubles y * 2^-32 from four words y << 20 (see fill_f64_blocks). */
static inline void store_unit4(double *o, u64x4 x, u64x4 one)
{
    f64x4 v = (f64x4)(x | one) - 1.0;
    memcpy(o, &v, sizeof v);
}

static inline __attribute__((always_inline)) void
fill_f64_blocks(const qmc_seq *seq, uint64_t start, uint64_t count,
                double *out, uint32_t j_begin, uint32_t j_end)
{
    const sobol_view s = view(seq);
    const uint32_t d = seq->spec.dims;
    const uint32_t d4 = j_begin + ((j_end - j_begin) & ~3u);
    const int shift = seq->spec.scramble == QMC_SCRAMBLE_SHIFT;
    const uint64_t e = 0x3ff0000000000000ull; /* the exponent of 1.0 */
    const u64x4 one = {e, e, e, e};
    uint64_t st[CHUNK]; /* state of dimension j at st[j - j_begin] */
    for (uint32_t j = j_begin; j < j_end; j++) {
        uint32_t x = gather(s.v + (size_t)j * BITS, (uint32_t)start);
        st[j - j_begin] = (uint64_t)(shift ? x ^ s.seed[j] : x) << 20;
    }
    const uint32_t block = block_points(j_end - j_begin, count);
    for (uint64_t p0 = 0; p0 < count; p0 += block) {
        const uint32_t n = count - p0 < block ? (uint32_t)(count - p0) : block;
        const uint64_t *row[BLOCK];
        for (uint32_t p = 0; p < n; p++) {
            uint64_t i = start + p0 + p;
            row[p] = s.w64 + (size_t)(i == start ? BITS : __builtin_ctz((uint32_t)i)) * d;
        }
        /* Four vectors of four dimensions per step, then one: a row
         * pointer load and a loop test serve up to sixteen coordinates.
         * (Named variables: arrays of vectors end up spilled to memory.) */
        uint32_t j = j_begin;
        for (; j + 16 <= d4; j += 16) {
            uint64_t *sj = st + (j - j_begin);
            u64x4 x0 = load4(sj), x1 = load4(sj + 4), x2 = load4(sj + 8), x3 = load4(sj + 12);
            for (uint32_t p = 0; p < n; p++) {
                const uint64_t *w = row[p] + j;
                double *o = out + (size_t)(p0 + p) * d + j;
                x0 ^= load4(w);
                x1 ^= load4(w + 4);
                x2 ^= load4(w + 8);
                x3 ^= load4(w + 12);
                store_unit4(o, x0, one);
                store_unit4(o + 4, x1, one);
                store_unit4(o + 8, x2, one);
                store_unit4(o + 12, x3, one);
            }
            memcpy(sj, &x0, sizeof x0);
            memcpy(sj + 4, &x1, sizeof x1);
            memcpy(sj + 8, &x2, sizeof x2);
            memcpy(sj + 12, &x3, sizeof x3);
        }
        for (; j < d4; j += 4) {
            uint64_t *sj = st + (j - j_begin);
            u64x4 x = load4(sj);
            for (uint32_t p = 0; p < n; p++) {
                x ^= load4(row[p] + j);
                store_unit4(out + (size_t)(p0 + p) * d + j, x, one);
            }
            memcpy(sj, &x, sizeof x);
        }
        for (; j < j_end; j++) {
            uint64_t x = st[j - j_begin];
            for (uint32_t p = 0; p < n; p++) {
                x ^= row[p][j];
                uint64_t b = x | 0x3ff0000000000000ull;
                double v;
                memcpy(&v, &b, sizeof v);
                out[(size_t)(p0 + p) * d + j] = v - 1.0;
            }
            st[j - j_begin] = x;
        }
    }
}
/*
 * Points [start, start + count) with start and count multiples of 8, for
 * has_packed() dimensions (table P, sobol_impl.h): the 8*d coordinates
 * of 8 consecutive points are d full vectors, each stepping by its row of
 * P, so no lane idles.  Groups of blocks keep their output within 16 KiB
 * (L1) while each vector walks them.  Same states, finish8 and store8 as
 * fill_blocks, so the same bits.
 */
enum { PACKED_GROUP_BYTES = 16384, PACKED_GROUP_MAX = 256 };

static inline __attribute__((always_inline)) void
fill_packed(const qmc_seq *seq, uint64_t start, uint64_t count, qmc_format fmt,
            qmc_scramble scr, void *out)
{
    const sobol_view s = view(seq);
    const uint32_t d = seq->spec.dims;
    const uint32_t lanes = 8 * d;
    uint32_t st[8 * QMC__SOBOL_PACK_DIMS], seed[8 * QMC__SOBOL_PACK_DIMS];
    /* Point start (a multiple of 8) by gathering, start + k from start +
     * k - 1 by one step, as in fill_blocks: bits 0..ctz(k) flip. */
    for (uint32_t j = 0; j < d; j++) {
        st[j] = gather(s.v + (size_t)j * BITS, (uint32_t)start);
        seed[j] = s.seed[j];
    }
    for (uint32_t k = 1; k < 8; k++) {
        const uint32_t *w = s.w + (size_t)__builtin_ctz(k) * d;
        for (uint32_t j = 0; j < d; j++) {
            st[k * d + j] = st[(k - 1) * d + j] ^ w[j];
            seed[k * d + j] = s.seed[j];
        }
    }
    uint32_t group = PACKED_GROUP_BYTES / (lanes * (uint32_t)qmc_format_bytes(fmt));
    group = group < 1 ? 1 : group > PACKED_GROUP_MAX ? PACKED_GROUP_MAX : group;
    const uint64_t blocks = count / 8, first = start / 8;
    for (uint64_t b0 = 0; b0 < blocks; b0 += group) {
        const uint32_t n = blocks - b0 < group ? (uint32_t)(blocks - b0) : group;
        const uint32_t *row[PACKED_GROUP_MAX];
        for (uint32_t m = 0; m < n; m++) {
            const uint64_t b = first + b0 + m;
            const uint32_t r = b == first ? QMC__SOBOL_PACK_ROWS - 1
                                          : (uint32_t)__builtin_ctzll(b);
            row[m] = s.packed + (size_t)r * packed_row_words(d);
        }
        for (uint32_t q = 0, j = 0; q < lanes; q += 8, j = (j + 8) % d) {
            u32x8 x = load8(st + q), sd = load8(seed + q);
            for (uint32_t m = 0; m < n; m++) {
                x ^= load8(row[m] + j); /* lanes q..q+7: dimensions j.. */
                emit8(out, (size_t)(b0 + m) * lanes + q, x, sd, scr, fmt);
            }
            memcpy(st + q, &x, sizeof x);
        }
    }
}

/* Any range, point by point (fill_blocks, fill_f64_blocks), in passes of
 * CHUNK dimensions. */
static inline void fill_pointwise(const qmc_seq *seq, uint64_t start, uint64_t count,
                                  qmc_format fmt, void *out)
{
    const qmc_scramble scr = kernel_scramble(seq->spec.scramble);
    const uint32_t d = seq->spec.dims;
    for (uint32_t j0 = 0; j0 < d; j0 += CHUNK) {
        const uint32_t j1 = d - j0 > CHUNK ? j0 + CHUNK : d;
        if (fmt == QMC_FORMAT_F64 && scr != QMC_SCRAMBLE_OWEN) {
            fill_f64_blocks(seq, start, count, out, j0, j1);
            continue;
        }
#define QMC__SOBOL_CASE(F, S)                                                  \
    if (fmt == QMC_FORMAT_##F && scr == QMC_SCRAMBLE_##S) {                    \
        fill_blocks(seq, start, count, QMC_FORMAT_##F, QMC_SCRAMBLE_##S, out,  \
                    j0, j1);                                                   \
        continue;                                                              \
    }
#define QMC__SOBOL_FMT(F) \
    QMC__SOBOL_CASE(F, NONE) QMC__SOBOL_CASE(F, SHIFT) QMC__SOBOL_CASE(F, OWEN)
        QMC__SOBOL_CASE(F64, OWEN) /* (none and shift went above) */
        QMC__SOBOL_FMT(F32)
        QMC__SOBOL_FMT(U32)
#undef QMC__SOBOL_FMT
#undef QMC__SOBOL_CASE
    }
}

static inline void fill_packed_any(const qmc_seq *seq, uint64_t start, uint64_t count,
                                   qmc_format fmt, void *out)
{
    const qmc_scramble scr = kernel_scramble(seq->spec.scramble);
#define QMC__SOBOL_CASE(F, S)                                                  \
    if (fmt == QMC_FORMAT_##F && scr == QMC_SCRAMBLE_##S) {                    \
        fill_packed(seq, start, count, QMC_FORMAT_##F, QMC_SCRAMBLE_##S, out); \
        return;                                                                \
    }
#define QMC__SOBOL_FMT(F) \
    QMC__SOBOL_CASE(F, NONE) QMC__SOBOL_CASE(F, SHIFT) QMC__SOBOL_CASE(F, OWEN)
    QMC__SOBOL_FMT(F64)
    QMC__SOBOL_FMT(F32)
    QMC__SOBOL_FMT(U32)
#undef QMC__SOBOL_FMT
#undef QMC__SOBOL_CASE
}

/* Below QMC__SOBOL_PACK_DIMS the whole blocks of 8 points between an
 * unaligned head and tail go packed, when there are at least d of them:
 * setting up the 8d lanes costs about a block per dimension (measured: 30
 * dimensions, 16 points a fill, 30% slower packed). */
static inline void sobol_fill_natural(const qmc_seq *seq, uint64_t start, uint64_t count,
                                      qmc_format fmt, void *out)
{
    const sobol_view s = view(seq);
    const uint64_t end = start + count;
    const uint64_t mid = (start + 7) & ~(uint64_t)7, mid_end = end & ~(uint64_t)7;
    if (!s.packed || mid >= mid_end || mid_end - mid < 8 * (uint64_t)seq->spec.dims) {
        fill_pointwise(seq, start, count, fmt, out);
        return;
    }
    const size_t point = (size_t)seq->spec.dims * qmc_format_bytes(fmt);
    if (mid > start)
        fill_pointwise(seq, start, mid - start, fmt, out);
    fill_packed_any(seq, mid, mid_end - mid, fmt, (char *)out + (mid - start) * point);
    if (end > mid_end)
        fill_pointwise(seq, mid_end, end - mid_end, fmt, (char *)out + (mid_end - start) * point);
}

#endif
