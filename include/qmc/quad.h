/*
 * qmc/quad.h - deterministic quadrature and cubature on the unit cube.
 *
 * Four families, each in its own source file:
 *
 *   - one-dimensional rules on [0,1]: composite midpoint, trapezoid and
 *     Simpson (core/quad_rules.c) and Gauss-Legendre (core/gauss_legendre.c),
 *     returned as nodes and weights;
 *   - adaptive Gauss-Kronrod for one-dimensional integrands, with QUADPACK's
 *     error estimate and roundoff tests (core/quad_gk.c);
 *   - tensor products of any one-dimensional rule in d dimensions, refused
 *     before any evaluation when n^d exceeds the caller's budget
 *     (core/quad_tensor.c);
 *   - adaptive cubature with the Genz-Malik degree-7/5 rule for low
 *     dimensions (core/cubature.c).
 *
 * Integrators take a caller-owned workspace (size it with the matching
 * *_workspace_bytes function; it must be aligned for double, as malloc's
 * memory is) and never allocate.  They fill *res on every return path
 * (qmc_result_init first): 0 means the integrator ran and res holds its best
 * estimate, its error estimate (error_kind QMC_ERROR_ESTIMATE) and flags
 * saying whether the tolerance was met (QUADPACK's habit: best estimate plus
 * status); a negative QMC_E* code means nothing was evaluated, or the
 * arguments were wrong, or the caller's interrupt hook (qmc_interrupt, see
 * qmc/integrand.h) stopped the run: QMC_ECANCELED, res then holds no
 * estimate, only the evaluations spent (res->evals).  The adaptive methods
 * and the tensor rules poll the hook every QMC_INTERRUPT_EVALS evaluations
 * or so, Gauss-Legendre nodes as they are computed for a tensor rule; the
 * rest (other nodes, workspace checks) is O(n) work at most.  Integrands
 * are called in batches and only with
 * points in [0,1)^dims: a rule node at exactly 1 (trapezoid, Simpson) is
 * passed as the largest double below 1.  Non-finite integrand values are
 * counted in res->nonfinite and raise QMC_FLAG_NONFINITE.
 *
 * Nothing here keeps global state; every function may be called from any
 * number of threads at once, each with its own workspace.
 */
#ifndef QMC_QUAD_H
#define QMC_QUAD_H

#include <stddef.h>
#include <stdint.h>

#include "qmc/error.h"
#include "qmc/integrand.h"
#include "qmc/result.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- one-dimensional rules ------------------------------------------------
 *
 * X(name, value, key, smallest n, degree of exactness as text).
 * Composite midpoint: n panels, nodes (i + 1/2)/n, exact for degree 1.
 * Composite trapezoid: n >= 2 equally spaced nodes including 0 and 1,
 * exact for degree 1.  Composite Simpson: odd n >= 3 equally spaced nodes,
 * weights h/3 (1 4 2 4 ... 4 1), exact for degree 3.  Gauss-Legendre: n
 * nodes, exact for degree 2n - 1.
 */
#define QMC_RULE1D_MAP(X)                                                      \
    X(MIDPOINT, 0, "midpoint", 1, "composite midpoint, exact for degree 1")    \
    X(TRAPEZOID, 1, "trapezoid", 2, "composite trapezoid, exact for degree 1") \
    X(SIMPSON, 2, "simpson", 3, "composite Simpson, odd n, exact for degree 3") \
    X(GAUSS_LEGENDRE, 3, "gauss-legendre", 1, "Gauss-Legendre, exact for degree 2n-1")

typedef enum qmc_rule1d {
#define QMC__RULE1D_ENUM(name, value, key, min_n, text) QMC_RULE1D_##name = (value),
    QMC_RULE1D_MAP(QMC__RULE1D_ENUM)
#undef QMC__RULE1D_ENUM
    QMC_RULE1D_COUNT
} qmc_rule1d;

/* Largest n qmc_gauss_legendre accepts: the nodes cost O(n^2) flops (about
 * half a minute at this n, 2 s at n = 16384), which is why a tensor rule
 * polls its interrupt hook while it computes them. */
#define QMC_GAUSS_LEGENDRE_MAX_N 65536u

/* Short key of a rule ("gauss-legendre"); "" for values outside the enum. */
const char *qmc_rule1d_name(qmc_rule1d rule);

/* Parses a key as written by qmc_rule1d_name.  Errors: QMC_EINVAL (NULL
 * argument), QMC_EKIND (unknown name); *rule is untouched on error. */
