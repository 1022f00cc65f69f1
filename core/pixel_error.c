/*
 * pixel_error.c - the error image of a pixel sampler: every pixel of a
 * square estimates the same integral, the area of a disk, with its own
 * samples, and the image holds estimate - exact.  Its power spectrum
 * (image_spectrum.c) shows whether neighbouring pixels' errors cancel
 * (blue noise: little power at low frequencies) or not (white noise).
 *
 * The disk is centred at (1/2, 1/2) with radius r <= 1/2, so its area pi
 * r^2 is exact and the indicator has a curved edge that no dyadic box
 * follows: a net's error on it is not zero, and is what the spectrum
 * looks at.  A sample is the point (v0, v1) / 2^32 of its first two
 * values, exactly as qmc_pixels_fill's f64 format gives it.
 *
 * This file must not allocate, print or keep state.
 */
#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include "qmc/pixel.h"
#include "qmc/quality.h"

/* C11 does not promise M_PI. */
static const double pi = 3.14159265358979323846264338327950288;

int qmc_pixel_disk_error(const qmc_pixels *p, uint32_t x0, uint32_t y0,
                         uint32_t side, uint64_t samples, double radius,
                         uint32_t *work, double *image)
{
    if (p == NULL || work == NULL || image == NULL)
        return QMC_EINVAL;
    if (!(radius > 0.0 && radius <= 0.5))
        return QMC_EDOMAIN;
    const qmc_pixel_spec *spec = qmc_pixels_get_spec(p);
    if (spec->dims < 2)
        return QMC_EDIMS;
    if (side == 0 || samples == 0)
        return QMC_EINVAL;
    /* One check of the whole square's extent, so that no pixel's fill can
     * fail half way and leave a partial image. */
    qmc_pixel_tile all = {x0, y0, side, side, 0, samples};
    int err = qmc_pixels_tile_check(p, &all, NULL, NULL, 0);
    if (err != 0)
        return err;

    const double scale = 0x1p-32, r2 = radius * radius, area = pi * r2;
    const uint32_t dims = spec->dims;
    for (uint32_t j = 0; j < side; j++)
        for (uint32_t i = 0; i < side; i++) {
            qmc_pixel_tile one = {x0 + i, y0 + j, 1, 1, 0, samples};
            err = qmc_pixels_fill(p, &one, QMC_FORMAT_U32, work);
            if (err != 0)
                return err;
            uint64_t inside = 0;
            for (uint64_t s = 0; s < samples; s++) {
                double u = (double)work[s * dims] * scale - 0.5;
                double v = (double)work[s * dims + 1] * scale - 0.5;
                inside += u * u + v * v < r2;
            }
            image[(size_t)j * side + i] = (double)inside / (double)samples - area;
        }
    return 0;
}
