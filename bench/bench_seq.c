/*
 * bench_seq.c - batch-fill speed of the sampling core against GSL's
 * quasi-random generators and memset of the same buffer, in one run.
 *
 * Rates are coordinates per second for f64 output (and, in one table,
 * instances built per second), in seconds of this thread's CPU time: the
 * development machine is shared, and wall time there also counts the
 * time other people's work held the core (every generator, ours and the
 * peers, is timed the same way).  Each measurement fills
 * a buffer of BUF_BYTES again and again (advancing the index, as a real
 * client would) for at least MIN_SECONDS, and the median of REPS such
 * measurements is reported.  The buffer is sized to stay in L2 so the
 * numbers are about generation, not DRAM; a second table repeats the d = 32
 * row with a 64 MiB buffer, where everything meets the memory wall.
 *
 * GSL is a benchmark peer only (GPL): it is linked into this program and
 * never into libqmc, qmcd or qmc.  Speed goals are reported as ratios, not
 * asserted: wall-clock thresholds do not belong in tests.
 */
#include <gsl/gsl_qrng.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "qmc/seq.h"

enum { REPS = 5 };
static const double MIN_SECONDS = 0.15;

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

typedef struct job {
    const char *name;
    uint32_t dims;
    size_t points;     /* per fill */
    double *buf;
    qmc_seq *seq;      /* ours, or */
    gsl_qrng *qrng;    /* GSL's, or neither for memset */
    uint64_t next;     /* our next start index */
    volatile double sink;
} job;

