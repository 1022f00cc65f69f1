/*
 * cmd_compare.c - `qmc compare`: runs each method over a ladder of
 * evaluation budgets (R seeds for the randomized ones) on the user's own
 * integrand or scene, measures the actual error against a reference and
 * the wall time, and writes a CSV, charts and a report (compare_report.c).
 *
 * Everything that can be wrong with the request (names, lists, the
 * reference, the daemon) is checked before DIR is touched, and DIR is
 * written all at once (outdir.c): bad input leaves nothing half-written.
 */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "compare.h"
#include "integrate.h"
#include "outdir.h"
#include "runner_threads.h"
#include "qmc/job.h"
#include "qmc/scene.h"

static const char compare_help[] =
    "usage: qmc compare (--integrand NAME --dims D [--a LIST] [--u LIST] |\n"
    "                    --scene FILE [--strategy S] [--beta B])\n"
    "                   [--methods LIST] [--budgets 1e3:1e7[:K]] [--reps R]\n"
    "                   [--threads T] [--seed X] [--reference exact|auto|VALUE]\n"
    "                   [--connect ENDPOINT] --out DIR\n"
    "\n"
    "Speed against accuracy on your own job.  Runs each method at every budget\n"
    "of the ladder (R seeds for the randomized methods, one run for the\n"
    "deterministic rules), measures the actual error against the reference and\n"
    "the wall time, and writes into DIR (all files or none):\n"
    "\n"
    "  compare.csv          method,budget,rep,estimate,reported_error,\n"
    "                       actual_error,seconds,evals,flags (+ error_kind,\n"
    "                       class: OK/FLAGGED/REFUSED/SILENT as qmc stability)\n"
    "  error-time.png/.svg  median error against median time, the Pareto\n"
    "                       front marked\n"
    "  error-evals.png/.svg error against evaluations, fitted slopes in the\n"
    "                       legend\n"
    "  honesty.png/.svg     reported against actual error, every run\n"
    "  REPORT.md            which method reaches a given error fastest at each\n"
    "                       time budget, and how honest each method's bars were\n"
    "\n"
    "  --methods LIST   comma-separated METHOD[/SEQ[/SCRAMBLE]] (qmc and rqmc take\n"
    "                   a sequence and scramble, e.g. rqmc/halton/owen); default\n"
    "                   mc, rqmc/sobol/owen, cubature, auto, and gauss-legendre up\n"
    "                   to 3 dims, gauss-kronrod in 1D (scenes: mc, rqmc, auto)\n"
    "  --budgets A:B[:K] evaluation budgets from A to B, K a decade (default\n"
    "                   1e3:1e7:1); or one number.  Sampling methods take n =\n"
    "                   budget (rqmc: 16 replicates of budget/16), tensor rules\n"
    "                   the largest grid that fits, adaptive methods (cubature,\n"
    "                   clenshaw-curtis, gauss-kronrod, auto) the budget as\n"
    "                   their cap with a tolerance they cannot reach\n"
    "  --reps R         seeds per randomized method and budget (default 5)\n"
    "  --threads T      in-process worker threads (same numbers)\n"
    "  --seed X         first seed (default 1)\n"
    "  --reference R    exact (fail without a closed form), auto (default: the\n"
    "                   closed form, else the scene quadrature, else a 4M-point\n"
    "                   rqmc run, with its own error shown), or a VALUE\n"
    "  --strategy, --beta  scene sampling, as in qmc integrate\n"
    "  --connect EP     run every job on the qmcd daemon at EP (seconds are\n"
    "                   then each job's round trip: transport and queueing too)\n"
    "\n"
    "A progress line is written to stderr while it runs.\n";

typedef struct cmp_opts {
    cli_integrate job;          /* what to integrate (integrand or scene) */
    const char *methods, *budgets, *reference, *out;
    uint32_t reps;
    unsigned threads;
    int have_threads;
    uint64_t seed;
} cmp_opts;

