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

#endif
