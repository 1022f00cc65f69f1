/*
 * stats_format.c - turns the daemon's STATS entries into text, JSON or the
 * Prometheus text exposition format.
 *
 * Prometheus: every entry becomes a sample of a metric family, and each
 * family is printed once, contiguously, as "# HELP", "# TYPE" and its
 * samples (the format forbids a family in two places).  The latency
 * histogram comes from the cumulative latency_le_us_T entries (requests of
 * at most T microseconds), latency_sum_us and latency_count; le is T in
 * seconds, printed exactly (T us = T / 10^6 s, six decimals), so a request
 * of exactly 2^k us is never counted under an le it exceeds.  The
 * percentile entries (latency_p50_us ...) are left out: they are the
 * histogram's, coarser than Prometheus's own histogram_quantile.
 *
 * This file must not talk to the daemon; it formats what it is given.
 */
#include <stdlib.h>
#include <string.h>

#include "json.h"
#include "stats_format.h"

void cli_stats_print_text(FILE *f, const cli_stat *s, unsigned n)
{
    for (unsigned i = 0; i < n; i++)
        fprintf(f, "%-32s %llu\n", s[i].name, (unsigned long long)s[i].value);
}

void cli_stats_print_json(FILE *f, const cli_stat *s, unsigned n)
{
    fputc('{', f);
    for (unsigned i = 0; i < n; i++) {
        fputs(i ? ", " : "", f);
        cli_json_string(f, s[i].name); /* protocol text: escape what JSON requires */
        fprintf(f, ": %llu", (unsigned long long)s[i].value);
    }
    fputs("}\n", f);
}

/* ---- Prometheus --------------------------------------------------------- */

/* The entries this qmc documents: the daemon's counters (each exported as
 * qmcd_NAME_total) and gauges (qmcd_NAME). */
typedef struct known_stat {
    const char *name;
    int gauge;
    const char *help;
} known_stat;

static const known_stat known[] = {
    {"connections_accepted", 0, "Connections accepted."},
    {"connections_rejected", 0, "Connections refused for max-connections."},
    {"connections_closed", 0, "Connections closed, for any reason."},
    {"connections_timed_out", 0, "Connections closed by a handshake, idle, frame or write "
                                 "timeout."},
    {"bytes_in", 0, "Bytes received from clients."},
    {"bytes_out", 0, "Bytes sent to clients."},
    {"frames_in", 0, "Frames received."},
    {"frames_out", 0, "Frames sent."},
    {"malformed_frames", 0, "Frames refused as malformed."},
    {"errors_sent", 0, "ERROR frames sent."},
    {"limit_refusals", 0, "Requests refused because a configured limit was reached."},
    {"points_sent", 0, "Points sent in POINTS answers."},
    {"pixel_samples_sent", 0, "Samples sent in PIXELS answers."},
    {"jobs_accepted", 0, "INTEGRATE jobs accepted."},
    {"jobs_done", 0, "Jobs finished with a result."},
    {"jobs_failed", 0, "Jobs that ended in an error."},
    {"jobs_cancelled", 0, "Jobs cancelled by their client or at shutdown."},
    {"jobs_timed_out", 0, "Jobs stopped by job-time-limit-ms."},
    {"config_reloads", 0, "Configuration reloads applied (SIGHUP)."},
    {"jobs_dropped", 0, "Jobs whose connection closed before their answer was sent."},
    {"auth_failures", 0, "Handshakes refused for a wrong key proof."},
    {"auth_lockouts", 0, "Handshakes refused because the address was locked out."},
    {"refused_connections_per_peer", 0, "Connections refused for max-connections-per-peer."},
    {"out_buffer_waits", 0, "Times a stream waited for out-buffer-total-bytes."},
    {"refused_jobs_per_conn", 0, "INTEGRATEs refused for max-jobs-per-conn."},
    {"refused_jobs", 0, "INTEGRATEs refused for max-jobs."},
    {"refused_cancels_per_conn", 0, "JOB_CANCELs refused for max-cancels-per-conn."},
    {"refused_job_memory", 0, "INTEGRATEs refused: alone over max-jobs-memory-total."},
    {"job_memory_waits", 0, "Jobs that waited for max-jobs-memory-total before they ran."},
    {"job_memory_backfills", 0, "Jobs that started ahead of a job waiting for its memory."},
    {"sessions_opened", 0, "Integration sessions opened."},
    {"sessions_done", 0, "Sessions that ended with a result."},
    {"sessions_failed", 0, "Sessions that ended in an error."},
    {"sessions_closed", 0, "Sessions closed by SESSION_CLOSE."},
    {"sessions_parked", 0, "Times a session's connection went and it was kept for a resume."},
    {"sessions_resumed", 0, "Sessions taken up again by SESSION_RESUME."},
    {"sessions_expired", 0, "Parked sessions freed after session-idle-timeout-ms."},
    {"refused_sessions", 0, "SESSION_OPENs refused by a session or memory cap."},
    {"refused_session_values", 0, "SESSION_VALUES refused."},
    {"session_batches", 0, "Session batches whose values were all taken."},
    {"session_values", 0, "Values taken from clients in session batches."},
    {"session_nonfinite_values", 0, "Session values that were NaN or infinite."},
    {"connections_open", 1, "Connections open now."},
    {"jobs_open", 1, "Jobs queued or running now."},
    {"job_memory_reserved_bytes", 1, "Bytes of max-jobs-memory-total reserved by running "
                                     "jobs now."},
    {"job_memory_waiting", 1, "1 while a job waits for its memory (others may backfill)."},
    {"sessions_open", 1, "Integration sessions open now, attached or parked."},
    {"sessions_parked_now", 1, "Sessions parked now (their connection gone)."},
    {"session_memory_reserved_bytes", 1, "Bytes the open sessions reserve."},
};

