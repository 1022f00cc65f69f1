/*
 * integrate_command.c - `qmc integrate --command 'PROGRAM ARGS'`: the
 * user's own f, evaluated by a program of theirs in any language, driven
 * through an integration session (qmc/session.h): each batch the session
 * asks for goes to PROGRAM's stdin, its values come back from its stdout
 * (command_codec.h says how they are written, command_pump.c moves them,
 * command_proc.c owns the process, command_session.c holds the session,
 * here or on a daemon), and the report is `qmc integrate`'s own, with the
 * command as the integrand's name.
 *
 * Must not: print a result unless PROGRAM answered every point exactly
 * and ended well; fail with more than one line, or without naming what
 * was computed so far; leave PROGRAM running or unreaped.
 */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>

#include "cli.h"
#include "command_codec.h"
#include "command_proc.h"
#include "command_pump.h"
#include "command_session.h"
#include "integrate.h"

/* How long a program whose output has ended gets to exit, so that the
 * message can give its exit status (at most --command-timeout). */
enum { EXIT_GRACE_MS = 2000 };

int cli_smoothness_parse(const char *name, qmc_smoothness *out)
{
    static const struct {
        const char *name;
        qmc_smoothness s;
    } names[] = {{"smooth", QMC_SMOOTH_ANALYTIC},
                 {"kinks", QMC_SMOOTH_CONTINUOUS},
                 {"jumps", QMC_SMOOTH_DISCONTINUOUS},
                 {"singular", QMC_SMOOTH_SINGULAR}};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if (strcmp(name, names[i].name) == 0) {
            *out = names[i].s;
            return 0;
        }
    return -1;
}

/* Nothing in qmc can evaluate a program's f: the declared integrand is
 * for the report and merge, which never call it. */
static void declared_eval(const void *ctx, const double *x, size_t n, uint32_t dims,
                          double *out)
{
    (void)ctx, (void)x, (void)dims;
    for (size_t i = 0; i < n; i++)
        out[i] = NAN;
}

int cli_command_problem(const cli_integrate *o, cli_problem *p)
{
    memset(p, 0, sizeof *p);
    if (o->integrand || o->scene || o->have_a || o->have_u || o->difficulty || o->control ||
        o->strategy)
        return cli_error("--command: the program is the integrand: --integrand, --scene, --a, "
                         "--u, --difficulty, --control and --strategy do not apply"), -1;
    if (!o->have_dims)
        return cli_error("--command needs --dims D: the dimension of the points the program "
                         "gets"), -1;
    qmc_integrand *f = &p->declared;
    f->eval = declared_eval;
    f->dims = o->dims;
    f->smoothness = o->smoothness;
    f->has_exact = o->have_exact;
    f->exact = o->exact;
    f->name = "command";
    p->f = f;
    p->label = o->command;
    if (o->have_exact)
        p->reference = o->exact, p->has_reference = 1, p->reference_exact = 1;
    return 0;
}

/* ---- one run ------------------------------------------------------------------- */

typedef struct cmd_run {
    const cli_integrate *o;
    const char *shown;        /* the command, cut for messages */
    char shown_buf[72];
    int timeout_ms;
    cli_cmd_format format;
    cli_cmd_session cs;
    cli_child child;
    int child_started;
    cli_pump pump;            /* both zeroed until made: closing is safe */
    cli_cmd_dec dec;
} cmd_run;

/* "; so far ..." - what the session had computed when the program failed:
 * the values it took, and its running estimate where the method has one
 * (qmc_session_status: the sampling methods, from whole replicates). */
static void so_far(const cli_cmd_session *cs, char *buf, size_t cap)
{
    qmc_session_report r;
    cli_cmd_session_status(cs, &r);
    if (r.evals == 0) {
        snprintf(buf, cap, "; nothing was computed yet");
        return;
    }
    int n = snprintf(buf, cap, "; so far %llu values in %llu batch%s",
                     (unsigned long long)r.evals, (unsigned long long)r.batches,
                     r.batches == 1 ? "" : "es");
    if (n < 0 || (size_t)n >= cap)
        return;
    if (!r.has_estimate) {
        snprintf(buf + n, cap - (size_t)n, ", no running estimate yet");
        return;
    }
    n += snprintf(buf + n, cap - (size_t)n, ", running estimate %.10g", r.running.estimate);
    if ((size_t)n < cap && r.running.error_kind == QMC_ERROR_STDERR)
        snprintf(buf + n, cap - (size_t)n, " (stderr %.3g)", r.running.error);
    else if ((size_t)n < cap && r.running.error_kind == QMC_ERROR_ESTIMATE)
        snprintf(buf + n, cap - (size_t)n, " (error estimate %.3g)", r.running.error);
}

