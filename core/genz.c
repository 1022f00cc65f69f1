/*
 * genz.c - Genz's six test families: evaluation and closed-form integrals.
 *
 * Every closed form here is written so that it sums or multiplies only
 * terms of one sign, so it keeps full double precision whatever the
 * dimension; products over up to QMC_TESTFN_MAX_DIMS factors carry a
 * separate binary exponent so that a representable answer is never lost to
 * an intermediate overflow or underflow.  The corner peak, whose textbook
 * formula is an alternating sum over the 2^dims cube vertices, is computed
 * from a positive one-dimensional integral instead (see corner_exact).
 *
 * Must not: allocate, or write to the testfn, during eval; read a clock or
 * keep state.  Parameters arrive validated by testfn.c (a_i > 0 and finite,
 * u_i in [0,1], dims of each).
 */
#include <float.h>
#include <math.h>

#include "testfn_impl.h"

#define PI 3.14159265358979323846

/* ---- a product with its own exponent ------------------------------------ */

typedef struct xprod {
    double m; /* 0 or in [0.5, 1) */
    long e;   /* value = m * 2^e */
} xprod;

static void xp_init(xprod *p)
{
    p->m = 1.0;
    p->e = 0;
}

/* Multiplies by a finite positive factor; frexp is exact, so the only
 * rounding is the multiplication itself. */
static void xp_mul(xprod *p, double f)
{
    int k;
    p->m = frexp(p->m * f, &k);
    p->e += k;
}

static double xp_value(const xprod *p)
{
    if (p->m == 0.0 || isinf(p->m))
        return p->m;
    if (p->e > DBL_MAX_EXP)
        return HUGE_VAL;
    if (p->e < DBL_MIN_EXP - DBL_MANT_DIG - 1)
        return 0.0;
    return ldexp(p->m, (int)p->e);
}

/*
 * Sets exact and abs for a family whose integrand is positive.  A value
 * below DBL_MIN has lost relative precision to underflow and one past
 * DBL_MAX is infinite: neither is offered as exact.
 */
static void set_positive(qmc_testfn *fn, double v)
{
    qmc__testfn_set_exact(fn, v, 1, v);
    if (!(v >= DBL_MIN)) {
        fn->view.has_exact = 0;
        fn->view.has_abs_integral = 0;
    }
}

/* The integrand contract passes dims; a caller passing another value than
 * the function's own gets NaN rather than reads past a row. */
static int dims_mismatch(const qmc_testfn *fn, uint32_t dims, size_t n,
                         double *out)
{
    if (dims == fn->dims)
        return 0;
    for (size_t k = 0; k < n; k++)
        out[k] = NAN;
    return 1;
}

/* ---- oscillatory: cos(2 pi u1 + sum a_i x_i) ------------------------------
 *
 * int = Re(e^{i 2 pi u1} prod_j (e^{i a_j} - 1) / (i a_j)), and
 * (e^{ia} - 1)/(ia) = e^{ia/2} sin(a/2)/(a/2), so
 * int = cos(2 pi u1 + sum a_j / 2) prod_j 2 sin(a_j / 2) / a_j.
 * The sinc factors lose nothing for small a.  |f| has no closed form.
 */
void qmc__genz_osc_setup(qmc_testfn *fn)
{
    double phase = 0.0;
    xprod p;
    xp_init(&p);
    int sign = 1;
    for (uint32_t j = 0; j < fn->dims; j++) {
        double h = 0.5 * fn->a[j];
        double f = sin(h) / h;
        phase += h;
        if (f < 0) {
            sign = -sign;
            f = -f;
        }
        if (f == 0) {
            p.m = 0;
            break;
        }
        xp_mul(&p, f);
    }
    fn->c0 = 2.0 * PI * fn->u[0];
    double v = sign * cos(fn->c0 + phase) * xp_value(&p);
    qmc__testfn_set_exact(fn, v, 0, 0.0);
}

void qmc__genz_osc_eval(const void *ctx, const double *x, size_t n,
                        uint32_t dims, double *out)
{
    const qmc_testfn *fn = ctx;
    if (dims_mismatch(fn, dims, n, out))
        return;
    for (size_t k = 0; k < n; k++, x += dims) {
        double s = fn->c0;
        for (uint32_t j = 0; j < dims; j++)
            s += fn->a[j] * x[j];
        out[k] = cos(s);
    }
}

/* ---- product peak: prod 1 / (a_i^-2 + (x_i - u_i)^2) ---------------------
 *
 * int_0^1 dx / (a^-2 + (x - u)^2) = a (atan(a (1 - u)) + atan(a u)): two
 * non-negative terms.
 */
