/*
 * main.c - the qmc command: dispatch to subcommands, --help, --version.
 *
 * Every subcommand takes --connect ENDPOINT (or QMC_ENDPOINT): points,
 * spectrum and integrate then run on the daemon, ping and stats need one,
 * and discrepancy and merge, which work on local files, accept and ignore
 * it so that scripts can pass it everywhere.
 */
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

static const cli_command commands[] = {
    {"points", cli_cmd_points, 0, "write points of a sequence (CSV or binary)"},
    {"discrepancy", cli_cmd_discrepancy, 1, "discrepancy of a CSV point set"},
    {"spectrum", cli_cmd_spectrum, 0, "Fourier power spectrum of a 2D point set"},
    {"integrate", cli_cmd_integrate, 0, "integrate a test function or a scene"},
    {"merge", cli_cmd_merge, 1, "combine --part results of an integration"},
    {"ping", cli_cmd_ping, 0, "round-trip time and identity of a qmcd daemon"},
    {"stats", cli_cmd_stats, 0, "a qmcd daemon's counters"},
    {"compare", cli_cmd_compare, 0, "methods on your job: error against time, charted"},
    {"stability", cli_cmd_stability, 0, "every method on known failure cases: where bars lie"},
};

static void usage(FILE *f)
{
    fputs("usage: qmc COMMAND [OPTIONS]   (qmc COMMAND --help for options)\n\n"
          "commands:\n", f);
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
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

int main(int argc, char **argv)
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
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++) {
        const cli_command *cmd = &commands[i];
        if (strcmp(argv[1], cmd->name) != 0)
            continue;
        if (cmd->local_only)
            return run_local_only(cmd, argc - 1, argv + 1);
        return cmd->run(argc - 1, argv + 1);
    }
    return cli_error("unknown command '%s' (try qmc --help)", argv[1]);
}
