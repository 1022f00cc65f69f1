/*
 * compare.h - `qmc compare` internals (private to the CLI).
 *
 * cmd_compare.c parses options, builds the job and the reference, and runs
 * every method over the budget ladder (in-process or on a daemon);
 * compare_report.c writes compare.csv, REPORT.md and the charts.
 */
#ifndef QMC_CLI_COMPARE_H
#define QMC_CLI_COMPARE_H

#include <stdint.h>
#include <stdio.h>

#include "method_spec.h"
#include "qmc/stability.h"

enum { CLI_CMP_MAX_METHODS = 24, CLI_CMP_MAX_BUDGETS = 64 };

/* One run: a method at a budget with one seed. */
typedef struct cli_cmp_run {
    uint32_t method, budget_index, rep;
    uint64_t budget;
    int refused;
    char reason[160];
    qmc_result res;
    qmc_stab_verdict v;
    double seconds;
} cli_cmp_run;

/* Medians over the reps of one (method, budget). */
typedef struct cli_cmp_point {
    uint32_t method;
    uint64_t budget;
    uint32_t runs;              /* not refused */
    double seconds, error, evals;
    int pareto;                 /* on the error-time front */
} cli_cmp_point;

typedef struct cli_cmp {
    const char *label;          /* integrand name or scene file */
    uint32_t dims;
    cli_method methods[CLI_CMP_MAX_METHODS];
    uint32_t n_methods;
    uint64_t budgets[CLI_CMP_MAX_BUDGETS];
    uint32_t n_budgets;
    uint32_t reps;
    const char *endpoint;       /* NULL: in-process */
    qmc_stab_truth truth;
    const char *ref_source;     /* "exact", "scene quadrature", ... */
    cli_cmp_run *runs;
    size_t n_runs;
    cli_cmp_point *points;
    size_t n_points;
    double slope[CLI_CMP_MAX_METHODS];   /* fitted d log(error) / d log(evals) */
    double intercept[CLI_CMP_MAX_METHODS]; /* log10 error at 1 evaluation */
    double fit_lo[CLI_CMP_MAX_METHODS], fit_hi[CLI_CMP_MAX_METHODS]; /* evals fitted */
    int has_slope[CLI_CMP_MAX_METHODS];
    int at_rounding[CLI_CMP_MAX_METHODS]; /* points left out: at rounding */
} cli_cmp;

/* compare_report.c: medians, the Pareto front and slopes, then files.
 * Each prints its own errors and returns -1. */
int cli_cmp_summarize(cli_cmp *c);
struct cli_outdir;
int cli_cmp_write(struct cli_outdir *od, const cli_cmp *c);

int cli_cmd_compare(int argc, char **argv);

#endif
