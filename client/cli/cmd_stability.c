/*
 * cmd_stability.c - `qmc stability`: every method against every failure
 * case (stability_cases.c), each cell classified OK, FLAGGED, REFUSED or
 * SILENT against a reference computed without the method
 * (qmc_stab_classify), written as a CSV, REPORT.md and a heat map.
 *
 * Cells run in parallel on --threads threads, each cell's runs serially,
 * so the matrix is the same whatever the thread count: every run is a
 * pure function of (case, method, budget, seed).
 */
#include <getopt.h>
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "outdir.h"
#include "stability.h"
#include "qmc/job.h"

static const char stability_help[] =
    "usage: qmc stability [--quick] [--out DIR] [--json] [--threads T]\n"
    "                     [--cases LIST] [--methods LIST] [--seeds K]\n"
    "                     [--fail-on-silent] [--strip-flags]\n"
    "\n"
    "Runs every integration method (each quadrature rule, mc, stratified, lhs,\n"
    "qmc per sequence, rqmc per scramble, cubature, clenshaw-curtis, auto) on\n"
    "cases where error bars are known to fail: jumps, kinks, endpoint\n"
    "singularities, infinite variance, narrow peaks in 1-5 dims, tiny supports\n"
    "and tiny lights (scenes under each sampling strategy, MIS included),\n"
    "unscrambled Halton past 10 dims, non-power-of-two nets, tensor rules at\n"
    "d = 10, tiny budgets, near-zero integrals, NaN and overflow.  Each cell is\n"
    "judged against a reference computed without the method (a closed form,\n"
    "or the scene reference quadrature with its own error bound):\n"
    "\n"
    "  OK       |estimate - truth| <= 3 x the reported error (flags or not)\n"
    "  FLAGGED  wrong, but a flag says the bar cannot be trusted (or the\n"
    "           method says it has no bar, as plain qmc does)\n"
    "  REFUSED  the method declined the job with an error\n"
    "  SILENT   wrong with no flag: outside 3 x the bar, or a NaN/infinite\n"
    "           bar printed bare, or a finite answer to an integral that\n"
    "           overflows\n"
    "\n"
    "Randomized methods run on K seeds; their cell is SILENT when more runs\n"
    "are silent than an honest 3-sigma bar would miss by chance (binomial\n"
    "test, p = 1%, alpha = 1e-3).  Prints a summary and the silent cells.\n"
    "\n"
    "  --quick           2^16 evaluations a run, 1e6 for adaptive methods, 3\n"
    "                    seeds, about 12 CPU seconds (default: 2^20, 2e7, 5\n"
    "                    seeds, about 5 CPU minutes)\n"
    "  --out DIR         write DIR/stability.csv, DIR/REPORT.md and the heat\n"
    "                    map DIR/stability.png and .svg (with its gnuplot\n"
    "                    script and data); all or nothing\n"
    "  --json            print the matrix as one JSON object instead\n"
    "  --threads T       cells run in parallel (default 2; same results)\n"
    "  --cases LIST      only these case names (comma-separated)\n"
    "  --methods LIST    only these methods (METHOD[/SEQ[/SCRAMBLE]])\n"
    "  --seeds K         seeds per randomized cell (tiny-budget cases use 64)\n"
    "  --fail-on-silent  exit 1 when any cell is SILENT (make check's gate)\n"
    "  --strip-flags     judge as if no method raised a flag: shows which\n"
    "                    cells only their flags keep from being SILENT (and\n"
    "                    tests the classification itself)\n";

typedef struct stab_opts {
    int quick, json, fail_on_silent, strip_flags;
    const char *out;
    unsigned threads;
    const char *cases, *methods;
    uint32_t seeds;
} stab_opts;

/* Is name in the comma-separated list? */
static int in_list(const char *list, const char *name)
{
    const size_t len = strlen(name);
    const char *p = list, *it;
    size_t n;
    while (cli_list_next(&p, &it, &n))
        if (n == len && strncmp(it, name, n) == 0)
            return 1;
    return 0;
}

