/*
 * job.c - integration jobs as data (see qmc/job.h).
 */
#include <stdlib.h>
#include <string.h>

#include "msg.h"
#include "qmc/job.h"

struct qmc_job {
    qmc_testfn *fn, *control;
    qmc_scene_job *scene;     /* integrand.ctx points into it: heap, never moved */
    double reference;
    int has_reference, reference_exact;
    int reference_done;       /* scenes: computed by the first qmc_job_reference */
};

void qmc_job_spec_init(qmc_job_spec *spec)
{
    memset(spec, 0, sizeof *spec);
    spec->difficulty = -1;
    spec->strategy = QMC_SCENE_MIS_POWER;
    spec->beta = 2.0;
    spec->samples_brdf = spec->samples_light = 1;
    qmc_integrate_spec_init(&spec->integrate);
}

static int bounded_name(const char *s)
{
    return memchr(s, '\0', QMC_JOB_NAME_BYTES) != NULL;
}

static int make_testfn(const qmc_job_spec *s, const char *name, qmc_testfn **out, qmc__msg *why)
{
    double *a = NULL, *u = NULL;
    const double *pa = s->a, *pu = s->u;
    size_t na = s->n_a, nu = s->n_u;
    qmc_genz_family fam;
    int err = 0;
    if (s->difficulty >= 0) {
        if (qmc_genz_family_parse(name, &fam) != 0) {
            qmc__msg_str(why, "a difficulty preset applies to the genz-* integrands, not ");
            qmc__msg_str(why, name);
            return QMC_EINVAL;
        }
        if (s->a || s->u) {
            qmc__msg_str(why, "a difficulty preset draws a and u: give either it or a and u");
            return QMC_EINVAL;
        }
        if (s->dims == 0 || s->dims > QMC_TESTFN_MAX_DIMS) {
            qmc__msg_set(why, "", s->dims, " dims is outside 1..");
            qmc__msg_u64(why, QMC_TESTFN_MAX_DIMS);
            return QMC_EDIMS;
        }
        a = malloc(s->dims * sizeof *a);
        u = malloc(s->dims * sizeof *u);
        if (!a || !u) {
            err = QMC_ENOMEM;
            qmc__msg_str(why, "out of memory");
            goto done;
        }
        err = qmc_genz_draw(fam, s->dims, (qmc_difficulty)s->difficulty,
                            s->integrate.sampling.seed, a, u);
        if (err) {
            qmc__msg_str(why, "unknown difficulty preset");
            goto done;
        }
        pa = a, pu = u, na = nu = s->dims;
    }
    err = qmc_testfn_new(name, s->dims, pa, na, pu, nu, out, why->buf, why->cap);
done:
    free(a);
    free(u);
    return err;
}

static int make_scene(const qmc_job_spec *s, qmc_job *job, qmc__msg *why)
{
    if (s->integrand[0] || s->control[0] || s->a || s->u || s->difficulty >= 0) {
        qmc__msg_str(why, "a scene fixes the integrand: integrand, dims, a, u, difficulty and "
                          "control do not apply");
        return QMC_EINVAL;
    }
    qmc_scene scene;
    int err = qmc_scene_parse(s->scene_text, s->scene_len, &scene, why->buf, why->cap);
    if (err)
        return err;
    job->scene = malloc(sizeof *job->scene);
    if (!job->scene) {
        qmc__msg_str(why, "out of memory");
        return QMC_ENOMEM;
    }
    err = qmc_scene_integrand(&scene, s->strategy, s->beta, s->samples_brdf, s->samples_light,
                              job->scene, why->buf, why->cap);
    if (err)
        return err;
    /* The reference waits for qmc_job_reference: it can cost a second of
     * quadrature, which the daemon's loop thread must not spend here. */
    return 0;
}

int qmc_job_new(const qmc_job_spec *s, qmc_job **out, char *why, size_t why_bytes)
{
    qmc__msg m;
    qmc__msg_init(&m, why, why_bytes);
    *out = NULL;
    if (!bounded_name(s->integrand) || !bounded_name(s->control)) {
        qmc__msg_str(&m, "integrand and control names are at most 31 bytes");
        return QMC_EINVAL;
    }
    if (!s->integrand[0] && !s->scene_text) {
        qmc__msg_str(&m, "name an integrand or give a scene");
        return QMC_EINVAL;
    }
    if (s->integrand[0] && s->scene_text) {
        qmc__msg_str(&m, "give either an integrand or a scene, not both");
        return QMC_EINVAL;
    }
    qmc_job *job = calloc(1, sizeof *job);
    if (!job) {
        qmc__msg_str(&m, "out of memory");
        return QMC_ENOMEM;
    }
    int err;
    if (s->scene_text) {
        err = make_scene(s, job, &m);
    } else {
        err = make_testfn(s, s->integrand, &job->fn, &m);
        if (!err) {
            const qmc_integrand *f = qmc_testfn_integrand(job->fn);
            job->has_reference = job->reference_exact = f->has_exact;
            job->reference = f->exact;
            job->reference_done = 1;
        }
        if (!err && s->control[0]) {
            err = make_testfn(s, s->control, &job->control, &m);
            if (!err && !qmc_testfn_integrand(job->control)->has_exact) {
                qmc__msg_set(&m, "the control variate has no known integral at ", s->dims,
                             " dims");
                err = QMC_EINVAL;
            }
        }
    }
    if (err) {
        qmc_job_free(job);
        return err;
    }
    *out = job;
    return 0;
}

void qmc_job_free(qmc_job *job)
{
    if (!job)
        return;
    qmc_testfn_free(job->fn);
    qmc_testfn_free(job->control);
    free(job->scene);
    free(job);
}

const qmc_integrand *qmc_job_integrand(const qmc_job *job)
{
    return job->scene ? &job->scene->integrand : qmc_testfn_integrand(job->fn);
}

const qmc_integrand *qmc_job_control(const qmc_job *job)
{
    return job->control ? qmc_testfn_integrand(job->control) : NULL;
}

int qmc_job_is_scene(const qmc_job *job)
{
    return job->scene != NULL;
}

int qmc_job_reference(qmc_job *job, double *value, int *exact)
{
    if (!job->reference_done && job->scene) {
        double ref = 0, ref_err = 0;
        int ex = 0;
        if (qmc_scene_reference(&job->scene->scene, &ref, &ref_err, &ex) == 0) {
            job->has_reference = 1;
            job->reference_exact = ex;
            job->reference = ref;
        }
    }
    job->reference_done = 1;
    *value = job->reference;
    *exact = job->reference_exact;
    return job->has_reference ? 0 : QMC_ENOTSUP;
}

int qmc_job_run(const qmc_job *job, const qmc_integrate_spec *spec, qmc_block_runner runner,
                void *runner_ctx, qmc_integrate_report *rep, char *why, size_t why_bytes)
{
    return qmc_integrate(spec, qmc_job_integrand(job), qmc_job_control(job), runner, runner_ctx,
                         rep, why, why_bytes);
}
