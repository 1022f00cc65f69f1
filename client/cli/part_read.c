/*
 * part_read.c - reads --part files record by record (the format is in
 * part_read.h), checking every field and the SHA-256 digest.  Must not: do
 * I/O, accept a field it did not read whole, hand on a record the digest
 * has not yet covered without the final check still to come (a handler
 * sees records as they arrive; only CLI_PART_DONE says the digest
 * matched), or go on after an error.
 */
#include "part_read.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The record expected next. */
enum {
    ST_MAGIC, ST_FINGERPRINT, ST_BLOCKS, ST_SECONDS, ST_ARGS, ST_SUMS, ST_END, ST_DONE,
    ST_FAILED
};

enum { STOP = 1 };

static int failv(cli_part_reader *r, int with_line, const char *fmt, va_list ap)
    __attribute__((format(printf, 3, 0)));
static int failv(cli_part_reader *r, int with_line, const char *fmt, va_list ap)
{
    size_t off = 0;
    if (with_line)
        off = (size_t)snprintf(r->why, sizeof r->why, "line %lu: ", r->lineno);
    if (off < sizeof r->why)
        vsnprintf(r->why + off, sizeof r->why - off, fmt, ap);
    r->state = ST_FAILED;
    return STOP;
}

static int fail(cli_part_reader *r, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static int fail(cli_part_reader *r, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    failv(r, 1, fmt, ap);
    va_end(ap);
    return STOP;
}

int cli_part_refuse(cli_part_reader *r, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    failv(r, 0, fmt, ap);
    va_end(ap);
    return STOP;
}

void cli_part_hex(const unsigned char digest[crypto_hash_sha256_BYTES], char out[65])
{
    static const char hex[] = "0123456789abcdef";
    for (size_t i = 0; i < crypto_hash_sha256_BYTES; i++) {
        out[2 * i] = hex[digest[i] >> 4];
        out[2 * i + 1] = hex[digest[i] & 15];
    }
    out[64] = '\0';
}

int cli_part_init(cli_part_reader *r, cli_part_fn on_item, void *ctx)
{
    memset(r, 0, sizeof *r);
    r->on_item = on_item;
    r->ctx = ctx;
    r->state = ST_MAGIC;
    if (sodium_init() < 0 || cli_linebuf_init(&r->lines, CLI_PART_MAX_LINE_BYTES) != 0) {
        snprintf(r->why, sizeof r->why, "out of memory");
        r->state = ST_FAILED;
        return -1;
    }
    crypto_hash_sha256_init(&r->sha);
    return 0;
}

void cli_part_close(cli_part_reader *r)
{
    cli_linebuf_close(&r->lines);
}

/* ---- fields ------------------------------------------------------------------- */

/* A whole decimal token at *p (digits only, at most max), then sep. */
static int take_u64(const char **p, char sep, uint64_t max, uint64_t *out)
{
    const char *s = *p;
    uint64_t v = 0;
    if (*s < '0' || *s > '9')
        return -1;
    if (s[0] == '0' && s[1] >= '0' && s[1] <= '9')
        return -1; /* no leading zeros: one spelling per number */
    for (; *s >= '0' && *s <= '9'; s++) {
        unsigned d = (unsigned)(*s - '0');
        if (v > (max - d) / 10)
            return -1;
        v = v * 10 + d;
    }
    if (*s != sep)
        return -1;
    *p = s + (sep ? 1 : 0);
    *out = v;
    return 0;
}

/* A whole floating-point token (as strtod reads it) ending at sep. */
static int take_double(const char **p, char sep, double *out)
{
    const char *s = *p;
    if (*s == ' ' || *s == '\t' || *s == '\0')
        return -1; /* strtod would skip blanks: not ours */
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (end == s || *end != sep)
        return -1;
    *p = end + (sep ? 1 : 0);
    *out = v;
    return 0;
}

static int hex_value(char c)
{
    if (c >= '0' && c <= '9')
        return c - '0';
    if (c >= 'a' && c <= 'f')
        return c - 'a' + 10;
    if (c >= 'A' && c <= 'F')
        return c - 'A' + 10;
    return -1;
}

static int is_lower_hex(const char *s, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!((s[i] >= '0' && s[i] <= '9') || (s[i] >= 'a' && s[i] <= 'f')))
            return 0;
    return s[n] == '\0';
}

