/*
 * pixel_kernel.c - the pixel kernels (pixel_kernel.h) built for the
 * baseline instruction set, 4 lanes, and the dispatch that picks the
 * widest build the CPU runs (pixel_kernel_avx2.c, pixel_kernel_avx512.c).
 * Every build gives the same bits: test_pixel compares fills with at().
 *
 * Must not: allocate, or keep state (the CPU flags are libgcc's).
 */
#define PK_VW 4
#include "pixel_kernel.h"

/* ---- passes and their lane patterns (the same for every build) ---------- */

uint32_t qmc__pixel_pass_cols(uint32_t dims, uint32_t d0)
{
    const uint32_t left = dims - d0;
    if (d0 == 0 && dims <= 16)
        return dims;
    if (left >= QMC__PIXEL_MAX_COLS)
        return QMC__PIXEL_MAX_COLS;
    return left >= 16 ? left & ~15u : left;
}

void qmc__pixel_pattern_init(qmc__pixel_pattern *pt, uint32_t nc, const uint8_t *mode,
                             int paired)
{
    /* lcm(nc, 16): nc <= 16 or a multiple of 16, so at most 240. */
    uint32_t g = nc, b = 16;
    while (b) {
        uint32_t t = g % b;
        g = b;
        b = t;
    }
    pt->nc = nc;
    pt->period = nc / g * 16;
    pt->rows_per_period = pt->period / nc;
    pt->any_plain = pt->any_dim1 = 0;
    pt->paired = paired != 0;
    const uint32_t width = paired ? (nc + 1) / 2 : nc;
    pt->in_per_period = pt->rows_per_period * width;
    for (uint32_t l = 0; l < pt->period; l++) {
        const uint32_t c = l % nc;
        pt->rowoff[l] = l / nc;
        /* A vector's lanes read at most PK_VW consecutive words from the
         * first one's: nc <= 16 lanes span < 16 / nc + 1 rows of nc / 2
         * words, and 16 lanes of one row 8 pairs. */
        pt->src[l] = pt->rowoff[l] * width + (paired ? c / 2 : c);
        pt->dim1[l] = mode[c] == QMC__PIXEL_OWEN_DIM1 ? ~0u : 0;
        pt->owen[l] = mode[c] == QMC__PIXEL_PLAIN ? 0 : ~0u;
        pt->any_dim1 |= mode[c] == QMC__PIXEL_OWEN_DIM1;
        pt->any_plain |= mode[c] == QMC__PIXEL_PLAIN;
    }
}

void qmc__pixel_pattern_set(qmc__pixel_pattern *pt, const uint32_t *xorc, const uint32_t *seed,
                            const uint32_t *perm)
{
    const uint32_t nc = pt->nc;
    for (uint32_t l = 0, c = 0; l < pt->period; l++, c = c + 1 == nc ? 0 : c + 1) {
        if (xorc)
            pt->xorc[l] = xorc[c];
        if (seed) {
            pt->seed[l] = seed[c];
            pt->smul[l] = (seed[c] >> 16) | 1u;
        }
        if (perm)
            pt->perm[l] = perm[c];
    }
}

/* ---- dispatch ---------------------------------------------------------------- */

#if defined(__x86_64__) && defined(__GNUC__)
#define PIXEL_KERNEL_X86 1
#endif

/* AVX-512 needs F, VL, BW and DQ, as seq_sobol.c asks. */
int qmc__pixel_isa(void)
{
#ifdef PIXEL_KERNEL_X86
    if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
        __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512dq"))
        return 2;
    return __builtin_cpu_supports("avx2") ? 1 : 0;
#else
    return 0;
#endif
}

void qmc__pixel_emit(int isa, const qmc__pixel_pattern *pt, const uint32_t *in, uint64_t row_start,
                     uint32_t w, uint32_t rows, qmc_format fmt, void *out, size_t stride,
                     void *scratch)
{
#ifdef PIXEL_KERNEL_X86
    switch (isa) {
    case 2:
        qmc__pixel_emit_avx512(pt, in, row_start, w, rows, fmt, out, stride, scratch);
        return;
    case 1:
        qmc__pixel_emit_avx2(pt, in, row_start, w, rows, fmt, out, stride, scratch);
        return;
    }
#endif
    pk_emit(pt, in, row_start, w, rows, fmt, out, stride, scratch);
}

void qmc__pixel_nodes(int isa, uint64_t key0, uint64_t salt, uint32_t n, int bit, uint8_t *out)
{
#ifdef PIXEL_KERNEL_X86
    switch (isa) {
    case 2:
        qmc__pixel_nodes_avx512(key0, salt, n, bit, out);
        return;
    case 1:
        qmc__pixel_nodes_avx2(key0, salt, n, bit, out);
        return;
    }
#endif
    pk_nodes(key0, salt, n, bit, out);
}
