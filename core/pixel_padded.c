/*
 * pixel_padded.c - pbrt-v4's PaddedSobolSampler with FastOwen
 * randomization.
 *
 * Every (pixel, dimension pair) hashes to its own shuffle of the sample
 * index (PermutationElement) and its own Owen scramble of the 2D Sobol'
 * net: the pairs are "padded" together independently, any spp works and
 * dims are unlimited; the image's error is white noise.  docs/SEQUENCES.md
 * has every step.
 *
 * Must not: answer a sample at or past spp (pixel.c refuses it), or
 * allocate in a fill.
 */
#include "pixel_impl.h"
#include "sobol_wide.h"

/* pbrt's PermutationElement is 32-bit: spp up to 2^32. */
#define PADDED_MAX_SPP (1ull << 32)

static int padded_check(const qmc_pixel_spec *spec, qmc__msg *why)
{
    if (spec->spp > PADDED_MAX_SPP) {
        qmc__msg_set(why, "spp ", spec->spp,
                     " is past padded-sobol's 4294967296 (its sample shuffle is 32-bit): "
                     "use spp <= 4294967296, or zsobol or sobol");
        return QMC_ECOUNT;
    }
    return 0;
}

static size_t padded_table_bytes(const qmc_pixel_spec *spec)
{
    (void)spec;
    return 0;
}

static void padded_init(qmc_pixels *p)
{
    p->sample_end = p->spec.spp;
}

/* pbrt's Hash(pixel, dimension, seed) (16 bytes), mixed with the frame. */
static inline uint64_t padded_hash(const qmc_pixels *p, uint32_t x, uint32_t y, uint32_t dim)
{
    return qmc__frame_hash(qmc__hash_i32x4(x, y, dim, p->spec.seed), p->frame_mix);
}

static uint32_t padded_at(const qmc_pixels *p, uint32_t x, uint32_t y, uint64_t sample,
                          uint32_t d)
{
    const uint64_t h = padded_hash(p, x, y, d & ~1u);
    /* The low 32 bits pick both the index shuffle and the first value's
     * scramble, as in pbrt. */
    const uint32_t index = qmc__permutation_element32((uint32_t)sample, p->spec.spp,
                                                      (uint32_t)h);
    if (d & 1u)
        return qmc__reverse32(qmc__fast_owen_reversed(qmc__sobol_dim1_reversed32(index),
                                                      (uint32_t)(h >> 32)));
    return qmc__reverse32(qmc__fast_owen_reversed(index, (uint32_t)h));
}

static void padded_fill(const qmc_pixels *p, const qmc_pixel_tile *t, qmc_format fmt, void *out)
{
    qmc__pixel_fill_from_at(p, t, fmt, out);
}

const qmc__pixel_ops qmc__pixel_padded = {
    .check = padded_check,
    .table_bytes = padded_table_bytes,
    .init = padded_init,
    .at = padded_at,
    .fill = padded_fill,
};
