/*
 * pixel_kernel.h - the pixel samplers' vector kernels, as static inline
 * functions over PK_VW 32-bit lanes (private; included only by
 * pixel_kernel.c, pixel_kernel_avx2.c and pixel_kernel_avx512.c, which
 * compile them for different instruction sets: PK_VW 4 for the baseline,
 * 8 with AVX2, 16 with AVX-512).  The two shuffles that differ by
 * instruction set are chosen here by PK_VW, as sobol_fill.h chooses its
 * own; a build that defines PK_EMIT_NAME and PK_NODES_NAME gets its entry
 * points under those names (the end of this file).
 *
 * Written with the GCC/clang vector extensions, integer operations only
 * (plus the exact u32 -> f32 conversion of a 24-bit integer), so every
 * build gives the same bits; the unit tests compare fills with at().
 * The samplers stage values in the bit-reversed domain, row-major (one
 * row per sample, one column per value); the kernel walks the flat block
 * a vector at a time with each column's parameters laid out as periodic
 * lane patterns (pixel_impl.h), scrambles, reverses once and stores in
 * the caller's format - no transposition.
 *
 * Must not: allocate, or read more than QMC__PIXEL_PAD words past a
 * staged block's end (the callers' staging arrays have that much more).
 */
#include <string.h>

#include "pixel_impl.h"
#include "sobol_wide.h"

#if defined(__GNUC__)
/* Vectors never cross an ABI boundary: every helper here is inlined. */
#pragma GCC diagnostic ignored "-Wpsabi"
#endif

typedef uint32_t pk_u __attribute__((vector_size(PK_VW * 4)));
typedef int32_t pk_i __attribute__((vector_size(PK_VW * 4)));
typedef float pk_f __attribute__((vector_size(PK_VW * 4)));
typedef uint8_t pk_b __attribute__((vector_size(PK_VW * 4)));

/* ---- the instruction set's shuffles --------------------------------------- */

/* pk_reverse: the bit reversal of each lane.  pk_permute: lane l of the
 * result is lane idx[l] of x (idx < PK_VW).  Each with the best shuffles
 * the build's instruction set has. */
#if PK_VW == 8 || PK_VW == 16
#include <immintrin.h>

/* The byte shuffle that reverses each word's bytes, and rev_hi: byte n of
 * every 16 is the 4 bits of n reversed, in the high nibble (vpshufb looks
 * up within 16-byte lanes).  Built as each width builds such constants
 * best. */
#if PK_VW == 16
typedef __m512i pk_m;
#define PK_MM(op) _mm512_##op
#define PK_SI(op) _mm512_##op##_si512
#define PK_BSWAP                                                                        \
    _mm512_set_epi64(0x0c0d0e0f08090a0bll, 0x0405060700010203ll, 0x0c0d0e0f08090a0bll, \
                     0x0405060700010203ll, 0x0c0d0e0f08090a0bll, 0x0405060700010203ll, \
                     0x0c0d0e0f08090a0bll, 0x0405060700010203ll)
#define PK_REV_HI \
    _mm512_set4_epi32((int)0xf070b030, (int)0xd0509010, (int)0xe060a020, (int)0xc0408000)
#else
typedef __m256i pk_m;
#define PK_MM(op) _mm256_##op
#define PK_SI(op) _mm256_##op##_si256
#define PK_BSWAP                                                                       \
    _mm256_setr_epi8(3, 2, 1, 0, 7, 6, 5, 4, 11, 10, 9, 8, 15, 14, 13, 12, 3, 2, 1, 0, 7, \
                     6, 5, 4, 11, 10, 9, 8, 15, 14, 13, 12)
#define PK_REV_HI                                                                          \
    _mm256_setr_epi8(0x00, (char)0x80, 0x40, (char)0xc0, 0x20, (char)0xa0, 0x60, (char)0xe0, \
                     0x10, (char)0x90, 0x50, (char)0xd0, 0x30, (char)0xb0, 0x70, (char)0xf0, \
                     0x00, (char)0x80, 0x40, (char)0xc0, 0x20, (char)0xa0, 0x60, (char)0xe0, \
                     0x10, (char)0x90, 0x50, (char)0xd0, 0x30, (char)0xb0, 0x70, (char)0xf0)
#endif

/* Bytes reversed by one shuffle, then each byte's bits by looking up both
 * nibbles in a 16-entry table (two vpshufb). */
