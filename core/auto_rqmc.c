/*
 * auto_rqmc.c - the RQMC that `auto` runs (auto_rqmc.h): a VEGAS map when
 * its pilot pays, 8 replicates, split nets, and the first round's size.
 */
#include <math.h>
#include <string.h>

#include "auto_rqmc.h"
#include "integrate_memory.h"
#include "qmc/sampling.h"

/*
 * auto's RQMC may run over a VEGAS map (vegas_map.h): a pilot trains it
 * (pilot_evals: a tenth of the budget or what the RQMC rounds would leave
 * unspent, at most AUTO_PILOT_MAX evaluations, 12 rounds of about 11000
 * points, which trains a map at d = 30 as well as 1e6 did and keeps a
 * tolerance-driven job with the default budget of 1e8 from spending a
 * million evaluations on its pilot; only for budgets of
 * AUTO_PILOT_MIN_BUDGET or more), and RQMC integrates f J over
 * the map when the pilot's variance under the map is AUTO_MAP_GAIN times
 * below plain f's.  The gain must be large because the map's bin edges
 * are jumps in f J, which cost QMC part of its edge on smooth integrands;
 * peaks, corners and support confined to a box gain far more than that.
 * The pilot's evaluations count against the budget either way.  Not for
 * integrands that declare jumps: the bin that straddles a jump is wide on
 * its zero side, so the rare points that land there with f != 0 carry
 * large weights (the heavy-tail test fired on 6 of 12 draws of the
 * discontinuous Genz family at d = 20), and over 8 draws the error was
 * 1.4x worse than plain RQMC's.
 */
enum { AUTO_PILOT_SHARE = 10, AUTO_MAP_GAIN = 16, AUTO_MAP_AGREE = 3 };
/* (integrate_memory.h's QMC__AUTO_MAP_MIN_BUDGET must equal it.) */
#define AUTO_PILOT_MIN_BUDGET 10000u
_Static_assert(AUTO_PILOT_MIN_BUDGET == QMC__AUTO_MAP_MIN_BUDGET, "the bound's map budget");
#define AUTO_PILOT_MAX (1u << 17)

/* The pilot's evaluations out of a budget.  RQMC's rounds double n, so
 * once they reuse each other (8 x 4096 points and up) they end at the
 * largest 8 x 2^k that fits and leave the rest unspent - a third of a
 * budget of 1e5.  The pilot takes that rest rather than a tenth: at
 * d = 30 a pilot of 1e4 evaluations never trained a map that helped the
 * corner peak, one of 3.4e4 did in half the draws (the error over 50-200
 * draws fell 13-21x), at no cost in RQMC points; where no map helps
 * (the oscillatory family) the pilot stops after 4 of its rounds, which
 * at d = 20 costs 0.8 ms more than the smaller pilot did. */
static uint64_t pilot_evals(uint64_t budget)
{
    uint64_t evals = budget / AUTO_PILOT_SHARE;
    uint64_t main_run = (uint64_t)QMC_SAMPLING_MIN_REPS * QMC_SAMPLING_BLOCK;
    if (main_run <= budget - evals) {
        while (2 * main_run <= budget - evals)
            main_run *= 2;
        evals = budget - main_run;
    }
    return evals > AUTO_PILOT_MAX ? AUTO_PILOT_MAX : evals;
}

/* Appends to auto's reason without cutting what is there. */
void qmc__auto_reason_append(char *reason, size_t bytes, const char *a, uint64_t v,
                             const char *b)
{
    qmc__msg m;
    size_t len = strlen(reason);
    qmc__msg_init(&m, reason + len, bytes - len);
    qmc__msg_set(&m, a, v, b);
}

static int auto_map(const qmc_integrate_spec *spec, const qmc_integrand *f, qmc__vmap **map,
                    uint64_t *pilot, char *reason, size_t bytes)
{
    *map = NULL;
    *pilot = 0;
    if (f->dims > QMC__VMAP_MAX_DIMS || spec->max_evals < AUTO_PILOT_MIN_BUDGET ||
        f->smoothness >= QMC_SMOOTH_DISCONTINUOUS)
        return 0;
    const uint64_t evals = pilot_evals(spec->max_evals);
    qmc__vmap_report vr;
    qmc__vmap *m = NULL;
    int err = qmc__vmap_train(f, evals, spec->sampling.seed, &spec->interrupt, &m, &vr);
    *pilot = vr.evals;
    if (err == QMC_EBUDGET || err == QMC_EDIMS)
        return 0;
    if (err)
        return err;
    if (!m)
        return 0; /* non-finite values: plain RQMC counts and flags them */
    /* Both rounds estimate the same integral: a map whose round disagrees
     * with the plain one by more than AUTO_MAP_AGREE standard errors has
     * missed mass that its own variance cannot show (rare points of huge
     * weight, the failure of a product of per-axis Jacobians when the
     * pilot was too thin for the dimension). */
    const double n = (double)vr.round_points;
    const double spread = sqrt(vr.var_plain / n + vr.var_mapped / n);
    const int agree = fabs(vr.mean_mapped - vr.mean_plain) <= AUTO_MAP_AGREE * spread;
    if (agree && vr.var_mapped * AUTO_MAP_GAIN <= vr.var_plain) {
        *map = m;
        double gain = vr.var_mapped > 0 ? vr.var_plain / vr.var_mapped : 1e6;
        qmc__auto_reason_append(reason, bytes, "; over a VEGAS map (a pilot of ", vr.evals,
                      " evaluations cut the variance ");
        qmc__auto_reason_append(reason, bytes, "", (uint64_t)(gain > 1e6 ? 1e6 : gain), "x)");
    } else {
        qmc__vmap_free(m);
        qmc__auto_reason_append(reason, bytes, "; a VEGAS map's pilot (", vr.evals,
                      agree ? " evaluations) did not cut the variance 16x"
                            : " evaluations) disagreed with the plain round");
    }
    return 0;
}

