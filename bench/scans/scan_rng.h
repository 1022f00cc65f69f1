/*
 * scan_rng.h - the scans' one random stream (xorshift64, uniform doubles in
 * [0,1) from its top 53 bits): a scan's draws are a function of the seed
 * it is given, so a run can be repeated and compared across builds.
 * Header-only: each scan is one C file compiled on its own.
 */
#ifndef QMC_SCAN_RNG_H
#define QMC_SCAN_RNG_H

#include <stdint.h>

static uint64_t state; /* the seed; must not be 0 */

static double u01(void)
{
    state ^= state << 13;
    state ^= state >> 7;
    state ^= state << 17;
    return (double)(state >> 11) * 0x1p-53;
}

#endif
