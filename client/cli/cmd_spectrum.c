/*
 * cmd_spectrum.c - `qmc spectrum`: the mean Fourier power spectrum of R
 * realisations of a 2D point set, written as a radial-average CSV and a
 * grayscale PNG of the 2D periodogram.
 *
 * libqmc does the arithmetic (qmc_spectrum_accumulate / _finish); this file
 * makes the point sets, scales the image and writes the files.  Both
 * targets are checked (outfile.h) before any work, both files are built in
 * memory, written beside their targets and fsynced, and only then renamed
 * into place together: an error, a bad second target or a signal leaves
 * neither file changed.  With --connect the
 * points come from the daemon (the same bits) and the arithmetic stays here.
 */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli.h"
#include "json.h"
#include "outfile.h"
#include "png.h"
#include "qmc/quality.h"

#define SPEC_MAX_COUNT (1u << 20)
#define SPEC_MAX_REPS 1024u
#define SPEC_MAX_FREQ 256u
/* Coordinates held per realisation (256 MiB of doubles). */
#define SPEC_MAX_VALUES (1u << 25)
/* count x reps x (2K+1)^2 complex multiply-adds: a few seconds at most. */
#define SPEC_MAX_WORK 4000000000.0
/* The image is scaled up by whole pixels to at least this many a side. */
#define SPEC_MIN_IMAGE_SIDE 256u
/* log10 of the darkest power shown: 1e-3 of the white-noise level 1. */
#define SPEC_LOG_FLOOR (-3.0)

static const char spectrum_help[] =
    "usage: qmc spectrum --seq KIND [--scramble S] [--seed X] [--dims D]\n"
    "                    --count N [--reps R] [--freq K] [--png FILE] [--csv FILE]\n"
    "                    [--json]\n"
    "\n"
    "Periodogram P(k) = |sum_j exp(-2 pi i k.x_j)|^2 / N of the first two\n"
    "coordinates of points 0 .. N-1, for integer k in [-K, K]^2, averaged\n"
    "over R realisations; realisation r uses seed X + r.  Unscrambled sobol,\n"
    "halton and hammersley do not depend on the seed, so all their\n"
    "realisations coincide and R > 1 only repeats work.  For uniform random\n"
    "points E[P(k)] = 1 (k != 0); P(0) = N.\n"
    "\n"
    "  --count N   points per realisation, 1 .. 1048576 (required)\n"
    "  --reps R    realisations, 1 .. 1024 (default 1)\n"
    "  --freq K    largest |kx|, |ky|, 1 .. 256 (default 32)\n"
    "  --csv FILE  radial average: header \"frequency,power\", then one row per\n"
    "              integer b = 0 .. K, the mean of P(k) over b-1/2 <= |k| < b+1/2\n"
    "  --png FILE  8-bit grayscale image of P, DC at the centre, ky up,\n"
    "              log10 scale from 1e-3 (black) to the largest non-DC\n"
    "              power (white); the DC pixel is white; each frequency is a\n"
    "              square of pixels so the image is at least 256 wide\n"
    "  --json      one JSON object on stdout: seq, scramble, seed, dims, count,\n"
    "              reps, freq, csv and png (the files written, or null) and\n"
    "              radial_power, the CSV's power column (index = frequency)\n"
    "At least one of --png, --csv and --json is required.\n"
    "\n"
    "Work limit: N x R x (2K+1)^2 <= 4e9.\n";

/* Points 0 .. count-1 of spec as f64, from the daemon when c is set. */
static int fetch(qmc_client *c, const qmc_seq_spec *spec, uint64_t count, double *pts)
{
    if (c) {
        int err = qmc_client_points(c, spec, 0, count, QMC_FORMAT_F64, pts,
                                    (size_t)count * spec->dims * sizeof *pts);
        return err ? cli_remote_fail(c, err, "spectrum: ") : 0;
    }
    qmc_seq *seq = NULL;
    char why[256];
    int err = qmc_seq_new(spec, &seq);
    if (err)
        return cli_error("spectrum: %s", qmc_strerror(err));
    err = qmc_seq_range_check(seq, 0, count, why, sizeof why);
    if (err) {
        qmc_seq_free(seq);
        return cli_error("spectrum: %s", why);
    }
    err = qmc_seq_fill(seq, 0, count, QMC_FORMAT_F64, pts);
    qmc_seq_free(seq);
    return err ? cli_error("spectrum: %s", qmc_strerror(err)) : 0;
}