static inline pk_u pk_reverse(pk_u x)
{
    const pk_m rev_hi = PK_REV_HI;
    const pk_m rev_lo = PK_MM(srli_epi16)(rev_hi, 4);
    const pk_m nib = PK_MM(set1_epi8)(0x0f);
    const pk_m v = PK_MM(shuffle_epi8)((pk_m)x, PK_BSWAP);
    const pk_m low = PK_SI(and)(v, nib);
    const pk_m high = PK_SI(and)(PK_MM(srli_epi16)(v, 4), nib);
    return (pk_u)PK_SI(or)(PK_MM(shuffle_epi8)(rev_hi, low),
                           PK_MM(shuffle_epi8)(rev_lo, high));
}

static inline pk_u pk_permute(pk_u x, pk_u idx)
{
#if PK_VW == 16
    return (pk_u)_mm512_permutexvar_epi32((__m512i)idx, (__m512i)x);
#else
    return (pk_u)_mm256_permutevar8x32_epi32((__m256i)x, (__m256i)idx);
#endif
}
#else /* the baseline: 4 lanes, generic shuffles */
static inline pk_u pk_reverse(pk_u x)
{
    pk_b b = (pk_b)x;
    b = __builtin_shufflevector(b, b, 3, 2, 1, 0, 7, 6, 5, 4, 11, 10, 9, 8, 15, 14, 13, 12);
    x = (pk_u)b;
    x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    return x;
}

static inline pk_u pk_permute(pk_u x, pk_u idx)
{
#if defined(__clang__)
    /* clang has no variable-index vector shuffle builtin. */
    pk_u r;
    for (int l = 0; l < PK_VW; l++)
        r[l] = x[idx[l] & (PK_VW - 1)];
    return r;
#else
    return __builtin_shuffle(x, idx);
#endif
}
#endif

/* ---- lanes -------------------------------------------------------------------- */

static inline pk_u pk_load(const uint32_t *p)
{
    pk_u v;
    memcpy(&v, p, sizeof v);
    return v;
}

static inline void pk_store(uint32_t *p, pk_u v)
{
    memcpy(p, &v, sizeof v);
}

static inline pk_u pk_splat(uint32_t x)
{
    return (pk_u){0} + x;
}

/* Dimension 1 in the reversed domain (sobol_wide.h), lane by lane. */
static inline pk_u pk_dim1(pk_u x)
{
    QMC__SOBOL_DIM1_REVERSED32_STEPS(x);
    return x;
}

/* qmc__fast_owen_reversed, lane by lane (smul = (seed >> 16) | 1). */
static inline pk_u pk_owen(pk_u x, pk_u seed, pk_u smul)
{
    QMC__FAST_OWEN_STEPS(x, seed, smul);
    return x;
}

/* ---- zsobol's node hashes: 64-bit lanes ---------------------------------- */

typedef uint64_t pk_q __attribute__((vector_size(PK_VW * 4)));
typedef uint8_t pk_q8 __attribute__((vector_size(PK_VW / 2)));
#define PK_QW (PK_VW / 2)

/* pbrt-v4's MixBits (render_hash.h), lane by lane. */
static inline pk_q pk_mix_bits(pk_q v)
{
    QMC__MIX_BITS_STEPS(v);
    return v;
}

/*
 * out[j] = (MixBits((key0 + j) ^ salt) >> 24) % 24 for j < n (written up
 * to n rounded up to PK_QW), or MixBits(...) & 1 when bit.  The modulo
 * without a division: x = h >> 24 < 2^40 is exact in a double (built from
 * its bits), and q = floor(x / 24) is x / 24 - 11.5 / 24 rounded to the
 * nearest integer - the fraction r / 24 - 11.5 / 24 stays 0.02 away from
 * a half, and the double arithmetic errs by under 2^-16 - rounded by
 * adding 1.5 2^52, whose ulp is 1.  Then x % 24 = x - 24 q.
 */
static inline void pk_nodes(uint64_t key0, uint64_t salt, uint32_t n, int bit, uint8_t *out)
{
    typedef double pk_qd __attribute__((vector_size(PK_VW * 4)));
    const uint64_t exp52 = 0x4330000000000000ull;  /* the bits of 2^52 */
    const uint64_t magic = 0x4338000000000000ull;  /* the bits of 1.5 2^52 */
    pk_q k = (pk_q){0} + key0;
    for (uint32_t l = 0; l < PK_QW; l++)
        k[l] += l;
    for (uint32_t j = 0; j < n; j += PK_QW, k += PK_QW) {
        const pk_q h = pk_mix_bits(k ^ salt);
        pk_q r;
        if (bit) {
            r = h & 1u;
        } else {
            const pk_q x = h >> 24;
            const pk_qd d = (pk_qd)(x | exp52) - 0x1p52;
            const pk_qd z = (d * (1.0 / 24) - 11.5 / 24) + 0x1.8p52;
            const pk_q q = (pk_q)z - magic;
            r = x - ((q << 4) + (q << 3));
        }
        const pk_q8 b = __builtin_convertvector(r, pk_q8);
        memcpy(out + j, &b, sizeof b);
    }
}

