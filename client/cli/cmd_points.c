/*
 * cmd_points.c - `qmc points`: write points [start, start + count) of a
 * sequence as CSV or raw little-endian binary.
 *
 * Everything that can be checked is checked before the first byte goes
 * out, so an error never leaves partial output; with --out the file is
 * written as outfile.h says (beside its target, fsynced, renamed into place
 * only when complete; devices and FIFOs written in place; read-only and
 * other users' files refused).
 *
 * With --connect the points come from the daemon as a stream of chunks and
 * are written as they arrive, in the same bytes, in as many requests as the
 * daemon's max-points needs (the client library splits them).  Only a
 * connection lost halfway can leave part of a stream on stdout, and the
 * error line then says how many points got through.
 */
#include <getopt.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "emit.h"

static const char points_help[] =
    "usage: qmc points --seq KIND [--dims D] [--count N] [--start I]\n"
    "                  [--scramble S] [--seed X] [--shuffle] [--set-size N]\n"
    "                  [--format csv|f64|f32|u32] [--out FILE]\n"
    "\n"
    "Writes points start .. start+count-1 (index 0 is the first point), one\n"
    "point per row.  csv: coordinates joined by ',', each \"%.17g\".  f64, f32,\n"
    "u32: raw little-endian, row-major; u32 is the coordinate times 2^32.\n"
    "Every coordinate lies in [0, 1).\n"
    "\n"
    "  --count N         number of points (default 16)\n"
    "  --start I         first index (default 0)\n"
    "  --format F        csv (default) | f64 | f32 | u32\n"
    "  --out FILE        write to FILE instead of stdout: a regular file is\n"
    "                    replaced atomically (keeping its mode) and only when\n"
    "                    complete; a device or FIFO is written in place; a\n"
    "                    read-only file or another user's is refused\n"
    "\n";

enum { BLOCK_BYTES = 1 << 20 };

static int write_csv(FILE *f, const double *x, size_t n_points, uint32_t dims)
{
    char line[32];
    for (size_t p = 0; p < n_points; p++) {
        for (uint32_t j = 0; j < dims; j++) {
            int len = snprintf(line, sizeof line, j + 1 < dims ? "%.17g," : "%.17g\n",
                               x[p * dims + j]);
            if (cli_write_all(f, line, (size_t)len, "points"))
                return -1;
        }
    }
    return 0;
}

/* What to write and where the points come from: a local sequence, or
 * the daemon. */
typedef struct points_src {
    const qmc_seq *seq;           /* in-process, or NULL */
    qmc_client *client;           /* remote, or NULL */
    const qmc_seq_spec *spec;
    uint64_t start, count;
    int csv;                      /* CSV (from f64 values), else fmt raw */
    qmc_format fmt;
} points_src;

typedef struct remote_sink {
    cli_raw_sink raw;             /* the file, and binary chunks as they come */
    int csv;
    uint32_t dims;
    double *values;               /* csv: the chunk decoded, host order */
} remote_sink;

static int remote_chunk(void *ctx, uint64_t first, uint32_t points, const void *data,
                        size_t bytes)
{
    remote_sink *k = ctx;
    if (!k->csv)
        return cli_raw_chunk(&k->raw, first, points, data, bytes);
    memcpy(k->values, data, bytes);
    cli_to_little_endian(k->values, bytes / sizeof(double), sizeof(double));
    if (write_csv(k->raw.f, k->values, points, k->dims))
        return k->raw.failed = -1;
    return 0;
}

static int emit_remote(const points_src *src, FILE *f)
{
    remote_sink k = {{f, "points", 0}, src->csv, src->spec->dims, NULL};
    if (src->csv && !(k.values = malloc(QMC_CLIENT_MAX_FRAME)))
        return cli_error("out of memory for a chunk of points");
    int err = qmc_client_points_stream(src->client, src->spec, src->start, src->count,
                                       src->fmt, remote_chunk, &k);
    free(k.values);
    return cli_stream_done(src->client, err, k.raw.failed);
}

/* The points, all of them, to f (a cli_emit_fn). */
static int emit(void *ctx, FILE *f)
{
    const points_src *src = ctx;
    if (src->client)
        return emit_remote(src, f);
    const qmc_seq *seq = src->seq;
    const uint64_t start = src->start, count = src->count;
    const qmc_format fmt = src->fmt;
    const uint32_t dims = qmc_seq_get_spec(seq)->dims;
    const size_t value_bytes = qmc_format_bytes(fmt);
    size_t block = BLOCK_BYTES / (value_bytes * dims);
    if (block == 0)
        block = 1;
    void *buf = malloc(block * dims * value_bytes);
    if (!buf)
        return cli_error("out of memory for a %zu-point block", block);
    int rc = 0;
    for (uint64_t done = 0; done < count && rc == 0;) {
        size_t n = count - done < block ? (size_t)(count - done) : block;
        int err = qmc_seq_fill(seq, start + done, n, fmt, buf);
        if (err) {
            rc = cli_error("points: %s", qmc_strerror(err));
            break;
        }
        if (src->csv) {
            rc = write_csv(f, buf, n, dims) ? CLI_EXIT_FAIL : 0;
        } else {
            cli_to_little_endian(buf, n * dims, value_bytes);
            rc = cli_write_all(f, buf, n * dims * value_bytes, "points") ? CLI_EXIT_FAIL : 0;
        }
        done += n;
    }
    free(buf);
    return rc;
}

