/*
 * cli_common.c - what every qmc subcommand shares: error lines, number
 * parsing, the sequence options, checked writes, the clock runs are timed
 * by, list items and texts cut to fit a report's fields.
 */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "cli.h"

int cli_error(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fputs("qmc: ", stderr);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    return CLI_EXIT_FAIL;
}

static int is_digit_in_base(char c, int base)
{
    if (c >= '0' && c <= '9')
        return 1;
    return base == 16 && ((c >= 'a' && c <= 'f') || (c >= 'A' && c <= 'F'));
}

int cli_parse_u64(const char *opt, const char *text, uint64_t min,
                  uint64_t max, uint64_t *out)
{
    /* Decimal, or hexadecimal with 0x; no sign, no octal surprises. */
    int base = 10;
    const char *digits = text;
    if (text[0] == '0' && (text[1] == 'x' || text[1] == 'X')) {
        base = 16;
        digits = text + 2;
    }
    char *end = NULL;
    unsigned long long v = 0;
    errno = 0;
    if (is_digit_in_base(digits[0], base))
        v = strtoull(digits, &end, base);
    if (!end || errno || *end != '\0') {
        if (errno == ERANGE)
            cli_error("%s: '%s' is too large", opt, text);
        else
            cli_error("%s: '%s' is not a whole number", opt, text);
        return -1;
    }
    if (v < min || v > max) {
        cli_error("%s: %s is outside %llu..%llu", opt, text,
                  (unsigned long long)min, (unsigned long long)max);
        return -1;
    }
    *out = v;
    return 0;
}

int cli_parse_double(const char *opt, const char *text, double *out)
{
    char *end = NULL;
    errno = 0;
    double v = strtod(text, &end);
    if (end == text || *end != '\0' || errno == ERANGE || !isfinite(v)) {
        cli_error("%s: '%s' is not a finite number", opt, text);
        return -1;
    }
    *out = v;
    return 0;
}

const char cli_seq_help[] =
    "sequence options:\n"
    "  --seq KIND        sobol | halton | hammersley | random | stratified | lhs\n"
    "  --dims D          dimensions (default 2; sobol 1..21201, halton and\n"
    "                    hammersley 1..4096, the others 1..21201)\n"
    "  --scramble S      none (default); sobol: shift | owen | fast-owen\n"
    "                    (fast-owen: pbrt-v4's SobolSampler values);\n"
    "                    halton, hammersley: faure | owen\n"
    "  --seed X          scramble / random seed, decimal or 0x hex (default 0)\n"
    "  --shuffle         sobol only: nested-uniform shuffled index order\n"
    "  --set-size N      hammersley, stratified, lhs: points in the finite set\n"
    "                    (default: start + count); stratified needs N = k^dims\n";

void cli_seq_opts_init(cli_seq_opts *o)
{
    memset(o, 0, sizeof *o);
    o->spec.dims = 2;
    o->spec.scramble = QMC_SCRAMBLE_NONE;
}

int cli_seq_option(cli_seq_opts *o, const char *name, const char *arg)
{
    uint64_t v;
    if (strcmp(name, "seq") == 0) {
        if (qmc_seq_kind_parse(arg, &o->spec.kind) != 0) {
            cli_error("--seq: unknown sequence kind '%s' (sobol, halton, "
                      "hammersley, random, stratified, lhs)", arg);
            return -1;
        }
        o->have_kind = 1;
        return 1;
    }
    if (strcmp(name, "dims") == 0) {
        if (cli_parse_u64("--dims", arg, 1, QMC_MAX_DIMS, &v))
            return -1;
        o->spec.dims = (uint32_t)v;
        return 1;
    }
    if (strcmp(name, "scramble") == 0) {
        if (qmc_scramble_parse(arg, &o->spec.scramble) != 0) {
            cli_error("--scramble: unknown scramble '%s' (none, shift, owen, faure, fast-owen)", arg);
            return -1;
        }
        return 1;
    }
    if (strcmp(name, "seed") == 0) {
        if (cli_parse_u64("--seed", arg, 0, UINT64_MAX, &o->spec.seed))
            return -1;
        return 1;
    }
    if (strcmp(name, "shuffle") == 0) {
        o->spec.flags |= QMC_SEQ_SHUFFLE;
        return 1;
    }
    if (strcmp(name, "set-size") == 0) {
        if (cli_parse_u64("--set-size", arg, 1, QMC_SEQ_MAX_INDEX, &o->spec.set_size))
            return -1;
        o->have_set_size = 1;
        return 1;
    }
    return 0;
}

int cli_seq_finish(cli_seq_opts *o, uint64_t default_set_size)
{
    if (!o->have_kind) {
        cli_error("--seq KIND is required (sobol, halton, hammersley, random, "
                  "stratified, lhs)");
        return -1;
    }
    const qmc_seq_kind k = o->spec.kind;
    const int finite = k == QMC_SEQ_HAMMERSLEY || k == QMC_SEQ_STRATIFIED ||
                       k == QMC_SEQ_LHS;
    if (!finite && o->have_set_size) {
        cli_error("--set-size: %s is an infinite sequence and takes no set size",
                  qmc_seq_kind_name(k));
        return -1;
    }
    if (finite && !o->have_set_size)
        o->spec.set_size = default_set_size;
    char why[256];
    int err = qmc_seq_spec_check(&o->spec, why, sizeof why);
    if (err) {
        cli_error("%s", why);
        return -1;
    }
    return 0;
}

int cli_write_all(FILE *f, const void *buf, size_t bytes, const char *what)
{
    if (bytes && fwrite(buf, 1, bytes, f) != bytes) {
        cli_error("writing %s: %s", what, strerror(errno));
        return -1;
    }
    return 0;
}

int cli_next_option(const char *cmd, int argc, char **argv,
                    const struct option *longopts, int *first,
                    const char **name, const char **arg)
{
    if (*first) {
        opterr = 0; /* we print our own one-line errors */
        optind = 1;
        *first = 0;
    }
    int idx = -1;
    int c = getopt_long(argc, argv, "", longopts, &idx);
    if (c == -1) {
        if (optind < argc) {
            cli_error("%s: unexpected argument '%s'", cmd, argv[optind]);
            return -1;
        }
        return 0;
    }
    if (c != 0 || idx < 0) {
        cli_error("%s: unknown or incomplete option '%s' (try qmc %s --help)", cmd,
                  argv[optind - 1], cmd);
        return -1;
    }
    *name = longopts[idx].name;
    *arg = optarg;
    return 1;
}

double cli_now_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int cli_list_next(const char **p, const char **item, size_t *len)
{
    if (**p == '\0')
        return 0;
    const char *comma = strchr(*p, ',');
    *item = *p;
    *len = comma ? (size_t)(comma - *p) : strlen(*p);
    *p += *len + (comma ? 1 : 0);
    return 1;
}

int cli_list_copy(const char *item, size_t len, char *buf, size_t bytes)
{
    if (len == 0 || len >= bytes)
        return -1;
    memcpy(buf, item, len);
    buf[len] = '\0';
    return 0;
}

void cli_copy_text(char *dst, size_t bytes, const char *src)
{
    size_t n = strlen(src);
    if (n >= bytes)
        n = bytes - 1;
    memcpy(dst, src, n);
    dst[n] = '\0';
}