/* PermutationElement(i, w + 1, p) per lane, for a power-of-two length
 * w + 1 (no cycle walking: every step stays at or below w). */
static inline pk_u pk_perm(pk_u i, uint32_t w, pk_u p)
{
    QMC__PERMUTATION_STEPS(i, w, p);
    return (i + p) & w;
}

/* A vector's worth of a pattern: the lanes at offset po of the period. */
typedef struct pk_lanes {
    pk_u rowoff, perm, src, dim1, xorc, seed, smul, owen;
    uint32_t base; /* the first lane's staged word */
} pk_lanes;

static inline __attribute__((always_inline)) pk_lanes pk_lanes_at(const qmc__pixel_pattern *pt,
                                                                  uint32_t po)
{
    pk_lanes v;
    v.rowoff = pk_load(pt->rowoff + po);
    v.perm = pk_load(pt->perm + po);
    v.base = pt->src[po];
    v.src = pk_load(pt->src + po) - v.base;
    v.dim1 = pk_load(pt->dim1 + po);
    v.xorc = pk_load(pt->xorc + po);
    v.seed = pk_load(pt->seed + po);
    v.smul = pk_load(pt->smul + po);
    v.owen = pk_load(pt->owen + po);
    return v;
}

/* One vector of finished values, from the staged words of its period
 * (in) or, in index mode, from the period's first row row0. */
static inline __attribute__((always_inline)) pk_u
pk_value(const pk_lanes *v, const uint32_t *in, uint32_t row0, uint32_t w, int index_mode,
         int paired, int any_dim1, int any_plain)
{
    pk_u x;
    if (index_mode)
        x = pk_perm(pk_splat(row0) + v->rowoff, w, v->perm);
    else if (paired) /* both columns of a pair read its one staged word */
        x = pk_permute(pk_load(in + v->base), v->src);
    else
        x = pk_load(in + v->base);
    if (any_dim1)
        x = (pk_dim1(x) & v->dim1) | (x & ~v->dim1);
    x ^= v->xorc;
    const pk_u y = pk_owen(x, v->seed, v->smul);
    x = any_plain ? (y & v->owen) | (x & ~v->owen) : y;
    return pk_reverse(x);
}

/* Stores the first n <= PK_VW lanes of x at element k of dst, in fmt. */
static inline __attribute__((always_inline)) void pk_put(void *dst, size_t k, pk_u x, uint32_t n,
                                                         qmc_format fmt)
{
    if (fmt == QMC_FORMAT_F64) {
        typedef uint32_t pk_uh __attribute__((vector_size(PK_VW * 2)));
        typedef double pk_d __attribute__((vector_size(PK_VW * 4)));
        uint32_t lanes[PK_VW];
        pk_uh lo, hi;
        pk_store(lanes, x);
        memcpy(&lo, lanes, sizeof lo);
        memcpy(&hi, lanes + PK_VW / 2, sizeof hi);
        /* u32 -> f64 and the power-of-two scale are exact. */
        pk_d d[2] = {__builtin_convertvector(lo, pk_d) * 0x1p-32,
                     __builtin_convertvector(hi, pk_d) * 0x1p-32};
        if (n == PK_VW) /* a constant size: vector stores, not a call */
            memcpy((double *)dst + k, d, sizeof d);
        else
            memcpy((double *)dst + k, d, n * sizeof(double));
        return;
    }
    if (fmt == QMC_FORMAT_F32) {
        /* x >> 8 < 2^24 converts exactly, as qmc__pixel_store does. */
        pk_f f = __builtin_convertvector((pk_i)(x >> 8), pk_f) * 0x1p-24f;
        memcpy(&x, &f, sizeof x);
    }
    if (n == PK_VW)
        pk_store((uint32_t *)dst + k, x);
    else
        memcpy((uint32_t *)dst + k, &x, n * sizeof(uint32_t));
}

