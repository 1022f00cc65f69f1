/*
 * pixel_sobol.c - one Joe-Kuo Sobol' sequence over the whole image, as
 * pbrt-v4's SobolSampler maps pixels to indices, up to 21201 dimensions.
 *
 * With m = log2 of the image's power-of-two scale, sample f of pixel
 * (x, y) is the point of index i in [f 4^m, (f + 1) 4^m) whose first two
 * coordinates' top m bits are x and y (pbrt's SobolIntervalToIndex: in
 * every aligned block of 4^m points, dimensions 0 and 1 form a (0, 2m,
 * 2)-net, so each pixel gets exactly one).  Values 0 and 1 are the
 * position inside the pixel; value d >= 2 is Sobol' dimension d at i,
 * FastOwen-scrambled as pbrt's SampleDimension does, without pbrt's wrap
 * at 1024 dimensions.  Indices are 64-bit (no 2^32 cap).
 *
 * Must not: allocate in a fill, or move values 0 and 1 out of their pixel
 * (frames scramble them only inside it).
 */
#include <string.h>

#include "pixel_impl.h"
#include "sobol_wide.h"

typedef struct sobol_tables {
    uint32_t m;       /* log2 of the scale */
    uint32_t ncols;   /* dimensions with columns: max(dims, 2) */
    uint64_t lx[32];  /* index bits that set x's bit j alone, j < m */
    uint64_t ly[32];  /* index bits that set y's bit j alone */
    uint32_t *cols;   /* ncols x 64 generator columns (sobol_wide.h) */
    uint32_t *seed;   /* frame 0's Owen seed of value d >= 2 (0 for d < 2) */
} sobol_tables;

static int sobol_check(const qmc_pixel_spec *spec, qmc__msg *why)
{
    if (spec->dims > QMC_PIXEL_SOBOL_MAX_DIMS) {
        qmc__msg_set(why, "dims ", spec->dims,
                     " is past sobol's 21201 (the Joe-Kuo table): use dims <= 21201, "
                     "or zsobol or padded-sobol, whose dimensions are unlimited");
        return QMC_EDIMS;
    }
    const uint32_t w = spec->width > spec->height ? spec->width : spec->height;
    const uint32_t m = qmc__ceil_log2(w);
    /* 2m index bits pick the pixel, the rest the sample. */
    if (m > 0 && spec->spp > (m == 32 ? 1 : 1ull << (64 - 2 * m))) {
        qmc__msg_set(why, "spp ", spec->spp, " is past the sobol sampler's ");
        qmc__msg_u64(why, m == 32 ? 1 : 1ull << (64 - 2 * m));
        qmc__msg_str(why, " samples per pixel at this resolution (its 64-bit index "
                          "spends 2 log2 of the image's side on the pixel): ask for fewer");
        return QMC_ECOUNT;
    }
    return 0;
}

static uint32_t ncols_of(const qmc_pixel_spec *spec)
{
    return spec->dims < 2 ? 2 : spec->dims;
}

static size_t sobol_table_bytes(const qmc_pixel_spec *spec)
{
    const size_t n = ncols_of(spec);
    return sizeof(sobol_tables) + n * QMC__SOBOL_WIDE_COLS * sizeof(uint32_t) +
           spec->dims * sizeof(uint32_t);
}

/* Top m bits of a 32-bit output. */
static inline uint64_t top(uint32_t v, uint32_t m)
{
    return m == 0 ? 0 : v >> (32 - m);
}

/*
 * Solves for the index bits below 2m: the map from those bits to (x, y)
 * (x's m bits low, y's above) is invertible over GF(2), because dimensions
 * 0 and 1 form a (0, 2)-sequence.  Gauss-Jordan on (image, preimage) pairs.
 */
static void solve_pixel_bits(sobol_tables *s)
{
    const uint32_t m = s->m, n = 2 * m;
    const uint32_t *c0 = s->cols, *c1 = s->cols + QMC__SOBOL_WIDE_COLS;
    uint64_t img[64], pre[64];
    for (uint32_t c = 0; c < n; c++) {
        img[c] = top(c0[c], m) | (top(c1[c], m) << m);
        pre[c] = 1ull << c;
    }
    for (uint32_t b = 0; b < n; b++) {
        uint32_t r = b;
        while (!((img[r] >> b) & 1u))
            r++; /* exists: the map is invertible */
        uint64_t ti = img[r], tp = pre[r];
        img[r] = img[b], pre[r] = pre[b];
        img[b] = ti, pre[b] = tp;
        for (uint32_t k = 0; k < n; k++)
            if (k != b && ((img[k] >> b) & 1u)) {
                img[k] ^= img[b];
                pre[k] ^= pre[b];
            }
    }
    for (uint32_t j = 0; j < m; j++) {
        s->lx[j] = pre[j];
        s->ly[j] = pre[m + j];
    }
}

