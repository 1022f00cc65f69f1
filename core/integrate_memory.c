/*
 * integrate_memory.c - an upper bound on the memory one qmc_integrate call
 * allocates, from its spec and the integrand's dimension alone, so that a
 * server can reserve it before the call runs (qmcd's max-jobs-memory-total)
 * instead of finding out from the kernel.
 *
 * The bound follows each method's allocations in integrate.c and the
 * sampling files: a rule's one workspace; the sampling methods' block sums
 * (one qmc_sampling_sums per block, and the adaptive loop holds two rounds'
 * arrays at once); for auto, only the rules it can reach at these dims and
 * this budget, and its RQMC's rounds counted as they run, with its VEGAS
 * map.  It leaves out what does not grow with
 * the request (the integrand, a few sequence instances) and the block
 * workspace a caller's runner brings (qmcd's workers keep one each, bounded
 * by the number of workers, not of jobs).
 *
 * Pure computation: no allocation here.
 */
#include "auto_choice.h"
#include "integrate_memory.h"
#include "rule_pilot.h"
#include "vegas_map.h"
#include "qmc/quad.h"
#include "qmc/sampling.h"

static uint64_t sat_add(uint64_t a, uint64_t b)
{
    return a > UINT64_MAX - b ? UINT64_MAX : a + b;
}

static uint64_t sat_mul(uint64_t a, uint64_t b)
{
    return b && a > UINT64_MAX / b ? UINT64_MAX : a * b;
}

size_t qmc__cubature_bytes(const qmc_integrate_spec *spec, uint32_t dims, int cc)
{
    size_t useful;
    if (cc) {
        useful = qmc_cubature_cc_workspace_bytes(dims, spec->max_evals);
    } else {
        uint64_t region = qmc_cubature_region_evals(dims);
        uint64_t regions = region ? spec->max_evals / region + 2 : 2;
        useful = qmc_cubature_workspace_bytes(
            dims, regions > UINT32_MAX ? UINT32_MAX : (uint32_t)regions);
    }
    size_t bytes = spec->max_memory > SIZE_MAX ? SIZE_MAX : (size_t)spec->max_memory;
    if (useful && bytes > useful)
        bytes = useful;
    return bytes;
}

/* The sampling methods: a round's blocks are at most the budget's points
 * in QMC_SAMPLING_BLOCK-point blocks, plus one partial block per
 * replicate; the adaptive loop keeps the previous round's sums (at most
 * half as many: n doubles) while it fills the next, so 1.5x covers it. */
static uint64_t sampling_bytes(const qmc_integrate_spec *spec)
{
    /* A fixed n (no tolerance, n as given: stratified may round an n it
     * chose itself) is one array of exactly its blocks. */
    if (spec->method != QMC_METHOD_AUTO && spec->tol_abs == 0 && spec->tol_rel == 0 &&
        (spec->method != QMC_METHOD_STRATIFIED || spec->n_given)) {
        uint64_t per_rep = spec->sampling.n / QMC_SAMPLING_BLOCK +
                           (spec->sampling.n % QMC_SAMPLING_BLOCK != 0);
        return sat_mul(sat_mul(per_rep, spec->sampling.reps), sizeof(qmc_sampling_sums));
    }
    uint64_t reps = spec->sampling.reps > QMC_SAMPLING_MAX_REPS ? spec->sampling.reps
                                                                : QMC_SAMPLING_MAX_REPS;
    uint64_t blocks = sat_add(spec->max_evals / QMC_SAMPLING_BLOCK, reps);
    return sat_mul(sat_add(blocks, blocks / 2 + reps), sizeof(qmc_sampling_sums));
}

static uint64_t max_u64(uint64_t a, uint64_t b)
{
    return a > b ? a : b;
}

/* qmc_sampling_adaptive from n0 points a replicate: each round doubles n
 * and allocates its block sums while the previous round's are still held,
 * and every round's reps x n points (per_point evaluations each) are
 * evaluated within the budget.  So the last round's n is at most the
 * largest n0 2^k with reps n per_point <= budget (and n <= 2^32), and the
 * peak is its sums and its predecessor's - for this budget and for every
 * smaller one (a tolerance met earlier, or a budget the pilot or a rule
 * cut, only ends sooner).  0 when even the first round is over the budget
 * (refused before anything is allocated). */
static uint64_t adaptive_peak_bytes(uint64_t n0, uint64_t reps, uint64_t per_point,
                                    uint64_t budget)
{
    if (n0 == 0 || n0 > QMC_SEQ_MAX_INDEX || n0 * reps * per_point > budget)
        return 0;
    uint64_t n = n0;
    while (2 * n <= QMC_SEQ_MAX_INDEX && 2 * n * reps * per_point <= budget)
        n *= 2;
    const uint64_t b = QMC_SAMPLING_BLOCK;
    uint64_t blocks = reps * ((n + b - 1) / b);
    if (n > n0)
        blocks += reps * ((n / 2 + b - 1) / b);
    return blocks * sizeof(qmc_sampling_sums);
}

/*
 * auto's RQMC (integrate.c's auto_rqmc): 8 replicates from its first n
 * (or the caller's), adaptive (a control variate doubles a point's
 * evaluations), and, when may_map, from QMC__AUTO_MAP_MIN_BUDGET on a
 * VEGAS map that lives through the
 * run (its training buffers only through the pilot).  The budget it runs
 * on is at most spec->max_evals (the pilot's and a rule's evaluations
 * come off it), which adaptive_peak_bytes covers with every smaller one.
 */
