/*
 * exact_sum.c - exact sums of quotients of doubles by small whole numbers,
 * rounded once (see exact_sum.h for why and for what it must not do).
 *
 * Every finite double is M 2^E with M < 2^53 a whole number and E >=
 * -1074, so num[k] (L / den[k]) is a whole multiple of 2^-1074 below
 * 2^(1024 + 48) and their sum, in units of 2^-1074, a whole number below
 * 2^2152: WIDE_LIMBS 32-bit limbs hold it with room to spare.  Positive
 * and negative terms go to two such numbers; the smaller is subtracted
 * from the larger, the difference divided by L (remainder kept), and the
 * quotient rounded to 53 bits with the remainder as the last sticky bit.
 */
#include <math.h>
#include <string.h>

#include "exact_sum.h"
#include "qmc/error.h"

enum { WIDE_LIMBS = 70 }; /* 2240 bits */

typedef struct wide {
    uint32_t limb[WIDE_LIMBS]; /* least significant first */
} wide;

/* w += v 2^bit (v < 2^64, bit + 64 within the number). */
static void add_at(wide *w, uint64_t v, unsigned bit)
{
    unsigned i = bit / 32, b = bit % 32;
    /* v 2^b spans up to three limbs */
    uint64_t lo = v << b, hi = b ? v >> (64 - b) : 0;
    uint64_t carry = 0;
    uint32_t parts[3] = {(uint32_t)lo, (uint32_t)(lo >> 32), (uint32_t)hi};
    for (unsigned k = 0; i + k < WIDE_LIMBS && (k < 3 || carry); k++) {
        uint64_t s = (uint64_t)w->limb[i + k] + (k < 3 ? parts[k] : 0) + carry;
        w->limb[i + k] = (uint32_t)s;
        carry = s >> 32;
    }
}

/* -1, 0 or 1 as a < b, a == b, a > b. */
static int compare(const wide *a, const wide *b)
{
    for (unsigned i = WIDE_LIMBS; i-- > 0;)
        if (a->limb[i] != b->limb[i])
            return a->limb[i] < b->limb[i] ? -1 : 1;
    return 0;
}

/* a -= b, for a >= b. */
static void subtract(wide *a, const wide *b)
{
    int64_t borrow = 0;
    for (unsigned i = 0; i < WIDE_LIMBS; i++) {
        int64_t d = (int64_t)a->limb[i] - b->limb[i] - borrow;
        borrow = d < 0;
        a->limb[i] = (uint32_t)(d + (borrow ? (int64_t)1 << 32 : 0));
    }
}

/* w /= d (d < 2^48), returning the remainder: 16 bits at a time, so that
 * remainder 2^16 + digit stays below 2^64. */
static uint64_t divide(wide *w, uint64_t d)
{
    uint64_t rem = 0;
    for (unsigned i = WIDE_LIMBS; i-- > 0;) {
        uint32_t q = 0;
        for (int half = 1; half >= 0; half--) {
            uint64_t cur = (rem << 16) | ((w->limb[i] >> (16 * half)) & 0xffffu);
            q |= (uint32_t)(cur / d) << (16 * half);
            rem = cur % d;
        }
        w->limb[i] = q;
    }
    return rem;
}

static int bit_of(const wide *w, unsigned bit)
{
    return (int)((w->limb[bit / 32] >> (bit % 32)) & 1u);
}

/* The highest set bit, or -1 for 0. */
static int top_bit(const wide *w)
{
    for (unsigned i = WIDE_LIMBS; i-- > 0;)
        if (w->limb[i])
            for (int b = 31; b >= 0; b--)
                if (w->limb[i] >> b & 1u)
                    return (int)(i * 32) + b;
    return -1;
}

/* Any bit below `bit` set? */
static int any_below(const wide *w, unsigned bit)
{
    for (unsigned i = 0; i < bit / 32; i++)
        if (w->limb[i])
            return 1;
    return bit % 32 && (w->limb[bit / 32] & ((1u << (bit % 32)) - 1u));
}

/* (q + rem / d) 2^-1074 rounded to nearest, ties to even. */
static double round_wide(const wide *q, uint64_t rem, uint64_t d)
{
    int p = top_bit(q);
    unsigned s = p > 52 ? (unsigned)p - 52 : 0; /* bits below the last kept */
    uint64_t mant = 0;
    for (unsigned b = 0; b < 53; b++) /* bits above p are 0 */
        mant |= (uint64_t)bit_of(q, s + b) << b;
    int up;
    if (s == 0) {
        /* the fraction is rem / d itself */
        up = 2 * rem > d || (2 * rem == d && (mant & 1u));
    } else {
        int round = bit_of(q, s - 1);
        int sticky = rem != 0 || any_below(q, s - 1);
        up = round && (sticky || (mant & 1u));
    }
    mant += (uint64_t)up;
    return ldexp((double)mant, (int)s - 1074);
}

static uint64_t gcd(uint64_t a, uint64_t b)
{
    while (b) {
        uint64_t t = a % b;
        a = b;
        b = t;
    }
    return a;
}

int qmc__exact_quotient_sum(const double *num, const uint32_t *den, size_t n, double *out)
{
    *out = NAN;
    if (n > QMC__EXACT_MAX_TERMS || (n && (!num || !den)))
        return QMC_EINVAL;
    uint64_t lcm = 1;
    for (size_t k = 0; k < n; k++) {
        if (!isfinite(num[k]) || den[k] == 0 || den[k] > QMC__EXACT_MAX_DEN)
            return QMC_EINVAL;
        lcm = lcm / gcd(lcm, den[k]) * den[k]; /* <= lcm(1..32) < 2^48 */
    }
    wide pos, neg;
    memset(&pos, 0, sizeof pos);
    memset(&neg, 0, sizeof neg);
    for (size_t k = 0; k < n; k++) {
        if (num[k] == 0.0)
            continue;
        int e;
        double m = frexp(fabs(num[k]), &e); /* |num| = m 2^e, m in [0.5, 1) */
        uint64_t mant = (uint64_t)ldexp(m, 53);
        int shift = e - 53 + 1074; /* |num| = mant 2^(shift - 1074) */
        if (shift < 0) {
            /* a subnormal: its trailing bits are zeros (mant = k 2^-shift) */
            mant >>= -shift;
            shift = 0;
        }
        /* mant (L / den): 53 x 48 bits, as three partial products */
        uint64_t f = lcm / den[k];
        uint64_t m0 = mant & 0xffffffffu, m1 = mant >> 32;
        uint64_t f0 = f & 0xffffffffu, f1 = f >> 32;
        wide *w = num[k] > 0 ? &pos : &neg;
        add_at(w, m0 * f0, (unsigned)shift);
        add_at(w, m1 * f0 + m0 * f1, (unsigned)shift + 32); /* < 2^54 */
        add_at(w, m1 * f1, (unsigned)shift + 64);
    }
    int c = compare(&pos, &neg);
    if (c == 0) {
        *out = 0.0;
        return 0;
    }
    wide *big = c > 0 ? &pos : &neg;
    subtract(big, c > 0 ? &neg : &pos);
    uint64_t rem = divide(big, lcm);
    double v = round_wide(big, rem, lcm);
    *out = c > 0 ? v : -v;
    return 0;
}