QMC_MUST_CHECK int qmc_rule1d_parse(const char *name, qmc_rule1d *rule);

/*
 * Checks that the rule exists and that n points are valid for it, writing a
 * one-line reason to why (may be NULL) when they are not, e.g. "simpson
 * needs an odd n >= 3, got 4".  Returns 0, QMC_EKIND or QMC_ECOUNT.
 */
QMC_MUST_CHECK int qmc_rule1d_check(qmc_rule1d rule, uint32_t n, char *why,
                                    size_t why_bytes);

/*
 * Writes the n nodes (ascending, in [0,1]) and weights (summing to 1) of a
 * rule on [0,1] to the caller's arrays x[n] and w[n].  Errors: QMC_EINVAL
 * (NULL array), QMC_EKIND, QMC_ECOUNT (n invalid for the rule, see
 * qmc_rule1d_check; Gauss-Legendre above QMC_GAUSS_LEGENDRE_MAX_N); the
 * arrays are untouched on error.
 */
QMC_MUST_CHECK int qmc_rule1d_nodes(qmc_rule1d rule, uint32_t n, double *x,
                                    double *w);

/*
 * Gauss-Legendre nodes and weights on [0,1] (x ascending, w summing to 1),
 * to full double precision: nodes near 0 to full relative precision, nodes
 * near 1 to an ulp of 1.  Errors: QMC_EINVAL (NULL array), QMC_ECOUNT (n is
 * 0 or above QMC_GAUSS_LEGENDRE_MAX_N).
 */
QMC_MUST_CHECK int qmc_gauss_legendre(uint32_t n, double *x, double *w);

/* ---- adaptive Gauss-Kronrod on [0,1] ---------------------------------------
 *
 * QUADPACK's QAG (Piessens, de Doncker-Kapenga, Ueberhuber and Kahaner,
 * "QUADPACK", Springer 1983): the interval with the largest error estimate
 * is bisected until the summed error meets max(tol_abs, tol_rel |I|).
 * No extrapolation; endpoints are never evaluated, so integrable endpoint
 * singularities (x^-1/2, log x) converge by repeated bisection.  Beyond
 * QUADPACK: when a bisection's halves disagree with their parent by more
 * than their claimed errors (a jump hidden in the nodes' end gaps), that
 * difference becomes a floor on their errors for the next bisections, so a
 * step converges slowly but its error bar keeps holding the true error.
 * No sampling rule can see a jump within 0.2% of 0 or 1 on [0,1] itself.
 *
 * Flags when the tolerance is missed (each also sets NOT_CONVERGED):
 * MAX_SUBDIV (the workspace's max_subdiv intervals are all in use), BUDGET
 * (another bisection would pass max_evals), ROUNDOFF (QUADPACK's roundoff
 * tests fired, or an interval became too small to bisect in doubles: the
 * attainable accuracy is limited, e.g. tol_rel below ~50 eps).  res->n is
 * the number of intervals, res->evals the integrand evaluations.
 */
typedef struct qmc_quad_gk_opts {
    double tol_abs;          /* >= 0 */
    double tol_rel;          /* >= 0; at least one of the two > 0 */
    uint32_t max_subdiv;     /* intervals the workspace holds, >= 1 */
    uint32_t kronrod_points; /* 15 (G7-K15) or 21 (G10-K21) */
    uint64_t max_evals;      /* hard cap; UINT64_MAX for none */
    qmc_interrupt interrupt; /* polled between bisections; fn NULL: never */
} qmc_quad_gk_opts;

/* Defaults: tol_abs 0, tol_rel 1e-10, max_subdiv 200, kronrod_points 21,
 * max_evals UINT64_MAX, no interrupt hook. */
void qmc_quad_gk_opts_init(qmc_quad_gk_opts *opts);

/* Workspace bytes for max_subdiv intervals (0 when that overflows). */
size_t qmc_quad_gk_workspace_bytes(uint32_t max_subdiv);

/*
 * Integrates the one-dimensional f over [0,1].  Returns 0 with res filled
 * (check res->flags), or: QMC_EINVAL (NULL argument, bad tolerances,
 * kronrod_points not 15 or 21, max_subdiv 0, workspace too small or
 * misaligned), QMC_EDIMS (f->dims != 1), QMC_EBUDGET (max_evals below one
 * Kronrod rule; nothing evaluated), QMC_ECANCELED (opts->interrupt fired).
 */
