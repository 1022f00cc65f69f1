/*
 * stats_format.h - `qmc stats` output formats: text, JSON and the
 * Prometheus text exposition format (version 0.0.4).
 */
#ifndef QMC_CLI_STATS_FORMAT_H
#define QMC_CLI_STATS_FORMAT_H

#include <stdint.h>
#include <stdio.h>

/* The daemon's STATS entries, in its order. */
typedef struct cli_stat {
    const char *name;
    uint64_t value;
} cli_stat;

/* "name value" lines. */
void cli_stats_print_text(FILE *f, const cli_stat *s, unsigned n);
/* One JSON object {"name": value, ...} and a newline. */
void cli_stats_print_json(FILE *f, const cli_stat *s, unsigned n);
/*
 * Prometheus text format: counters qmcd_*_total, gauges, the request
 * counts as qmcd_requests_total{type="..."}, and the latency histogram
 * qmcd_request_latency_seconds (docs/OPERATIONS.md lists every metric).
 * Entries this qmc does not know are exported untyped as qmcd_<name>, so
 * a newer daemon's counters still arrive.
 */
void cli_stats_print_prometheus(FILE *f, const cli_stat *s, unsigned n);

#endif
