/*
 * integrate_run.c - runs `qmc integrate` through the library's
 * qmc_integrate, on --threads threads, and times it; or, with --connect,
 * sends the same job (cli_job_spec + cli_integrate_spec) to the daemon.
 */
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "integrate.h"
#include "runner_threads.h"

int cli_integrate_spec(const cli_integrate *o, qmc_integrate_spec *s)
{
    qmc_integrate_spec_init(s);
    if (qmc_method_parse(o->method, &s->method) != 0)
        return cli_error("--method: unknown method '%s' (auto, mc, stratified, lhs, qmc, rqmc, "
                         "midpoint, trapezoid, simpson, gauss-legendre, gauss-kronrod, cubature)",
                         o->method), -1;
    s->sampling = o->spec;
    s->n_given = o->have_n;
    if (o->have_n && o->spec.n > UINT32_MAX)
        return cli_error("--n: %llu is too many points per axis",
                         (unsigned long long)o->spec.n), -1;
    s->n_axis = o->have_n ? (uint32_t)o->spec.n : 0;
    s->tol_abs = o->tol_abs;
    s->tol_rel = o->tol_rel;
    s->max_evals = o->max_evals;
    s->max_memory = o->max_memory;
    return 0;
}

static void report_init(const cli_integrate *o, const cli_problem *p, cli_report *rep)
{
    memset(rep, 0, sizeof *rep);
    qmc_result_init(&rep->res);
    rep->requested = o->method;
    rep->problem = p;
    rep->confidence = o->spec.confidence;
}

int cli_integrate_run(const cli_integrate *o, const cli_problem *p, cli_report *rep)
{
    report_init(o, p, rep);
    qmc_integrate_spec s;
    if (cli_integrate_spec(o, &s))
        return CLI_EXIT_FAIL;
    cli_threads t = {o->threads};
    qmc_integrate_report r;
    char why[256] = "";
    double t0 = cli_now_seconds();
    int err = qmc_integrate(&s, p->f, p->g, cli_run_blocks_threaded, &t, &r, why, sizeof why);
    rep->seconds = cli_now_seconds() - t0;
    if (err)
        return cli_error("%s", why[0] ? why : qmc_strerror(err));
    rep->res = r.res;
    rep->cv = r.cv;
    rep->method = qmc_method_name(r.method_used);
    cli_copy_text(rep->detail, sizeof rep->detail, r.detail);
    cli_copy_text(rep->auto_reason, sizeof rep->auto_reason, r.auto_reason);
    return 0;
}


int cli_integrate_remote(const cli_integrate *o, const cli_problem *p, const char *endpoint,
                         cli_report *rep)
{
    report_init(o, p, rep);
    qmc_job_spec job;
    char *scene_text = NULL;
    if (cli_job_spec(o, &job, &scene_text))
        return CLI_EXIT_FAIL;
    int rc = cli_integrate_spec(o, &job.integrate) ? CLI_EXIT_FAIL : 0;
    qmc_client *c = NULL;
    if (rc == 0)
        rc = cli_remote_connect(endpoint, &c);
    if (rc == 0) {
        qmc_client_result *r = malloc(sizeof *r);
        int err = r ? qmc_client_integrate(c, &job, r) : QMC_ENOMEM;
        if (!r) {
            rc = cli_error("out of memory");
        } else if (err) {
            rc = cli_remote_fail(c, err, "");
        } else {
            rep->res = r->res;
            rep->cv = r->cv;
            rep->method = qmc_method_name(r->method_used);
            rep->seconds = r->seconds;
            /* The daemon's word on the integral of |f| (version 6); an
             * older daemon's answer leaves it to the problem built here. */
            rep->known_abs_told = r->has_known_abs >= 0;
            rep->has_known_abs = r->has_known_abs > 0;
            rep->known_abs = r->known_abs;
            cli_copy_text(rep->detail, sizeof rep->detail, r->detail);
            cli_copy_text(rep->auto_reason, sizeof rep->auto_reason, r->auto_reason);
        }
        free(r);
    }
    qmc_client_close(c);
    free(scene_text);
    return rc;
}
