/*
 * test_exact_sum.c - the exact quotient sum (core/exact_sum.c) and poly's
 * exact integral built on it, against closed forms written here:
 *   - the shifted Legendre polynomials P~n(x) = sum_k (-1)^(n+k) C(n,k)
 *     C(n+k,k) x^k integrate to exactly 0 on [0,1] for n >= 1 (they are
 *     orthogonal to 1), with coefficients up to 7e15 at n = 22;
 *   - (1 - 2x)^k expanded, sum_j C(k,j) (-2)^j x^j, integrates to 1/(k+1)
 *     for even k and 0 for odd k (substitute t = 1 - 2x), with coefficients
 *     up to 9e13 at k = 31; a sum in doubles gave 0.04761904939854844 for
 *     1/21 and -2.4e-7 for 0;
 *   - rounding: ties to even, subnormal results, overflow, signs, and the
 *     refusals.
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <float.h>
#include <math.h>

#include "exact_sum.h"
#include "qmc/error.h"
#include "qmc/testfn.h"

/* C(n, k) in whole numbers (exact for the sizes here: at most C(44, 22)). */
static uint64_t choose(unsigned n, unsigned k)
{
    uint64_t c = 1;
    for (unsigned i = 1; i <= k; i++)
        c = c * (n - k + i) / i; /* C(n-k+i, i) stays whole at each step */
    return c;
}

/* poly's exact value with coefficients c[0..n). */
static double poly_exact(const double *c, size_t n)
{
    qmc_testfn *fn = NULL;
    char why[128];
    assert_int_equal(qmc_testfn_new("poly", 1, c, n, NULL, 0, &fn, why, sizeof why), 0);
    const qmc_integrand *f = qmc_testfn_integrand(fn);
    assert_true(f->has_exact);
    double v = f->exact;
    qmc_testfn_free(fn);
    return v;
}

static void test_shifted_legendre_integrates_to_zero(void **state)
{
    (void)state;
    for (unsigned n = 1; n <= 22; n++) {
        double c[QMC_TESTFN_MAX_COEFS];
        double biggest = 0;
        for (unsigned k = 0; k <= n; k++) {
            uint64_t m = choose(n, k) * choose(n + k, k);
            assert_true(m < (UINT64_C(1) << 53)); /* exact as a double */
            c[k] = ((n + k) % 2 ? -1.0 : 1.0) * (double)m;
            biggest = fmax(biggest, fabs(c[k]));
        }
        double v = poly_exact(c, n + 1);
        if (v != 0.0)
            fail_msg("P~%u: exact %.17g, want 0 (coefficients to %.3g)", n, v, biggest);
    }
}

static void test_one_minus_2x_power(void **state)
{
    (void)state;
    for (unsigned k = 1; k <= 31; k++) {
        double c[QMC_TESTFN_MAX_COEFS];
        for (unsigned j = 0; j <= k; j++)
            c[j] = (j % 2 ? -1.0 : 1.0) * (double)choose(k, j) * ldexp(1.0, (int)j);
        double want = k % 2 ? 0.0 : 1.0 / (k + 1); /* IEEE division rounds correctly */
        double v = poly_exact(c, k + 1);
        if (v != want)
            fail_msg("(1 - 2x)^%u: exact %.17g, want %.17g", k, v, want);
    }
}

static double qsum(const double *num, const uint32_t *den, size_t n)
{
    double v;
    assert_int_equal(qmc__exact_quotient_sum(num, den, n, &v), 0);
    return v;
}

static void test_rounding(void **state)
{
    (void)state;
    const uint32_t d12[] = {1, 2}, d11[] = {1, 1}, d3[] = {3}, d36[] = {3, 6};
    /* 1 + 2^-53 is halfway between 1 and its successor: ties to even */
    double a[] = {1.0, ldexp(1.0, -52)};
    assert_true(qsum(a, d12, 2) == 1.0);
    /* 1 + 1.5 ulp: halfway between 1 + 1 ulp and 1 + 2 ulp: to the even 2 */
    double b[] = {1.0, 3 * ldexp(1.0, -52)};
    assert_true(qsum(b, d12, 2) == 1.0 + ldexp(1.0, -51));
    /* just above the tie: up */
    double c[] = {1.0, ldexp(1.0, -52) + ldexp(1.0, -104)};
    assert_true(qsum(c, d12, 2) == 1.0 + ldexp(1.0, -52));
    /* the remainder of the division is the sticky bit: 1 + 2^-53 + 2^-53/3 */
    double e[] = {1.0, ldexp(1.0, -52), ldexp(1.0, -52)};
    const uint32_t d126[] = {1, 2, 6};
    assert_true(qsum(e, d126, 3) == 1.0 + ldexp(1.0, -52));
    /* correctly rounded thirds, both signs; 1/3 + 1/6 is exactly 1/2 */
    double one[] = {1.0}, minus[] = {-1.0}, two[] = {1.0, 1.0};
    assert_true(qsum(one, d3, 1) == 1.0 / 3);
    assert_true(qsum(minus, d3, 1) == -1.0 / 3);
    assert_true(qsum(two, d36, 2) == 0.5);
    /* subnormals: half the smallest ties to 0, 1.5 of it to 2 of it */
    double s1[] = {0.0, ldexp(1.0, -1074)}, s3[] = {0.0, 3 * ldexp(1.0, -1074)};
    assert_true(qsum(s1, d12, 2) == 0.0);
    assert_true(qsum(s3, d12, 2) == 2 * ldexp(1.0, -1074));
    /* cancellation to exactly 0, and at the top of the range */
    double z[] = {1e300, -1e300}, top[] = {DBL_MAX, -DBL_MAX};
    assert_true(qsum(z, d11, 2) == 0.0);
    assert_true(qsum(top, d12, 2) == DBL_MAX / 2);
    double over[] = {DBL_MAX, DBL_MAX};
    assert_true(isinf(qsum(over, d12, 2)) && qsum(over, d12, 2) > 0);
    /* and poly with such coefficients has no finite exact value */
    qmc_testfn *fn = NULL;
    char why[128];
    assert_int_equal(qmc_testfn_new("poly", 1, over, 2, NULL, 0, &fn, why, sizeof why), 0);
    assert_false(qmc_testfn_integrand(fn)->has_exact);
    qmc_testfn_free(fn);
}

static void test_refusals(void **state)
{
    (void)state;
    double v = 0;
    double one[] = {1.0}, nan1[] = {NAN};
    const uint32_t zero[] = {0}, big[] = {QMC__EXACT_MAX_DEN + 1}, ok[] = {1};
    assert_int_equal(qmc__exact_quotient_sum(one, zero, 1, &v), QMC_EINVAL);
    assert_true(isnan(v));
    assert_int_equal(qmc__exact_quotient_sum(one, big, 1, &v), QMC_EINVAL);
    assert_int_equal(qmc__exact_quotient_sum(nan1, ok, 1, &v), QMC_EINVAL);
    assert_int_equal(qmc__exact_quotient_sum(one, ok, QMC__EXACT_MAX_TERMS + 1, &v), QMC_EINVAL);
    assert_int_equal(qmc__exact_quotient_sum(NULL, NULL, 0, &v), 0);
    assert_true(v == 0.0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_shifted_legendre_integrates_to_zero),
        cmocka_unit_test(test_one_minus_2x_power),
        cmocka_unit_test(test_rounding),
        cmocka_unit_test(test_refusals),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