static inline __attribute__((always_inline)) void
pk_run(const qmc__pixel_pattern *pt, const uint32_t *in, uint64_t row_start, uint32_t w,
       uint32_t rows, qmc_format fmt, void *dst, int index_mode, int paired, int any_dim1,
       int any_plain)
{
    const size_t total = (size_t)rows * pt->nc;
    uint32_t row0 = (uint32_t)row_start;
    if (pt->period <= 2 * PK_VW) {
        /* One or two vectors per period (nc divides 16 or is 32, AVX2's
         * 8 lanes): the pattern stays in registers. */
        const int two = pt->period == 2 * PK_VW;
        const pk_lanes v0 = pk_lanes_at(pt, 0), v1 = pk_lanes_at(pt, two ? PK_VW : 0);
        for (size_t q = 0; q < total;) {
            pk_u x = pk_value(&v0, in, row0, w, index_mode, paired, any_dim1, any_plain);
            pk_put(dst, q, x, total - q < PK_VW ? (uint32_t)(total - q) : PK_VW, fmt);
            q += PK_VW;
            if (two && q < total) {
                x = pk_value(&v1, in, row0, w, index_mode, paired, any_dim1, any_plain);
                pk_put(dst, q, x, total - q < PK_VW ? (uint32_t)(total - q) : PK_VW, fmt);
                q += PK_VW;
            }
            row0 += pt->rows_per_period;
            if (!index_mode)
                in += pt->in_per_period;
        }
        return;
    }
    uint32_t po = 0;
    for (size_t q = 0; q < total; q += PK_VW) {
        const pk_lanes v = pk_lanes_at(pt, po);
        const pk_u x = pk_value(&v, in, row0, w, index_mode, paired, any_dim1, any_plain);
        pk_put(dst, q, x, total - q < PK_VW ? (uint32_t)(total - q) : PK_VW, fmt);
        po += PK_VW;
        if (po == pt->period) {
            po = 0;
            row0 += pt->rows_per_period;
            if (!index_mode)
                in += pt->in_per_period;
        }
    }
}

/* The variants the samplers use, each inlined with its flags constant. */
static inline __attribute__((always_inline)) void
pk_run_fmt(const qmc__pixel_pattern *pt, const uint32_t *in, uint64_t row_start, uint32_t w,
           uint32_t rows, qmc_format fmt, void *dst)
{
    if (in == NULL) /* padded-sobol, power-of-two spp: index mode */
        pk_run(pt, in, row_start, w, rows, fmt, dst, 1, 0, 1, 0);
    else if (pt->paired) /* zsobol, padded-sobol's other spp */
        pk_run(pt, in, row_start, w, rows, fmt, dst, 0, 1, 1, 0);
    else if (pt->any_plain) /* sobol at frame 0 */
        pk_run(pt, in, row_start, w, rows, fmt, dst, 0, 0, 0, 1);
    else
        pk_run(pt, in, row_start, w, rows, fmt, dst, 0, 0, 0, 0);
}

static inline void pk_emit(const qmc__pixel_pattern *pt, const uint32_t *in, uint64_t row_start,
                           uint32_t w, uint32_t rows, qmc_format fmt, void *out, size_t stride,
                           void *scratch)
{
    const uint32_t nc = pt->nc;
    void *dst = nc == stride ? out : scratch;
    switch (fmt) {
    case QMC_FORMAT_F64:
        pk_run_fmt(pt, in, row_start, w, rows, QMC_FORMAT_F64, dst);
        break;
    case QMC_FORMAT_F32:
        pk_run_fmt(pt, in, row_start, w, rows, QMC_FORMAT_F32, dst);
        break;
    default:
        pk_run_fmt(pt, in, row_start, w, rows, QMC_FORMAT_U32, dst);
        break;
    }
    if (dst == out)
        return;
    const size_t es = fmt == QMC_FORMAT_F64 ? 8 : 4;
    for (uint32_t r = 0; r < rows; r++)
        memcpy((char *)out + r * stride * es, (char *)scratch + (size_t)r * nc * es, nc * es);
}

/* ---- an instruction set's entry points (pixel_kernel.c dispatches) -------- */

#if defined(__x86_64__) && defined(__GNUC__)
void qmc__pixel_emit_avx2(const qmc__pixel_pattern *pt, const uint32_t *in, uint64_t row_start,
                          uint32_t w, uint32_t rows, qmc_format fmt, void *out, size_t stride,
                          void *scratch);
void qmc__pixel_emit_avx512(const qmc__pixel_pattern *pt, const uint32_t *in,
                            uint64_t row_start, uint32_t w, uint32_t rows, qmc_format fmt,
                            void *out, size_t stride, void *scratch);
void qmc__pixel_nodes_avx2(uint64_t key0, uint64_t salt, uint32_t n, int bit, uint8_t *out);
void qmc__pixel_nodes_avx512(uint64_t key0, uint64_t salt, uint32_t n, int bit, uint8_t *out);
#endif

#if defined(PK_EMIT_NAME) && defined(PK_NODES_NAME)
void PK_EMIT_NAME(const qmc__pixel_pattern *pt, const uint32_t *in, uint64_t row_start,
                  uint32_t w, uint32_t rows, qmc_format fmt, void *out, size_t stride,
                  void *scratch)
{
    pk_emit(pt, in, row_start, w, rows, fmt, out, stride, scratch);
}

void PK_NODES_NAME(uint64_t key0, uint64_t salt, uint32_t n, int bit, uint8_t *out)
{
    pk_nodes(key0, salt, n, bit, out);
}
#endif
