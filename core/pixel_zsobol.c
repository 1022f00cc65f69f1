/*
 * pixel_zsobol.c - pbrt-v4's ZSobolSampler with FastOwen randomization
 * (Ahmed and Wonka 2020, "Screen-Space Blue-Noise Diffusion of Monte Carlo
 * Sampling Error via Hierarchical Ordering of Pixels").
 *
 * Sample i of pixel (x, y) is point P(m) of one 2D Sobol' sequence per
 * dimension pair, m = (EncodeMorton2(x, y) << log2 spp) | i, where P
 * permutes each base-4 digit of m by a hash of the digits above it and the
 * dimension: neighbouring pixels get complementary parts of the sequence
 * and the image's error is blue noise.  docs/SEQUENCES.md has every step.
 *
 * Must not: answer a sample at or past spp (pbrt-v4 ORs it into the
 * pixel's Morton bits and returns another pixel's sample, PR #298; pixel.c
 * refuses it first), or allocate in a fill.
 */
#include <string.h>

#include "pixel_impl.h"
#include "sobol_wide.h"

/* pbrt-v4's table of the 24 permutations of {0, 1, 2, 3}, in its order
 * (ZSobolSampler::GetSampleIndex): the hash picks a row. */
static const uint8_t perm4[24][4] = {
    {0, 1, 2, 3}, {0, 1, 3, 2}, {0, 2, 1, 3}, {0, 2, 3, 1}, {0, 3, 2, 1}, {0, 3, 1, 2},
    {1, 0, 2, 3}, {1, 0, 3, 2}, {1, 2, 0, 3}, {1, 2, 3, 0}, {1, 3, 2, 0}, {1, 3, 0, 2},
    {2, 1, 0, 3}, {2, 1, 3, 0}, {2, 0, 1, 3}, {2, 0, 3, 1}, {2, 3, 0, 1}, {2, 3, 1, 0},
    {3, 1, 2, 0}, {3, 1, 0, 2}, {3, 2, 1, 0}, {3, 2, 0, 1}, {3, 0, 2, 1}, {3, 0, 1, 2}};

/* The same rows as 32-bit lanes, for four children at once. */
typedef uint32_t zs_u4 __attribute__((vector_size(16)));
static const zs_u4 perm4w[24] = {
    {0, 1, 2, 3}, {0, 1, 3, 2}, {0, 2, 1, 3}, {0, 2, 3, 1}, {0, 3, 2, 1}, {0, 3, 1, 2},
    {1, 0, 2, 3}, {1, 0, 3, 2}, {1, 2, 0, 3}, {1, 2, 3, 0}, {1, 3, 2, 0}, {1, 3, 0, 2},
    {2, 1, 0, 3}, {2, 1, 3, 0}, {2, 0, 1, 3}, {2, 0, 3, 1}, {2, 3, 0, 1}, {2, 3, 1, 0},
    {3, 1, 2, 0}, {3, 1, 0, 2}, {3, 2, 1, 0}, {3, 2, 0, 1}, {3, 0, 2, 1}, {3, 0, 1, 2}};

typedef struct zsobol_tables {
    uint32_t log2_spp; /* L: the sample's bits at the bottom of the index */
    uint32_t digits;   /* pbrt's nBase4Digits: log2 res + ceil(L / 2) */
} zsobol_tables;

static int zsobol_check(const qmc_pixel_spec *spec, qmc__msg *why)
{
    const uint64_t spp = spec->spp;
    if (spp & (spp - 1)) {
        /* The pattern is built on base-4 digits of the index: a partial
         * power of two would leave holes (pbrt warns; we refuse). */
        uint32_t lo = 63u - (uint32_t)__builtin_clzll(spp);
        qmc__msg_set(why, "spp ", spp, " is not a power of two, which zsobol needs: use ");
        qmc__msg_u64(why, 1ull << lo);
        if (lo < 63) {
            qmc__msg_str(why, " or ");
            qmc__msg_u64(why, 1ull << (lo + 1));
        }
        return QMC_ECOUNT;
    }
    const uint32_t w = spec->width > spec->height ? spec->width : spec->height;
    const uint32_t res_bits = qmc__ceil_log2(w);
    const uint32_t spp_bits = 63u - (uint32_t)__builtin_clzll(spp);
    if (2 * res_bits + spp_bits > 64) {
        qmc__msg_set(why, "zsobol's Morton index needs ", 2 * res_bits + spp_bits,
                     " bits at resolution ");
        qmc__msg_u64(why, spec->width);
        qmc__msg_str(why, "x");
        qmc__msg_u64(why, spec->height);
        qmc__msg_str(why, " and spp ");
        qmc__msg_u64(why, spp);
        qmc__msg_str(why, ", past 64: use spp <= ");
        qmc__msg_u64(why, 1ull << (64 - 2 * res_bits));
        qmc__msg_str(why, " or an image at most ");
        uint64_t side = 1ull << ((64 - spp_bits) / 2);
        qmc__msg_u64(why, side);
        qmc__msg_str(why, " pixels on a side");
        return QMC_ERANGE;
    }
    return 0;
}

