/*
 * qmc/seq.h - low-discrepancy and random point sequences.
 *
 * A sequence is fixed by a qmc_seq_spec: (kind, dims, scramble, flags, seed,
 * and for finite kinds the set size).  Point i, coordinate j is a pure
 * function of the spec and (i, j), always in [0, 1), never 1.0.  Random
 * access (qmc_seq_at) and batch fill (qmc_seq_fill) agree bit for bit, at
 * any optimisation level and thread count.
 *
 * A qmc_seq is immutable after qmc_seq_new: any number of threads may call
 * qmc_seq_at / qmc_seq_fill on one instance at once.  Neither allocates.
 */
#ifndef QMC_SEQ_H
#define QMC_SEQ_H

#include <stddef.h>
#include <stdint.h>

#include "qmc/error.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Sequence kinds.  X(enum suffix, wire value, CLI name). */
#define QMC_SEQ_KIND_MAP(X)          \
    X(SOBOL,      1, "sobol")        \
    X(HALTON,     2, "halton")       \
    X(HAMMERSLEY, 3, "hammersley")   \
    X(RANDOM,     4, "random")       \
    X(STRATIFIED, 5, "stratified")   \
    X(LHS,        6, "lhs")

typedef enum qmc_seq_kind {
#define QMC__KIND_ENUM(name, value, text) QMC_SEQ_##name = (value),
    QMC_SEQ_KIND_MAP(QMC__KIND_ENUM)
#undef QMC__KIND_ENUM
} qmc_seq_kind;

/* Scrambles.  Which kinds take which is checked by qmc_seq_spec_check;
 * docs/SEQUENCES.md defines each.  fast-owen (sobol only) is owen's hash
 * with pbrt-v4's per-dimension seeds: with a seed below 2^32 its values are
 * pbrt-v4's SobolSampler with FastOwen randomization. */
#define QMC_SCRAMBLE_MAP(X)          \
    X(NONE,      0, "none")          \
    X(SHIFT,     1, "shift")         \
    X(OWEN,      2, "owen")          \
    X(FAURE,     3, "faure")         \
    X(FAST_OWEN, 4, "fast-owen")

typedef enum qmc_scramble {
#define QMC__SCR_ENUM(name, value, text) QMC_SCRAMBLE_##name = (value),
    QMC_SCRAMBLE_MAP(QMC__SCR_ENUM)
#undef QMC__SCR_ENUM
} qmc_scramble;

/* Output formats for qmc_seq_fill. */
#define QMC_FORMAT_MAP(X) \
    X(F64, 1, "f64", 8)   \
    X(F32, 2, "f32", 4)   \
    X(U32, 3, "u32", 4)

typedef enum qmc_format {
#define QMC__FMT_ENUM(name, value, text, bytes) QMC_FORMAT_##name = (value),
    QMC_FORMAT_MAP(QMC__FMT_ENUM)
#undef QMC__FMT_ENUM
} qmc_format;

/* Flag bits for qmc_seq_spec.flags. */
enum {
    /* Sobol only: visit points in a seeded nested-uniform shuffled index
     * order (Burley 2020, section 4), so that prefixes of a scrambled
     * sequence are decorrelated between pixels.  Batch fill is then no
     * faster than random access. */
    QMC_SEQ_SHUFFLE = 1u << 0
};

/* Limits, checked by qmc_seq_spec_check and the range checks. */
#define QMC_SOBOL_MAX_DIMS 21201u
#define QMC_HALTON_MAX_DIMS 4096u
#define QMC_MAX_DIMS 21201u            /* the largest of all kinds */
#define QMC_SEQ_MAX_INDEX 4294967296ull /* 2^32: indices are below this */

typedef struct qmc_seq_spec {
    qmc_seq_kind kind;
    uint32_t dims;         /* 1 .. the kind's maximum */
    qmc_scramble scramble; /* QMC_SCRAMBLE_NONE where the kind has none */
    uint32_t flags;        /* QMC_SEQ_* bits */
    uint64_t seed;         /* ignored by unscrambled deterministic kinds */
    uint64_t set_size;     /* finite kinds (hammersley, stratified, lhs):
                              number of points in the set; 0 otherwise */
} qmc_seq_spec;

typedef struct qmc_seq qmc_seq;

/*
 * Checks a spec without allocating.  Returns 0 or the code qmc_seq_new
 * would return.  When why is not NULL, writes a one-line, NUL-terminated
 * reason naming the problem (e.g. valid stratified counts) into why[0 ..
 * why_bytes).
 */
QMC_MUST_CHECK int qmc_seq_spec_check(const qmc_seq_spec *spec, char *why,
                                      size_t why_bytes);

/*
 * Creates a sequence.  On success *out owns a new instance (free it with
 * qmc_seq_free); on failure *out is NULL.  Errors: those of
 * qmc_seq_spec_check, QMC_ENOMEM.
 */
QMC_MUST_CHECK int qmc_seq_new(const qmc_seq_spec *spec, qmc_seq **out);

/* Frees a sequence; NULL is a no-op. */
void qmc_seq_free(qmc_seq *seq);

/* The spec the sequence was made from. */
const qmc_seq_spec *qmc_seq_get_spec(const qmc_seq *seq);

/* One past the last valid index: 2^32, or set_size for finite kinds. */
uint64_t qmc_seq_end(const qmc_seq *seq);

/*
 * Checks that [start, start + count) lies inside the sequence.  Returns 0
 * or QMC_ERANGE, with a reason in why as for qmc_seq_spec_check.
 */
QMC_MUST_CHECK int qmc_seq_range_check(const qmc_seq *seq, uint64_t start,
                                       uint64_t count, char *why,
                                       size_t why_bytes);

/*
 * Coordinate dim of point index, in [0, 1).  Errors: QMC_ERANGE (index),
 * QMC_EDIMS (dim >= dims); *out is 0.0 on error.
 */
QMC_MUST_CHECK int qmc_seq_at(const qmc_seq *seq, uint64_t index,
                              uint32_t dim, double *out);

/*
 * Writes points [start, start + count) row-major into out: count * dims
 * values of the format's size (f64: double; f32: float; u32: uint32_t, the
 * value times 2^32).  The three formats are the same numbers: u32 is
 * floor(x * 2^32) and f32 is floor(x * 2^24) / 2^24, so neither can round up
 * to 1.0.  Errors: QMC_ERANGE, QMC_EFORMAT; nothing is written on error.
 */
QMC_MUST_CHECK int qmc_seq_fill(const qmc_seq *seq, uint64_t start,
                                uint64_t count, qmc_format format, void *out);

/* Bytes one coordinate takes in a format, 0 for an unknown format. */
size_t qmc_format_bytes(qmc_format format);

/* Name <-> value lookups for the X-macro tables above.  The parse functions
 * return 0 or QMC_EKIND / QMC_ESCRAMBLE / QMC_EFORMAT. */
const char *qmc_seq_kind_name(qmc_seq_kind kind);
const char *qmc_scramble_name(qmc_scramble scramble);
const char *qmc_format_name(qmc_format format);
QMC_MUST_CHECK int qmc_seq_kind_parse(const char *name, qmc_seq_kind *out);
QMC_MUST_CHECK int qmc_scramble_parse(const char *name, qmc_scramble *out);
QMC_MUST_CHECK int qmc_format_parse(const char *name, qmc_format *out);

/*
 * A 64-bit fingerprint of the built-in Sobol direction-number table, so
 * that peers can confirm they generate the same sequence.
 */
uint64_t qmc_sobol_table_hash(void);

#ifdef __cplusplus
}
#endif
#endif /* QMC_SEQ_H */
