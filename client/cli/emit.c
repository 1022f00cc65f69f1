/*
 * emit.c - writing a command's binary answer (emit.h): byte order, --out
 * or stdout, and the raw sink of remote streams.
 *
 * Must not: make the bytes (the commands do) or decide what an output file
 * may replace (outfile.c does).
 */
#include <errno.h>
#include <string.h>

#include "cli.h"
#include "emit.h"
#include "outfile.h"

void cli_to_little_endian(void *buf, size_t n_values, size_t value_bytes)
{
    const uint16_t probe = 1;
    if (*(const uint8_t *)&probe == 1)
        return;
    uint8_t *b = buf;
    for (size_t i = 0; i < n_values; i++, b += value_bytes)
        for (size_t k = 0; k < value_bytes / 2; k++) {
            uint8_t t = b[k];
            b[k] = b[value_bytes - 1 - k];
            b[value_bytes - 1 - k] = t;
        }
}

int cli_emit_out(const char *path, const char *what, cli_emit_fn *emit, void *ctx)
{
    if (path) {
        cli_outfile of;
        if (cli_outfile_open(&of, path, "--out") != 0)
            return CLI_EXIT_FAIL;
        int rc = emit(ctx, of.f);
        if (rc == 0)
            return cli_outfile_commit(&of);
        cli_outfile_abort(&of);
        return rc;
    }
    int rc = emit(ctx, stdout);
    if (fflush(stdout) != 0 && rc == 0)
        rc = cli_error("writing %s: %s", what, strerror(errno));
    return rc;
}

int cli_raw_chunk(void *ctx, uint64_t first, uint32_t points, const void *data, size_t bytes)
{
    cli_raw_sink *k = ctx;
    (void)first, (void)points;
    if (cli_write_all(k->f, data, bytes, k->what))
        return k->failed = -1;
    return 0;
}

int cli_stream_done(const qmc_client *c, int err, int sink_failed)
{
    if (err && !sink_failed)
        return cli_remote_fail(c, err, "");
    return err ? CLI_EXIT_FAIL : 0;
}