/* Every item of list must name one of names[] (via canon for methods). */
static int check_list(const char *opt, const char *list, int is_method)
{
    const char *p = list, *it;
    size_t n;
    while (cli_list_next(&p, &it, &n)) {
        char item[64];
        if (cli_list_copy(it, n, item, sizeof item))
            return cli_error("%s: bad list '%s'", opt, list), -1;
        int found = 0;
        if (is_method) {
            cli_method m;
            char why[256];
            if (cli_method_parse(item, &m, why, sizeof why) != 0)
                return cli_error("%s: %s", opt, why), -1;
            for (size_t i = 0; i < cli_stab_method_count; i++) {
                cli_method col;
                if (cli_method_parse(cli_stab_methods[i], &col, why, sizeof why) == 0 &&
                    strcmp(col.name, m.name) == 0)
                    found = 1;
            }
            if (!found)
                return cli_error("%s: %s is not a column of the matrix (see qmc stability "
                                 "--help)", opt, m.name), -1;
        } else {
            for (size_t i = 0; i < cli_stab_case_count; i++)
                found |= strcmp(cli_stab_cases[i].name, item) == 0;
            if (!found)
                return cli_error("%s: no case named '%s'", opt, item), -1;
        }
    }
    return 0;
}

static int parse(int argc, char **argv, stab_opts *o)
{
    static const struct option longopts[] = {
        {"quick", no_argument, 0, 0},        {"out", required_argument, 0, 0},
        {"json", no_argument, 0, 0},         {"threads", required_argument, 0, 0},
        {"cases", required_argument, 0, 0},  {"methods", required_argument, 0, 0},
        {"seeds", required_argument, 0, 0},  {"fail-on-silent", no_argument, 0, 0},
        {"strip-flags", no_argument, 0, 0},  {"help", no_argument, 0, 0},
        {0, 0, 0, 0},
    };
    memset(o, 0, sizeof *o);
    o->threads = 2;
    int first = 1, more;
    const char *name, *arg;
    uint64_t v;
    while ((more = cli_next_option("stability", argc, argv, longopts, &first, &name, &arg)) > 0) {
        if (strcmp(name, "help") == 0) {
            fputs(stability_help, stdout);
            return 1;
        } else if (strcmp(name, "quick") == 0) {
            o->quick = 1;
        } else if (strcmp(name, "out") == 0) {
            o->out = arg;
        } else if (strcmp(name, "json") == 0) {
            o->json = 1;
        } else if (strcmp(name, "threads") == 0) {
            if (cli_parse_u64("--threads", arg, 1, 256, &v))
                return -1;
            o->threads = (unsigned)v;
        } else if (strcmp(name, "cases") == 0) {
            if (check_list("--cases", arg, 0))
                return -1;
            o->cases = arg;
        } else if (strcmp(name, "methods") == 0) {
            if (check_list("--methods", arg, 1))
                return -1;
            o->methods = arg;
        } else if (strcmp(name, "seeds") == 0) {
            if (cli_parse_u64("--seeds", arg, 1, 1000, &v))
                return -1;
            o->seeds = (uint32_t)v;
        } else if (strcmp(name, "fail-on-silent") == 0) {
            o->fail_on_silent = 1;
        } else if (strcmp(name, "strip-flags") == 0) {
            o->strip_flags = 1;
        }
    }
    return more < 0 ? -1 : 0;
}

/* ---- the matrix -------------------------------------------------------- */

typedef struct stab_row {
    qmc_job *job;
} stab_row;

static int is_adaptive(qmc_method m)
{
    return m == QMC_METHOD_GAUSS_KRONROD || m == QMC_METHOD_CUBATURE ||
           m == QMC_METHOD_CLENSHAW_CURTIS || m == QMC_METHOD_AUTO;
}

