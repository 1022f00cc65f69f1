/*
 * qmc/job.h - an integration job as data: what to integrate (a named test
 * function with its parameters, or a scene given as text) and how
 * (qmc_integrate_spec).  The in-process CLI and the daemon both build
 * their integrands here, so a job means the same thing in either place.
 */
#ifndef QMC_JOB_H
#define QMC_JOB_H

#include <stddef.h>
#include <stdint.h>

#include "qmc/integrate.h"
#include "qmc/scene.h"
#include "qmc/testfn.h"

#ifdef __cplusplus
extern "C" {
#endif

enum { QMC_JOB_NAME_BYTES = 32 };

typedef struct qmc_job_spec {
    /* What: a test function ... */
    char integrand[QMC_JOB_NAME_BYTES]; /* "" when scene_text is given */
    uint32_t dims;
    const double *a;          /* parameters, caller-owned; NULL: defaults */
    uint32_t n_a;
    const double *u;
    uint32_t n_u;
    int difficulty;           /* -1, or a qmc_difficulty: draw a and u from
                                 integrate.sampling.seed (Genz only) */
    char control[QMC_JOB_NAME_BYTES]; /* control variate name, or "" */
    /* ... or a scene (docs/SCENES.md), caller-owned text */
    const char *scene_text;
    uint32_t scene_len;
    qmc_scene_strategy strategy;
    double beta;
    uint32_t samples_brdf, samples_light;
    /* How. */
    qmc_integrate_spec integrate;
} qmc_job_spec;

/* Defaults: no integrand yet, difficulty -1, MIS power heuristic with
 * beta 2 and one sample per strategy, qmc_integrate_spec_init. */
void qmc_job_spec_init(qmc_job_spec *spec);

typedef struct qmc_job qmc_job;

/*
 * Builds the integrand(s).  The job copies what it needs; spec and its
 * arrays and text may be freed afterwards.  Errors, with a one-line reason:
 * QMC_EINVAL (names, combinations), QMC_EDIMS, QMC_EDOMAIN, QMC_EPROTO and
 * QMC_ETOOBIG (scene text), QMC_ENOMEM.
 */
QMC_MUST_CHECK int qmc_job_new(const qmc_job_spec *spec, qmc_job **out,
                               char *why, size_t why_bytes);
void qmc_job_free(qmc_job *job);

const qmc_integrand *qmc_job_integrand(const qmc_job *job);
const qmc_integrand *qmc_job_control(const qmc_job *job); /* or NULL */
int qmc_job_is_scene(const qmc_job *job);

/* The exact value (*exact = 1) or, for scenes without a closed form, a
 * high-accuracy reference (*exact = 0).  Returns 0, or QMC_ENOTSUP when
 * there is neither.  A scene's reference is computed on the first call (a
 * quadrature of up to tens of millions of evaluations, so qmc_job_new
 * stays cheap enough for an event loop) and kept: the first call writes to
 * job, so it must not race with another call on the same job. */
QMC_MUST_CHECK int qmc_job_reference(qmc_job *job, double *value, int *exact);

/* Runs the job's integrate spec (qmc_integrate). */
QMC_MUST_CHECK int qmc_job_run(const qmc_job *job, const qmc_integrate_spec *spec,
                               qmc_block_runner runner, void *runner_ctx,
                               qmc_integrate_report *rep, char *why,
                               size_t why_bytes);

#ifdef __cplusplus
}
#endif
#endif /* QMC_JOB_H */
