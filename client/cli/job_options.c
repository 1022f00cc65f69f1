/*
 * job_options.c - the options that name what a job integrates, shared by
 * `qmc integrate` and `qmc compare` (both fill a cli_integrate): their
 * defaults, and --integrand, --scene, --dims, --a, --u, --strategy and
 * --beta, parsed and checked in one place so that the two commands accept
 * the same words and say the same things about bad ones.  Each command
 * keeps its own option table, help and the options only it has.
 */
#include <string.h>

#include "cli.h"
#include "integrate.h"
#include "qmc/session.h"

void cli_job_options_init(cli_integrate *o)
{
    memset(o, 0, sizeof *o);
    qmc_sampling_spec_init(&o->spec, QMC_SAMPLER_MC);
    o->method = "auto";
    o->beta = 2.0;
    o->samples_brdf = o->samples_light = 1;
    o->max_evals = 100000000;
    o->max_memory = 64u << 20;
    o->threads = 1;
    o->command_timeout_ms = 60000;
    o->smoothness = QMC_SMOOTH_CONTINUOUS;
}

/* "1,2.5,3" -> out[0 .. *n): at most CLI_MAX_LIST numbers, no empty item
 * (a trailing comma included). */
static int parse_list(const char *opt, const char *text, double *out, size_t *n)
{
    *n = 0;
    const char *p = text, *it;
    size_t len;
    while (cli_list_next(&p, &it, &len)) {
        if (*n == CLI_MAX_LIST)
            return cli_error("%s: more than %d values", opt, CLI_MAX_LIST), -1;
        char item[64];
        if (cli_list_copy(it, len, item, sizeof item))
            return cli_error("%s: bad list '%s'", opt, text), -1;
        if (cli_parse_double(opt, item, &out[(*n)++]))
            return -1;
        if (it[len] == ',' && *p == '\0')
            return cli_error("%s: bad list '%s'", opt, text), -1;
    }
    if (*n == 0)
        return cli_error("%s: empty list", opt), -1;
    return 0;
}

int cli_job_option(cli_integrate *o, const char *name, const char *arg)
{
    uint64_t v;
    if (strcmp(name, "integrand") == 0) {
        o->integrand = arg;
    } else if (strcmp(name, "scene") == 0) {
        o->scene = arg;
    } else if (strcmp(name, "dims") == 0) {
        /* A --command takes as many as a session; cli_job_spec holds the
         * built-in integrands to theirs. */
        if (cli_parse_u64("--dims", arg, 1, QMC_SESSION_MAX_DIMS, &v))
            return -1;
        o->dims = (uint32_t)v, o->have_dims = 1;
    } else if (strcmp(name, "a") == 0) {
        if (parse_list("--a", arg, o->a, &o->n_a))
            return -1;
        o->have_a = 1;
    } else if (strcmp(name, "u") == 0) {
        if (parse_list("--u", arg, o->u, &o->n_u))
            return -1;
        o->have_u = 1;
    } else if (strcmp(name, "strategy") == 0) {
        o->strategy = arg;
    } else if (strcmp(name, "beta") == 0) {
        if (cli_parse_double("--beta", arg, &o->beta))
            return -1;
    } else {
        return 0;
    }
    return 1;
}
