/*
 * cmd_integrate.c - `qmc integrate`: parse options, run the method, print.
 *
 * Sampling methods run on --threads threads through the block runner; the
 * numbers do not depend on the thread count.  --part K/P runs only part K
 * of the blocks and prints a partial result for `qmc merge`.  --command
 * runs a program of the user's as f (integrate_command.c).
 */
#include <getopt.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "command_codec.h"
#include "integrate.h"
#include "runner_threads.h"

static const char integrate_help[] =
    "usage: qmc integrate (--integrand NAME --dims D [--a LIST] [--u LIST]\n"
    "                      [--difficulty testpack|fixed] | --scene FILE |\n"
    "                      --command 'PROGRAM ARGS' --dims D [--command-format text|f64]\n"
    "                      [--command-timeout MS] [--smoothness S] [--exact V])\n"
    "         --method auto|mc|stratified|lhs|qmc|rqmc|midpoint|trapezoid|simpson|\n"
    "                  gauss-legendre|gauss-kronrod|cubature|clenshaw-curtis\n"
    "         [--seq KIND] [--scramble S] [--shuffle] [--n N] [--reps R] [--split-net]\n"
    "         [--seed X] [--strategy uniform|brdf|light|mis-balance|mis-power|mis-max]\n"
    "         [--beta B] [--control NAME] [--tol-abs E] [--tol-rel E] [--max-evals N]\n"
    "         [--max-memory BYTES] [--confidence C] [--threads T] [--part K/P] [--json]\n"
    "\n"
    "Integrates over the unit cube [0,1)^D and prints the estimate, its error\n"
    "(standard error for randomized methods, error estimate for quadrature, none\n"
    "for plain qmc), the confidence interval, the exact value and the actual\n"
    "error when known, n, evaluations, dimensions, seconds, and flags that say\n"
    "when a number cannot be trusted.\n"
    "\n"
    "  --integrand NAME  genz-oscillatory, genz-product-peak, genz-corner-peak,\n"
    "                    genz-gaussian, genz-continuous, genz-discontinuous (a, u:\n"
    "                    D values each; default: --difficulty fixed, seed 0);\n"
    "                    poly (a = coefficients, default x^5), exp, cos (a1),\n"
    "                    inv-sqrt, log, step (u1) - the 1D functions need --dims 1\n"
    "  --a LIST, --u LIST  comma-separated parameters\n"
    "  --command 'PROGRAM ARGS'  your own f: qmc starts PROGRAM (/bin/sh -c) and\n"
    "                    sends it batches of points on its stdin; it writes f at\n"
    "                    each point on its stdout, in order (docs/SESSIONS.md)\n"
    "  --command-format F  text (default): a point is a line of D numbers, an\n"
    "                    empty line ends a batch, and PROGRAM writes one value a\n"
    "                    line; f64: a batch is a u32 count then count x D doubles,\n"
    "                    the answer count doubles (all little-endian)\n"
    "  --command-timeout MS  stop PROGRAM when it reads and writes nothing for MS\n"
    "                    milliseconds while qmc waits on it (default 60000; 0 never)\n"
    "  --smoothness S    what you know of your f, for auto and the flags: smooth,\n"
    "                    kinks (the default: an unknown f may have them), jumps,\n"
    "                    singular\n"
    "  --exact V         your f's exact integral, when known: the report then\n"
    "                    prints the actual error\n"
    "  --difficulty P    draw Genz a and u from --seed: testpack (sum a = h/d^e,\n"
    "                    Genz's h and e) or fixed (dimension-independent sums)\n"
    "  --method M        sampling: mc, stratified, lhs, qmc, rqmc;\n"
    "                    tensor rules: midpoint, trapezoid, simpson,\n"
    "                    gauss-legendre (--n points per axis, cost about\n"
    "                    n^D + 3 (n/2)^D: two levels and a check of the bar);\n"
    "                    gauss-kronrod (1D, adaptive); cubature (Genz-Malik,\n"
    "                    adaptive, low D); clenshaw-curtis (tensor rule whose\n"
    "                    axes are raised adaptively; analytic integrands, D <= 5);\n"
    "                    auto picks and says why\n"
    "  --n N             points per replicate (sampling, default 4096; stratified:\n"
    "                    the largest k^D not above it) or per axis (tensor, 16)\n"
    "  --reps R          independent replicates (rqmc default 16)\n"
    "  --split-net       rqmc: the replicates are consecutive blocks of one\n"
    "                    scrambled sequence - the accuracy of one net of R n\n"
    "                    points, and a conservative bar (auto's choice with\n"
    "                    jumps, and from 4096 points a replicate without)\n"
    "  --seq, --scramble sequence and scramble for qmc/rqmc (sobol, owen)\n"
    "  --seed X          seeds the sampling and --difficulty\n"
    "  --control NAME    a control variate with known integral (same D, a, u)\n"
    "  --scene FILE      a shading point, BRDF, light and medium (docs/SCENES.md);\n"
    "                    integrates the reflected radiance; the dims reported are\n"
    "                    the sample dimensions the scene consumed\n"
    "  --strategy S      scene sampling: uniform (hemisphere), brdf, light, or MIS\n"
    "                    of brdf + light: mis-balance, mis-power (default), mis-max\n"
    "  --beta B          the power heuristic's exponent (default 2)\n"
    "  --samples B/L     MIS: BRDF and light samples per point (default 1/1)\n"
    "  --tol-abs, --tol-rel  adaptive: double n until the interval half-width\n"
    "                    meets the tolerance or --max-evals runs out (default 1e8)\n"
    "  --max-memory B    bytes for cubature regions or the clenshaw-curtis grid\n"
    "                    (default 64 MiB)\n"
    "  --threads T       worker threads for sampling methods (same numbers)\n"
    "  --part K/P        compute part K of P of a fixed-n sampling job and print\n"
    "                    a partial result; combine with qmc merge\n"
    "  --json            one JSON object instead of text\n"
    "\n"
    "  --threads and --part are in-process options: with --connect the daemon's\n"
    "  worker pool runs the whole job, and giving either is an error; but a\n"
    "  --command's --part runs on the daemon too (the same part file).\n";

