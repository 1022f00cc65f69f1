/*
 * pixel_kernel.h - the pixel samplers' vector kernels, as static inline
 * functions over PK_VW 32-bit lanes (private; included only by
 * pixel_kernel.c, pixel_kernel_avx2.c and pixel_kernel_avx512.c, which
 * compile them for different instruction sets and name them with PK_NAME).
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
 * Must not: allocate, or read a staged block past its size rounded up to
 * QMC__PIXEL_PAD lanes (the callers pad their blocks that far).
 */
#include <string.h>

#include "pixel_impl.h"

#if defined(__GNUC__)
/* Vectors never cross an ABI boundary: every helper here is inlined. */
#pragma GCC diagnostic ignored "-Wpsabi"
#endif

typedef uint32_t pk_u __attribute__((vector_size(PK_VW * 4)));
typedef int32_t pk_i __attribute__((vector_size(PK_VW * 4)));
typedef float pk_f __attribute__((vector_size(PK_VW * 4)));
typedef uint8_t pk_b __attribute__((vector_size(PK_VW * 4)));

/* Bit reversal of each lane: defined by the including file, with the best
 * byte shuffle its instruction set has. */
static inline pk_u pk_reverse(pk_u x);

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
    x ^= (x >> 1) & 0x55555555u;
    x ^= (x >> 2) & 0x33333333u;
    x ^= (x >> 4) & 0x0f0f0f0fu;
    x ^= (x >> 8) & 0x00ff00ffu;
    x ^= (x >> 16) & 0x0000ffffu;
    return x;
}

/* qmc__fast_owen_reversed, lane by lane (smul = (seed >> 16) | 1). */
static inline pk_u pk_owen(pk_u x, pk_u seed, pk_u smul)
{
    x ^= x * 0x3d20adeau;
    x += seed;
    x *= smul;
    x ^= x * 0x05526c56u;
    x ^= x * 0x53a22864u;
    return x;
}

/* ---- zsobol's node hashes: 64-bit lanes ---------------------------------- */

typedef uint64_t pk_q __attribute__((vector_size(PK_VW * 4)));
typedef uint8_t pk_q8 __attribute__((vector_size(PK_VW / 2)));
#define PK_QW (PK_VW / 2)

/* pbrt-v4's MixBits, lane by lane. */
static inline pk_q pk_mix_bits(pk_q v)
{
    v ^= v >> 31;
    v *= 0x7fb5d329728ea185ull;
    v ^= v >> 27;
    v *= 0x81dadef4bc2dd44dull;
    v ^= v >> 33;
    return v;
}

/*
 * out[j] = (MixBits((key0 + j) ^ salt) >> 24) % 24 for j < n (written up
 * to n rounded up to PK_QW), or MixBits(...) & 1 when bit.  The modulo
 * without a division: x % 24 = 8 ((x >> 3) % 3) + (x & 7), and a residue
 * mod 3 survives folding a number's high part onto its low part at any
 * even bit position (4 = 1 mod 3).
 */
static inline void pk_nodes(uint64_t key0, uint64_t salt, uint32_t n, int bit, uint8_t *out)
{
    pk_q k = (pk_q){0} + key0;
    for (uint32_t l = 0; l < PK_QW; l++)
        k[l] += l;
    for (uint32_t j = 0; j < n; j += PK_QW, k += PK_QW) {
        const pk_q h = pk_mix_bits(k ^ salt);
        pk_q r;
        if (bit) {
            r = h & 1u;
        } else {
            pk_q y = h >> 27; /* (h >> 24) >> 3 < 2^37 */
            y = (y >> 32) + (y & 0xffffffffu);
            y = (y >> 16) + (y & 0xffffu);
            y = (y >> 8) + (y & 0xffu);
            y = (y >> 4) + (y & 0xfu);
            y = (y >> 2) + (y & 3u);
            y = (y >> 2) + (y & 3u);
            y = (y >> 2) + (y & 3u); /* now 0 .. 4 */
            y -= (pk_q)(y >= 3u) & 3u;
            r = (y << 3) | ((h >> 24) & 7u);
        }
        const pk_q8 b = __builtin_convertvector(r, pk_q8);
        memcpy(out + j, &b, sizeof b);
    }
}

