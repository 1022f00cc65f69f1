/*
 * rule_pilot.c - a rule's doubtful bar checked by a randomized pilot whose
 * points share none of the rule's nodes (see rule_pilot.h for the rule,
 * the budget and what it must not do).
 */
#include <float.h>
#include <math.h>

#include "interrupt.h"
#include "msg.h"
#include "rule_evidence.h"
#include "scaled_integrand.h"
#include "sampling_impl.h"
#include "rule_pilot.h"
#include "qmc/quad.h"
#include "qmc/sampling.h"

/* Below this many points a replicate, 16 replicate means of a bounded
 * integrand are too coarse a spread to check anything by. */
#define PILOT_MIN_POINTS 16u

/* A check, not a second integration: past this it costs time and memory
 * (a daemon reserves the pilot's block sums for a rule's budget) for a bar
 * that a rule of 8 million evaluations or more rarely needs from it. */
#define PILOT_MAX_EVALS (UINT64_C(1) << 20)

uint64_t qmc__rule_pilot_evals(uint64_t rule_evals, uint64_t left)
{
    uint64_t want = rule_evals / 8;
    if (want < QMC_INTEGRATE_CONFIRM_EVALS)
        want = QMC_INTEGRATE_CONFIRM_EVALS;
    if (want > PILOT_MAX_EVALS)
        want = PILOT_MAX_EVALS;
    if (want > left)
        want = left;
    uint64_t m = PILOT_MIN_POINTS;
    if (want / QMC_INTEGRATE_PILOT_REPS < m)
        return 0;
    while (2 * m <= want / QMC_INTEGRATE_PILOT_REPS)
        m *= 2;
    return m * QMC_INTEGRATE_PILOT_REPS;
}

/* The pilot of `evals` evaluations for a rule run by s on an integrand
 * of this smoothness.  Across a jump a scrambled net's replicates are a
 * poor witness: an axis-aligned jump cuts one stratum of each 1D
 * projection, so a replicate's error is nearly two-valued, and 16
 * replicates that all drew the common value agree on a biased mean
 * (genz-discontinuous, d = 1, u = 0.98410, 16 x 128 points: 6.8 standard
 * errors off).  Independent points have no strata to cut: plain MC, whose
 * bar is the CLT's over all of them.  Only an integrand declared analytic
 * gets the scrambled net: one declared to have kinks may be an unknown f
 * (the CLI's default for --command) with jumps it never declared. */
static void pilot_spec(const qmc_integrate_spec *s, qmc_smoothness smoothness, uint64_t evals,
                       qmc_integrate_spec *p)
{
    const int mc = smoothness != QMC_SMOOTH_ANALYTIC;
    qmc_integrate_spec_init(p);
    p->method = mc ? QMC_METHOD_MC : QMC_METHOD_RQMC;
    qmc_sampling_spec_init(&p->sampling, mc ? QMC_SAMPLER_MC : QMC_SAMPLER_RQMC);
    p->sampling.seed = s->sampling.seed;
    p->sampling.reps = mc ? 1 : QMC_INTEGRATE_PILOT_REPS;
    p->sampling.n = mc ? evals : evals / QMC_INTEGRATE_PILOT_REPS;
    p->n_given = 1;
    p->max_evals = evals;
    p->max_memory = s->max_memory;
    p->interrupt = s->interrupt;
}

uint64_t qmc__rule_pilot_bytes(uint64_t max_evals, uint32_t dims)
{
    const uint64_t evals = qmc__rule_pilot_evals(max_evals, max_evals);
    if (evals == 0)
        return 0;
    /* Block sums: 16 replicates of m points, or one sample of 16 m (no
     * more blocks); the serial workspace (the pilot runs without the
     * caller's runner); the job and its sequences, for either kind. */
    const uint64_t m = evals / QMC_INTEGRATE_PILOT_REPS;
    const uint64_t per_rep = m / QMC_SAMPLING_BLOCK + (m % QMC_SAMPLING_BLOCK != 0);
    uint64_t bytes = per_rep * QMC_INTEGRATE_PILOT_REPS * sizeof(qmc_sampling_sums);
    bytes += qmc__sampling_workspace_bytes_for(dims);
    qmc_integrate_spec rule, net, mc;
    qmc_integrate_spec_init(&rule);
    pilot_spec(&rule, QMC_SMOOTH_ANALYTIC, evals, &net);
    pilot_spec(&rule, QMC_SMOOTH_DISCONTINUOUS, evals, &mc);
    const uint64_t jn = qmc__sampling_job_bytes(&net.sampling, dims),
                   jm = qmc__sampling_job_bytes(&mc.sampling, dims);
    return bytes + (jn > jm ? jn : jm);
}

