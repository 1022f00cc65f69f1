/*
 * csv_read.h - the points reader of `qmc discrepancy` (private to the
 * CLI): CSV text, fed in pieces of any size, to a row-major array of
 * coordinates in [0, 1].  Pure (no I/O), so tests/fuzz/fuzz_csv.c drives
 * it exactly as the CLI does.
 *
 * The format: one point per line, coordinates joined by ',', each a number
 * strtod reads whole (blanks around it allowed) that is finite and in
 * [0, 1]; every point has as many coordinates as the first; blank lines
 * and lines whose first non-blank is '#' are skipped.  Points, coordinates
 * and bytes per line are capped (the caller's limits).
 */
#ifndef QMC_CLI_CSV_READ_H
#define QMC_CLI_CSV_READ_H

#include <stddef.h>
#include <stdint.h>

#include "linebuf.h"

typedef struct cli_csv_reader {
    cli_linebuf lines;
    const char *name;         /* "stdin" or the file, for messages */
    size_t lineno;
    size_t max_points;
    uint32_t max_dims;
    double *v;                /* n x dims, row-major; owned */
    size_t n, cap;            /* points read, points v holds */
    uint32_t dims;            /* from the first point; 0 before it */
    double *row;              /* max_dims scratch */
    char why[160];            /* the reason, after an error */
} cli_csv_reader;

/* Returns 0, or -1 (out of memory, with why set).  name is borrowed. */
int cli_csv_init(cli_csv_reader *r, const char *name, size_t max_points,
                 uint32_t max_dims, size_t max_line_bytes);
void cli_csv_close(cli_csv_reader *r);
/* Feeds n more bytes.  Returns 0, or -1 with why naming the line and the
 * problem ("line 3: coordinate 2: 'x' is not a number"); once it failed,
 * the reader stays failed. */
int cli_csv_feed(cli_csv_reader *r, const char *data, size_t n);
/* The end of the input: the last line, and at least one point.  Returns 0
 * with r->v, r->n and r->dims set, or -1 with why. */
int cli_csv_finish(cli_csv_reader *r);

#endif