void qmc__genz_ppeak_setup(qmc_testfn *fn)
{
    xprod p;
    xp_init(&p);
    for (uint32_t j = 0; j < fn->dims; j++) {
        double a = fn->a[j], u = fn->u[j];
        fn->w[j] = 1.0 / (a * a);
        xp_mul(&p, a * (atan(a * (1.0 - u)) + atan(a * u)));
    }
    set_positive(fn, xp_value(&p));
}

void qmc__genz_ppeak_eval(const void *ctx, const double *x, size_t n,
                          uint32_t dims, double *out)
{
    const qmc_testfn *fn = ctx;
    if (dims_mismatch(fn, dims, n, out))
        return;
    for (size_t k = 0; k < n; k++, x += dims) {
        double p = 1.0;
        for (uint32_t j = 0; j < dims; j++) {
            double t = x[j] - fn->u[j];
            p /= fn->w[j] + t * t;
        }
        out[k] = p;
    }
}

/* ---- corner peak: (1 + sum a_i x_i)^-(d+1) -------------------------------
 *
 * The textbook closed form (1/(d! prod a)) sum_v (-1)^|v| / (1 + a.v) over
 * the 2^d vertices v adds terms of size ~1 to get a result of size
 * ~d! prod a_i: in double it is wrong past d ~ 10 for Genz's parameters,
 * and no fixed extra precision rescues it for large d.
 *
 * We use instead t^-(d+1) = (1/d!) int_0^inf s^d e^{-ts} ds with t = 1+a.x
 * and integrate over the cube first (Fubini; everything is positive):
 *
 *   I = (1/d!) int_0^inf s^d e^{-s} prod_i phi(a_i s) ds,
 *   phi(z) = (1 - e^{-z}) / z = int_0^1 e^{-z x} dx.
 *
 * With s = e^y the integrand becomes
 *   F(y) = s e^{-s} prod_i (-expm1(-a_i s)) / (i a_i),
 * a product of positive factors.  log F is concave in y (y - e^y is, and
 * d/dy log(1 - e^{-a e^y}) = w/(e^w - 1), w = a e^y, decreases), so F is a
 * single smooth bump, and F is entire in y.  The trapezoidal rule on the
 * whole line converges geometrically for such functions (Trefethen and
 * Weideman, "The exponentially convergent trapezoidal rule", SIAM Review
 * 56, 2014): we centre the grid on the mode y*, take the step as half the
 * bump's width 1/sqrt(-(log F)''(y*)), and march out until F falls below
 * 1e-20 F(y*) (log-concavity bounds the rest of the tail by the same
 * order).  Then the step is halved, reusing the nodes, and the two sums
 * must agree to 1e-14: the a-posteriori check.
 *
 * Rounding: each F is ~3d + 10 correctly rounded operations on positive
 * numbers, and the positive sum is compensated, so the relative error is
 * below (3d + 12) u, u = 2^-53, plus the quadrature difference: 1.2e-14 at
 * d = 30, 3.5e-13 at d = 1024 as a worst case.  Measured against mpmath
 * vertex sums carried to enough digits to survive their cancellation
 * (tests/vectors/testfn_vectors.h): at most 4e-16 at d <= 30, 1.6e-15 at
 * d = 100 and 6.8e-15 at d = 1024.  So the value is trusted for every dims
 * this module takes; it is refused (QMC_ERANGE, has_exact = 0) only when
 * the check fails or the value is below DBL_MIN, where it has lost relative
 * precision to underflow.  Cost: ~100-300 nodes of d factors each, about
 * 2 ms at d = 1024, once per qmc_testfn_new.
 */

/* Cody and Waite's split of ln 2 (fdlibm's ln2_hi has 32 trailing zero
 * bits, so n * LN2_HI is exact for |n| < 2^20). */
#define LN2_HI 6.93147180369123816490e-01
#define LN2_LO 1.90821492927058770002e-10

/* F(log s) as a scaled product: s e^{-s} prod (-expm1(-a_i s))/(i a_i). */
static xprod corner_f(uint32_t d, const double *a, double s)
{
    xprod p;
    xp_init(&p);
    /* e^{-s} = e^{-r} 2^{-n}, r = s - n ln 2 in [-ln2/2, ln2/2]: no
     * underflow however large s is. */
    double n = nearbyint(s / (LN2_HI + LN2_LO));
    double r = (s - n * LN2_HI) - n * LN2_LO;
    int k;
    p.m = frexp(s * exp(-r), &k);
    p.e = k - (long)n;
    for (uint32_t i = 0; i < d; i++) {
        double f = -expm1(-a[i] * s) / a[i];
        xp_mul(&p, f / (double)(i + 1));
    }
    return p;
}

/* F(y) / F(y*) given F(y*) as ref. */
static double corner_ratio(uint32_t d, const double *a, double y,
                           const xprod *ref)
{
    xprod p = corner_f(d, a, exp(y));
    long de = p.e - ref->e;
    if (p.m == 0.0 || de < -1100)
        return 0.0;
    return ldexp(p.m / ref->m, (int)de);
}