static int is_sampler(const char *m)
{
    qmc_sampler s;
    return qmc_sampler_parse(m, &s) == 0;
}

int cli_integrate_parse(int argc, char **argv, cli_integrate *o)
{
    static const struct option longopts[] = {
        {"integrand", required_argument, 0, 0}, {"scene", required_argument, 0, 0},
        {"dims", required_argument, 0, 0},      {"a", required_argument, 0, 0},
        {"u", required_argument, 0, 0},         {"difficulty", required_argument, 0, 0},
        {"method", required_argument, 0, 0},    {"seq", required_argument, 0, 0},
        {"scramble", required_argument, 0, 0},  {"shuffle", no_argument, 0, 0},
        {"split-net", no_argument, 0, 0},
        {"n", required_argument, 0, 0},         {"reps", required_argument, 0, 0},
        {"seed", required_argument, 0, 0},      {"strategy", required_argument, 0, 0},
        {"beta", required_argument, 0, 0},      {"samples", required_argument, 0, 0},
        {"control", required_argument, 0, 0},   {"tol-abs", required_argument, 0, 0},
        {"tol-rel", required_argument, 0, 0},   {"max-evals", required_argument, 0, 0},
        {"max-memory", required_argument, 0, 0}, {"confidence", required_argument, 0, 0},
        {"threads", required_argument, 0, 0},   {"part", required_argument, 0, 0},
        {"json", no_argument, 0, 0},            {"help", no_argument, 0, 0},
        {"command", required_argument, 0, 0},  {"command-format", required_argument, 0, 0},
        {"command-timeout", required_argument, 0, 0},
        {"smoothness", required_argument, 0, 0}, {"exact", required_argument, 0, 0},
        {0, 0, 0, 0},
    };
    cli_job_options_init(o);
    int first = 1, more;
    const char *name, *arg;
    uint64_t v;
    while ((more = cli_next_option("integrate", argc, argv, longopts, &first, &name, &arg)) > 0) {
        int job_arg = strcmp(name, "part") != 0 && strcmp(name, "threads") != 0 &&
                      strcmp(name, "json") != 0 && strcmp(name, "help") != 0 &&
                      strcmp(name, "command-timeout") != 0;
        if (job_arg && o->n_job_args + 2 <= CLI_MAX_ARGS) {
            /* Kept verbatim (argv outlives the run) for partial files:
             * "--opt=value" is one word, "--opt value" two. */
            char *last = argv[optind - 1];
            if (!arg || (arg > last && arg <= last + strlen(last))) {
                o->job_args[o->n_job_args++] = last;
            } else {
                o->job_args[o->n_job_args++] = argv[optind - 2];
                o->job_args[o->n_job_args++] = (char *)arg;
            }
        }
        int job = cli_job_option(o, name, arg);
        if (job < 0)
            return -1;
        if (job > 0)
            continue;
        if (strcmp(name, "help") == 0) {
            fputs(integrate_help, stdout);
            fputs(cli_remote_help, stdout);
            return 1;
        } else if (strcmp(name, "difficulty") == 0) {
            o->difficulty = arg;
        } else if (strcmp(name, "method") == 0) {
            o->method = arg;
        } else if (strcmp(name, "seq") == 0) {
            if (qmc_seq_kind_parse(arg, &o->spec.seq) != 0)
                return cli_error("--seq: unknown sequence kind '%s'", arg), -1;
            o->have_seq = 1;
        } else if (strcmp(name, "scramble") == 0) {
            if (qmc_scramble_parse(arg, &o->spec.scramble) != 0)
                return cli_error("--scramble: unknown scramble '%s' (none, shift, owen, faure, fast-owen)", arg), -1;
            o->have_scramble = 1;
        } else if (strcmp(name, "shuffle") == 0) {
            o->spec.seq_flags |= QMC_SEQ_SHUFFLE;
        } else if (strcmp(name, "split-net") == 0) {
            o->spec.split_net = 1;
        } else if (strcmp(name, "n") == 0) {
            if (cli_parse_u64("--n", arg, 1, QMC_SEQ_MAX_INDEX, &o->spec.n))
                return -1;
            o->have_n = 1;
        } else if (strcmp(name, "reps") == 0) {
            if (cli_parse_u64("--reps", arg, 1, 1u << 20, &v))
                return -1;
            o->spec.reps = (uint32_t)v, o->have_reps = 1;
        } else if (strcmp(name, "seed") == 0) {
            if (cli_parse_u64("--seed", arg, 0, UINT64_MAX, &o->spec.seed))
                return -1;
        } else if (strcmp(name, "samples") == 0) {
            unsigned b, l;
            char tail;
            if (sscanf(arg, "%u/%u%c", &b, &l, &tail) != 2 || b == 0 || l == 0 || b > 64 || l > 64)
                return cli_error("--samples: want B/L, samples per point for the BRDF and "
                                 "light strategies (1..64 each), not '%s'", arg), -1;
            o->samples_brdf = b, o->samples_light = l;
        } else if (strcmp(name, "control") == 0) {
            o->control = arg;
        } else if (strcmp(name, "tol-abs") == 0) {
            if (cli_parse_double("--tol-abs", arg, &o->tol_abs) || !(o->tol_abs > 0))
                return cli_error("--tol-abs: must be a positive number"), -1;
        } else if (strcmp(name, "tol-rel") == 0) {
            if (cli_parse_double("--tol-rel", arg, &o->tol_rel) || !(o->tol_rel > 0))
                return cli_error("--tol-rel: must be a positive number"), -1;
        } else if (strcmp(name, "max-evals") == 0) {
            if (cli_parse_u64("--max-evals", arg, 1, UINT64_MAX, &o->max_evals))
                return -1;
        } else if (strcmp(name, "max-memory") == 0) {
            if (cli_parse_u64("--max-memory", arg, 4096, 1ull << 40, &o->max_memory))
                return -1;
        } else if (strcmp(name, "confidence") == 0) {
            if (cli_parse_double("--confidence", arg, &o->spec.confidence) ||
                !(o->spec.confidence > 0 && o->spec.confidence < 1))
                return cli_error("--confidence: must lie strictly between 0 and 1"), -1;
        } else if (strcmp(name, "threads") == 0) {
            if (cli_parse_u64("--threads", arg, 1, 1024, &v))
                return -1;
            o->threads = (unsigned)v;
        } else if (strcmp(name, "part") == 0) {
            unsigned k, p;
            char tail;
            if (sscanf(arg, "%u/%u%c", &k, &p, &tail) != 2 || p == 0 || k == 0 || k > p)
                return cli_error("--part: want K/P with 1 <= K <= P, not '%s'", arg), -1;
            o->part_k = k, o->part_p = p;
        } else if (strcmp(name, "json") == 0) {
            o->json = 1;
        } else if (strcmp(name, "command") == 0) {
            if (!arg[strspn(arg, " \t\n")])
                return cli_error("--command: name the PROGRAM to run"), -1;
            o->command = arg;
        } else if (strcmp(name, "command-format") == 0) {
            cli_cmd_format fmt;
            if (cli_cmd_format_parse(arg, &fmt) != 0)
                return cli_error("--command-format: want text or f64, not '%s'", arg), -1;
            o->command_format = arg;
        } else if (strcmp(name, "command-timeout") == 0) {
            if (cli_parse_u64("--command-timeout", arg, 0, INT32_MAX, &o->command_timeout_ms))
                return -1;
        } else if (strcmp(name, "smoothness") == 0) {
            if (cli_smoothness_parse(arg, &o->smoothness) != 0)
                return cli_error("--smoothness: want smooth, kinks, jumps or singular, not "
                                 "'%s'", arg), -1;
            o->have_smoothness = 1;
        } else if (strcmp(name, "exact") == 0) {
            if (cli_parse_double("--exact", arg, &o->exact))
                return -1;
            o->have_exact = 1;
        }
    }
    if (more < 0)
        return -1;
    if (o->n_job_args + 2 > CLI_MAX_ARGS)
        return cli_error("integrate: too many arguments"), -1;
    return 0;
}

