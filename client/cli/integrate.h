/*
 * integrate.h - `qmc integrate` and `qmc merge` internals (private).
 *
 * cmd_integrate.c parses options into a cli_integrate and runs it;
 * integrate_setup.c builds integrands from names or scenes;
 * integrate_output.c prints results (text or JSON) for both commands;
 * partial.c writes --part files; part_read.c reads them (format there);
 * integrate_command.c runs --command, a program of the user's as f.
 */
#ifndef QMC_CLI_INTEGRATE_H
#define QMC_CLI_INTEGRATE_H

#include <stdint.h>
#include <stdio.h>

#include "qmc/integrate.h"
#include "qmc/job.h"
#include "qmc/sampling.h"
#include "qmc/testfn.h"

enum { CLI_MAX_LIST = 1024, CLI_MAX_ARGS = 128 };

/* Everything `qmc integrate` was asked to do. */
typedef struct cli_integrate {
    /* what */
    const char *integrand;        /* testfn name, or NULL with scene */
    const char *scene;            /* scene file, or NULL */
    uint32_t dims;
    int have_dims;
    double a[CLI_MAX_LIST], u[CLI_MAX_LIST];
    size_t n_a, n_u;
    int have_a, have_u;
    const char *difficulty;       /* testpack | fixed | NULL */
    const char *control;          /* testfn name or NULL */
    const char *strategy;         /* scene strategy */
    double beta;
    uint32_t samples_brdf, samples_light;
    /* --command: a program evaluates f (integrate_command.c), with what
     * the user declares about it */
    const char *command;
    const char *command_format;   /* "text" | "f64"; NULL: text */
    uint64_t command_timeout_ms;  /* 0: wait for ever */
    qmc_smoothness smoothness;
    int have_smoothness;
    double exact;
    int have_exact;
    /* how */
    const char *method;
    qmc_sampling_spec spec;
    int have_n, have_reps, have_seq, have_scramble;
    double tol_abs, tol_rel;
    uint64_t max_evals;
    uint64_t max_memory;          /* bytes for cubature regions */
    unsigned threads;
    uint32_t part_k, part_p;      /* part K of P; 0 0 for the whole job */
    int json;
    /* The arguments that define the job (no --part, --threads, --json),
     * kept for partial files so qmc merge can rebuild the job. */
    char *job_args[CLI_MAX_ARGS];
    int n_job_args;
} cli_integrate;

/* The job a cli_integrate names (built by the library, as in qmcd). */
typedef struct cli_problem {
    qmc_job *job;
    const qmc_integrand *f, *g;   /* owned by job */
    double reference;             /* exact or high-accuracy reference */
    int has_reference, reference_exact;
    int is_scene;
    const char *label;            /* e.g. "genz-gaussian" or the scene file */
    /* --command: no job; f points here, at what the user declared about
     * the program's f (dims, smoothness, exact value), for the report
     * and qmc merge.  Its eval gives NaN: nothing here can run f. */
    qmc_integrand declared;
} cli_problem;

/* What was run, for printing. */
typedef struct cli_report {
    const char *requested;        /* the --method given ("auto", ...) */
    const char *method;           /* the method that ran */
    char detail[160];             /* e.g. "sobol owen, 16 x 4096 points" */
    char auto_reason[QMC_AUTO_REASON_BYTES]; /* why auto chose what it chose */
    qmc_result res;
    qmc_cv_report cv;
    double seconds;
    double confidence;            /* the interval's level */
    const cli_problem *problem;
    /* The integral of |f| known in closed form as the daemon told it
     * (protocol version 6; known_abs_told 1).  Untold (0: in-process, a
     * --command, merge, an older daemon), the problem's integrand says. */
    int known_abs_told, has_known_abs;
    double known_abs;
} cli_report;

/* Parses `qmc integrate` options (argv[0] is the subcommand name). */
int cli_integrate_parse(int argc, char **argv, cli_integrate *opt);
/* job_options.c, for every command that fills a cli_integrate: the
 * defaults (auto, 1e8 evaluations, 64 MiB, one thread, ...), and the
 * options naming what to integrate (--integrand, --scene, --dims, --a,
 * --u, --strategy, --beta).  cli_job_option returns 1 when `name` is one
 * of them and arg went into opt, 0 when it is not, -1 after an error. */
void cli_job_options_init(cli_integrate *opt);
int cli_job_option(cli_integrate *opt, const char *name, const char *arg);
/* The qmc_job_spec for opt; *scene_text (free it) holds a --scene file's
 * text.  Prints an error and returns -1 on failure. */
int cli_job_spec(const cli_integrate *opt, qmc_job_spec *spec, char **scene_text);
/* Builds the problem; prints an error and returns -1 on failure. */
int cli_problem_make(const cli_integrate *opt, cli_problem *p);
void cli_problem_free(cli_problem *p);
/* Runs opt on p into rep (not --part); prints errors; returns exit code. */
int cli_integrate_run(const cli_integrate *opt, const cli_problem *p, cli_report *rep);
/* Prints a report as text or one JSON object. */
void cli_report_print(FILE *f, const cli_report *rep, int json);
/* Fills spec-dependent defaults (stratified n = k^d, ...) after parsing. */
int cli_integrate_defaults(cli_integrate *opt, const cli_problem *p);

/* --part: writes the partial result of blocks of part K; merge reads. */
int cli_partial_write(FILE *f, const cli_integrate *opt, const qmc_sampling_job *job,
                      const qmc_sampling_sums *sums, uint64_t first, uint64_t count,
                      double seconds);
/* The same from a job's fingerprint and block count (a --command part,
 * whose job ran in a session). */
int cli_partial_write_sums(FILE *f, const cli_integrate *opt, uint64_t fingerprint,
                           uint64_t blocks, const qmc_sampling_sums *sums, uint64_t first,
                           uint64_t count, double seconds);

/* integrate_command.c.  The problem for --command (the declared f), or
 * -1 after an error line (options that name another integrand). */
int cli_command_problem(const cli_integrate *opt, cli_problem *p);
/* Runs --command in a session, in-process or on the daemon at endpoint
 * (NULL: here), and prints the report or, with --part, the part file.
 * Returns the exit code after one error line on any failure. */
int cli_integrate_command(const cli_integrate *opt, const cli_problem *p,
                          const char *endpoint);
/* "smooth", "kinks", "jumps", "singular" -> *out; -1 for anything else. */
int cli_smoothness_parse(const char *name, qmc_smoothness *out);

int cli_cmd_integrate(int argc, char **argv);
int cli_cmd_merge(int argc, char **argv);

#endif
