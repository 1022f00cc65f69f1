/*
 * cmd_discrepancy.c - `qmc discrepancy`: the discrepancy of a point set
 * read as CSV, computed by libqmc (qmc/quality.h).
 *
 * The whole input is read and checked (csv_read.c, a pure reader the
 * fuzzer drives too) before anything is computed, so an error names its
 * line and never leaves output on stdout.  Input is capped
 * (points, coordinates per point, bytes per line) because the measures
 * cost O(n^2 d): the caps are what keeps one call within seconds.
 */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "csv_read.h"
#include "json.h"
#include "qmc/quality.h"

/* n^2 d at the caps is 6.4e9 multiply-adds: a few seconds. */
#define DISC_MAX_POINTS 10000u
#define DISC_MAX_DIMS 64u
#define DISC_MAX_LINE_BYTES 4096u

static const char discrepancy_help[] =
    "usage: qmc discrepancy --method l2-star|cd|wd|md|star [--in FILE] [--json]\n"
    "\n"
    "Reads points as CSV (stdin by default): one point per line, coordinates\n"
    "in [0,1] joined by ','; blank lines and lines starting with '#' are\n"
    "skipped.  Prints the discrepancy as \"%.17g\" and a newline.\n"
    "\n"
    "  --json   one JSON object instead: method, value, squared (whether the\n"
    "           value is the squared discrepancy), exact (false when star\n"
    "           gives only a lower bound), points, dims\n"
    "\n"
    "  l2-star  L2 star discrepancy (Warnock 1972), NOT squared\n"
    "  cd       centered L2 discrepancy (Hickernell 1998), SQUARED\n"
    "  wd       wrap-around L2 discrepancy (Hickernell 1998), SQUARED\n"
    "  md       mixture L2 discrepancy (Zhou, Fang & Ning 2013), SQUARED\n"
    "           These four equal scipy.stats.qmc.discrepancy with method\n"
    "           'L2-star', 'CD', 'WD', 'MD', which also squares the last three.\n"
    "  star     star discrepancy D* over boxes [0,u) and [0,u].  Exact in\n"
    "           1 and 2 dimensions and whenever the grid of critical boxes\n"
    "           is small; otherwise a lower bound from a deterministic\n"
    "           subset of boxes (about 4e8 comparisons), and then a line\n"
    "           saying \"lower bound\" goes to stderr (exit status 0).\n"
    "\n"
    "Limits: at most 10000 points, 64 coordinates per point and 4096 bytes\n"
    "per line (the work grows as points^2 x coordinates).  Any error prints\n"
    "one line to stderr and exits with status 2.\n";

/* Reads every point of f (fed to the pure reader in csv_read.c).  Returns
 * 0 or CLI_EXIT_FAIL (printed). */
static int read_points(FILE *f, cli_csv_reader *r)
{
    char buf[1 << 16];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, f)) > 0)
        if (cli_csv_feed(r, buf, n) != 0)
            return cli_error("discrepancy: %s", r->why);
    if (ferror(f))
        return cli_error("discrepancy: reading %s: %s", r->name, strerror(errno));
    if (cli_csv_finish(r) != 0)
        return cli_error("discrepancy: %s", r->why);
    return 0;
}

/* *exact is 0 only for a star discrepancy that is a lower bound. */
static int compute(const cli_csv_reader *pb, int star, qmc_disc_method method,
                   double *value, int *exact)
{
    *exact = 1;
    if (!star) {
        int err = qmc_disc_compute(pb->v, pb->n, pb->dims, method, value);
        return err ? cli_error("discrepancy: %s", qmc_strerror(err)) : 0;
    }
    size_t len = qmc_star_work_len(pb->n, pb->dims);
    double *work = len ? malloc(len * sizeof *work) : NULL;
    if (!work)
        return cli_error("discrepancy: out of memory for the star workspace");
    int err = qmc_star_compute(pb->v, pb->n, pb->dims, 0, work, value, exact);
    free(work);
    if (err)
        return cli_error("discrepancy: %s", qmc_strerror(err));
    if (!*exact)
        fprintf(stderr, "qmc: discrepancy: star: lower bound (%u dimensions, "
                "too many critical boxes to check all)\n", pb->dims);
    return 0;
}

int cli_cmd_discrepancy(int argc, char **argv)
{
    static const struct option longopts[] = {
        {"method", required_argument, 0, 0},
        {"in", required_argument, 0, 0},
        {"json", no_argument, 0, 0},
        {"help", no_argument, 0, 0},
        {0, 0, 0, 0},
    };
    const char *method_name = NULL, *in = NULL;
    int json = 0;
    int first = 1, more;
    const char *name, *arg;
    while ((more = cli_next_option("discrepancy", argc, argv, longopts, &first, &name, &arg)) > 0) {
        if (strcmp(name, "help") == 0) {
            fputs(discrepancy_help, stdout);
            return CLI_EXIT_OK;
        }
        if (strcmp(name, "method") == 0)
            method_name = arg;
        if (strcmp(name, "in") == 0)
            in = arg;
        if (strcmp(name, "json") == 0)
            json = 1;
    }
    if (more < 0)
        return CLI_EXIT_FAIL;
    if (method_name == NULL)
        return cli_error("discrepancy: --method is required (l2-star, cd, wd, "
                         "md, star)");
    int star = strcmp(method_name, "star") == 0;
    qmc_disc_method method = QMC_DISC_CD;
    if (!star && qmc_disc_method_parse(method_name, &method) != 0)
        return cli_error("discrepancy: --method: unknown method '%s' (l2-star, "
                         "cd, wd, md, star)", method_name);

    FILE *f = stdin;
    const char *source = "stdin";
    if (in != NULL) {
        f = fopen(in, "r");
        if (!f)
            return cli_error("discrepancy: --in: cannot open '%s': %s", in,
                             strerror(errno));
        source = in;
    }
    cli_csv_reader pb;
    double value = 0.0;
    int exact = 1;
    int rc = 0;
    if (cli_csv_init(&pb, source, DISC_MAX_POINTS, DISC_MAX_DIMS, DISC_MAX_LINE_BYTES) != 0)
        rc = cli_error("discrepancy: %s", pb.why);
    else
        rc = read_points(f, &pb);
    if (f != stdin)
        fclose(f);
    if (rc == 0)
        rc = compute(&pb, star, method, &value, &exact);
    size_t n_points = pb.n; /* for --json, before the reader lets go */
    uint32_t dims = pb.dims;
    cli_csv_close(&pb);
    if (rc != 0)
        return rc;

    if (json) {
        /* l2-star and star are the discrepancy itself; cd, wd and md are
         * squared, as scipy returns them. */
        putchar('{');
        cli_json_str(stdout, "method", method_name, 1);
        cli_json_num(stdout, "value", value, 1);
        cli_json_bool(stdout, "squared", !star && method != QMC_DISC_L2_STAR, 1);
        cli_json_bool(stdout, "exact", exact, 1);
        cli_json_u64(stdout, "points", n_points, 1);
        cli_json_u64(stdout, "dims", dims, 0);
        fputs("}\n", stdout);
        if (ferror(stdout) || fflush(stdout) != 0)
            return cli_error("discrepancy: writing the result: %s", strerror(errno));
        return CLI_EXIT_OK;
    }
    char out[40];
    int len = snprintf(out, sizeof out, "%.17g\n", value);
    if (cli_write_all(stdout, out, (size_t)len, "the result") != 0 ||
        fflush(stdout) != 0)
        return cli_error("discrepancy: writing the result: %s", strerror(errno));
    return CLI_EXIT_OK;
}
