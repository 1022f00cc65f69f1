/*
 * integrate_memory.c - an upper bound on the memory one qmc_integrate call
 * allocates, from its spec and the integrand's dimension alone, so that a
 * server can reserve it before the call runs (qmcd's max-jobs-memory-total)
 * instead of finding out from the kernel.
 *
 * The bound follows each method's allocations in integrate.c and the
 * sampling files: a rule's one workspace; the sampling methods' block sums
 * (one qmc_sampling_sums per block, and the adaptive loop holds two rounds'
 * arrays at once); auto's VEGAS map.  It leaves out what does not grow with
 * the request (the integrand, a few sequence instances) and the block
 * workspace a caller's runner brings (qmcd's workers keep one each, bounded
 * by the number of workers, not of jobs).
 *
 * Pure computation: no allocation here.
 */
#include "integrate_memory.h"
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

/* auto's VEGAS map (vegas_map.c): its edges, widths and Jacobians at 64
 * bins an axis, and the pilot's batch buffers of 65536 values. */
static uint64_t vegas_bytes(uint32_t dims)
{
    const uint64_t bins = 64, d = dims;
    return sizeof(double) * (3 * d * (bins + 1) + 5 * 65536 + 3 * d + d * bins + 2 * (bins + 1));
}

static uint64_t max_u64(uint64_t a, uint64_t b)
{
    return a > b ? a : b;
}

uint64_t qmc_integrate_memory_bytes(const qmc_integrate_spec *spec, uint32_t dims)
{
    uint32_t n = spec->n_axis ? spec->n_axis : 17;
    qmc_quad_gk_opts g;
    qmc_quad_gk_opts_init(&g);
    switch (spec->method) {
    case QMC_METHOD_GAUSS_KRONROD:
        return qmc_quad_gk_workspace_bytes(g.max_subdiv);
    case QMC_METHOD_CUBATURE:
        return qmc__cubature_bytes(spec, dims, 0);
    case QMC_METHOD_CLENSHAW_CURTIS:
        return qmc__cubature_bytes(spec, dims, 1);
    case QMC_METHOD_MIDPOINT:
    case QMC_METHOD_TRAPEZOID:
    case QMC_METHOD_SIMPSON:
    case QMC_METHOD_GAUSS_LEGENDRE:
        return qmc_quad_tensor_workspace_bytes(n, dims);
    case QMC_METHOD_AUTO: {
        /* Whichever it picks (the rules at their default sizes), and after
         * an unresolved rule, RQMC over a VEGAS map: the rule's workspace
         * is freed before the fallback starts, so the larger of the two. */
        uint64_t rule = qmc__cubature_bytes(spec, dims, 0);
        rule = max_u64(rule, qmc__cubature_bytes(spec, dims, 1));
        if (dims == 1)
            rule = max_u64(rule, qmc_quad_gk_workspace_bytes(g.max_subdiv));
        return max_u64(rule, sat_add(sampling_bytes(spec), vegas_bytes(dims)));
    }
    default:
        return sampling_bytes(spec);
    }
}
