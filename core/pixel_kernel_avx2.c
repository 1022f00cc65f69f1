/*
 * pixel_kernel_avx2.c - the pixel kernels (pixel_kernel.h) built with
 * -mavx2, 8 lanes, as qmc__pixel_emit_avx2 and qmc__pixel_nodes_avx2 (the
 * Makefile sets the flag for this file on x86-64).  pixel_kernel.c calls
 * them only when the CPU reports AVX2; -mavx2 does not enable FMA and the
 * build uses -ffp-contract=off, so the bits equal the baseline's.
 *
 * Must not: be called on a CPU without AVX2 (pixel_kernel.c asks the
 * CPU first), or differ from the baseline build in one bit.
 */
#if defined(__x86_64__) && defined(__GNUC__) && defined(__AVX2__)
#define PK_VW 8
#define PK_EMIT_NAME qmc__pixel_emit_avx2
#define PK_NODES_NAME qmc__pixel_nodes_avx2
#include "pixel_kernel.h"
#endif
