/*
 * cli.h - helpers shared by the qmc subcommands (private to the CLI).
 *
 * The CLI is the only layer besides the daemon that talks to people.  Its
 * rule for errors: one line on stderr naming the problem, exit status 2,
 * nothing partial on stdout.
 */
#ifndef QMC_CLI_H
#define QMC_CLI_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "qmc/client.h"
#include "qmc/integrate.h"
#include "qmc/seq.h"

enum { CLI_EXIT_OK = 0, CLI_EXIT_FAIL = 2 };

/* Prints "qmc: <message>" and a newline to stderr.  Returns CLI_EXIT_FAIL so
 * callers can write `return cli_error(...)`. */
int cli_error(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

/* Parse a whole-string number into [min, max]; on failure print an error
 * naming the option and return -1. */
int cli_parse_u64(const char *opt, const char *text, uint64_t min,
                  uint64_t max, uint64_t *out);
int cli_parse_double(const char *opt, const char *text, double *out);

/* Options every sequence-producing subcommand shares.  cli_seq_option
 * returns 1 when it consumed option `name` (with argument `arg`), 0 when the
 * option is not a sequence option, -1 after printing an error. */
typedef struct cli_seq_opts {
    qmc_seq_spec spec;
    int have_kind;
    int have_set_size;
} cli_seq_opts;

void cli_seq_opts_init(cli_seq_opts *o);
int cli_seq_option(cli_seq_opts *o, const char *name, const char *arg);

/* Completes and checks the spec: --seq is required; finite kinds take
 * set_size from --set-size or else default_set_size.  Prints the library's
 * reason on failure and returns -1. */
int cli_seq_finish(cli_seq_opts *o, uint64_t default_set_size);

/* Help text for the shared sequence options. */
extern const char cli_seq_help[];

/* Walks a subcommand's long options (every option is long-only; getopt
 * state is reset on the first call).  Returns 1 with *name and *arg set
 * for the next option, 0 at the end (after checking that no positional
 * argument is left), or -1 after printing an error naming the option. */
struct option;
int cli_next_option(const char *cmd, int argc, char **argv,
                    const struct option *longopts, int *first,
                    const char **name, const char **arg);

/* Writes all of buf to f; prints an error and returns -1 on failure. */
int cli_write_all(FILE *f, const void *buf, size_t bytes, const char *what);
/* Comma-separated list options ("mc,rqmc", "0.3,0.6").  cli_list_next
 * returns 0 at the end of the list at *p; else it points *item at the
 * next item, *len bytes long (0 for the empty item of ",,"), and moves *p
 * past it and its comma.  A trailing comma ends the list after the item
 * before it; a caller that refuses one checks (*item)[*len] == ',' with
 * **p == '\0'.  cli_list_copy copies an item into buf as a string: -1 if
 * it is empty or does not fit in bytes. */
int cli_list_next(const char **p, const char **item, size_t *len);
int cli_list_copy(const char *item, size_t len, char *buf, size_t bytes);
/* Copies src into dst (bytes long, at least 1) as a string, cut to
 * bytes - 1 characters where it is longer: report texts into fixed fields. */
void cli_copy_text(char *dst, size_t bytes, const char *src);
/* Seconds on the monotonic clock: what every run's wall time is measured
 * by (differences only). */
double cli_now_seconds(void);

/* Subcommands: each takes argv with argv[0] the subcommand name. */
int cli_cmd_points(int argc, char **argv);
int cli_cmd_pixels(int argc, char **argv);
int cli_cmd_discrepancy(int argc, char **argv);
int cli_cmd_spectrum(int argc, char **argv);
int cli_cmd_ping(int argc, char **argv);
int cli_cmd_stats(int argc, char **argv);

/*
 * Remote mode (remote.c).  Every subcommand takes --connect ENDPOINT; the
 * QMC_ENDPOINT environment variable is the default and the flag wins.  An
 * empty endpoint (--connect '') means in-process.
 */
/* How long to wait for the daemon: to connect, and for each answer. */
#define CLI_REMOTE_TIMEOUT_MS 30000
/* Removes every --connect ENDPOINT / --connect=ENDPOINT from argv (before
 * a subcommand parses it) and sets *endpoint: the last flag's, else
 * $QMC_ENDPOINT, else NULL for in-process.  Returns 0, or -1 after
 * printing an error (--connect without an endpoint). */
int cli_remote_take(int *argc, char **argv, const char **endpoint);
/* Connects; on failure prints one error line and returns CLI_EXIT_FAIL. */
int cli_remote_connect(const char *endpoint, qmc_client **out);
/* Prints "qmc: <prefix><the client's message>" and returns CLI_EXIT_FAIL. */
int cli_remote_fail(const qmc_client *c, int err, const char *prefix);
/* Refuses an in-process option given with --connect: prints "OPTION is
 * an in-process option: the daemon runs WHAT on its own pool (drop it, or
 * --connect '' to run here)" and returns CLI_EXIT_FAIL. */
int cli_remote_in_process_only(const char *option, const char *what);
/* Help text for --connect. */
extern const char cli_remote_help[];

/* `qmc integrate` pieces shared with remote mode (integrate_run.c); the
 * types are in integrate.h. */
struct cli_integrate;
struct cli_problem;
struct cli_report;
/* The integrate spec for the options (prints errors; returns -1). */
int cli_integrate_spec(const struct cli_integrate *opt, qmc_integrate_spec *s);
/* Runs the job on the daemon at endpoint and fills rep as
 * cli_integrate_run does; seconds are the server's compute time. */
int cli_integrate_remote(const struct cli_integrate *opt, const struct cli_problem *p,
                         const char *endpoint, struct cli_report *rep);

#endif
