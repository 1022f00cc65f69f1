/*
 * pixel_impl.h - the sampler table behind qmc/pixel.h (private to core/).
 *
 * A sampler is a const table of functions plus the tables an instance
 * builds once in qmc_pixels_new (seq_impl.h's pattern).  pixel.c checks
 * every argument, so a sampler only ever sees pixels inside the image,
 * samples below its end and dimensions below dims.  Fills must equal at()
 * bit for bit and must not allocate: they work in bounded stack blocks.
 */
#ifndef QMC_PIXEL_IMPL_H
#define QMC_PIXEL_IMPL_H

#include <stddef.h>
#include <stdint.h>

#include "bits.h"
#include "msg.h"
#include "qmc/pixel.h"
#include "render_hash.h"

typedef struct qmc__pixel_ops {
    /* Sampler-specific checks of a spec whose common fields (resolution,
     * spp >= 1, dims >= 1) are valid.  Returns 0 or QMC_E* with a reason. */
    int (*check)(const qmc_pixel_spec *spec, qmc__msg *why);
    /* Bytes of tables an instance needs: bounded whatever spp is. */
    size_t (*table_bytes)(const qmc_pixel_spec *spec);
    /* Fills p->tables and p->sample_end; cannot fail. */
    void (*init)(qmc_pixels *p);
    /* Value dim of sample `sample` of pixel (x, y), all in range. */
    uint32_t (*at)(const qmc_pixels *p, uint32_t x, uint32_t y, uint64_t sample,
                   uint32_t dim);
    /* A checked, non-empty tile in a valid format, pixel-major. */
    void (*fill)(const qmc_pixels *p, const qmc_pixel_tile *tile, qmc_format fmt,
                 void *out);
} qmc__pixel_ops;

struct qmc_pixels {
    qmc_pixel_spec spec;
    const qmc__pixel_ops *ops;
    uint64_t sample_end; /* one past the largest sample index */
    uint64_t frame_mix;  /* qmc__frame_mix(spec.frame) */
    uint32_t log2_res;   /* log2 of RoundUpPow2(max(width, height)) */
    void *tables;        /* sampler-owned, allocated with the instance */
};

extern const qmc__pixel_ops qmc__pixel_zsobol;
extern const qmc__pixel_ops qmc__pixel_padded;
extern const qmc__pixel_ops qmc__pixel_sobol;

/*
 * The frame mix F(frame) = MixBits(frame * 0x9e3779b97f4a7c15): a
 * bijection of the frame (an odd multiplier, then pbrt's invertible
 * finaliser), so distinct frames never share a mix, and F = 0 only for
 * frame 0.  docs/SEQUENCES.md says where each sampler uses it.
 */
static inline uint64_t qmc__frame_mix(uint32_t frame)
{
    return qmc__mix_bits((uint64_t)frame * 0x9e3779b97f4a7c15ull);
}

/*
 * A pbrt hash h as frame F sees it: h itself for frame 0 (pbrt-v4's
 * values), MixBits(h ^ F) for any other.  Not h ^ F alone: FastOwen's seed
 * enters by addition and multiplication, so its top output bits depend on
 * the seed's low bits nearly linearly, and XORing one constant into every
 * pixel's seed would flip the same top bits everywhere - correlated frames
 * (test_pixel_props.c measures it).
 */
static inline uint64_t qmc__frame_hash(uint64_t h, uint64_t f)
{
    return f ? qmc__mix_bits(h ^ f) : h;
}

/* pbrt-v4's EncodeMorton2(x, y): x's bits at even positions, y's at odd. */
static inline uint64_t qmc__morton2(uint32_t x, uint32_t y)
{
    uint64_t v[2] = {x, y};
    for (int k = 0; k < 2; k++) {
        uint64_t t = v[k];
        t = (t ^ (t << 16)) & 0x0000ffff0000ffffull;
        t = (t ^ (t << 8)) & 0x00ff00ff00ff00ffull;
        t = (t ^ (t << 4)) & 0x0f0f0f0f0f0f0f0full;
        t = (t ^ (t << 2)) & 0x3333333333333333ull;
        t = (t ^ (t << 1)) & 0x5555555555555555ull;
        v[k] = t;
    }
    return v[0] | (v[1] << 1);
}

/* ceil(log2(n)) for n >= 1: the exponent of pbrt's RoundUpPow2(n). */
static inline uint32_t qmc__ceil_log2(uint64_t n)
{
    return n <= 1 ? 0 : 64u - (uint32_t)__builtin_clzll(n - 1);
}

/* ---- finishing: reversed-domain columns to the caller's format --------- */

/*
 * A block of values still in the bit-reversed domain, column-major:
 * col[c * rows + r] is value (d0 + c) of the block's sample r.  Column c
 * is finished as reverse32(fast_owen_reversed(col, seed[c])), except the
 * first `plain` columns, which are only reversed (sobol's in-pixel
 * position is not scrambled).
 */
typedef struct qmc__pixel_block {
    uint32_t *col;
    const uint32_t *seed;
    uint32_t cols, rows, plain;
} qmc__pixel_block;

/* Words of stack a sampler's block may use: 16 KiB. */
#define QMC__PIXEL_BLOCK_WORDS 4096u

/*
 * Finishes the block in place and writes it row-major: value c of row r
 * goes to element r * stride + c of out (in the format's element size),
 * stride being the spec's dims.
 */
void qmc__pixel_block_store(const qmc__pixel_block *b, qmc_format fmt, void *out,
                            size_t stride);

/* One finished value in a format, at element k of out. */
static inline void qmc__pixel_store(void *out, size_t k, uint32_t v, qmc_format fmt)
{
    switch (fmt) {
    case QMC_FORMAT_F64:
        ((double *)out)[k] = (double)v * 0x1p-32;
        break;
    case QMC_FORMAT_F32:
        ((float *)out)[k] = (float)(v >> 8) * 0x1p-24f;
        break;
    case QMC_FORMAT_U32:
        ((uint32_t *)out)[k] = v;
        break;
    }
}

/* Element offset of (tile pixel index, sample offset, value d) in a fill. */
static inline size_t qmc__pixel_offset(const qmc_pixel_tile *t, uint64_t pixel,
                                       uint64_t sample_off, uint32_t dims)
{
    return (size_t)((pixel * t->sample_count + sample_off) * dims);
}

/* The generic fill: at() for every value (the reference, and small tiles). */
void qmc__pixel_fill_from_at(const qmc_pixels *p, const qmc_pixel_tile *tile,
                             qmc_format fmt, void *out);

#endif