static uint64_t auto_rqmc_bytes(const qmc_integrate_spec *spec, uint32_t dims, int may_map,
                                int control)
{
    /* Its own first n is a power of two from 16 to 4096 (smaller for a
     * smaller budget), so its rounds are powers of two from 16 on; a
     * control variate doubles the evaluations a point. */
    const uint64_t n0 = spec->n_given ? spec->sampling.n : qmc__auto_min_first_n();
    uint64_t sums = adaptive_peak_bytes(n0, QMC_SAMPLING_MIN_REPS, control ? 2 : 1,
                                        spec->max_evals);
    uint64_t map = 0, train = 0;
    if (may_map && spec->max_evals >= QMC__AUTO_MAP_MIN_BUDGET)
        qmc__vmap_bytes(dims, &map, &train);
    return sat_add(map, max_u64(train, sums));
}

static uint64_t rule_bytes(const qmc_integrate_spec *spec, uint32_t dims, qmc_method m)
{
    qmc_quad_gk_opts g;
    qmc_quad_gk_opts_init(&g);
    switch (m) {
    case QMC_METHOD_GAUSS_KRONROD:
        return qmc_quad_gk_workspace_bytes(g.max_subdiv);
    case QMC_METHOD_CLENSHAW_CURTIS:
        return qmc__cubature_bytes(spec, dims, 1);
    case QMC_METHOD_CUBATURE:
        return qmc__cubature_bytes(spec, dims, 0);
    default:
        return 0;
    }
}

/* A rule's workspace, or the RQMC pilot that may check its bar after it
 * is freed (rule_pilot.h). */
static uint64_t checked_rule_bytes(const qmc_integrate_spec *spec, uint32_t dims, uint64_t rule)
{
    return max_u64(rule, qmc__rule_pilot_bytes(spec->max_evals, dims));
}

uint64_t qmc_integrate_memory_bytes_for(const qmc_integrate_spec *spec, const qmc_integrand *f,
                                        const qmc_integrand *g)
{
    if (spec->method != QMC_METHOD_AUTO || !f)
        return qmc_integrate_memory_bytes(spec, f ? f->dims : 1);
    /* The one rule auto picks for this integrand (qmc__auto_pick is its
     * own choice), then possibly RQMC, directly or after the rule; a map
     * only without a control variate and without jumps (auto_map). */
    uint64_t rule =
        checked_rule_bytes(spec, f->dims, rule_bytes(spec, f->dims, qmc__auto_pick(spec, f, g)));
    int may_map = !g && f->smoothness < QMC_SMOOTH_DISCONTINUOUS;
    return max_u64(rule, auto_rqmc_bytes(spec, f->dims, may_map, g != NULL));
}

uint64_t qmc_integrate_memory_bytes(const qmc_integrate_spec *spec, uint32_t dims)
{
    uint32_t n = spec->n_axis ? spec->n_axis : 17;
    qmc_quad_gk_opts g;
    qmc_quad_gk_opts_init(&g);
    switch (spec->method) {
    case QMC_METHOD_GAUSS_KRONROD:
        return checked_rule_bytes(spec, dims, qmc_quad_gk_workspace_bytes(g.max_subdiv));
    case QMC_METHOD_CUBATURE:
        return checked_rule_bytes(spec, dims, qmc__cubature_bytes(spec, dims, 0));
    case QMC_METHOD_CLENSHAW_CURTIS:
        return checked_rule_bytes(spec, dims, qmc__cubature_bytes(spec, dims, 1));
    case QMC_METHOD_MIDPOINT:
        return checked_rule_bytes(
            spec, dims, qmc_quad_tensor_rule_workspace_bytes(QMC_RULE1D_MIDPOINT, n, dims));
    case QMC_METHOD_TRAPEZOID:
        return checked_rule_bytes(
            spec, dims, qmc_quad_tensor_rule_workspace_bytes(QMC_RULE1D_TRAPEZOID, n, dims));
    case QMC_METHOD_SIMPSON:
        return checked_rule_bytes(
            spec, dims, qmc_quad_tensor_rule_workspace_bytes(QMC_RULE1D_SIMPSON, n, dims));
    case QMC_METHOD_GAUSS_LEGENDRE:
        return checked_rule_bytes(
            spec, dims, qmc_quad_tensor_rule_workspace_bytes(QMC_RULE1D_GAUSS_LEGENDRE, n, dims));
    case QMC_METHOD_AUTO: {
        /* Whichever rule it may pick for these dims and budget (each
         * allocates exactly its workspace: cubature's regions and the
         * Clenshaw-Curtis grid within max_memory), or RQMC, which it may
         * always pick (a non-smooth integrand, a control variate) and
         * which follows a rule left unresolved or in doubt: the rule's
         * workspace is freed before it starts, so the larger of the two. */
        uint64_t rule = 0;
        const qmc_method rules[] = {QMC_METHOD_GAUSS_KRONROD, QMC_METHOD_CLENSHAW_CURTIS,
                                    QMC_METHOD_CUBATURE};
        for (size_t i = 0; i < sizeof rules / sizeof rules[0]; i++)
            if (qmc__auto_may_use(rules[i], dims, spec->max_evals))
                rule = max_u64(rule, rule_bytes(spec, dims, rules[i]));
        /* Without the integrand: its RQMC with no control variate (the
         * longer rounds) and a map. */
        return max_u64(checked_rule_bytes(spec, dims, rule), auto_rqmc_bytes(spec, dims, 1, 0));
    }
    default:
        return sampling_bytes(spec);
    }
}