/* The tolerance rule s stopped on: the caller's, else cubature's and
 * Clenshaw-Curtis's 1e-8 and Gauss-Kronrod's 1e-10 relative (integrate.c,
 * qmc_quad_gk_opts_init); INFINITY for a tensor grid, which has none.  A raised bar
 * must still meet it: an adaptive rule never claims a tolerance the
 * evidence does not support, so it keeps its bar and its flag instead (a
 * session still ends cannot_tell). */
double qmc__rule_tolerance(const qmc_integrate_spec *s, const qmc_result *res)
{
    double tol_abs = s->tol_abs, tol_rel = s->tol_rel;
    if (tol_abs == 0.0 && tol_rel == 0.0) {
        if (s->method == QMC_METHOD_CUBATURE || s->method == QMC_METHOD_CLENSHAW_CURTIS) {
            tol_rel = QMC__CUBATURE_TOL_REL;
        } else if (s->method == QMC_METHOD_GAUSS_KRONROD) {
            qmc_quad_gk_opts g;
            qmc_quad_gk_opts_init(&g);
            tol_abs = g.tol_abs;
            tol_rel = g.tol_rel;
        } else {
            return INFINITY;
        }
    }
    return fmax(tol_abs, tol_rel * fabs(res->estimate));
}

/* One pilot of `evals` evaluations: 0 with *r and *t (its result, in f's
 * units, and the 99% quantile for its bar), QMC_ECANCELED with why set,
 * or 1 when it failed to run (too many dims for Sobol, memory).  Its
 * evaluations and non-finite values are added to res's. */
static int run_pilot(const qmc_integrate_spec *s, const qmc_integrand *f, uint64_t evals,
                     qmc_result *res, char *why, size_t why_bytes, qmc_result *r, double *t)
{
    qmc_integrate_spec p;
    pilot_spec(s, f->smoothness, evals, &p);
    qmc__scaled_integrand sf;
    qmc__scaled_integrand_init(&sf, f, res);
    qmc_integrate_report rep;
    char pwhy[160];
    int err = qmc_integrate(&p, &sf.g, NULL, NULL, NULL, &rep, pwhy, sizeof pwhy);
    qmc__unscale_result(&rep.res, sf.e);
    res->evals += rep.res.evals;
    /* values of f the rule's nodes never met, but f has them: said */
    res->nonfinite += rep.res.nonfinite;
    if (rep.res.nonfinite)
        res->flags |= QMC_FLAG_NONFINITE;
    if (err == QMC_ECANCELED) {
        qmc__msg m;
        qmc__msg_init(&m, why, why_bytes);
        qmc__msg_str(&m, "the rule's pilot: ");
        qmc__msg_str(&m, pwhy);
        return err;
    }
    if (err)
        return 1;
    *r = rep.res;
    const double df = p.method == QMC_METHOD_MC ? (double)evals - 1.0
                                                : (double)(QMC_INTEGRATE_PILOT_REPS - 1);
    *t = qmc_student_t_quantile(0.99, df);
    return 0;
}

/* Whether a pilot of `evals` can still clear the flag of a rule that
 * stopped on tolerance `tol`: only if its reach t se comes within twice
 * the larger of the bar and the tolerance.  A probe of PROBE_EVALS points
 * says: projected to `evals` at the most favourable rate (1/sqrt(n) for
 * MC, n^-1.5 for a scrambled net) and with room for the probe's own
 * noise, a reach more than 4 times that limit is not worth the points.
 * Skipping never clears a flag.  Cubature on a 3D kink at 1e-8 spent 13%
 * more evaluations on pilots that could not vouch for it. */
