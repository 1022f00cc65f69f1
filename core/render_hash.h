/*
 * render_hash.h - the hashes production renderers' samplers are built on,
 * bit for bit (private to core/).
 *
 * The pixel samplers (pixel_*.c) promise pbrt-v4's values, and the
 * fast-owen scramble of the global Sobol sequence uses the same
 * hash-based Owen scramble, so these functions must compute exactly what
 * pbrt-v4's util/hash.h, util/math.h and util/lowdiscrepancy.h compute.
 * They are written here from the published definitions; the test vectors
 * in tests/vectors/ (made by compiling pbrt-v4's own functions outside
 * this tree) are what prove they agree.  Nothing here keeps state.
 *
 * The bodies of MixBits, the Owen scramble and PermutationElement's steps
 * are statement macros on an lvalue (QMC__*_STEPS), each used by the
 * scalar function beside it and by the pixel samplers' vector kernels
 * (pixel_kernel.h), where the same operators act on GCC vector lanes and
 * the scalar constants broadcast: one definition, so the vector values
 * are the scalar ones by construction (test_pixel compares them anyway).
 */
#ifndef QMC_RENDER_HASH_H
#define QMC_RENDER_HASH_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "bits.h"

/*
 * MurmurHash64A (Austin Appleby, MurmurHash2, public domain) of len bytes.
 * pbrt-v4's Hash(a, b, ...) is this over the arguments' bytes laid end to
 * end (little-endian here) with seed 0; see qmc__hash_i32x2 and friends.
 */
static inline uint64_t qmc__murmur64a(const unsigned char *key, size_t len, uint64_t seed)
{
    const uint64_t m = 0xc6a4a7935bd1e995ull;
    const int r = 47;
    uint64_t h = seed ^ (len * m);
    const unsigned char *end = key + 8 * (len / 8);
    while (key != end) {
        uint64_t k;
        memcpy(&k, key, sizeof k);
        key += 8;
        k *= m;
        k ^= k >> r;
        k *= m;
        h ^= k;
        h *= m;
    }
    uint64_t tail = 0;
    for (size_t i = len & 7; i > 0; i--)
        tail |= (uint64_t)key[i - 1] << (8 * (i - 1));
    if (len & 7) {
        h ^= tail;
        h *= m;
    }
    h ^= h >> r;
    h *= m;
    h ^= h >> r;
    return h;
}

/* pbrt-v4's Hash(int a, int b): the 8 bytes of two 32-bit integers. */
static inline uint64_t qmc__hash_i32x2(uint32_t a, uint32_t b)
{
    unsigned char buf[8];
    for (int i = 0; i < 4; i++) {
        buf[i] = (unsigned char)(a >> (8 * i));
        buf[4 + i] = (unsigned char)(b >> (8 * i));
    }
    return qmc__murmur64a(buf, sizeof buf, 0);
}

/* pbrt-v4's Hash(Point2i p, int dim, int seed): 16 bytes, x y dim seed. */
static inline uint64_t qmc__hash_i32x4(uint32_t a, uint32_t b, uint32_t c, uint32_t d)
{
    unsigned char buf[16];
    const uint32_t w[4] = {a, b, c, d};
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++)
            buf[4 * j + i] = (unsigned char)(w[j] >> (8 * i));
    return qmc__murmur64a(buf, sizeof buf, 0);
}

/*
 * pbrt-v4's MixBits (David Stafford's "Mix13"-style 64-bit finaliser,
 * constants from http://zimbry.blogspot.ch/2011/09/): a bijection with
 * full avalanche.  Not qmc__mix64 (bits.h), whose constants differ.
 */
#define QMC__MIX_BITS_STEPS(v)        \
    do {                              \
        (v) ^= (v) >> 31;             \
        (v) *= 0x7fb5d329728ea185ull; \
        (v) ^= (v) >> 27;             \
        (v) *= 0x81dadef4bc2dd44dull; \
        (v) ^= (v) >> 33;             \
    } while (0)

