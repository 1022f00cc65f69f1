/*
 * cmd_pixels.c - `qmc pixels`: a tile of a pixel sampler (qmc/pixel.h) as
 * raw little-endian binary, pixel-major: pixel rows y, then x; each
 * pixel's samples START .. START+COUNT-1; each sample's D values.
 *
 * In-process the tile is filled piece by piece (qmc_pixel_tile_piece, at
 * most a block of values at a time), so a tile of any size needs one
 * block of memory.  With --connect the same tile comes from the daemon as
 * a PIXELS stream, written as it arrives, in the same bytes (the client
 * library cuts a tile past the daemon's max-points into several
 * requests).  The spec and the tile are checked here first either way,
 * with the core's one-line reasons, so a bad request never leaves partial
 * output and gets the same message in-process and remote; --out writes as
 * outfile.h says (never a partial file, never a clobbered read-only one).
 *
 * Must not: print anything but the tile on stdout, or compute a value
 * itself (the core or the daemon does).
 */
#include <getopt.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "emit.h"
#include "qmc/pixel.h"

static const char pixels_help[] =
    "usage: qmc pixels --sampler zsobol|padded-sobol|sobol --resolution W,H --spp N\n"
    "                  [--seed S] [--frame F] --tile X,Y,W,H [--samples START:COUNT]\n"
    "                  --dims D [--format f32|f64|u32] [--out FILE]\n"
    "\n"
    "Writes a tile of a pixel sampler: the values a renderer draws for each pixel\n"
    "(docs/SEQUENCES.md defines every sampler down to its constants).  Output is\n"
    "raw little-endian binary, pixel-major: for each pixel of the tile in row\n"
    "order (y, then x), for each sample START .. START+COUNT-1, D values.  With\n"
    "--frame 0, zsobol and padded-sobol give pbrt-v4's values for the same\n"
    "resolution, spp and seed.\n"
    "\n"
    "  --sampler NAME    zsobol (pbrt-v4's ZSobolSampler: blue-noise error),\n"
    "                    padded-sobol (PaddedSobolSampler), sobol (one Sobol'\n"
    "                    sequence over the image, up to 21201 dims)\n"
    "  --resolution W,H  the whole image, in pixels\n"
    "  --spp N           samples per pixel the pattern is built for (zsobol: a\n"
    "                    power of two); zsobol and padded-sobol have no sample\n"
    "                    past it\n"
    "  --seed S          pbrt-v4's int seed: 0 .. 4294967295, 0x hex, or a\n"
    "                    negative int (its 32 bits; default 0)\n"
    "  --frame F         0 (default): pbrt-v4's values; another frame\n"
    "                    decorrelates the whole image (animations)\n"
    "  --tile X,Y,W,H    the pixels [X, X+W) x [Y, Y+H), inside the image\n"
    "  --samples START:COUNT\n"
    "                    the samples of each pixel (default 0:N, all of them)\n"
    "  --dims D          values per sample\n"
    "  --format F        f32 (default) | f64 | u32.  u32 is the sampler's 32-bit\n"
    "                    value v; f64 is v / 2^32 exactly; f32 is\n"
    "                    floor(v / 2^8) / 2^24, never 1.0 (pbrt-v4 rounds\n"
    "                    v * 2^-32 to the nearest float instead: from u32 you\n"
    "                    get pbrt's float exactly)\n"
    "  --out FILE        write to FILE instead of stdout: a regular file is\n"
    "                    replaced atomically (keeping its mode) and only when\n"
    "                    complete; a device or FIFO is written in place; a\n"
    "                    read-only file or another user's is refused\n"
    "\n"
    "Node k of K rendering samples [k*N/K, (k+1)*N/K) of every pixel\n"
    "(--samples k*N/K:N/K) writes, pixel by pixel, its part of one render's\n"
    "samples (docs/OPERATIONS.md).\n";

enum { BLOCK_BYTES = 1 << 20 };

/* The options as given. */
typedef struct pixels_opts {
    qmc_pixel_spec spec;
    qmc_pixel_tile tile;
    qmc_format fmt;
    int have_sampler, have_resolution, have_spp, have_tile, have_samples, have_dims;
    const char *out;
} pixels_opts;

/* "A,B,..." of exactly n whole numbers, each at most max. */
static int parse_tuple(const char *opt, const char *form, const char *text, size_t n,
                       uint64_t max, uint64_t *out)
{
    const char *p = text, *item = text;
    size_t len = 0, k = 0;
    int bad = text[0] == '\0';
    char buf[32];
    while (!bad && cli_list_next(&p, &item, &len)) {
        /* one too many, an empty item, or an item too long for a number */
        if (k == n || cli_list_copy(item, len, buf, sizeof buf) != 0) {
            bad = 1;
            break;
        }
        if (cli_parse_u64(opt, buf, 0, max, &out[k]))
            return -1;
        k++;
    }
    /* A trailing comma ends the list without an item after it. */
    if (bad || k != n || (len && item[len] == ',')) {
        cli_error("%s: '%s' is not %s", opt, text, form);
        return -1;
    }
    return 0;
}

