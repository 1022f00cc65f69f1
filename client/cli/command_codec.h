/*
 * command_codec.h - the bytes `qmc integrate --command` exchanges with
 * PROGRAM (private to the CLI): batches of points out, values in.  Pure:
 * no I/O, no process, so a unit test and a fuzzer drive it exactly as the
 * pipe pump (command_pump.c) does, with the bytes cut anywhere.
 *
 * text (the default):
 *   out  each point is one line of D numbers separated by one blank, each
 *        the shortest decimal that reads back as the same double ("%.15g",
 *        else "%.16g", else "%.17g": the first that strtod returns
 *        exactly), then an empty line ends the batch.
 *   in   one value per point, one per line, in order: a number as strtod
 *        reads it ("0.25", "-1e-3", "nan", "inf"), blanks around it and a
 *        final '\r' allowed.  An empty line or anything else is not a
 *        number.
 * f64:
 *   out  a little-endian u32 count, then count x D little-endian f64.
 *   in   count little-endian f64.
 *
 * A batch's answer is complete when count values have been read; a byte
 * past them is an error ("too many values"), never the next batch's.
 */
#ifndef QMC_CLI_COMMAND_CODEC_H
#define QMC_CLI_COMMAND_CODEC_H

#include <stddef.h>
#include <stdint.h>

#include "linebuf.h"

typedef enum cli_cmd_format { CLI_CMD_TEXT = 0, CLI_CMD_F64 = 1 } cli_cmd_format;

/* "text" or "f64" -> *out; -1 for anything else. */
int cli_cmd_format_parse(const char *name, cli_cmd_format *out);

/* The longest a number takes in text ("-2.2250738585072014e-308"), and
 * a value line (longer is "not a number"). */
enum { CLI_CMD_NUMBER_BYTES = 25, CLI_CMD_LINE_BYTES = 1024 };

/* Writes the shortest round-trip decimal of x into buf (at least
 * CLI_CMD_NUMBER_BYTES + 1 bytes) and returns its length. */
size_t cli_cmd_shortest(double x, char *buf);

/* ---- out: one batch's bytes, produced in pieces --------------------------- */
typedef struct cli_cmd_enc {
    cli_cmd_format format;
    const double *points;     /* count x dims, the caller's */
    size_t count, next;       /* points, and the next one to encode */
    uint32_t dims;
    int stage;                /* 0 header, 1 points, 2 trailer, 3 done */
} cli_cmd_enc;

/* The smallest buffer cli_cmd_enc_fill always makes progress with: one
 * point of dims numbers (and a header or trailer). */
size_t cli_cmd_enc_min_bytes(cli_cmd_format format, uint32_t dims);
void cli_cmd_enc_start(cli_cmd_enc *e, cli_cmd_format format, const double *points,
                       size_t count, uint32_t dims);
/* Appends the next whole points (and the header or the trailer) that fit
 * in buf[0 .. cap) and returns the bytes written; 0 once the batch is all
 * out (cli_cmd_enc_done) - or when cap is below cli_cmd_enc_min_bytes. */
size_t cli_cmd_enc_fill(cli_cmd_enc *e, char *buf, size_t cap);
int cli_cmd_enc_done(const cli_cmd_enc *e);

/* ---- in: one batch's values, read in pieces -------------------------------- */
typedef enum cli_cmd_status {
    CLI_CMD_MORE = 0,         /* fewer than count values so far */
    CLI_CMD_DONE = 1,         /* exactly count values */
    CLI_CMD_NOT_NUMBER = -1,  /* why says which line and what it held */
    CLI_CMD_TOO_MANY = -2,    /* a byte past the count-th value */
    CLI_CMD_NOMEM = -3
} cli_cmd_status;

typedef struct cli_cmd_dec {
    cli_cmd_format format;
    double *values;           /* count, the caller's */
    size_t count, got;
    cli_linebuf lines;        /* text */
    unsigned char part[8];    /* f64: the bytes of a value cut by a read */
    size_t part_len;
    int status;
    char why[160];            /* after NOT_NUMBER or TOO_MANY */
} cli_cmd_dec;

/* Returns 0, or CLI_CMD_NOMEM. */
int cli_cmd_dec_init(cli_cmd_dec *d, cli_cmd_format format);
void cli_cmd_dec_close(cli_cmd_dec *d);
/* Expects count values into values[0 .. count) (count >= 1). */
void cli_cmd_dec_start(cli_cmd_dec *d, double *values, size_t count);
/* Feeds n bytes; returns the status (sticky once an error). */
int cli_cmd_dec_feed(cli_cmd_dec *d, const char *data, size_t n);
/* The output ended: a text line cut short by the end counts if it is a
 * number.  Returns the status (CLI_CMD_MORE: too few values). */
int cli_cmd_dec_end(cli_cmd_dec *d);

#endif
