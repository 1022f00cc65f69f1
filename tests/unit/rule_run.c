/*
 * rule_run.c - one integration of a named test function (rule_run.h).
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <float.h>
#include <math.h>
#include <string.h>

#include "rule_run.h"
#include "qmc/testfn.h"

/* f times 2^e (rule_run_spec_scaled). */
typedef struct scaled_fn {
    const qmc_integrand *f;
    double factor;
} scaled_fn;

static void scaled_eval(const void *ctx, const double *x, size_t n, uint32_t dims, double *out)
{
    const scaled_fn *s = ctx;
    s->f->eval(s->f->ctx, x, n, dims, out);
    for (size_t i = 0; i < n; i++)
        out[i] *= s->factor;
}

rule_outcome rule_run_spec_scaled(const char *name, uint32_t dims, const double *a,
                                  const double *u, const qmc_integrate_spec *s, int e)
{
    qmc_testfn *fn = NULL;
    char why[256];
    size_t np = a ? dims : 0, nu = u ? dims : 0;
    if (qmc_testfn_new(name, dims, a, np, u, nu, &fn, why, sizeof why))
        fail_msg("%s: %s", name, why);
    const qmc_integrand *f = qmc_testfn_integrand(fn);
    scaled_fn sf = {f, ldexp(1.0, e)};
    qmc_integrand g = *f;
    if (e != 0) {
        g.eval = scaled_eval;
        g.ctx = &sf;
        g.exact = ldexp(f->exact, e);
        g.abs_integral = ldexp(f->abs_integral, e);
    }
    qmc_integrate_report rep;
    rule_outcome o;
    o.err = qmc_integrate(s, &g, NULL, NULL, NULL, &rep, why, sizeof why);
    o.res = rep.res;
    o.truth = g.exact;
    o.method_used = rep.method_used;
    memcpy(o.auto_reason, rep.auto_reason, sizeof o.auto_reason);
    qmc_testfn_free(fn);
    return o;
}

rule_outcome rule_run_spec(const char *name, uint32_t dims, const double *a, const double *u,
                           const qmc_integrate_spec *s)
{
    return rule_run_spec_scaled(name, dims, a, u, s, 0);
}

/* method at n_axis points an axis (0: its default), within max_evals (0:
 * the default budget), on f times 2^e; fails the test on an error. */
static rule_outcome run_method(const char *name, uint32_t dims, const double *a,
                               const double *u, qmc_method method, uint32_t n_axis,
                               uint64_t max_evals, int e)
{
    qmc_integrate_spec s;
    qmc_integrate_spec_init(&s);
    s.method = method;
    s.n_axis = n_axis;
    s.n_given = n_axis != 0;
    if (max_evals)
        s.max_evals = max_evals;
    rule_outcome o = rule_run_spec_scaled(name, dims, a, u, &s, e);
    if (o.err)
        fail_msg("%s by %s at 2^%d: error %d", name, qmc_method_name(method), e, o.err);
    return o;
}

rule_outcome rule_run_scaled(const char *name, uint32_t dims, const double *a, const double *u,
                             qmc_method method, uint32_t n_axis, int e)
{
    return run_method(name, dims, a, u, method, n_axis, 0, e);
}

rule_outcome rule_run(const char *name, uint32_t dims, const double *a, const double *u,
                      qmc_method method, uint32_t n_axis, uint64_t max_evals)
{
    return run_method(name, dims, a, u, method, n_axis, max_evals, 0);
}

int rule_covers(const rule_outcome *o)
{
    return fabs(o->res.estimate - o->truth) <=
           3.0 * o->res.error + 64.0 * DBL_EPSILON * fabs(o->truth);
}
