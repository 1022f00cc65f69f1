/*
 * auto_choice.c - which method `auto` runs (auto_choice.h): the measured
 * reasons below, and the budget conditions the memory bound shares.
 */
#include "auto_choice.h"
#include "msg.h"
#include "quad_impl.h"
#include "qmc/quad.h"

/*
 * auto, measured by bench/bench_integrate.c against GSL and cubature, over
 * 8 draws of each Genz family (geometric mean error):
 *  - smooth 1D: Gauss-Kronrod;
 *  - on analytic integrands whose budget affords the tensor Clenshaw-Curtis
 *    rule at 17 points an axis (17^d evaluations: d <= 5 in practice),
 *    that rule raised axis by axis (cubature_cc.c): at d = 2 and 3 it
 *    reached rounding (1e-14 of int |f|) with a few thousand evaluations
 *    at every budget, 10-10^5x ahead of Genz-Malik; at d = 4 it won from
 *    1e5 evaluations (17^4 = 83521) and lost 12-118x at 1e4; at d = 5 it
 *    won 18-100x at 1e7 (1e-14 of int |f| in 0.09 s) but lost on
 *    product-peak at 1e6; at d = 6 it mostly lost;
 *  - on the other analytic integrands up to 10 dimensions, cubature's degree-7 rule
 *    as soon as the budget buys one region (1245 evaluations at d = 10):
 *    even that single region beat RQMC with as many points by 2x to 400x
 *    at d = 10 on the four analytic families, at both the fixed and the
 *    testpack difficulty;
 *  - on continuous integrands (kinks), cubature only up to 4 dimensions
 *    and when the budget buys QMC_AUTO_MIN_REGIONS regions: at d = 3 it
 *    beat RQMC 13x, at d = 4 it won at 1e5 evaluations and lost 1.7x at
 *    1e4, and at d = 5 RQMC won 3.4x; its bar there rests on its own
 *    nodes, so with half the budget left RQMC follows it and vouches for
 *    that bar or replaces the answer (integrate.c, auto_witness);
 *  - everywhere else randomized QMC (owen-scrambled Sobol), whose error
 *    bar stays honest at any dimension and smoothness.
 */
enum { QMC_AUTO_MIN_REGIONS = 50, QMC_AUTO_CONTINUOUS_MAX_DIMS = 4 };

/* 17^d, the tensor Clenshaw-Curtis grid at level 4 on every axis
 * (UINT64_MAX past 2^64). */
static uint64_t cc_full_grid(uint32_t d)
{
    uint64_t p = 1;
    for (uint32_t j = 0; j < d; j++) {
        if (p > UINT64_MAX / 17)
            return UINT64_MAX;
        p *= 17;
    }
    return p;
}

/* The budget conditions of auto's rules, shared with the memory bound
 * (integrate_memory.h), so that the bound covers exactly the rules auto can
 * reach: Clenshaw-Curtis when the budget buys 17 points an axis, cubature
 * when it buys min_regions regions. */
static int cc_affordable(uint32_t d, uint64_t budget)
{
    return d <= QMC_CC_MAX_DIMS && budget >= cc_full_grid(d);
}

static int cubature_affordable(uint32_t d, uint64_t budget, uint64_t min_regions)
{
    const uint64_t region = qmc_cubature_region_evals(d);
    return region > 0 && budget / min_regions >= region;
}

int qmc__auto_may_use(qmc_method m, uint32_t dims, uint64_t budget)
{
    switch (m) {
    /* In 1 dimension an integrand smooth enough for a rule, without a
     * control variate, always gets Gauss-Kronrod first. */
    case QMC_METHOD_GAUSS_KRONROD:
        return dims == 1;
    case QMC_METHOD_CLENSHAW_CURTIS:
        return dims > 1 && cc_affordable(dims, budget);
    case QMC_METHOD_CUBATURE: /* the analytic case reaches furthest */
        return dims > 1 && dims <= QMC_AUTO_CUBATURE_MAX_DIMS &&
               cubature_affordable(dims, budget, 1);
    default:
        return m == QMC_METHOD_RQMC;
    }
}

