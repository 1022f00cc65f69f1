/*
 * session_common.h - what the two session benchmarks share
 * (bench_session.c in-process, bench_session_wire.c through qmcd): the
 * cheap integrand, the clock, its measured cost, and one run's outcome.
 *
 * Must not: print, or run a session or the daemon (each benchmark runs
 * its own side).
 */
#ifndef QMC_BENCH_SESSION_COMMON_H
#define QMC_BENCH_SESSION_COMMON_H

#include <stddef.h>
#include <stdint.h>

#include "qmc/session.h"

/* Monotonic seconds. */
double bench_now(void);

/* The integrand, about 20 ns a point: one exp and one cos (in 1D an
 * oscillating one, which Gauss-Kronrod must bisect).  As a qmc_integrand's
 * eval: ctx unused. */
double bench_cheap(const double *x, uint32_t d);
void bench_cheap_eval(const void *ctx, const double *x, size_t n, uint32_t dims, double *out);

/* bench_cheap's cost in nanoseconds a point at dims dimensions: the
 * fastest of reps timings of 16 x 65536 scattered points. */
double bench_integrand_ns(uint32_t dims, int reps);

/* One whole integration, timed. */
typedef struct bench_run {
    double seconds;
    uint64_t evals, batches;
    double estimate;
} bench_run;

/* 1 when two runs gave the same estimate, bit for bit, from as many
 * evaluations. */
int bench_same(const bench_run *a, const bench_run *b);

/* The job both benchmarks time: rqmc, 16 replicates x 65536 points (256
 * blocks of 4096), a fixed n. */
void bench_rqmc_spec(qmc_integrate_spec *is);

/* The session spec of the job is on f of dims dims and smoothness sm,
 * batches of at most max_batch points (0: the default). */
void bench_session_spec(qmc_session_spec *ss, const qmc_integrate_spec *is, uint32_t dims,
                        qmc_smoothness sm, uint64_t max_batch);

#endif