static int parse(int argc, char **argv, cmp_opts *o)
{
    static const struct option longopts[] = {
        {"integrand", required_argument, 0, 0}, {"scene", required_argument, 0, 0},
        {"dims", required_argument, 0, 0},      {"a", required_argument, 0, 0},
        {"u", required_argument, 0, 0},         {"strategy", required_argument, 0, 0},
        {"beta", required_argument, 0, 0},      {"methods", required_argument, 0, 0},
        {"budgets", required_argument, 0, 0},   {"reps", required_argument, 0, 0},
        {"threads", required_argument, 0, 0},   {"seed", required_argument, 0, 0},
        {"reference", required_argument, 0, 0}, {"out", required_argument, 0, 0},
        {"help", no_argument, 0, 0},            {0, 0, 0, 0},
    };
    memset(o, 0, sizeof *o);
    cli_job_options_init(&o->job);
    o->reps = 5;
    o->threads = 1;
    o->seed = 1;
    o->budgets = "1e3:1e7";
    o->reference = "auto";
    int first = 1, more;
    const char *name, *arg;
    uint64_t v;
    while ((more = cli_next_option("compare", argc, argv, longopts, &first, &name, &arg)) > 0) {
        int job = cli_job_option(&o->job, name, arg);
        if (job < 0)
            return -1;
        if (job > 0)
            continue;
        if (strcmp(name, "help") == 0) {
            fputs(compare_help, stdout);
            fputs(cli_remote_help, stdout);
            return 1;
        } else if (strcmp(name, "methods") == 0) {
            o->methods = arg;
        } else if (strcmp(name, "budgets") == 0) {
            o->budgets = arg;
        } else if (strcmp(name, "reps") == 0) {
            if (cli_parse_u64("--reps", arg, 1, 1000, &v))
                return -1;
            o->reps = (uint32_t)v;
        } else if (strcmp(name, "threads") == 0) {
            if (cli_parse_u64("--threads", arg, 1, 1024, &v))
                return -1;
            o->threads = (unsigned)v, o->have_threads = 1;
        } else if (strcmp(name, "seed") == 0) {
            if (cli_parse_u64("--seed", arg, 0, UINT64_MAX, &o->seed))
                return -1;
        } else if (strcmp(name, "reference") == 0) {
            o->reference = arg;
        } else if (strcmp(name, "out") == 0) {
            o->out = arg;
        }
    }
    if (more < 0)
        return -1;
    if (!o->out)
        return cli_error("compare: --out DIR is required (it receives compare.csv, "
                         "REPORT.md and the charts)"), -1;
    if (!o->job.integrand && !o->job.scene)
        return cli_error("compare: name an --integrand (with --dims) or a --scene"), -1;
    if (o->job.integrand && o->job.scene)
        return cli_error("compare: give either --integrand or --scene, not both"), -1;
    if (o->job.integrand && !o->job.have_dims)
        return cli_error("compare: --dims D is required with --integrand"), -1;
    return 0;
}

/* "1e3:1e7[:K]" or one number -> budgets. */
static int parse_budgets(const char *text, cli_cmp *c)
{
    char buf[128];
    if (strlen(text) >= sizeof buf)
        return cli_error("--budgets: '%.40s...' is too long", text), -1;
    strcpy(buf, text);
    char *parts[3] = {buf, NULL, NULL};
    int n = 1;
    for (char *p = buf; *p; p++)
        if (*p == ':') {
            if (n == 3)
                return cli_error("--budgets: want A:B[:K], not '%s'", text), -1;
            *p = '\0';
            parts[n++] = p + 1;
        }
    double lo, hi = 0, k = 1;
    if (cli_parse_double("--budgets", parts[0], &lo) ||
        (n > 1 && cli_parse_double("--budgets", parts[1], &hi)) ||
        (n > 2 && cli_parse_double("--budgets", parts[2], &k)))
        return -1;
    if (n == 1)
        hi = lo;
    if (!(lo >= 1 && hi >= lo && hi <= 1e10))
        return cli_error("--budgets: want 1 <= A <= B <= 1e10 evaluations, not '%s'", text), -1;
    if (!(k >= 1 && k <= 10 && k == floor(k)))
        return cli_error("--budgets: K (budgets a decade) must be a whole number 1..10"), -1;
    c->n_budgets = 0;
    for (int i = 0;; i++) {
        double b = floor(lo * pow(10.0, i / k) + 0.5);
        if (b > hi * (1 + 1e-9))
            break;
        if (c->n_budgets == CLI_CMP_MAX_BUDGETS)
            return cli_error("--budgets: more than %d budgets", CLI_CMP_MAX_BUDGETS), -1;
        c->budgets[c->n_budgets++] = (uint64_t)b;
    }
    return 0;
}

static int parse_methods(const char *list, cli_cmp *c)
{
    c->n_methods = 0;
    const char *p = list, *it;
    size_t len;
    while (cli_list_next(&p, &it, &len)) {
        char item[64], why[256];
        if (cli_list_copy(it, len, item, sizeof item))
            return cli_error("--methods: bad list '%s'", list), -1;
        if (c->n_methods == CLI_CMP_MAX_METHODS)
            return cli_error("--methods: more than %d methods", CLI_CMP_MAX_METHODS), -1;
        if (cli_method_parse(item, &c->methods[c->n_methods], why, sizeof why) != 0)
            return cli_error("--methods: %s", why), -1;
        for (uint32_t i = 0; i < c->n_methods; i++)
            if (strcmp(c->methods[i].name, c->methods[c->n_methods].name) == 0)
                return cli_error("--methods: %s is listed twice", c->methods[i].name), -1;
        c->n_methods++;
    }
    return c->n_methods ? 0 : (cli_error("--methods: empty list"), -1);
}