/* The job of a case (the integrand only; methods come per run). */
static int case_job(const cli_stab_case *c, qmc_job **out)
{
    qmc_job_spec s;
    qmc_job_spec_init(&s);
    if (c->scene) {
        s.scene_text = c->scene;
        s.scene_len = (uint32_t)strlen(c->scene);
        s.strategy = c->strategy;
        s.beta = c->beta > 0 ? c->beta : 2.0;
    } else {
        snprintf(s.integrand, sizeof s.integrand, "%s", c->integrand);
        s.dims = c->dims;
        if (c->n_params) {
            s.a = c->a;
            s.u = c->u;
            s.n_a = s.n_u = c->n_params;
            /* the 1D functions take only what they use */
            if (strcmp(c->integrand, "step") == 0)
                s.a = NULL, s.n_a = 0;
            if (strcmp(c->integrand, "poly") == 0 || strcmp(c->integrand, "cos") == 0)
                s.u = NULL, s.n_u = 0;
        }
    }
    char why[256];
    if (qmc_job_new(&s, out, why, sizeof why) != 0)
        return cli_error("stability case %s: %s", c->name, why), -1;
    return 0;
}

/* The case's reference, from a closed form or the scene module. */
static int case_reference(const cli_stab_case *c, const qmc_job *job, cli_stab_ref *ref)
{
    memset(ref, 0, sizeof *ref);
    if (c->infinite) {
        ref->truth.value = INFINITY;
        ref->source = "overflows (no finite integral)";
        return 0;
    }
    if (c->scene) {
        qmc_scene sc;
        char why[256];
        int exact = 0;
        if (qmc_scene_parse(c->scene, strlen(c->scene), &sc, why, sizeof why) != 0 ||
            qmc_scene_reference(&sc, &ref->truth.value, &ref->truth.abs_error, &exact) != 0)
            return cli_error("stability case %s: no scene reference", c->name), -1;
        ref->truth.defined = 1;
        ref->truth.scale = ref->truth.value; /* radiance >= 0 */
        ref->source = exact ? "scene closed form" : "scene quadrature";
        return 0;
    }
    const qmc_integrand *f = qmc_job_integrand(job);
    if (!f->has_exact)
        return cli_error("stability case %s: no closed form", c->name), -1;
    ref->truth.value = f->exact;
    ref->truth.defined = 1;
    ref->truth.scale = f->has_abs_integral ? f->abs_integral : c->scale;
    ref->source = "closed form";
    return 0;
}

typedef struct stab_ctx {
    cli_stab_matrix *mx;
    const stab_opts *o;
    stab_row *rows;
    atomic_size_t next;
} stab_ctx;

static void copy_text(char *dst, size_t bytes, const char *src)
{
    snprintf(dst, bytes, "%s", src);
}