static size_t zsobol_table_bytes(const qmc_pixel_spec *spec)
{
    (void)spec;
    return sizeof(zsobol_tables);
}

static void zsobol_init(qmc_pixels *p)
{
    zsobol_tables *z = p->tables;
    z->log2_spp = 63u - (uint32_t)__builtin_clzll(p->spec.spp);
    z->digits = p->log2_res + (z->log2_spp + 1) / 2;
    p->sample_end = p->spec.spp;
}

/* m >> s for s in 0..64 (pbrt never shifts by 64; we define it as 0). */
static inline uint64_t shr64(uint64_t m, uint32_t s)
{
    return s >= 64 ? 0 : m >> s;
}

/*
 * The permuted base-4 digits i in [lo, hi) of a Morton index (pbrt-v4's
 * GetSampleIndex loop): digit i sits at bit 2i - odd and is permuted by a
 * hash of the bits above it and the dimension's salt.
 */
static inline uint64_t permute_digits(const zsobol_tables *z, uint64_t morton, uint64_t salt,
                                      uint32_t lo, uint32_t hi)
{
    const uint32_t odd = z->log2_spp & 1u;
    uint64_t index = 0;
    for (uint32_t i = hi; i-- > lo;) {
        const uint32_t shift = 2 * i - odd;
        const uint32_t digit = (uint32_t)(morton >> shift) & 3u;
        const uint64_t higher = shr64(morton, shift + 2);
        const uint32_t p = (uint32_t)((qmc__mix_bits(higher ^ salt) >> 24) % 24);
        index |= (uint64_t)perm4[p][digit] << shift;
    }
    return index;
}

/* pbrt's 0x55555555u * dimension (32-bit), with the frame mix F XORed in
 * (F = 0 for frame 0). */
static inline uint64_t salt_of(uint32_t dim, uint64_t f)
{
    return (uint64_t)(0x55555555u * dim) ^ f;
}

/* pbrt-v4's GetSampleIndex for the pair's first dimension. */
static uint64_t zsobol_index(const zsobol_tables *z, uint64_t morton, uint64_t salt)
{
    const uint32_t odd = z->log2_spp & 1u;
    uint64_t index = permute_digits(z, morton, salt, odd, z->digits);
    if (odd)
        index |= (morton & 1u) ^ (qmc__mix_bits((morton >> 1) ^ salt) & 1u);
    return index;
}

static uint32_t zsobol_at(const qmc_pixels *p, uint32_t x, uint32_t y, uint64_t sample,
                          uint32_t d)
{
    const zsobol_tables *z = p->tables;
    const uint32_t dim = d & ~1u;
    const uint64_t morton = (qmc__morton2(x, y) << z->log2_spp) | sample;
    const uint64_t index = zsobol_index(z, morton, salt_of(dim, p->frame_mix));
    /* pbrt's Get2D hashes the dimension after its `dimension += 2`. */
    const uint64_t bits = qmc__frame_hash(qmc__hash_i32x2(dim + 2, p->spec.seed), p->frame_mix);
    /* Sobol' dimension 0 is the bit reversal of the index's low 32 bits;
     * dimension 1 is the Pascal matrix (sobol_wide.h). */
    if (d & 1u)
        return qmc__reverse32(qmc__fast_owen_reversed(qmc__sobol_dim1_reversed(index),
                                                      (uint32_t)(bits >> 32)));
    return qmc__reverse32(qmc__fast_owen_reversed((uint32_t)index, (uint32_t)bits));
}

/*
 * The fast fill's sample part: the permuted low L bits of the index for
 * samples a .. a + n - 1 of one pixel and pair (L <= 32, n <= the staging
 * rows), written to dst[r * stride].
 * The sample's digits form a tree: a digit's permutation depends only on
 * the digits above it, so each tree level is hashed once per node, the
 * nodes of a level at once (qmc__pixel_nodes) - 1 + 4 + 16 + ... hashes
 * for a whole pixel instead of one per digit per sample.  Level j = 0 is
 * the bottom: for odd L, pbrt's lone bit 0, hashed from the bits above it.
 * v[j][m] holds the permuted bits above level j of level j's node m.
 */