/* Neumaier's compensated sum of positive terms. */
typedef struct ksum {
    double s, c;
} ksum;

static void ks_add(ksum *k, double x)
{
    double t = k->s + x;
    if (fabs(k->s) >= fabs(x))
        k->c += (k->s - t) + x;
    else
        k->c += (x - t) + k->s;
    k->s = t;
}

/* Sum of F(y* + (j + offset) h) / F(y*) over all integers j, marching out
 * from the mode until the terms fall below 1e-20.  Returns -1 when more
 * than max_nodes are needed. */
#define CORNER_TAIL 1e-20
#define CORNER_MAX_NODES 200000

static double corner_sum(uint32_t d, const double *a, double ystar, double h,
                         double offset, const xprod *ref)
{
    ksum k = {0, 0};
    long nodes = 0;
    for (int dir = 1; dir >= -1; dir -= 2) {
        /* Right: j = 0, 1, ... (offset, 1 + offset, ...); left: j = -1, -2,
         * ... so every node is visited once. */
        for (long j = dir > 0 ? 0 : -1;; j += dir) {
            double r = corner_ratio(d, a, ystar + ((double)j + offset) * h,
                                    ref);
            ks_add(&k, r);
            if (++nodes > CORNER_MAX_NODES)
                return -1.0;
            /* Past the mode the terms only decrease (log-concavity). */
            if (r < CORNER_TAIL && (double)j * dir > 0)
                break;
        }
    }
    return k.s + k.c;
}

/* w / expm1(w), the derivative of log(1 - e^{-w}) with respect to log w. */
static double bern(double w)
{
    if (w < 1e-300)
        return 1.0;
    double e = expm1(w);
    return isinf(e) ? 0.0 : w / e;
}

int qmc__genz_corner_exact(uint32_t d, const double *a, double *value,
                           double *err_est)
{
    /* The mode: (log F)'(y) = 1 - s + sum bern(a_i s) decreases in s from
     * > 0 at s = 1 to <= 0 at s = d + 1 (bern is in (0, 1]); bisect. */
    double lo = 1.0, hi = (double)d + 1.0;
    for (int it = 0; it < 80 && hi - lo > 1e-12 * hi; it++) {
        double s = 0.5 * (lo + hi), g = 1.0 - s;
        for (uint32_t i = 0; i < d; i++)
            g += bern(a[i] * s);
        if (g > 0)
            lo = s;
        else
            hi = s;
    }
    double sstar = 0.5 * (lo + hi);
    /* Curvature -(log F)''(y*) = s + sum w (-bern'(w)) with
     * -bern'(w) = e^{-w} (w + expm1(-w)) / expm1(-w)^2 (-> 1/2 as w -> 0). */
    double kappa = sstar;
    for (uint32_t i = 0; i < d; i++) {
        double w = a[i] * sstar, mb;
        if (w < 1e-4)
            mb = 0.5;
        else if (w > 700)
            mb = 0.0;
        else {
            double em = expm1(-w);
            mb = exp(-w) * (w + em) / (em * em);
        }
        kappa += w * mb;
    }
    double ystar = log(sstar);
    double h = 0.5 / sqrt(kappa);
    xprod ref = corner_f(d, a, exp(ystar));

    double sum = corner_sum(d, a, ystar, h, 0.0, &ref);
    double t_old = h * sum, t_new = t_old, diff = HUGE_VAL;
    int ok = 0;
    for (int level = 0; level < 5 && sum > 0; level++) {
        double mid = corner_sum(d, a, ystar, h, 0.5, &ref);
        if (mid < 0)
            break;
        sum += mid;
        h *= 0.5;
        t_new = h * sum;
        diff = fabs(t_new - t_old);
        if (diff <= 1e-14 * t_new) {
            ok = 1;
            break;
        }
        t_old = t_new;
    }
    xprod v = ref;
    if (t_new > 0)
        xp_mul(&v, t_new);
    else
        v.m = 0.0;
    *value = xp_value(&v);
    *err_est = (t_new > 0 ? diff / t_new : HUGE_VAL) +
               (3.0 * d + 12.0) * 0.5 * DBL_EPSILON;
    if (!ok || !(*value >= DBL_MIN))
        return QMC_ERANGE;
    return 0;
}

void qmc__genz_corner_setup(qmc_testfn *fn)
{
    double v, err;
    int rc = qmc__genz_corner_exact(fn->dims, fn->a, &v, &err);
    fn->c0 = -((double)fn->dims + 1.0);
    qmc__testfn_set_exact(fn, v, 1, v);
    if (rc != 0) {
        fn->view.has_exact = 0;
        fn->view.has_abs_integral = 0;
    }
}