/* PermutationElement(i, w + 1, p) per lane, for a power-of-two length
 * w + 1 (no cycle walking: every step stays at or below w). */
static inline pk_u pk_perm(pk_u i, uint32_t w, pk_u p)
{
    i ^= p;
    i *= 0xe170893du;
    i ^= p >> 16;
    i ^= (i & w) >> 4;
    i ^= p >> 8;
    i *= 0x0929eb3fu;
    i ^= p >> 23;
    i ^= (i & w) >> 1;
    i *= 1u | p >> 27;
    i *= 0x6935fa69u;
    i ^= (i & w) >> 11;
    i *= 0x74dcb303u;
    i ^= (i & w) >> 2;
    i *= 0x9e501cc3u;
    i ^= (i & w) >> 2;
    i *= 0xc860a3dfu;
    i &= w;
    i ^= i >> 5;
    return (i + p) & w;
}

/* One vector of finished values: lanes q .. q + PK_VW - 1 of the block,
 * at offset po of the pattern period. */
static inline __attribute__((always_inline)) pk_u
pk_value(const qmc__pixel_pattern *pt, const uint32_t *in, size_t q, uint32_t po, uint32_t row0,
         uint32_t w, int index_mode, int any_dim1, int any_plain)
{
    pk_u x;
    if (index_mode)
        x = pk_perm(pk_splat(row0) + pk_load(pt->rowoff + po), w, pk_load(pt->perm + po));
    else
        x = pk_load(in + q);
    if (any_dim1) {
        const pk_u m = pk_load(pt->dim1 + po);
        x = (pk_dim1(x) & m) | (x & ~m);
    }
    x ^= pk_load(pt->xorc + po);
    const pk_u y = pk_owen(x, pk_load(pt->seed + po), pk_load(pt->smul + po));
    if (any_plain) {
        const pk_u m = pk_load(pt->owen + po);
        x = (y & m) | (x & ~m);
    } else {
        x = y;
    }
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
       uint32_t rows, qmc_format fmt, void *dst, int index_mode, int any_dim1, int any_plain)
{
    const size_t total = (size_t)rows * pt->nc;
    uint32_t po = 0, row0 = (uint32_t)row_start;
    for (size_t q = 0; q < total; q += PK_VW) {
        const pk_u x = pk_value(pt, in, q, po, row0, w, index_mode, any_dim1, any_plain);
        pk_put(dst, q, x, total - q < PK_VW ? (uint32_t)(total - q) : PK_VW, fmt);
        po += PK_VW;
        if (po == pt->period) {
            po = 0;
            row0 += pt->rows_per_period;
        }
    }
}

/* The variants the samplers use, each inlined with its flags constant. */
static inline __attribute__((always_inline)) void
pk_run_fmt(const qmc__pixel_pattern *pt, const uint32_t *in, uint64_t row_start, uint32_t w,
           uint32_t rows, qmc_format fmt, void *dst)
{
    const int im = in == NULL;
    if (im) /* padded-sobol: index mode, dimension-1 lanes */
        pk_run(pt, in, row_start, w, rows, fmt, dst, 1, 1, 0);
    else if (pt->any_dim1) /* zsobol, padded-sobol by table */
        pk_run(pt, in, row_start, w, rows, fmt, dst, 0, 1, 0);
    else if (pt->any_plain) /* sobol at frame 0 */
        pk_run(pt, in, row_start, w, rows, fmt, dst, 0, 0, 1);
    else
        pk_run(pt, in, row_start, w, rows, fmt, dst, 0, 0, 0);
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
