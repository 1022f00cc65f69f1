/*
 * vegas_map.h - a separable adaptive importance map (private to core/).
 *
 * Lepage's VEGAS grid (J. Comput. Phys. 27 (1978) 192; and "Adaptive
 * multidimensional integration: vegas enhanced", J. Comput. Phys. 439
 * (2021) 110386): each axis gets a piecewise-linear map from u in [0,1) to
 * x in [0,1) with N bins of equal probability in u and adapted widths in
 * x, so that the sampling density is large where |f| is, axis by axis.
 * The map is trained on a few pilot rounds, then frozen; the integral of
 * f over x equals the integral of f(x(u)) J(u) over u for any such map,
 * so an RQMC estimate over u with the frozen map is unbiased and its
 * replicates stay independent: the error bar stays honest.
 *
 * auto uses it in front of RQMC when the pilot shows the map cuts the
 * variance enough to pay for the pilot (core/integrate.c).  Must not: keep
 * state between calls, or allocate in the mapped integrand's eval (it
 * runs on many threads at once and uses a stack buffer).
 */
#ifndef QMC_VEGAS_MAP_H
#define QMC_VEGAS_MAP_H

#include <stdint.h>

#include "qmc/integrand.h"

/* Dimensions the map is offered for: the Jacobian is a product over the
 * axes, and past about a hundred factors it can under- or overflow. */
#define QMC__VMAP_MAX_DIMS 128u

typedef struct qmc__vmap qmc__vmap;

typedef struct qmc__vmap_report {
    uint64_t evals;        /* pilot evaluations made */
    uint32_t rounds, bins; /* pilot rounds run and bins per axis */
    double var_plain;      /* variance of f over the first round (no map) */
    double var_mapped;     /* variance of f J over the last round's map */
    double mean_plain;     /* the two rounds' means of f and of f J */
    double mean_mapped;
    uint64_t round_points; /* points per round */
    int nonfinite;         /* the pilot met a non-finite value: no map */
} qmc__vmap_report;

/*
 * Trains a map for f with about pilot_evals evaluations, from seed.  On
 * success *out is the map (the caller frees it) and *rep says what the
 * pilot saw; when the pilot met a non-finite value, *out is NULL,
 * rep->nonfinite is set and 0 is returned (the caller integrates without a
 * map and flags the values then).  Errors: QMC_EDIMS (f->dims past
 * QMC__VMAP_MAX_DIMS), QMC_EBUDGET (pilot_evals too small to train for f->dims),
 * QMC_ENOMEM, QMC_ECANCELED (hook, which may be NULL, fired).  Deterministic: the same (f, pilot_evals, seed) gives the
 * same map bit for bit.
 */
int qmc__vmap_train(const qmc_integrand *f, uint64_t pilot_evals, uint64_t seed,
                    const qmc_interrupt *hook, qmc__vmap **out, qmc__vmap_report *rep);

/* What a map of f->dims = dims allocates, at most (any pilot): the map
 * itself, kept while it is used, and training's batch buffers, freed
 * when qmc__vmap_train returns.  0 and 0 above QMC__VMAP_MAX_DIMS. */
void qmc__vmap_bytes(uint32_t dims, uint64_t *map_bytes, uint64_t *train_bytes);

/* f(x(u)) J(u) as an integrand on [0,1)^dims, valid while the map lives;
 * it declares the same exact integral and int |f| as f. */
const qmc_integrand *qmc__vmap_integrand(const qmc__vmap *m);

/* Bin edges of axis `axis` (bins + 1 values, 0 first and 1 last). */
const double *qmc__vmap_edges(const qmc__vmap *m, uint32_t axis);

void qmc__vmap_free(qmc__vmap *m);

#endif
