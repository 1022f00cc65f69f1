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
    int isa;             /* the kernels fills use: qmc__pixel_isa() */
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

/* ---- finishing: staged values to the caller's format ------------------ */

/*
 * Fast fills stage a pass of nc values (columns) for each of rows samples
 * in the bit-reversed domain, row-major, and a vector kernel finishes them
 * into the caller's rows.  Value x of column c becomes
 *   reverse32(fast_owen_reversed(T(x) ^ xorc[c], seed[c]))
 * where T is the dimension-1 transform of sobol_wide.h for
 * QMC__PIXEL_OWEN_DIM1 columns and the identity otherwise, and the Owen
 * step is skipped for QMC__PIXEL_PLAIN columns.  In index mode x is
 * PermutationElement(row, w + 1, perm[c]) of the row's sample (padded-sobol
 * with a power-of-two spp), computed in the kernel.
 *
 * The kernel works on whole vectors of the flat row-major block, so each
 * column's parameters are laid out once per pass as lane patterns of
 * period lcm(nc, 16) lanes; a pass has nc <= 16, or nc a multiple of 16 up
 * to 64 (qmc__pixel_pass_cols), so a period is at most 240 lanes.
 */
enum { QMC__PIXEL_PLAIN = 0, QMC__PIXEL_OWEN = 1, QMC__PIXEL_OWEN_DIM1 = 2 };

#define QMC__PIXEL_MAX_PERIOD 240u
#define QMC__PIXEL_MAX_COLS 64u
/* Staged words per block (8 KiB), and the lanes every block is padded to. */
#define QMC__PIXEL_STAGE_WORDS 2048u
#define QMC__PIXEL_PAD 16u

typedef struct qmc__pixel_pattern {
    uint32_t nc, period, rows_per_period, any_plain, any_dim1;
    uint32_t paired, in_per_period;         /* staged words per period */
    uint32_t rowoff[QMC__PIXEL_MAX_PERIOD]; /* lane's row within its period */
    uint32_t src[QMC__PIXEL_MAX_PERIOD];    /* lane's staged word in its period */
    uint32_t dim1[QMC__PIXEL_MAX_PERIOD];   /* all ones on DIM1 lanes */
    uint32_t owen[QMC__PIXEL_MAX_PERIOD];   /* all ones on scrambled lanes */
    uint32_t xorc[QMC__PIXEL_MAX_PERIOD];
    uint32_t seed[QMC__PIXEL_MAX_PERIOD];
    uint32_t smul[QMC__PIXEL_MAX_PERIOD];   /* (seed >> 16) | 1 */
    uint32_t perm[QMC__PIXEL_MAX_PERIOD];
} qmc__pixel_pattern;

/* Columns of the pass that starts at value d0 of dims. */
uint32_t qmc__pixel_pass_cols(uint32_t dims, uint32_t d0);

/* Lays out a pass of nc columns with their modes.  Staged rows hold nc
 * words, or with paired one word per pair of columns (2k, 2k + 1), both
 * columns reading it: (nc + 1) / 2 words per row. */
void qmc__pixel_pattern_init(qmc__pixel_pattern *pt, uint32_t nc, const uint8_t *mode,
                             int paired);

/* Lays out the columns' parameters (any pointer may be NULL: unchanged). */
void qmc__pixel_pattern_set(qmc__pixel_pattern *pt, const uint32_t *xorc,
                            const uint32_t *seed, const uint32_t *perm);

/* The widest kernel build this CPU runs: 2 AVX-512, 1 AVX2, 0 baseline.
 * Every build gives the same bits; tests run each on one instance by
 * setting its isa field. */
int qmc__pixel_isa(void);

/*
 * Finishes rows x nc staged values and writes value c of row r at element
 * r * stride + c of out, in the format.  in holds the block row-major,
 * readable QMC__PIXEL_PAD words past its end; in == NULL is index
 * mode, rows being samples row_start .. and w + 1 the power-of-two spp.
 * When nc < stride, scratch (rows * nc doubles) stages the rows.  isa
 * picks the kernel build (at most qmc__pixel_isa()).
 */
void qmc__pixel_emit(int isa, const qmc__pixel_pattern *pt, const uint32_t *in, uint64_t row_start,
                     uint32_t w, uint32_t rows, qmc_format fmt, void *out, size_t stride,
                     void *scratch);

/*
 * zsobol's digit-permutation hashes for n consecutive tree nodes:
 * out[j] = (MixBits((key0 + j) ^ salt) >> 24) % 24, or MixBits(...) & 1
 * when bit, written up to n rounded up to 8.
 */
void qmc__pixel_nodes(int isa, uint64_t key0, uint64_t salt, uint32_t n, int bit, uint8_t *out);

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

/* ---- the fast fills' blocks (pixel_zsobol.c, pixel_padded.c, pixel_sobol.c) */

/*
 * Sample rows per block for a pass of nc of the dims columns, at most the
 * tile's samples: the staging holds a row's nc words, or (nc + 1) / 2
 * when paired columns share a word, and the scratch (nc values a row)
 * serves only passes narrower than a row.
 */
static inline uint32_t qmc__pixel_block_rows(const qmc_pixel_tile *t, uint32_t nc, uint32_t dims,
                                             int paired)
{
    const uint32_t staged = paired ? (nc + 1) / 2 : nc;
    const uint32_t rows = QMC__PIXEL_STAGE_WORDS / (nc == dims ? staged : nc);
    return rows > t->sample_count ? (uint32_t)t->sample_count : rows;
}

/* The rows of the block at sample offset a: rows, or what is left. */
static inline uint32_t qmc__pixel_block_n(const qmc_pixel_tile *t, uint64_t a, uint32_t rows)
{
    return t->sample_count - a < rows ? (uint32_t)(t->sample_count - a) : rows;
}

/* Where value d0 of sample offset a of tile pixel `pixel` (row-major
 * index in the tile) goes in a fill's out, of elements esize bytes. */
static inline void *qmc__pixel_out(void *out, const qmc_pixel_tile *t, uint64_t pixel,
                                   uint64_t a, uint32_t dims, uint32_t d0, size_t esize)
{
    return (char *)out + ((size_t)((pixel * t->sample_count + a) * dims) + d0) * esize;
}

/* The generic fill: at() for every value (the reference, and small tiles). */
void qmc__pixel_fill_from_at(const qmc_pixels *p, const qmc_pixel_tile *tile,
                             qmc_format fmt, void *out);

#endif
