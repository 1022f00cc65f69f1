/*
 * command_session.h - the session behind `qmc integrate --command`
 * (private to the CLI): libqmc's in-process qmc_session, or one on a qmcd
 * daemon through libqmcclient's qmc_client_session, behind the same six
 * calls, so that the loop that feeds PROGRAM (integrate_command.c) does
 * not know where the integrator runs.  Both give the same bytes, a
 * part's block sums included.
 */
#ifndef QMC_CLI_COMMAND_SESSION_H
#define QMC_CLI_COMMAND_SESSION_H

#include <stddef.h>

#include "qmc/client.h"
#include "qmc/session.h"

typedef struct cli_cmd_session {
    qmc_session *local;           /* in-process, or */
    qmc_client *client;           /* on the daemon */
    qmc_client_session *remote;
    double *vals;                 /* in-process: room for a batch's values */
    size_t vals_cap;
} cli_cmd_session;

/* Opens it here (endpoint NULL) or on the daemon at endpoint.  0, or
 * CLI_EXIT_FAIL after one error line (the session's or the daemon's
 * refusal, a connection that failed). */
int cli_cmd_session_open(cli_cmd_session *cs, const qmc_session_spec *spec,
                         const char *endpoint);
/* The batch the session waits for (count 0: done) and where its values go
 * (*vals, room for count).  0, or CLI_EXIT_FAIL after one error line
 * ending with so_far (a lost connection). */
int cli_cmd_session_ask(cli_cmd_session *cs, qmc_session_batch *b, double **vals,
                        const char *so_far);
/* Hands in the values of batch seq.  0, or CLI_EXIT_FAIL after one line. */
int cli_cmd_session_tell(cli_cmd_session *cs, uint64_t seq, const double *vals, size_t count);
/* The session's state after the last tell. */
void cli_cmd_session_status(const cli_cmd_session *cs, qmc_session_report *out);
/* The final answer: *ir as qmc_session_result fills it.  0, or
 * CLI_EXIT_FAIL after one error line. */
int cli_cmd_session_result(const cli_cmd_session *cs, qmc_integrate_report *ir);
/* A part session's answer once done (its block sums: here, or as the
 * daemon sent them, the same bytes); valid until close.  0, or
 * CLI_EXIT_FAIL after one error line. */
int cli_cmd_session_part(const cli_cmd_session *cs, qmc_session_part_sums *out);
/* Closes and frees it (on the daemon too), and the connection. */
void cli_cmd_session_close(cli_cmd_session *cs);

#endif
