/*
 * command_codec.c - the --command exchange's bytes (see command_codec.h).
 * Must not: touch a file descriptor, allocate per value, or take a value
 * from a line that is not wholly a number.
 */
#include "command_codec.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int cli_cmd_format_parse(const char *name, cli_cmd_format *out)
{
    if (strcmp(name, "text") == 0)
        *out = CLI_CMD_TEXT;
    else if (strcmp(name, "f64") == 0)
        *out = CLI_CMD_F64;
    else
        return -1;
    return 0;
}

/* The reference way: the first of 15, 16, 17 significant digits that
 * strtod reads back as x.  15 digits always read back as themselves, so
 * "%.15g" is the shortest form when one of 15 digits or fewer reads back
 * (and %g drops the trailing zeros); 17 always suffice (IEEE 754-2008,
 * 5.12.2).  (A subnormal, with fewer bits, may have a shorter form that
 * %.15g misses; what is written still reads back exactly.)  About 1 us a
 * number, so only for what the fast path leaves. */
static size_t shortest_printf(double x, char *buf)
{
    int n = 0;
    for (int digits = 15; digits <= 17; digits++) {
        n = snprintf(buf, CLI_CMD_NUMBER_BYTES + 1, "%.*g", digits, x);
        if (digits == 17 || strtod(buf, NULL) == x)
            break;
    }
    return n > 0 ? (size_t)n : 0;
}

#ifdef __SIZEOF_INT128__
typedef unsigned __int128 u128;

/* Does D x 10^-k read back as x = m 2^-s (m in [2^52, 2^53))?  In exact
 * integers: the distance |D 2^s - m 10^k| against half the gap to x's
 * neighbour on that side, scaled by 10^k 2^s (the gap below is half as
 * wide when m = 2^52); a tie reads back as the even mantissa. */
static int reads_back(uint64_t d, uint64_t m, int s, uint64_t p10)
{
    u128 v = (u128)d << s, n = (u128)m * p10;
    u128 diff = v >= n ? v - n : n - v;
    u128 lim = p10;
    u128 twice = v < n && m == (1ull << 52) ? diff * 4 : diff * 2;
    return twice < lim || (twice == lim && (m & 1) == 0);
}

/* Points live in [0, 1): for x in [1e-3, 1) the shortest digits come from
 * exact 128-bit integers in about 50 ns, and are the ones the reference
 * way gives (the closest of the shortest; Python's repr too), written as
 * "0.0ddd" as %g and repr write them.  0 elsewhere (the caller falls
 * back). */
static size_t shortest_fast(double x, char *buf)
{
    static const uint64_t p10[20] = {
        1ull, 10ull, 100ull, 1000ull, 10000ull, 100000ull, 1000000ull, 10000000ull,
        100000000ull, 1000000000ull, 10000000000ull, 100000000000ull, 1000000000000ull,
        10000000000000ull, 100000000000000ull, 1000000000000000ull, 10000000000000000ull,
        100000000000000000ull, 1000000000000000000ull, 10000000000000000000ull};
    if (!(x >= 1e-3 && x < 1.0))
        return 0;
    /* The doubles nearest 1e-1, 1e-2 and 1e-3 lie above those numbers,
     * so these comparisons give the decimal exponent exactly. */
    const int e10 = x >= 1e-1 ? -1 : x >= 1e-2 ? -2 : -3;
    int ex;
    double f = frexp(x, &ex);                  /* x = f 2^ex, f in [0.5, 1) */
    const uint64_t m = (uint64_t)ldexp(f, 53); /* exact: 53 bits */
    const int s = 53 - ex;                     /* x = m 2^-s, s in 53 .. 62 */
    for (int n = 15; n <= 17; n++) {
        const int k = n - 1 - e10;             /* D = x 10^k has n digits */
        const u128 num = (u128)m * p10[k];
        const uint64_t lo = (uint64_t)(num >> s);
        const int exact = (num & (((u128)1 << s) - 1)) == 0;
        const uint64_t hi = lo + !exact;
        /* Of the two n-digit neighbours, the closer that reads back. */
        const u128 below = num - ((u128)lo << s), above = ((u128)hi << s) - num;
        uint64_t first = above < below ? hi : below < above ? lo : (hi & 1) ? lo : hi;
        uint64_t second = first == lo ? hi : lo; /* (a tie goes to the even digit) */
        uint64_t d = reads_back(first, m, s, p10[k])    ? first
                     : reads_back(second, m, s, p10[k]) ? second
                                                        : 0;
        if (d == 0 || d >= p10[n] || d < p10[n - 1])
            continue; /* none, or one digit more or less: the next n, or printf */
        while (d % 10 == 0)
            d /= 10, n--;
        /* D's first digit is worth 10^e10: "0.", -e10 - 1 zeros, the digits */
        size_t len = 0;
        buf[len++] = '0';
        buf[len++] = '.';
        for (int z = 0; z < -e10 - 1; z++)
            buf[len++] = '0';
        char digits[20];
        int nd = 0;
        for (; d; d /= 10)
            digits[nd++] = (char)('0' + d % 10);
        while (nd > 0)
            buf[len++] = digits[--nd];
        buf[len] = '\0';
        return len;
    }
    return 0;
}
#else
static size_t shortest_fast(double x, char *buf)
{
    (void)x, (void)buf;
    return 0;
}
#endif

