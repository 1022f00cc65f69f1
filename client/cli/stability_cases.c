/*
 * stability_cases.c - the failure cases `qmc stability` runs every method
 * on, and the method columns.
 *
 * Each case is where some method's error bar is known to go wrong (issue
 * 13's audit and the textbook failure modes): jumps, kinks, endpoint
 * singularities, infinite variance, narrow peaks in 1-5 dimensions, tiny
 * supports and tiny lights, unscrambled Halton past 10 dimensions,
 * non-power-of-two nets, tensor rules at d = 10, tiny budgets, grids that
 * alias, near-zero integrals, NaN and overflow.  References come from closed forms
 * (qmc/testfn.h) or the scene reference module (qmc_scene_reference),
 * never from a method in the matrix.  Adding a case is adding a row here.
 */
#include <stddef.h>

#include "stability.h"

/* Scenes, as text (docs/SCENES.md). */

/* A Lambert point under a sphere light that subtends 3e-4 radians:
 * uniform and BRDF sampling almost never hit it (closed form). */
static const char tiny_light[] =
    "point 0 0 0\nnormal 0 0 1\nbrdf lambert albedo 0.8\n"
    "light sphere center 0.3 0.2 10 radius 0.003 radiance 1e6\n";

/* A near-mirror Phong lobe (exponent 5000) that BRDF sampling finds and
 * light sampling rarely does (quadrature reference). */
static const char sharp_phong[] =
    "point 0 0 0\nnormal 0 0 1\nview 0.6 0 0.8\n"
    "brdf phong kd 0.05 ks 0.95 exponent 5000\n"
    "light sphere center -2 0.3 3.5 radius 0.8 radiance 8\n";

/* Radiance near the largest double: any sum of a few samples overflows
 * (closed form 1.1e307 is finite). */
static const char overflow_light[] =
    "point 0 0 0\nnormal 0 0 1\nbrdf lambert albedo 1\n"
    "light sphere center 0 0 3 radius 1 radiance 1e308\n";

/* issue 23: a Phong lobe (kd 0.5, ks 0.5, exponent 50) under a 200 x 200
 * light 0.01 above the point.  The power heuristic at beta 0.05 gives the
 * light technique about a quarter of the weight where the lobe is, right
 * above the point, where uniform area samples almost never land: 0.71
 * against 1 (closed form in tests/unit/test_stability_scenes.c). */
static const char mis_rect[] =
    "point 0 0 0\nnormal 0 0 1\nbrdf phong kd 0.5 ks 0.5 exponent 50\n"
    "light rect corner -100 -100 0.01 edge1 0 200 0 edge2 200 0 0 radiance 1\n";

/* issue 23: a narrow lobe (exponent 3000, 3e-4 of the hemisphere) about the
 * normal under a sphere light on the axis: uniform directions miss the
 * lobe and see only the diffuse 0.5% (closed form 2.6 (0.02 sin^2 + 0.98
 * (1 - cos^3002)) of the light's half-angle, in the scene tests). */
static const char narrow_lobe[] =
    "point 0 0 0\nnormal 0 0 1\nbrdf phong kd 0.02 ks 0.98 exponent 3000\n"
    "light sphere center 0 0 2 radius 1 radiance 2.6\n";

#define TINY 16

