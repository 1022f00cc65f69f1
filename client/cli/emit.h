/*
 * emit.h - writing a command's binary answer (private to the CLI): the
 * byte order, where it goes (--out FILE or stdout) and the sink a remote
 * stream's chunks are written through.  `qmc points` and `qmc pixels`
 * share these; what the bytes are is each command's business.
 */
#ifndef QMC_CLI_EMIT_H
#define QMC_CLI_EMIT_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "qmc/client.h"

/* Puts n_values values of value_bytes each in little-endian order (the
 * output's on every host): a swap on a big-endian host, else nothing. */
void cli_to_little_endian(void *buf, size_t n_values, size_t value_bytes);

/* Writes the whole answer to f: 0, or CLI_EXIT_FAIL after its error line. */
typedef int cli_emit_fn(void *ctx, FILE *f);

/*
 * Runs emit into --out path by outfile.h's rules (nothing is replaced
 * unless emit returns 0), or, with path NULL, into stdout and flushes it
 * ("writing WHAT: <reason>" when that fails).  Returns emit's code, or
 * CLI_EXIT_FAIL after one error line.
 */
int cli_emit_out(const char *path, const char *what, cli_emit_fn *emit, void *ctx);

/* A remote stream's destination for chunks written as they come: the
 * wire carries exactly the little-endian bytes the output holds. */
typedef struct cli_raw_sink {
    FILE *f;
    const char *what;             /* for the error line: "points" */
    int failed;                   /* a write failed and said so */
} cli_raw_sink;

/* A qmc_client_chunk_fn for a cli_raw_sink: writes data; -1 after an
 * error line (the stream then stops). */
int cli_raw_chunk(void *ctx, uint64_t first, uint32_t points, const void *data, size_t bytes);

/* What a stream into a sink comes to: 0 when err is 0, else
 * CLI_EXIT_FAIL, after the client's message unless the sink failed and
 * said why already. */
int cli_stream_done(const qmc_client *c, int err, int sink_failed);

#endif