size_t cli_cmd_shortest(double x, char *buf)
{
    if (x == 0 && !signbit(x)) {
        buf[0] = '0', buf[1] = '\0';
        return 1;
    }
    size_t n = shortest_fast(x, buf);
    return n ? n : shortest_printf(x, buf);
}

/* ---- out ------------------------------------------------------------------- */

size_t cli_cmd_enc_min_bytes(cli_cmd_format format, uint32_t dims)
{
    if (format == CLI_CMD_F64)
        return 4 + (size_t)dims * 8;
    return (size_t)dims * (CLI_CMD_NUMBER_BYTES + 1) + 1;
}

void cli_cmd_enc_start(cli_cmd_enc *e, cli_cmd_format format, const double *points,
                       size_t count, uint32_t dims)
{
    e->format = format;
    e->points = points;
    e->count = count;
    e->next = 0;
    e->dims = dims;
    e->stage = 0;
}

static void put_le64(unsigned char *p, double x)
{
    uint64_t u;
    memcpy(&u, &x, sizeof u);
    for (int k = 0; k < 8; k++)
        p[k] = (unsigned char)(u >> (8 * k));
}

size_t cli_cmd_enc_fill(cli_cmd_enc *e, char *buf, size_t cap)
{
    size_t len = 0;
    unsigned char *u = (unsigned char *)buf;
    if (e->stage == 0) { /* the header: f64's count (text has none) */
        if (e->format == CLI_CMD_F64) {
            if (cap < 4)
                return 0;
            /* A session's batches are far below 2^32 points. */
            uint32_t c = (uint32_t)e->count;
            for (int k = 0; k < 4; k++)
                u[k] = (unsigned char)(c >> (8 * k));
            len = 4;
        }
        e->stage = 1;
    }
    if (e->stage == 1) {
        const size_t per = e->format == CLI_CMD_F64
                               ? (size_t)e->dims * 8
                               : (size_t)e->dims * (CLI_CMD_NUMBER_BYTES + 1);
        while (e->next < e->count && cap - len >= per) {
            const double *x = e->points + e->next * e->dims;
            if (e->format == CLI_CMD_F64) {
                for (uint32_t j = 0; j < e->dims; j++, len += 8)
                    put_le64(u + len, x[j]);
            } else {
                for (uint32_t j = 0; j < e->dims; j++) {
                    len += cli_cmd_shortest(x[j], buf + len);
                    buf[len++] = j + 1 < e->dims ? ' ' : '\n';
                }
            }
            e->next++;
        }
        if (e->next == e->count)
            e->stage = 2;
    }
    if (e->stage == 2) { /* the trailer: text's empty line (f64 has none) */
        if (e->format == CLI_CMD_F64) {
            e->stage = 3;
        } else if (cap - len >= 1) {
            buf[len++] = '\n';
            e->stage = 3;
        }
    }
    return len;
}

int cli_cmd_enc_done(const cli_cmd_enc *e)
{
    return e->stage == 3;
}


/* ---- in -------------------------------------------------------------------- */

int cli_cmd_dec_init(cli_cmd_dec *d, cli_cmd_format format)
{
    d->format = format;
    d->values = NULL;
    d->count = d->got = d->part_len = 0;
    d->status = CLI_CMD_MORE;
    d->why[0] = '\0';
    d->lines.buf = NULL;
    if (format == CLI_CMD_TEXT && cli_linebuf_init(&d->lines, CLI_CMD_LINE_BYTES) != 0)
        return CLI_CMD_NOMEM;
    return 0;
}

