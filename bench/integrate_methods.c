/*
 * integrate_methods.c - one budgeted run of each integrator (see
 * integrate_methods.h).
 *
 * How each one is given its budget B of evaluations:
 *   gsl-plain   gsl_monte_plain_integrate, calls = B (mt19937 seeded with
 *               the integrand's draw seed, as all randomized methods are).
 *   gsl-miser   gsl_monte_miser_integrate, calls = B, default parameters.
 *   gsl-vegas   GSL's recommended two stages: a warm-up (stage 0, 5
 *               iterations of B/50 calls) that only trains the grid, then
 *               a final run (stage 1: keep the grid, drop the warm-up's
 *               results) of 5 iterations sharing what is left; total B.
 *   gsl-sobol   the plain average of the first B points of gsl_qrng_sobol
 *               (no error estimate; GSL stops at 40 dimensions).
 *   hcubature,  hcubature_v / pcubature_v with maxEval = B, reqAbsError =
 *   pcubature   reqRelError = 0, so they stop on the budget alone.  Both
 *               check the budget only after a whole rule or refinement,
 *               so they may overshoot it: evals records what they spent.
 *   auto        qmc_integrate, method auto, tol_rel 1e-14 (unreachable,
 *               so it spends the budget), max_evals = B, seed = the draw
 *               seed plus the scramble number times 2^32.
 *   rqmc        qmc_integrate, method rqmc, owen-scrambled Sobol, 16
 *               replicates of the largest power of two n with 16 n <= B,
 *               seeded as auto is (one scramble a draw).
 *   cubature    qmc_integrate, method cubature (Genz-Malik), tol_rel
 *               1e-14, max_evals = B, the default 64 MiB of regions.
 * Peers' evaluations are counted in the wrapper that calls our integrand;
 * ours report res.evals.  Seconds cover the integration call and the
 * peer's own state allocation, not making the test function.  Every run
 * is deterministic (GSL's generator is re-seeded each time), so a fast run
 * is repeated, up to REPEAT_MAX times while the repeats total less than
 * REPEAT_SECONDS, and the median time is reported (as bench_seq does):
 * sub-millisecond timings are otherwise at the mercy of one page fault.
 */
#include "integrate_methods.h"

#include <cubature.h>
#include <errno.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_monte_miser.h>
#include <gsl/gsl_monte_plain.h>
#include <gsl/gsl_monte_vegas.h>
#include <gsl/gsl_qrng.h>
#include <gsl/gsl_rng.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "qmc/integrate.h"

enum { SOBOL_BATCH = 256, GSL_SOBOL_MAX_DIMS = 40, REPEAT_MAX = 5 };
static const double REPEAT_SECONDS = 0.1;

const char *bench_method_name(bench_method m)
{
    switch (m) {
#define BENCH__METHOD_TEXT(name, text, peer) \
    case BENCH_M_##name:                     \
        return text;
        BENCH_METHOD_MAP(BENCH__METHOD_TEXT)
#undef BENCH__METHOD_TEXT
    default:
        return "?";
    }
}

uint32_t bench_method_scrambles(bench_method m)
{
    return m == BENCH_M_AUTO ? BENCH_SCRAMBLES : 1;
}

int bench_method_is_peer(bench_method m)
{
    switch (m) {
#define BENCH__METHOD_PEER(name, text, peer) \
    case BENCH_M_##name:                     \
        return peer;
        BENCH_METHOD_MAP(BENCH__METHOD_PEER)
#undef BENCH__METHOD_PEER
    default:
        return 0;
    }
}

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int bench_make_genz(qmc_genz_family family, uint32_t dims, uint64_t draw_seed,
                    qmc_testfn **out)
{
    *out = NULL;
    double *a = malloc(2 * (size_t)dims * sizeof *a);
    if (!a)
        return QMC_ENOMEM;
    double *u = a + dims;
    int err = qmc_genz_draw(family, dims, QMC_DIFFICULTY_FIXED, draw_seed, a, u);
    if (!err)
        err = qmc_testfn_new(qmc_genz_family_name(family), dims, a, dims, u, dims, out, NULL, 0);
    free(a);
    return err;
}

/* ---- peers ------------------------------------------------------------- */

/* The peers see our integrand through these wrappers, which count. */
typedef struct peer_ctx {
    const qmc_integrand *f;
    uint64_t evals;
} peer_ctx;

static double gsl_f(double *x, size_t dim, void *p)
{
    peer_ctx *c = p;
    double y;
    c->f->eval(c->f->ctx, x, 1, (uint32_t)dim, &y);
    c->evals++;
    return y;
}

static int cub_f(unsigned ndim, size_t npt, const double *x, void *p, unsigned fdim,
                 double *fval)
{
    peer_ctx *c = p;
    (void)fdim;
    c->f->eval(c->f->ctx, x, npt, ndim, fval);
    c->evals += npt;
    return 0;
}