/* Prints the one line for a failed exchange and returns CLI_EXIT_FAIL. */
static int fail_batch(cmd_run *r, cli_pump_end end, const qmc_session_batch *b,
                      const cli_cmd_enc *e)
{
    char sf[200], how[96];
    so_far(&r->cs, sf, sizeof sf);
    const char *cmd = r->shown;
    unsigned long long seq = (unsigned long long)b->seq;
    size_t got = r->dec.got, count = b->count;
    switch (end) {
    case CLI_PUMP_OK:
        break;
    case CLI_PUMP_BAD:
        if (r->dec.status == CLI_CMD_TOO_MANY)
            return cli_error("--command: '%s' answered more values than the %zu points of "
                             "batch %llu%s", cmd, count, seq, sf);
        return cli_error("--command: '%s' answered batch %llu badly: %s%s", cmd, seq,
                         r->dec.why, sf);
    case CLI_PUMP_EOF:
        cli_child_wait(&r->child, r->timeout_ms > 0 && r->timeout_ms < EXIT_GRACE_MS
                                      ? r->timeout_ms : EXIT_GRACE_MS);
        cli_child_describe(&r->child, how, sizeof how);
        if (r->child.reaped)
            return cli_error("--command: '%s' %s after answering %zu of the %zu points of "
                             "batch %llu%s", cmd, how, got, count, seq, sf);
        return cli_error("--command: '%s' closed its output after answering %zu of the %zu "
                         "points of batch %llu%s", cmd, got, count, seq, sf);
    case CLI_PUMP_TIMEOUT:
        if (r->pump.epipe)
            return cli_error("--command: '%s' stopped reading its input during batch %llu, "
                             "then wrote nothing for %d ms (--command-timeout) with %zu of "
                             "its %zu points answered%s", cmd, seq, r->timeout_ms, got, count,
                             sf);
        if (cli_cmd_enc_done(e))
            return cli_error("--command: '%s' answered %zu of the %zu points of batch %llu, "
                             "then nothing for %d ms (--command-timeout): too few values, "
                             "or it hangs%s", cmd, got, count, seq, r->timeout_ms, sf);
        return cli_error("--command: '%s' read and wrote nothing for %d ms "
                         "(--command-timeout) during batch %llu (%zu of its %zu points "
                         "answered)%s", cmd, r->timeout_ms, seq, got, count, sf);
    case CLI_PUMP_SYS:
        return cli_error("--command: talking to '%s' failed: %s%s", cmd,
                         strerror(r->pump.sys_errno), sf);
    }
    return CLI_EXIT_FAIL;
}

/* After the last batch: nothing more from the program, and a clean end. */
static int finish_child(cmd_run *r)
{
    cli_cmd_dec_start(&r->dec, NULL, 0);
    cli_pump_end end = cli_pump_drain(&r->pump, &r->child, &r->dec, r->timeout_ms);
    char sf[200], how[96];
    if (end == CLI_PUMP_BAD) {
        so_far(&r->cs, sf, sizeof sf);
        return cli_error("--command: '%s' wrote more after its last answer: more values "
                         "than points%s", r->shown, sf);
    }
    if (end == CLI_PUMP_SYS) {
        so_far(&r->cs, sf, sizeof sf);
        return cli_error("--command: talking to '%s' failed: %s%s", r->shown,
                         strerror(r->pump.sys_errno), sf);
    }
    /* Its output ended (or stayed open, silent, past the timeout: every
     * value is in, so it is only stopped).  A program that reads to the
     * end of its input exits now; one that fails on its way out says
     * something went wrong that its values may share. */
    if (end == CLI_PUMP_OK)
        cli_child_wait(&r->child, r->timeout_ms > 0 ? r->timeout_ms : INT32_MAX);
    if (r->child.reaped &&
        !(WIFEXITED(r->child.status) && WEXITSTATUS(r->child.status) == 0)) {
        cli_child_describe(&r->child, how, sizeof how);
        so_far(&r->cs, sf, sizeof sf);
        return cli_error("--command: '%s' %s after answering every point: no result "
                         "printed%s", r->shown, how, sf);
    }
    return 0;
}