int cli_integrate_defaults(cli_integrate *o, const cli_problem *p)
{
    qmc_sampler s;
    if (o->spec.split_net && strcmp(o->method, "rqmc") != 0)
        return cli_error("--split-net is for rqmc (auto decides by itself), not %s",
                         o->method), -1;
    if (qmc_sampler_parse(o->method, &s) != 0)
        return 0;
    qmc_sampling_spec d;
    qmc_sampling_spec_init(&d, s);
    o->spec.sampler = s;
    if (!o->have_scramble)
        o->spec.scramble = d.scramble;
    if (!o->have_reps)
        o->spec.reps = d.reps;
    if (s == QMC_SAMPLER_STRATIFIED && !o->have_n) {
        /* the largest k^D not above the default n, as qmc_integrate does */
        uint64_t best = 1;
        for (uint64_t k = 2;; k++) {
            uint64_t q = 1;
            for (uint32_t j = 0; j < p->f->dims && q <= o->spec.n; j++)
                q *= k;
            if (q > o->spec.n)
                break;
            best = q;
        }
        o->spec.n = best;
    }
    if ((s == QMC_SAMPLER_MC || s == QMC_SAMPLER_STRATIFIED || s == QMC_SAMPLER_LHS) &&
        (o->have_seq || o->have_scramble))
        return cli_error("--seq and --scramble are for qmc and rqmc; %s draws its own points",
                         o->method), -1;
    return 0;
}