qmc_method qmc__auto_choice(const qmc_integrate_spec *spec, const qmc_integrand *f,
                            const qmc_integrand *g, char *reason, size_t bytes)
{
    qmc__msg m;
    qmc__msg_init(&m, reason, bytes);
    const int analytic = f->smoothness == QMC_SMOOTH_ANALYTIC;
    const int smooth = f->smoothness <= QMC_SMOOTH_CONTINUOUS;
    const uint32_t d = f->dims;
    if (!g && smooth && d == 1) {
        qmc__msg_str(&m, "gauss-kronrod: 1 dimension and a smooth integrand");
        return QMC_METHOD_GAUSS_KRONROD;
    }
    /* Jumps at declared places are no jumps to Gauss-Kronrod, which starts
     * from them: each piece is smooth and its bar QUADPACK's.  RQMC's split
     * nets on genz-discontinuous (d = 1, jump at 0.41) reported 1.0e-8
     * against an error of 5.2e-7; Gauss-Kronrod from the jump is exact. */
    if (!g && d == 1 && f->smoothness == QMC_SMOOTH_DISCONTINUOUS && qmc__gk_breaks_usable(f)) {
        qmc__msg_set(&m, "gauss-kronrod: 1 dimension, and the integrand declares where its ",
                     f->n_breaks, f->n_breaks == 1 ? " jump is (the rule starts from it)"
                                                   : " jumps are (the rule starts from them)");
        return QMC_METHOD_GAUSS_KRONROD;
    }
    /* A declared singularity in 1D: Gauss-Kronrod bisects toward it and,
     * when it converges, leaves the unbounded part below its tolerance
     * (x^-1/2 to 1e-11 of 2 in 2751 evaluations at its default tolerance), where
     * RQMC's variance is infinite and its bar flagged (x^-1/2 at 2e7:
     * 2.0002 +- 0.0006, heavy_tail).  A run that does not converge is
     * flagged by the rule itself (quad_gk.c), a converged one must agree
     * with a second run at a sixteenth of the tolerance (rule_confirm.c),
     * and one that lands on the singularity (a non-finite value) hands
     * the rest of the budget to RQMC (integrate.c). */
    if (!g && d == 1 && f->smoothness == QMC_SMOOTH_SINGULAR) {
        qmc__msg_str(&m, "gauss-kronrod: 1 dimension and a declared singularity (the rule "
                         "bisects toward it; rqmc's variance may be infinite)");
        return QMC_METHOD_GAUSS_KRONROD;
    }
    if (!g && analytic && cc_affordable(d, spec->max_evals)) {
        qmc__msg_set(&m, "clenshaw-curtis: ", d, " dimensions, an integrand declared smooth and "
                     "a budget for 17 points an axis (17^d)");
        return QMC_METHOD_CLENSHAW_CURTIS;
    }
    const uint64_t min_regions = analytic ? 1 : QMC_AUTO_MIN_REGIONS;
    const int affordable = cubature_affordable(d, spec->max_evals, min_regions);
    const uint32_t max_dims = analytic ? QMC_AUTO_CUBATURE_MAX_DIMS
                                       : QMC_AUTO_CONTINUOUS_MAX_DIMS;
    if (!g && smooth && d <= max_dims && affordable) {
        qmc__msg_set(&m, "cubature: ", d, analytic ? " dimensions and an integrand declared "
                                                     "smooth (cubature up to "
                                                   : " dimensions and an integrand declared "
                                                     "continuous (cubature up to ");
        qmc__msg_u64(&m, max_dims);
        qmc__msg_str(&m, analytic ? " dims when the budget buys one region)"
                                  : " dims when the budget buys 50 regions)");
        return QMC_METHOD_CUBATURE;
    }
    qmc__msg_str(&m, "rqmc (owen-scrambled sobol): ");
    if (g)
        qmc__msg_str(&m, "a control variate was given, ");
    if (!smooth)
        qmc__msg_str(&m, "a non-smooth integrand, ");
    qmc__msg_u64(&m, d);
    if (smooth && !g && d <= max_dims)
        qmc__msg_str(&m, analytic ? " dimensions, but the budget buys no cubature region"
                                  : " dimensions, but the budget buys fewer than 50 cubature "
                                    "regions");
    else if (smooth && !g)
        qmc__msg_str(&m, " dimensions (above cubature's range)");
    else
        qmc__msg_str(&m, " dimensions");
    return QMC_METHOD_RQMC;
}

qmc_method qmc__auto_pick(const qmc_integrate_spec *spec, const qmc_integrand *f,
                          const qmc_integrand *g)
{
    char reason[8]; /* the choice only */
    return qmc__auto_choice(spec, f, g, reason, sizeof reason);
}
