/*
 * seq_halton.c - Halton sequence and Hammersley set: radical inverses in
 * the first primes.
 *
 * Halton coordinate j of point i is the radical inverse of i in the j-th
 * prime; point 0 is the origin.  Hammersley's set of N points is
 * (i / N, Halton coordinates 0 .. d-2 of i).
 *
 * Exactness: with K digits, where b^K >= 2^32 covers every index, the
 * radical inverse is the rational r / b^K with r = the digits reversed;
 * both are integers below 2^53, so one correctly rounded division gives the
 * nearest double - the same in at() and in fill.  Fill keeps the digits of
 * consecutive indices and updates r incrementally (amortised one add per
 * coordinate) instead of redoing the base-b expansion.
 *
 * Scrambles (Hammersley's first coordinate i/N is never scrambled):
 *  - faure: Faure's deterministic permutations sigma_b (Faure 1992,
 *    "Good permutations for extreme discrepancy"), applied to every digit.
 *    sigma_b(0) = 0, so point 0 stays the origin and K digits suffice.
 *  - owen:  nested uniform scrambling: digit k goes through a random
 *    permutation of [0, b) chosen by hashing (seed, dimension, k, digits
 *    0..k-1), Kensler's hashed permutation.  Digits past the index's own
 *    (zeros) are scrambled too, down to b^-Kmax with b^Kmax <= 2^53, so the
 *    scrambled point is uniform to full double precision.
 *
 * Must not: allocate, or keep a primes table beyond the instance.
 */
#include <string.h>

#include "bits.h"
#include "seq_impl.h"

typedef struct halton_dim {
    uint32_t base;
    uint32_t digits;       /* K: smallest with base^K >= 2^32 */
    double denom;          /* base^K, exact */
    uint32_t owen_digits;  /* Kmax: largest with base^Kmax <= 2^53 */
    uint32_t owen_seed;
    double owen_denom;     /* base^Kmax, exact */
    uint32_t low_digits;   /* L: digits in the fill's low part (see below) */
    uint32_t low_period;   /* P = base^L */
    int32_t low_slot;      /* its row in the low tables, or -1: lo * w_0 */
} halton_dim;

/*
 * Batch fill splits an index into a low part lo = i mod P, P = base^L <=
 * LOW_MAX, and the rest.  The reversed-digit integer is then r = hi +
 * T(lo): hi changes once every P points, T(lo) is one table entry (bases
 * up to 16, where L >= 2) or lo * w_0 (L = 1).  Only bases <= 16 get a
 * table: the first six primes, LOW_SLOTS rows of LOW_MAX entries.
 */
enum { LOW_MAX = 256, LOW_SLOTS = 6 };

/* Hammersley's first coordinate is i/N; its Halton part starts at dim 1. */
static uint32_t first_radical_dim(const qmc_seq_spec *spec)
{
    return spec->kind == QMC_SEQ_HAMMERSLEY ? 1u : 0u;
}

static const unsigned halton_scrambles = QMC__SCR_BIT(QMC_SCRAMBLE_NONE) |
                                         QMC__SCR_BIT(QMC_SCRAMBLE_FAURE) |
                                         QMC__SCR_BIT(QMC_SCRAMBLE_OWEN);

static int halton_check(const qmc_seq_spec *spec, qmc__msg *why)
{
    int err = qmc__check_dims(spec, QMC_HALTON_MAX_DIMS, why);
    if (!err)
        err = qmc__check_scramble(spec, halton_scrambles, why);
    return err;
}

static int hammersley_check(const qmc_seq_spec *spec, qmc__msg *why)
{
    int err = halton_check(spec, why);
    if (!err)
        err = qmc__check_set_size(spec, why);
    return err;
}

static size_t halton_table_bytes(const qmc_seq_spec *spec)
{
    return spec->dims * sizeof(halton_dim) + LOW_SLOTS * LOW_MAX * sizeof(uint64_t);
}

static uint64_t *low_tables(const qmc_seq *seq)
{
    return (uint64_t *)((halton_dim *)seq->tables + seq->spec.dims);
}

/* Weight of digit k (0 = least significant digit of the index): the
 * reversed-digit integer r has digit k at position K-1-k. */
static uint64_t digit_weight(const halton_dim *h, uint32_t k)
{
    uint64_t w = 1;
    for (uint32_t e = k + 1; e < h->digits; e++)
        w *= h->base;
    return w;
}

