/*
 * session_example.c - integrating a function of your own through qmcd:
 * the daemon hands out batches of points, this program evaluates its
 * function at them, and the daemon keeps the estimate, the error bar and
 * the stopping rule (an integration session; docs/SESSIONS.md).
 *
 * Two ways, which must give the same bytes as each other and as libqmc
 * integrating the same function in-process (qmc_integrate with a
 * callback), for every method:
 *
 *   1. the callback convenience: qmc_client_session_run calls your
 *      function for every batch;
 *   2. ask/tell: you own the loop (next batch, your values, tell), for
 *      when your function is a measurement, or elsewhere.
 *
 * The function is f(x) = exp(-|x|^2) on the unit cube in 3 dimensions,
 * whose integral is (sqrt(pi)/2 erf(1))^3.  Build against an installed
 * qmcd (make install):
 *
 *   cc -std=c11 session_example.c $(pkg-config --cflags --libs qmcclient) -lm -o session_example
 *
 * and run it with the daemon's endpoint:
 *
 *   qmcd --listen unix:/tmp/qmcd.sock &
 *   ./session_example unix:/tmp/qmcd.sock
 *
 * It exits 1 if a way disagrees with the others or an interval misses the
 * true value, 2 if the daemon cannot be reached.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <qmc/client.h>
#include <qmc/integrate.h>

enum { DIMS = 3 };

/* Your function, at one point. */
static double my_f(const double *x)
{
    double r2 = 0.0;
    for (int j = 0; j < DIMS; j++)
        r2 += x[j] * x[j];
    return exp(-r2);
}

/* 1. For qmc_client_session_run: a batch of count points, row-major. */
static int my_batch(void *ctx, const double *points, size_t count, uint32_t dims,
                    double *values)
{
    (void)ctx;
    for (size_t i = 0; i < count; i++)
        values[i] = my_f(points + i * dims);
    return 0; /* non-zero would stop the session */
}

/* The same function as libqmc's callback, for the in-process answer. */
static void my_eval(const void *ctx, const double *x, size_t n, uint32_t dims, double *out)
{
    (void)ctx;
    (void)my_batch(NULL, x, n, dims, out);
}

/* 2. Ask/tell: you own the loop. */
static int ask_tell(qmc_client *c, const qmc_session_spec *spec, qmc_client_result *out,
                    unsigned long long *batches)
{
    qmc_client_session *s;
    int err = qmc_client_session_open(c, spec, &s);
    if (err)
        return err;
    for (;;) {
        qmc_session_batch b;
        if ((err = qmc_client_session_next(s, &b)) != 0 || b.count == 0)
            break; /* count 0: done, b.end says why */
        /* Room for the values next to the points (in shared memory on a
         * Unix socket): nothing is copied on the way back. */
        double *v = qmc_client_session_values(s);
        for (size_t i = 0; i < b.count; i++)
            v[i] = my_f(b.points + i * b.dims);
        if ((err = qmc_client_session_tell(s, b.seq, v, b.count)) != 0)
            break;
    }
    qmc_session_report rep;
    qmc_client_session_report(s, &rep);
    *batches = (unsigned long long)rep.batches;
    if (!err)
        err = qmc_client_session_result(s, out);
    qmc_client_session_free(s);
    return err;
}

static int same(const qmc_result *a, const qmc_result *b)
{
    return memcmp(&a->estimate, &b->estimate, sizeof(double)) == 0 &&
           memcmp(&a->error, &b->error, sizeof(double)) == 0 && a->evals == b->evals &&
           a->flags == b->flags;
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: session_example ENDPOINT (unix:PATH or tcp:HOST:PORT)\n");
        return 2;
    }
    qmc_client *c;
    if (qmc_client_connect(argv[1], 10000, &c) != 0) {
        fprintf(stderr, "session_example: %s\n", qmc_client_last_error(c));
        qmc_client_close(c);
        return 2;
    }
    const double exact = pow(0.5 * sqrt(acos(-1.0)) * erf(1.0), DIMS);
    const qmc_method methods[] = {QMC_METHOD_AUTO, QMC_METHOD_RQMC, QMC_METHOD_CUBATURE};
    int bad = 0;
    for (size_t i = 0; i < sizeof methods / sizeof methods[0]; i++) {
        qmc_session_spec spec;
        qmc_session_spec_init(&spec);
        spec.dims = DIMS;
        spec.smoothness = QMC_SMOOTH_ANALYTIC; /* what you know about f: smooth */
        spec.integrate.method = methods[i];
        if (methods[i] == QMC_METHOD_RQMC)
            qmc_sampling_spec_init(&spec.integrate.sampling, QMC_SAMPLER_RQMC);
        spec.integrate.tol_rel = 1e-6;
        spec.integrate.max_evals = 10000000;

        qmc_client_result run, told;
        unsigned long long batches = 0;
        if (qmc_client_session_run(c, &spec, my_batch, NULL, &run) != 0 ||
            ask_tell(c, &spec, &told, &batches) != 0) {
            fprintf(stderr, "session_example: %s\n", qmc_client_last_error(c));
            qmc_client_close(c);
            return 1;
        }
        /* libqmc in-process, with the same function as a callback. */
        qmc_integrand f = {.eval = my_eval, .dims = DIMS, .smoothness = QMC_SMOOTH_ANALYTIC};
        qmc_integrate_report local;
        char why[256];
        if (qmc_integrate(&spec.integrate, &f, NULL, NULL, NULL, &local, why, sizeof why) != 0) {
            fprintf(stderr, "session_example: %s\n", why);
            qmc_client_close(c);
            return 1;
        }
        const int agree = same(&run.res, &told.res) && same(&run.res, &local.res);
        const int covers = run.res.ci_low <= exact && exact <= run.res.ci_high;
        printf("%s (%s): %.15g +- %.2g, %llu evaluations in %llu batches\n",
               qmc_method_name(methods[i]), qmc_method_name(run.method_used), run.res.estimate,
               run.res.error, (unsigned long long)run.res.evals, batches);
        printf("  true error %.2g; interval covers the true value: %s\n",
               run.res.estimate - exact, covers ? "yes" : "no");
        printf("  callback, ask/tell and in-process agree bit for bit: %s\n",
               agree ? "yes" : "no");
        bad |= !agree || !covers;
    }
    qmc_client_close(c);
    return bad;
}
