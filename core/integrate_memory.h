/*
 * integrate_memory.h - the workspace a deterministic rule allocates, shared
 * by integrate.c (which allocates it) and integrate_memory.c (which bounds
 * a whole call), so that the bound cannot drift from the allocation.
 */
#ifndef QMC_INTEGRATE_MEMORY_H
#define QMC_INTEGRATE_MEMORY_H

#include <stddef.h>

#include "qmc/integrate.h"

/* The bytes run_cubature allocates for Genz-Malik (cc 0) or the tensor
 * Clenshaw-Curtis grid (cc 1): spec->max_memory, or less when the budget
 * cannot fill that much. */
size_t qmc__cubature_bytes(const qmc_integrate_spec *spec, uint32_t dims, int cc);

/* auto's RQMC: the points per replicate of its first round (8 replicates,
 * QMC_SAMPLING_MIN_REPS), with or without a control variate: a power of
 * two from qmc__auto_min_first_n() to QMC_SAMPLING_BLOCK. */
uint64_t qmc__auto_first_n(uint64_t budget, int control);
uint64_t qmc__auto_min_first_n(void);

/* The sampling spec a fixed-n sampling method runs, as qmc_integrate
 * makes it (the sampler from spec->method, stratified's default k^d),
 * within the budget: what a part of the job (--part, a part session) cuts
 * into blocks.  QMC_EINVAL (with a reason) for other methods or a
 * tolerance; QMC_ECOUNT, QMC_EBUDGET as qmc_integrate. */
int qmc__fixed_sampling_spec(const qmc_integrate_spec *spec, uint32_t dims,
                             qmc_sampling_spec *out, char *why, size_t why_bytes);

/* The least budget for which auto trains a VEGAS map. */
#define QMC__AUTO_MAP_MIN_BUDGET 10000u

#endif
