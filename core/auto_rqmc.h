/*
 * auto_rqmc.h - the RQMC `auto` runs, chosen first or after a rule
 * (private to core/; integrate.c runs it, auto_rqmc.c says why each
 * setting is what it is).
 */
#ifndef QMC_AUTO_RQMC_H
#define QMC_AUTO_RQMC_H

#include <stddef.h>
#include <stdint.h>

#include "msg.h"
#include "vegas_map.h"
#include "qmc/integrate.h"

/* auto's RQMC on *f within s->max_evals, g the control variate (NULL:
 * none): a VEGAS map when its pilot pays (no control variate), then the
 * replicates in s->sampling (n_given set).  *f becomes f over the map,
 * *map is the caller's to free (NULL: none), *pilot the map pilot's
 * evaluations, which leave s->max_evals.  Appends to rep->auto_reason.
 * 0, or QMC_ECANCELED / QMC_ENOMEM with why set. */
int qmc__auto_rqmc_setup(qmc_integrate_spec *s, const qmc_integrand **f,
                         const qmc_integrand *g, qmc_integrate_report *rep, qmc__vmap **map,
                         uint64_t *pilot, qmc__msg *why);

/* a, v and b onto auto's reason, without cutting what is there. */
void qmc__auto_reason_append(char *reason, size_t bytes, const char *a, uint64_t v,
                             const char *b);

#endif
