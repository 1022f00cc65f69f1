/*
 * cmd_ping.c - `qmc ping`: round trips to the daemon, and who it is.
 *
 * Prints the server's identity and limits from the handshake, whether its
 * Sobol table is the one this qmc was built with (if not, the two would
 * generate different points), and one round-trip time per PING.
 */
#include <getopt.h>
#include <string.h>

#include "cli.h"
#include "json.h"

static const char ping_help[] =
    "usage: qmc ping --connect ENDPOINT [--count N] [--json]\n"
    "\n"
    "Connects to the qmcd daemon, prints its identity (server, engine, Sobol\n"
    "table fingerprint and whether it matches this qmc's) and its limits, then\n"
    "sends N PINGs (default 1) and prints each round-trip time.\n"
    "\n"
    "  --count N         pings to send, 1 .. 1000\n"
    "  --json            one JSON object instead: server, engine, sobol_table\n"
    "                    (hex), sobol_table_matches, max_frame_bytes,\n"
    "                    max_inflight, max_points, rtt_ms (one per PING)\n";

/* The same facts as the text, for scripts: times in milliseconds. */
static int print_json(const qmc_client *c, const double *rtt, size_t count)
{
    uint64_t theirs = qmc_client_sobol_table_hash(c);
    char hex[17];
    snprintf(hex, sizeof hex, "%016llx", (unsigned long long)theirs);
    double ms[1000];
    for (size_t i = 0; i < count; i++)
        ms[i] = 1e3 * rtt[i];
    putchar('{');
    cli_json_str(stdout, "server", qmc_client_server_name(c), 1);
    cli_json_str(stdout, "engine", qmc_client_engine(c), 1);
    cli_json_str(stdout, "sobol_table", hex, 1);
    cli_json_bool(stdout, "sobol_table_matches", theirs == qmc_sobol_table_hash(), 1);
    cli_json_u64(stdout, "max_frame_bytes", qmc_client_max_frame(c), 1);
    cli_json_u64(stdout, "max_inflight", qmc_client_max_inflight(c), 1);
    cli_json_u64(stdout, "max_points", qmc_client_max_points(c), 1);
    cli_json_num_array(stdout, "rtt_ms", ms, count, 0);
    fputs("}\n", stdout);
    if (ferror(stdout) || fflush(stdout) != 0)
        return cli_error("ping: writing the output failed");
    return 0;
}

int cli_cmd_ping(int argc, char **argv)
{
    static const struct option longopts[] = {
        {"count", required_argument, 0, 0},
        {"json", no_argument, 0, 0},
        {"help", no_argument, 0, 0},
        {0, 0, 0, 0},
    };
    const char *endpoint;
    if (cli_remote_take(&argc, argv, &endpoint))
        return CLI_EXIT_FAIL;
    uint64_t count = 1;
    int json = 0;
    int first = 1, more;
    const char *name, *arg;
    while ((more = cli_next_option("ping", argc, argv, longopts, &first, &name, &arg)) > 0) {
        if (strcmp(name, "help") == 0) {
            fputs(ping_help, stdout);
            fputs(cli_remote_help, stdout);
            return CLI_EXIT_OK;
        }
        if (strcmp(name, "count") == 0 && cli_parse_u64("--count", arg, 1, 1000, &count))
            return CLI_EXIT_FAIL;
        if (strcmp(name, "json") == 0)
            json = 1;
    }
    if (more < 0)
        return CLI_EXIT_FAIL;
    if (!endpoint)
        return cli_error("ping: no daemon to ping: give --connect ENDPOINT or set "
                         "QMC_ENDPOINT");
    qmc_client *c = NULL;
    if (cli_remote_connect(endpoint, &c))
        return CLI_EXIT_FAIL;
    /* Every ping first, so that an error leaves nothing on stdout. */
    double rtt[1000];
    int rc = 0;
    for (uint64_t i = 0; i < count && rc == 0; i++) {
        int err = qmc_client_ping(c, &rtt[i]);
        if (err)
            rc = cli_remote_fail(c, err, "ping: ");
    }
    if (rc == 0 && json) {
        rc = print_json(c, rtt, (size_t)count);
    } else if (rc == 0) {
        uint64_t ours = qmc_sobol_table_hash(), theirs = qmc_client_sobol_table_hash(c);
        printf("server     %s\n", qmc_client_server_name(c));
        printf("engine     %s\n", qmc_client_engine(c));
        printf("sobol      %016llx (%s)\n", (unsigned long long)theirs,
               ours == theirs ? "the same table as this qmc" : "DIFFERS from this qmc's table");
        printf("limits     frames up to %u bytes, %u requests in flight, %llu points a "
               "request\n", qmc_client_max_frame(c), qmc_client_max_inflight(c),
               (unsigned long long)qmc_client_max_points(c));
        for (uint64_t i = 0; i < count; i++)
            printf("rtt        %.3f ms\n", 1e3 * rtt[i]);
        if (fflush(stdout) != 0)
            rc = cli_error("ping: writing the output failed");
    }
    qmc_client_close(c);
    return rc;
}
