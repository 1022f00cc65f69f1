/*
 * modbus_device.c - the Modbus master and measuring device of the
 * integration block's unit tests (see modbus_device.h).
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <string.h>

#include "modbus_device.h"

mb_reply mb_call(qmc_modbus_session *s, const qmc_modbus_env *env, const uint8_t *req, size_t n)
{
    mb_reply r;
    memset(&r, 0xEE, sizeof r);
    r.n = qmc_modbus_handle(s, env, req, n, r.b, sizeof r.b);
    assert_true(r.n > 0);
    return r;
}

mb_reply mb_read(qmc_modbus_session *s, const qmc_modbus_env *env, uint8_t fc, unsigned addr,
                 unsigned count)
{
    uint8_t q[5] = {fc, (uint8_t)(addr >> 8), (uint8_t)addr, (uint8_t)(count >> 8),
                    (uint8_t)count};
    return mb_call(s, env, q, sizeof q);
}

mb_reply mb_write1(qmc_modbus_session *s, const qmc_modbus_env *env, unsigned addr, unsigned v)
{
    uint8_t q[5] = {0x06, (uint8_t)(addr >> 8), (uint8_t)addr, (uint8_t)(v >> 8), (uint8_t)v};
    return mb_call(s, env, q, sizeof q);
}

mb_reply mb_write(qmc_modbus_session *s, const qmc_modbus_env *env, unsigned addr,
                  const uint16_t *v, unsigned n)
{
    uint8_t q[QMC_MODBUS_MAX_PDU];
    q[0] = 0x10;
    q[1] = (uint8_t)(addr >> 8), q[2] = (uint8_t)addr;
    q[3] = (uint8_t)(n >> 8), q[4] = (uint8_t)n;
    q[5] = (uint8_t)(2 * n);
    for (unsigned i = 0; i < n; i++)
        q[6 + 2 * i] = (uint8_t)(v[i] >> 8), q[7 + 2 * i] = (uint8_t)v[i];
    return mb_call(s, env, q, 6 + 2 * (size_t)n);
}

mb_reply mb_read_write(qmc_modbus_session *s, const qmc_modbus_env *env, unsigned raddr,
                       unsigned rn, unsigned waddr, const uint16_t *v, unsigned wn)
{
    uint8_t q[QMC_MODBUS_MAX_PDU];
    q[0] = 0x17;
    q[1] = (uint8_t)(raddr >> 8), q[2] = (uint8_t)raddr;
    q[3] = (uint8_t)(rn >> 8), q[4] = (uint8_t)rn;
    q[5] = (uint8_t)(waddr >> 8), q[6] = (uint8_t)waddr;
    q[7] = (uint8_t)(wn >> 8), q[8] = (uint8_t)wn;
    q[9] = (uint8_t)(2 * wn);
    for (unsigned i = 0; i < wn; i++)
        q[10 + 2 * i] = (uint8_t)(v[i] >> 8), q[11 + 2 * i] = (uint8_t)v[i];
    return mb_call(s, env, q, 10 + 2 * (size_t)wn);
}

uint16_t mb_reg(const mb_reply *r, unsigned i)
{
    return (uint16_t)(r->b[2 + 2 * i] << 8 | r->b[3 + 2 * i]);
}

void mb_assert_exception(const mb_reply *r, uint8_t fc, uint8_t code)
{
    assert_int_equal(r->n, 2);
    assert_int_equal(r->b[0], fc | 0x80);
    assert_int_equal(r->b[1], code);
}

void mb_assert_written(const mb_reply *r)
{
    assert_int_equal(r->n, 5);
    assert_int_equal(r->b[0], 0x10);
}

void mb_snapshot_take(qmc_modbus_session *s, const qmc_modbus_env *env, mb_snapshot *out)
{
    mb_reply r = mb_read(s, env, 0x03, QMC_MODBUS_SETUP_BASE, QMC_MODBUS_SETUP_COUNT);
    assert_int_equal(r.n, 2 + 2 * QMC_MODBUS_SETUP_COUNT);
    for (unsigned i = 0; i < QMC_MODBUS_SETUP_COUNT; i++)
        out->setup[i] = mb_reg(&r, i);
    r = mb_read(s, env, 0x03, QMC_MODBUS_VALUE_BASE, QMC_MODBUS_VALUE_COUNT);
    assert_int_equal(r.n, 2 + 2 * QMC_MODBUS_VALUE_COUNT);
    for (unsigned i = 0; i < QMC_MODBUS_VALUE_COUNT; i++)
        out->value[i] = mb_reg(&r, i);
    r = mb_read(s, env, 0x04, QMC_MODBUS_INTEG_BASE, QMC_MODBUS_INTEG_COUNT);
    assert_int_equal(r.n, 2 + 2 * QMC_MODBUS_INTEG_COUNT);
    for (unsigned i = 0; i < QMC_MODBUS_INTEG_COUNT; i++)
        out->ib[i] = mb_reg(&r, i);
    mb_reply h = mb_read(s, env, 0x03, QMC_MODBUS_INTEG_BASE, QMC_MODBUS_INTEG_COUNT);
    assert_int_equal(h.n, r.n);
    assert_memory_equal(h.b + 2, r.b + 2, (size_t)r.n - 2);
}

uint32_t mb_u32(const uint16_t *r)
{
    return (uint32_t)r[0] << 16 | r[1];
}

uint64_t mb_u64(const uint16_t *r)
{
    return (uint64_t)r[0] << 48 | (uint64_t)r[1] << 32 | (uint64_t)r[2] << 16 | r[3];
}

float mb_f32(const uint16_t *r, int low_first)
{
    uint32_t bits = low_first ? (uint32_t)r[1] << 16 | r[0] : (uint32_t)r[0] << 16 | r[1];
    float f;
    memcpy(&f, &bits, sizeof f);
    return f;
}

double mb_f64(const uint16_t *r, int low_first)
{
    uint64_t bits = 0;
    for (int i = 0; i < 4; i++)
        bits = bits << 16 | r[low_first ? 3 - i : i];
    double x;
    memcpy(&x, &bits, sizeof x);
    return x;
}

void mb_put_f32(uint16_t *r, float f, int low_first)
{
    uint32_t bits;
    memcpy(&bits, &f, sizeof bits);
    uint16_t hi = (uint16_t)(bits >> 16), lo = (uint16_t)bits;
    r[0] = low_first ? lo : hi;
    r[1] = low_first ? hi : lo;
}

double mb_coord(const uint16_t *r, int format, int low_first, unsigned *regs)
{
    if (format == QMC_MODBUS_FORMAT_U16) {
        *regs = 1;
        return r[0] / 65536.0;
    }
    *regs = 2;
    if (format == QMC_MODBUS_FORMAT_U32) {
        uint32_t u = low_first ? (uint32_t)r[1] << 16 | r[0] : (uint32_t)r[0] << 16 | r[1];
        return u / 4294967296.0;
    }
    return mb_f32(r, low_first);
}

uint64_t mb_device_run(qmc_modbus_session *s, const qmc_modbus_env *env, const mb_device *d,
                       uint64_t max_points)
{
    const unsigned per = d->format == QMC_MODBUS_FORMAT_U16 ? 1 : 2;
    const unsigned head = QMC_MODBUS_IB_POINT + per * d->dims;
    uint64_t done = 0;
    uint32_t last_request = 0;
    mb_reply e0 = mb_read(s, env, 0x04, QMC_MODBUS_INTEG_BASE + QMC_MODBUS_IB_EVALS, 4);
    const uint16_t ev0[4] = {mb_reg(&e0, 0), mb_reg(&e0, 1), mb_reg(&e0, 2), mb_reg(&e0, 3)};
    const uint64_t evals0 = mb_u64(ev0);
    mb_reply r = mb_read(s, env, 0x04, QMC_MODBUS_INTEG_BASE, head);
    for (;;) {
        assert_int_equal(r.n, 2 + 2 * (int)head);
        if (mb_reg(&r, QMC_MODBUS_IB_STATUS) != QMC_MODBUS_INTEG_WAITING || done == max_points)
            return done;
        const uint16_t rq[2] = {mb_reg(&r, QMC_MODBUS_IB_REQUEST),
                                mb_reg(&r, QMC_MODBUS_IB_REQUEST + 1)};
        const uint32_t request = mb_u32(rq);
        assert_true(request > last_request); /* a new number for every point */
        last_request = request;
        double x[QMC_MODBUS_MAX_DIMS];
        uint16_t regs[2 * QMC_MODBUS_MAX_DIMS];
        for (unsigned i = 0; i < per * d->dims; i++)
            regs[i] = mb_reg(&r, QMC_MODBUS_IB_POINT + i);
        const uint16_t *c = regs;
        for (uint32_t j = 0; j < d->dims; j++) {
            unsigned used;
            x[j] = mb_coord(c, d->format, d->low_first, &used);
            c += used;
        }
        uint16_t w[4] = {rq[0], rq[1], 0, 0};
        mb_put_f32(&w[2], (float)d->f(x, d->dims), d->low_first);
        if (d->fc23) {
            r = mb_read_write(s, env, QMC_MODBUS_INTEG_BASE, head, QMC_MODBUS_VALUE_BASE, w, 4);
            assert_int_equal(r.b[0], 0x17);
        } else {
            mb_reply a = mb_write(s, env, QMC_MODBUS_VALUE_BASE, w, 4);
            mb_assert_written(&a);
            r = mb_read(s, env, 0x04, QMC_MODBUS_INTEG_BASE, head);
        }
        done++;
        mb_reply e = mb_read(s, env, 0x04, QMC_MODBUS_INTEG_BASE + QMC_MODBUS_IB_EVALS, 4);
        const uint16_t ev[4] = {mb_reg(&e, 0), mb_reg(&e, 1), mb_reg(&e, 2), mb_reg(&e, 3)};
        assert_int_equal(mb_u64(ev), evals0 + done);
    }
}