static const char *default_methods(const cli_problem *p)
{
    if (p->is_scene)
        return "mc,rqmc/sobol/owen,auto";
    if (p->f->dims == 1)
        return "mc,rqmc/sobol/owen,gauss-legendre,gauss-kronrod,auto";
    if (p->f->dims <= 3)
        return "mc,rqmc/sobol/owen,gauss-legendre,cubature,auto";
    return "mc,rqmc/sobol/owen,cubature,auto";
}

/* The reference: exact, auto or a value (before anything is written). */
static int make_reference(const cmp_opts *o, cli_problem *p, const char *scene_text,
                          cli_cmp *c)
{
    qmc_stab_truth *t = &c->truth;
    memset(t, 0, sizeof *t);
    t->defined = 1;
    t->scale = p->f->has_abs_integral ? p->f->abs_integral : 0;
    if (strcmp(o->reference, "exact") != 0 && strcmp(o->reference, "auto") != 0) {
        char *end;
        errno = 0;
        t->value = strtod(o->reference, &end);
        if (end == o->reference || *end || errno || !isfinite(t->value))
            return cli_error("--reference: want exact, auto or a finite number, not '%s'",
                             o->reference), -1;
        c->ref_source = "given (--reference)";
        return 0;
    }
    if (p->has_reference && p->reference_exact) {
        t->value = p->reference;
        c->ref_source = "exact (closed form)";
        return 0;
    }
    if (strcmp(o->reference, "exact") == 0)
        return cli_error("--reference exact: %s has no closed form (use --reference auto or "
                         "a value)", p->label), -1;
    if (p->is_scene) {
        qmc_scene sc;
        int exact;
        if (qmc_scene_parse(scene_text, strlen(scene_text), &sc, NULL, 0) != 0 ||
            qmc_scene_reference(&sc, &t->value, &t->abs_error, &exact) != 0)
            return cli_error("compare: the scene's reference quadrature failed (give "
                             "--reference VALUE)"), -1;
        t->scale = t->value;
        c->ref_source = exact ? "exact (scene closed form)" : "scene reference quadrature";
        return 0;
    }
    /* A high-accuracy run of a method that need not be among those
     * compared: 32 owen-scrambled Sobol nets of 2^17 points; its 3-sigma
     * error is carried as the reference's own error. */
    cli_method m;
    char why[256];
    if (cli_method_parse("rqmc/sobol/owen", &m, why, sizeof why) != 0)
        return cli_error("%s", why), -1;
    cli_budget b = {.evals = 32u << 17, .dims = p->f->dims, .reps = 32, .seed = 987654321};
    qmc_integrate_spec s;
    cli_method_spec(&m, &b, &s);
    qmc_integrate_report r;
    cli_threads th = {o->threads};
    if (qmc_job_run(p->job, &s, cli_run_blocks_threaded, &th, &r, why, sizeof why) != 0)
        return cli_error("compare: the reference run failed: %s", why), -1;
    if (r.res.flags || !isfinite(r.res.error))
        return cli_error("compare: the reference run is not trustworthy (flags 0x%x); give "
                         "--reference VALUE", r.res.flags), -1;
    t->value = r.res.estimate;
    t->abs_error = 3 * r.res.error;
    c->ref_source = "rqmc/sobol/owen, 32 x 2^17 points (3 sigma shown as its error)";
    return 0;
}

/* Runs one (method, budget, rep) in-process or remotely. */
static int run_one(const cmp_opts *o, const cli_problem *p, qmc_job_spec *remote_spec,
                    qmc_client *client, const cli_cmp *c, cli_cmp_run *run)
{
    const cli_method *m = &c->methods[run->method];
    cli_budget b = {.evals = run->budget, .dims = p->f->dims, .seed = o->seed + run->rep,
                    .exhaust = 1, .pow2 = 1};
    qmc_integrate_spec s;
    cli_method_spec(m, &b, &s);
    char why[256] = "";
    int err;
    if (client) {
        remote_spec->integrate = s;
        /* The wall time the user waits for, transport and queueing
         * included: the daemon's own compute time rounds tiny jobs to 0. */
        qmc_client_result *r = malloc(sizeof *r);
        double t0 = cli_now_seconds();
        err = r ? qmc_client_integrate(client, remote_spec, r) : QMC_ENOMEM;
        run->seconds = cli_now_seconds() - t0;
        if (r && err == 0) {
            run->res = r->res;
        } else {
            snprintf(why, sizeof why, "%s", qmc_client_last_error(client));
        }
        free(r);
    } else {
        qmc_integrate_report rep;
        cli_threads th = {o->threads};
        double t0 = cli_now_seconds();
        err = qmc_job_run(p->job, &s, cli_run_blocks_threaded, &th, &rep, why, sizeof why);
        run->seconds = cli_now_seconds() - t0;
        run->res = rep.res;
    }
    run->refused = err != 0;
    if (err)
        snprintf(run->reason, sizeof run->reason, "%s", why[0] ? why : qmc_strerror(err));
    run->v = qmc_stab_classify(run->refused, &run->res, &c->truth);
    return err;
}