static void sample_part(const qmc_pixels *p, uint64_t mpix, uint64_t salt, uint64_t a,
                        uint32_t n, uint32_t *dst, uint32_t stride)
{
    const zsobol_tables *z = p->tables;
    const uint32_t L = z->log2_spp, odd = L & 1u, nl = (L + odd) / 2;
    if (nl == 0) {
        for (uint32_t r = 0; r < n; r++, dst += stride)
            dst[0] = 0;
        return;
    }
    /* Node m of level j spans samples [m 2^top, (m + 1) 2^top); its hash
     * key is the Morton index above them: (mpix >> top) + m. */
    /* Level j has at most n / 2^top[j] + 2 nodes, each level rounded up
     * to 8: with top = 1, 3, 5, ... (odd L) under 2n / 3 + 9 per level. */
    enum { NODES = QMC__PIXEL_STAGE_WORDS * 2 / 3 + 9 * 17 + 16 };
    uint8_t perm[NODES + 16];
    uint32_t val[NODES];
    uint32_t first[17], base[17], sh[17], top[17];
    uint32_t used = 0;
    for (uint32_t j = 0; j < nl; j++) {
        sh[j] = odd ? (j ? 2 * j - 1 : 0) : 2 * j;
        top[j] = odd && j == 0 ? 1 : sh[j] + 2;
    }
    for (uint32_t j = nl; j-- > 0;) {
        const uint64_t m0 = a >> top[j], m1 = (a + n - 1) >> top[j];
        const uint32_t cnt = (uint32_t)(m1 - m0 + 1);
        first[j] = (uint32_t)m0;
        base[j] = used;
        qmc__pixel_nodes(p->isa, (mpix >> top[j]) + m0, salt, cnt, (int)(odd && j == 0),
                         perm + used);
        uint32_t *v = val + used;
        if (j + 1 == nl) {
            for (uint32_t m = 0; m < cnt; m++)
                v[m] = 0;
        } else {
            /* A node's parent is m >> 2 one level up, its digit there m & 3:
             * the four children of a parent at once, from its row. */
            const uint32_t pb = base[j + 1], pf = first[j + 1], s1 = sh[j + 1];
            uint32_t m = 0;
            for (; m < cnt && ((first[j] + m) & 3u); m++) {
                const uint32_t mm = first[j] + m, q = (mm >> 2) - pf;
                v[m] = val[pb + q] | (uint32_t)perm4[perm[pb + q]][mm & 3u] << s1;
            }
            for (; cnt - m >= 4; m += 4) {
                const uint32_t q = ((first[j] + m) >> 2) - pf;
                const zs_u4 kids = ((zs_u4){0} + val[pb + q]) | (perm4w[perm[pb + q]] << s1);
                memcpy(v + m, &kids, sizeof kids);
            }
            for (; m < cnt; m++) {
                const uint32_t mm = first[j] + m, q = (mm >> 2) - pf;
                v[m] = val[pb + q] | (uint32_t)perm4[perm[pb + q]][mm & 3u] << s1;
            }
        }
        used += (cnt + 7) & ~7u;
    }
    const uint8_t *p0 = perm + base[0];
    const uint32_t *v0 = val + base[0];
    const uint64_t end = a + n;
    uint64_t i = a;
    if (odd) {
        for (; i < end; i++, dst += stride) {
            const uint32_t m = (uint32_t)(i >> 1) - first[0];
            dst[0] = v0[m] | ((uint32_t)(i & 1u) ^ p0[m]);
        }
        return;
    }
    for (; i < end && (i & 3u); i++, dst += stride) {
        const uint32_t m = (uint32_t)(i >> 2) - first[0];
        dst[0] = v0[m] | perm4[p0[m]][i & 3u];
    }
    if (stride == 1) /* one pair a row: a node's four samples are adjacent */
        for (; end - i >= 4; i += 4, dst += 4) {
            const uint32_t m = (uint32_t)(i >> 2) - first[0];
            const zs_u4 four = ((zs_u4){0} + v0[m]) | perm4w[p0[m]];
            memcpy(dst, &four, sizeof four);
        }
    for (; end - i >= 4; i += 4, dst += 4 * stride) {
        const uint32_t m = (uint32_t)(i >> 2) - first[0], up = v0[m];
        const uint8_t *row = perm4[p0[m]];
        dst[0] = up | row[0];
        dst[stride] = up | row[1];
        dst[2 * stride] = up | row[2];
        dst[3 * stride] = up | row[3];
    }
    for (; i < end; i++, dst += stride) {
        const uint32_t m = (uint32_t)(i >> 2) - first[0];
        dst[0] = v0[m] | perm4[p0[m]][i & 3u];
    }
}

