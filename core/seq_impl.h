/*
 * seq_impl.h - the sequence-kind table behind qmc/seq.h (private).
 *
 * A kind is a const table of functions (GSL's qrng_type habit) plus the
 * tables an instance precomputes once in qmc_seq_new.  seq.c does all the
 * argument checking and format conversion, so a kind only ever sees valid
 * indices and dimensions.
 */
#ifndef QMC_SEQ_IMPL_H
#define QMC_SEQ_IMPL_H

#include <stddef.h>
#include <stdint.h>

#include "msg.h"
#include "qmc/seq.h"

typedef struct qmc__seq_ops {
    /* Kind-specific checks: dimension range, scrambles, flags, set size.
     * Returns 0 or a QMC_E* code with a reason in why. */
    int (*check)(const qmc_seq_spec *spec, qmc__msg *why);
    /* Bytes of precomputed tables an instance needs (may be 0). */
    size_t (*table_bytes)(const qmc_seq_spec *spec);
    /* Fills seq->tables; cannot fail (memory is already there). */
    void (*init)(qmc_seq *seq);
    /* Coordinate dim of point index; both already range-checked. */
    double (*at)(const qmc_seq *seq, uint64_t index, uint32_t dim);
    /* Optional fast path: points [start, start + count), all dimensions,
     * row-major, in any format.  Must equal at() bit for bit.  NULL means
     * seq.c builds the fill from at(). */
    void (*fill)(const qmc_seq *seq, uint64_t start, uint64_t count,
                 qmc_format format, void *out);
} qmc__seq_ops;

struct qmc_seq {
    qmc_seq_spec spec;
    const qmc__seq_ops *ops;
    uint64_t end;   /* one past the last valid index */
    void *tables;   /* kind-owned, allocated with the instance */
};

/* What qmc_seq_new allocates for spec (0 for a spec it refuses). */
size_t qmc__seq_bytes(const qmc_seq_spec *spec);

extern const qmc__seq_ops qmc__seq_sobol;
extern const qmc__seq_ops qmc__seq_halton;
extern const qmc__seq_ops qmc__seq_hammersley;
extern const qmc__seq_ops qmc__seq_random;
extern const qmc__seq_ops qmc__seq_stratified;
extern const qmc__seq_ops qmc__seq_lhs;

/* The fill for kinds (or cases) without a fast path: at() for every
 * coordinate, one point at a time, converted to the format. */
void qmc__fill_from_at(const qmc_seq *seq, uint64_t start, uint64_t count,
                       qmc_format format, void *out);

/* Shared checks the kinds compose. */
int qmc__check_dims(const qmc_seq_spec *spec, uint32_t max_dims,
                    qmc__msg *why);
int qmc__check_scramble(const qmc_seq_spec *spec, unsigned allowed_mask,
                        qmc__msg *why);
int qmc__check_set_size(const qmc_seq_spec *spec, qmc__msg *why);
#define QMC__SCR_BIT(s) (1u << (s))

/* The three output formats are one number: f64 x, u32 floor(x * 2^32),
 * f32 floor(x * 2^24) / 2^24.  Scaling by a power of two is exact, so the
 * truncating casts below are the floors. */
static inline uint32_t qmc__f64_to_u32(double x)
{
    return (uint32_t)(x * 0x1p32);
}

static inline float qmc__f64_to_f32(double x)
{
    return (float)((double)(uint32_t)(x * 0x1p24) * 0x1p-24);
}

/* Per-dimension seeds for scrambles: hashed from the user's seed, the
 * dimension and a tag naming the use, so no dimension ever sees the raw
 * seed and two uses of one seed are independent. */
enum {
    QMC__TAG_OWEN = 0x6f77656e,   /* "owen" */
    QMC__TAG_SHIFT = 0x73686674,  /* "shft" */
    QMC__TAG_SHUFFLE = 0x73686666,/* "shff" */
    QMC__TAG_JITTER = 0x6a697472, /* "jitr" */
    QMC__TAG_PERM = 0x7065726d    /* "perm" */
};

#endif
