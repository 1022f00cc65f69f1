/*
 * seq_sobol.c - Sobol' sequence, Joe-Kuo direction numbers, 1..21201 dims.
 *
 * Natural binary index order: point i is the XOR of the direction numbers
 * v_k for the set bits k of i, so point 0 is the origin and any point is
 * reachable directly.  Batch fill walks consecutive indices: from i to i+1
 * exactly bits 0..c flip, c = ctz(i+1), so the state takes one XOR with the
 * prefix XOR W_c = v_0 ^ ... ^ v_c per coordinate - the same words at()
 * XORs together, hence bit-identical results.
 *
 * Scrambles:
 *  - shift: random digital shift, y = x ^ s_j.
 *  - owen:  hash-based nested uniform scrambling (Burley, "Practical
 *    Hash-based Owen Scrambling", JCGT 9(4), 2020) with the improved
 *    Laine-Karras-style hash of N. Vegdahl (2021).  The hash scrambles in
 *    bit-reversed order, so owen instances keep their direction numbers
 *    bit-reversed and reverse once per coordinate at the end.
 *  - fast-owen: the same hash (pbrt-v4's FastOwenScrambler), seeded per
 *    dimension as pbrt-v4's SobolSampler seeds it, Hash(dim, seed), so
 *    that a seed below 2^32 gives pbrt's values (fast_owen_seed below).
 *  - QMC_SEQ_SHUFFLE: the index itself goes through a nested uniform
 *    scramble first (Burley section 4), which maps every aligned block of
 *    2^m indices onto an aligned block, so nets stay nets.
 * Per-dimension seeds are hashed from (seed, dimension, use): never raw.
 *
 * Must not: read the data file (the table is compiled in), or allocate.
 */
#include "render_hash.h"
#include "sobol_impl.h"
#include "sobol_table.h"

static int sobol_check(const qmc_seq_spec *spec, qmc__msg *why)
{
    int err = qmc__check_dims(spec, QMC_SOBOL_MAX_DIMS, why);
    if (err)
        return err;
    return qmc__check_scramble(spec,
                               QMC__SCR_BIT(QMC_SCRAMBLE_NONE) |
                                   QMC__SCR_BIT(QMC_SCRAMBLE_SHIFT) |
                                   QMC__SCR_BIT(QMC_SCRAMBLE_OWEN) |
                                   QMC__SCR_BIT(QMC_SCRAMBLE_FAST_OWEN),
                               why);
}

static size_t sobol_table_bytes(const qmc_seq_spec *spec)
{
    return (u32_words(spec->dims) + w64_words(spec) + packed_words(spec)) *
           sizeof(uint32_t);
}

/* Direction numbers v[0..31] of dimension dim (0-based), scaled so that
 * v[k] = m_{k+1} << (31 - k) (Joe & Kuo 2008, section 2). */
static void direction_numbers(uint32_t dim, uint32_t v[BITS])
{
    const qmc__sobol_poly *p = &qmc__sobol_polys[dim];
    const uint32_t s = p->degree;
    if (s == 0) {
        for (int k = 0; k < BITS; k++)
            v[k] = 1u << (31 - k);
        return;
    }
    for (uint32_t k = 0; k < s && k < BITS; k++)
        v[k] = qmc__sobol_m[p->m_offset + k] << (31 - k);
    /* The recurrence of the primitive polynomial x^s + a_1 x^(s-1) + ... +
     * a_(s-1) x + 1, with a_1 the high bit of coeffs. */
    for (uint32_t k = s; k < BITS; k++) {
        uint32_t x = v[k - s] ^ (v[k - s] >> s);
        for (uint32_t i = 1; i < s; i++)
            if ((p->coeffs >> (s - 1 - i)) & 1u)
                x ^= v[k - i];
        v[k] = x;
    }
}

/*
 * fast-owen's seed of dimension j: the low 32 bits of MurmurHash64A (seed
 * 0) over j as 4 little-endian bytes followed by the user's seed as 4
 * little-endian bytes when it is below 2^32, or as 8 when it is not.  The
 * first case is pbrt-v4's Hash(int dimension, int seed) truncated to the
 * uint32_t FastOwenScrambler takes (SobolSampler::SampleDimension), so
 * pbrt's seeds (ints, negative ones as their two's complement) give pbrt's
 * values; the 12-byte case keeps all 64 bits of larger seeds.
 */
static uint32_t fast_owen_seed(uint64_t seed, uint32_t j)
{
    if (seed <= UINT32_MAX)
        return (uint32_t)qmc__hash_i32x2(j, (uint32_t)seed);
    unsigned char buf[12];
    for (int b = 0; b < 4; b++)
        buf[b] = (unsigned char)(j >> (8 * b));
    for (int b = 0; b < 8; b++)
        buf[4 + b] = (unsigned char)(seed >> (8 * b));
    return (uint32_t)qmc__murmur64a(buf, sizeof buf, 0);
}

static uint32_t dim_seed(const qmc_seq_spec *spec, uint32_t j)
{
    switch (spec->scramble) {
    case QMC_SCRAMBLE_FAST_OWEN:
        return fast_owen_seed(spec->seed, j);
    case QMC_SCRAMBLE_SHIFT:
        return (uint32_t)qmc__hash3(spec->seed, j, QMC__TAG_SHIFT);
    default: /* owen; unused by none */
        return (uint32_t)qmc__hash3(spec->seed, j, QMC__TAG_OWEN);
    }
}

