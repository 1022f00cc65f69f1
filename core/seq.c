/*
 * seq.c - the public sequence API: spec checking, instance lifetime, range
 * checks, and the f64/f32/u32 output formats, over the kind table in
 * seq_impl.h.  Kinds live one to a file (seq_sobol.c, seq_halton.c, ...).
 *
 * Must not: allocate after qmc_seq_new, or let any kind see an index or
 * dimension outside the instance's range.
 */
#include <stdlib.h>
#include <string.h>

#include "seq_impl.h"

static const qmc__seq_ops *kind_ops(qmc_seq_kind kind)
{
    switch (kind) {
    case QMC_SEQ_SOBOL:
        return &qmc__seq_sobol;
    case QMC_SEQ_HALTON:
        return &qmc__seq_halton;
    case QMC_SEQ_HAMMERSLEY:
        return &qmc__seq_hammersley;
    case QMC_SEQ_RANDOM:
        return &qmc__seq_random;
    case QMC_SEQ_STRATIFIED:
        return &qmc__seq_stratified;
    case QMC_SEQ_LHS:
        return &qmc__seq_lhs;
    }
    return NULL;
}

static int is_finite_kind(qmc_seq_kind kind)
{
    return kind == QMC_SEQ_HAMMERSLEY || kind == QMC_SEQ_STRATIFIED ||
           kind == QMC_SEQ_LHS;
}

int qmc__check_dims(const qmc_seq_spec *spec, uint32_t max_dims,
                    qmc__msg *why)
{
    if (spec->dims >= 1 && spec->dims <= max_dims)
        return 0;
    qmc__msg_set(why, "", spec->dims, " dims is outside ");
    qmc__msg_str(why, qmc_seq_kind_name(spec->kind));
    qmc__msg_str(why, "'s range 1..");
    qmc__msg_u64(why, max_dims);
    return QMC_EDIMS;
}

