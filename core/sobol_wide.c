/*
 * sobol_wide.c - Joe-Kuo generator matrices with 64 index columns (see
 * sobol_wide.h).
 *
 * Must not: allocate, or differ from seq_sobol.c's direction numbers in
 * the first 32 columns (both read the same compiled-in table).
 */
#include "sobol_wide.h"
#include "sobol_table.h"

void qmc__sobol_wide_columns(uint32_t dim, uint32_t cols[QMC__SOBOL_WIDE_COLS])
{
    /* 64-bit direction numbers v[k] = m_(k+1) << (63 - k) (Joe & Kuo
     * 2008, section 2, at 64 bits of precision); the column is the top 32
     * bits, as a 32-bit output keeps. */
    uint64_t v[QMC__SOBOL_WIDE_COLS];
    const qmc__sobol_poly *p = &qmc__sobol_polys[dim];
    const uint32_t s = p->degree;
    if (s == 0) {
        for (int k = 0; k < QMC__SOBOL_WIDE_COLS; k++)
            v[k] = 1ull << (63 - k);
    } else {
        for (uint32_t k = 0; k < s && k < QMC__SOBOL_WIDE_COLS; k++)
            v[k] = (uint64_t)qmc__sobol_m[p->m_offset + k] << (63 - k);
        /* The primitive polynomial's recurrence, a_1 the high bit of
         * coeffs (as in seq_sobol.c, widened). */
        for (uint32_t k = s; k < QMC__SOBOL_WIDE_COLS; k++) {
            uint64_t x = v[k - s] ^ (v[k - s] >> s);
            for (uint32_t i = 1; i < s; i++)
                if ((p->coeffs >> (s - 1 - i)) & 1u)
                    x ^= v[k - i];
            v[k] = x;
        }
    }
    for (int k = 0; k < QMC__SOBOL_WIDE_COLS; k++)
        cols[k] = (uint32_t)(v[k] >> 32);
}
