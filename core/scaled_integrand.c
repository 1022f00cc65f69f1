/*
 * scaled_integrand.c - f seen at the scale of a rule's result
 * (scaled_integrand.h says why).
 */
#include <math.h>

#include "scaled_integrand.h"

static void scaled_eval(const void *ctx, const double *x, size_t n, uint32_t dims, double *out)
{
    const qmc__scaled_integrand *s = ctx;
    s->f->eval(s->f->ctx, x, n, dims, out);
    for (size_t i = 0; i < n; i++)
        out[i] *= s->factor;
}

void qmc__unscale_result(qmc_result *r, int e)
{
    if (e == 0)
        return;
    r->estimate = ldexp(r->estimate, e);
    r->error = ldexp(r->error, e);
    r->ci_low = ldexp(r->ci_low, e);
    r->ci_high = ldexp(r->ci_high, e);
    r->abs_integral = ldexp(r->abs_integral, e);
}

static uint32_t scaled_audit(const void *ctx, const qmc_result *res)
{
    const qmc__scaled_integrand *s = ctx;
    qmc_result r = *res;
    qmc__unscale_result(&r, s->e);
    return s->f->audit(s->f->ctx, &r);
}

/* The exponent to scale f by for a rule result of this size (0: none). */
static int scale_exponent(const qmc_result *res)
{
    const double size = fmax(fabs(res->estimate), res->abs_integral);
    if (!(size > 0.0) || !isfinite(size))
        return 0;
    /* a subnormal integral's exponent reaches -1074, and 2^1074 is inf */
    const int e = ilogb(size) < -1022 ? -1022 : ilogb(size);
    return e > QMC__SCALE_PAST || e < -QMC__SCALE_PAST ? e : 0;
}

void qmc__scaled_integrand_init(qmc__scaled_integrand *s, const qmc_integrand *f,
                                const qmc_result *res)
{
    s->f = f;
    s->e = scale_exponent(res);
    s->factor = ldexp(1.0, -s->e);
    s->g = *f;
    if (s->e == 0)
        return;
    s->g.eval = scaled_eval;
    s->g.ctx = s;
    s->g.exact = ldexp(f->exact, -s->e);
    s->g.abs_integral = ldexp(f->abs_integral, -s->e);
    s->g.audit = f->audit ? scaled_audit : NULL;
}
