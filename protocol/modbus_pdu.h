/*
 * modbus_pdu.h - bounded big-endian cursors over one Modbus PDU (private to
 * protocol/modbus*.c).  A read past the end sets `bad` and yields 0; a
 * write past the end sets `bad` and stores nothing, so a handler checks
 * once, after its fields, instead of before each one.
 */
#ifndef QMC_PROTOCOL_MODBUS_PDU_H
#define QMC_PROTOCOL_MODBUS_PDU_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "qmc/modbus.h"

typedef struct qmc__mb_rd {
    const uint8_t *p;
    size_t len, off;
    int bad;
} qmc__mb_rd;

typedef struct qmc__mb_wr {
    uint8_t *p;
    size_t cap, off;
    int bad;
} qmc__mb_wr;

static inline uint8_t qmc__mb_u8(qmc__mb_rd *r)
{
    if (r->len - r->off < 1) {
        r->bad = 1;
        return 0;
    }
    return r->p[r->off++];
}

static inline uint16_t qmc__mb_u16(qmc__mb_rd *r)
{
    if (r->len - r->off < 2) {
        r->bad = 1;
        r->off = r->len;
        return 0;
    }
    uint16_t v = (uint16_t)(r->p[r->off] << 8 | r->p[r->off + 1]);
    r->off += 2;
    return v;
}

/* Every field was present and nothing follows them. */
static inline int qmc__mb_rd_done(const qmc__mb_rd *r)
{
    return !r->bad && r->off == r->len;
}

static inline void qmc__mb_put_bytes(qmc__mb_wr *w, const void *src, size_t n)
{
    if (w->cap - w->off < n) {
        w->bad = 1;
        return;
    }
    memcpy(w->p + w->off, src, n);
    w->off += n;
}

static inline void qmc__mb_put_u8(qmc__mb_wr *w, uint8_t v)
{
    qmc__mb_put_bytes(w, &v, 1);
}

static inline void qmc__mb_put_u16(qmc__mb_wr *w, uint16_t v)
{
    uint8_t b[2] = {(uint8_t)(v >> 8), (uint8_t)v};
    qmc__mb_put_bytes(w, b, 2);
}

/* A u64 into four registers, high word first (the index, the counters,
 * the integration block's counts). */
static inline void qmc__mb_regs_u64(uint16_t *r, uint64_t v)
{
    for (int i = 0; i < 4; i++)
        r[i] = (uint16_t)(v >> (48 - 16 * i));
}

/* FC17 and FC43/14 (modbus_ident.c): return 0 or an exception code. */
int qmc__modbus_report_id(const qmc_modbus_env *env, qmc__mb_rd *r, qmc__mb_wr *w);
int qmc__modbus_device_id(const qmc_modbus_env *env, qmc__mb_rd *r, qmc__mb_wr *w);

#endif
