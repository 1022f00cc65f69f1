/*
 * exact_sum.h - sums of quotients num[k] / den[k] (doubles over small whole
 * numbers), computed exactly and rounded once (private to core/).
 *
 * Why: a polynomial's integral over [0,1] is sum c_k / (k + 1).  With large
 * coefficients that cancel (a shifted Legendre polynomial, (1 - 2x)^25
 * expanded: terms of 1e10 summing to 0) a floating-point sum keeps none of
 * the answer's digits - it gave -2.4e-7 for an integral of exactly 0, and
 * 6% off for P20 / 1000 - and the stability matrix judged every method
 * against that wrong "exact" value.  Here every quotient is put over the
 * common denominator L = lcm(den), the numerators num[k] (L / den[k]) are
 * added as one wide integer, and the total is divided by L and rounded to
 * the nearest double (ties to even): the result is the correctly rounded
 * value of the exact rational sum, whatever the cancellation.
 *
 * Must not: allocate (the wide integer is on the stack, 2.2 kbit), or
 * round anywhere but once at the end.
 */
#ifndef QMC_EXACT_SUM_H
#define QMC_EXACT_SUM_H

#include <stddef.h>
#include <stdint.h>

/* Denominators are 1..QMC__EXACT_MAX_DEN (lcm(1..32) < 2^48), at most
 * QMC__EXACT_MAX_TERMS terms. */
#define QMC__EXACT_MAX_DEN 32u
#define QMC__EXACT_MAX_TERMS 64u

/* Sets *out to sum num[k] / den[k] rounded to nearest, ties to even
 * (+-inf when that overflows a double).  Returns 0, or QMC_EINVAL (and *out
 * NaN) when a num is not finite, a den is outside 1..QMC__EXACT_MAX_DEN or n
 * exceeds QMC__EXACT_MAX_TERMS. */
int qmc__exact_quotient_sum(const double *num, const uint32_t *den, size_t n, double *out);

#endif