QMC_MUST_CHECK int qmc_quad_gk(const qmc_integrand *f,
                               const qmc_quad_gk_opts *opts, void *workspace,
                               size_t workspace_bytes, qmc_result *res);

/* ---- tensor-product rules -------------------------------------------------
 *
 * The product of a one-dimensional rule with n points per axis over
 * [0,1]^dims: n^dims evaluations, in batches.  The error estimate is the
 * difference against the same rule with a coarser n_c per axis: n/2 for
 * midpoint and Gauss-Legendre, (n+1)/2 for trapezoid, (n+1)/2 rounded down
 * to odd for Simpson (nested for n = 2^k + 1).  It is the coarse rule's
 * error, so it overstates the fine rule's error for smooth integrands.  The
 * coarse rule costs n_c^dims more evaluations, counted against the budget.
 * When no coarser rule exists (n at the rule's minimum) the error is
 * |estimate| and QMC_FLAG_ERROR_UNRELIABLE is set.  res->n is n^dims, and
 * res->abs_integral the fine rule's sum of |w f|.
 *
 * The bar is then checked by evidence that shares none of the levels'
 * nodes, as far as the budget left by the two levels allows
 * (qmc_quad_tensor_check_evals): the same rule at the two sizes above n_c
 * (n_c + 1 and n_c + 2; Simpson n_c + 2 and n_c + 4; only sizes below n),
 * and a rounding probe of 32 evaluations.  The error is at least the
 * largest difference between a sibling and the estimate (an aliased
 * frequency or a missed feature moves with the nodes; a resolved
 * integrand does not), and at least the probe's rounding floor where that
 * is above |fine - coarse| and 64 ulps of the integral of |f|
 * (QMC_FLAG_ROUNDOFF).  The estimate is the fine rule's.
 */

/* Workspace bytes for rule with n points per axis in dims dimensions (0
 * on overflow): Gauss-Legendre from 8 nodes an axis also keeps each axis's
 * marginal, (dims + 1) n doubles, for its Legendre-decay test. */
size_t qmc_quad_tensor_rule_workspace_bytes(qmc_rule1d rule, uint32_t n, uint32_t dims);

/* The same for the rule that needs the most (Gauss-Legendre): enough for
 * any rule. */
size_t qmc_quad_tensor_workspace_bytes(uint32_t n, uint32_t dims);

/* The evaluations qmc_quad_tensor's check adds to n^dims + n_c^dims when
 * the budget holds them: its two sibling levels and its rounding probe
 * (UINT64_MAX past 2^64).  A caller that fits n to a budget leaves room
 * for them. */
uint64_t qmc_quad_tensor_check_evals(qmc_rule1d rule, uint32_t n, uint32_t dims);

/*
 * Integrates f over [0,1]^f->dims.  Refuses, BEFORE evaluating anything,
 * with QMC_EBUDGET when n^dims + n_c^dims exceeds max_evals, and a reason
 * naming the cost ("tensor gauss-legendre: 64^6 + 32^6 = 69793218560
 * evaluations exceed the budget of 10000000").  interrupt (NULL, or fn
 * NULL: never) is polled while Gauss-Legendre nodes are computed (O(n^2)
 * work: tens of seconds at the largest n) and between chunks of points.
 * Other errors: QMC_EINVAL (NULL argument, workspace too small or
 * misaligned), QMC_EDIMS (dims 0), QMC_EKIND, QMC_ECOUNT (n invalid for the
 * rule), QMC_ECANCELED (the hook fired); each with a reason in why (may be
 * NULL).
 */
QMC_MUST_CHECK int qmc_quad_tensor(const qmc_integrand *f, qmc_rule1d rule,
                                   uint32_t n, uint64_t max_evals,
                                   const qmc_interrupt *interrupt,
                                   void *workspace, size_t workspace_bytes,
                                   qmc_result *res, char *why,
                                   size_t why_bytes);

