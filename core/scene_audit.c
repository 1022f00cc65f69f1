/*
 * scene_audit.c - what a scene job's one sum hides, checked after the run
 * (qmc_integrand.audit; qmc_integrate calls it).
 *
 * Each sampling technique t of a job (the strategy's one, or MIS's BRDF
 * and light techniques) adds Y_t = w_t f / p_t per sample, w_t its MIS
 * weight (1 alone).  The spread of the points cannot show a technique
 * whose share of the integral, s_t = E_t[Y_t], sits in directions its
 * samples almost never reach: the estimate lacks that share and the bar,
 * built from the points that did come, is tight around the wrong value.
 * Three cases of it:
 *  - MIS's balance heuristic on a tiny light: the BRDF technique owns 1e-6
 *    of the integral where a BRDF sample lands once in 10^6;
 *  - the power heuristic at beta 0.05 under a 200 x 200 light 0.01 above
 *    a Phong lobe (issue 23): the light technique keeps a quarter of the
 *    weight right above the point, where its uniform area samples land
 *    once in 10^8, so 28% of the integral is missing (0.71 against 1) -
 *    the light technique covers every direction, and still misses;
 *  - uniform directions at 16 points a replicate on a lobe of exponent
 *    3000: every replicate sees only the diffuse 0.5%.
 * The measure that covers all three, whatever the weights, is the
 * technique's effective sample fraction e_t = s_t^2 / E_t[Y_t^2] (Kish):
 * 1 for a constant Y_t, the hit rate for Y_t constant on the hits, and
 * tiny when the share comes from rare large values.  A run of N points
 * with c_t samples of t each expects N c_t e_t samples that carry t's
 * share; below QMC_SAMPLING_MIN_NONZERO, with s_t above the interval's
 * half-width, the bar cannot see a bias of that size:
 * QMC_FLAG_MIS_UNDERSAMPLED (+ error_unreliable), for MIS's techniques and
 * a single strategy's one alike, on sampling methods' results (a rule's
 * nodes are not samples of any technique).
 *
 * s_t and E_t[Y_t^2] = int (w_t f)^2 / p_t are integrals over directions;
 * they are taken by a deterministic quadrature that no strategy's blind
 * spot can fool: AUDIT_SIDE^2 midpoints of the BRDF technique's own
 * parameter square and as many of the light's, combined by the balance
 * heuristic (int g = sum over both grids of g / (M (p_brdf + p_light))).
 * The BRDF grid resolves the lobe however narrow, the light grid the light
 * however small, and f lives where the light is.  Values are divided by
 * the radiance first (e_t does not depend on it), so that a radiance of
 * 1e308 squares without overflowing.
 *
 * The light grid also checks the single-technique strategies' support: a
 * direction with radiance where the strategy's density is 0 is mass the
 * estimator can never draw (QMC_FLAG_ZERO_PDF).  scene_eval.c argues no
 * accepted scene has one; this is the check that the argument still holds
 * in floating point.
 *
 * Deterministic (the same job and result give the same flags), about 8192
 * shading evaluations a job.  Must not: allocate, or change the result's
 * numbers - it only adds flags.
 */
#include <math.h>

#include "scene_impl.h"
#include "qmc/result.h"
#include "qmc/sampling.h"

enum { AUDIT_SIDE = 64, TECH_BRDF = 0, TECH_LIGHT = 1, TECH_UNIFORM = 2, TECHS = 3 };

static int is_mis(qmc_scene_strategy st)
{
    return st == QMC_SCENE_MIS_BALANCE || st == QMC_SCENE_MIS_POWER ||
           st == QMC_SCENE_MIS_MAX;
}

/* What the audit accumulates: per technique, int w f and int (w f)^2 / p
 * (f over the radiance), and the directions where a single strategy's
 * density is 0 while radiance arrives. */
typedef struct audit_sums {
    double share[TECHS], second[TECHS];
    double count[TECHS];  /* c_t: samples of t a point */
    uint64_t unreachable;
} audit_sums;

/* One quadrature node: direction w reaching the light at distance d, with
 * the light's density pl, carrying weight q = 1 / (M (p_brdf + p_light)). */