static int run_part(const cli_integrate *o, const cli_problem *p)
{
    char why[256];
    qmc_sampling_job *job = NULL;
    if (qmc_sampling_job_new(&o->spec, p->f, p->g, &job, why, sizeof why) != 0)
        return cli_error("%s", why);
    uint64_t nb = qmc_sampling_blocks(job);
    uint64_t first = nb * (o->part_k - 1) / o->part_p, end = nb * o->part_k / o->part_p;
    qmc_sampling_sums *sums = calloc(end - first + 1, sizeof *sums);
    int rc = 0;
    double t0 = cli_now_seconds();
    cli_threads t = {o->threads};
    if (!sums)
        rc = cli_error("out of memory for %llu block sums", (unsigned long long)(end - first));
    else if (cli_run_blocks_threaded(&t, job, first, end - first, sums) != 0)
        rc = cli_error("integrate: computing blocks failed");
    if (rc == 0 && cli_partial_write(stdout, o, job, sums, first, end - first, cli_now_seconds() - t0))
        rc = CLI_EXIT_FAIL;
    free(sums);
    qmc_sampling_job_free(job);
    return rc;
}

int cli_cmd_integrate(int argc, char **argv)
{
    const char *endpoint;
    if (cli_remote_take(&argc, argv, &endpoint))
        return CLI_EXIT_FAIL;
    cli_integrate o;
    int r = cli_integrate_parse(argc, argv, &o);
    if (r != 0)
        return r > 0 ? CLI_EXIT_OK : CLI_EXIT_FAIL;
    if (endpoint && !o.command && (o.part_p || o.threads > 1))
        return cli_remote_in_process_only(o.part_p ? "--part" : "--threads", "the whole job");
    /* The problem is built here in remote mode too: the same checks and
     * messages before anything is sent, and the integrand's known
     * integral of |f| and reference for the report. */
    cli_problem p;
    if (cli_problem_make(&o, &p))
        return CLI_EXIT_FAIL;
    int rc = cli_integrate_defaults(&o, &p) ? CLI_EXIT_FAIL : 0;
    if (rc == 0 && o.part_p && !is_sampler(o.method))
        rc = cli_error("--part splits sampling methods (mc, stratified, lhs, qmc, rqmc), "
                       "not %s", o.method);
    else if (rc == 0 && o.part_p && (o.tol_abs > 0 || o.tol_rel > 0))
        rc = cli_error("--part needs a fixed --n: adaptive stopping decides n as it goes");
    if (rc == 0 && o.command) {
        rc = cli_integrate_command(&o, &p, endpoint);
    } else if (rc == 0 && o.part_p) {
        rc = run_part(&o, &p);
    } else if (rc == 0) {
        cli_report rep;
        rc = endpoint ? cli_integrate_remote(&o, &p, endpoint, &rep)
                      : cli_integrate_run(&o, &p, &rep);
        if (rc == 0) {
            cli_report_print(stdout, &rep, o.json);
            if (fflush(stdout) != 0)
                rc = cli_error("writing the result failed");
        }
    }
    cli_problem_free(&p);
    return rc;
}
