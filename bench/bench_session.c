/*
 * bench_session.c - what an in-process integration session costs against
 * qmc_integrate calling the same integrand back, in one run.
 *
 * The integrand is cheap on purpose (about 20 ns an evaluation, measured
 * and printed), so that the session's own work shows: its fiber switches
 * (two swapcontext calls, each with a sigprocmask system call, per batch)
 * and, for the sampling methods, the collect pass that assembles whole
 * blocks into one batch (session_run.c: one fill a block into the batch;
 * behind a VEGAS map the points are made twice).  The integrand and the
 * clock are session_common.c's, shared with bench_session_wire.c.  Each
 * row times REPS whole integrations each way, alternating
 * the two so that both see the same load on a shared machine, and keeps
 * the fastest of each (the least disturbed: the noise here is other
 * processes, which only ever add time).
 *
 *  - Table 1: rqmc with a fixed n, by batch size: evaluations per second
 *    through qmc_integrate and through a session, their ratio, the
 *    overhead per batch and per point.
 *  - Table 2: the other methods at their own batch sizes (a rule's batch
 *    is what it evaluates at once: 21 or 42 points for Gauss-Kronrod, 256
 *    for cubature and the tensor rules).
 *
 * Speed goals are ratios measured here, never asserted in a test.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "qmc/integrate.h"
#include "qmc/session.h"
#include "session_common.h"

enum { REPS = 7, DIMS = 4 };

typedef bench_run run;

static run integrate_once(const qmc_integrate_spec *is, uint32_t dims, qmc_smoothness sm)
{
    qmc_integrand f = {.eval = bench_cheap_eval, .dims = dims, .smoothness = sm, .name = "cheap"};
    run r = {0};
    qmc_integrate_report rep;
    char why[256];
    double t0 = bench_now();
    if (qmc_integrate(is, &f, NULL, NULL, NULL, &rep, why, sizeof why) != 0) {
        fprintf(stderr, "bench_session: qmc_integrate: %s\n", why);
        exit(1);
    }
    r.seconds = bench_now() - t0;
    r.evals = rep.res.evals;
    r.estimate = rep.res.estimate;
    return r;
}

/* The caller's side of an ask/tell loop; its values buffer is kept across
 * runs, as a real caller's would be. */
static double *vals;
static size_t vals_cap;

static run session_once(const qmc_session_spec *ss)
{
    run r = {0};
    char why[256];
    qmc_session *s = NULL;
    double t0 = bench_now();
    if (qmc_session_new(ss, &s, why, sizeof why) != 0) {
        fprintf(stderr, "bench_session: qmc_session_new: %s\n", why);
        exit(1);
    }
    for (;;) {
        qmc_session_batch b;
        if (qmc_session_ask(s, &b) != 0 || b.count == 0)
            break;
        if (b.count > vals_cap) {
            free(vals);
            vals_cap = b.count;
            vals = malloc(vals_cap * sizeof *vals);
            if (!vals)
                exit(1);
        }
        bench_cheap_eval(NULL, b.points, b.count, b.dims, vals);
        if (qmc_session_tell(s, b.seq, vals, b.count, why, sizeof why) != 0) {
            fprintf(stderr, "bench_session: tell: %s\n", why);
            exit(1);
        }
        r.batches++;
    }
    qmc_integrate_report rep;
    if (qmc_session_result(s, &rep, why, sizeof why) != 0) {
        fprintf(stderr, "bench_session: session: %s\n", why);
        exit(1);
    }
    qmc_session_free(s);
    r.seconds = bench_now() - t0;
    r.evals = rep.res.evals;
    r.estimate = rep.res.estimate;
    return r;
}

/* REPS runs each way, alternating; the fastest of each. */
static void measure(const qmc_integrate_spec *is, uint32_t dims, qmc_smoothness sm,
                    uint64_t max_batch, run *in, run *se)
{
    qmc_session_spec ss;
    bench_session_spec(&ss, is, dims, sm, max_batch);
    for (int k = 0; k < REPS; k++) {
        run a = integrate_once(is, dims, sm), b = session_once(&ss);
        if (k == 0 || a.seconds < in->seconds)
            *in = a;
        if (k == 0 || b.seconds < se->seconds)
            *se = b;
    }
}

static void same_or_die(const run *a, const run *b, const char *what)
{
    if (!bench_same(a, b)) {
        fprintf(stderr, "bench_session: %s: the session's answer differs\n", what);
        exit(1);
    }
}

