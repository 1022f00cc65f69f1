/*
 * quad_impl.h - the interruptible node computations behind qmc_rule1d_nodes
 * and qmc_gauss_legendre, shared by quad_rules.c, gauss_legendre.c and
 * quad_tensor.c (private to core/).
 */
#ifndef QMC_QUAD_IMPL_H
#define QMC_QUAD_IMPL_H

#include <stdint.h>

#include "interrupt.h"
#include "qmc/quad.h"

/* qmc_gauss_legendre, polling poll (NULL: never) as the O(n^2) work goes:
 * returns QMC_ECANCELED, with x and w partly written, when it fires. */
int qmc__gauss_legendre(uint32_t n, double *x, double *w, qmc__poll *poll);

/* qmc_rule1d_nodes, polling poll (NULL: never) for Gauss-Legendre, the only
 * rule whose nodes cost more than O(n). */
int qmc__rule1d_nodes(qmc_rule1d rule, uint32_t n, double *x, double *w, qmc__poll *poll);

/* Whether f declares breaks that Gauss-Kronrod can start from
 * (qmc_integrand.breaks: 1D, 1..QMC_INTEGRAND_MAX_BREAKS points strictly
 * inside (0,1), strictly ascending).  qmc_quad_gk refuses other breaks
 * with QMC_EINVAL; auto asks here before it picks the rule. */
int qmc__gk_breaks_usable(const qmc_integrand *f);

#endif /* QMC_QUAD_IMPL_H */
