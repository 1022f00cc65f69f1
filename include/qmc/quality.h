/*
 * qmc/quality.h - quality measures of point sets: L2-type discrepancies,
 * the star discrepancy D*, the Fourier power spectrum of 2D sets, the
 * t-value of a 2D projection of a base-2 digital net, and the power
 * spectrum of a square image (a renderer's error image).
 *
 * Everything here is pure computation on caller-owned arrays: no function
 * allocates, prints or keeps state, so any number of threads may call them
 * at once on distinct output arrays.  Point sets are row-major: coordinate k
 * of point i is points[i * dims + k].
 */
#ifndef QMC_QUALITY_H
#define QMC_QUALITY_H

#include <stddef.h>
#include <stdint.h>

#include "qmc/error.h"
#include "qmc/pixel.h"

#ifdef __cplusplus
extern "C" {
#endif

/*
 * Checks a point set as every function below over double points does.
 * Returns 0, QMC_EINVAL (points NULL), QMC_EDOMAIN (n == 0, dims == 0, a
 * coordinate outside [0,1] or NaN) or QMC_ETOOBIG (n * dims overflows).
 */
QMC_MUST_CHECK int qmc_quality_check(const double *points, size_t n,
                                     uint32_t dims);

/*
 * L2-type discrepancies.  X(enum suffix, value, CLI name, scipy name).
 * Each returns exactly what scipy.stats.qmc.discrepancy(method=<scipy name>)
 * returns (SciPy 1.10): L2-star is the square root of the squared
 * discrepancy (Warnock 1972), while CD, WD and MD are the *squared*
 * discrepancies (Hickernell 1998; Zhou, Fang & Ning 2013 for MD).
 */
#define QMC_DISC_METHOD_MAP(X)              \
    X(L2_STAR, 1, "l2-star", "L2-star")     \
    X(CD,      2, "cd",      "CD")          \
    X(WD,      3, "wd",      "WD")          \
    X(MD,      4, "md",      "MD")

typedef enum qmc_disc_method {
#define QMC__DISC_ENUM(name, value, cli, scipy) QMC_DISC_##name = (value),
    QMC_DISC_METHOD_MAP(QMC__DISC_ENUM)
#undef QMC__DISC_ENUM
} qmc_disc_method;

/* The CLI name ("l2-star", "cd", ...) of a method; "?" when unknown. */
const char *qmc_disc_method_name(qmc_disc_method method);

/* Parses a CLI name (case-sensitive).  Returns 0 or QMC_EINVAL; *out is
 * untouched on error. */
QMC_MUST_CHECK int qmc_disc_method_parse(const char *name,
                                         qmc_disc_method *out);

/*
 * Computes the discrepancy of n points in [0,1]^dims with the O(n^2 dims)
 * closed forms SciPy uses.  Returns 0 and the value in *out, or:
 *   QMC_EINVAL   points or out NULL, unknown method;
 *   QMC_EDOMAIN  n == 0, dims == 0, a coordinate outside [0,1] or NaN;
 *   QMC_ETOOBIG  n * dims overflows size_t.
 * *out is 0.0 on error.  Nothing is allocated.
 */
QMC_MUST_CHECK int qmc_disc_compute(const double *points, size_t n,
                                    uint32_t dims, qmc_disc_method method,
                                    double *out);

/*
 * Star discrepancy D* = sup over boxes [0,u) of |#{x_i in box}/n - vol|.
 *
 * dims == 2: exact, by a sweep over the grid of point coordinates and 1 in
 * O(n log n + n^2) time, checking open and closed boxes (see
 * core/star_discrepancy.c).  dims > 2 (and dims == 1): exact when the whole
 * grid of critical boxes fits in max_ops coordinate comparisons, otherwise a
 * lower bound from a deterministic subset of critical boxes whose cost stays
 * within max_ops.  *exact says which (1 exact, 0 lower bound).  max_ops == 0
 * means QMC_STAR_DEFAULT_OPS.
 *
 * work is caller-owned scratch of qmc_star_work_len(n, dims) doubles (0
 * when n or dims is 0 or the size overflows: QMC_ETOOBIG);
 * its contents on return are unspecified.
 * Errors: as qmc_disc_compute, plus QMC_EINVAL when work, exact is NULL.
 * On error *out is 0.0 and *exact 0.
 */
#define QMC_STAR_DEFAULT_OPS 400000000ull

size_t qmc_star_work_len(size_t n, uint32_t dims);

QMC_MUST_CHECK int qmc_star_compute(const double *points, size_t n,
                                    uint32_t dims, uint64_t max_ops,
                                    double *work, double *out, int *exact);

/*
 * Fourier power spectrum of a 2D projection (coordinates dim_x, dim_y) of a
 * point set: the periodogram P(k) = |sum_j exp(-2 pi i k.x_j)|^2 / n over
 * integer frequencies k in [-kmax, kmax]^2.
 *
 * power holds side * side doubles, side = qmc_spectrum_side(kmax), row-major
 * with ky rows: P(kx, ky) is power[(ky + kmax) * side + (kx + kmax)].  The
 * caller zeroes it, calls qmc_spectrum_accumulate once per realisation
 * (which adds that realisation's P), then qmc_spectrum_finish.
 * work is caller-owned scratch of qmc_spectrum_work_len(kmax) doubles.
 *
 * accumulate errors: QMC_EINVAL (NULL pointer, dim_x == dim_y),
 * QMC_EDOMAIN (n == 0, a coordinate outside [0,1] or NaN), QMC_EDIMS
 * (dim_x or dim_y >= dims), QMC_ETOOBIG (kmax > QMC_SPECTRUM_MAX_FREQ).
 * power is unchanged on error.
 */
#define QMC_SPECTRUM_MAX_FREQ 4096u

size_t qmc_spectrum_side(uint32_t kmax);
size_t qmc_spectrum_work_len(uint32_t kmax);

QMC_MUST_CHECK int qmc_spectrum_accumulate(const double *points, size_t n,
                                           uint32_t dims, uint32_t dim_x,
                                           uint32_t dim_y, uint32_t kmax,
                                           double *power, double *work);

/*
 * Divides the accumulated power by reps (so it becomes the mean
 * periodogram) and writes the radial average into radial[0 .. kmax]:
 * radial[b] is the mean of P(k) over the k with b - 1/2 <= |k| < b + 1/2.
 * Bins past kmax are left out because their annuli leave the square.
 * radial[0] is P(0) = n, the DC term.  Errors: QMC_EINVAL (NULL, reps == 0),
 * QMC_ETOOBIG (kmax too large); nothing is written on error.
 */
QMC_MUST_CHECK int qmc_spectrum_finish(double *power, uint32_t kmax,
                                       uint32_t reps, double *radial);

/*
 * Power spectrum of a square image (side x side doubles, row-major: pixel
 * (x, y) is image[y * side + x]), e.g. the error image of a pixel sampler
 * (estimate - exact in every pixel): the periodogram
 *   P(k) = |sum_{x,y} image[y][x] exp(-2 pi i (kx x + ky y) / side)|^2 / side^2
 * over integer k in [-kmax, kmax]^2, kmax = qmc_image_spectrum_kmax(side)
 * = side / 2.  White noise of variance s^2 has E[P(k)] = s^2 for k != 0;
 * the sum of P over one period of k (for even side, leave out the row and
 * column k = +kmax, which repeat -kmax) is the sum of image^2 (Parseval).
 *
 * power uses qmc_spectrum_accumulate's layout and conventions: the caller
 * zeroes qmc_spectrum_side(kmax)^2 doubles, calls this once per image
 * (adding that image's P), then qmc_spectrum_finish(power, kmax, reps,
 * radial) for the mean periodogram and its radial average radial[0 ..
 * kmax] (there radial[0] = P(0) = (sum of image)^2 / side^2).
 * work is caller-owned scratch of qmc_image_spectrum_work_len(side)
 * doubles (0 when side is 0 or too large).  Cost O(side^3); nothing is
 * allocated.
 *
 * Errors: QMC_EINVAL (NULL pointer), QMC_EDOMAIN (side 0, a NaN or
 * infinite pixel), QMC_ETOOBIG (side > QMC_IMAGE_SPECTRUM_MAX_SIDE).
 * power is unchanged on error.
 */
#define QMC_IMAGE_SPECTRUM_MAX_SIDE 1024u

uint32_t qmc_image_spectrum_kmax(uint32_t side);
size_t qmc_image_spectrum_work_len(uint32_t side);

QMC_MUST_CHECK int qmc_image_spectrum_accumulate(const double *image,
                                                 uint32_t side, double *power,
                                                 double *work);

/*
 * The low band of a radial spectrum: rings 1 .. qmc_image_spectrum_low_rings
 * (kmax) = max(1, kmax / 8), the lowest eighth of the frequencies without
 * the DC term (the image's mean, not a pattern in it).
 * qmc_image_spectrum_low_band returns the sum of radial[b] over those
 * rings, the measure issue 20 compares between samplers (each ring counts
 * once, whatever its number of frequencies); 0 when radial is NULL or
 * kmax is 0.
 */
uint32_t qmc_image_spectrum_low_rings(uint32_t kmax);
double qmc_image_spectrum_low_band(const double *radial, uint32_t kmax);

/*
 * The error image of a pixel sampler on a disk.  Pixel (x0 + i, y0 + j),
 * for i, j < side, estimates the area of the disk of the given radius
 * centred at (1/2, 1/2) from its samples 0 .. samples - 1, each the point
 * (value 0, value 1) / 2^32; image[j * side + i] is that estimate minus
 * pi radius^2.  work is caller-owned scratch of samples * dims uint32_t
 * (dims of p's spec).  Feed the image to qmc_image_spectrum_accumulate.
 *
 * Errors: QMC_EINVAL (NULL pointer, side or samples 0), QMC_EDOMAIN
 * (radius not in (0, 1/2]), QMC_EDIMS (the spec has fewer than 2 dims),
 * and qmc_pixels_tile_check's (QMC_ERANGE: the square or the samples
 * leave the image or the spp).  Nothing is written on error.
 */
QMC_MUST_CHECK int qmc_pixel_disk_error(const qmc_pixels *p, uint32_t x0,
                                        uint32_t y0, uint32_t side,
                                        uint64_t samples, double radius,
                                        uint32_t *work, double *image);

/*
 * t-value of the 2D projection (dim_a, dim_b) of n = 2^m points given as
 * u32 coordinates (floor(x * 2^32), row-major, dims per point): the
 * smallest t such that every elementary interval
 * [a/2^q1, (a+1)/2^q1) x [b/2^q2, (b+1)/2^q2) with q1 + q2 = m - t holds
 * exactly 2^t points, i.e. the projection is a (t, m, 2)-net in base 2.
 * Always <= m.  work is caller-owned scratch of n uint32_t.
 * Errors: QMC_EINVAL (NULL pointer, dim_a == dim_b), QMC_EDIMS (a dim >=
 * dims, dims == 0), QMC_ECOUNT (n not a power of two in [1, 2^31]).
 * *t_out is 0 on error.
 */
QMC_MUST_CHECK int qmc_tvalue_compute(const uint32_t *points, size_t n,
                                      uint32_t dims, uint32_t dim_a,
                                      uint32_t dim_b, uint32_t *work,
                                      uint32_t *t_out);

#ifdef __cplusplus
}
#endif
#endif /* QMC_QUALITY_H */
