/*
 * integrate_setup.c - from `qmc integrate` options to a qmc_job (the
 * library builds the integrands, exactly as the daemon does).
 */
#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "integrate.h"

/* Reads a scene file whole (at most QMC_SCENE_MAX_BYTES + 1, so the
 * parser can refuse oversize input itself). */
static char *read_scene(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        cli_error("--scene: cannot open '%s': %s", path, strerror(errno));
        return NULL;
    }
    char *buf = malloc(QMC_SCENE_MAX_BYTES + 2);
    if (!buf) {
        fclose(f);
        cli_error("out of memory");
        return NULL;
    }
    *len = fread(buf, 1, QMC_SCENE_MAX_BYTES + 1, f);
    int failed = ferror(f);
    fclose(f);
    if (failed) {
        free(buf);
        cli_error("--scene: reading '%s' failed", path);
        return NULL;
    }
    buf[*len] = '\0';
    return buf;
}

static int copy_name(char *dst, const char *src, const char *opt)
{
    if (strlen(src) >= QMC_JOB_NAME_BYTES)
        return cli_error("%s: '%.40s...' is not a known name", opt, src), -1;
    strcpy(dst, src);
    return 0;
}

int cli_job_spec(const cli_integrate *o, qmc_job_spec *s, char **scene_text)
{
    qmc_job_spec_init(s);
    *scene_text = NULL;
    if (!o->integrand && !o->scene)
        return cli_error("integrate: name an --integrand, a --scene or a --command"), -1;
    if (o->integrand && o->scene)
        return cli_error("integrate: give either --integrand or --scene, not both"), -1;
    if (o->strategy && !o->scene)
        return cli_error("--strategy chooses how a --scene is sampled; there is no scene"), -1;
    if (o->integrand && !o->have_dims)
        return cli_error("integrate: --dims D is required with --integrand"), -1;
    if (o->dims > QMC_TESTFN_MAX_DIMS) /* --dims admits more for --command */
        return cli_error("--dims: %u is outside 1..%u", o->dims, QMC_TESTFN_MAX_DIMS), -1;
    if (o->have_smoothness || o->have_exact)
        return cli_error("--smoothness and --exact declare what a --command computes; "
                         "built-in integrands and scenes declare their own"), -1;
    if (o->scene && (o->have_dims || o->have_a || o->have_u || o->difficulty || o->control))
        return cli_error("--scene fixes the integrand: --dims, --a, --u, --difficulty and "
                         "--control do not apply"), -1;
    if (o->integrand && copy_name(s->integrand, o->integrand, "--integrand"))
        return -1;
    if (o->control && copy_name(s->control, o->control, "--control"))
        return -1;
    s->dims = o->dims;
    if (o->have_a)
        s->a = o->a, s->n_a = (uint32_t)o->n_a;
    if (o->have_u)
        s->u = o->u, s->n_u = (uint32_t)o->n_u;
    if (o->difficulty) {
        qmc_difficulty d;
        if (qmc_difficulty_parse(o->difficulty, &d) != 0)
            return cli_error("--difficulty: unknown preset '%s' (testpack, fixed)",
                             o->difficulty), -1;
        s->difficulty = (int)d;
    }
    if (o->scene) {
        size_t len = 0;
        *scene_text = read_scene(o->scene, &len);
        if (!*scene_text)
            return -1;
        s->scene_text = *scene_text;
        s->scene_len = (uint32_t)len;
        if (o->strategy && qmc_scene_strategy_parse(o->strategy, &s->strategy) != 0)
            return cli_error("--strategy: unknown strategy '%s' (uniform, brdf, light, "
                             "mis-balance, mis-power, mis-max)", o->strategy), -1;
        s->beta = o->beta;
        s->samples_brdf = o->samples_brdf;
        s->samples_light = o->samples_light;
    }
    s->integrate.sampling.seed = o->spec.seed; /* seeds --difficulty too */
    return 0;
}

int cli_problem_make(const cli_integrate *o, cli_problem *p)
{
    if (o->command)
        return cli_command_problem(o, p);
    memset(p, 0, sizeof *p);
    qmc_job_spec s;
    char *scene_text = NULL;
    int rc = cli_job_spec(o, &s, &scene_text);
    char why[256];
    if (rc == 0 && qmc_job_new(&s, &p->job, why, sizeof why) != 0)
        rc = o->scene ? cli_error("%s: %s", o->scene, why) : cli_error("%s", why);
    free(scene_text);
    if (rc)
        return -1;
    p->f = qmc_job_integrand(p->job);
    p->g = qmc_job_control(p->job);
    p->label = o->scene ? o->scene : o->integrand;
    p->is_scene = qmc_job_is_scene(p->job);
    if (qmc_job_reference(p->job, &p->reference, &p->reference_exact) == 0)
        p->has_reference = 1;
    return 0;
}

void cli_problem_free(cli_problem *p)
{
    qmc_job_free(p->job);
    memset(p, 0, sizeof *p);
}
