/*
 * linebuf.h - splits a byte stream, fed in pieces of any size, into lines
 * (private to the CLI).  Pure: no I/O, so the readers built on it (the CSV
 * points reader, the --part reader) can be driven by a fuzzer exactly as
 * by a file.  Every line is capped; a longer one is an error, never a
 * silent split.
 */
#ifndef QMC_CLI_LINEBUF_H
#define QMC_CLI_LINEBUF_H

#include <stddef.h>

enum {
    CLI_LINE_OK = 0,
    CLI_LINE_NOMEM = -1,      /* allocation failed */
    CLI_LINE_TOO_LONG = -2,   /* a line past max_bytes (without its '\n') */
    CLI_LINE_NUL = -3         /* a NUL byte: text files carry none */
};

/* Called once per line with the line NUL-terminated, without its '\n';
 * terminated is 0 only for a last line that ends without one.  Return 0
 * to go on, anything else to stop (cli_linebuf_feed returns it). */
typedef int (*cli_line_fn)(void *ctx, char *line, size_t len, int terminated);

typedef struct cli_linebuf {
    char *buf;                /* the partial line; max_bytes + 1 */
    size_t len, max_bytes;
} cli_linebuf;

/* Returns CLI_LINE_OK or CLI_LINE_NOMEM. */
int cli_linebuf_init(cli_linebuf *lb, size_t max_bytes);
void cli_linebuf_close(cli_linebuf *lb);
/* Feeds n bytes; on_line runs for each line they complete.  Returns 0, a
 * CLI_LINE_* error, or on_line's non-zero value. */
int cli_linebuf_feed(cli_linebuf *lb, const char *data, size_t n, cli_line_fn on_line,
                     void *ctx);
/* The end of the stream: a last line without '\n' goes to on_line with
 * terminated 0.  Returns as cli_linebuf_feed. */
int cli_linebuf_end(cli_linebuf *lb, cli_line_fn on_line, void *ctx);

#endif
