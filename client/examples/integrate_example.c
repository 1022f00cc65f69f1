/*
 * integrate_example.c - integrating a function of your own in-process
 * with libqmc, two ways, and checking that they agree bit for bit:
 *
 *   1. the callback API: qmc_integrate calls your function with batches
 *      of points (qmc/integrate.h);
 *   2. the ask/tell API: a session hands you batches of points and you
 *      hand back the values, for when nobody can call your function back
 *      - it runs in another process, on another machine, or behind an
 *      instrument (qmc/session.h).
 *
 * The function is f(x) = exp(-|x|^2) on the unit cube in 3 dimensions,
 * whose integral is (sqrt(pi)/2 erf(1))^3, so the answer can be checked.
 * Build against an installed qmcd (make install):
 *
 *   cc -std=c11 integrate_example.c $(pkg-config --cflags --libs qmc) -o integrate_example
 *
 * and run it without arguments.  It exits 1 if the two ways disagree or
 * the interval misses the true value.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <qmc/integrate.h>
#include <qmc/session.h>

enum { DIMS = 3 };

/* Your function, at one point. */
static double my_f(const double *x)
{
    double r2 = 0.0;
    for (int j = 0; j < DIMS; j++)
        r2 += x[j] * x[j];
    return exp(-r2);
}

/* 1. The callback API: a batch of n points, row-major, n x dims. */
static void my_eval(const void *ctx, const double *x, size_t n, uint32_t dims, double *out)
{
    (void)ctx;
    for (size_t i = 0; i < n; i++)
        out[i] = my_f(x + i * dims);
}

static int by_callback(const qmc_integrate_spec *spec, qmc_integrate_report *rep)
{
    qmc_integrand f = {.eval = my_eval, .dims = DIMS, .smoothness = QMC_SMOOTH_ANALYTIC,
                       .name = "my-gaussian"};
    char why[256];
    int err = qmc_integrate(spec, &f, NULL, NULL, NULL, rep, why, sizeof why);
    if (err)
        fprintf(stderr, "integrate_example: %s\n", why);
    return err;
}

/* 2. The ask/tell API: you own the loop. */
static int by_session(const qmc_integrate_spec *spec, qmc_integrate_report *rep,
                      qmc_session_report *status)
{
    qmc_session_spec ss;
    qmc_session_spec_init(&ss);
    ss.integrate = *spec;
    ss.dims = DIMS;
    ss.smoothness = QMC_SMOOTH_ANALYTIC; /* what you know about f: here, smooth */
    char why[256];
    qmc_session *s = NULL;
    int err = qmc_session_new(&ss, &s, why, sizeof why);
    if (err) {
        fprintf(stderr, "integrate_example: %s\n", why);
        return err;
    }
    double *vals = NULL;
    size_t cap = 0;
    for (;;) {
        qmc_session_batch b;
        if ((err = qmc_session_ask(s, &b)) != 0 || b.count == 0)
            break; /* count 0: done */
        if (b.count > cap) {
            double *more = realloc(vals, b.count * sizeof *vals);
            if (!more) {
                err = QMC_ENOMEM;
                break;
            }
            vals = more;
            cap = b.count;
        }
        for (size_t i = 0; i < b.count; i++) /* evaluate wherever you like */
            vals[i] = my_f(b.points + i * b.dims);
        if ((err = qmc_session_tell(s, b.seq, vals, b.count, why, sizeof why)) != 0) {
            fprintf(stderr, "integrate_example: %s\n", why);
            break;
        }
    }
    free(vals);
    if (!err) {
        qmc_session_status(s, status);
        err = qmc_session_result(s, rep, why, sizeof why);
        if (err)
            fprintf(stderr, "integrate_example: %s\n", why);
    }
    qmc_session_free(s);
    return err;
}

static void print_flags(uint32_t flags)
{
    if (!flags) {
        printf(" none");
        return;
    }
    for (uint32_t bit = 1; bit; bit <<= 1)
        if (flags & bit)
            printf(" %s", qmc_flag_key(bit));
}

int main(void)
{
    const double exact = pow(0.5 * sqrt(acos(-1.0)) * erf(1.0), DIMS);
    const qmc_method methods[] = {QMC_METHOD_AUTO, QMC_METHOD_RQMC};
    int bad = 0;
    for (size_t i = 0; i < sizeof methods / sizeof methods[0]; i++) {
        qmc_integrate_spec spec;
        qmc_integrate_spec_init(&spec);
        spec.method = methods[i];
        if (methods[i] == QMC_METHOD_RQMC)
            qmc_sampling_spec_init(&spec.sampling, QMC_SAMPLER_RQMC);
        spec.tol_rel = 1e-6;
        spec.max_evals = 10000000;
        qmc_integrate_report a, b;
        qmc_session_report status;
        if (by_callback(&spec, &a) != 0 || by_session(&spec, &b, &status) != 0)
            return 1;
        const int same = memcmp(&a.res.estimate, &b.res.estimate, sizeof(double)) == 0 &&
                         memcmp(&a.res.error, &b.res.error, sizeof(double)) == 0 &&
                         a.res.evals == b.res.evals && a.res.flags == b.res.flags;
        const int covers = a.res.ci_low <= exact && exact <= a.res.ci_high;
        printf("%s (%s): %.15g +- %.2g, %llu evaluations, flags:", qmc_method_name(methods[i]),
               qmc_method_name(a.method_used), a.res.estimate, a.res.error,
               (unsigned long long)a.res.evals);
        print_flags(a.res.flags);
        printf("\n  true error %.2g; interval covers the true value: %s\n",
               a.res.estimate - exact, covers ? "yes" : "no");
        printf("  ask/tell: %llu batches, ended %s; agrees with the callback bit for bit: %s\n",
               (unsigned long long)status.batches, qmc_session_end_key(status.end),
               same ? "yes" : "no");
        bad |= !same || !covers;
    }
    return bad;
}