static void init_low_part(halton_dim *h, uint32_t radical_index, uint64_t *tables)
{
    h->low_digits = 1;
    h->low_period = h->base;
    h->low_slot = -1;
    if (h->base > 16 || radical_index >= LOW_SLOTS)
        return;
    while (h->low_period * h->base <= LOW_MAX) {
        h->low_period *= h->base;
        h->low_digits++;
    }
    h->low_slot = (int32_t)radical_index;
    /* Entry lo = q * base + d has digit 0 = d, of weight w0, and q's
     * digits one place lower: q's entry divided by base, exactly (every
     * weight is a power of base above 1, as digits > low_digits).  One
     * pass, not a digit expansion per entry with each weight rebuilt:
     * that was ~100k multiplies per sequence built (16-26 us, ten times a
     * Sobol instance), paid whenever a Modbus client or a request asks for
     * a new Halton spec. */
    const uint64_t w0 = digit_weight(h, 0);
    uint64_t *t = tables + (size_t)radical_index * LOW_MAX;
    t[0] = 0;
    for (uint32_t q = 0; q < h->low_period / h->base; q++) {
        const uint64_t upper = t[q] / h->base;
        for (uint32_t d = 0; d < h->base; d++)
            t[q * h->base + d] = d * w0 + upper;
    }
}

static void halton_init(qmc_seq *seq)
{
    halton_dim *t = seq->tables;
    const uint32_t first = first_radical_dim(&seq->spec);
    uint32_t candidate = 2;
    for (uint32_t j = first; j < seq->spec.dims; j++) {
        /* The next prime, by trial division by the primes found so far
         * (the table itself); at most 4096 primes, so this is cheap. */
        for (;; candidate++) {
            int prime = 1;
            for (uint32_t q = first; q < j && t[q].base * t[q].base <= candidate; q++)
                if (candidate % t[q].base == 0) {
                    prime = 0;
                    break;
                }
            if (prime)
                break;
        }
        halton_dim *h = &t[j];
        h->base = candidate++;
        uint64_t p = 1;
        h->digits = 0;
        while (p < (1ull << 32)) {
            p *= h->base;
            h->digits++;
        }
        h->denom = (double)p;
        p = 1;
        h->owen_digits = 0;
        while (p <= (1ull << 53) / h->base) {
            p *= h->base;
            h->owen_digits++;
        }
        h->owen_denom = (double)p;
        h->owen_seed = (uint32_t)qmc__hash3(seq->spec.seed, j, QMC__TAG_OWEN);
        init_low_part(h, (uint32_t)(j - first), low_tables(seq));
    }
}

/* Faure's permutation sigma_b(d), by its recursive definition: for even b,
 * sigma_b = (2 sigma_{b/2}, 2 sigma_{b/2} + 1); for odd b, sigma_{b-1} with
 * values >= c = (b-1)/2 raised by one and c inserted in the middle. */
static uint32_t faure_permute(uint32_t d, uint32_t b)
{
    if (b <= 2)
        return d;
    if (b % 2 == 0) {
        uint32_t half = b / 2;
        return d < half ? 2 * faure_permute(d, half)
                        : 2 * faure_permute(d - half, half) + 1;
    }
    uint32_t c = (b - 1) / 2;
    if (d == c)
        return c;
    uint32_t s = faure_permute(d < c ? d : d - 1, b - 1);
    return s < c ? s : s + 1;
}

static double radical_inverse(const halton_dim *h, uint64_t i,
                              qmc_scramble scr)
{
    const uint64_t b = h->base;
    uint64_t r = 0;
    if (scr == QMC_SCRAMBLE_OWEN) {
        uint64_t prefix = 1; /* digits so far, behind a leading 1 */
        for (uint32_t k = 0; k < h->owen_digits; k++) {
            uint64_t d = i % b;
            i /= b;
            uint64_t perm_seed = qmc__hash3(h->owen_seed, k, prefix);
            r = r * b + qmc__permute(d, b, perm_seed);
            prefix = prefix * b + d;
        }
        return qmc__below_one((double)r / h->owen_denom);
    }
    for (uint32_t k = 0; k < h->digits; k++) {
        uint64_t d = i % b;
        i /= b;
        r = r * b + (scr == QMC_SCRAMBLE_FAURE ? faure_permute((uint32_t)d, (uint32_t)b) : d);
    }
    return (double)r / h->denom;
}

