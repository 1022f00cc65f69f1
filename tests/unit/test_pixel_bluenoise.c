/*
 * test_pixel_bluenoise.c - issue 20's blue-noise measure, as a test that
 * can fail: every pixel of a 64 x 64 image estimates the area of a disk
 * (radius 0.4, exact pi 0.16) from its spp samples of dimensions (0, 1);
 * the error image's radially averaged power spectrum, averaged over 16
 * seeds, must carry in its lowest eighth of frequencies (rings 1 .. 4, no
 * DC) at most a quarter of what padded-sobol's carries there, for zsobol
 * at frame 0 and at frame 1.
 *
 * The oracles: the disk's closed-form area and padded-sobol, whose pixels
 * are decorrelated by construction (white error).  The error image itself
 * is checked against random access (qmc_pixels_at), a path apart from the
 * tile fill it uses.
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>

#include "pixel_test.h"
#include "qmc/pixel.h"
#include "qmc/quality.h"

enum { SIDE = 64, SEEDS = 16 };
static const double RADIUS = 0.4;
static const double MAX_RATIO = 0.25;

static qmc_pixels *make(qmc_pixel_sampler s, uint64_t spp, uint32_t seed, uint32_t frame)
{
    return pixel_make(s, SIDE, SIDE, spp, seed, frame, 2);
}

/* The low band of the mean radial spectrum over SEEDS seeds. */
static double low_band(qmc_pixel_sampler s, uint64_t spp, uint32_t frame)
{
    uint32_t kmax = qmc_image_spectrum_kmax(SIDE);
    size_t ks = qmc_spectrum_side(kmax);
    double *power = calloc(ks * ks, sizeof(double));
    double *work = calloc(qmc_image_spectrum_work_len(SIDE), sizeof(double));
    double *image = calloc((size_t)SIDE * SIDE, sizeof(double));
    uint32_t *values = calloc(spp * 2, sizeof(uint32_t));
    double *radial = calloc(kmax + 1, sizeof(double));
    assert_true(power && work && image && values && radial);
    for (uint32_t seed = 0; seed < SEEDS; seed++) {
        qmc_pixels *p = make(s, spp, seed, frame);
        assert_int_equal(qmc_pixel_disk_error(p, 0, 0, SIDE, spp, RADIUS, values, image), 0);
        assert_int_equal(qmc_image_spectrum_accumulate(image, SIDE, power, work), 0);
        qmc_pixels_free(p);
    }
    assert_int_equal(qmc_spectrum_finish(power, kmax, SEEDS, radial), 0);
    double low = qmc_image_spectrum_low_band(radial, kmax);
    free(power);
    free(work);
    free(image);
    free(values);
    free(radial);
    return low;
}

static void check_blue(uint64_t spp, uint32_t frame)
{
    double z = low_band(QMC_PIXEL_ZSOBOL, spp, frame);
    double w = low_band(QMC_PIXEL_PADDED_SOBOL, spp, frame);
    assert_true(w > 0.0); /* a white error image has power at every ring */
    double ratio = z / w;
    print_message("spp %3llu frame %u: low band zsobol %.4g, padded-sobol %.4g, ratio %.4f "
                  "(must be <= %.2f)\n",
                  (unsigned long long)spp, frame, z, w, ratio, MAX_RATIO);
    if (!(ratio <= MAX_RATIO))
        fail_msg("zsobol's low band is %.4f of padded-sobol's at spp %llu frame %u (> %.2f)",
                 ratio, (unsigned long long)spp, frame, MAX_RATIO);
}

static void test_blue_frame0(void **state)
{
    (void)state;
    check_blue(16, 0);
    check_blue(64, 0);
}

static void test_blue_frame1(void **state)
{
    (void)state;
    check_blue(16, 1);
    check_blue(64, 1);
}

/* The error image from random access, pixel by pixel, against the tile
 * path; and the exact area it subtracts. */
static void test_error_image_by_at(void **state)
{
    (void)state;
    const uint64_t spp = 8;
    const uint32_t side = 5, x0 = 30, y0 = 41;
    qmc_pixels *p = make(QMC_PIXEL_ZSOBOL, spp, 3, 0);
    uint32_t values[16];
    double image[25];
    assert_int_equal(qmc_pixel_disk_error(p, x0, y0, side, spp, RADIUS, values, image), 0);
    for (uint32_t j = 0; j < side; j++)
        for (uint32_t i = 0; i < side; i++) {
            unsigned inside = 0;
            for (uint64_t s = 0; s < spp; s++) {
                uint32_t a, b;
                assert_int_equal(qmc_pixels_at(p, x0 + i, y0 + j, s, 0, &a), 0);
                assert_int_equal(qmc_pixels_at(p, x0 + i, y0 + j, s, 1, &b), 0);
                double u = ldexp((double)a, -32) - 0.5, v = ldexp((double)b, -32) - 0.5;
                inside += u * u + v * v < 0.16;
            }
            double want = inside / 8.0 - 0.50265482457436691815; /* pi 0.4^2 */
            assert_true(fabs(image[j * side + i] - want) < 1e-15);
        }
    qmc_pixels_free(p);
}

static void test_error_image_errors(void **state)
{
    (void)state;
    qmc_pixels *p = make(QMC_PIXEL_PADDED_SOBOL, 4, 0, 0);
    uint32_t values[8];
    double image[4] = {7, 7, 7, 7};
    assert_int_equal(qmc_pixel_disk_error(NULL, 0, 0, 2, 4, 0.4, values, image), QMC_EINVAL);
    assert_int_equal(qmc_pixel_disk_error(p, 0, 0, 2, 4, 0.4, NULL, image), QMC_EINVAL);
    assert_int_equal(qmc_pixel_disk_error(p, 0, 0, 0, 4, 0.4, values, image), QMC_EINVAL);
    assert_int_equal(qmc_pixel_disk_error(p, 0, 0, 2, 0, 0.4, values, image), QMC_EINVAL);
    assert_int_equal(qmc_pixel_disk_error(p, 0, 0, 2, 4, 0.6, values, image), QMC_EDOMAIN);
    assert_int_equal(qmc_pixel_disk_error(p, 0, 0, 2, 4, NAN, values, image), QMC_EDOMAIN);
    /* past spp, past the image's edge */
    assert_int_equal(qmc_pixel_disk_error(p, 0, 0, 2, 5, 0.4, values, image), QMC_ERANGE);
    assert_int_equal(qmc_pixel_disk_error(p, SIDE - 1, 0, 2, 4, 0.4, values, image), QMC_ERANGE);
    for (int i = 0; i < 4; i++)
        assert_true(image[i] == 7.0);
    qmc_pixels_free(p);

    qmc_pixel_spec one_dim = {.sampler = QMC_PIXEL_ZSOBOL, .width = 4, .height = 4, .spp = 4,
                              .dims = 1};
    assert_int_equal(qmc_pixels_new(&one_dim, &p), 0);
    assert_int_equal(qmc_pixel_disk_error(p, 0, 0, 2, 4, 0.4, values, image), QMC_EDIMS);
    qmc_pixels_free(p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_error_image_by_at),
        cmocka_unit_test(test_error_image_errors),
        cmocka_unit_test(test_blue_frame0),
        cmocka_unit_test(test_blue_frame1),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