int qmc__check_scramble(const qmc_seq_spec *spec, unsigned allowed_mask,
                        qmc__msg *why)
{
    if (QMC__SCR_BIT(spec->scramble) & allowed_mask)
        return 0;
    qmc__msg_str(why, qmc_seq_kind_name(spec->kind));
    qmc__msg_str(why, " does not take scramble '");
    qmc__msg_str(why, qmc_scramble_name(spec->scramble));
    qmc__msg_str(why, "'; it takes:");
#define QMC__LIST_SCR(name, value, text)                \
    if (QMC__SCR_BIT(QMC_SCRAMBLE_##name) & allowed_mask) \
        qmc__msg_str(why, " " text);
    QMC_SCRAMBLE_MAP(QMC__LIST_SCR)
#undef QMC__LIST_SCR
    if (spec->scramble == QMC_SCRAMBLE_FAST_OWEN)
        qmc__msg_str(why, " (fast-owen scrambles base-2 digits: sobol only)");
    return QMC_ESCRAMBLE;
}

int qmc__check_set_size(const qmc_seq_spec *spec, qmc__msg *why)
{
    if (spec->set_size >= 1 && spec->set_size <= QMC_SEQ_MAX_INDEX)
        return 0;
    qmc__msg_str(why, qmc_seq_kind_name(spec->kind));
    qmc__msg_str(why, " is a finite set: its size must be 1..2^32, not ");
    qmc__msg_u64(why, spec->set_size);
    return QMC_ECOUNT;
}

int qmc_seq_spec_check(const qmc_seq_spec *spec, char *why, size_t why_bytes)
{
    qmc__msg m;
    qmc__msg_init(&m, why, why_bytes);
    if (!spec) {
        qmc__msg_str(&m, "no sequence spec");
        return QMC_EINVAL;
    }
    const qmc__seq_ops *ops = kind_ops(spec->kind);
    if (!ops) {
        qmc__msg_set(&m, "unknown sequence kind ", (uint64_t)spec->kind, "");
        return QMC_EKIND;
    }
    if (!qmc_scramble_name(spec->scramble)[0]) {
        qmc__msg_set(&m, "unknown scramble ", (uint64_t)spec->scramble, "");
        return QMC_ESCRAMBLE;
    }
    if (spec->flags & ~(uint32_t)QMC_SEQ_SHUFFLE) {
        qmc__msg_set(&m, "unknown sequence flag bits ", spec->flags, "");
        return QMC_EINVAL;
    }
    if (spec->flags & QMC_SEQ_SHUFFLE && spec->kind != QMC_SEQ_SOBOL) {
        qmc__msg_str(&m, "index shuffling is for sobol only");
        return QMC_EINVAL;
    }
    if (!is_finite_kind(spec->kind) && spec->set_size != 0) {
        qmc__msg_str(&m, qmc_seq_kind_name(spec->kind));
        qmc__msg_str(&m, " is an infinite sequence: set size must be 0");
        return QMC_ECOUNT;
    }
    return ops->check(spec, &m);
}

size_t qmc__seq_bytes(const qmc_seq_spec *spec)
{
    if (qmc_seq_spec_check(spec, NULL, 0) != 0)
        return 0;
    size_t head = (sizeof(qmc_seq) + 63) & ~(size_t)63;
    return (head + kind_ops(spec->kind)->table_bytes(spec) + 63) & ~(size_t)63;
}

int qmc_seq_new(const qmc_seq_spec *spec, qmc_seq **out)
{
    *out = NULL;
    int err = qmc_seq_spec_check(spec, NULL, 0);
    if (err)
        return err;
    const qmc__seq_ops *ops = kind_ops(spec->kind);
    size_t tables = ops->table_bytes(spec);
    /* One block: the header, padded to 64 bytes so the tables start on a
     * cache line, then the kind's tables. */
    size_t head = (sizeof(qmc_seq) + 63) & ~(size_t)63;
    qmc_seq *seq = aligned_alloc(64, (head + tables + 63) & ~(size_t)63);
    if (!seq)
        return QMC_ENOMEM;
    seq->spec = *spec;
    seq->ops = ops;
    seq->end = is_finite_kind(spec->kind) ? spec->set_size : QMC_SEQ_MAX_INDEX;
    seq->tables = tables ? (char *)seq + head : NULL;
    ops->init(seq);
    *out = seq;
    return 0;
}

void qmc_seq_free(qmc_seq *seq)
{
    free(seq);
}

const qmc_seq_spec *qmc_seq_get_spec(const qmc_seq *seq)
{
    return &seq->spec;
}

uint64_t qmc_seq_end(const qmc_seq *seq)
{
    return seq->end;
}

int qmc_seq_range_check(const qmc_seq *seq, uint64_t start, uint64_t count,
                        char *why, size_t why_bytes)
{
    qmc__msg m;
    qmc__msg_init(&m, why, why_bytes);
    if (start <= seq->end && count <= seq->end - start)
        return 0;
    qmc__msg_set(&m, "points [", start, ", ");
    /* start + count may wrap; print it as start and count then. */
    if (count <= UINT64_MAX - start) {
        qmc__msg_u64(&m, start + count);
        qmc__msg_str(&m, ")");
    } else {
        qmc__msg_str(&m, "start+");
        qmc__msg_u64(&m, count);
        qmc__msg_str(&m, ")");
    }
    qmc__msg_str(&m, " run past the end of ");
    qmc__msg_str(&m, qmc_seq_kind_name(seq->spec.kind));
    qmc__msg_str(&m, is_finite_kind(seq->spec.kind) ? " (a set of "
                                                    : " (which has ");
    qmc__msg_u64(&m, seq->end);
    qmc__msg_str(&m, " points)");
    return QMC_ERANGE;
}

int qmc_seq_at(const qmc_seq *seq, uint64_t index, uint32_t dim, double *out)
{
    *out = 0.0;
    if (index >= seq->end)
        return QMC_ERANGE;
    if (dim >= seq->spec.dims)
        return QMC_EDIMS;
    *out = seq->ops->at(seq, index, dim);
    return 0;
}

size_t qmc_format_bytes(qmc_format format)
{
    switch (format) {
#define QMC__FMT_BYTES(name, value, text, bytes) \
    case QMC_FORMAT_##name:                      \
        return bytes;
        QMC_FORMAT_MAP(QMC__FMT_BYTES)
#undef QMC__FMT_BYTES
    }
    return 0;
}

void qmc__fill_from_at(const qmc_seq *seq, uint64_t start, uint64_t count,
                         qmc_format format, void *out)
{
    const uint32_t dims = seq->spec.dims;
    for (uint64_t p = 0; p < count; p++) {
        for (uint32_t j = 0; j < dims; j++) {
            double x = seq->ops->at(seq, start + p, j);
            size_t k = (size_t)p * dims + j;
            switch (format) {
            case QMC_FORMAT_F64:
                ((double *)out)[k] = x;
                break;
            case QMC_FORMAT_F32:
                ((float *)out)[k] = qmc__f64_to_f32(x);
                break;
            case QMC_FORMAT_U32:
                ((uint32_t *)out)[k] = qmc__f64_to_u32(x);
                break;
            }
        }
    }
}

int qmc_seq_fill(const qmc_seq *seq, uint64_t start, uint64_t count,
                 qmc_format format, void *out)
{
    if (qmc_format_bytes(format) == 0)
        return QMC_EFORMAT;
    int err = qmc_seq_range_check(seq, start, count, NULL, 0);
    if (err)
        return err;
    if (count == 0)
        return 0;
    if (seq->ops->fill)
        seq->ops->fill(seq, start, count, format, out);
    else
        qmc__fill_from_at(seq, start, count, format, out);
    return 0;
}

/* ---- names ---------------------------------------------------------------- */

const char *qmc_seq_kind_name(qmc_seq_kind kind)
{
    switch (kind) {
#define QMC__KIND_TEXT(name, value, text) \
    case QMC_SEQ_##name:                  \
        return text;
        QMC_SEQ_KIND_MAP(QMC__KIND_TEXT)
#undef QMC__KIND_TEXT
    }
    return "";
}

const char *qmc_scramble_name(qmc_scramble scramble)
{
    switch (scramble) {
#define QMC__SCR_TEXT(name, value, text) \
    case QMC_SCRAMBLE_##name:            \
        return text;
        QMC_SCRAMBLE_MAP(QMC__SCR_TEXT)
#undef QMC__SCR_TEXT
    }
    return "";
}

const char *qmc_format_name(qmc_format format)
{
    switch (format) {
#define QMC__FMT_TEXT(name, value, text, bytes) \
    case QMC_FORMAT_##name:                     \
        return text;
        QMC_FORMAT_MAP(QMC__FMT_TEXT)
#undef QMC__FMT_TEXT
    }
    return "";
}

int qmc_seq_kind_parse(const char *name, qmc_seq_kind *out)
{
#define QMC__KIND_PARSE(n, value, text) \
    if (strcmp(name, text) == 0) {      \
        *out = QMC_SEQ_##n;             \
        return 0;                       \
    }
    QMC_SEQ_KIND_MAP(QMC__KIND_PARSE)
#undef QMC__KIND_PARSE
    return QMC_EKIND;
}

int qmc_scramble_parse(const char *name, qmc_scramble *out)
{
#define QMC__SCR_PARSE(n, value, text) \
    if (strcmp(name, text) == 0) {     \
        *out = QMC_SCRAMBLE_##n;       \
        return 0;                      \
    }
    QMC_SCRAMBLE_MAP(QMC__SCR_PARSE)
#undef QMC__SCR_PARSE
    return QMC_ESCRAMBLE;
}

int qmc_format_parse(const char *name, qmc_format *out)
{
#define QMC__FMT_PARSE(n, value, text, bytes) \
    if (strcmp(name, text) == 0) {            \
        *out = QMC_FORMAT_##n;                \
        return 0;                             \
    }
    QMC_FORMAT_MAP(QMC__FMT_PARSE)
#undef QMC__FMT_PARSE
    return QMC_EFORMAT;
}
