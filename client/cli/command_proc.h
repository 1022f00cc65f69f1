/*
 * command_proc.h - the PROGRAM of `qmc integrate --command` as a child
 * process (private to the CLI): started, fed, stopped and reaped.
 *
 * The command runs as `/bin/sh -c COMMAND` in a process group of its own,
 * with its stdin and stdout on pipes to us and its stderr ours (so what
 * it says passes through).  Our ends are non-blocking; command_pump.c
 * moves the bytes.  While a child runs:
 *   - SIGPIPE is ignored here, so that a program that exits early gives
 *     EPIPE on a write, never kills qmc; the child gets back the
 *     disposition qmc started with.
 *   - SIGINT, SIGTERM, SIGHUP and SIGQUIT kill the child's process group
 *     and reap it (kill and waitpid are async-signal-safe), then go on to
 *     the handler that was there before (outfile.c's) or the default
 *     action, so qmc still dies of the signal and leaves no child behind.
 * cli_child_stop kills and reaps on every other path.  One child at a
 * time (the handler's state is one static slot).
 */
#ifndef QMC_CLI_COMMAND_PROC_H
#define QMC_CLI_COMMAND_PROC_H

#include <stddef.h>
#include <sys/types.h>

typedef struct cli_child {
    pid_t pid;                /* 0 when none */
    int to_fd, from_fd;       /* its stdin (we write), its stdout (we read);
                                 -1 once closed */
    int reaped;               /* 1 once waited for: status holds its end */
    int status;               /* the wait status */
    int killed;               /* 1 when we killed it */
} cli_child;

/* Starts `/bin/sh -c command`.  Returns 0, or -1 with why set (pipe, fork). */
int cli_child_start(cli_child *c, const char *command, char *why, size_t why_bytes);
/* Closes its stdin: a program reading to the end of its input then ends. */
void cli_child_close_input(cli_child *c);
/* Waits for it to exit by itself, at most timeout_ms (0: no wait, just a
 * look).  Returns 1 once it has been reaped, else 0. */
int cli_child_wait(cli_child *c, int timeout_ms);
/* Kills its process group (SIGKILL) unless it has been reaped, reaps it,
 * closes our ends and restores the signal dispositions.  Idempotent. */
void cli_child_stop(cli_child *c);
/* How it ended, for a message: "exited with status 3", "was killed by
 * signal 11 (Segmentation fault)", or "is still running". */
void cli_child_describe(const cli_child *c, char *buf, size_t cap);

#endif