static inline uint64_t qmc__mix_bits(uint64_t v)
{
    QMC__MIX_BITS_STEPS(v);
    return v;
}

/*
 * The hash-based Owen scramble of pbrt-v4's FastOwenScrambler (after Laine
 * and Karras 2011, constants as in Burley 2020 and Cycles'
 * reversed_bit_owen): on the bit-reversed value, each step changes a bit
 * only as a function of the bits below it, which after reversal are the
 * bits above it: a nested uniform scramble's structure.  This is the
 * reversed-domain core: it takes and returns bit-reversed words, so a
 * caller that keeps its values reversed saves both reversals.
 */
#define QMC__FAST_OWEN_STEPS(r, seed, smul) \
    do {                                     \
        (r) ^= (r) * 0x3d20adeau;            \
        (r) += (seed);                       \
        (r) *= (smul);                       \
        (r) ^= (r) * 0x05526c56u;            \
        (r) ^= (r) * 0x53a22864u;            \
    } while (0)

/* smul = (seed >> 16) | 1: a caller with many values and few seeds (the
 * pixel kernels) computes it once per seed. */
static inline uint32_t qmc__fast_owen_reversed(uint32_t r, uint32_t seed)
{
    QMC__FAST_OWEN_STEPS(r, seed, (seed >> 16) | 1u);
    return r;
}

/* FastOwenScrambler(seed)(v), exactly. */
static inline uint32_t qmc__fast_owen(uint32_t v, uint32_t seed)
{
    return qmc__reverse32(qmc__fast_owen_reversed(qmc__reverse32(v), seed));
}

/*
 * pbrt-v4's PermutationElement(i, l, p): element i of a permutation of
 * [0, l) chosen by p (Kensler 2013), in its 32-bit form, with pbrt's final
 * (i + p) % l, the sum taken modulo 2^32.  Not qmc__permute (bits.h), which is widened to 64 bits
 * and gives other permutations.  Requires 1 <= l <= 2^32 and i < l; l is
 * 64-bit only so that l = 2^32 (every 32-bit index, where pbrt's int spp
 * cannot reach) is the natural limit of the same steps: w = 2^32 - 1, no
 * cycle walking, and the modulo of the wrapped sum is the identity.
 */
#define QMC__PERMUTATION_STEPS(i, w, p) \
    do {                                \
        (i) ^= (p);                     \
        (i) *= 0xe170893du;             \
        (i) ^= (p) >> 16;               \
        (i) ^= ((i) & (w)) >> 4;        \
        (i) ^= (p) >> 8;                \
        (i) *= 0x0929eb3fu;             \
        (i) ^= (p) >> 23;               \
        (i) ^= ((i) & (w)) >> 1;        \
        (i) *= 1u | (p) >> 27;          \
        (i) *= 0x6935fa69u;             \
        (i) ^= ((i) & (w)) >> 11;       \
        (i) *= 0x74dcb303u;             \
        (i) ^= ((i) & (w)) >> 2;        \
        (i) *= 0x9e501cc3u;             \
        (i) ^= ((i) & (w)) >> 2;        \
        (i) *= 0xc860a3dfu;             \
        (i) &= (w);                     \
        (i) ^= (i) >> 5;                \
    } while (0)

static inline uint32_t qmc__permutation_element32(uint32_t i, uint64_t l, uint32_t p)
{
    uint32_t w = (uint32_t)(l - 1);
    w |= w >> 1;
    w |= w >> 2;
    w |= w >> 4;
    w |= w >> 8;
    w |= w >> 16;
    do {
        QMC__PERMUTATION_STEPS(i, w, p);
    } while (i >= l);
    /* pbrt adds in uint32_t: the sum wraps before the modulo. */
    return (uint32_t)((uint32_t)(i + p) % l);
}

#endif
