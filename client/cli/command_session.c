/*
 * command_session.c - --command's session, in-process or on the daemon
 * (see command_session.h).  Must not: print more than one line for an
 * error, or reach past include/qmc/session.h and include/qmc/client.h.
 */
#include "command_session.h"

#include <stdlib.h>
#include <string.h>

#include "cli.h"

int cli_cmd_session_open(cli_cmd_session *cs, const qmc_session_spec *spec,
                         const char *endpoint)
{
    memset(cs, 0, sizeof *cs);
    if (!endpoint) {
        char why[256] = "";
        int err = qmc_session_new(spec, &cs->local, why, sizeof why);
        if (err)
            return cli_error("%s", why[0] ? why : qmc_strerror(err));
        return 0;
    }
    int rc = cli_remote_connect(endpoint, &cs->client);
    if (rc)
        return rc;
    int err = qmc_client_session_open(cs->client, spec, &cs->remote);
    if (err)
        return cli_remote_fail(cs->client, err, "");
    return 0;
}

int cli_cmd_session_ask(cli_cmd_session *cs, qmc_session_batch *b, double **vals,
                        const char *so_far)
{
    if (cs->local) {
        if (qmc_session_ask(cs->local, b) != 0)
            return cli_error("--command: the session handed out no batch%s", so_far);
        if (b->count > cs->vals_cap) {
            double *v = realloc(cs->vals, b->count * sizeof *v);
            if (!v)
                return cli_error("out of memory for a batch of %zu values", b->count);
            cs->vals = v;
            cs->vals_cap = b->count;
        }
        *vals = cs->vals;
        return 0;
    }
    int err = qmc_client_session_next(cs->remote, b);
    if (err) {
        const char *msg = qmc_client_last_error(cs->client);
        return cli_error("--command: the daemon: %s%s", msg[0] ? msg : qmc_strerror(err),
                         so_far);
    }
    /* The values go where the client sends them from (the ring slot of
     * the batch, on a unix: endpoint): nothing is copied. */
    *vals = b->count ? qmc_client_session_values(cs->remote) : NULL;
    if (b->count && !*vals)
        return cli_error("--command: the client library gave no room for the values");
    return 0;
}

int cli_cmd_session_tell(cli_cmd_session *cs, uint64_t seq, const double *vals, size_t count)
{
    if (cs->local) {
        char why[256] = "";
        if (qmc_session_tell(cs->local, seq, vals, count, why, sizeof why) != 0)
            return cli_error("--command: %s", why);
        return 0;
    }
    int err = qmc_client_session_tell(cs->remote, seq, vals, count);
    if (err)
        return cli_remote_fail(cs->client, err, "--command: the daemon: ");
    return 0;
}

void cli_cmd_session_status(const cli_cmd_session *cs, qmc_session_report *out)
{
    if (cs->local)
        qmc_session_status(cs->local, out);
    else if (cs->remote)
        qmc_client_session_report(cs->remote, out);
    else
        memset(out, 0, sizeof *out);
}

int cli_cmd_session_result(const cli_cmd_session *cs, qmc_integrate_report *ir)
{
    memset(ir, 0, sizeof *ir);
    if (cs->local) {
        char why[256] = "";
        int err = qmc_session_result(cs->local, ir, why, sizeof why);
        if (err)
            return cli_error("%s", why[0] ? why : qmc_strerror(err));
        return 0;
    }
    qmc_client_result *r = malloc(sizeof *r);
    if (!r)
        return cli_error("out of memory");
    int err = qmc_client_session_result(cs->remote, r);
    int rc = 0;
    if (err) {
        rc = cli_remote_fail(cs->client, err, "");
    } else {
        ir->res = r->res;
        ir->cv = r->cv;
        ir->method_used = r->method_used;
        cli_copy_text(ir->detail, sizeof ir->detail, r->detail);
        cli_copy_text(ir->auto_reason, sizeof ir->auto_reason, r->auto_reason);
    }
    free(r);
    return rc;
}

int cli_cmd_session_part(const cli_cmd_session *cs, qmc_session_part_sums *out)
{
    int err = cs->local ? qmc_session_part(cs->local, out)
                        : qmc_client_session_part(cs->remote, out);
    if (err == 0)
        return 0;
    if (cs->local)
        return cli_error("--part: %s", qmc_strerror(err));
    return cli_remote_fail(cs->client, err, "--part: the daemon: ");
}

void cli_cmd_session_close(cli_cmd_session *cs)
{
    qmc_session_free(cs->local);
    /* The daemon's copy ends with it: a failed run leaves nothing parked. */
    (void)qmc_client_session_close(cs->remote);
    qmc_client_close(cs->client);
    free(cs->vals);
    memset(cs, 0, sizeof *cs);
}
