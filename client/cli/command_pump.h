/*
 * command_pump.h - moves one batch between qmc and the --command child
 * (private to the CLI): the points out through its stdin, the values in
 * from its stdout, interleaved with poll(2) on non-blocking descriptors.
 *
 * A program may answer point by point or only after reading a whole
 * batch (a vectorised numpy program); either way neither side waits on
 * a full pipe, because qmc writes only what the pipe takes and reads
 * whatever has come each time poll wakes it.  Nothing here blocks longer
 * than the timeout: "nothing moved" (no byte written or read) for
 * timeout_ms ends the exchange.
 */
#ifndef QMC_CLI_COMMAND_PUMP_H
#define QMC_CLI_COMMAND_PUMP_H

#include <stddef.h>
#include <stdint.h>

#include "command_codec.h"
#include "command_proc.h"

typedef enum cli_pump_end {
    CLI_PUMP_OK = 0,      /* the batch went out and exactly its values came in */
    CLI_PUMP_BAD,         /* the values were refused: the decoder's status and why */
    CLI_PUMP_EOF,         /* its output ended before the last value (epipe:
                             it had stopped reading too) */
    CLI_PUMP_TIMEOUT,     /* nothing moved for timeout_ms */
    CLI_PUMP_SYS          /* poll, read or write failed: sys_errno */
} cli_pump_end;

typedef struct cli_pump {
    char *out;                /* encoded bytes waiting to be written */
    size_t out_cap, out_off, out_len;
    char *in;                 /* one read's bytes */
    size_t in_cap;
    int epipe;                /* the batch's points met a closed stdin */
    int sys_errno;
} cli_pump;

/* Buffers for points of dims coordinates in format.  0, or -1 (memory). */
int cli_pump_init(cli_pump *p, cli_cmd_format format, uint32_t dims);
void cli_pump_close(cli_pump *p);

/* Sends the batch e was started on and reads d's values (timeout_ms 0:
 * wait for ever). */
cli_pump_end cli_pump_batch(cli_pump *p, cli_child *c, cli_cmd_enc *e, cli_cmd_dec *d,
                            int timeout_ms);

/* After the last batch: closes the child's stdin and reads its stdout to
 * the end.  d, started with count 0, refuses any byte (CLI_PUMP_BAD:
 * values nobody asked for).  CLI_PUMP_OK at the end of its output,
 * CLI_PUMP_TIMEOUT if it is still open after timeout_ms. */
cli_pump_end cli_pump_drain(cli_pump *p, cli_child *c, cli_cmd_dec *d, int timeout_ms);

#endif