enum { FAM_MAX = 256, SAMPLES_MAX = 256, NAME_BYTES = 96 };

typedef struct family {
    char name[NAME_BYTES];
    const char *type;
    char help[160];
    unsigned first;              /* index of its first sample */
} family;

typedef struct sample {
    unsigned fam;
    char labels[NAME_BYTES];     /* "" or {type="PING"} / {le="0.000015"} */
    char value[32];
} sample;

typedef struct prom {
    family fam[FAM_MAX];
    unsigned n_fam;
    sample smp[SAMPLES_MAX];
    unsigned n_smp;
} prom;

/* The family called name, created with type and help on first use. */
static unsigned family_of(prom *p, const char *name, const char *type, const char *help)
{
    for (unsigned i = 0; i < p->n_fam; i++)
        if (strcmp(p->fam[i].name, name) == 0)
            return i;
    family *fa = &p->fam[p->n_fam];
    snprintf(fa->name, sizeof fa->name, "%s", name);
    fa->type = type;
    snprintf(fa->help, sizeof fa->help, "%s", help);
    return p->n_fam++;
}

static void add(prom *p, unsigned fam, const char *labels, const char *value)
{
    if (p->n_smp == SAMPLES_MAX)
        return;
    sample *s = &p->smp[p->n_smp++];
    s->fam = fam;
    snprintf(s->labels, sizeof s->labels, "%s", labels);
    snprintf(s->value, sizeof s->value, "%s", value);
}

/* Microseconds as exact decimal seconds. */
static void us_to_seconds(uint64_t us, char *out, size_t bytes)
{
    snprintf(out, bytes, "%llu.%06llu", (unsigned long long)(us / 1000000),
             (unsigned long long)(us % 1000000));
}

/* A metric name from an entry name: [a-zA-Z0-9_] kept, anything else '_'. */
static void metric_name(const char *prefix, const char *entry, const char *suffix, char *out,
                        size_t bytes)
{
    snprintf(out, bytes, "%s%s%s", prefix, entry, suffix);
    for (char *c = out; *c; c++)
        if (!((*c >= 'a' && *c <= 'z') || (*c >= 'A' && *c <= 'Z') ||
              (*c >= '0' && *c <= '9') || *c == '_'))
            *c = '_';
}

