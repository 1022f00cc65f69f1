/*
 * stability_cases.c - the stability suite's shared runner and closed
 * forms (stability_cases.h).
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <string.h>

#include "qmc/testfn.h"

#include "stability_cases.h"

/* One qmc_integrate call on the test function; audit: the audit's budget
 * and seed before tweak. */
static run_out run_case(const char *name, uint32_t dims, const double *a, const double *u,
                        qmc_method method, int audit, void (*tweak)(qmc_integrate_spec *))
{
    qmc_testfn *fn = NULL;
    char why[256];
    if (qmc_testfn_new(name, dims, a, a ? dims : 0, u, u ? dims : 0, &fn, why, sizeof why) != 0)
        fail_msg("%s", why);
    qmc_integrate_spec s;
    qmc_integrate_spec_init(&s);
    s.method = method;
    if (method == QMC_METHOD_RQMC)
        qmc_sampling_spec_init(&s.sampling, QMC_SAMPLER_RQMC);
    if (audit) {
        s.max_evals = 20000000;
        s.sampling.seed = 12345;
    }
    if (tweak)
        tweak(&s);
    run_out o;
    memset(&o, 0, sizeof o);
    o.err = qmc_integrate(&s, qmc_testfn_integrand(fn), NULL, NULL, NULL, &o.rep, o.why,
                          sizeof o.why);
    qmc_testfn_free(fn);
    return o;
}

run_out run(const char *name, uint32_t dims, qmc_method method,
            void (*tweak)(qmc_integrate_spec *))
{
    return run_case(name, dims, NULL, NULL, method, 0, tweak);
}

run_out run_au(const char *name, uint32_t dims, const double *a, const double *u,
               qmc_method method, void (*tweak)(qmc_integrate_spec *))
{
    return run_case(name, dims, a, u, method, 1, tweak);
}

double gaussian_truth(uint32_t d, const double *a, const double *u)
{
    double p = 1.0;
    for (uint32_t j = 0; j < d; j++)
        p *= sqrt(3.14159265358979323846) / (2.0 * a[j]) * (erf(a[j] * (1.0 - u[j])) + erf(a[j] * u[j]));
    return p;
}

double discontinuous_truth(uint32_t d, const double *a, const double *u)
{
    double p = 1.0;
    for (uint32_t j = 0; j < d; j++)
        p *= j < 2 ? expm1(a[j] * u[j]) / a[j] : expm1(a[j]) / a[j];
    return p;
}
