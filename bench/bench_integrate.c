/*
 * bench_integrate.c - integration accuracy per evaluation and per second:
 * our methods against GSL (plain, MISER, VEGAS, Sobol average) and
 * cubature (hcubature, pcubature) in the same run (issue 3).
 *
 *   bench_integrate OUTDIR      writes OUTDIR/integrate-*.csv
 *   BENCH_QUICK=1               budgets up to 1e6 and N up to 2^16 only
 *
 * Part 1 (integrate_conv.c): convergence slopes of mc, qmc and rqmc on the
 * smooth Genz families at d = 2, 4, 8, and Gauss-Legendre's exponential
 * rate in 1D.
 *
 * Part 2: every method at budgets of 1e4 .. 1e7 evaluations on the six
 * Genz families at d = 2, 5, 10, 20, 30, each on DRAWS integrands drawn at
 * fixed difficulty (qmc_genz_draw FIXED, seeds 1 .. DRAWS; the randomized
 * methods, ours and GSL's, are seeded with the same number, and auto runs
 * BENCH_SCRAMBLES seeds a draw: integrate_methods.h).  One draw is one
 * lottery ticket: a single u can sit where a method's points happen to be
 * lucky (an unscrambled net whose box corner falls on a dyadic grid), so
 * comparisons are made over the draws, as Genz's own test package does;
 * see integrate_report.c.  See integrate_methods.c for how each method is
 * held to its budget.  Each run,
 * ours included, happens in a forked child under RLIMIT_AS = 2 GiB and an
 * alarm of WALL_BASE_S + budget * WALL_PER_EVAL_S seconds, and reports back
 * over a pipe: a peer that crashes, exhausts the memory cap or hangs is
 * recorded, and the benchmark goes on.  Once a method has crashed, run out
 * of memory or timed out on a (family, d), its larger budgets are recorded
 * as skipped rather than run again (they would fail the same way, slower).
 * Runs are serial, so no two measurements share the machine.
 *
 * Part 3 (integrate_report.c): auto against the best peer at equal wall
 * time, honesty of error estimates, outcomes and memory.  Errors are also
 * written relative to int |f|: the oscillatory family's integral can sit
 * near zero, so its int |f| is estimated once per d by an RQMC run of
 * 16 x 2^16 points (printed below), while the other families are positive
 * and int |f| is their exact integral.
 *
 * GSL and cubature are benchmark peers only (GSL is GPL): linked into this
 * program, never into libqmc, qmcd or qmc.  Targets are reported with
 * "met" / "MISSED", never asserted: timings do not belong in tests.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>

#include "integrate_child.h"
#include "integrate_conv.h"
#include "integrate_methods.h"
#include "integrate_report.h"
#include "qmc/integrate.h"
#include "qmc/testfn.h"

static const uint64_t AS_CAP_BYTES = 2ull << 30; /* RLIMIT_AS per run */
static const double WALL_BASE_S = 5.0;
static const double WALL_PER_EVAL_S = 3e-6; /* 30 s more per 1e7 evaluations */

static const uint32_t dims_list[] = {2, 5, 10, 20, 30};
static const qmc_genz_family families[] = {QMC_GENZ_OSCILLATORY, QMC_GENZ_PRODUCT_PEAK,
                                           QMC_GENZ_CORNER_PEAK, QMC_GENZ_GAUSSIAN,
                                           QMC_GENZ_CONTINUOUS, QMC_GENZ_DISCONTINUOUS};
static const uint64_t budgets_full[] = {10000, 100000, 1000000, 10000000};
enum { DRAWS = 8 }; /* integrands per (family, d) */

#define COUNT(a) (sizeof(a) / sizeof((a)[0]))

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static FILE *open_csv(const char *dir, const char *name)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "w");
    if (!f)
        fprintf(stderr, "bench_integrate: cannot write %s\n", path);
    return f;
}

/* int |f| of the oscillatory family by RQMC, 16 x 2^16 points. */
static double osc_abs_integral(uint32_t d, uint64_t draw_seed, double *exact)
{
    qmc_testfn *fn = NULL;
    if (bench_make_genz(QMC_GENZ_OSCILLATORY, d, draw_seed, &fn) != 0)
        return NAN;
    const qmc_integrand *f = qmc_testfn_integrand(fn);
    *exact = f->exact;
    qmc_integrate_spec spec;
    qmc_integrate_spec_init(&spec);
    spec.method = QMC_METHOD_RQMC;
    qmc_sampling_spec_init(&spec.sampling, QMC_SAMPLER_RQMC);
    spec.sampling.seed = 7;
    spec.sampling.n = 1u << 16;
    spec.n_given = 1;
    qmc_integrate_report rep;
    double v = NAN;
    if (qmc_integrate(&spec, f, NULL, NULL, NULL, &rep, NULL, 0) == 0)
        v = rep.res.abs_integral;
    qmc_testfn_free(fn);
    return v;
}