/* pbrt-v4's seed is an int: 0 .. 2^32 - 1 as its bits, or -2^31 .. -1. */
static int parse_seed(const char *text, uint32_t *out)
{
    uint64_t v;
    if (text[0] == '-') {
        if (cli_parse_u64("--seed", text + 1, 1, 1ull << 31, &v))
            return -1;
        *out = (uint32_t)(0x100000000ull - v);
        return 0;
    }
    if (cli_parse_u64("--seed", text, 0, UINT32_MAX, &v))
        return -1;
    *out = (uint32_t)v;
    return 0;
}

/* START:COUNT. */
static int parse_samples(const char *text, qmc_pixel_tile *t)
{
    const char *colon = strchr(text, ':');
    char start[32];
    if (!colon || (size_t)(colon - text) >= sizeof start || colon == text || !colon[1]) {
        cli_error("--samples: '%s' is not START:COUNT (e.g. 0:16)", text);
        return -1;
    }
    memcpy(start, text, (size_t)(colon - text));
    start[colon - text] = '\0';
    if (cli_parse_u64("--samples", start, 0, UINT64_MAX, &t->sample_start) ||
        cli_parse_u64("--samples", colon + 1, 0, UINT64_MAX, &t->sample_count))
        return -1;
    return 0;
}

/* One option; 0, or -1 after printing an error. */
static int take_option(pixels_opts *o, const char *name, const char *arg)
{
    uint64_t v[4];
    if (strcmp(name, "sampler") == 0) {
        if (qmc_pixel_sampler_parse(arg, &o->spec.sampler) != 0) {
            cli_error("--sampler: unknown sampler '%s' (zsobol, padded-sobol, sobol)", arg);
            return -1;
        }
        o->have_sampler = 1;
    } else if (strcmp(name, "resolution") == 0) {
        if (parse_tuple("--resolution", "W,H (e.g. 1920,1080)", arg, 2, UINT32_MAX, v))
            return -1;
        o->spec.width = (uint32_t)v[0];
        o->spec.height = (uint32_t)v[1];
        o->have_resolution = 1;
    } else if (strcmp(name, "tile") == 0) {
        if (parse_tuple("--tile", "X,Y,W,H (e.g. 0,0,64,64)", arg, 4, UINT32_MAX, v))
            return -1;
        o->tile.x = (uint32_t)v[0];
        o->tile.y = (uint32_t)v[1];
        o->tile.width = (uint32_t)v[2];
        o->tile.height = (uint32_t)v[3];
        o->have_tile = 1;
    } else if (strcmp(name, "spp") == 0) {
        if (cli_parse_u64("--spp", arg, 0, UINT64_MAX, &o->spec.spp))
            return -1;
        o->have_spp = 1;
    } else if (strcmp(name, "seed") == 0) {
        return parse_seed(arg, &o->spec.seed);
    } else if (strcmp(name, "frame") == 0) {
        if (cli_parse_u64("--frame", arg, 0, UINT32_MAX, v))
            return -1;
        o->spec.frame = (uint32_t)v[0];
    } else if (strcmp(name, "samples") == 0) {
        if (parse_samples(arg, &o->tile))
            return -1;
        o->have_samples = 1;
    } else if (strcmp(name, "dims") == 0) {
        if (cli_parse_u64("--dims", arg, 0, UINT32_MAX, v))
            return -1;
        o->spec.dims = (uint32_t)v[0];
        o->have_dims = 1;
    } else if (strcmp(name, "format") == 0) {
        if (qmc_format_parse(arg, &o->fmt) != 0) {
            cli_error("--format: unknown format '%s' (f32, f64, u32)", arg);
            return -1;
        }
    } else if (strcmp(name, "out") == 0) {
        o->out = arg;
    }
    return 0;
}

/* Every required option given; the first one missing is named. */
static int check_required(const pixels_opts *o)
{
    const char *missing = !o->have_sampler      ? "--sampler zsobol|padded-sobol|sobol"
                          : !o->have_resolution ? "--resolution W,H"
                          : !o->have_spp        ? "--spp N"
                          : !o->have_tile       ? "--tile X,Y,W,H"
                          : !o->have_dims       ? "--dims D"
                                                : NULL;
    if (missing) {
        cli_error("pixels: %s is required (qmc pixels --help)", missing);
        return -1;
    }
    return 0;
}