static const char LAT_FAMILY[] = "qmcd_request_latency_seconds";

void cli_stats_print_prometheus(FILE *f, const cli_stat *s, unsigned n)
{
    prom *p = calloc(1, sizeof *p);
    if (!p)
        return;
    const cli_stat *lat_sum = NULL, *lat_count = NULL;
    int have_buckets = 0;
    for (unsigned i = 0; i < n; i++)
        if (strncmp(s[i].name, "latency_le_us_", 14) == 0)
            have_buckets = 1;
        else if (strcmp(s[i].name, "latency_sum_us") == 0)
            lat_sum = &s[i];
        else if (strcmp(s[i].name, "latency_count") == 0)
            lat_count = &s[i];
    int histogram = have_buckets && lat_sum && lat_count;
    char name[NAME_BYTES], labels[NAME_BYTES], value[32], help[160];
    for (unsigned i = 0; i < n; i++) {
        const char *e = s[i].name;
        snprintf(value, sizeof value, "%llu", (unsigned long long)s[i].value);
        const known_stat *k = NULL;
        for (size_t j = 0; j < sizeof known / sizeof known[0]; j++)
            if (strcmp(known[j].name, e) == 0)
                k = &known[j];
        if (k) {
            metric_name("qmcd_", e, k->gauge ? "" : "_total", name, sizeof name);
            add(p, family_of(p, name, k->gauge ? "gauge" : "counter", k->help), "", value);
        } else if (strncmp(e, "requests_", 9) == 0) {
            metric_name("", e + 9, "", labels + 7, sizeof labels - 9);
            memcpy(labels, "{type=\"", 7);
            strcat(labels, "\"}");
            add(p, family_of(p, "qmcd_requests_total", "counter",
                             "Requests received, by message type."), labels, value);
        } else if (histogram && strncmp(e, "latency_", 8) == 0) {
            if (strncmp(e, "latency_p", 9) == 0)
                continue; /* percentiles: see the file comment */
            unsigned fam = family_of(p, LAT_FAMILY, "histogram",
                                     "Time from a request's arrival to its final answer.");
            if (strncmp(e, "latency_le_us_", 14) == 0) {
                char le[32];
                us_to_seconds(strtoull(e + 14, NULL, 10), le, sizeof le);
                snprintf(labels, sizeof labels, "{le=\"%s\"}", le);
                add(p, fam, labels, value);
            }
        } else {
            metric_name("qmcd_", e, "", name, sizeof name);
            snprintf(help, sizeof help, "The daemon's STATS entry %s (not documented by this qmc).",
                     e);
            add(p, family_of(p, name, "untyped", help), "", value);
        }
    }
    for (unsigned fi = 0; fi < p->n_fam; fi++) {
        const family *fa = &p->fam[fi];
        fprintf(f, "# HELP %s %s\n# TYPE %s %s\n", fa->name, fa->help, fa->name, fa->type);
        const char *suffix = strcmp(fa->name, LAT_FAMILY) == 0 ? "_bucket" : "";
        for (unsigned si = 0; si < p->n_smp; si++)
            if (p->smp[si].fam == fi)
                fprintf(f, "%s%s%s %s\n", fa->name, suffix, p->smp[si].labels, p->smp[si].value);
        if (*suffix) {
            char sum[32];
            us_to_seconds(lat_sum->value, sum, sizeof sum);
            fprintf(f, "%s_bucket{le=\"+Inf\"} %llu\n%s_sum %s\n%s_count %llu\n", fa->name,
                    (unsigned long long)lat_count->value, fa->name, sum, fa->name,
                    (unsigned long long)lat_count->value);
        }
    }
    free(p);
}
