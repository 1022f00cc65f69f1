/*
 * image_spectrum.c - power spectrum (periodogram) of a square real image,
 * such as a renderer's error image.
 *
 * P(k) = |F(k)|^2 / N, F(k) = sum_{x,y} img[y][x] exp(-2 pi i (kx x + ky y) / n),
 * for an n x n image of N = n^2 pixels and integer k in [-K, K]^2, K = n/2
 * (rounded down).  The division by N is the one qmc_spectrum_* makes by the
 * point count: white noise of variance s^2 has E[P(k)] = s^2 at every
 * k != 0, and Parseval reads sum over one period of P = sum of img^2.  A
 * blue-noise error image has little power at low |k| (Ulichney 1987;
 * Georgiev and Fajardo 2016; Ahmed and Wonka 2020 for renderers' samples).
 *
 * The layout is qmc_spectrum's (rows ky, columns kx, centred), so
 * qmc_spectrum_finish averages realisations and rings the same way.  The
 * DFT of a sampled image is periodic in k with period n: for even n the
 * lines kx = +-n/2 (and ky = +-n/2) hold the same values, the Nyquist
 * frequency seen from both sides.  Every ring b <= K lies inside the
 * square, so the radial average sees every frequency of its annulus.
 *
 * The transform is separable and direct: a DFT along each row for the
 * 2K+1 kx we keep, then one along each column, O(n^3) multiply-adds (a
 * quarter of a million for 64 x 64).  Phases come from a table of the n
 * n-th roots of unity indexed by (k x) mod n, computed exactly in
 * integers, so no rounding accumulates along k.
 *
 * This file must not allocate, print or keep state.
 */
#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include "qmc/quality.h"

/* C11 does not promise M_PI. */
static const double two_pi = 6.283185307179586476925286766559;

uint32_t qmc_image_spectrum_kmax(uint32_t side)
{
    return side / 2;
}

size_t qmc_image_spectrum_work_len(uint32_t side)
{
    if (side == 0 || side > QMC_IMAGE_SPECTRUM_MAX_SIDE)
        return 0;
    /* the roots of unity (re, im), then the row transforms G(y, kx) */
    return 2 * (size_t)side +
           2 * (size_t)side * qmc_spectrum_side(qmc_image_spectrum_kmax(side));
}

/* (k * x) mod n for a signed frequency k, in [0, n). */
static size_t phase_index(int64_t k, size_t x, size_t n)
{
    int64_t r = (k * (int64_t)x) % (int64_t)n;
    return (size_t)(r < 0 ? r + (int64_t)n : r);
}

int qmc_image_spectrum_accumulate(const double *image, uint32_t side,
                                  double *power, double *work)
{
    if (image == NULL || power == NULL || work == NULL)
        return QMC_EINVAL;
    if (side == 0)
        return QMC_EDOMAIN;
    if (side > QMC_IMAGE_SPECTRUM_MAX_SIDE)
        return QMC_ETOOBIG;
    size_t n = side;
    for (size_t i = 0; i < n * n; i++)
        if (!isfinite(image[i]))
            return QMC_EDOMAIN;

    uint32_t kmax = qmc_image_spectrum_kmax(side);
    size_t ks = qmc_spectrum_side(kmax);
    double *wr = work, *wi = work + n;
    double *gr = work + 2 * n, *gi = gr + n * ks; /* G(y, kx) at [y * ks + c] */

    /* exp(-2 pi i j / n); j / n is exact enough that the table's error is
     * that of cos and sin themselves. */
    for (size_t j = 0; j < n; j++) {
        double ang = -two_pi * (double)j / (double)n;
        wr[j] = cos(ang);
        wi[j] = sin(ang);
    }

    /* Rows: G(y, kx) = sum_x img[y][x] w^(kx x). */
    for (size_t y = 0; y < n; y++) {
        const double *row = image + y * n;
        for (size_t c = 0; c < ks; c++) {
            int64_t kx = (int64_t)c - (int64_t)kmax;
            double sr = 0.0, si = 0.0;
            for (size_t x = 0; x < n; x++) {
                size_t p = phase_index(kx, x, n);
                sr += row[x] * wr[p];
                si += row[x] * wi[p];
            }
            gr[y * ks + c] = sr;
            gi[y * ks + c] = si;
        }
    }

    /* Columns: F(kx, ky) = sum_y G(y, kx) w^(ky y). */
    double inv_pixels = 1.0 / ((double)n * (double)n);
    for (size_t r = 0; r < ks; r++) {
        int64_t ky = (int64_t)r - (int64_t)kmax;
        double *prow = power + r * ks;
        for (size_t c = 0; c < ks; c++) {
            double fr = 0.0, fi = 0.0;
            for (size_t y = 0; y < n; y++) {
                size_t p = phase_index(ky, y, n);
                double a = gr[y * ks + c], b = gi[y * ks + c];
                fr += a * wr[p] - b * wi[p];
                fi += a * wi[p] + b * wr[p];
            }
            prow[c] += (fr * fr + fi * fi) * inv_pixels;
        }
    }
    return 0;
}

uint32_t qmc_image_spectrum_low_rings(uint32_t kmax)
{
    return kmax / 8 > 0 ? kmax / 8 : 1;
}

double qmc_image_spectrum_low_band(const double *radial, uint32_t kmax)
{
    double sum = 0.0;
    if (radial == NULL || kmax == 0)
        return 0.0;
    for (uint32_t b = 1; b <= qmc_image_spectrum_low_rings(kmax); b++)
        sum += radial[b];
    return sum;
}