/* Accumulates `reps` realisations into power.  Returns 0 or CLI_EXIT_FAIL. */
static int accumulate(qmc_client *c, const qmc_seq_spec *base, uint64_t count,
                      uint32_t reps, uint32_t kmax, double *power)
{
    const uint32_t dims = base->dims;
    double *pts = malloc((size_t)count * dims * sizeof *pts);
    double *work = malloc(qmc_spectrum_work_len(kmax) * sizeof *work);
    int rc = 0;
    if (!pts || !work) {
        rc = cli_error("spectrum: out of memory for %llu points",
                       (unsigned long long)count);
        goto fail;
    }
    for (uint32_t r = 0; r < reps; r++) {
        qmc_seq_spec spec = *base;
        spec.seed = base->seed + r;
        rc = fetch(c, &spec, count, pts);
        if (rc)
            goto fail;
        int err = qmc_spectrum_accumulate(pts, (size_t)count, dims, 0, 1, kmax,
                                          power, work);
        if (err) {
            rc = cli_error("spectrum: %s", qmc_strerror(err));
            goto fail;
        }
    }
fail:
    free(pts);
    free(work);
    return rc;
}

/* Log-scaled gray levels, each frequency a scale x scale square, ky = +K
 * on the top row. */
static void render(const double *power, uint32_t kmax, uint32_t scale,
                   uint8_t *pixels)
{
    size_t side = qmc_spectrum_side(kmax), dc = kmax * side + kmax;
    double hi = SPEC_LOG_FLOOR;
    for (size_t i = 0; i < side * side; i++)
        if (i != dc && power[i] > 0.0 && log10(power[i]) > hi)
            hi = log10(power[i]);
    if (hi <= SPEC_LOG_FLOOR)
        hi = SPEC_LOG_FLOOR + 1.0;
    size_t width = side * scale;
    for (size_t row = 0; row < side; row++) {
        const double *src = power + (side - 1 - row) * side;
        for (size_t c = 0; c < side; c++) {
            double l = src[c] > 0.0 ? log10(src[c]) : SPEC_LOG_FLOOR;
            double g = (l - SPEC_LOG_FLOOR) / (hi - SPEC_LOG_FLOOR);
            g = g < 0.0 ? 0.0 : g > 1.0 ? 1.0 : g;
            uint8_t v = (side - 1 - row) * side + c == dc
                            ? 255
                            : (uint8_t)lrint(255.0 * g);
            for (size_t dy = 0; dy < scale; dy++)
                memset(pixels + (row * scale + dy) * width + c * scale, v,
                       scale);
        }
    }
}

static int write_csv(cli_outfile *out, const double *radial, uint32_t kmax)
{
    size_t cap = 32 + (size_t)(kmax + 1) * 40, len = 0;
    char *buf = malloc(cap);
    if (!buf)
        return cli_error("spectrum: out of memory");
    len += (size_t)snprintf(buf, cap, "frequency,power\n");
    for (uint32_t b = 0; b <= kmax; b++)
        len += (size_t)snprintf(buf + len, cap - len, "%u,%.17g\n", b,
                                radial[b]);
    int rc = cli_write_all(out->f, buf, len, "--csv") ? CLI_EXIT_FAIL : 0;
    free(buf);
    return rc;
}

