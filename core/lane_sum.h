/*
 * lane_sum.h - a compensated sum in four interleaved lanes (private).
 *
 * One Neumaier sum is a chain of dependent additions: a sampling block
 * spent most of its own time waiting on it (one add's latency a point, for
 * each of the f, |f| and g sums).  Four lanes, each a sum of every fourth
 * value, run as one vector and break the chain.  Each lane adds with
 * Knuth's TwoSum, which yields the same exact rounding error as Neumaier's
 * branch without the branch.  Lanes fold into an ordinary Neumaier pair
 * (neumaier.h) in lane order, so a block's sum depends on its values and
 * how the caller groups them, never on the machine: the vectors are GCC /
 * clang vector extensions (SSE2, AVX or NEON alike) and -ffp-contract=off
 * keeps every step a separate rounding.
 */
#ifndef QMC_LANE_SUM_H
#define QMC_LANE_SUM_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "neumaier.h"

#if defined(__GNUC__)
#pragma GCC diagnostic ignored "-Wpsabi" /* static inline: no vector crosses an ABI */
#endif
typedef double qmc__f64x4 __attribute__((vector_size(32)));
typedef uint64_t qmc__u64x4 __attribute__((vector_size(32)));

typedef struct {
    qmc__f64x4 s, c; /* per lane: running sum and its compensation */
} qmc__lane_sum;

/* Adds one value to each lane (TwoSum: t + e == s + x exactly). */
static inline void qmc__lane_add(qmc__lane_sum *a, qmc__f64x4 x)
{
    qmc__f64x4 t = a->s + x, z = t - a->s;
    a->c += (a->s - (t - z)) + (x - z);
    a->s = t;
}

/* v[0 .. m) as vectors of four, the last one padded with zeros (adding
 * zero leaves a lane's value as it was). */
static inline qmc__f64x4 qmc__lane_load(const double *v, size_t k, size_t m)
{
    qmc__f64x4 x = {0, 0, 0, 0};
    if (m - k >= 4)
        memcpy(&x, v + k, sizeof x);
    else
        memcpy(&x, v + k, (m - k) * sizeof(double));
    return x;
}

/* |x| of each lane: the sign bit cleared, as fabs does. */
static inline qmc__f64x4 qmc__lane_abs(qmc__f64x4 x)
{
    return (qmc__f64x4)((qmc__u64x4)x & (uint64_t)INT64_MAX);
}

/* Adds the lanes, in lane order, to the Neumaier pair s. */
static inline void qmc__lane_fold(const qmc__lane_sum *a, double s[2])
{
    for (int l = 0; l < 4; l++)
        qmc__sum_add(s, a->s[l]);
    s[1] += (a->c[0] + a->c[1]) + (a->c[2] + a->c[3]);
}

#endif
