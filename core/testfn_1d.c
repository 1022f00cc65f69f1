/*
 * testfn_1d.c - one-dimensional test functions on [0,1] with exact
 * integrals, for quadrature rules:
 *
 *   poly      c0 + c1 x + ... (a = coefficients; default x^5), exact
 *             sum c_k / (k + 1): shows a rule's degree of exactness
 *   exp       e^(a1 x), exact expm1(a1) / a1 (default a1 = 1: e - 1)
 *   cos       cos(a1 x), exact sin(a1) / a1 (default a1 = 1)
 *   inv-sqrt  x^-1/2, exact 2 (+inf at x = 0: integrators count it)
 *   log       log x, exact -1 (-inf at x = 0)
 *   step      1 for x < u1 else 0, exact u1 (default u1 = 0.3)
 *
 * Must not: allocate or write to the testfn during eval.  Parameters arrive
 * validated and defaulted by testfn.c; dims is 1.
 */
#include <math.h>

#include "exact_sum.h"
#include "testfn_impl.h"

#define PI 3.14159265358979323846

/* Every eval here is for dims == 1; another dims gets NaN rather than a
 * misread row. */
static int bad_dims(uint32_t dims, size_t n, double *out)
{
    if (dims == 1)
        return 0;
    for (size_t k = 0; k < n; k++)
        out[k] = NAN;
    return 1;
}

/* ---- poly ---------------------------------------------------------------- */

void qmc__fn1d_poly_setup(qmc_testfn *fn)
{
    /* sum c_k / (k + 1), exactly and rounded once (exact_sum.h): a sum in
     * doubles kept none of the digits of an integral whose coefficients
     * cancel ((1 - 2x)^25 expanded: -2.4e-7 for 0).  The registry caps the
     * coefficients at QMC_TESTFN_MAX_COEFS (32), the exact sum's largest
     * denominator. */
    _Static_assert(QMC_TESTFN_MAX_COEFS <= QMC__EXACT_MAX_DEN, "poly degree past the exact sum");
    uint32_t den[QMC_TESTFN_MAX_COEFS];
    int nonneg = 1;
    for (size_t k = 0; k < fn->n_a; k++) {
        den[k] = (uint32_t)(k + 1);
        nonneg &= fn->a[k] >= 0.0;
    }
    double v = NAN;
    if (fn->n_a > QMC_TESTFN_MAX_COEFS || qmc__exact_quotient_sum(fn->a, den, fn->n_a, &v) != 0)
        v = NAN; /* not reached: the registry checked count and finiteness */
    /* With every coefficient >= 0 the polynomial is >= 0 on [0,1]. */
    qmc__testfn_set_exact(fn, v, nonneg, v);
}

void qmc__fn1d_poly_eval(const void *ctx, const double *x, size_t n,
                         uint32_t dims, double *out)
{
    const qmc_testfn *fn = ctx;
    if (bad_dims(dims, n, out))
        return;
    for (size_t k = 0; k < n; k++) {
        double p = 0.0;
        for (size_t j = fn->n_a; j-- > 0;)
            p = p * x[k] + fn->a[j];
        out[k] = p;
    }
}

/* ---- exp ----------------------------------------------------------------- */

void qmc__fn1d_exp_setup(qmc_testfn *fn)
{
    double v = expm1(fn->a[0]) / fn->a[0];
    qmc__testfn_set_exact(fn, v, 1, v);
}

void qmc__fn1d_exp_eval(const void *ctx, const double *x, size_t n,
                        uint32_t dims, double *out)
{
    const qmc_testfn *fn = ctx;
    if (bad_dims(dims, n, out))
        return;
    for (size_t k = 0; k < n; k++)
        out[k] = exp(fn->a[0] * x[k]);
}

/* ---- cos ----------------------------------------------------------------- */

/*
 * int_0^1 |cos(a x)| dx = (1/a) int_0^a |cos t| dt.  |cos| has period pi
 * and integral 2 per period; on [0, r], r < pi, the integral is sin r up to
 * pi/2 and 2 - sin r past it.
 */
static double abs_cos_integral(double a)
{
    double periods = floor(a / PI);
    double r = a - periods * PI;
    double part = r <= 0.5 * PI ? sin(r) : 2.0 - sin(r);
    return (2.0 * periods + part) / a;
}

void qmc__fn1d_cos_setup(qmc_testfn *fn)
{
    double a = fn->a[0];
    qmc__testfn_set_exact(fn, sin(a) / a, 1, abs_cos_integral(a));
}

void qmc__fn1d_cos_eval(const void *ctx, const double *x, size_t n,
                        uint32_t dims, double *out)
{
    const qmc_testfn *fn = ctx;
    if (bad_dims(dims, n, out))
        return;
    for (size_t k = 0; k < n; k++)
        out[k] = cos(fn->a[0] * x[k]);
}

/* ---- inv-sqrt and log: integrable endpoint singularities ----------------- */

void qmc__fn1d_invsqrt_setup(qmc_testfn *fn)
{
    qmc__testfn_set_exact(fn, 2.0, 1, 2.0);
}

void qmc__fn1d_invsqrt_eval(const void *ctx, const double *x, size_t n,
                            uint32_t dims, double *out)
{
    (void)ctx;
    if (bad_dims(dims, n, out))
        return;
    for (size_t k = 0; k < n; k++)
        out[k] = 1.0 / sqrt(x[k]);
}

void qmc__fn1d_log_setup(qmc_testfn *fn)
{
    qmc__testfn_set_exact(fn, -1.0, 1, 1.0);
}

void qmc__fn1d_log_eval(const void *ctx, const double *x, size_t n,
                        uint32_t dims, double *out)
{
    (void)ctx;
    if (bad_dims(dims, n, out))
        return;
    for (size_t k = 0; k < n; k++)
        out[k] = log(x[k]);
}

/* ---- step ---------------------------------------------------------------- */

void qmc__fn1d_step_setup(qmc_testfn *fn)
{
    qmc__testfn_set_exact(fn, fn->u[0], 1, fn->u[0]);
    qmc__testfn_break_at_u1(fn);
}

void qmc__fn1d_step_eval(const void *ctx, const double *x, size_t n,
                         uint32_t dims, double *out)
{
    const qmc_testfn *fn = ctx;
    if (bad_dims(dims, n, out))
        return;
    for (size_t k = 0; k < n; k++)
        out[k] = x[k] < fn->u[0] ? 1.0 : 0.0;
}