void qmc__genz_corner_eval(const void *ctx, const double *x, size_t n,
                           uint32_t dims, double *out)
{
    const qmc_testfn *fn = ctx;
    if (dims_mismatch(fn, dims, n, out))
        return;
    for (size_t k = 0; k < n; k++, x += dims) {
        double s = 1.0;
        for (uint32_t j = 0; j < dims; j++)
            s += fn->a[j] * x[j];
        out[k] = pow(s, fn->c0);
    }
}

/* ---- gaussian: exp(-sum a_i^2 (x_i - u_i)^2) ------------------------------
 *
 * int_0^1 e^{-a^2 (x-u)^2} dx = sqrt(pi) / (2a) (erf(a (1-u)) + erf(a u)).
 */
void qmc__genz_gauss_setup(qmc_testfn *fn)
{
    xprod p;
    xp_init(&p);
    for (uint32_t j = 0; j < fn->dims; j++) {
        double a = fn->a[j], u = fn->u[j];
        fn->w[j] = a * a;
        xp_mul(&p, 0.5 * sqrt(PI) * (erf(a * (1.0 - u)) + erf(a * u)) / a);
    }
    set_positive(fn, xp_value(&p));
}

void qmc__genz_gauss_eval(const void *ctx, const double *x, size_t n,
                          uint32_t dims, double *out)
{
    const qmc_testfn *fn = ctx;
    if (dims_mismatch(fn, dims, n, out))
        return;
    for (size_t k = 0; k < n; k++, x += dims) {
        double s = 0.0;
        for (uint32_t j = 0; j < dims; j++) {
            double t = x[j] - fn->u[j];
            s += fn->w[j] * t * t;
        }
        out[k] = exp(-s);
    }
}

/* ---- continuous: exp(-sum a_i |x_i - u_i|) --------------------------------
 *
 * int_0^1 e^{-a |x-u|} dx = (2 - e^{-au} - e^{-a(1-u)}) / a
 *                         = (-expm1(-au) - expm1(-a(1-u))) / a.
 */
void qmc__genz_cont_setup(qmc_testfn *fn)
{
    xprod p;
    xp_init(&p);
    for (uint32_t j = 0; j < fn->dims; j++) {
        double a = fn->a[j], u = fn->u[j];
        xp_mul(&p, (-expm1(-a * u) - expm1(-a * (1.0 - u))) / a);
    }
    set_positive(fn, xp_value(&p));
    qmc__testfn_break_at_u1(fn); /* in 1D the kink is at u1 */
}

void qmc__genz_cont_eval(const void *ctx, const double *x, size_t n,
                         uint32_t dims, double *out)
{
    const qmc_testfn *fn = ctx;
    if (dims_mismatch(fn, dims, n, out))
        return;
    for (size_t k = 0; k < n; k++, x += dims) {
        double s = 0.0;
        for (uint32_t j = 0; j < dims; j++)
            s += fn->a[j] * fabs(x[j] - fn->u[j]);
        out[k] = exp(-s);
    }
}

/* ---- discontinuous: 0 past u1 (and u2), else exp(sum a_i x_i) -------------
 *
 * int = prod_{j<2} expm1(a_j u_j)/a_j * prod_{j>=2} expm1(a_j)/a_j.  The
 * integrand overflows to +inf when sum a_i x_i > ~709; so may the value.
 */
void qmc__genz_disc_setup(qmc_testfn *fn)
{
    xprod p;
    xp_init(&p);
    for (uint32_t j = 0; j < fn->dims; j++) {
        double a = fn->a[j], t = j < 2 ? fn->u[j] : 1.0;
        double f = expm1(a * t) / a;
        if (f == 0.0) { /* u_j = 0: the integrand vanishes a.e. */
            p.m = 0.0;
            break;
        }
        if (isinf(f)) {
            p.m = HUGE_VAL;
            break;
        }
        xp_mul(&p, f);
    }
    double v = xp_value(&p);
    /* A zero from u_j = 0 is exact, unlike an underflow. */
    if (v == 0.0 && p.m == 0.0)
        qmc__testfn_set_exact(fn, 0.0, 1, 0.0);
    else
        set_positive(fn, v);
    qmc__testfn_break_at_u1(fn); /* in 1D the jump is at u1 */
}

void qmc__genz_disc_eval(const void *ctx, const double *x, size_t n,
                         uint32_t dims, double *out)
{
    const qmc_testfn *fn = ctx;
    if (dims_mismatch(fn, dims, n, out))
        return;
    for (size_t k = 0; k < n; k++, x += dims) {
        if (x[0] > fn->u[0] || (dims > 1 && x[1] > fn->u[1])) {
            out[k] = 0.0;
            continue;
        }
        double s = 0.0;
        for (uint32_t j = 0; j < dims; j++)
            s += fn->a[j] * x[j];
        out[k] = exp(s);
    }
}