static int open_session(cmd_run *r, const cli_problem *p, const char *endpoint)
{
    const cli_integrate *o = r->o;
    qmc_session_spec ss;
    qmc_session_spec_init(&ss);
    ss.dims = o->dims;
    ss.smoothness = p->f->smoothness;
    ss.has_exact = p->f->has_exact;
    ss.exact = p->f->exact;
    strcpy(ss.name, "command");
    if (cli_integrate_spec(o, &ss.integrate))
        return CLI_EXIT_FAIL;
    ss.part_k = o->part_k;
    ss.part_p = o->part_p;
    return cli_cmd_session_open(&r->cs, &ss, endpoint);
}

/* Asks, sends, reads and tells until the session is done. */
static int run_batches(cmd_run *r)
{
    for (;;) {
        qmc_session_batch b;
        double *vals;
        char sf[200];
        so_far(&r->cs, sf, sizeof sf);
        if (cli_cmd_session_ask(&r->cs, &b, &vals, sf))
            return CLI_EXIT_FAIL;
        if (b.count == 0)
            return 0;
        cli_cmd_enc e;
        cli_cmd_enc_start(&e, r->format, b.points, b.count, b.dims);
        cli_cmd_dec_start(&r->dec, vals, b.count);
        cli_pump_end end = cli_pump_batch(&r->pump, &r->child, &e, &r->dec, r->timeout_ms);
        if (end != CLI_PUMP_OK)
            return fail_batch(r, end, &b, &e);
        if (cli_cmd_session_tell(&r->cs, b.seq, vals, b.count))
            return CLI_EXIT_FAIL;
    }
}

/* The session's answer: the report, or the part file. */
static int print_answer(cmd_run *r, const cli_problem *p, double seconds)
{
    const cli_integrate *o = r->o;
    if (o->part_p) { /* here or on the daemon: the same sums */
        qmc_session_part_sums ps;
        if (cli_cmd_session_part(&r->cs, &ps))
            return CLI_EXIT_FAIL;
        if (cli_partial_write_sums(stdout, o, ps.fingerprint, ps.blocks, ps.sums, ps.first,
                                   ps.count, seconds))
            return CLI_EXIT_FAIL;
        return 0;
    }
    qmc_integrate_report ir;
    if (cli_cmd_session_result(&r->cs, &ir))
        return CLI_EXIT_FAIL;
    cli_report rep;
    memset(&rep, 0, sizeof rep);
    rep.requested = o->method;
    rep.problem = p;
    rep.confidence = o->spec.confidence;
    rep.seconds = seconds;
    rep.res = ir.res;
    rep.cv = ir.cv;
    rep.method = qmc_method_name(ir.method_used);
    cli_copy_text(rep.detail, sizeof rep.detail, ir.detail);
    cli_copy_text(rep.auto_reason, sizeof rep.auto_reason, ir.auto_reason);
    cli_report_print(stdout, &rep, o->json);
    return 0;
}

int cli_integrate_command(const cli_integrate *o, const cli_problem *p, const char *endpoint)
{
    if (o->threads > 1)
        return cli_error("--threads runs built-in integrands on several threads; a "
                         "--command's program is one process (drop --threads)");
    cmd_run r;
    memset(&r, 0, sizeof r);
    r.o = o;
    r.timeout_ms = (int)o->command_timeout_ms;
    if (o->command_format && cli_cmd_format_parse(o->command_format, &r.format) != 0)
        return cli_error("--command-format: want text or f64");
    snprintf(r.shown_buf, sizeof r.shown_buf, "%.60s%s", o->command,
             strlen(o->command) > 60 ? "..." : "");
    r.shown = r.shown_buf;
    double t0 = cli_now_seconds();
    int rc = open_session(&r, p, endpoint);
    char why[256] = "";
    if (rc == 0 && (cli_pump_init(&r.pump, r.format, o->dims) != 0 ||
                    cli_cmd_dec_init(&r.dec, r.format) != 0))
        rc = cli_error("out of memory");
    if (rc == 0 && cli_child_start(&r.child, o->command, why, sizeof why) != 0)
        rc = cli_error("--command: %s", why);
    else if (rc == 0)
        r.child_started = 1;
    if (rc == 0)
        rc = run_batches(&r);
    if (rc == 0)
        rc = finish_child(&r);
    if (r.child_started)
        cli_child_stop(&r.child);
    double seconds = cli_now_seconds() - t0;
    if (rc == 0)
        rc = print_answer(&r, p, seconds);
    cli_cmd_dec_close(&r.dec);
    cli_pump_close(&r.pump);
    cli_cmd_session_close(&r.cs);
    return rc;
}
