/*
 * integrate_report.h - part 3 of bench_integrate: reads the budgeted runs
 * and prints auto against the best peer at equal wall time, the honesty
 * of every method's error estimate, what happened to each method (crashes,
 * refusals, memory), and writes the matching CSV files.
 */
#ifndef BENCH_INTEGRATE_REPORT_H
#define BENCH_INTEGRATE_REPORT_H

#include <float.h>
#include <stddef.h>
#include <stdio.h>

#include "integrate_child.h"
#include "integrate_methods.h"

/* One budgeted run and what is known about its integrand. */
typedef struct bench_rec {
    bench_job job;
    bench_out out;
    bench_proc proc;
    double exact;     /* the closed-form integral */
    double absint;    /* int |f|: closed form, or (oscillatory) an RQMC estimate */
    double abs_err;   /* |estimate - exact| for ok runs, else NAN */
} bench_rec;

/* The error used in ratios: |error| floored at rel_floor * max(|I|,
 * int |f|), so that a run which hits the exact value to the last bit does
 * not divide by 0, and two runs both at rounding level compare equal. */
double bench_floored_error(const bench_rec *r, double rel_floor);

/* Floors: comparisons of two methods treat errors below 1e-14 of int |f|
 * as rounding (equal); honesty ratios floor the actual error at 4 ulps. */
#define BENCH_COMPARE_FLOOR 1e-14
#define BENCH_HONESTY_FLOOR (4 * DBL_EPSILON)
/* Honesty is also reported over the runs whose actual error is at least
 * this far above rounding, where an estimate has something to estimate. */
#define BENCH_HONESTY_CLEAR 1e-12

typedef struct bench_grid {
    const uint32_t *dims;
    size_t n_dims;
    const qmc_genz_family *families;
    size_t n_families;
    const uint64_t *budgets;
    size_t n_budgets;
    size_t draws;              /* integrands per (family, d): seeds 1 .. draws */
} bench_grid;

/* Our memory bound per run: cubature's default 64 MiB of regions plus 32
 * MiB for the process, the sampling workspaces and the block sums. */
#define BENCH_OURS_RSS_BOUND_KB (96L * 1024)

/*
 * Prints the tables and verdicts to stdout and writes pair_csv (auto vs
 * best peer, one row per auto run) and honesty_csv (per method and
 * family); either may be NULL.  Adds the verdict counts to *met and
 * *missed.
 */
void bench_report(const bench_rec *recs, size_t n, const bench_grid *g, FILE *pair_csv,
                  FILE *honesty_csv, int *met, int *missed);

#endif