const cli_stab_case cli_stab_cases[] = {
    /* jumps and kinks */
    {.name = "jump-step-1d", .category = "jump",
     .why = "step at an irrational point: replicates of split nets can agree exactly",
     .integrand = "step", .dims = 1, .u = {0.7071}, .n_params = 1},
    {.name = "jump-disc-2d", .category = "jump",
     .why = "genz-discontinuous, jump through the middle",
     .integrand = "genz-discontinuous", .dims = 2, .a = {1, 1}, .u = {0.5, 0.5}, .n_params = 2},
    {.name = "jump-step-end-1d", .category = "jump",
     .why = "issue 23: a step 1e-9 from the end, in the gap beyond every Kronrod node",
     .integrand = "step", .dims = 1, .u = {0.999999999}, .n_params = 1},
    {.name = "jump-disc-1d", .category = "jump",
     .why = "issue 23: auto chose split-net RQMC (bar 1e-8, error 5.2e-7); the jump is declared",
     .integrand = "genz-discontinuous", .dims = 1, .a = {3}, .u = {0.41}, .n_params = 1},
    {.name = "kink-cont-3d", .category = "kink",
     .why = "genz-continuous: |x - u| kinks off the grid points",
     .integrand = "genz-continuous", .dims = 3, .a = {5, 5, 5}, .u = {0.31, 0.62, 0.47},
     .n_params = 3},
    /* endpoint singularities and infinite variance */
    {.name = "endpoint-log-1d", .category = "endpoint singularity",
     .why = "log x: integrable singularity at 0", .integrand = "log", .dims = 1},
    {.name = "infvar-invsqrt-1d", .category = "infinite variance",
     .why = "x^-1/2: finite integral 2, infinite variance, inf at x = 0",
     .integrand = "inv-sqrt", .dims = 1},
    {.name = "infvar-invsqrt-n16", .category = "infinite variance",
     .why = "x^-1/2 on 16 points: below the heavy-tail test's minimum",
     .integrand = "inv-sqrt", .dims = 1, .evals = TINY, .tiny = 1, .seeds = 64},
    /* narrow peaks, 1-5 dims */
    {.name = "peak-gauss-1d", .category = "narrow peak",
     .why = "Gaussian of width 1/300 off the rule's nodes",
     .integrand = "genz-gaussian", .dims = 1, .a = {300}, .u = {0.37}, .n_params = 1},
    {.name = "peak-gauss-2d", .category = "narrow peak",
     .why = "issue 13: auto's Clenshaw-Curtis saw 0 +- 0",
     .integrand = "genz-gaussian", .dims = 2, .a = {400, 400}, .u = {0.123, 0.777},
     .n_params = 2},
    {.name = "peak-gauss-3d", .category = "narrow peak",
     .why = "Gaussian of width 1/150 in 3 dims",
     .integrand = "genz-gaussian", .dims = 3, .a = {150, 150, 150}, .u = {0.21, 0.68, 0.43},
     .n_params = 3},
    {.name = "peak-product-4d", .category = "narrow peak",
     .why = "genz-product-peak with a = 80",
     .integrand = "genz-product-peak", .dims = 4, .a = {80, 80, 80, 80},
     .u = {0.13, 0.71, 0.52, 0.37}, .n_params = 4},
    {.name = "peak-gauss-5d", .category = "narrow peak",
     .why = "Gaussian of width 1/40 in 5 dims",
     .integrand = "genz-gaussian", .dims = 5, .a = {40, 40, 40, 40, 40},
     .u = {0.33, 0.58, 0.27, 0.81, 0.46}, .n_params = 5},
    /* tiny supports */
    {.name = "support-disc-2d", .category = "tiny support",
     .why = "issue 13: nonzero on [0,0.003]x[0,0.002] only; every sample 0",
     .integrand = "genz-discontinuous", .dims = 2, .a = {1, 1}, .u = {0.003, 0.002},
     .n_params = 2},
    /* dimensions */
    {.name = "smooth-16d", .category = "halton past 10 dims",
     .why = "genz-oscillatory at d = 16: unscrambled Halton's correlated bases",
     .integrand = "genz-oscillatory", .dims = 16},
    {.name = "tensor-10d", .category = "tensor rule at d = 10",
     .why = "genz-gaussian at d = 10: a tensor rule affords 3 points an axis",
     .integrand = "genz-gaussian", .dims = 10},
    {.name = "stratified-14d", .category = "degraded bar",
     .why = "d = 14 on 4096 points: stratified falls back to one point a stratum",
     .integrand = "genz-product-peak", .dims = 14, .evals = 4096},
    {.name = "nonpow2-4d", .category = "non-power-of-two net",
     .why = "16 x 1000 points: the net property is lost",
     .integrand = "genz-gaussian", .dims = 4, .evals = 16000},
    /* tiny budgets */
    {.name = "tiny-osc-2d", .category = "tiny budget",
     .why = "16 evaluations of a smooth integrand",
     .integrand = "genz-oscillatory", .dims = 2, .evals = TINY, .tiny = 1, .seeds = 64},
    {.name = "tiny-disc-3d", .category = "tiny budget",
     .why = "16 evaluations of a discontinuous integrand",
     .integrand = "genz-discontinuous", .dims = 3, .evals = TINY, .tiny = 1, .seeds = 64},
    /* regular grids that alias (issue 23): budgets that buy the grids,
     * Simpson 17 and 9 nodes on cos(100 x), midpoint 16 and 8 an axis on
     * cos(2 pi 16 (x + y)), with room for the rules' check */
    {.name = "alias-cos-1d", .category = "aliasing",
     .why = "issue 23: cos(100 x), Simpson's 17 and 9 nodes at one phase",
     .integrand = "cos", .dims = 1, .a = {100}, .n_params = 1, .evals = 82},
    {.name = "alias-osc-2d", .category = "aliasing",
     .why = "issue 23: 2 pi 16 an axis, in phase with 16 and 8 midpoints",
     .integrand = "genz-oscillatory", .dims = 2, .a = {100.53096491487338, 100.53096491487338},
     .u = {0, 0}, .n_params = 2, .evals = 533, .scale = 1 /* |cos| <= 1 bounds int |f| */},
    /* near-zero integrals */
    {.name = "zero-poly-1d", .category = "near-zero integral",
     .why = "-1 + 2x: integral exactly 0", .integrand = "poly", .dims = 1,
     .a = {-1, 2}, .n_params = 2, .scale = 0.5 /* int |2x - 1| */},
    {.name = "zero-osc-2d", .category = "near-zero integral",
     .why = "cos(pi/2 + pi x + pi y): integral 0 up to rounding",
     .integrand = "genz-oscillatory", .dims = 2, .a = {3.141592653589793, 3.141592653589793},
     .u = {0.25, 0}, .n_params = 2, .scale = 1 /* |cos| <= 1 bounds int |f| */},
    /* NaN and overflow */
    {.name = "overflow-disc-2d", .category = "NaN and overflow",
     .why = "exp(400 x + 400 y): values overflow to inf, the integral too",
     .integrand = "genz-discontinuous", .dims = 2, .a = {400, 400}, .u = {1, 1},
     .n_params = 2, .infinite = 1},
    /* scenes: tiny lights, sharp lobes, MIS, overflow */
    {.name = "tiny-light/uniform", .category = "tiny light",
     .why = "uniform hemisphere sampling of a 3e-4 rad light",
     .scene = tiny_light, .strategy = QMC_SCENE_UNIFORM},
    {.name = "tiny-light/brdf", .category = "tiny light",
     .why = "cosine sampling of a 3e-4 rad light",
     .scene = tiny_light, .strategy = QMC_SCENE_BRDF},
    {.name = "tiny-light/light", .category = "tiny light",
     .why = "light sampling: the right technique (control row)",
     .scene = tiny_light, .strategy = QMC_SCENE_LIGHT},
    {.name = "tiny-light/mis-balance", .category = "tiny light",
     .why = "balance heuristic: the BRDF technique draws none of the mass",
     .scene = tiny_light, .strategy = QMC_SCENE_MIS_BALANCE},
    {.name = "tiny-light/mis-power-0.05", .category = "tiny light",
     .why = "issue 13: the power heuristic with beta 0.05",
     .scene = tiny_light, .strategy = QMC_SCENE_MIS_POWER, .beta = 0.05},
    {.name = "mis-rect/mis-power-0.05", .category = "MIS",
     .why = "issue 23: beta 0.05 starves the light technique under a 200 x 200 light (0.71 "
            "against 1)",
     .scene = mis_rect, .strategy = QMC_SCENE_MIS_POWER, .beta = 0.05},
    {.name = "lobe3000/uniform-n16", .category = "narrow peak",
     .why = "issue 23: 16 points a replicate, uniform directions: every replicate misses the "
            "lobe",
     .scene = narrow_lobe, .strategy = QMC_SCENE_UNIFORM, .evals = 256},
    {.name = "phong5000/light", .category = "narrow peak",
     .why = "light sampling of a near-mirror lobe",
     .scene = sharp_phong, .strategy = QMC_SCENE_LIGHT},
    {.name = "phong5000/brdf-n16", .category = "tiny budget",
     .why = "issue 13: --n 16 on a Phong exponent of 5000",
     .scene = sharp_phong, .strategy = QMC_SCENE_BRDF, .evals = TINY, .tiny = 1, .seeds = 64},
    {.name = "phong5000/mis-max", .category = "narrow peak",
     .why = "the maximum heuristic on a near-mirror lobe",
     .scene = sharp_phong, .strategy = QMC_SCENE_MIS_MAX},
    {.name = "overflow-light/light", .category = "NaN and overflow",
     .why = "issue 13: radiance 1e308 overflows the sums (estimate -nan)",
     .scene = overflow_light, .strategy = QMC_SCENE_LIGHT},
    {.name = "overflow-light/mis-power", .category = "NaN and overflow",
     .why = "radiance 1e308 under MIS",
     .scene = overflow_light, .strategy = QMC_SCENE_MIS_POWER},
};
const size_t cli_stab_case_count = sizeof cli_stab_cases / sizeof cli_stab_cases[0];

const char *const cli_stab_methods[] = {
    "midpoint", "trapezoid", "simpson", "gauss-legendre", "gauss-kronrod",
    "cubature", "clenshaw-curtis",
    "mc", "stratified", "lhs",
    "qmc/sobol/none", "qmc/halton/none", "qmc/halton/faure", "qmc/hammersley/none",
    "rqmc/sobol/owen", "rqmc/sobol/shift", "rqmc/halton/owen",
    "auto",
};
const size_t cli_stab_method_count = sizeof cli_stab_methods / sizeof cli_stab_methods[0];