static int write_png(cli_outfile *out, const double *power, uint32_t kmax)
{
    uint32_t side = (uint32_t)qmc_spectrum_side(kmax);
    uint32_t scale = (SPEC_MIN_IMAGE_SIDE + side - 1) / side;
    uint32_t width = side * scale;
    size_t bytes = cli_png_encoded_bytes(width, width);
    uint8_t *pixels = malloc((size_t)width * width);
    uint8_t *png = bytes ? malloc(bytes) : NULL;
    int rc;
    if (!pixels || !png) {
        rc = cli_error("spectrum: out of memory for a %ux%u image", width,
                       width);
    } else {
        render(power, kmax, scale, pixels);
        size_t n = cli_png_encode_gray8(pixels, width, width, png, bytes);
        rc = n ? (cli_write_all(out->f, png, n, "--png") ? CLI_EXIT_FAIL : 0)
               : cli_error("spectrum: cannot encode a %ux%u image", width,
                           width);
    }
    free(pixels);
    free(png);
    return rc;
}

/* A path as a JSON string member, or null when the file was not asked for. */
static void json_path(const char *key, const char *path)
{
    if (path)
        cli_json_str(stdout, key, path, 1);
    else
        printf("\"%s\":null,", key);
}

static int print_json(const qmc_seq_spec *spec, uint64_t count, uint32_t reps,
                      uint32_t kmax, const double *radial, const char *csv_path,
                      const char *png_path)
{
    putchar('{');
    cli_json_str(stdout, "seq", qmc_seq_kind_name(spec->kind), 1);
    cli_json_str(stdout, "scramble", qmc_scramble_name(spec->scramble), 1);
    cli_json_u64(stdout, "seed", spec->seed, 1);
    cli_json_u64(stdout, "dims", spec->dims, 1);
    cli_json_u64(stdout, "count", count, 1);
    cli_json_u64(stdout, "reps", reps, 1);
    cli_json_u64(stdout, "freq", kmax, 1);
    json_path("csv", csv_path);
    json_path("png", png_path);
    cli_json_num_array(stdout, "radial_power", radial, (size_t)kmax + 1, 0);
    fputs("}\n", stdout);
    if (ferror(stdout) || fflush(stdout) != 0)
        return cli_error("spectrum: writing the JSON result: %s", strerror(errno));
    return 0;
}