/* Where the tile comes from: the sampler here, or the daemon. */
typedef struct pixels_src {
    const qmc_pixels *px;         /* in-process */
    qmc_client *client;           /* remote, or NULL */
    const pixels_opts *o;
} pixels_src;

/* The tile, whole, to f (a cli_emit_fn). */
static int emit(void *ctx, FILE *f)
{
    const pixels_src *src = ctx;
    const pixels_opts *o = src->o;
    if (src->client) {
        cli_raw_sink k = {f, "pixels", 0};
        int err = qmc_client_pixels_stream(src->client, &o->spec, &o->tile, o->fmt,
                                           cli_raw_chunk, &k);
        return cli_stream_done(src->client, err, k.failed);
    }
    const size_t value_bytes = qmc_format_bytes(o->fmt);
    const uint64_t row_bytes = (uint64_t)o->spec.dims * value_bytes;
    uint64_t block = BLOCK_BYTES / row_bytes;
    if (block == 0)
        block = 1;
    if (row_bytes > SIZE_MAX / block)
        return cli_error("pixels: one sample of %u dims is more than this machine can "
                         "hold", o->spec.dims);
    void *buf = malloc((size_t)(block * row_bytes));
    if (!buf)
        return cli_error("pixels: out of memory for a block of %llu bytes",
                         (unsigned long long)(block * row_bytes));
    const uint64_t total = (uint64_t)o->tile.width * o->tile.height * o->tile.sample_count;
    int rc = 0;
    for (uint64_t done = 0; done < total && rc == 0;) {
        qmc_pixel_tile piece;
        int err = qmc_pixel_tile_piece(&o->tile, done, block, &piece);
        if (err == 0)
            err = qmc_pixels_fill(src->px, &piece, o->fmt, buf);
        if (err) {
            rc = cli_error("pixels: %s", qmc_strerror(err));
            break;
        }
        const uint64_t n = (uint64_t)piece.width * piece.height * piece.sample_count;
        cli_to_little_endian(buf, (size_t)n * o->spec.dims, value_bytes);
        rc = cli_write_all(f, buf, (size_t)(n * row_bytes), "pixels") ? CLI_EXIT_FAIL : 0;
        done += n;
    }
    free(buf);
    return rc;
}

int cli_cmd_pixels(int argc, char **argv)
{
    static const struct option longopts[] = {
        {"sampler", required_argument, 0, 0}, {"resolution", required_argument, 0, 0},
        {"spp", required_argument, 0, 0},     {"seed", required_argument, 0, 0},
        {"frame", required_argument, 0, 0},   {"tile", required_argument, 0, 0},
        {"samples", required_argument, 0, 0}, {"dims", required_argument, 0, 0},
        {"format", required_argument, 0, 0},  {"out", required_argument, 0, 0},
        {"help", no_argument, 0, 0},          {0, 0, 0, 0},
    };
    const char *endpoint;
    if (cli_remote_take(&argc, argv, &endpoint))
        return CLI_EXIT_FAIL;
    pixels_opts o;
    memset(&o, 0, sizeof o);
    o.fmt = QMC_FORMAT_F32;
    int first = 1, more;
    const char *name, *arg;
    while ((more = cli_next_option("pixels", argc, argv, longopts, &first, &name, &arg)) > 0) {
        if (strcmp(name, "help") == 0) {
            fputs(pixels_help, stdout);
            fputs(cli_remote_help, stdout);
            return CLI_EXIT_OK;
        }
        if (take_option(&o, name, arg))
            return CLI_EXIT_FAIL;
    }
    if (more < 0 || check_required(&o))
        return CLI_EXIT_FAIL;
    if (!o.have_samples) {
        o.tile.sample_start = 0;
        o.tile.sample_count = o.spec.spp;
    }
    /* The same checks, and so the same messages, in-process and remote,
     * and all before the first byte goes out. */
    char why[256];
    int err = qmc_pixel_spec_check(&o.spec, why, sizeof why);
    if (err)
        return cli_error("%s", why[0] ? why : qmc_strerror(err));
    qmc_pixels *px = NULL;
    err = qmc_pixels_new(&o.spec, &px);
    if (err)
        return cli_error("pixels: %s", qmc_strerror(err));
    int rc;
    if (qmc_pixels_tile_check(px, &o.tile, NULL, why, sizeof why) != 0) {
        rc = cli_error("%s", why);
    } else if (endpoint) {
        qmc_client *c = NULL;
        rc = cli_remote_connect(endpoint, &c);
        if (rc == 0) {
            pixels_src src = {px, c, &o};
            rc = cli_emit_out(o.out, "pixels", emit, &src);
        }
        qmc_client_close(c);
    } else {
        pixels_src src = {px, NULL, &o};
        rc = cli_emit_out(o.out, "pixels", emit, &src);
    }
    qmc_pixels_free(px);
    return rc;
}