/* %XX-decoding into out (as long as w, plus its NUL). */
static int decode_word(const char *w, char *out)
{
    for (; *w; w++) {
        if (*w == '%') {
            int hi = hex_value(w[1]), lo = hi < 0 ? -1 : hex_value(w[2]);
            if (lo < 0 || (hi == 0 && lo == 0))
                return -1;
            *out++ = (char)(hi * 16 + lo);
            w += 2;
        } else if (*w == ' ' || *w == '\t' || *w == '\r') {
            return -1; /* the writer encodes these */
        } else {
            *out++ = *w;
        }
    }
    *out = '\0';
    return 0;
}

static int parse_sums(cli_part_reader *r, const char *p, qmc_sampling_sums *s)
{
    memset(s, 0, sizeof *s);
    uint64_t block, count, nonfinite, top;
    if (take_u64(&p, ' ', UINT64_MAX, &block) || take_u64(&p, ' ', UINT64_MAX, &count) ||
        take_u64(&p, ' ', UINT64_MAX, &nonfinite))
        return fail(r, "malformed block sums (block, count, nonfinite)");
    if (block >= r->blocks)
        return fail(r, "block %llu past the job's %llu blocks", (unsigned long long)block,
                    (unsigned long long)r->blocks);
    if (r->n_sums > 0 && block != r->next_block)
        return fail(r, "block %llu where block %llu comes next (a part holds consecutive "
                    "blocks)", (unsigned long long)block,
                    (unsigned long long)r->next_block);
    if (count > QMC_SAMPLING_BLOCK || nonfinite > count)
        return fail(r, "block %llu: %llu points, %llu non-finite (at most %d points a "
                    "block, non-finite among them)", (unsigned long long)block,
                    (unsigned long long)count, (unsigned long long)nonfinite,
                    QMC_SAMPLING_BLOCK);
    s->block = block, s->count = count, s->nonfinite = nonfinite;
    double *d[11] = {&s->f[0], &s->f[1], &s->absf[0], &s->absf[1], &s->g[0], &s->g[1],
                     &s->mean_f, &s->mean_g, &s->m2_f, &s->m2_g, &s->c_fg};
    for (int i = 0; i < 11; i++)
        if (take_double(&p, ' ', d[i]))
            return fail(r, "block %llu: sum %d is not a number", (unsigned long long)block,
                        i + 1);
    const char *top_at = p;
    while (*p >= '0' && *p <= '9')
        p++;
    const char top_sep = *p;
    p = top_at;
    if ((top_sep != ' ' && top_sep != '\0') || take_u64(&p, top_sep, QMC_SAMPLING_TOP, &top) ||
        (top == 0) != (top_sep == '\0'))
        return fail(r, "block %llu: malformed count of largest values (0 .. %d)",
                    (unsigned long long)block, QMC_SAMPLING_TOP);
    for (uint64_t k = 0; k < top; k++) {
        if (take_double(&p, k + 1 < top ? ' ' : '\0', &s->top[k]))
            return fail(r, "block %llu: largest value %llu is not a number",
                        (unsigned long long)block, (unsigned long long)k + 1);
        if (!(s->top[k] >= 0.0) || (k > 0 && s->top[k] > s->top[k - 1]))
            return fail(r, "block %llu: the largest values are not non-negative and "
                        "descending", (unsigned long long)block);
    }
    return 0;
}

/* ---- records -------------------------------------------------------------------- */

static int handle(cli_part_reader *r, cli_part_event ev)
{
    r->item.event = ev;
    if (r->on_item(r->ctx, &r->item) != 0) {
        if (r->state != ST_FAILED) /* a handler that gave no reason */
            cli_part_refuse(r, "line %lu: refused", r->lineno);
        return STOP;
    }
    return 0;
}

static int digest_line(cli_part_reader *r, const char *hex)
{
    unsigned char want[crypto_hash_sha256_BYTES];
    char got[65];
    crypto_hash_sha256_final(&r->sha, want);
    cli_part_hex(want, got);
    if (!is_lower_hex(hex, 64))
        return fail(r, "malformed digest (want 64 lowercase hex digits)");
    if (strcmp(hex, got) != 0)
        return fail(r, "the digest does not match the content: the part was edited or "
                    "damaged");
    r->state = ST_END;
    return 0;
}

