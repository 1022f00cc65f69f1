/*
 * csv_read.c - CSV points for `qmc discrepancy` (the format is in
 * csv_read.h).  Must not: do I/O, accept a coordinate strtod did not read
 * whole, grow past the caller's caps, or keep going after an error.
 */
#include "csv_read.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { CSV_FAILED = 1 };

static int fail(cli_csv_reader *r, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static int fail(cli_csv_reader *r, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(r->why, sizeof r->why, fmt, ap);
    va_end(ap);
    return CSV_FAILED;
}

int cli_csv_init(cli_csv_reader *r, const char *name, size_t max_points,
                 uint32_t max_dims, size_t max_line_bytes)
{
    memset(r, 0, sizeof *r);
    r->name = name;
    r->max_points = max_points;
    r->max_dims = max_dims;
    r->row = malloc((max_dims ? max_dims : 1) * sizeof *r->row);
    if (!r->row || cli_linebuf_init(&r->lines, max_line_bytes) != CLI_LINE_OK) {
        cli_csv_close(r);
        snprintf(r->why, sizeof r->why, "out of memory");
        return -1;
    }
    return 0;
}

void cli_csv_close(cli_csv_reader *r)
{
    cli_linebuf_close(&r->lines);
    free(r->row);
    free(r->v);
    r->row = r->v = NULL;
    r->n = r->cap = 0;
}

static int is_blank(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\n';
}

/* Appends r->row; grows by doubling up to the point cap. */
static int push_point(cli_csv_reader *r)
{
    if (r->n == r->cap) {
        size_t cap = r->cap ? 2 * r->cap : 64;
        if (cap > r->max_points)
            cap = r->max_points;
        double *v = realloc(r->v, cap * r->dims * sizeof *v);
        if (!v)
            return -1;
        r->v = v;
        r->cap = cap;
    }
    memcpy(r->v + r->n * r->dims, r->row, r->dims * sizeof *r->row);
    r->n++;
    return 0;
}

/* One line into r->row[0 .. *count). */
static int parse_line(cli_csv_reader *r, char *line, uint32_t *count)
{
    uint32_t k = 0;
    char *p = line;
    for (;;) {
        char *field = p;
        while (*p != ',' && *p != '\0')
            p++;
        char sep = *p;
        *p = '\0';
        /* Trim the field for parsing and for quoting it in messages. */
        while (is_blank(*field))
            field++;
        char *end = field + strlen(field);
        while (end > field && is_blank(end[-1]))
            *--end = '\0';
        if (k == r->max_dims)
            return fail(r, "line %zu: more than %u coordinates (the limit)", r->lineno,
                        r->max_dims);
        if (*field == '\0')
            return fail(r, "line %zu: coordinate %u is empty", r->lineno, k + 1);
        char *stop = NULL;
        errno = 0;
        double v = strtod(field, &stop);
        if (stop == field || *stop != '\0')
            return fail(r, "line %zu: coordinate %u: '%.40s' is not a number", r->lineno,
                        k + 1, field);
        if (!isfinite(v))
            return fail(r, "line %zu: coordinate %u: '%.40s' is not finite", r->lineno,
                        k + 1, field);
        if (!(v >= 0.0 && v <= 1.0))
            return fail(r, "line %zu: coordinate %.40s outside [0,1]", r->lineno, field);
        r->row[k++] = v;
        if (sep == '\0')
            break;
        p++;
    }
    *count = k;
    return 0;
}

static int on_line(void *ctx, char *line, size_t len, int terminated)
{
    cli_csv_reader *r = ctx;
    (void)len, (void)terminated;
    r->lineno++;
    size_t lead = strspn(line, " \t\r\n");
    if (line[lead] == '\0' || line[lead] == '#')
        return 0;
    uint32_t count = 0;
    if (parse_line(r, line, &count) != 0)
        return CSV_FAILED;
    if (r->dims == 0)
        r->dims = count;
    else if (count != r->dims)
        return fail(r, "line %zu: %u coordinate%s, expected %u", r->lineno, count,
                    count == 1 ? "" : "s", r->dims);
    if (r->n == r->max_points)
        return fail(r, "more than %zu points (the limit that keeps the O(n^2) work "
                    "bounded)", r->max_points);
    if (push_point(r) != 0)
        return fail(r, "out of memory at line %zu", r->lineno);
    return 0;
}

/* Turns a linebuf result into 0 / -1 with why. */
static int result(cli_csv_reader *r, int lr)
{
    if (lr == 0)
        return 0;
    if (lr == CLI_LINE_TOO_LONG)
        fail(r, "line %zu: longer than %zu bytes", r->lineno + 1, r->lines.max_bytes);
    else if (lr == CLI_LINE_NUL)
        fail(r, "line %zu: a NUL byte (not a text file?)", r->lineno + 1);
    else if (lr == CLI_LINE_NOMEM)
        fail(r, "out of memory");
    if (!r->why[0])
        fail(r, "failed");
    return -1;
}

int cli_csv_feed(cli_csv_reader *r, const char *data, size_t n)
{
    if (r->why[0])
        return -1;
    return result(r, cli_linebuf_feed(&r->lines, data, n, on_line, r));
}

int cli_csv_finish(cli_csv_reader *r)
{
    if (r->why[0])
        return -1;
    if (result(r, cli_linebuf_end(&r->lines, on_line, r)) != 0)
        return -1;
    if (r->n == 0) {
        fail(r, "%s holds no points", r->name);
        return -1;
    }
    return 0;
}
