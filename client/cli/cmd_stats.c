/*
 * cmd_stats.c - `qmc stats`: the daemon's counters, one "name value" line
 * each, in the daemon's order; --json for scripts, --format prometheus
 * for node_exporter's textfile collector (stats_format.c).
 */
#include <getopt.h>
#include <string.h>

#include "cli.h"
#include "stats_format.h"

static const char stats_help[] =
    "usage: qmc stats --connect ENDPOINT [--json | --format text|json|prometheus]\n"
    "\n"
    "Prints the qmcd daemon's counters (requests, points and bytes served,\n"
    "jobs, errors, ...) and its request-latency histogram, one \"name value\"\n"
    "line each.\n"
    "\n"
    "  --json            one JSON object {\"name\": value, ...}\n"
    "  --format F        text (default), json, or prometheus: the Prometheus\n"
    "                    text exposition format (metrics in docs/OPERATIONS.md)\n";

enum { STATS_MAX = QMC_PROTO_MAX_STATS };

typedef struct stats_list {
    char name[STATS_MAX][QMC_PROTO_MAX_NAME + 1];
    uint64_t value[STATS_MAX];
    unsigned n;
} stats_list;

static int keep(void *ctx, const char *name, uint64_t value)
{
    stats_list *l = ctx;
    if (l->n == STATS_MAX)
        return 0;
    memcpy(l->name[l->n], name, strlen(name) + 1);
    l->value[l->n++] = value;
    return 0;
}

int cli_cmd_stats(int argc, char **argv)
{
    static const struct option longopts[] = {
        {"help", no_argument, 0, 0},
        {"json", no_argument, 0, 0},
        {"format", required_argument, 0, 0},
        {0, 0, 0, 0},
    };
    enum { TEXT, JSON, PROMETHEUS } format = TEXT;
    const char *endpoint;
    if (cli_remote_take(&argc, argv, &endpoint))
        return CLI_EXIT_FAIL;
    int first = 1, more;
    const char *name, *arg;
    while ((more = cli_next_option("stats", argc, argv, longopts, &first, &name, &arg)) > 0) {
        if (strcmp(name, "help") == 0) {
            fputs(stats_help, stdout);
            fputs(cli_remote_help, stdout);
            return CLI_EXIT_OK;
        }
        if (strcmp(name, "json") == 0) {
            format = JSON;
        } else if (strcmp(name, "format") == 0) {
            if (strcmp(arg, "text") == 0)
                format = TEXT;
            else if (strcmp(arg, "json") == 0)
                format = JSON;
            else if (strcmp(arg, "prometheus") == 0)
                format = PROMETHEUS;
            else
                return cli_error("stats: --format '%s': expected text, json or prometheus", arg);
        }
    }
    if (more < 0)
        return CLI_EXIT_FAIL;
    if (!endpoint)
        return cli_error("stats: no daemon to ask: give --connect ENDPOINT or set "
                         "QMC_ENDPOINT");
    qmc_client *c = NULL;
    if (cli_remote_connect(endpoint, &c))
        return CLI_EXIT_FAIL;
    stats_list l; /* 17 KiB: the protocol's cap on entries */
    l.n = 0;
    int rc = 0, err = qmc_client_stats(c, keep, &l);
    if (err) {
        rc = cli_remote_fail(c, err, "stats: ");
    } else {
        static cli_stat entries[STATS_MAX];
        for (unsigned i = 0; i < l.n; i++)
            entries[i] = (cli_stat){l.name[i], l.value[i]};
        if (format == JSON)
            cli_stats_print_json(stdout, entries, l.n);
        else if (format == PROMETHEUS)
            cli_stats_print_prometheus(stdout, entries, l.n);
        else
            cli_stats_print_text(stdout, entries, l.n);
        if (fflush(stdout) != 0)
            rc = cli_error("stats: writing the output failed");
    }
    qmc_client_close(c);
    return rc;
}