static double halton_at(const qmc_seq *seq, uint64_t index, uint32_t dim)
{
    const halton_dim *t = seq->tables;
    if (dim < first_radical_dim(&seq->spec))
        return (double)index / (double)seq->spec.set_size;
    return radical_inverse(&t[dim], index, seq->spec.scramble);
}

enum { CHUNK = 64, MAX_DIGITS = 32 };

/* Vectors of 4 (GCC/clang extensions): explicit, because GCC's -O2 cost
 * model leaves the division loop scalar.  Static and inlined, so no vector
 * crosses an ABI boundary; GCC warns about the AVX convention regardless. */
#if defined(__GNUC__)
#pragma GCC diagnostic ignored "-Wpsabi"
#endif
typedef uint64_t u64x4 __attribute__((vector_size(32)));
typedef double f64x4 __attribute__((vector_size(32)));

/* An exact integer below 2^52 as a double without a conversion
 * instruction: 2^52 + r assembled from bits, minus 2^52.  Vectorizes with
 * SSE2 and AVX2, which lack unsigned 64-bit conversions. */
static inline double exact_double(uint64_t r)
{
    uint64_t b = r | 0x4330000000000000ull;
    double d;
    memcpy(&d, &b, sizeof d);
    return d - 0x1p52;
}

/*
 * Unscrambled fill of the radical-inverse dims [j0, j1) with base > 16
 * (so L = 1 and r = hi + lo * w_0).  r / base^K is the correctly rounded
 * radical inverse, exactly what at() computes.  Four dimensions' r, lo,
 * digit 1, w_0, base and denominator live in vector registers while a
 * block of points goes by, so a coordinate costs an add, the exact
 * conversion and a division.  Digit 0 wrapping into digit 1 (once every
 * base points) is handled in the vector without a branch; digit 1
 * wrapping (once every base^2 points) goes to scalar code.
 */
typedef int64_t i64x4 __attribute__((vector_size(32)));

/* The first `valid` (< 4) lanes of *v; kept out of line so the full-group
 * loop stays a plain vector store.  The vector goes by pointer: by value it
 * would cross between the AVX2 clone and this baseline function with two
 * different calling conventions. */
static __attribute__((noinline)) void store_partial(double *o, const f64x4 *v,
                                                     uint32_t valid)
{
    double lanes[4];
    memcpy(lanes, v, sizeof lanes);
    for (uint32_t q = 0; q < valid; q++)
        o[q] = lanes[q];
}

