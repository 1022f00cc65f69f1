/*
 * pixel.c - the pixel-sampler API (qmc/pixel.h): spec and tile checks
 * with their one-line reasons, new/free, random access, fill dispatch,
 * names.
 *
 * Every argument is checked here, so the samplers (pixel_zsobol.c,
 * pixel_padded.c, pixel_sobol.c) only see values in range.  Limits are
 * said, never hidden: a sample past spp is refused (pbrt-v4's ZSobol
 * answers it with another pixel's sample, PR #298), and so is anything
 * whose index would not fit the sampler's bits.
 *
 * Must not: allocate outside qmc_pixels_new, print, or let a sampler see
 * an unchecked pixel, sample or dimension.
 */
#include <stdlib.h>
#include <string.h>

#include "pixel_impl.h"

static const qmc__pixel_ops *sampler_ops(qmc_pixel_sampler s)
{
    switch (s) {
    case QMC_PIXEL_ZSOBOL:
        return &qmc__pixel_zsobol;
    case QMC_PIXEL_PADDED_SOBOL:
        return &qmc__pixel_padded;
    case QMC_PIXEL_SOBOL:
        return &qmc__pixel_sobol;
    }
    return NULL;
}

static void msg_res(qmc__msg *m, uint32_t w, uint32_t h)
{
    qmc__msg_u64(m, w);
    qmc__msg_str(m, "x");
    qmc__msg_u64(m, h);
}

int qmc_pixel_spec_check(const qmc_pixel_spec *spec, char *why, size_t why_bytes)
{
    qmc__msg m;
    qmc__msg_init(&m, why, why_bytes);
    const qmc__pixel_ops *ops = sampler_ops(spec->sampler);
    if (!ops) {
        qmc__msg_set(&m, "unknown pixel sampler ", (uint64_t)spec->sampler,
                     ": use zsobol, padded-sobol or sobol");
        return QMC_EKIND;
    }
    if (spec->width == 0 || spec->height == 0) {
        qmc__msg_str(&m, "resolution ");
        msg_res(&m, spec->width, spec->height);
        qmc__msg_str(&m, " is empty: width and height must be at least 1");
        return QMC_EINVAL;
    }
    if (spec->dims == 0) {
        qmc__msg_str(&m, "dims 0: a sample needs at least 1 value");
        return QMC_EDIMS;
    }
    if (spec->spp == 0) {
        qmc__msg_str(&m, "spp 0: a pixel needs at least 1 sample");
        return QMC_ECOUNT;
    }
    return ops->check(spec, &m);
}

int qmc_pixels_new(const qmc_pixel_spec *spec, qmc_pixels **out)
{
    *out = NULL;
    int err = qmc_pixel_spec_check(spec, NULL, 0);
    if (err)
        return err;
    const qmc__pixel_ops *ops = sampler_ops(spec->sampler);
    size_t tables = ops->table_bytes(spec);
    /* One block: the header padded to a cache line, then the tables. */
    size_t head = (sizeof(qmc_pixels) + 63) & ~(size_t)63;
    qmc_pixels *p = aligned_alloc(64, (head + tables + 63) & ~(size_t)63);
    if (!p)
        return QMC_ENOMEM;
    memset(p, 0, head);
    p->spec = *spec;
    p->ops = ops;
    p->frame_mix = qmc__frame_mix(spec->frame);
    p->log2_res = qmc__ceil_log2(spec->width > spec->height ? spec->width : spec->height);
    p->tables = tables ? (char *)p + head : NULL;
    p->isa = qmc__pixel_isa();
    ops->init(p);
    *out = p;
    return 0;
}

void qmc_pixels_free(qmc_pixels *p)
{
    free(p);
}

const qmc_pixel_spec *qmc_pixels_get_spec(const qmc_pixels *p)
{
    return &p->spec;
}

uint64_t qmc_pixels_sample_end(const qmc_pixels *p)
{
    return p->sample_end;
}

/* The fix for a sample past the end: zsobol needs a power of two. */
static void msg_past_end(qmc__msg *m, const qmc_pixels *p, uint64_t sample)
{
    const qmc_pixel_spec *s = &p->spec;
    qmc__msg_set(m, "sample ", sample, "");
    if (s->sampler == QMC_PIXEL_SOBOL) {
        qmc__msg_str(m, " is past the sobol sampler's index space at ");
        msg_res(m, s->width, s->height);
        qmc__msg_str(m, " (");
        qmc__msg_u64(m, p->sample_end);
        qmc__msg_str(m, " samples per pixel): ask for fewer samples or a smaller image");
        return;
    }
    qmc__msg_str(m, " is past spp ");
    qmc__msg_u64(m, s->spp);
    qmc__msg_str(m, ": ask for a larger spp");
    uint64_t need = sample + 1;
    if (s->sampler == QMC_PIXEL_ZSOBOL && need <= (1ull << 63)) {
        need = 1ull << qmc__ceil_log2(need);
        qmc__msg_str(m, " (");
        qmc__msg_u64(m, need);
        qmc__msg_str(m, " covers it)");
    } else if (s->sampler == QMC_PIXEL_PADDED_SOBOL && need <= (1ull << 32)) {
        qmc__msg_str(m, " (at least ");
        qmc__msg_u64(m, need);
        qmc__msg_str(m, ")");
    }
}