/*
 * Fills pixel by pixel.  Per pixel and pair, the pixel's own digits are
 * permuted once (shared by all its samples), the samples' digits come
 * from the tree above, and by linearity the index's Sobol' values are the
 * pixel part's XOR the sample part's: dimension 0 in the reversed domain
 * is the index's low 32 bits, dimension 1 the superset transform
 * (sobol_wide.h), both cheap per lane in the kernel.
 */
static void zsobol_fill(const qmc_pixels *p, const qmc_pixel_tile *t, qmc_format fmt, void *out)
{
    const zsobol_tables *z = p->tables;
    const uint32_t L = z->log2_spp, dims = p->spec.dims, odd = L & 1u;
    if (L > 32) { /* sample parts past 32 bits: rare (spp > 2^32), by value */
        qmc__pixel_fill_from_at(p, t, fmt, out);
        return;
    }
    const size_t esize = qmc_format_bytes(fmt);
    uint32_t in[QMC__PIXEL_STAGE_WORDS + QMC__PIXEL_PAD];
    double scratch[QMC__PIXEL_STAGE_WORDS];
    qmc__pixel_pattern pt;
    uint8_t mode[QMC__PIXEL_MAX_COLS];
    uint32_t seed[QMC__PIXEL_MAX_COLS], xorc[QMC__PIXEL_MAX_COLS];
    uint64_t salt[QMC__PIXEL_MAX_COLS / 2];
    memset(in, 0, sizeof in); /* the pad lanes the kernel reads past a block */
    for (uint32_t d0 = 0, nc; d0 < dims; d0 += nc) {
        nc = qmc__pixel_pass_cols(dims, d0);
        const uint32_t np = (nc + 1) / 2;
        const uint32_t rows = qmc__pixel_block_rows(t, nc, dims, 1);
        for (uint32_t k = 0; k < np; k++) {
            const uint32_t dim = d0 + 2 * k;
            salt[k] = salt_of(dim, p->frame_mix);
            const uint64_t bits =
                qmc__frame_hash(qmc__hash_i32x2(dim + 2, p->spec.seed), p->frame_mix);
            seed[2 * k] = (uint32_t)bits;
            seed[2 * k + 1] = (uint32_t)(bits >> 32);
            mode[2 * k] = QMC__PIXEL_OWEN;
            mode[2 * k + 1] = QMC__PIXEL_OWEN_DIM1;
        }
        qmc__pixel_pattern_init(&pt, nc, mode, 1);
        qmc__pixel_pattern_set(&pt, NULL, seed, NULL);
        uint64_t pixel = 0;
        for (uint32_t y = t->y; y < t->y + t->height; y++)
            for (uint32_t x = t->x; x < t->x + t->width; x++, pixel++) {
                const uint64_t mpix = qmc__morton2(x, y) << L;
                for (uint32_t k = 0; k < np; k++) {
                    const uint64_t hi =
                        permute_digits(z, mpix, salt[k], (L + odd) / 2, z->digits);
                    xorc[2 * k] = (uint32_t)hi;
                    xorc[2 * k + 1] = qmc__sobol_dim1_reversed(hi);
                }
                qmc__pixel_pattern_set(&pt, xorc, NULL, NULL);
                for (uint64_t a = 0; a < t->sample_count; a += rows) {
                    const uint32_t n = qmc__pixel_block_n(t, a, rows);
                    for (uint32_t k = 0; k < np; k++)
                        sample_part(p, mpix, salt[k], t->sample_start + a, n, in + k, np);
                    void *o = qmc__pixel_out(out, t, pixel, a, dims, d0, esize);
                    qmc__pixel_emit(p->isa, &pt, in, 0, 0, n, fmt, o, dims, scratch);
                }
            }
    }
}

const qmc__pixel_ops qmc__pixel_zsobol = {
    .check = zsobol_check,
    .table_bytes = zsobol_table_bytes,
    .init = zsobol_init,
    .at = zsobol_at,
    .fill = zsobol_fill,
};