static void row(const char *what, uint64_t max_batch, const run *in, const run *se)
{
    const double extra = se->seconds - in->seconds;
    printf("%-34s %9llu %8llu %9.1f %9.1f %6.2f %10.2f %8.2f\n", what,
           (unsigned long long)max_batch, (unsigned long long)se->batches,
           (double)in->evals / in->seconds / 1e6, (double)se->evals / se->seconds / 1e6,
           in->seconds / se->seconds, se->batches ? 1e6 * extra / (double)se->batches : 0.0,
           1e9 * extra / (double)se->evals);
}

static void header(void)
{
    printf("%-34s %9s %8s %9s %9s %6s %10s %8s\n", "job", "max_batch", "batches", "Me/s in",
           "Me/s sess", "ratio", "us/batch", "ns/eval");
}

int main(void)
{
    printf("integrand: %.1f ns an evaluation (exp and cos, %d dims)\n\n",
           bench_integrand_ns(DIMS, REPS), DIMS);

    /* Table 1: rqmc, 16 replicates x 65536 points (256 blocks of 4096). */
    qmc_integrate_spec is;
    bench_rqmc_spec(&is);
    printf("rqmc, 16 x 65536 points, by the largest batch a session assembles\n");
    printf("(below one block, 4096 points, batches are the engine's chunks of 256)\n");
    header();
    const uint64_t sizes[] = {256, 4096, 16384, 65536, 262144, 1048576};
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) {
        run in, se;
        measure(&is, DIMS, QMC_SMOOTH_ANALYTIC, sizes[i], &in, &se);
        same_or_die(&in, &se, "rqmc");
        row("rqmc 16 x 65536", sizes[i], &in, &se);
    }

    /* Table 2: the other methods, each at its own batches. */
    printf("\nother methods, default batches (mean batch = evaluations / batches)\n");
    header();
    const struct {
        const char *name;
        qmc_method m;
        uint32_t dims;
        qmc_smoothness sm;
        double tol;
        uint64_t budget, n;
    } jobs[] = {
        {"mc 1 x 1048576", QMC_METHOD_MC, DIMS, QMC_SMOOTH_ANALYTIC, 0, 0, 1048576},
        {"rqmc adaptive, tol 1e-7", QMC_METHOD_RQMC, DIMS, QMC_SMOOTH_ANALYTIC, 1e-7, 4000000, 0},
        {"auto (rqmc over a map), 8 dims", QMC_METHOD_AUTO, 8, QMC_SMOOTH_DISCONTINUOUS, 1e-5,
         2000000, 0},
        {"auto (clenshaw-curtis)", QMC_METHOD_AUTO, DIMS, QMC_SMOOTH_ANALYTIC, 1e-12, 2000000, 0},
        {"cubature, tol 1e-13", QMC_METHOD_CUBATURE, 3, QMC_SMOOTH_ANALYTIC, 1e-13, 2000000, 0},
        {"gauss-legendre 32^4", QMC_METHOD_GAUSS_LEGENDRE, DIMS, QMC_SMOOTH_ANALYTIC, 0, 0, 0},
        {"gauss-kronrod, tol 1e-13", QMC_METHOD_GAUSS_KRONROD, 1, QMC_SMOOTH_ANALYTIC, 1e-13, 0,
         0},
    };
    for (size_t i = 0; i < sizeof jobs / sizeof jobs[0]; i++) {
        qmc_integrate_spec_init(&is);
        is.method = jobs[i].m;
        if (jobs[i].m == QMC_METHOD_RQMC)
            qmc_sampling_spec_init(&is.sampling, QMC_SAMPLER_RQMC);
        is.tol_rel = jobs[i].tol;
        if (jobs[i].budget)
            is.max_evals = jobs[i].budget;
        if (jobs[i].n) {
            is.sampling.n = jobs[i].n;
            is.n_given = 1;
        }
        is.n_axis = 32;
        run a, b;
        measure(&is, jobs[i].dims, jobs[i].sm, 0, &a, &b);
        same_or_die(&a, &b, jobs[i].name);
        row(jobs[i].name, b.batches ? b.evals / b.batches : 0, &a, &b);
    }
    printf("\n(for table 2 the max_batch column is the mean batch)\n");
    free(vals);
    return 0;
}