/* Exact integral and int |f| of a family at d. */
static int truth(qmc_genz_family fam, uint32_t d, uint64_t draw_seed, const double *osc_absf,
                 double *exact, double *absint)
{
    qmc_testfn *fn = NULL;
    if (bench_make_genz(fam, d, draw_seed, &fn) != 0)
        return -1;
    const qmc_integrand *f = qmc_testfn_integrand(fn);
    *exact = f->has_exact ? f->exact : NAN;
    if (f->has_abs_integral)
        *absint = f->abs_integral;
    else if (fam == QMC_GENZ_OSCILLATORY)
        *absint = *osc_absf;
    else
        *absint = fabs(*exact);
    qmc_testfn_free(fn);
    return 0;
}

/* A CSV field without commas or newlines. */
static void csv_text(FILE *f, const char *s)
{
    for (; *s; s++)
        fputc(*s == ',' || *s == '\n' ? ';' : *s, f);
}

static void write_run(FILE *csv, const bench_rec *r)
{
    if (!csv)
        return;
    fprintf(csv, "%s,%s,%u,%llu,%llu,%llu,%.6g,%.6e,%.6e,%.6e,%.17g,%.17g,%ld,%s,%s,%u,",
            bench_method_name(r->job.method), qmc_genz_family_name(r->job.family), r->job.dims,
            (unsigned long long)r->job.draw_seed, (unsigned long long)r->job.budget, (unsigned long long)r->out.evals, r->out.seconds,
            r->abs_err, r->out.err_est, r->abs_err / r->absint, r->exact, r->absint,
            r->proc.maxrss_kb, bench_outcome_name(r->out.outcome),
            r->out.method_used >= 0 ? qmc_method_name((qmc_method)r->out.method_used) : "",
            r->out.timing_runs);
    csv_text(csv, r->out.note);
    fprintf(csv, ",%u\n", r->job.scramble);
    fflush(csv);
}

/* A run of the same method and (family, d), on any draw, at the same or a
 * smaller budget that crashed, ran out of memory or timed out, or NULL:
 * such failures come from the dimension and budget, not the draw. */
static const bench_rec *earlier_failure(const bench_rec *recs, size_t n, const bench_job *job)
{
    for (size_t i = 0; i < n; i++) {
        const bench_rec *r = &recs[i];
        if (r->job.method == job->method && r->job.family == job->family &&
            r->job.dims == job->dims && r->job.budget <= job->budget &&
            (r->out.outcome == BENCH_CRASHED || r->out.outcome == BENCH_OOM ||
             r->out.outcome == BENCH_TIMEOUT))
            return r;
    }
    return NULL;
}

/* Runs r->job in a child (or records it as skipped after an earlier
 * failure of the same method on the same integrand). */
static void run_one(bench_rec *r, const bench_rec *recs, size_t n, const bench_limits *base,
                    double exact, double absint)
{
    r->exact = exact;
    r->absint = absint;
    r->abs_err = NAN;
    const bench_rec *prev = earlier_failure(recs, n, &r->job);
    if (prev) {
        r->out.outcome = r->proc.outcome = BENCH_SKIPPED;
        r->out.err_est = NAN;
        r->out.method_used = -1;
        snprintf(r->out.note, sizeof r->out.note, "%s at budget %.0e",
                 bench_outcome_name(prev->out.outcome), (double)prev->job.budget);
        return;
    }
    bench_limits lim = *base;
    lim.wall_seconds = (unsigned)(WALL_BASE_S + WALL_PER_EVAL_S * (double)r->job.budget);
    if (bench_child_run(bench_method_run, &r->job, &lim, &r->out, &r->proc) != 0) {
        fprintf(stderr, "bench_integrate: fork failed\n");
        exit(1);
    }
    if (r->out.outcome == BENCH_OK)
        r->abs_err = fabs(r->out.estimate - exact);
}

