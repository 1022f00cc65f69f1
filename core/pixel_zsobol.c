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
#include "pixel_impl.h"
#include "sobol_wide.h"

/* pbrt-v4's table of the 24 permutations of {0, 1, 2, 3}, in its order
 * (ZSobolSampler::GetSampleIndex): the hash picks a row. */
static const uint8_t perm4[24][4] = {
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
 * pbrt-v4's GetSampleIndex for the pair's first dimension `dim`, with the
 * frame mix F XORed into the hash's argument (F = 0 for frame 0).
 */
static uint64_t zsobol_index(const zsobol_tables *z, uint64_t morton, uint32_t dim, uint64_t f)
{
    const uint32_t odd = z->log2_spp & 1u;
    const uint64_t salt = (uint64_t)(0x55555555u * dim) ^ f;
    uint64_t index = 0;
    for (uint32_t i = z->digits; i-- > odd;) {
        const uint32_t shift = 2 * i - odd;
        const uint32_t digit = (uint32_t)(morton >> shift) & 3u;
        const uint64_t higher = shr64(morton, shift + 2);
        const uint32_t p = (uint32_t)((qmc__mix_bits(higher ^ salt) >> 24) % 24);
        index |= (uint64_t)perm4[p][digit] << shift;
    }
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
    const uint64_t index = zsobol_index(z, morton, dim, p->frame_mix);
    /* pbrt's Get2D hashes the dimension after its `dimension += 2`. */
    const uint64_t bits = qmc__frame_hash(qmc__hash_i32x2(dim + 2, p->spec.seed), p->frame_mix);
    /* Sobol' dimension 0 is the bit reversal of the index's low 32 bits;
     * dimension 1 is the Pascal matrix (sobol_wide.h). */
    if (d & 1u)
        return qmc__reverse32(qmc__fast_owen_reversed(qmc__sobol_dim1_reversed(index),
                                                      (uint32_t)(bits >> 32)));
    return qmc__reverse32(qmc__fast_owen_reversed((uint32_t)index, (uint32_t)bits));
}

static void zsobol_fill(const qmc_pixels *p, const qmc_pixel_tile *t, qmc_format fmt, void *out)
{
    qmc__pixel_fill_from_at(p, t, fmt, out);
}

const qmc__pixel_ops qmc__pixel_zsobol = {
    .check = zsobol_check,
    .table_bytes = zsobol_table_bytes,
    .init = zsobol_init,
    .at = zsobol_at,
    .fill = zsobol_fill,
};