static inline __attribute__((always_inline)) void
fill_radical_lanes(const qmc_seq *seq, uint64_t start, uint64_t count,
                   uint32_t j0, uint32_t j1, double *out)
{
    const halton_dim *t = seq->tables;
    const size_t d = seq->spec.dims;
    const uint64_t e = 0x4330000000000000ull;
    const u64x4 exp52 = {e, e, e, e};
    enum { LANE_BLOCK = 64 }; /* points per block: its rows stay in L1 */
    for (uint32_t c0 = j0; c0 < j1; c0 += CHUNK) {
        const uint32_t n = j1 - c0 < CHUNK ? j1 - c0 : CHUNK;
        /* A last group of fewer than 4 dims is padded with copies of its
         * last dim: computed alongside, never stored. */
        const uint32_t padded = (n + 3) & ~3u;
        uint32_t digit[CHUNK][MAX_DIGITS];
        uint64_t weight[CHUNK][MAX_DIGITS], r[CHUNK], lo[CHUNK], d1[CHUNK], w0[CHUNK];
        uint64_t base[CHUNK], delta1[CHUNK];
        double den[CHUNK];
        for (uint32_t q = 0; q < padded; q++) {
            const halton_dim *h = &t[c0 + (q < n ? q : n - 1)];
            uint64_t i = start;
            r[q] = 0;
            base[q] = h->base;
            den[q] = h->denom;
            for (uint32_t k = 0; k < h->digits; k++, i /= h->base) {
                weight[q][k] = digit_weight(h, k);
                digit[q][k] = (uint32_t)(i % h->base);
                r[q] += digit[q][k] * weight[q][k];
            }
            lo[q] = digit[q][0];
            d1[q] = digit[q][1]; /* K >= 3 for every base used here */
            w0[q] = weight[q][0];
            /* Digit 0 wrapping and digit 1 absorbing it changes r by this
             * (mod 2^64; the sum stays exact). */
            delta1[q] = weight[q][1] - base[q] * weight[q][0];
        }
        for (uint64_t p0 = 0; p0 < count; p0 += LANE_BLOCK) {
            const uint64_t m = count - p0 < LANE_BLOCK ? count - p0 : LANE_BLOCK;
            for (uint32_t g = 0; g < padded; g += 4) {
                const uint32_t valid = n - g < 4 ? n - g : 4;
                u64x4 vr, vlo, vd1, vdelta1, vw, vb;
                f64x4 vden;
                memcpy(&vr, r + g, sizeof vr);
                memcpy(&vlo, lo + g, sizeof vlo);
                memcpy(&vd1, d1 + g, sizeof vd1);
                memcpy(&vdelta1, delta1 + g, sizeof vdelta1);
                memcpy(&vw, w0 + g, sizeof vw);
                memcpy(&vb, base + g, sizeof vb);
                memcpy(&vden, den + g, sizeof vden);
                double *o = out + (size_t)p0 * d + c0 + g;
                for (uint64_t p = 0; p < m; p++, o += d) {
                    f64x4 v = ((f64x4)(vr | exp52) - 0x1p52) / vden;
                    if (__builtin_expect(valid == 4, 1))
                        memcpy(o, &v, sizeof v);
                    else
                        store_partial(o, &v, valid);
                    vlo += 1;
                    vr += vw;
                    /* Digit 0 wrapped: zero it, carry into digit 1 (wrap is
                     * all ones in those lanes, so d1 - wrap adds one). */
                    u64x4 wrap = (u64x4)(vlo == vb);
                    vlo &= ~wrap;
                    vr += wrap & vdelta1;
                    vd1 -= wrap;
                    i64x4 wrap2 = (i64x4)(vd1 == vb);
                    if (__builtin_expect((wrap2[0] | wrap2[1] | wrap2[2] | wrap2[3]) == 0, 1))
                        continue;
                    /* Digit 1 wrapped too (once every base^2 points): the
                     * scalar carry from digit 1 up. */
                    memcpy(r + g, &vr, sizeof vr);
                    memcpy(d1 + g, &vd1, sizeof vd1);
                    for (uint32_t q = g; q < g + 4; q++) {
                        if (d1[q] != base[q])
                            continue;
                        const uint64_t b = base[q];
                        uint32_t k = 1;
                        digit[q][1] = (uint32_t)b;
                        while (digit[q][k] == b) {
                            digit[q][k] = 0;
                            r[q] -= b * weight[q][k];
                            k++;
                            digit[q][k]++;
                            r[q] += weight[q][k];
                        }
                        d1[q] = 0;
                    }
                    memcpy(&vr, r + g, sizeof vr);
                    memcpy(&vd1, d1 + g, sizeof vd1);
                }
                memcpy(r + g, &vr, sizeof vr);
                memcpy(lo + g, &vlo, sizeof vlo);
                memcpy(d1 + g, &vd1, sizeof vd1);
            }
        }
    }
}

/*
 * The small bases (the dims with a low table, base <= 16) vectorized the
 * other way: along points.  Within a run of the low part, r = hi + T[lo]
 * for consecutive lo, so four points are one contiguous table load, one
 * add, the exact conversion and one division; the four results go to four
 * rows.  hi changes only at a carry, once every P >= 49 points.
 */