static void run_cell(stab_ctx *x, size_t index)
{
    cli_stab_matrix *mx = x->mx;
    cli_stab_cell *cell = &mx->cells[index];
    size_t row = index / mx->n_methods, col = index % mx->n_methods;
    const cli_stab_case *c = mx->cases[row];
    const cli_method *m = &mx->methods[col];
    const qmc_job *job = x->rows[row].job;
    const qmc_stab_truth *truth = &mx->refs[row].truth;
    cell->c = c;
    cell->m = m;
    uint32_t seeds = m->randomized ? (c->seeds ? c->seeds : mx->default_seeds) : 1;
    qmc_stab_verdict *verdicts = calloc(seeds, sizeof *verdicts);
    qmc_integrate_report *reps = calloc(seeds, sizeof *reps);
    char (*whys)[160] = calloc(seeds, sizeof *whys);
    int *refused = calloc(seeds, sizeof *refused);
    double t0 = cli_now_seconds();
    if (!verdicts || !reps || !whys || !refused) {
        cell->cls = QMC_STAB_REFUSED;
        copy_text(cell->reason, sizeof cell->reason, "out of memory");
        goto done;
    }
    for (uint32_t k = 0; k < seeds; k++) {
        cli_budget b = {.evals = c->evals ? c->evals : mx->default_evals,
                        .dims = qmc_job_integrand(job)->dims,
                        .seed = 12345 + 1000003ull * k};
        qmc_integrate_spec s;
        cli_method_spec(m, &b, &s);
        if (is_adaptive(m->method))
            s.max_evals = c->tiny ? b.evals : mx->adaptive_evals;
        char why[256] = "";
        int err = qmc_job_run(job, &s, NULL, NULL, &reps[k], why, sizeof why);
        refused[k] = err != 0;
        if (err)
            copy_text(whys[k], sizeof whys[k], why[0] ? why : qmc_strerror(err));
        if (x->o->strip_flags)
            reps[k].res.flags = 0;
        verdicts[k] = qmc_stab_classify(refused[k], &reps[k].res, truth);
        qmc_stab_tally_add(&cell->tally, &verdicts[k], refused[k] ? NULL : &reps[k].res);
        qmc_stab_flag_tally_add(&cell->flags, refused[k], &verdicts[k], &reps[k].res);
    }
    cell->cls = qmc_stab_tally_class(&cell->tally, qmc_stab_silent_needed(seeds, m->randomized));
    /* show the first run of the cell's class (else the first run) */
    uint32_t shown = 0;
    for (uint32_t k = 0; k < seeds; k++)
        if (verdicts[k].cls == cell->cls) {
            shown = k;
            break;
        }
    cell->res = reps[shown].res;
    cell->v = verdicts[shown];
    cell->seed = 12345 + 1000003ull * shown;
    copy_text(cell->method_used, sizeof cell->method_used,
              refused[shown] ? "" : qmc_method_name(reps[shown].method_used));
    copy_text(cell->reason, sizeof cell->reason, refused[shown] ? whys[shown] : "");
done:
    cell->seconds = cli_now_seconds() - t0;
    free(verdicts), free(reps), free(whys), free(refused);
}

static void *worker(void *arg)
{
    stab_ctx *x = arg;
    size_t total = x->mx->n_cases * x->mx->n_methods;
    for (;;) {
        size_t i = atomic_fetch_add(&x->next, 1);
        if (i >= total)
            return NULL;
        run_cell(x, i);
    }
}

static int run_matrix(const stab_opts *o, cli_stab_matrix *mx)
{
    memset(mx, 0, sizeof *mx);
    mx->quick = o->quick;
    mx->default_evals = o->quick ? (1u << 16) : (1u << 20);
    mx->adaptive_evals = o->quick ? 1000000 : 20000000;
    mx->default_seeds = o->seeds ? o->seeds : (o->quick ? 3 : 5);
    mx->cases = calloc(cli_stab_case_count, sizeof *mx->cases);
    mx->methods = calloc(cli_stab_method_count, sizeof *mx->methods);
    mx->refs = calloc(cli_stab_case_count, sizeof *mx->refs);
    stab_row *rows = calloc(cli_stab_case_count, sizeof *rows);
    int rc = -1;
    if (!mx->cases || !mx->methods || !mx->refs || !rows) {
        cli_error("out of memory");
        goto fail;
    }
    for (size_t i = 0; i < cli_stab_case_count; i++)
        if (!o->cases || in_list(o->cases, cli_stab_cases[i].name))
            mx->cases[mx->n_cases++] = &cli_stab_cases[i];
    for (size_t i = 0; i < cli_stab_method_count; i++) {
        cli_method m;
        char why[256];
        if (cli_method_parse(cli_stab_methods[i], &m, why, sizeof why) != 0) {
            cli_error("stability: %s", why);
            goto fail;
        }
        int want = !o->methods;
        const char *p = o->methods ? o->methods : "", *it;
        size_t n;
        while (!want && cli_list_next(&p, &it, &n)) {
            char item[64];
            cli_method other;
            snprintf(item, sizeof item, "%.*s", (int)n, it);
            want = cli_method_parse(item, &other, why, sizeof why) == 0 &&
                   strcmp(other.name, m.name) == 0;
        }
        if (want)
            mx->methods[mx->n_methods++] = m;
    }
    for (size_t r = 0; r < mx->n_cases; r++)
        if (case_job(mx->cases[r], &rows[r].job) ||
            case_reference(mx->cases[r], rows[r].job, &mx->refs[r]))
            goto fail;
    size_t total = mx->n_cases * mx->n_methods;
    mx->cells = calloc(total ? total : 1, sizeof *mx->cells);
    if (!mx->cells) {
        cli_error("out of memory");
        goto fail;
    }
    stab_ctx x = {.mx = mx, .o = o, .rows = rows};
    atomic_init(&x.next, 0);
    double t0 = cli_now_seconds();
    unsigned n = o->threads;
    pthread_t *ids = calloc(n, sizeof *ids);
    unsigned started = 0;
    if (ids)
        for (; started + 1 < n; started++)
            if (pthread_create(&ids[started], NULL, worker, &x) != 0)
                break;
    worker(&x);
    for (unsigned i = 0; i < started; i++)
        pthread_join(ids[i], NULL);
    free(ids);
    mx->seconds = cli_now_seconds() - t0;
    for (size_t i = 0; i < total; i++) {
        mx->count[mx->cells[i].cls]++;
        mx->ok_flagged_runs += mx->cells[i].tally.ok_flagged;
        mx->runs += mx->cells[i].tally.runs;
        if (!mx->cells[i].c->tiny) {
            mx->ok_flagged_runs_normal += mx->cells[i].tally.ok_flagged;
            mx->runs_normal += mx->cells[i].tally.runs;
            qmc_stab_flag_tally_merge(&mx->flags_normal, &mx->cells[i].flags);
        } else {
            qmc_stab_flag_tally_merge(&mx->flags_tiny, &mx->cells[i].flags);
        }
    }
    rc = 0;
fail:
    for (size_t r = 0; rows && r < mx->n_cases; r++)
        qmc_job_free(rows[r].job);
    free(rows);
    return rc;
}