/* One fill of the buffer; returns coordinates written. */
static double run_once(job *j)
{
    size_t n = j->points * j->dims;
    if (j->seq) {
        if (j->next + j->points > QMC_SEQ_MAX_INDEX)
            j->next = 0;
        if (qmc_seq_fill(j->seq, j->next, j->points, QMC_FORMAT_F64, j->buf) != 0) {
            fprintf(stderr, "bench_seq: fill failed\n");
            exit(1);
        }
        j->next += j->points;
    } else if (j->qrng) {
        for (size_t p = 0; p < j->points; p++)
            if (gsl_qrng_get(j->qrng, j->buf + p * j->dims) != 0) {
                gsl_qrng_init(j->qrng); /* exhausted: start over */
                p--;
            }
    } else {
        memset(j->buf, 0, n * sizeof(double));
    }
    j->sink = j->buf[n / 2];
    return (double)n;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Median over REPS of coordinates per second. */
static double measure(job *j)
{
    double rates[REPS];
    run_once(j); /* warm the cache and the page tables */
    for (int r = 0; r < REPS; r++) {
        double coords = 0, t0 = now(), t;
        do
            coords += run_once(j);
        while ((t = now() - t0) < MIN_SECONDS);
        rates[r] = coords / t;
    }
    qsort(rates, REPS, sizeof rates[0], cmp_double);
    return rates[REPS / 2];
}

static qmc_seq *ours(qmc_seq_kind kind, uint32_t dims, qmc_scramble scr)
{
    qmc_seq_spec spec = {.kind = kind, .dims = dims, .scramble = scr, .seed = 1};
    qmc_seq *s = NULL;
    if (qmc_seq_new(&spec, &s) != 0) {
        fprintf(stderr, "bench_seq: cannot make %s\n", qmc_seq_kind_name(kind));
        exit(1);
    }
    return s;
}

/* fast-owen is a Sobol scramble (pbrt-v4's FastOwenScrambler seeding). */
enum { GEN_MEMSET, GEN_SOBOL, GEN_SOBOL_OWEN, GEN_SOBOL_FAST_OWEN, GEN_SOBOL_SHIFT,
       GEN_HALTON, GEN_GSL_SOBOL, GEN_GSL_HALTON, NGEN };
static const char *gen_names[NGEN] = {"memset", "sobol", "sobol-owen", "fast-owen",
                                      "sobol-shift", "halton", "gsl-sobol", "gsl-halton"};

static double rate_of(int gen, uint32_t dims, size_t buf_bytes, double *buf)
{
    job j = {.name = gen_names[gen], .dims = dims, .buf = buf};
    j.points = buf_bytes / (sizeof(double) * dims);
    switch (gen) {
    case GEN_SOBOL: j.seq = ours(QMC_SEQ_SOBOL, dims, QMC_SCRAMBLE_NONE); break;
    case GEN_SOBOL_OWEN: j.seq = ours(QMC_SEQ_SOBOL, dims, QMC_SCRAMBLE_OWEN); break;
    case GEN_SOBOL_FAST_OWEN:
        j.seq = ours(QMC_SEQ_SOBOL, dims, QMC_SCRAMBLE_FAST_OWEN);
        break;
    case GEN_SOBOL_SHIFT: j.seq = ours(QMC_SEQ_SOBOL, dims, QMC_SCRAMBLE_SHIFT); break;
    case GEN_HALTON: j.seq = ours(QMC_SEQ_HALTON, dims, QMC_SCRAMBLE_NONE); break;
    case GEN_GSL_SOBOL:
        if (dims > 40) /* GSL's sobol stops at 40 dimensions */
            return 0;
        j.qrng = gsl_qrng_alloc(gsl_qrng_sobol, dims);
        break;
    case GEN_GSL_HALTON:
        if (dims > 1229)
            return 0;
        j.qrng = gsl_qrng_alloc(gsl_qrng_halton, dims);
        break;
    default: break;
    }
    double r = measure(&j);
    qmc_seq_free(j.seq);
    if (j.qrng)
        gsl_qrng_free(j.qrng);
    return r;
}

static void print_ratio(double num, double den)
{
    if (num > 0 && den > 0)
        printf(" %8.2fx", num / den);
    else
        printf(" %9s", "n/a");
}

/*
 * Instances built and freed per second (qmc_seq_new + qmc_seq_free, or
 * gsl_qrng_alloc + gsl_qrng_free, which initialises), median of REPS.  A
 * Modbus client or a POINTS request that changes kind, dims, scramble or
 * seed pays one construction, so it is a per-request cost too.
 */
static double builds_per_second(int gen, uint32_t dims)
{
    double rates[REPS];
    for (int r = 0; r < REPS; r++) {
        double n = 0, t0 = now(), t;
        do {
            if (gen == GEN_SOBOL || gen == GEN_HALTON) {
                qmc_seq_free(ours(gen == GEN_SOBOL ? QMC_SEQ_SOBOL : QMC_SEQ_HALTON, dims,
                                  QMC_SCRAMBLE_NONE));
            } else {
                gsl_qrng *q = gsl_qrng_alloc(gen == GEN_GSL_SOBOL ? gsl_qrng_sobol
                                                                  : gsl_qrng_halton, dims);
                if (!q) {
                    fprintf(stderr, "bench_seq: gsl_qrng_alloc failed\n");
                    exit(1);
                }
                gsl_qrng_free(q);
            }
            n++;
        } while ((t = now() - t0) < MIN_SECONDS);
        rates[r] = n / t;
    }
    qsort(rates, REPS, sizeof rates[0], cmp_double);
    return rates[REPS / 2];
}

static void print_builds(void)
{
    static const uint32_t dims_list[] = {2, 8, 32};
    static const int gens[] = {GEN_SOBOL, GEN_HALTON, GEN_GSL_SOBOL, GEN_GSL_HALTON};
    printf("Construction (new + free), thousand instances/s, median of %d\n", REPS);
    printf("%5s", "dims");
    for (size_t g = 0; g < 4; g++)
        printf(" %11s", gen_names[gens[g]]);
    printf(" | %9s %9s\n", "sob/gsl", "hal/gsl");
    for (size_t k = 0; k < sizeof dims_list / sizeof dims_list[0]; k++) {
        double r[4];
        printf("%5u", dims_list[k]);
        for (size_t g = 0; g < 4; g++) {
            r[g] = builds_per_second(gens[g], dims_list[k]);
            printf(" %11.1f", r[g] / 1e3);
        }
        /* Three decimals: GSL's halton_alloc only zeroes a state, so
         * hal/gsl is far below 1 (it has no tables to build). */
        printf(" | %8.3fx %8.3fx\n", r[0] / r[2], r[1] / r[3]);
    }
    printf("\n");
}

static void verdict(const char *what, double ratio, double target)
{
    printf("  %-24s %6.2fx  (target >= %.1fx: %s)\n", what, ratio, target,
           ratio >= target ? "met" : "MISSED");
}

int main(int argc, char **argv)
{
    const size_t l2_bytes = 512 * 1024, dram_bytes = 64u << 20;
    double *buf = aligned_alloc(64, dram_bytes);
    if (!buf)
        return 1;
    FILE *csv = argc > 1 ? fopen(argv[1], "w") : NULL;
    if (csv)
        fprintf(csv, "buffer,dims,generator,coords_per_s\n");
    static const uint32_t dims_list[] = {2, 8, 32, 256};
    printf("Batch fill, f64, %zu KiB buffer (L2-resident); million coordinates/s, "
           "median of %d\n\n", l2_bytes / 1024, REPS);
    printf("%5s", "dims");
    for (int g = 0; g < NGEN; g++)
        printf(" %11s", gen_names[g]);
    printf(" | %9s %9s %9s %9s %9s %9s\n", "sob/gsl", "sob/mset", "owen/gsl", "fowen/gsl",
           "hal/gsl", "shft/gsl");
    double at32[NGEN] = {0};
    double fast_owen_low = 0; /* lowest fast-owen / gsl-sobol over the dims GSL has */
    for (size_t k = 0; k < sizeof dims_list / sizeof dims_list[0]; k++) {
        uint32_t d = dims_list[k];
        double r[NGEN];
        printf("%5u", d);
        for (int g = 0; g < NGEN; g++) {
            r[g] = rate_of(g, d, l2_bytes, buf);
            if (r[g] > 0)
                printf(" %11.1f", r[g] / 1e6);
            else
                printf(" %11s", "n/a");
            if (csv && r[g] > 0)
                fprintf(csv, "l2,%u,%s,%.0f\n", d, gen_names[g], r[g]);
            fflush(stdout);
        }
        printf(" |");
        print_ratio(r[GEN_SOBOL], r[GEN_GSL_SOBOL]);
        print_ratio(r[GEN_SOBOL], r[GEN_MEMSET]);
        print_ratio(r[GEN_SOBOL_OWEN], r[GEN_GSL_SOBOL]);
        print_ratio(r[GEN_SOBOL_FAST_OWEN], r[GEN_GSL_SOBOL]);
        print_ratio(r[GEN_HALTON], r[GEN_GSL_HALTON]);
        print_ratio(r[GEN_SOBOL_SHIFT], r[GEN_GSL_SOBOL]);
        printf("\n");
        if (d == 32)
            memcpy(at32, r, sizeof r);
        if (r[GEN_GSL_SOBOL] > 0) {
            double q = r[GEN_SOBOL_FAST_OWEN] / r[GEN_GSL_SOBOL];
            fast_owen_low = fast_owen_low == 0 || q < fast_owen_low ? q : fast_owen_low;
        }
    }
    printf("\nTargets (issue 2), at d = 32, this run:\n");
    verdict("sobol / gsl-sobol", at32[GEN_SOBOL] / at32[GEN_GSL_SOBOL], 4.0);
    verdict("sobol / memset", at32[GEN_SOBOL] / at32[GEN_MEMSET], 0.5);
    verdict("sobol-owen / gsl-sobol", at32[GEN_SOBOL_OWEN] / at32[GEN_GSL_SOBOL], 1.5);
    verdict("halton / gsl-halton", at32[GEN_HALTON] / at32[GEN_GSL_HALTON], 10.0);
    printf("Target (issue 20), this run:\n");
    verdict("fast-owen / gsl-sobol", at32[GEN_SOBOL_FAST_OWEN] / at32[GEN_GSL_SOBOL], 2.5);
    verdict("  lowest of d = 2, 8, 32", fast_owen_low, 2.5);
    printf("\n");

    print_builds();
    printf("Same at d = 32 with a 64 MiB buffer (DRAM-bound), million coordinates/s\n");
    const int dram_gens[] = {GEN_MEMSET, GEN_SOBOL, GEN_SOBOL_OWEN, GEN_SOBOL_FAST_OWEN,
                             GEN_GSL_SOBOL};
    for (size_t g = 0; g < sizeof dram_gens / sizeof dram_gens[0]; g++) {
        double r = rate_of(dram_gens[g], 32, dram_bytes, buf);
        printf("  %-11s %9.1f\n", gen_names[dram_gens[g]], r / 1e6);
        if (csv)
            fprintf(csv, "dram,32,%s,%.0f\n", gen_names[dram_gens[g]], r);
    }
    if (csv)
        fclose(csv);
    free(buf);
    return 0;
}