int main(int argc, char **argv)
{
    const char *dir = argc > 1 ? argv[1] : ".";
    const char *q = getenv("BENCH_QUICK");
    const int quick = q && *q && strcmp(q, "0") != 0;
    const size_t n_budgets = quick ? COUNT(budgets_full) - 1 : COUNT(budgets_full);
    const double t_start = now();
    int met = 0, missed = 0;

    printf("bench_integrate: %s run; peers and ours each in a forked child "
           "(RLIMIT_AS %llu MiB, alarm %.0f s + %.0e s per budgeted evaluation)\n\n",
           quick ? "quick (BENCH_QUICK)" : "full", (unsigned long long)(AS_CAP_BYTES >> 20),
           WALL_BASE_S, WALL_PER_EVAL_S);

    /* ---- part 1 ---- */
    FILE *conv_csv = open_csv(dir, "integrate-conv.csv");
    FILE *gl_csv = open_csv(dir, "integrate-gl.csv");
    int conv_met = 0;
    int conv_missed = bench_conv_run(conv_csv, gl_csv, quick ? 16 : 20, &conv_met);
    if (conv_csv)
        fclose(conv_csv);
    if (gl_csv)
        fclose(gl_csv);
    if (conv_missed < 0) {
        fprintf(stderr, "bench_integrate: a convergence run failed\n");
        return 1;
    }
    met += conv_met;
    missed += conv_missed;
    fprintf(stderr, "bench_integrate: part 1 took %.1f s\n", now() - t_start);

    /* ---- part 2 ---- */
    double osc_absf[COUNT(dims_list)][DRAWS];
    printf("\nOscillatory family: exact integral and int |f| (RQMC, 16 x 2^16 points, once "
           "per d and draw), which errors are also divided by; the draw whose integral is "
           "nearest zero\n");
    printf("%5s %14s %14s %10s\n", "d", "integral", "int |f|", "ratio");
    for (size_t di = 0; di < COUNT(dims_list); di++) {
        size_t nearest = 0;
        double ex[DRAWS];
        for (size_t k = 0; k < DRAWS; k++) {
            ex[k] = NAN;
            osc_absf[di][k] = osc_abs_integral(dims_list[di], k + 1, &ex[k]);
            if (fabs(ex[k]) / osc_absf[di][k] < fabs(ex[nearest]) / osc_absf[di][nearest])
                nearest = k;
        }
        printf("%5u %14.6e %14.6e %10.3g\n", dims_list[di], ex[nearest], osc_absf[di][nearest],
               fabs(ex[nearest]) / osc_absf[di][nearest]);
    }

    size_t runs_per_draw = 0;
    for (int m = 0; m < BENCH_M_COUNT; m++)
        runs_per_draw += bench_method_scrambles((bench_method)m);
    const size_t total = COUNT(dims_list) * COUNT(families) * DRAWS * n_budgets * runs_per_draw;
    bench_rec *recs = calloc(total, sizeof *recs);
    if (!recs)
        return 1;
    FILE *runs_csv = open_csv(dir, "integrate-runs.csv");
    if (runs_csv)
        fprintf(runs_csv, "method,family,dims,draw,budget,evals,seconds,abs_error,"
                          "error_estimate,error_rel_absf,exact,abs_integral,peak_rss_kb,outcome,"
                          "method_used,timing_runs,note,scramble\n");
    const bench_limits base = {.as_bytes = AS_CAP_BYTES};
    size_t n = 0;
    const double t_part2 = now();
    for (size_t di = 0; di < COUNT(dims_list); di++) {
        for (size_t fi = 0; fi < COUNT(families); fi++) {
            for (uint64_t draw = 1; draw <= DRAWS; draw++) {
                double exact, absint;
                if (truth(families[fi], dims_list[di], draw, &osc_absf[di][draw - 1], &exact,
                          &absint) != 0)
                    return 1;
                for (size_t b = 0; b < n_budgets; b++) {
                    for (int m = 0; m < BENCH_M_COUNT; m++) {
                        for (uint32_t s = 0; s < bench_method_scrambles((bench_method)m); s++) {
                            bench_rec *r = &recs[n];
                            r->job = (bench_job){.method = (bench_method)m,
                                                 .family = families[fi],
                                                 .dims = dims_list[di],
                                                 .budget = budgets_full[b],
                                                 .draw_seed = draw,
                                                 .scramble = s};
                            run_one(r, recs, n, &base, exact, absint);
                            write_run(runs_csv, r);
                            n++;
                            fprintf(stderr,
                                    "[%4zu/%zu %5.0fs] d=%-2u %-19s #%llu.%u %.0e %-9s %8.3fs "
                                    "err %-9.2e %s%s%s\n",
                                    n, total, now() - t_start, r->job.dims,
                                    qmc_genz_family_name(r->job.family),
                                    (unsigned long long)draw, s, (double)r->job.budget,
                                    bench_method_name(r->job.method), r->out.seconds,
                                    r->abs_err, bench_outcome_name(r->out.outcome),
                                    r->out.outcome == BENCH_OK ? "" : ": ",
                                    r->out.outcome == BENCH_OK ? "" : r->out.note);
                        }
                    }
                }
            }
        }
    }
    if (runs_csv)
        fclose(runs_csv);
    fprintf(stderr, "bench_integrate: part 2 took %.1f s\n", now() - t_part2);

    /* ---- part 3 ---- */
    bench_grid g = {.dims = dims_list, .n_dims = COUNT(dims_list), .families = families,
                    .n_families = COUNT(families), .budgets = budgets_full,
                    .n_budgets = n_budgets, .draws = DRAWS};
    FILE *pair_csv = open_csv(dir, "integrate-auto-vs-peer.csv");
    FILE *hon_csv = open_csv(dir, "integrate-honesty.csv");
    bench_report(recs, n, &g, pair_csv, hon_csv, &met, &missed);
    if (pair_csv)
        fclose(pair_csv);
    if (hon_csv)
        fclose(hon_csv);
    free(recs);

    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    printf("\nAll verdicts: %d met, %d MISSED.  Total wall time %.0f s (parent peak RSS "
           "%.1f MiB).\n", met, missed, now() - t_start, (double)ru.ru_maxrss / 1024.0);
    return 0;
}
