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
#include <string.h>

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

/*
 * Fills pixel by pixel: per pixel and pair one hash gives the index
 * shuffle and both scrambles; for a power-of-two spp the kernel computes
 * the shuffled indices itself (no cycle walking is ever needed), other
 * spp are staged here by qmc__permutation_element32.  Dimension 0 of the
 * shuffled index in the reversed domain is the index itself, dimension 1
 * its superset transform (sobol_wide.h).
 */
static void padded_fill(const qmc_pixels *p, const qmc_pixel_tile *t, qmc_format fmt, void *out)
{
    const uint64_t spp = p->spec.spp;
    const uint32_t dims = p->spec.dims;
    const int pow2 = (spp & (spp - 1)) == 0;
    const size_t esize = qmc_format_bytes(fmt);
    uint32_t in[QMC__PIXEL_STAGE_WORDS + QMC__PIXEL_PAD];
    double scratch[QMC__PIXEL_STAGE_WORDS];
    qmc__pixel_pattern pt;
    uint8_t mode[QMC__PIXEL_MAX_COLS];
    uint32_t seed[QMC__PIXEL_MAX_COLS], perm[QMC__PIXEL_MAX_COLS];
    uint32_t zero[QMC__PIXEL_MAX_COLS] = {0};
    memset(in, 0, sizeof in); /* the pad lanes the kernel reads past a block */
    for (uint32_t d0 = 0, nc; d0 < dims; d0 += nc) {
        nc = qmc__pixel_pass_cols(dims, d0);
        const uint32_t np = (nc + 1) / 2;
        const uint32_t rows = qmc__pixel_block_rows(t, nc, dims, 1);
        for (uint32_t c = 0; c < nc; c++)
            mode[c] = c & 1u ? QMC__PIXEL_OWEN_DIM1 : QMC__PIXEL_OWEN;
        qmc__pixel_pattern_init(&pt, nc, mode, 1);
        qmc__pixel_pattern_set(&pt, zero, NULL, NULL);
        uint64_t pixel = 0;
        for (uint32_t y = t->y; y < t->y + t->height; y++)
            for (uint32_t x = t->x; x < t->x + t->width; x++, pixel++) {
                for (uint32_t k = 0; k < np; k++) {
                    const uint64_t h = padded_hash(p, x, y, d0 + 2 * k);
                    perm[2 * k] = perm[2 * k + 1] = (uint32_t)h;
                    seed[2 * k] = (uint32_t)h;
                    seed[2 * k + 1] = (uint32_t)(h >> 32);
                }
                qmc__pixel_pattern_set(&pt, NULL, seed, perm);
                for (uint64_t a = 0; a < t->sample_count; a += rows) {
                    const uint32_t n = qmc__pixel_block_n(t, a, rows);
                    const uint64_t s0 = t->sample_start + a;
                    void *o = qmc__pixel_out(out, t, pixel, a, dims, d0, esize);
                    if (pow2) {
                        qmc__pixel_emit(p->isa, &pt, NULL, s0, (uint32_t)(spp - 1), n, fmt, o,
                                        dims, scratch);
                        continue;
                    }
                    for (uint32_t k = 0; k < np; k++)
                        for (uint32_t r = 0; r < n; r++) {
                            const uint32_t v = qmc__permutation_element32((uint32_t)(s0 + r), spp,
                                                                          perm[2 * k]);
                            in[r * np + k] = v;
                        }
                    qmc__pixel_emit(p->isa, &pt, in, 0, 0, n, fmt, o, dims, scratch);
                }
            }
    }
}

const qmc__pixel_ops qmc__pixel_padded = {
    .check = padded_check,
    .table_bytes = padded_table_bytes,
    .init = padded_init,
    .at = padded_at,
    .fill = padded_fill,
};