static void matrix_free(cli_stab_matrix *mx)
{
    free(mx->cases), free(mx->methods), free(mx->refs), free(mx->cells);
    memset(mx, 0, sizeof *mx);
}

static int write_outputs(const char *dir, const cli_stab_matrix *mx)
{
    cli_outdir od;
    if (cli_outdir_open(&od, dir))
        return -1;
    FILE *f = cli_outdir_fopen(&od, "stability.csv");
    if (!f || cli_stab_write_csv(f, mx) || cli_outdir_fclose(f, "stability.csv"))
        goto fail;
    f = cli_outdir_fopen(&od, "REPORT.md");
    if (!f || cli_stab_write_report(f, mx) || cli_outdir_fclose(f, "REPORT.md"))
        goto fail;
    if (cli_stab_write_heatmap(&od, mx))
        goto fail;
    return cli_outdir_commit(&od);
fail:
    cli_outdir_abort(&od);
    return -1;
}

int cli_cmd_stability(int argc, char **argv)
{
    const char *endpoint;
    if (cli_remote_take(&argc, argv, &endpoint))
        return CLI_EXIT_FAIL;
    stab_opts o;
    int r = parse(argc, argv, &o);
    if (r != 0)
        return r > 0 ? CLI_EXIT_OK : CLI_EXIT_FAIL;
    if (endpoint)
        return cli_error("stability runs in-process: it times and judges every method "
                         "itself (drop --connect; qmc compare --connect runs on a daemon)");
    cli_stab_matrix mx;
    if (run_matrix(&o, &mx)) {
        matrix_free(&mx);
        return CLI_EXIT_FAIL;
    }
    int rc = CLI_EXIT_OK;
    if (o.out && write_outputs(o.out, &mx))
        rc = CLI_EXIT_FAIL;
    if (rc == CLI_EXIT_OK) {
        if (o.json)
            cli_stab_print_json(stdout, &mx);
        else
            cli_stab_print_summary(stdout, &mx);
        if (fflush(stdout) != 0)
            rc = cli_error("writing the report failed");
    }
    if (rc == CLI_EXIT_OK && o.fail_on_silent && mx.count[QMC_STAB_SILENT] > 0)
        rc = 1;
    matrix_free(&mx);
    return rc;
}