void cli_cmd_dec_close(cli_cmd_dec *d)
{
    if (d->format == CLI_CMD_TEXT)
        cli_linebuf_close(&d->lines);
}

void cli_cmd_dec_start(cli_cmd_dec *d, double *values, size_t count)
{
    d->values = values;
    d->count = count;
    d->got = 0;
    d->part_len = 0;
    d->status = CLI_CMD_MORE;
    d->why[0] = '\0';
}

/* Up to 40 bytes of text for a message, anything unprintable as '?'. */
static void quote(char *out, size_t cap, const char *s, size_t n)
{
    size_t k = 0;
    for (; k < n && k < 40 && k + 4 < cap; k++)
        out[k] = s[k] >= 0x20 && s[k] < 0x7f ? s[k] : '?';
    if (k < n && k + 4 < cap) {
        memcpy(out + k, "...", 3);
        k += 3;
    }
    out[k] = '\0';
}

static int too_many(cli_cmd_dec *d)
{
    snprintf(d->why, sizeof d->why, "more values than the batch's %zu points", d->count);
    return d->status = CLI_CMD_TOO_MANY;
}

static int is_blank(char c)
{
    return c == ' ' || c == '\t' || c == '\r';
}

static int on_value_line(void *ctx, char *line, size_t len, int terminated)
{
    (void)terminated;
    cli_cmd_dec *d = ctx;
    if (d->got == d->count)
        return too_many(d);
    size_t a = 0, b = len;
    while (a < b && is_blank(line[a]))
        a++;
    while (b > a && is_blank(line[b - 1]))
        b--;
    line[b] = '\0';
    char *end = NULL;
    double v = a < b ? strtod(line + a, &end) : 0;
    if (a == b || end != line + b) {
        char q[48];
        quote(q, sizeof q, line, len);
        if (a == b)
            snprintf(d->why, sizeof d->why,
                     "an empty line where the value for point %zu was expected", d->got + 1);
        else
            snprintf(d->why, sizeof d->why, "'%s' is not a number (the value for point %zu)",
                     q, d->got + 1);
        return d->status = CLI_CMD_NOT_NUMBER;
    }
    d->values[d->got++] = v;
    return 0;
}

static int feed_text(cli_cmd_dec *d, const char *data, size_t n)
{
    int r = cli_linebuf_feed(&d->lines, data, n, on_value_line, d);
    if (r == CLI_LINE_TOO_LONG || r == CLI_LINE_NUL) {
        if (d->got == d->count)
            return too_many(d);
        snprintf(d->why, sizeof d->why, "%s where the value for point %zu was expected",
                 r == CLI_LINE_NUL ? "a NUL byte" : "a line of more than 1024 bytes",
                 d->got + 1);
        return d->status = CLI_CMD_NOT_NUMBER;
    }
    if (r < 0 || d->status < 0)
        return d->status < 0 ? d->status : (d->status = CLI_CMD_NOMEM);
    if (d->got == d->count && d->lines.len > 0)
        return too_many(d);
    return d->status = d->got == d->count ? CLI_CMD_DONE : CLI_CMD_MORE;
}

static int feed_f64(cli_cmd_dec *d, const unsigned char *p, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        if (d->got == d->count)
            return too_many(d);
        d->part[d->part_len++] = p[i];
        if (d->part_len == 8) {
            uint64_t u = 0;
            for (int k = 0; k < 8; k++)
                u |= (uint64_t)d->part[k] << (8 * k);
            memcpy(&d->values[d->got++], &u, sizeof u);
            d->part_len = 0;
        }
    }
    return d->status = d->got == d->count ? CLI_CMD_DONE : CLI_CMD_MORE;
}

int cli_cmd_dec_feed(cli_cmd_dec *d, const char *data, size_t n)
{
    if (d->status < 0 || n == 0)
        return d->status;
    if (d->format == CLI_CMD_F64)
        return feed_f64(d, (const unsigned char *)data, n);
    return feed_text(d, data, n);
}

int cli_cmd_dec_end(cli_cmd_dec *d)
{
    if (d->status < 0)
        return d->status;
    if (d->format == CLI_CMD_TEXT && cli_linebuf_end(&d->lines, on_value_line, d) != 0)
        return d->status;
    return d->status = d->got == d->count ? CLI_CMD_DONE : CLI_CMD_MORE;
}