int cli_cmd_spectrum(int argc, char **argv)
{
    static const struct option longopts[] = {
        {"seq", required_argument, 0, 0},   {"dims", required_argument, 0, 0},
        {"scramble", required_argument, 0, 0}, {"seed", required_argument, 0, 0},
        {"shuffle", no_argument, 0, 0},     {"set-size", required_argument, 0, 0},
        {"count", required_argument, 0, 0}, {"reps", required_argument, 0, 0},
        {"freq", required_argument, 0, 0},  {"png", required_argument, 0, 0},
        {"csv", required_argument, 0, 0},   {"help", no_argument, 0, 0},
        {"json", no_argument, 0, 0},
        {0, 0, 0, 0},
    };
    const char *endpoint;
    if (cli_remote_take(&argc, argv, &endpoint))
        return CLI_EXIT_FAIL;
    cli_seq_opts so;
    cli_seq_opts_init(&so);
    uint64_t count = 0, reps = 1, freq = 32;
    const char *png_path = NULL, *csv_path = NULL;
    int json = 0;
    int first = 1, more;
    const char *name, *arg;
    while ((more = cli_next_option("spectrum", argc, argv, longopts, &first, &name, &arg)) > 0) {
        int used = cli_seq_option(&so, name, arg);
        if (used < 0)
            return CLI_EXIT_FAIL;
        if (used)
            continue;
        if (strcmp(name, "help") == 0) {
            fputs(spectrum_help, stdout);
            fputs(cli_seq_help, stdout);
            fputs(cli_remote_help, stdout);
            return CLI_EXIT_OK;
        }
        if (strcmp(name, "count") == 0 &&
            cli_parse_u64("--count", arg, 1, SPEC_MAX_COUNT, &count))
            return CLI_EXIT_FAIL;
        if (strcmp(name, "reps") == 0 &&
            cli_parse_u64("--reps", arg, 1, SPEC_MAX_REPS, &reps))
            return CLI_EXIT_FAIL;
        if (strcmp(name, "freq") == 0 &&
            cli_parse_u64("--freq", arg, 1, SPEC_MAX_FREQ, &freq))
            return CLI_EXIT_FAIL;
        if (strcmp(name, "png") == 0)
            png_path = arg;
        if (strcmp(name, "csv") == 0)
            csv_path = arg;
        if (strcmp(name, "json") == 0)
            json = 1;
    }
    if (more < 0)
        return CLI_EXIT_FAIL;
    if (count == 0)
        return cli_error("spectrum: --count N is required");
    if (!png_path && !csv_path && !json)
        return cli_error("spectrum: nothing to write: give --png FILE, --csv FILE "
                         "or --json");
    double side = 2.0 * (double)freq + 1.0;
    if ((double)count * (double)reps * side * side > SPEC_MAX_WORK)
        return cli_error("spectrum: count x reps x (2 freq + 1)^2 = %.3g "
                         "exceeds the work limit %.3g",
                         (double)count * (double)reps * side * side,
                         SPEC_MAX_WORK);
    if (cli_seq_finish(&so, count))
        return CLI_EXIT_FAIL;
    if (so.spec.dims < 2)
        return cli_error("spectrum: --dims %u: the spectrum needs 2 "
                         "coordinates", so.spec.dims);
    if (count * so.spec.dims > SPEC_MAX_VALUES)
        return cli_error("spectrum: count x dims = %llu exceeds the limit of "
                         "%u coordinates per realisation",
                         (unsigned long long)(count * so.spec.dims),
                         SPEC_MAX_VALUES);

    if (png_path && csv_path && cli_outfile_same(png_path, csv_path))
        return cli_error("spectrum: --png and --csv both name '%s': give each its own "
                         "file", png_path);
    /* Both targets checked before any work; see outfile.h. */
    /* With --json either file may be left out: only those asked for. */
    cli_outfile outs[2];
    memset(outs, 0, sizeof outs);
    outs[0].slot = outs[1].slot = -1;
    cli_outfile *csv_out = NULL, *png_out = NULL;
    size_t n_outs = 0;
    if (csv_path) {
        if (cli_outfile_open(&outs[n_outs], csv_path, "--csv") != 0)
            return CLI_EXIT_FAIL;
        csv_out = &outs[n_outs++];
    }
    if (png_path) {
        if (cli_outfile_open(&outs[n_outs], png_path, "--png") != 0) {
            cli_outfile_abort(&outs[0]);
            return CLI_EXIT_FAIL;
        }
        png_out = &outs[n_outs++];
    }
    const uint32_t kmax = (uint32_t)freq;
    size_t cells = qmc_spectrum_side(kmax) * qmc_spectrum_side(kmax);
    double *power = calloc(cells, sizeof *power);
    double *radial = malloc(((size_t)kmax + 1) * sizeof *radial);
    qmc_client *client = NULL;
    int rc = 0;
    if (!power || !radial) {
        rc = cli_error("spectrum: out of memory");
        goto done;
    }
    if (endpoint && (rc = cli_remote_connect(endpoint, &client)) != 0)
        goto done;
    rc = accumulate(client, &so.spec, count, (uint32_t)reps, kmax, power);
    if (rc)
        goto done;
    int err = qmc_spectrum_finish(power, kmax, (uint32_t)reps, radial);
    if (err) {
        rc = cli_error("spectrum: %s", qmc_strerror(err));
        goto done;
    }
    if (csv_out)
        rc = write_csv(csv_out, radial, kmax);
    if (rc == 0 && png_out)
        rc = write_png(png_out, power, kmax);
    if (rc == 0)
        rc = cli_outfile_commit_all(outs, n_outs);
    /* Last, so that stdout names only files that were written. */
    if (rc == 0 && json)
        rc = print_json(&so.spec, count, (uint32_t)reps, kmax, radial, csv_path,
                        png_path);
done:
    cli_outfile_abort(&outs[0]);
    cli_outfile_abort(&outs[1]);
    qmc_client_close(client);
    free(power);
    free(radial);
    return rc;
}
