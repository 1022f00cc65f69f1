/*
 * session_common.c - the integrand and timing the session benchmarks
 * share (session_common.h).
 *
 * Must not: print, or run a session or the daemon.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "session_common.h"

double bench_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

double bench_cheap(const double *x, uint32_t d)
{
    if (d == 1)
        return exp(-x[0]) * cos(200.0 * x[0]);
    double s = 0.0;
    for (uint32_t j = 0; j < d; j++)
        s += (0.3 + 0.1 * j) * x[j];
    return exp(-x[0] * x[d - 1]) * cos(s);
}

void bench_cheap_eval(const void *ctx, const double *x, size_t n, uint32_t dims, double *out)
{
    (void)ctx;
    for (size_t i = 0; i < n; i++)
        out[i] = bench_cheap(x + i * dims, dims);
}

/* Keeps the timed loops from being optimised away. */
static volatile double sink;

double bench_integrand_ns(uint32_t dims, int reps)
{
    enum { N = 1 << 16 };
    double *x = malloc((size_t)N * dims * sizeof *x), *out = malloc(N * sizeof *out);
    if (!x || !out) {
        free(x);
        free(out);
        return NAN;
    }
    for (size_t i = 0; i < (size_t)N * dims; i++)
        x[i] = (double)((i * 2654435761u) % 1000003u) / 1000003.0;
    double best = 0.0;
    for (int k = 0; k < reps; k++) {
        double t0 = bench_now();
        for (int rep = 0; rep < 16; rep++)
            bench_cheap_eval(NULL, x, N, dims, out);
        double t = (bench_now() - t0) / (16.0 * N);
        best = k == 0 || t < best ? t : best;
        sink = out[N / 2];
    }
    free(x);
    free(out);
    return best * 1e9;
}

int bench_same(const bench_run *a, const bench_run *b)
{
    return memcmp(&a->estimate, &b->estimate, sizeof a->estimate) == 0 && a->evals == b->evals;
}

void bench_session_spec(qmc_session_spec *ss, const qmc_integrate_spec *is, uint32_t dims,
                        qmc_smoothness sm, uint64_t max_batch)
{
    qmc_session_spec_init(ss);
    ss->integrate = *is;
    ss->dims = dims;
    ss->smoothness = sm;
    ss->max_batch = max_batch;
}

void bench_rqmc_spec(qmc_integrate_spec *is)
{
    qmc_integrate_spec_init(is);
    is->method = QMC_METHOD_RQMC;
    qmc_sampling_spec_init(&is->sampling, QMC_SAMPLER_RQMC);
    is->sampling.n = 65536;
    is->n_given = 1;
}