/* A failed peer call: out of memory when the last libc call said so. */
static void peer_failed(bench_out *out, const char *what, int code)
{
    int oom = errno == ENOMEM;
    out->outcome = oom ? BENCH_OOM : BENCH_FAILED;
    snprintf(out->note, sizeof out->note, "%s returned %d%s", what, code,
             oom ? " (ENOMEM)" : "");
}

static void run_gsl_mc(const bench_job *job, peer_ctx *c, bench_out *out)
{
    const size_t d = job->dims;
    double *lo = calloc(2 * d, sizeof *lo);
    gsl_rng *rng = gsl_rng_alloc(gsl_rng_mt19937);
    if (!lo || !rng) {
        free(lo);
        gsl_rng_free(rng);
        out->outcome = BENCH_OOM;
        return;
    }
    gsl_rng_set(rng, job->draw_seed); /* a fresh stream per integrand draw */
    double *hi = lo + d;
    for (size_t i = 0; i < d; i++)
        hi[i] = 1.0;
    gsl_monte_function G = {.f = gsl_f, .dim = d, .params = c};
    double val = NAN, err = NAN, t0 = now();
    int rc = 0;
    const size_t B = (size_t)job->budget;
    if (job->method == BENCH_M_GSL_PLAIN) {
        gsl_monte_plain_state *s = gsl_monte_plain_alloc(d);
        if (!s)
            goto oom;
        rc = gsl_monte_plain_integrate(&G, lo, hi, d, B, rng, s, &val, &err);
        gsl_monte_plain_free(s);
    } else if (job->method == BENCH_M_GSL_MISER) {
        gsl_monte_miser_state *s = gsl_monte_miser_alloc(d);
        if (!s)
            goto oom;
        rc = gsl_monte_miser_integrate(&G, lo, hi, d, B, rng, s, &val, &err);
        gsl_monte_miser_free(s);
    } else {
        gsl_monte_vegas_state *s = gsl_monte_vegas_alloc(d);
        if (!s)
            goto oom;
        gsl_monte_vegas_params p;
        gsl_monte_vegas_params_get(s, &p);
        p.iterations = 5;
        p.stage = 0;
        gsl_monte_vegas_params_set(s, &p);
        rc = gsl_monte_vegas_integrate(&G, lo, hi, d, B / 50, rng, s, &val, &err);
        if (rc == 0 && c->evals < B) {
            p.stage = 1;
            gsl_monte_vegas_params_set(s, &p);
            rc = gsl_monte_vegas_integrate(&G, lo, hi, d, (B - c->evals) / 5, rng, s, &val,
                                           &err);
        }
        gsl_monte_vegas_free(s);
    }
    out->seconds = now() - t0;
    if (rc != 0) {
        peer_failed(out, bench_method_name(job->method), rc);
    } else {
        out->outcome = BENCH_OK;
        out->estimate = val;
        out->err_est = err;
    }
    gsl_rng_free(rng);
    free(lo);
    return;
oom:
    out->outcome = BENCH_OOM;
    snprintf(out->note, sizeof out->note, "%s state allocation failed",
             bench_method_name(job->method));
    gsl_rng_free(rng);
    free(lo);
}

static void run_gsl_sobol(const bench_job *job, peer_ctx *c, bench_out *out)
{
    const uint32_t d = job->dims;
    if (d > GSL_SOBOL_MAX_DIMS) {
        out->outcome = BENCH_REFUSED;
        snprintf(out->note, sizeof out->note, "gsl_qrng_sobol stops at %d dimensions",
                 GSL_SOBOL_MAX_DIMS);
        return;
    }
    double t0 = now();
    gsl_qrng *q = gsl_qrng_alloc(gsl_qrng_sobol, d);
    double *x = malloc((size_t)SOBOL_BATCH * d * sizeof *x);
    double y[SOBOL_BATCH];
    if (!q || !x) {
        if (q)
            gsl_qrng_free(q);
        free(x);
        out->outcome = BENCH_OOM;
        return;
    }
    double sum = 0;
    for (uint64_t done = 0; done < job->budget;) {
        size_t m = job->budget - done < SOBOL_BATCH ? (size_t)(job->budget - done) : SOBOL_BATCH;
        for (size_t i = 0; i < m; i++)
            gsl_qrng_get(q, x + i * d);
        c->f->eval(c->f->ctx, x, m, d, y);
        for (size_t i = 0; i < m; i++)
            sum += y[i];
        done += m;
        c->evals += m;
    }
    out->seconds = now() - t0;
    out->outcome = BENCH_OK;
    out->estimate = sum / (double)job->budget;
    gsl_qrng_free(q);
    free(x);
}

