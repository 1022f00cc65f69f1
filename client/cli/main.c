/*
 * main.c - the qmc command: dispatch to subcommands, --help, --version.
 *
 * Every subcommand takes --connect ENDPOINT (or QMC_ENDPOINT): points,
 * pixels, spectrum and integrate then run on the daemon, ping and stats need one,
 * and discrepancy and merge, which work on local files, accept and ignore
 * it so that scripts can pass it everywhere.
 *
 * `qmc help` lists the commands; `qmc help COMMAND` runs COMMAND --help
 * through the same dispatch, so the two can never print different text.
 */
#include <errno.h>
#include <string.h>

#include "cli.h"
#include "compare.h"
#include "integrate.h"
#include "stability.h"

typedef struct cli_command {
    const char *name;
    int (*run)(int argc, char **argv);
    int local_only;               /* --connect accepted and ignored */
    const char *summary;
} cli_command;

static int cmd_help(int argc, char **argv);

static const cli_command commands[] = {
    {"points", cli_cmd_points, 0, "write points of a sequence (CSV or binary)"},
    {"pixels", cli_cmd_pixels, 0, "write a tile of a renderer's pixel sampler (binary)"},
    {"discrepancy", cli_cmd_discrepancy, 1, "discrepancy of a CSV point set"},
    {"spectrum", cli_cmd_spectrum, 0, "Fourier power spectrum of a 2D point set"},
    {"integrate", cli_cmd_integrate, 0, "integrate a test function, a scene or your program"},
    {"merge", cli_cmd_merge, 1, "combine --part results of an integration"},
    {"ping", cli_cmd_ping, 0, "round-trip time and identity of a qmcd daemon"},
    {"stats", cli_cmd_stats, 0, "a qmcd daemon's counters"},
    {"compare", cli_cmd_compare, 0, "methods on your job: error against time, charted"},
    {"stability", cli_cmd_stability, 0, "every method on known failure cases: where bars lie"},
    {"help", cmd_help, 0, "this list, or a command's options (qmc help COMMAND)"},
};

enum { N_COMMANDS = sizeof commands / sizeof commands[0] };

static void usage(FILE *f)
{
    fputs("usage: qmc COMMAND [OPTIONS]   (qmc help COMMAND for options)\n\n"
          "commands:\n", f);
    for (size_t i = 0; i < N_COMMANDS; i++)
        fprintf(f, "  %-12s %s\n", commands[i].name, commands[i].summary);
    fputs("\nEvery command takes --connect ENDPOINT (unix:PATH or tcp:HOST:PORT; default\n"
          "$QMC_ENDPOINT) to run on a qmcd daemon, with the same output.\n", f);
}

static void version(void)
{
    printf("qmc (qmcd) 0.1.0\n"
           "Sobol direction numbers: S. Joe and F. Y. Kuo, new-joe-kuo-6.21201,\n"
           "Copyright (c) 2008, Frances Y. Kuo and Stephen Joe (BSD 3-clause).\n"
           "Sobol table fingerprint: %016llx\n",
           (unsigned long long)qmc_sobol_table_hash());
}

/* discrepancy and merge read local files: --connect is taken off their
 * arguments (for uniformity) and their --help says so. */
static int run_local_only(const cli_command *cmd, int argc, char **argv)
{
    const char *endpoint;
    if (cli_remote_take(&argc, argv, &endpoint))
        return CLI_EXIT_FAIL;
    int help = 0;
    for (int i = 1; i < argc; i++)
        help |= strcmp(argv[i], "--help") == 0;
    int rc = cmd->run(argc, argv);
    if (help && rc == CLI_EXIT_OK)
        printf("\n  --connect ENDPOINT  accepted for uniformity with the other commands\n"
               "                    (as is QMC_ENDPOINT); %s works on local files\n"
               "                    and never contacts the daemon\n", cmd->name);
    return rc;
}

static const cli_command *find_command(const char *name)
{
    for (size_t i = 0; i < N_COMMANDS; i++)
        if (strcmp(name, commands[i].name) == 0)
            return &commands[i];
    return NULL;
}

/* Runs cmd with argv[0] its name. */
static int run_command(const cli_command *cmd, int argc, char **argv)
{
    if (cmd->local_only)
        return run_local_only(cmd, argc, argv);
    return cmd->run(argc, argv);
}

static const char help_help[] =
    "usage: qmc help [COMMAND]\n"
    "\n"
    "Without COMMAND, lists the commands with a one-line summary each (as\n"
    "qmc --help does); with one, prints what `qmc COMMAND --help` prints.\n";

static int cmd_help(int argc, char **argv)
{
    if (argc == 1) {
        usage(stdout);
        return CLI_EXIT_OK;
    }
    if (argc > 2)
        return cli_error("help: give one COMMAND, not %d words (qmc help lists them)",
                         argc - 1);
    if (strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "help") == 0) {
        fputs(help_help, stdout);
        return CLI_EXIT_OK;
    }
    const cli_command *cmd = find_command(argv[1]);
    if (!cmd)
        return cli_error("help: unknown command '%s' (qmc help lists them)", argv[1]);
    static char help_flag[] = "--help";
    char *sub[] = {argv[1], help_flag, NULL};
    return run_command(cmd, 2, sub);
}

/* Every command's stdout goes through here once the command is done: a
 * write error that stdio kept in its buffer (a full disk, > /dev/full, a
 * closed pipe) shows at the final flush or close, and turns success into
 * a one-line error and exit status 2.  A command that already failed
 * said why; its exit status stands. */
static int close_stdout(int rc)
{
    errno = 0;
    int bad = fflush(stdout) != 0 || ferror(stdout);
    int err = errno;
    if (fclose(stdout) != 0 && !bad) {
        bad = 1;
        err = errno;
    }
    if (bad && rc == CLI_EXIT_OK)
        return cli_error("writing to standard output: %s", strerror(err ? err : EIO));
    return rc;
}

static int run(int argc, char **argv);

int main(int argc, char **argv)
{
    return close_stdout(run(argc, argv));
}

static int run(int argc, char **argv)
{
    if (argc < 2) {
        usage(stderr);
        return CLI_EXIT_FAIL;
    }
    if (strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0) {
        usage(stdout);
        return CLI_EXIT_OK;
    }
    if (strcmp(argv[1], "--version") == 0) {
        version();
        return CLI_EXIT_OK;
    }
    const cli_command *cmd = find_command(argv[1]);
    if (cmd)
        return run_command(cmd, argc - 1, argv + 1);
    return cli_error("unknown command '%s' (qmc help lists them)", argv[1]);
}