static void sobol_init(qmc_pixels *p)
{
    sobol_tables *s = p->tables;
    const qmc_pixel_spec *spec = &p->spec;
    s->m = p->log2_res;
    s->ncols = ncols_of(spec);
    s->cols = (uint32_t *)(s + 1);
    s->seed = s->cols + (size_t)s->ncols * QMC__SOBOL_WIDE_COLS;
    for (uint32_t d = 0; d < s->ncols; d++)
        qmc__sobol_wide_columns(d, s->cols + (size_t)d * QMC__SOBOL_WIDE_COLS);
    for (uint32_t d = 0; d < spec->dims; d++)
        s->seed[d] = d < 2 ? 0 : (uint32_t)qmc__hash_i32x2(d, spec->seed);
    solve_pixel_bits(s);
    p->sample_end = s->m == 0 ? UINT64_MAX : s->m == 32 ? 1 : 1ull << (64 - 2 * s->m);
}

/* pbrt's SobolIntervalToIndex(m, sample, (x, y)), by the solved map. */
static uint64_t sobol_index(const sobol_tables *s, uint32_t x, uint32_t y, uint64_t sample)
{
    const uint32_t m = s->m;
    if (m == 0)
        return sample;
    const uint64_t high = m == 32 ? 0 : sample << (2 * m);
    /* The sample's bits also reach y's rows of dimension 1: cancel them. */
    uint64_t ty = y ^ top(qmc__sobol_wide_gather(s->cols + QMC__SOBOL_WIDE_COLS, high), m);
    uint64_t index = high;
    for (uint32_t j = 0; j < m; j++) {
        if ((x >> j) & 1u)
            index ^= s->lx[j];
        if ((ty >> j) & 1u)
            index ^= s->ly[j];
    }
    return index;
}

/*
 * The Owen seed of value d at pixel (x, y).  Frame 0 is pbrt's: one
 * scramble per dimension d >= 2 for the whole image, Hash(d, seed), and
 * none for the in-pixel position.  Any other frame scrambles every value
 * per pixel, from pbrt's 16-byte Hash(x, y, d, seed) through the frame:
 * a new global scramble alone would leave every pixel its frame-0 points
 * under one shared map, and the frames' errors correlate (r near -0.2 in
 * test_pixel_props.c); a nested scramble keeps each pixel's nets.
 */
static inline uint32_t sobol_seed(const qmc_pixels *p, uint32_t x, uint32_t y, uint32_t d)
{
    const sobol_tables *s = p->tables;
    if (p->frame_mix == 0)
        return s->seed[d];
    return (uint32_t)qmc__frame_hash(qmc__hash_i32x4(x, y, d, p->spec.seed), p->frame_mix);
}

static uint32_t sobol_at(const qmc_pixels *p, uint32_t x, uint32_t y, uint64_t sample, uint32_t d)
{
    const sobol_tables *s = p->tables;
    const uint64_t index = sobol_index(s, x, y, sample);
    uint32_t v = qmc__sobol_wide_gather(s->cols + (size_t)d * QMC__SOBOL_WIDE_COLS, index);
    if (d < 2) {
        v = s->m == 32 ? 0 : v << s->m; /* u * scale - pixel, exactly */
        if (p->frame_mix == 0)
            return v;
    }
    return qmc__fast_owen(v, sobol_seed(p, x, y, d));
}

/* Column d's value at index i, in the reversed domain, pre-shifted for the
 * in-pixel position (d < 2): reverse32(v << m) = reverse32(v) >> m. */
static inline uint32_t rev_value(const sobol_tables *s, uint32_t d, uint64_t i)
{
    const uint32_t r = qmc__reverse32(
        qmc__sobol_wide_gather(s->cols + (size_t)d * QMC__SOBOL_WIDE_COLS, i));
    return d >= 2 ? r : s->m == 32 ? 0 : r >> s->m;
}

/* Sample-part steps cached per pass: from f to f + 1 the index's sample
 * part changes by S(2^(t+1) - 1), t = ctz(f + 1); rarer larger t gather. */
