/*
 * pixel_kernel_avx512.c - the pixel kernels (pixel_kernel.h) built with
 * AVX-512 (F, VL, BW, DQ; the Makefile sets the flags for this file on
 * x86-64), 16 lanes, as qmc__pixel_emit_avx512 and qmc__pixel_nodes_avx512.
 * pixel_kernel.c calls them only when the CPU reports those extensions;
 * the bits equal the baseline build's.
 *
 * Must not: be called on a CPU without AVX-512 F, VL, BW and DQ
 * (pixel_kernel.c asks the CPU first), or differ from the baseline build
 * in one bit.
 */
#if defined(__x86_64__) && defined(__GNUC__) && defined(__AVX512BW__)
#define PK_VW 16
#define PK_EMIT_NAME qmc__pixel_emit_avx512
#define PK_NODES_NAME qmc__pixel_nodes_avx512
#include "pixel_kernel.h"
#endif
