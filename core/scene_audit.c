/*
 * scene_audit.c - what a scene job's one sum hides, checked after the run
 * (qmc_integrand.audit; qmc_integrate calls it).
 *
 * MIS adds each technique's weighted samples into one value per point, so
 * the spread of those values cannot show a technique that owns part of
 * the integral but almost never samples it: with the balance heuristic
 * on a tiny light, or the power heuristic at beta = 0.05, the BRDF
 * technique owns a share (1e-6 of the integral; 35%) that its samples
 * reach perhaps once in 10^6 points, so the estimate lacks that share and
 * the bar, built from the points that did come, is tight around the wrong
 * value (33% low at z = 7.7e9 in the audit of issue 13).  The light
 * technique's own samples see that share: at a light-sampled direction w
 * the BRDF technique's weight w_b(w) and density p_b(w) are known, so
 *   share_b = E_light[w_b f / p_l]   (the BRDF technique's part of L_o)
 *   hit_b   = E_light[p_b / p_l]     (the chance a BRDF sample sees light)
 * and a run of N points expects N c_brdf hit_b useful BRDF samples.  When
 * that is below QMC_SAMPLING_MIN_NONZERO and share_b exceeds the
 * interval's half-width, the bar cannot see a bias of that size:
 * QMC_FLAG_MIS_UNDERSAMPLED (+ error_unreliable).  The light technique
 * covers every direction that carries radiance, so it cannot be the one
 * missing.
 *
 * The same light samples check the single-technique strategies' support:
 * a direction with radiance where the strategy's density is 0 is mass the
 * estimator can never draw (QMC_FLAG_ZERO_PDF).  scene_eval.c argues no
 * accepted scene has one; this is the check that the argument still holds
 * in floating point.
 *
 * The expectations are taken over a fixed AUDIT_SIDE^2 midpoint grid of
 * the light's own parameter square (deterministic: the same job and result
 * give the same flags), about 4096 shading evaluations a job.  Must not:
 * allocate, or change the result's numbers - it only adds flags.
 */
#include <math.h>

#include "scene_impl.h"
#include "qmc/result.h"
#include "qmc/sampling.h"

enum { AUDIT_SIDE = 64 };

static int is_mis(qmc_scene_strategy st)
{
    return st == QMC_SCENE_MIS_BALANCE || st == QMC_SCENE_MIS_POWER ||
           st == QMC_SCENE_MIS_MAX;
}

uint32_t qmc__scene_audit(const void *ctx, const qmc_result *res)
{
    const qmc_scene_job *job = ctx;
    qmc__scene_geom g;
    qmc__scene_geom_init(&job->scene, &g);
    const int mis = is_mis(job->strategy) && job->c_brdf > 0 && job->c_light > 0;
    const double cb = job->c_brdf, cl = job->c_light;
    double share_b = 0.0, hit_b = 0.0;
    uint64_t unreachable = 0;
    for (int i = 0; i < AUDIT_SIDE; i++)
        for (int j = 0; j < AUDIT_SIDE; j++) {
            double u[2] = {(i + 0.5) / AUDIT_SIDE, (j + 0.5) / AUDIT_SIDE}, d = 0.0, pl = 0.0;
            qmc_vec3 w = qmc__scene_sample_light(&g, u, &d, &pl);
            if (!(pl > 0.0))
                continue;
            double v = qmc__scene_shade(&g, w, d);
            if (!(v > 0.0) || !isfinite(v))
                continue;
            double pb = qmc__scene_pdf_brdf(&g, w);
            if (job->strategy == QMC_SCENE_BRDF && !(pb > 0.0))
                unreachable++;
            if (job->strategy == QMC_SCENE_UNIFORM && !(qmc__scene_pdf_uniform(&g, w) > 0.0))
                unreachable++;
            if (mis) {
                share_b += qmc_scene_mis_weight(job->strategy, job->beta, cb * pb, cl * pl) * v / pl;
                hit_b += pb / pl;
            }
        }
    const double cells = (double)AUDIT_SIDE * AUDIT_SIDE;
    uint32_t flags = 0;
    if (unreachable)
        flags |= QMC_FLAG_ZERO_PDF | QMC_FLAG_ERROR_UNRELIABLE;
    if (mis) {
        share_b /= cells;
        hit_b /= cells;
        const double expected = (double)res->evals * cb * hit_b;
        const double half = res->ci_high - res->estimate;
        if (expected < QMC_SAMPLING_MIN_NONZERO && share_b > half)
            flags |= QMC_FLAG_MIS_UNDERSAMPLED | QMC_FLAG_ERROR_UNRELIABLE;
    }
    return flags;
}