static void run_cubature_peer(const bench_job *job, peer_ctx *c, bench_out *out)
{
    const uint32_t d = job->dims;
    double *lo = calloc(2 * (size_t)d, sizeof *lo);
    if (!lo) {
        out->outcome = BENCH_OOM;
        return;
    }
    double *hi = lo + d;
    for (uint32_t i = 0; i < d; i++)
        hi[i] = 1.0;
    double val = NAN, err = NAN, t0 = now();
    int rc = job->method == BENCH_M_HCUBATURE
                 ? hcubature_v(1, cub_f, c, d, lo, hi, (size_t)job->budget, 0, 0,
                               ERROR_INDIVIDUAL, &val, &err)
                 : pcubature_v(1, cub_f, c, d, lo, hi, (size_t)job->budget, 0, 0,
                               ERROR_INDIVIDUAL, &val, &err);
    out->seconds = now() - t0;
    free(lo);
    if (rc != 0) {
        peer_failed(out, bench_method_name(job->method), rc);
        if (c->evals == 0 && out->outcome == BENCH_FAILED) {
            out->outcome = BENCH_REFUSED; /* e.g. pcubature's MAXDIM of 20 */
            snprintf(out->note, sizeof out->note, "%s returned %d before any evaluation",
                     bench_method_name(job->method), rc);
        }
        return;
    }
    out->outcome = BENCH_OK;
    out->estimate = val;
    out->err_est = err;
}

/* ---- ours -------------------------------------------------------------- */

static void run_ours(const bench_job *job, const qmc_integrand *f, bench_out *out)
{
    qmc_integrate_spec spec;
    qmc_integrate_spec_init(&spec);
    spec.max_evals = job->budget;
    /* Scramble 0 keeps the draw's seed; the others never meet a draw's. */
    const uint64_t seed = job->draw_seed + ((uint64_t)job->scramble << 32);
    spec.sampling.seed = seed;
    switch (job->method) {
    case BENCH_M_AUTO:
        spec.method = QMC_METHOD_AUTO;
        spec.tol_rel = 1e-14;
        break;
    case BENCH_M_RQMC: {
        spec.method = QMC_METHOD_RQMC;
        qmc_sampling_spec_init(&spec.sampling, QMC_SAMPLER_RQMC);
        spec.sampling.seed = seed;
        uint64_t n = 1;
        while (2 * n * spec.sampling.reps <= job->budget)
            n *= 2;
        spec.sampling.n = n;
        spec.n_given = 1;
        break;
    }
    default:
        spec.method = QMC_METHOD_CUBATURE;
        spec.tol_rel = 1e-14;
        break;
    }
    qmc_integrate_report rep;
    char why[200] = "";
    double t0 = now();
    int err = qmc_integrate(&spec, f, NULL, NULL, NULL, &rep, why, sizeof why);
    out->seconds = now() - t0;
    out->method_used = (int)rep.method_used;
    if (err) {
        out->outcome = err == QMC_EBUDGET   ? BENCH_REFUSED
                       : err == QMC_ENOMEM ? BENCH_OOM
                                           : BENCH_FAILED;
        snprintf(out->note, sizeof out->note, "%s: %.120s", qmc_err_name(err), why);
        return;
    }
    out->outcome = BENCH_OK;
    out->estimate = rep.res.estimate;
    out->err_est = rep.res.error_kind == QMC_ERROR_NONE ? NAN : rep.res.error;
    out->evals = rep.res.evals;
    out->flags = rep.res.flags;
    snprintf(out->note, sizeof out->note, "%s: %.120s", qmc_method_name(rep.method_used),
             rep.detail);
}

static void run_once(const bench_job *job, peer_ctx *c, bench_out *out)
{
    memset(out, 0, sizeof *out);
    out->err_est = NAN;
    out->method_used = -1;
    c->evals = 0;
    errno = 0;
    switch (job->method) {
    case BENCH_M_GSL_PLAIN:
    case BENCH_M_GSL_MISER:
    case BENCH_M_GSL_VEGAS:
        run_gsl_mc(job, c, out);
        break;
    case BENCH_M_GSL_SOBOL:
        run_gsl_sobol(job, c, out);
        break;
    case BENCH_M_HCUBATURE:
    case BENCH_M_PCUBATURE:
        run_cubature_peer(job, c, out);
        break;
    default:
        run_ours(job, c->f, out);
        break;
    }
    if (bench_method_is_peer(job->method))
        out->evals = c->evals;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

void bench_method_run(const void *arg, bench_out *out)
{
    const bench_job *job = arg;
    gsl_set_error_handler_off(); /* GSL's default handler aborts */
    qmc_testfn *fn = NULL;
    if (bench_make_genz(job->family, job->dims, job->draw_seed, &fn) != 0) {
        out->outcome = BENCH_FAILED;
        snprintf(out->note, sizeof out->note, "cannot make the test function");
        return;
    }
    peer_ctx c = {.f = qmc_testfn_integrand(fn), .evals = 0};
    double times[REPEAT_MAX], spent = 0;
    uint32_t k = 0;
    do {
        run_once(job, &c, out);
        times[k++] = out->seconds;
        spent += out->seconds;
    } while (out->outcome == BENCH_OK && k < REPEAT_MAX && spent < REPEAT_SECONDS);
    qsort(times, k, sizeof times[0], cmp_double);
    out->seconds = k % 2 ? times[k / 2] : 0.5 * (times[k / 2 - 1] + times[k / 2]);
    out->timing_runs = k;
    qmc_testfn_free(fn);
}
