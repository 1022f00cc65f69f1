/*
 * qmc/pixel.h - pixel samplers: the samples a renderer draws, by pixel.
 *
 * A pixel sampler is fixed by a qmc_pixel_spec: (sampler, full image
 * resolution, samples per pixel, seed, frame, dims).  Value d of sample i
 * of pixel (x, y) is a pure function of the spec and (x, y, i, d): a
 * 32-bit integer v, the coordinate v / 2^32 in [0, 1).  Random access
 * (qmc_pixels_at) and tile fills (qmc_pixels_fill) agree bit for bit, on
 * every thread count and machine.  docs/SEQUENCES.md defines every sampler
 * down to its constants.
 *
 * With frame 0, zsobol and padded-sobol give pbrt-v4's values: values
 * (2k, 2k+1) of sample i of pixel (x, y) are the two 32-bit integers that
 * pbrt-v4's StartPixelSample({x, y}, i, 2k) followed by Get2D() computes
 * (before its conversion to float) for the same spp, full resolution and
 * seed, with FastOwen randomization.  An odd dims count ends with the
 * first value of the next pair.
 *
 * A qmc_pixels is immutable after qmc_pixels_new: any number of threads
 * may call qmc_pixels_at / qmc_pixels_fill on one instance at once.
 * Neither allocates.
 */
#ifndef QMC_PIXEL_H
#define QMC_PIXEL_H

#include <stddef.h>
#include <stdint.h>

#include "qmc/error.h"
#include "qmc/seq.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Samplers.  X(enum suffix, wire value, CLI name). */
#define QMC_PIXEL_SAMPLER_MAP(X)          \
    X(ZSOBOL,       1, "zsobol")          \
    X(PADDED_SOBOL, 2, "padded-sobol")    \
    X(SOBOL,        3, "sobol")

typedef enum qmc_pixel_sampler {
#define QMC__PIXEL_ENUM(name, value, text) QMC_PIXEL_##name = (value),
    QMC_PIXEL_SAMPLER_MAP(QMC__PIXEL_ENUM)
#undef QMC__PIXEL_ENUM
} qmc_pixel_sampler;

/* The sobol sampler's dimensions are the Joe-Kuo table's. */
#define QMC_PIXEL_SOBOL_MAX_DIMS 21201u

typedef struct qmc_pixel_spec {
    qmc_pixel_sampler sampler;
    uint32_t width, height; /* the full image, in pixels, each >= 1 */
    uint64_t spp;           /* samples per pixel the pattern is built for */
    uint32_t seed;          /* pbrt-v4's int seed, as its 32 bits */
    uint32_t frame;         /* 0: pbrt-v4's values; others decorrelated */
    uint32_t dims;          /* values per sample, >= 1 */
} qmc_pixel_spec;

/* A rectangle of pixels and a run of sample indices: what one request
 * fills.  Pixels [x, x + width) x [y, y + height), samples
 * [sample_start, sample_start + sample_count). */
typedef struct qmc_pixel_tile {
    uint32_t x, y, width, height;
    uint64_t sample_start, sample_count;
} qmc_pixel_tile;

typedef struct qmc_pixels qmc_pixels;

/*
 * Checks a spec without allocating.  Returns 0 or the code qmc_pixels_new
 * would return (QMC_EKIND, QMC_EDIMS, QMC_ECOUNT, QMC_ERANGE, QMC_EINVAL).
 * When why is not NULL, writes a one-line, NUL-terminated reason naming
 * the problem and, where there is one, the fix (e.g. the nearest valid
 * spp) into why[0 .. why_bytes).
 */
QMC_MUST_CHECK int qmc_pixel_spec_check(const qmc_pixel_spec *spec, char *why,
                                        size_t why_bytes);

/*
 * Creates a sampler.  On success *out owns a new instance (free it with
 * qmc_pixels_free); on failure *out is NULL.  Errors: those of
 * qmc_pixel_spec_check, QMC_ENOMEM.
 */
QMC_MUST_CHECK int qmc_pixels_new(const qmc_pixel_spec *spec, qmc_pixels **out);

/* Frees a sampler; NULL is a no-op. */
void qmc_pixels_free(qmc_pixels *p);

/* The spec the sampler was made from. */
const qmc_pixel_spec *qmc_pixels_get_spec(const qmc_pixels *p);

/*
 * One past the largest sample index any pixel may ask for: spp for zsobol
 * and padded-sobol, the end of the image's Sobol index space for sobol.
 */
uint64_t qmc_pixels_sample_end(const qmc_pixels *p);

/*
 * Checks that a tile lies inside the image and the sample range inside
 * [0, qmc_pixels_sample_end), and that its value count (pixels x samples
 * x dims) fits in 64 bits.  Returns 0 or QMC_ERANGE (or QMC_EINVAL for an
 * empty tile), with a one-line reason in why as for qmc_pixel_spec_check;
 * a sample index past spp names the fix (a larger spp).  On success
 * *values, when not NULL, is the tile's value count.
 */
QMC_MUST_CHECK int qmc_pixels_tile_check(const qmc_pixels *p, const qmc_pixel_tile *tile,
                                         uint64_t *values, char *why, size_t why_bytes);

/*
 * Value dim of sample `sample` of pixel (x, y): the 32-bit integer v.
 * Errors: QMC_ERANGE (pixel or sample outside), QMC_EDIMS (dim >= dims);
 * *out is 0 on error.
 */
QMC_MUST_CHECK int qmc_pixels_at(const qmc_pixels *p, uint32_t x, uint32_t y,
                                 uint64_t sample, uint32_t dim, uint32_t *out);

/*
 * Writes a tile pixel-major: for each pixel in row order (y, then x), for
 * each sample sample_start .. sample_start + sample_count - 1, dims
 * values.  Formats as qmc_seq_fill: u32 is v itself, f64 is v / 2^32
 * exactly, f32 is floor(v / 2^8) / 2^24 (never rounds up to 1.0; pbrt
 * rounds v * 2^-32 to nearest instead: docs/SEQUENCES.md).  Errors: those
 * of qmc_pixels_tile_check, QMC_EFORMAT; nothing is written on error.
 */
QMC_MUST_CHECK int qmc_pixels_fill(const qmc_pixels *p, const qmc_pixel_tile *tile,
                                   qmc_format format, void *out);

/*
 * Cuts a tile into bounded pieces: sets *piece to the next piece of `tile`
 * from its output sample `done` on (samples counted in qmc_pixels_fill's
 * order, 0 the first), holding at most max_samples samples, whose own
 * output is one contiguous run of the tile's: whole rows where a row
 * fits, else whole pixels of one row, else part of one pixel's samples.
 * So filling (or fetching) piece after piece, done advancing by each
 * piece's width x height x sample_count, writes the tile's output in
 * order with bounded memory.  Returns 0, or QMC_EINVAL (an empty tile,
 * done not below its sample count, max_samples 0), *piece zeroed.  Pure:
 * no spec, no check of the tile against an image.
 */
QMC_MUST_CHECK int qmc_pixel_tile_piece(const qmc_pixel_tile *tile, uint64_t done,
                                        uint64_t max_samples, qmc_pixel_tile *piece);

/* Name <-> value lookups.  The parse function returns 0 or QMC_EKIND. */
const char *qmc_pixel_sampler_name(qmc_pixel_sampler sampler);
QMC_MUST_CHECK int qmc_pixel_sampler_parse(const char *name, qmc_pixel_sampler *out);

#ifdef __cplusplus
}
#endif
#endif /* QMC_PIXEL_H */