/* ---- adaptive cubature (Genz-Malik) ----------------------------------------
 *
 * A. C. Genz and A. A. Malik, "An adaptive algorithm for numerical
 * integration over an n-dimensional rectangular region", J. Comput. Appl.
 * Math. 6 (1980) 295-302.  Each region gets the degree-7 rule with an
 * embedded degree-5 rule; |R7 - R5| is the region's error.  The region with
 * the largest error (a max-heap) is halved along the axis with the largest
 * fourth divided difference.  Each region costs 2^d + 2d^2 + 2d + 1
 * evaluations, so the method is for low d; at large d it is refused.
 *
 * The workspace bounds the number of regions: when it is full, cubature
 * stops with QMC_FLAG_MEMORY_BOUND (+ NOT_CONVERGED) and the estimate over
 * the regions it has.  Another split that would pass max_evals stops with
 * QMC_FLAG_BUDGET (+ NOT_CONVERGED).  res->n is the number of regions.
 * res->error is the sum of their errors (for integrands declared analytic,
 * each sharpened to the degree-7 rule's scale and the sum raised when the
 * run's own splits show it short), or, for analytic integrands at d >= 3,
 * a Richardson bound from how the whole estimate converged, when that is
 * smaller: the regions' errors cancel, their sum does not (see
 * core/cubature.c).  The loop stops on the sum, and the flags say whether
 * the sum met the tolerance.
 */
typedef struct qmc_cubature_opts {
    double tol_abs;     /* >= 0 */
    double tol_rel;     /* >= 0; at least one of the two > 0 */
    uint64_t max_evals; /* hard cap on evaluations */
    qmc_interrupt interrupt; /* polled between chunks of points, even
                                inside one region; fn NULL: never */
} qmc_cubature_opts;

/* Evaluations of the Genz-Malik rule on one region in dims dimensions,
 * 2^d + 2d^2 + 2d + 1 (UINT64_MAX when that overflows). */
uint64_t qmc_cubature_region_evals(uint32_t dims);

/* Workspace bytes for up to max_regions regions in dims dimensions (0 on
 * overflow).  Grows like max_regions * (2 dims + 3) doubles. */
size_t qmc_cubature_workspace_bytes(uint32_t dims, uint32_t max_regions);

/*
 * Integrates f over [0,1]^f->dims.  Returns 0 with res filled (check
 * res->flags), or, with a reason in why (may be NULL) and nothing
 * evaluated: QMC_EBUDGET (one region's rule needs more than max_evals
 * evaluations: "cubature: one genz-malik region in 30 dimensions needs
 * 1073743685 evaluations, over the budget of 1000000"), QMC_EINVAL (NULL
 * argument, bad tolerances, workspace too small for one region or
 * misaligned), QMC_EDIMS (dims 0).  QMC_ECANCELED ("cubature: stopped by
 * the interrupt hook after N evaluations") when opts->interrupt fired.
 */
QMC_MUST_CHECK int qmc_cubature(const qmc_integrand *f,
                                const qmc_cubature_opts *opts,
                                void *workspace, size_t workspace_bytes,
                                qmc_result *res, char *why, size_t why_bytes);

/* ---- p-adaptive tensor Clenshaw-Curtis --------------------------------------
 *
 * For analytic integrands in a few dimensions, where raising a rule's
 * degree converges exponentially and splitting regions (above) only
 * algebraically.  Each axis carries a nested Clenshaw-Curtis rule of 2^m + 1
 * points; the axis whose rule one level lower changes the answer most is
 * raised next, reusing every point.  res->n is the grid's size and
 * res->error the sum over axes of that change, extrapolated one level
 * geometrically (still an overestimate while the levels converge) and at
 * least the rounding floor 16 eps int |f|.  A refinement past max_evals
 * stops with QMC_FLAG_BUDGET, past the workspace with QMC_FLAG_MEMORY_BOUND
 * (both with NOT_CONVERGED).  The grid points include the faces of the
 * cube (1 is moved to the last double below it).
 */
#define QMC_CC_MAX_DIMS 12u

/* Workspace bytes for grids of up to max_points points (0 on overflow or
 * bad dims): about 18 bytes a point, plus the 1D tables. */
size_t qmc_cubature_cc_workspace_bytes(uint32_t dims, uint64_t max_points);

/*
 * Integrates f over [0,1]^f->dims.  Returns 0 with res filled, or with a
 * reason in why: QMC_EBUDGET (the first grid, 3^d or 5^d points, is over
 * max_evals), QMC_EDIMS (0 or over QMC_CC_MAX_DIMS), QMC_EINVAL (NULL
 * argument, no tolerance, workspace too small or misaligned), and
 * QMC_ECANCELED when opts->interrupt fired.
 */
QMC_MUST_CHECK int qmc_cubature_cc(const qmc_integrand *f, const qmc_cubature_opts *opts,
                                   void *workspace, size_t workspace_bytes,
                                   qmc_result *res, char *why, size_t why_bytes);

#ifdef __cplusplus
}
#endif
#endif /* QMC_QUAD_H */