static int on_line(void *ctx, char *line, size_t len, int terminated)
{
    cli_part_reader *r = ctx;
    r->lineno++;
    if (!terminated)
        return fail(r, "incomplete (no newline): the part is truncated");
    const int is_digest = strncmp(line, "digest sha256 ", 14) == 0;
    if (!is_digest && r->state < ST_END) {
        crypto_hash_sha256_update(&r->sha, (const unsigned char *)line, len);
        crypto_hash_sha256_update(&r->sha, (const unsigned char *)"\n", 1);
    }
    switch (r->state) {
    case ST_MAGIC:
        if (strcmp(line, CLI_PART_MAGIC) == 0) {
            r->state = ST_FINGERPRINT;
            return 0;
        }
        if (strcmp(line, "qmc-partial 1") == 0)
            return fail(r, "a version-1 part, which carries no digest to check it by: "
                        "make it again with this qmc");
        return fail(r, "not a qmc partial result (first line '%.40s')", line);
    case ST_FINGERPRINT: {
        const char *p = line + 12;
        uint64_t v = 0;
        if (strncmp(line, "fingerprint ", 12) != 0 || !is_lower_hex(p, 16))
            return fail(r, "want 'fingerprint' and 16 lowercase hex digits");
        for (int i = 0; i < 16; i++)
            v = v << 4 | (uint64_t)hex_value(p[i]);
        r->fingerprint = v;
        r->state = ST_BLOCKS;
        return 0;
    }
    case ST_BLOCKS: {
        const char *p = line + 7;
        if (strncmp(line, "blocks ", 7) != 0 ||
            take_u64(&p, '\0', QMC_SAMPLING_MAX_BLOCKS, &r->blocks) || r->blocks == 0)
            return fail(r, "want 'blocks' and a whole number 1 .. %u",
                        (unsigned)QMC_SAMPLING_MAX_BLOCKS);
        r->state = ST_SECONDS;
        return 0;
    }
    case ST_SECONDS: {
        const char *p = line + 8;
        if (strncmp(line, "seconds ", 8) != 0 || take_double(&p, '\0', &r->seconds) ||
            !(r->seconds >= 0.0 && r->seconds <= CLI_PART_MAX_SECONDS))
            return fail(r, "want 'seconds' and a finite time 0 .. %g, not '%.40s'",
                        CLI_PART_MAX_SECONDS, line);
        r->state = ST_ARGS;
        return handle(r, CLI_PART_HEADER);
    }
    case ST_ARGS:
        if (strncmp(line, "arg ", 4) == 0) {
            if (r->n_args == CLI_PART_MAX_ARGS)
                return fail(r, "more than %d arguments", CLI_PART_MAX_ARGS);
            if (decode_word(line + 4, r->item.word) != 0)
                return fail(r, "malformed argument (a bad %%XX escape or a bare blank)");
            r->n_args++;
            return handle(r, CLI_PART_ARG);
        }
        /* Not an argument: the first sums record, handled below. */
        r->state = ST_SUMS;
        /* fall through */
    case ST_SUMS:
        if (strncmp(line, "sums ", 5) == 0) {
            if (parse_sums(r, line + 5, &r->item.sums) != 0)
                return STOP;
            r->next_block = r->item.sums.block + 1;
            r->n_sums++;
            return handle(r, CLI_PART_SUMS);
        }
        if (is_digest) {
            if (r->n_sums == 0)
                return fail(r, "a part with no block sums");
            return digest_line(r, line + 14);
        }
        return fail(r, "unknown or misplaced record '%.40s'", line);
    case ST_END:
        if (strcmp(line, "end") != 0)
            return fail(r, "want 'end' after the digest, not '%.40s'", line);
        r->state = ST_DONE;
        return handle(r, CLI_PART_DONE);
    case ST_DONE:
        return fail(r, "more after the end record");
    default:
        return STOP;
    }
}

/* A linebuf result as 0 / -1 with why. */
static int result(cli_part_reader *r, int lr)
{
    if (lr == 0)
        return 0;
    if (r->state != ST_FAILED) {
        r->lineno++;
        if (lr == CLI_LINE_TOO_LONG)
            fail(r, "longer than %u bytes", CLI_PART_MAX_LINE_BYTES);
        else if (lr == CLI_LINE_NUL)
            fail(r, "a NUL byte (not a text file?)");
        else
            fail(r, "out of memory");
    }
    return -1;
}

int cli_part_feed(cli_part_reader *r, const char *data, size_t n)
{
    if (r->state == ST_FAILED)
        return -1;
    return result(r, cli_linebuf_feed(&r->lines, data, n, on_line, r));
}

int cli_part_finish(cli_part_reader *r)
{
    if (r->state == ST_FAILED)
        return -1;
    if (result(r, cli_linebuf_end(&r->lines, on_line, r)) != 0)
        return -1;
    if (r->state != ST_DONE) {
        cli_part_refuse(r, "truncated (no end record after line %lu)", r->lineno);
        return -1;
    }
    return 0;
}