/* Remote mode: the spec and the range are checked here as in-process (the
 * same messages, and before anything is written: the client library splits
 * a count past the daemon's max-points into several requests, and a range
 * error found by a later one would come after the first one's output). */
static int points_remote(const char *endpoint, const qmc_seq_spec *spec, uint64_t start,
                         uint64_t count, int csv, qmc_format fmt, const char *out)
{
    qmc_seq *seq = NULL;
    char why[256];
    int err = qmc_seq_new(spec, &seq);
    if (err)
        return cli_error("points: %s", qmc_strerror(err));
    err = qmc_seq_range_check(seq, start, count, why, sizeof why);
    qmc_seq_free(seq);
    if (err)
        return cli_error("%s", why);
    qmc_client *c = NULL;
    if (cli_remote_connect(endpoint, &c))
        return CLI_EXIT_FAIL;
    points_src src = {NULL, c, spec, start, count, csv, csv ? QMC_FORMAT_F64 : fmt};
    int rc = cli_emit_out(out, "points", emit, &src);
    qmc_client_close(c);
    return rc;
}

int cli_cmd_points(int argc, char **argv)
{
    static const struct option longopts[] = {
        {"seq", required_argument, 0, 0},   {"dims", required_argument, 0, 0},
        {"scramble", required_argument, 0, 0}, {"seed", required_argument, 0, 0},
        {"shuffle", no_argument, 0, 0},     {"set-size", required_argument, 0, 0},
        {"count", required_argument, 0, 0}, {"start", required_argument, 0, 0},
        {"format", required_argument, 0, 0}, {"out", required_argument, 0, 0},
        {"help", no_argument, 0, 0},        {0, 0, 0, 0},
    };
    const char *endpoint;
    if (cli_remote_take(&argc, argv, &endpoint))
        return CLI_EXIT_FAIL;
    cli_seq_opts so;
    cli_seq_opts_init(&so);
    uint64_t count = 16, start = 0;
    const char *format = "csv", *out = NULL;
    int first = 1, more;
    const char *name, *arg;
    while ((more = cli_next_option("points", argc, argv, longopts, &first, &name, &arg)) > 0) {
        int used = cli_seq_option(&so, name, arg);
        if (used < 0)
            return CLI_EXIT_FAIL;
        if (used)
            continue;
        if (strcmp(name, "help") == 0) {
            fputs(points_help, stdout);
            fputs(cli_seq_help, stdout);
            fputs(cli_remote_help, stdout);
            return CLI_EXIT_OK;
        }
        if (strcmp(name, "count") == 0 &&
            cli_parse_u64("--count", arg, 1, QMC_SEQ_MAX_INDEX, &count))
            return CLI_EXIT_FAIL;
        if (strcmp(name, "start") == 0 &&
            cli_parse_u64("--start", arg, 0, QMC_SEQ_MAX_INDEX, &start))
            return CLI_EXIT_FAIL;
        if (strcmp(name, "format") == 0)
            format = arg;
        if (strcmp(name, "out") == 0)
            out = arg;
    }
    if (more < 0)
        return CLI_EXIT_FAIL;
    qmc_format fmt = QMC_FORMAT_F64;
    int csv = strcmp(format, "csv") == 0;
    if (!csv && qmc_format_parse(format, &fmt) != 0)
        return cli_error("--format: unknown format '%s' (csv, f64, f32, u32)", format);
    if (cli_seq_finish(&so, start + count))
        return CLI_EXIT_FAIL;
    if (endpoint)
        return points_remote(endpoint, &so.spec, start, count, csv, fmt, out);
    qmc_seq *seq = NULL;
    int err = qmc_seq_new(&so.spec, &seq);
    if (err)
        return cli_error("points: %s", qmc_strerror(err));
    char why[256];
    int rc;
    points_src src = {seq, NULL, &so.spec, start, count, csv, fmt};
    if (qmc_seq_range_check(seq, start, count, why, sizeof why) != 0)
        rc = cli_error("%s", why);
    else
        rc = cli_emit_out(out, "points", emit, &src);
    qmc_seq_free(seq);
    return rc;
}