static int run_all(const cmp_opts *o, const cli_problem *p, qmc_job_spec *remote_spec,
                   qmc_client *client, cli_cmp *c)
{
    size_t total = 0;
    for (uint32_t i = 0; i < c->n_methods; i++)
        total += (size_t)c->n_budgets * (c->methods[i].randomized ? c->reps : 1);
    c->runs = calloc(total, sizeof *c->runs);
    if (!c->runs)
        return cli_error("out of memory"), -1;
    for (uint32_t i = 0; i < c->n_methods; i++)
        for (uint32_t k = 0; k < c->n_budgets; k++)
            for (uint32_t r = 0; r < (c->methods[i].randomized ? c->reps : 1); r++) {
                cli_cmp_run *run = &c->runs[c->n_runs++];
                run->method = i, run->budget_index = k, run->rep = r;
                run->budget = c->budgets[k];
                fprintf(stderr, "\rqmc compare: run %zu/%zu  %-20s budget %-8.3g rep %u   ",
                        c->n_runs, total, c->methods[i].name, (double)run->budget, r + 1);
                fflush(stderr);
                int err = run_one(o, p, remote_spec, client, c, run);
                /* A lost connection (a system error, or bytes that are not
                 * the protocol) ends the comparison: every later run would
                 * fail the same way.  A job the daemon refuses is a row. */
                if (client && err && (err > -1000 || err == QMC_EPROTO)) {
                    fputc('\n', stderr);
                    return cli_error("compare: the daemon went away: %s", run->reason), -1;
                }
            }
    fprintf(stderr, "\rqmc compare: %zu runs done%40s\n", c->n_runs, "");
    return 0;
}

int cli_cmd_compare(int argc, char **argv)
{
    const char *endpoint;
    if (cli_remote_take(&argc, argv, &endpoint))
        return CLI_EXIT_FAIL;
    cmp_opts o;
    int r = parse(argc, argv, &o);
    if (r != 0)
        return r > 0 ? CLI_EXIT_OK : CLI_EXIT_FAIL;
    if (endpoint && o.have_threads)
        return cli_remote_in_process_only("--threads", "each job");
    cli_cmp *c = calloc(1, sizeof *c);
    if (!c)
        return cli_error("out of memory");
    cli_problem p;
    memset(&p, 0, sizeof p);
    qmc_job_spec remote_spec;
    char *scene_text = NULL;
    qmc_client *client = NULL;
    cli_outdir od;
    int rc = CLI_EXIT_FAIL, have_od = 0;
    if (parse_budgets(o.budgets, c) || cli_problem_make(&o.job, &p) ||
        cli_job_spec(&o.job, &remote_spec, &scene_text) ||
        parse_methods(o.methods ? o.methods : default_methods(&p), c) ||
        make_reference(&o, &p, scene_text, c))
        goto done;
    c->label = p.label;
    c->dims = p.f->dims;
    c->reps = o.reps;
    c->endpoint = endpoint;
    if (endpoint && cli_remote_connect(endpoint, &client))
        goto done;
    if (cli_outdir_open(&od, o.out))
        goto done;
    have_od = 1;
    if (run_all(&o, &p, &remote_spec, client, c) || cli_cmp_summarize(c) ||
        cli_cmp_write(&od, c) || cli_outdir_commit(&od))
        goto done;
    have_od = 0;
    printf("compare: %zu runs of %u methods; wrote %s/compare.csv, REPORT.md, "
           "error-time, error-evals and honesty (.png, .svg)\n", c->n_runs, c->n_methods, o.out);
    rc = fflush(stdout) == 0 ? CLI_EXIT_OK : cli_error("writing to stdout failed");
done:
    if (have_od)
        cli_outdir_abort(&od);
    qmc_client_close(client);
    free(scene_text);
    if (p.job)
        cli_problem_free(&p);
    free(c->runs);
    free(c->points);
    free(c);
    return rc;
}