int qmc_pixels_tile_check(const qmc_pixels *p, const qmc_pixel_tile *t, uint64_t *values,
                          char *why, size_t why_bytes)
{
    qmc__msg m;
    qmc__msg_init(&m, why, why_bytes);
    const qmc_pixel_spec *s = &p->spec;
    if (t->width == 0 || t->height == 0 || t->sample_count == 0) {
        qmc__msg_str(&m, "empty tile: width, height and sample count must be at least 1");
        return QMC_EINVAL;
    }
    if (t->x >= s->width || t->width > s->width - t->x || t->y >= s->height ||
        t->height > s->height - t->y) {
        qmc__msg_set(&m, "tile ", t->x, ",");
        qmc__msg_u64(&m, t->y);
        qmc__msg_str(&m, ",");
        qmc__msg_u64(&m, t->width);
        qmc__msg_str(&m, ",");
        qmc__msg_u64(&m, t->height);
        qmc__msg_str(&m, " reaches past the ");
        msg_res(&m, s->width, s->height);
        qmc__msg_str(&m, " image");
        return QMC_ERANGE;
    }
    if (t->sample_count - 1 > UINT64_MAX - t->sample_start) {
        qmc__msg_set(&m, "samples ", t->sample_start, " + ");
        qmc__msg_u64(&m, t->sample_count);
        qmc__msg_str(&m, " run past 2^64");
        return QMC_ERANGE;
    }
    uint64_t last = t->sample_start + (t->sample_count - 1);
    if (last >= p->sample_end) {
        msg_past_end(&m, p, last);
        return QMC_ERANGE;
    }
    uint64_t n;
    if (__builtin_mul_overflow((uint64_t)t->width, (uint64_t)t->height, &n) ||
        __builtin_mul_overflow(n, t->sample_count, &n) ||
        __builtin_mul_overflow(n, (uint64_t)s->dims, &n) || n > SIZE_MAX / sizeof(double)) {
        qmc__msg_str(&m, "tile of ");
        msg_res(&m, t->width, t->height);
        qmc__msg_str(&m, " pixels, ");
        qmc__msg_u64(&m, t->sample_count);
        qmc__msg_str(&m, " samples and ");
        qmc__msg_u64(&m, s->dims);
        qmc__msg_str(&m, " dims has too many values (its f64 bytes pass 2^64): split it");
        return QMC_ERANGE;
    }
    if (values)
        *values = n;
    return 0;
}

int qmc_pixels_at(const qmc_pixels *p, uint32_t x, uint32_t y, uint64_t sample, uint32_t dim,
                  uint32_t *out)
{
    *out = 0;
    if (x >= p->spec.width || y >= p->spec.height || sample >= p->sample_end)
        return QMC_ERANGE;
    if (dim >= p->spec.dims)
        return QMC_EDIMS;
    *out = p->ops->at(p, x, y, sample, dim);
    return 0;
}

int qmc_pixels_fill(const qmc_pixels *p, const qmc_pixel_tile *tile, qmc_format format,
                    void *out)
{
    if (qmc_format_bytes(format) == 0)
        return QMC_EFORMAT;
    int err = qmc_pixels_tile_check(p, tile, NULL, NULL, 0);
    if (err)
        return err;
    p->ops->fill(p, tile, format, out);
    return 0;
}

void qmc__pixel_fill_from_at(const qmc_pixels *p, const qmc_pixel_tile *t, qmc_format fmt,
                             void *out)
{
    const uint32_t dims = p->spec.dims;
    size_t k = 0;
    for (uint32_t y = t->y; y < t->y + t->height; y++)
        for (uint32_t x = t->x; x < t->x + t->width; x++)
            for (uint64_t i = 0; i < t->sample_count; i++)
                for (uint32_t d = 0; d < dims; d++)
                    qmc__pixel_store(out, k++, p->ops->at(p, x, y, t->sample_start + i, d),
                                     fmt);
}

/* ---- names ---------------------------------------------------------------- */

const char *qmc_pixel_sampler_name(qmc_pixel_sampler sampler)
{
    switch (sampler) {
#define QMC__PIXEL_TEXT(name, value, text) \
    case QMC_PIXEL_##name:                 \
        return text;
        QMC_PIXEL_SAMPLER_MAP(QMC__PIXEL_TEXT)
#undef QMC__PIXEL_TEXT
    }
    return "";
}

int qmc_pixel_sampler_parse(const char *name, qmc_pixel_sampler *out)
{
#define QMC__PIXEL_PARSE(ename, value, text) \
    if (strcmp(name, text) == 0) {           \
        *out = QMC_PIXEL_##ename;            \
        return 0;                            \
    }
    QMC_PIXEL_SAMPLER_MAP(QMC__PIXEL_PARSE)
#undef QMC__PIXEL_PARSE
    return QMC_EKIND;
}