/* auto's RQMC: 8 replicates (the fewest that keep the interval reliable,
 * QMC_SAMPLING_MIN_REPS; the coverage test checks them), and a first round
 * sized from the budget - at most 4096 points, so later rounds reuse it
 * whole, and at least what leaves room for doubling.  (Under 4096 points a
 * round is not reused, so a budget of 1e4 ends after one round of 8 x 512
 * points.  Spending it all, 8 x 1024, was measured: the error fell 1.5-2x
 * and the time doubled, which at d >= 20 let GSL's Sobol at 1e4 finish
 * first and beat it - 7 (family, d) pairs lost the equal-time target for
 * one gained.)
 *
 * The replicates split one net (qmc_sampling_spec.split_net): replicate r
 * is points [r n, (r+1) n) of one scrambled sequence, so the estimate is
 * that of one net of 8 n points, and the spread of the blocks - each a net
 * of n - overstates its error.  With jumps a net's error falls like 1/N,
 * so 8 independent nets of N/8 were sqrt(8) = 2.8x less accurate than one
 * of N (bench_integrate, the discontinuous family, every d).  Smooth
 * integrands gain more (N^-3/2): over 200 draws at budgets 1e5 and 1e6,
 * 2-6x on the Gaussian, product-peak, oscillatory and continuous families
 * at d = 5-30, and 1.1-2.3x on the corner peak, with the interval
 * covering 93-100% of the time against 92-98% for independent nets.  But
 * the blocks share the sequence's scramble, and the part of the error that
 * comes from it is the same in every block, out of sight of their spread:
 * at 8 x 512 points the corner peak at d = 30 covered 88.5% and lost 1.2x.
 * So smooth integrands split only from AUTO_SPLIT_MIN_N points a
 * replicate; integrands with jumps always (test_coverage). */
#define AUTO_SPLIT_MIN_N QMC_SAMPLING_BLOCK

enum { AUTO_MIN_FIRST_N = 16 };

uint64_t qmc__auto_first_n(uint64_t budget, int control)
{
    const uint64_t per_point = (uint64_t)QMC_SAMPLING_MIN_REPS * (control ? 2 : 1);
    uint64_t n = QMC_SAMPLING_BLOCK;
    while (n > AUTO_MIN_FIRST_N && n * per_point * 2 > budget)
        n /= 2;
    return n;
}

uint64_t qmc__auto_min_first_n(void)
{
    return AUTO_MIN_FIRST_N;
}

static qmc_sampling_spec auto_rqmc(const qmc_integrate_spec *spec, const qmc_integrand *f,
                                   const qmc_integrand *g, char *reason, size_t bytes)
{
    qmc_sampling_spec r;
    qmc_sampling_spec_init(&r, QMC_SAMPLER_RQMC);
    r.seed = spec->sampling.seed;
    r.confidence = spec->sampling.confidence;
    r.reps = QMC_SAMPLING_MIN_REPS; /* qmc__auto_first_n assumes it */
    r.n = spec->n_given ? spec->sampling.n : qmc__auto_first_n(spec->max_evals, g != NULL);
    const int jumps = f->smoothness >= QMC_SMOOTH_DISCONTINUOUS;
    if (jumps || r.n >= AUTO_SPLIT_MIN_N) {
        r.split_net = 1;
        qmc__auto_reason_append(reason, bytes, "; its ", r.reps,
                      jumps ? " replicates split one net (more accurate with jumps; a "
                              "conservative bar)"
                            : " replicates split one net (more accurate than independent "
                              "nets; a conservative bar)");
    }
    return r;
}

/* auto's RQMC: a VEGAS map when its pilot pays (no control variate), then
 * the replicates; *f becomes f over the map, *map is the caller's to free,
 * and the pilot's evaluations leave s->max_evals. */
int qmc__auto_rqmc_setup(qmc_integrate_spec *s, const qmc_integrand **f,
                         const qmc_integrand *g, qmc_integrate_report *rep, qmc__vmap **map,
                         uint64_t *pilot, qmc__msg *why)
{
    *map = NULL;
    *pilot = 0;
    if (!g) {
        int err = auto_map(s, *f, map, pilot, rep->auto_reason, sizeof rep->auto_reason);
        if (err) {
            qmc__msg_str(why, err == QMC_ECANCELED ? "interrupted"
                                                   : "out of memory for the VEGAS map");
            return err;
        }
        s->max_evals -= *pilot;
    }
    /* f's own smoothness: f J over a map declares the jumps at its bin
     * edges, but they are not what the split is for. */
    s->sampling = auto_rqmc(s, *f, g, rep->auto_reason, sizeof rep->auto_reason);
    if (*map)
        *f = qmc__vmap_integrand(*map);
    s->n_given = 1;
    return 0;
}