static void sobol_init(qmc_seq *seq)
{
    const qmc_seq_spec *spec = &seq->spec;
    const size_t d = spec->dims;
    uint32_t *t = seq->tables;
    uint32_t *vt = t, *wt = t + (size_t)BITS * d, *seed = wt + ((size_t)BITS + 1) * d;
    memset(wt + (size_t)BITS * d, 0, d * sizeof *wt);
    const int reversed = kernel_scramble(spec->scramble) == QMC_SCRAMBLE_OWEN;
    for (size_t j = 0; j < d; j++) {
        uint32_t v[BITS];
        direction_numbers((uint32_t)j, v);
        uint32_t prefix = 0;
        for (int k = 0; k < BITS; k++) {
            uint32_t x = reversed ? qmc__reverse32(v[k]) : v[k];
            vt[j * BITS + (size_t)k] = x;
            prefix ^= x;
            wt[(size_t)k * d + j] = prefix;
        }
        seed[j] = dim_seed(spec, (uint32_t)j);
    }
    seed[d] = (uint32_t)qmc__hash3(spec->seed, 0, QMC__TAG_SHUFFLE);
    seed[d + 1] = 0;
    memset(seed + d + 2, 0, QMC__SOBOL_PAD * sizeof *seed);
    if (has_w64(spec)) {
        uint64_t *w64 = (uint64_t *)(t + u32_words(d));
        for (size_t k = 0; k < ((size_t)BITS + 1) * d; k++)
            w64[k] = (uint64_t)wt[k] << 20;
    }
    if (has_packed(spec)) {
        uint32_t *packed = t + u32_words(d) + w64_words(spec);
        const size_t width = packed_row_words(d);
        for (size_t r = 0; r < QMC__SOBOL_PACK_ROWS; r++) {
            uint32_t *row = packed + r * width;
            for (size_t i = 0; i < width; i++)
                row[i] = r + 1 == QMC__SOBOL_PACK_ROWS
                             ? 0
                             : wt[(3 + r) * d + i % d] ^ wt[2 * d + i % d];
        }
    }
}

static inline uint32_t shuffled_index(const qmc_seq *seq, sobol_view s,
                                      uint64_t index)
{
    if (seq->spec.flags & QMC_SEQ_SHUFFLE)
        return nested_uniform_scramble((uint32_t)index, s.seed[seq->spec.dims]);
    return (uint32_t)index;
}
static uint32_t sobol_bits_at(const qmc_seq *seq, uint64_t index, uint32_t dim)
{
    sobol_view s = view(seq);
    uint32_t i = shuffled_index(seq, s, index);
    return finish(gather(s.v + (size_t)dim * BITS, i), s.seed[dim],
                  kernel_scramble(seq->spec.scramble));
}

static double sobol_at(const qmc_seq *seq, uint64_t index, uint32_t dim)
{
    return sobol_bits_at(seq, index, dim) * 0x1p-32;
}

static void sobol_fill(const qmc_seq *seq, uint64_t start, uint64_t count,
                       qmc_format fmt, void *out)
{
    /* One or two points (a daemon answering many tiny requests): gathering
     * them directly is cheaper than a batch fill's setup. */
    if (!(seq->spec.flags & QMC_SEQ_SHUFFLE) && count > 2) {
#ifdef QMC__SOBOL_AVX2
        if (qmc__sobol_has_avx512()) {
            qmc__sobol_fill_avx512(seq, start, count, fmt, out);
            return;
        }
        if (__builtin_cpu_supports("avx2")) {
            qmc__sobol_fill_avx2(seq, start, count, fmt, out);
            return;
        }
#endif
        qmc__sobol_fill_generic(seq, start, count, fmt, out);
        return;
    }
    /* A shuffled index order has no Gray-code-like walk: gather per point
     * (as for very small fills). */
    const uint32_t d = seq->spec.dims;
    for (uint64_t p = 0; p < count; p++)
        for (uint32_t j = 0; j < d; j++)
            store(out, (size_t)p * d + j, sobol_bits_at(seq, start + p, j), fmt);
}

const qmc__seq_ops qmc__seq_sobol = {
    .check = sobol_check,
    .table_bytes = sobol_table_bytes,
    .init = sobol_init,
    .at = sobol_at,
    .fill = sobol_fill,
};

uint64_t qmc_sobol_table_hash(void)
{
    /* FNV-1a over every degree, coefficient word and initial number, in
     * table order: any edit to the table changes the fingerprint. */
    uint64_t h = 0xcbf29ce484222325ull;
    const uint32_t dims = qmc__sobol_table_dims;
    for (uint32_t j = 0; j < dims; j++) {
        const qmc__sobol_poly *p = &qmc__sobol_polys[j];
        uint32_t words[2] = {p->degree, p->coeffs};
        for (int w = 0; w < 2 + (int)p->degree; w++) {
            uint32_t x = w < 2 ? words[w] : qmc__sobol_m[p->m_offset + (uint32_t)w - 2];
            for (int b = 0; b < 4; b++) {
                h ^= (x >> (8 * b)) & 0xffu;
                h *= 0x100000001b3ull;
            }
        }
    }
    return h;
}
