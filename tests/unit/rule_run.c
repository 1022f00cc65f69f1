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

#include "rule_run.h"
#include "qmc/testfn.h"

rule_outcome rule_run_spec(const char *name, uint32_t dims, const double *a, const double *u,
                           const qmc_integrate_spec *s)
{
    qmc_testfn *fn = NULL;
    char why[256];
    size_t np = a ? dims : 0, nu = u ? dims : 0;
    if (qmc_testfn_new(name, dims, a, np, u, nu, &fn, why, sizeof why))
        fail_msg("%s: %s", name, why);
    const qmc_integrand *f = qmc_testfn_integrand(fn);
    qmc_integrate_report rep;
    rule_outcome o;
    o.err = qmc_integrate(s, f, NULL, NULL, NULL, &rep, why, sizeof why);
    o.res = rep.res;
    o.truth = f->exact;
    qmc_testfn_free(fn);
    return o;
}

rule_outcome rule_run(const char *name, uint32_t dims, const double *a, const double *u,
                      qmc_method method, uint32_t n_axis, uint64_t max_evals)
{
    qmc_integrate_spec s;
    qmc_integrate_spec_init(&s);
    s.method = method;
    s.n_axis = n_axis;
    s.n_given = n_axis != 0;
    if (max_evals)
        s.max_evals = max_evals;
    rule_outcome o = rule_run_spec(name, dims, a, u, &s);
    if (o.err)
        fail_msg("%s by %s: error %d", name, qmc_method_name(method), o.err);
    return o;
}

int rule_covers(const rule_outcome *o)
{
    return fabs(o->res.estimate - o->truth) <=
           3.0 * o->res.error + 64.0 * DBL_EPSILON * fabs(o->truth);
}