static inline __attribute__((always_inline)) void
fill_radical_tabled(const qmc_seq *seq, uint64_t start, uint64_t count,
                    uint32_t j0, uint32_t j1, double *out)
{
    const halton_dim *t = seq->tables;
    const uint64_t *tables = low_tables(seq);
    const size_t d = seq->spec.dims;
    const uint64_t e = 0x4330000000000000ull;
    const u64x4 exp52 = {e, e, e, e};
    enum { TAB_BLOCK = 64 };
    uint32_t digit[LOW_SLOTS][MAX_DIGITS], lo[LOW_SLOTS];
    uint64_t weight[LOW_SLOTS][MAX_DIGITS], hi[LOW_SLOTS];
    for (uint32_t j = j0; j < j1; j++) {
        const halton_dim *h = &t[j];
        const uint32_t q = j - j0;
        uint64_t i = start;
        lo[q] = (uint32_t)(i % h->low_period);
        hi[q] = 0;
        for (uint32_t k = 0; k < h->digits; k++, i /= h->base) {
            weight[q][k] = digit_weight(h, k);
            digit[q][k] = (uint32_t)(i % h->base);
            if (k >= h->low_digits)
                hi[q] += digit[q][k] * weight[q][k];
        }
    }
    for (uint64_t p0 = 0; p0 < count; p0 += TAB_BLOCK) {
        const uint32_t m = count - p0 < TAB_BLOCK ? (uint32_t)(count - p0) : TAB_BLOCK;
        for (uint32_t j = j0; j < j1; j++) {
            const halton_dim *h = &t[j];
            const uint32_t q = j - j0;
            const uint64_t *tab = tables + (size_t)h->low_slot * LOW_MAX;
            const f64x4 den = {h->denom, h->denom, h->denom, h->denom};
            double *o = out + (size_t)p0 * d + j;
            for (uint32_t p = 0; p < m;) {
                if (lo[q] == h->low_period) {
                    /* Carry into digit L and up, once every P points, and
                     * only when a point needs it: after the last index
                     * (2^32 - 1 for base 2) there is no next one. */
                    lo[q] = 0;
                    const uint32_t b = h->base;
                    uint32_t kk = h->low_digits;
                    hi[q] += weight[q][kk];
                    while (++digit[q][kk] == b) {
                        digit[q][kk] = 0;
                        hi[q] -= b * weight[q][kk];
                        kk++;
                        hi[q] += weight[q][kk];
                    }
                }
                uint32_t run = h->low_period - lo[q] < m - p ? h->low_period - lo[q] : m - p;
                const u64x4 vhi = {hi[q], hi[q], hi[q], hi[q]};
                uint32_t k = 0;
                for (; k + 4 <= run; k += 4) {
                    u64x4 r;
                    memcpy(&r, tab + lo[q] + k, sizeof r);
                    f64x4 v = ((f64x4)((r + vhi) | exp52) - 0x1p52) / den;
                    double *ok = o + (size_t)(p + k) * d;
                    ok[0] = v[0];
                    ok[d] = v[1];
                    ok[2 * d] = v[2];
                    ok[3 * d] = v[3];
                }
                for (; k < run; k++)
                    o[(size_t)(p + k) * d] = exact_double(hi[q] + tab[lo[q] + k]) / h->denom;
                p += run;
                lo[q] += run;
            }
        }
    }
}

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define QMC__MULTIVERSION __attribute__((target_clones("avx2", "default")))
#else
#define QMC__MULTIVERSION
#endif

/* Vector division where the CPU has it; IEEE division is correctly rounded
 * on every instruction set, so the bits do not depend on the choice. */
QMC__MULTIVERSION
static void fill_radical(const qmc_seq *seq, uint64_t start, uint64_t count,
                         uint32_t first, double *out)
{
    const uint32_t d = seq->spec.dims;
    /* Small bases (the first LOW_SLOTS radical dims) along points, the rest
     * four dimensions at a time. */
    uint32_t lanes_begin = first + LOW_SLOTS < d ? first + LOW_SLOTS : d;
    fill_radical_tabled(seq, start, count, first, lanes_begin, out);
    fill_radical_lanes(seq, start, count, lanes_begin, d, out);
}

static void halton_fill(const qmc_seq *seq, uint64_t start, uint64_t count,
                        qmc_format fmt, void *out)
{
    const uint32_t d = seq->spec.dims;
    const uint32_t first = first_radical_dim(&seq->spec);
    if (fmt == QMC_FORMAT_F64 && seq->spec.scramble == QMC_SCRAMBLE_NONE) {
        double *o = out;
        fill_radical(seq, start, count, first, o);
        if (first)
            for (uint64_t p = 0; p < count; p++)
                o[(size_t)p * d] = halton_at(seq, start + p, 0);
        return;
    }
    qmc__fill_from_at(seq, start, count, fmt, out);
}

const qmc__seq_ops qmc__seq_halton = {
    .check = halton_check,
    .table_bytes = halton_table_bytes,
    .init = halton_init,
    .at = halton_at,
    .fill = halton_fill,
};

const qmc__seq_ops qmc__seq_hammersley = {
    .check = hammersley_check,
    .table_bytes = halton_table_bytes,
    .init = halton_init,
    .at = halton_at,
    .fill = halton_fill,
};
