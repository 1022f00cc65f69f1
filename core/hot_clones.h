/*
 * hot_clones.h - QMC__AVX2_CLONE: a hot loop built twice, for the baseline
 * instruction set and for AVX2, the copy chosen once when the library
 * loads (GNU ifunc, so x86-64 glibc and GCC; private to core/).
 *
 * The vector-extension loops (lane_sum.h) are written for 4 doubles: the
 * x86-64 baseline (SSE2) splits each into two halves, AVX2 runs it as one
 * instruction.  Only IEEE additions, subtractions, multiplications and
 * comparisons are involved, and AVX2 has no fused multiply-add (that is
 * the separate FMA extension; -ffp-contract=off forbids it anyway), so
 * both copies give the same bits: only the speed depends on the CPU.
 */
#ifndef QMC_HOT_CLONES_H
#define QMC_HOT_CLONES_H

#include <stdlib.h> /* defines __GLIBC__ on glibc: ifunc needs it (musl has none) */

/* GCC only: clang 14 rejects the baseline copy's calls to the inlined
 * 4-double helpers ("AVX vector argument ... changes the ABI") even when
 * nothing crosses a call; its builds (sanitizers, fuzzing) take the
 * baseline loop, which gives the same bits. */
#if defined(__x86_64__) && defined(__GLIBC__) && defined(__GNUC__) && \
    !defined(__clang__) && __GNUC__ >= 6
#define QMC__AVX2_CLONE __attribute__((target_clones("avx2", "default")))
#else
#define QMC__AVX2_CLONE
#endif

#endif