static void add_node(const qmc_scene_job *job, const qmc__scene_geom *g, qmc_vec3 w, double d,
                     double pl, audit_sums *a)
{
    double v = qmc__scene_shade(g, w, d) / g->radiance;
    if (!(v > 0.0) || !isfinite(v))
        return;
    double pb = qmc__scene_pdf_brdf(g, w);
    double pu = qmc__scene_pdf_uniform(g, w);
    double q = 1.0 / ((double)AUDIT_SIDE * AUDIT_SIDE * (pb + pl));
    if (!isfinite(q))
        return;
    const double cb = job->c_brdf, cl = job->c_light;
    double wt[TECHS] = {0.0, 0.0, 0.0}, p[TECHS] = {pb, pl, pu};
    switch (job->strategy) {
    case QMC_SCENE_UNIFORM:
        wt[TECH_UNIFORM] = 1.0;
        a->unreachable += !(pu > 0.0);
        break;
    case QMC_SCENE_BRDF:
        wt[TECH_BRDF] = 1.0;
        a->unreachable += !(pb > 0.0);
        break;
    case QMC_SCENE_LIGHT:
        wt[TECH_LIGHT] = 1.0;
        break;
    default:
        wt[TECH_BRDF] = qmc_scene_mis_weight(job->strategy, job->beta, cb * pb, cl * pl);
        wt[TECH_LIGHT] = qmc_scene_mis_weight(job->strategy, job->beta, cl * pl, cb * pb);
        break;
    }
    for (int t = 0; t < TECHS; t++)
        if (wt[t] > 0.0 && p[t] > 0.0) {
            double y = wt[t] * v;
            a->share[t] += y * q;
            a->second[t] += y * (y / p[t]) * q;
        }
}

uint32_t qmc__scene_audit(const void *ctx, const qmc_result *res)
{
    const qmc_scene_job *job = ctx;
    qmc__scene_geom g;
    qmc__scene_geom_init(&job->scene, &g);
    audit_sums a = {{0}, {0}, {0}, 0};
    const int mis = is_mis(job->strategy);
    a.count[TECH_BRDF] = mis ? job->c_brdf : job->strategy == QMC_SCENE_BRDF;
    a.count[TECH_LIGHT] = mis ? job->c_light : job->strategy == QMC_SCENE_LIGHT;
    a.count[TECH_UNIFORM] = job->strategy == QMC_SCENE_UNIFORM;
    for (int i = 0; i < AUDIT_SIDE; i++)
        for (int j = 0; j < AUDIT_SIDE; j++) {
            double u[2] = {(i + 0.5) / AUDIT_SIDE, (j + 0.5) / AUDIT_SIDE}, d = 0.0, pl = 0.0;
            /* the light's grid */
            qmc_vec3 w = qmc__scene_sample_light(&g, u, &d, &pl);
            if (pl > 0.0)
                add_node(job, &g, w, d, pl, &a);
            /* the BRDF's grid: only directions that reach the light carry f */
            double pb = 0.0;
            w = qmc__scene_sample_brdf(&g, u, &pb);
            pl = 0.0;
            if (pb > 0.0 && qmc__scene_hit(&g, w, &d, &pl))
                add_node(job, &g, w, d, pl, &a);
        }
    uint32_t flags = 0;
    if (a.unreachable)
        flags |= QMC_FLAG_ZERO_PDF | QMC_FLAG_ERROR_UNRELIABLE;
    /* A deterministic rule's nodes do not follow any technique's density
     * (cubature crowds them where the mass is): the count below is about
     * samples, random or low-discrepancy. */
    const double half = res->ci_high - res->estimate;
    for (int t = 0; t < TECHS && res->error_kind != QMC_ERROR_ESTIMATE; t++) {
        if (!(a.count[t] > 0.0) || !(a.share[t] > 0.0) || !(a.second[t] > 0.0))
            continue;
        /* e_t = s^2 / E[Y^2], as a ratio so that neither square overflows */
        double ess = a.share[t] / a.second[t] * a.share[t];
        double expected = (double)res->evals * a.count[t] * ess;
        if (expected < QMC_SAMPLING_MIN_NONZERO && a.share[t] * g.radiance > half)
            flags |= QMC_FLAG_MIS_UNDERSAMPLED | QMC_FLAG_ERROR_UNRELIABLE;
    }
    return flags;
}
