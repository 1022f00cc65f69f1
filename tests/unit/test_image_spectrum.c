/*
 * test_image_spectrum.c - unit tests for qmc_image_spectrum_* (qmc/quality.h)
 * against closed forms: a single cosine puts all its power at +-k, hence in
 * one ring; the Nyquist line repeats on both sides; Parseval's identity;
 * white noise of known variance is flat in expectation; and a naive 2D
 * DFT written here from the definition (no separability, no tables).
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "qmc/quality.h"

static const double two_pi = 6.283185307179586476925286766559;

static void assert_close(double got, double want, double rel, double abs_tol)
{
    double tol = rel * fabs(want) + abs_tol;
    if (!(fabs(got - want) <= tol))
        fail_msg("got %.17g, want %.17g (tolerance %.3g)", got, want, tol);
}

/* splitmix64 (Steele, Lea and Flood 2014): a test-side source of noise. */
static uint64_t splitmix(uint64_t *s)
{
    uint64_t z = (*s += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

/* Uniform on [-1/2, 1/2): variance exactly 1/12 in the limit. */
static double centred_uniform(uint64_t *s)
{
    return (double)(splitmix(s) >> 11) * 0x1p-53 - 0.5;
}

/* An image's spectrum, heap buffers sized by the library's own helpers. */
typedef struct spec {
    uint32_t side, kmax;
    size_t ks;
    double *power, *work, *radial;
} spec;

static void spec_open(spec *s, uint32_t side)
{
    s->side = side;
    s->kmax = qmc_image_spectrum_kmax(side);
    s->ks = qmc_spectrum_side(s->kmax);
    s->power = calloc(s->ks * s->ks, sizeof(double));
    s->work = calloc(qmc_image_spectrum_work_len(side), sizeof(double));
    s->radial = calloc(s->kmax + 1, sizeof(double));
    assert_non_null(s->power);
    assert_non_null(s->work);
    assert_non_null(s->radial);
}

static void spec_close(spec *s)
{
    free(s->power);
    free(s->work);
    free(s->radial);
}

static double power_at(const spec *s, int kx, int ky)
{
    return s->power[(size_t)(ky + (int)s->kmax) * s->ks + (size_t)(kx + (int)s->kmax)];
}

/* Ring b holds the integer k with b - 1/2 <= |k| < b + 1/2: counted here by
 * brute force over the square, apart from the library's integer formula. */
static double ring_count(int b, int kmax)
{
    double c = 0;
    for (int y = -kmax; y <= kmax; y++)
        for (int x = -kmax; x <= kmax; x++) {
            double r = sqrt((double)(x * x + y * y));
            if (r >= b - 0.5 && r < b + 0.5)
                c++;
        }
    return c;
}

/* A cos(2 pi (a x + b y) / n + phi): power A^2 N / 4 at k = +-(a, b) and
 * nothing elsewhere, so its ring alone carries power. */
static void check_cosine(uint32_t n, int a, int b, double amp, double phi)
{
    spec s;
    spec_open(&s, n);
    double *img = malloc((size_t)n * n * sizeof(double));
    assert_non_null(img);
    for (uint32_t y = 0; y < n; y++)
        for (uint32_t x = 0; x < n; x++)
            img[y * n + x] = amp * cos(two_pi * (double)(a * (int)x + b * (int)y) / n + phi);
    assert_int_equal(qmc_image_spectrum_accumulate(img, n, s.power, s.work), 0);
    double peak = amp * amp * (double)n * (double)n / 4.0;
    int km = (int)s.kmax;
    for (int ky = -km; ky <= km; ky++)
        for (int kx = -km; kx <= km; kx++) {
            int on = (kx == a && ky == b) || (kx == -a && ky == -b);
            assert_close(power_at(&s, kx, ky), on ? peak : 0.0, 1e-12, 1e-18 * peak);
        }
    assert_int_equal(qmc_spectrum_finish(s.power, s.kmax, 1, s.radial), 0);
    int ring = (int)floor(sqrt((double)(a * a + b * b)) + 0.5);
    for (int r = 0; r <= km; r++)
        assert_close(s.radial[r], r == ring ? 2.0 * peak / ring_count(r, km) : 0.0, 1e-12,
                     1e-18 * peak);
    free(img);
    spec_close(&s);
}

static void test_cosine_one_ring(void **state)
{
    (void)state;
    check_cosine(64, 3, 4, 1.0, 0.0);   /* ring 5 */
    check_cosine(64, -7, 2, 0.25, 1.0); /* ring 7 */
    check_cosine(15, 2, -1, 3.0, 0.3);  /* odd side: every k once */
    check_cosine(32, 0, 1, 1.0, 0.5);   /* the lowest ring */
}

/* (-1)^x is the Nyquist frequency: F = N at kx = n/2, which the periodic
 * spectrum shows at both +kmax and -kmax; P = N^2 / N there. */
static void test_nyquist_both_sides(void **state)
{
    (void)state;
    const uint32_t n = 16;
    spec s;
    spec_open(&s, n);
    double img[16 * 16];
    for (uint32_t y = 0; y < n; y++)
        for (uint32_t x = 0; x < n; x++)
            img[y * n + x] = (x & 1) ? -1.0 : 1.0;
    assert_int_equal(qmc_image_spectrum_accumulate(img, n, s.power, s.work), 0);
    int km = (int)s.kmax;
    assert_int_equal(km, 8);
    for (int ky = -km; ky <= km; ky++)
        for (int kx = -km; kx <= km; kx++)
            assert_close(power_at(&s, kx, ky), (ky == 0 && (kx == km || kx == -km)) ? 256.0 : 0.0,
                         1e-12, 1e-12);
    spec_close(&s);
}

/* Parseval: the sum of P over one period of k is the sum of image^2. */
static void check_parseval(uint32_t n, uint64_t seed)
{
    spec s;
    spec_open(&s, n);
    double *img = malloc((size_t)n * n * sizeof(double));
    assert_non_null(img);
    double energy = 0;
    for (size_t i = 0; i < (size_t)n * n; i++) {
        img[i] = centred_uniform(&seed) + 0.3; /* a mean, so P(0) counts too */
        energy += img[i] * img[i];
    }
    assert_int_equal(qmc_image_spectrum_accumulate(img, n, s.power, s.work), 0);
    int km = (int)s.kmax, hi = (n % 2 == 0) ? km - 1 : km; /* +kmax repeats -kmax */
    double total = 0;
    for (int ky = -km; ky <= hi; ky++)
        for (int kx = -km; kx <= hi; kx++)
            total += power_at(&s, kx, ky);
    assert_close(total, energy, 1e-12, 0);
    free(img);
    spec_close(&s);
}

static void test_parseval(void **state)
{
    (void)state;
    check_parseval(64, 1);
    check_parseval(15, 2);
    check_parseval(1, 3);
    check_parseval(2, 4);
}

/* The definition, term by term, with the library's normalisation. */
static void test_against_naive_dft(void **state)
{
    (void)state;
    for (uint32_t n = 5; n <= 8; n++) {
        spec s;
        spec_open(&s, n);
        double img[64];
        uint64_t seed = 100 + n;
        for (size_t i = 0; i < (size_t)n * n; i++)
            img[i] = centred_uniform(&seed);
        assert_int_equal(qmc_image_spectrum_accumulate(img, n, s.power, s.work), 0);
        /* Adding a second image adds its periodogram: accumulate twice. */
        assert_int_equal(qmc_image_spectrum_accumulate(img, n, s.power, s.work), 0);
        int km = (int)s.kmax;
        for (int ky = -km; ky <= km; ky++)
            for (int kx = -km; kx <= km; kx++) {
                double re = 0, im = 0;
                for (uint32_t y = 0; y < n; y++)
                    for (uint32_t x = 0; x < n; x++) {
                        double ang = -two_pi * ((double)kx * x + (double)ky * y) / n;
                        re += img[y * n + x] * cos(ang);
                        im += img[y * n + x] * sin(ang);
                    }
                assert_close(power_at(&s, kx, ky), 2.0 * (re * re + im * im) / (n * n), 1e-10,
                             1e-14);
            }
        spec_close(&s);
    }
}

/*
 * White noise of variance 1/12 (uniform on [-1/2, 1/2)): E[P(k)] = 1/12
 * at every k.  Over R images each ring mean averages about R pi b
 * independent exponential variables (P(k) = P(-k) for a real image), so
 * ring b's relative standard deviation is about 1/sqrt(R pi b): 3.5% at
 * b = 1 with R = 256.  The bounds (5 standard deviations per ring, 1% for
 * all rings pooled) are far inside what a wrong normalisation or a lost
 * frequency would give (a factor of n or more).
 */
static void test_white_noise_flat(void **state)
{
    (void)state;
    const uint32_t n = 32, reps = 256;
    const double var = 1.0 / 12.0;
    spec s;
    spec_open(&s, n);
    double img[32 * 32];
    uint64_t seed = 7;
    for (uint32_t r = 0; r < reps; r++) {
        for (size_t i = 0; i < (size_t)n * n; i++)
            img[i] = centred_uniform(&seed);
        assert_int_equal(qmc_image_spectrum_accumulate(img, n, s.power, s.work), 0);
    }
    assert_int_equal(qmc_spectrum_finish(s.power, s.kmax, reps, s.radial), 0);
    double pooled = 0, rings = 0;
    for (uint32_t b = 1; b <= s.kmax; b++) {
        double sd = var / sqrt((double)reps * 3.14159 * b);
        if (fabs(s.radial[b] - var) > 5.0 * sd)
            fail_msg("ring %u: %.5g, want %.5g +- %.3g", b, s.radial[b], var, 5.0 * sd);
        pooled += s.radial[b] * ring_count((int)b, (int)s.kmax);
        rings += ring_count((int)b, (int)s.kmax);
    }
    assert_close(pooled / rings, var, 0.01, 0);
    /* P(0) of zero-mean noise has the same expectation, over reps draws
     * of one exponential: a loose 3-sigma bound. */
    assert_close(s.radial[0], var, 3.0 / sqrt((double)reps), 0);
    spec_close(&s);
}

/* The low band: rings 1 .. kmax / 8 (at least ring 1), never the DC term. */
static void test_low_band(void **state)
{
    (void)state;
    double radial[33];
    for (int b = 0; b <= 32; b++)
        radial[b] = (double)(1u << (b < 20 ? b : 20));
    assert_int_equal(qmc_image_spectrum_low_rings(32), 4);
    assert_int_equal(qmc_image_spectrum_low_rings(64), 8);
    assert_int_equal(qmc_image_spectrum_low_rings(3), 1);
    assert_true(qmc_image_spectrum_low_band(radial, 32) == 2 + 4 + 8 + 16);
    assert_true(qmc_image_spectrum_low_band(radial, 15) == 2);
    assert_true(qmc_image_spectrum_low_band(radial, 0) == 0);
    assert_true(qmc_image_spectrum_low_band(NULL, 32) == 0);
}

static void test_errors(void **state)
{
    (void)state;
    double img[4] = {0.1, 0.2, 0.3, 0.4}, power[9] = {0}, work[64];
    assert_int_equal(qmc_image_spectrum_kmax(2), 1);
    assert_int_equal(qmc_image_spectrum_kmax(3), 1);
    assert_int_equal(qmc_image_spectrum_work_len(0), 0);
    assert_int_equal(qmc_image_spectrum_work_len(QMC_IMAGE_SPECTRUM_MAX_SIDE + 1), 0);
    assert_int_equal(qmc_image_spectrum_work_len(2), 2 * 2 + 2 * 2 * 3);
    assert_int_equal(qmc_image_spectrum_accumulate(NULL, 2, power, work), QMC_EINVAL);
    assert_int_equal(qmc_image_spectrum_accumulate(img, 2, NULL, work), QMC_EINVAL);
    assert_int_equal(qmc_image_spectrum_accumulate(img, 2, power, NULL), QMC_EINVAL);
    assert_int_equal(qmc_image_spectrum_accumulate(img, 0, power, work), QMC_EDOMAIN);
    assert_int_equal(qmc_image_spectrum_accumulate(img, QMC_IMAGE_SPECTRUM_MAX_SIDE + 1, power,
                                                   work),
                     QMC_ETOOBIG);
    img[3] = NAN;
    assert_int_equal(qmc_image_spectrum_accumulate(img, 2, power, work), QMC_EDOMAIN);
    img[3] = INFINITY;
    assert_int_equal(qmc_image_spectrum_accumulate(img, 2, power, work), QMC_EDOMAIN);
    for (size_t i = 0; i < 9; i++)
        assert_true(power[i] == 0.0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cosine_one_ring),
        cmocka_unit_test(test_nyquist_both_sides),
        cmocka_unit_test(test_parseval),
        cmocka_unit_test(test_against_naive_dft),
        cmocka_unit_test(test_white_noise_flat),
        cmocka_unit_test(test_low_band),
        cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