#define SOBOL_STEPS 12u

/*
 * Fills a sample block at a time, for every pixel.  The index splits as
 * i = P(x, y) ^ S(f) (sobol_index: the pixel's bits and the sample's), and
 * Sobol' values are linear over XOR, so a value is A_d(pixel) ^ B_d(f):
 * B is staged once per block and shared by all pixels (walked from one
 * sample to the next by one XOR, as seq_sobol.c walks its points), A is
 * one gather per pixel and value.  The kernel scrambles and reverses.
 */
static void sobol_fill(const qmc_pixels *p, const qmc_pixel_tile *t, qmc_format fmt, void *out)
{
    const sobol_tables *s = p->tables;
    const uint32_t dims = p->spec.dims;
    const size_t esize = qmc_format_bytes(fmt);
    const int framed = p->frame_mix != 0;
    uint32_t in[QMC__PIXEL_STAGE_WORDS + QMC__PIXEL_PAD];
    double scratch[QMC__PIXEL_STAGE_WORDS];
    qmc__pixel_pattern pt;
    uint8_t mode[QMC__PIXEL_MAX_COLS];
    uint32_t seed[QMC__PIXEL_MAX_COLS], xorc[QMC__PIXEL_MAX_COLS];
    uint32_t step[SOBOL_STEPS][QMC__PIXEL_MAX_COLS];
    memset(in, 0, sizeof in); /* the pad lanes the kernel reads past a block */
    for (uint32_t d0 = 0, nc; d0 < dims; d0 += nc) {
        nc = qmc__pixel_pass_cols(dims, d0);
        const uint32_t rows = qmc__pixel_block_rows(t, nc, dims, 0);
        for (uint32_t c = 0; c < nc; c++) {
            const uint32_t d = d0 + c;
            mode[c] = d < 2 && !framed ? QMC__PIXEL_PLAIN : QMC__PIXEL_OWEN;
            seed[c] = s->seed[d];
        }
        qmc__pixel_pattern_init(&pt, nc, mode, 0);
        if (!framed)
            qmc__pixel_pattern_set(&pt, NULL, seed, NULL);
        for (uint32_t k = 0; k < SOBOL_STEPS; k++) {
            const uint64_t h = sobol_index(s, 0, 0, (2ull << k) - 1);
            for (uint32_t c = 0; c < nc; c++)
                step[k][c] = rev_value(s, d0 + c, h);
        }
        for (uint64_t a = 0; a < t->sample_count; a += rows) {
            const uint32_t n = qmc__pixel_block_n(t, a, rows);
            /* B: row r holds the sample part of sample start + a + r. */
            const uint64_t f0 = t->sample_start + a;
            for (uint32_t r = 0; r < n; r++) {
                uint32_t *row = in + (size_t)r * nc;
                const uint64_t f = f0 + r;
                const uint32_t tz = r ? (uint32_t)__builtin_ctzll(f) : 64;
                if (tz < SOBOL_STEPS) {
                    const uint32_t *prev = row - nc;
                    for (uint32_t c = 0; c < nc; c++)
                        row[c] = prev[c] ^ step[tz][c];
                } else {
                    const uint64_t h = sobol_index(s, 0, 0, f);
                    for (uint32_t c = 0; c < nc; c++)
                        row[c] = rev_value(s, d0 + c, h);
                }
            }
            uint64_t pixel = 0;
            for (uint32_t y = t->y; y < t->y + t->height; y++)
                for (uint32_t x = t->x; x < t->x + t->width; x++, pixel++) {
                    const uint64_t h = sobol_index(s, x, y, 0);
                    for (uint32_t c = 0; c < nc; c++) {
                        xorc[c] = rev_value(s, d0 + c, h);
                        if (framed)
                            seed[c] = sobol_seed(p, x, y, d0 + c);
                    }
                    qmc__pixel_pattern_set(&pt, xorc, framed ? seed : NULL, NULL);
                    void *o = qmc__pixel_out(out, t, pixel, a, dims, d0, esize);
                    qmc__pixel_emit(p->isa, &pt, in, 0, 0, n, fmt, o, dims, scratch);
                }
        }
    }
}

const qmc__pixel_ops qmc__pixel_sobol = {
    .check = sobol_check,
    .table_bytes = sobol_table_bytes,
    .init = sobol_init,
    .at = sobol_at,
    .fill = sobol_fill,
};
