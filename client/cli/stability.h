/*
 * stability.h - `qmc stability` internals (private to the CLI).
 *
 * stability_cases.c holds the failure cases and the method columns;
 * cmd_stability.c parses options and runs the matrix; stability_output.c
 * writes the CSV, REPORT.md, JSON and the heat map.  Classification itself
 * is in the library (qmc/stability.h).
 */
#ifndef QMC_CLI_STABILITY_H
#define QMC_CLI_STABILITY_H

#include <stdint.h>
#include <stdio.h>

#include "method_spec.h"
#include "qmc/scene.h"
#include "qmc/stability.h"
#include "qmc/testfn.h"

/* a and u values a case may give: up to 5 dims, or a poly's coefficients */
enum { CLI_STAB_MAX_PARAMS = QMC_TESTFN_MAX_COEFS };

/* One failure case: an integrand (or a scene and strategy) that breaks
 * some method's error bar, with a reference computed without any of the
 * methods under test. */
typedef struct cli_stab_case {
    const char *name;             /* row label, e.g. "peak-gauss-2d" */
    const char *category;         /* the class, e.g. "narrow peak" */
    const char *why;              /* one line: what it probes */
    /* a test function ... */
    const char *integrand;        /* NULL for a scene */
    uint32_t dims;
    double a[CLI_STAB_MAX_PARAMS], u[CLI_STAB_MAX_PARAMS];
    uint32_t n_params;            /* 0: --difficulty fixed, seed 0 */
    int infinite;                 /* the integral overflows a double */
    double scale;                 /* int |f| (or a bound) where the test
                                     function does not know it, for the
                                     rounding slack of near-zero integrals */
    /* ... or a scene */
    const char *scene;            /* scene text */
    qmc_scene_strategy strategy;
    double beta;                  /* mis-power; 0: 2 */
    /* the budget */
    uint64_t evals;               /* sampling and tensor rules (0: default);
                                     also caps the adaptive methods when
                                     tiny is set */
    int tiny;                     /* a tiny budget for every method */
    uint32_t seeds;               /* seeds for randomized methods (0: default) */
} cli_stab_case;

extern const cli_stab_case cli_stab_cases[];
extern const size_t cli_stab_case_count;
/* The method columns, as cli_method_parse tokens. */
extern const char *const cli_stab_methods[];
extern const size_t cli_stab_method_count;

/* A cell: one method on one case, over its seeds. */
typedef struct cli_stab_cell {
    const cli_stab_case *c;
    const cli_method *m;
    qmc_stab_tally tally;
    qmc_stab_flag_tally flags;    /* each flag on its correct and wrong runs */
    qmc_stab_class cls;
    /* the run shown (the first whose class is the cell's) */
    qmc_result res;
    qmc_stab_verdict v;
    uint64_t seed;
    char method_used[24];
    char reason[160];             /* refusal text */
    double seconds;               /* all its runs */
} cli_stab_cell;

/* The reference of a case. */
typedef struct cli_stab_ref {
    qmc_stab_truth truth;
    const char *source;           /* "closed form", "scene closed form",
                                     "scene quadrature", "overflows" */
} cli_stab_ref;

typedef struct cli_stab_matrix {
    int quick;
    uint64_t default_evals, adaptive_evals;
    uint32_t default_seeds;
    size_t n_cases, n_methods;
    const cli_stab_case **cases;  /* rows */
    cli_method *methods;          /* columns */
    cli_stab_ref *refs;           /* per row */
    cli_stab_cell *cells;         /* row-major */
    uint32_t count[4];            /* cells per class */
    uint32_t ok_flagged_runs, runs;
    /* the same, on the cases without a tiny budget: there a flag on a
     * correct answer is a false alarm, while at 16 evaluations the issue
     * asks for one ("n below the heavy-tail test's minimum") */
    uint32_t ok_flagged_runs_normal, runs_normal;
    /* what each flag is worth: its runs on correct and on wrong answers,
     * at normal budgets and on the tiny-budget cases */
    qmc_stab_flag_tally flags_normal, flags_tiny;
    double seconds;
} cli_stab_matrix;

/* Output (stability_output.c).  Each prints its own errors, returns -1. */
struct cli_outdir;
int cli_stab_write_csv(FILE *f, const cli_stab_matrix *mx);
int cli_stab_write_report(FILE *f, const cli_stab_matrix *mx);
void cli_stab_print_json(FILE *f, const cli_stab_matrix *mx);
void cli_stab_print_summary(FILE *f, const cli_stab_matrix *mx);
int cli_stab_write_heatmap(struct cli_outdir *od, const cli_stab_matrix *mx);

int cli_cmd_stability(int argc, char **argv);

#endif