#define PROBE_EVALS 256u
static int probe_hopeless(const qmc_integrate_spec *s, const qmc_integrand *f, uint64_t evals,
                          double limit, qmc_result *res, char *why, size_t why_bytes)
{
    qmc_result r;
    double t;
    int err = run_pilot(s, f, PROBE_EVALS, res, why, why_bytes, &r, &t);
    if (err == QMC_ECANCELED)
        return err;
    if (err || r.error_kind != QMC_ERROR_STDERR || !isfinite(r.error))
        return 0; /* no reading: let the pilot itself decide */
    const double rate = f->smoothness == QMC_SMOOTH_ANALYTIC ? 1.5 : 0.5;
    const double projected = t * r.error * pow((double)PROBE_EVALS / (double)evals, rate);
    return projected > 4.0 * limit ? 1 : 0;
}

/* What the pilot decided about res's bar: *clear is
 * QMC_FLAG_ERROR_UNRELIABLE when it vouches for it (res->error may have
 * been raised).  0, or QMC_ECANCELED with why set. */
static int pilot_judges(const qmc_integrate_spec *s, const qmc_integrand *f, qmc_result *res,
                        char *why, size_t why_bytes, uint32_t *clear)
{
    *clear = 0;
    if (!(res->flags & QMC_FLAG_ERROR_UNRELIABLE) || (res->flags & QMC_FLAG_NONFINITE) ||
        f->smoothness >= QMC_SMOOTH_SINGULAR || !isfinite(res->estimate) ||
        !isfinite(res->error) || !(res->error >= 0.0))
        return 0;
    const uint64_t left = s->max_evals > res->evals ? s->max_evals - res->evals : 0;
    uint64_t evals = qmc__rule_pilot_evals(res->evals, left);
    if (evals == 0)
        return 0;
    const double tol = qmc__rule_tolerance(s, res);
    if (isfinite(tol) && evals >= 2 * PROBE_EVALS) {
        /* the pilot after the probe: at least PROBE_EVALS are left for it */
        evals = qmc__rule_pilot_evals(res->evals, left - PROBE_EVALS);
        int hopeless =
            probe_hopeless(s, f, evals, 2.0 * fmax(res->error, tol), res, why, why_bytes);
        if (hopeless)
            return hopeless == QMC_ECANCELED ? QMC_ECANCELED : 0;
    }
    qmc_result r;
    double t;
    int err = run_pilot(s, f, evals, res, why, why_bytes, &r, &t);
    if (err == QMC_ECANCELED)
        return err;
    if (err || r.flags != 0 || r.error_kind != QMC_ERROR_STDERR || !isfinite(r.estimate) ||
        !isfinite(r.error))
        return 0; /* too many dims for Sobol, or a pilot in doubt itself */
    if (qmc__rule_bar_vouched(res, &r, t, tol))
        *clear = QMC_FLAG_ERROR_UNRELIABLE;
    return 0;
}

int qmc__rule_bar_vouched(qmc_result *res, const qmc_result *r, double t, double tol)
{
    const double scale = fmax(fabs(res->estimate), res->abs_integral);
    const double slack = 32.0 * DBL_EPSILON * scale;
    const double gap = fabs(res->estimate - r->estimate), reach = t * r->error;
    if (gap + reach <= 2.0 * res->error + slack)
        return 1; /* the bar as it stands */
    if (gap > reach)
        return 0; /* the witness sees the rule off by more than its own noise */
    /* The witness agrees within its own resolution, which is coarser than
     * the rule's claim: the bar becomes what the witness can vouch for. */
    const double bar = 0.5 * (gap + reach);
    if (!(bar <= tol))
        return 0;
    res->error = bar;
    res->ci_low = res->estimate - bar;
    res->ci_high = res->estimate + bar;
    /* A bar raised to a tenth of the mass or more says the rule did not
     * resolve the integrand, as rule_evidence.h's test would have. */
    if (!(bar < QMC__UNRESOLVED_SHARE * fmax(fabs(res->estimate), res->abs_integral)))
        res->flags |= QMC_FLAG_UNRESOLVED;
    return 1;
}

int qmc__rule_pilot(const qmc_integrate_spec *s, const qmc_integrand *f, qmc_result *res,
                    char *why, size_t why_bytes)
{
    uint32_t clear;
    int err = pilot_judges(s, f, res, why, why_bytes, &clear);
    if (err == QMC_ECANCELED)
        return qmc__cancelled(res, res->dims, res->evals);
    res->flags &= ~clear;
    return 0;
}
