/*
 * modbus_device.h - a Modbus master and a measuring device in the unit
 * tests (test_modbus.c, and the integration block's
 * test_modbus_integrate*.c): request PDUs built from the Modbus
 * application protocol spec (v1.1b3, section 6), and
 * a device loop that reads each point from the status block, evaluates f
 * there and writes the value with its request number, as
 * protocol/MODBUS.md section 9 tells a device to.  Written from the spec
 * and MODBUS.md, not from protocol/modbus*.c.
 */
#ifndef QMC_TEST_MODBUS_DEVICE_H
#define QMC_TEST_MODBUS_DEVICE_H

#include <stddef.h>
#include <stdint.h>

#include "qmc/modbus.h"

typedef struct mb_reply {
    uint8_t b[QMC_MODBUS_MAX_PDU];
    int n;
} mb_reply;

/* One request through qmc_modbus_handle (fails the test unless it answers). */
mb_reply mb_call(qmc_modbus_session *s, const qmc_modbus_env *env, const uint8_t *req,
                 size_t n);
/* FC03 / FC04. */
mb_reply mb_read(qmc_modbus_session *s, const qmc_modbus_env *env, uint8_t fc, unsigned addr,
                 unsigned count);
/* FC06. */
mb_reply mb_write1(qmc_modbus_session *s, const qmc_modbus_env *env, unsigned addr,
                   unsigned v);
/* FC16. */
mb_reply mb_write(qmc_modbus_session *s, const qmc_modbus_env *env, unsigned addr,
                  const uint16_t *v, unsigned n);
/* FC23: write wn registers at waddr, then read rn at raddr. */
mb_reply mb_read_write(qmc_modbus_session *s, const qmc_modbus_env *env, unsigned raddr,
                       unsigned rn, unsigned waddr, const uint16_t *v, unsigned wn);

/* Register i of a read's answer (FC03, FC04, FC23). */
uint16_t mb_reg(const mb_reply *r, unsigned i);
/* Fails unless r is exception code for fc. */
void mb_assert_exception(const mb_reply *r, uint8_t fc, uint8_t code);
/* Fails unless r is FC16's normal answer. */
void mb_assert_written(const mb_reply *r);

/* Everything a master can read of the integration block: holding
 * 300..315 and 320..323, input 400..495 (and checks holding 400..495 reads
 * the same). */
typedef struct mb_snapshot {
    uint16_t setup[QMC_MODBUS_SETUP_COUNT];
    uint16_t value[QMC_MODBUS_VALUE_COUNT];
    uint16_t ib[QMC_MODBUS_INTEG_COUNT];
} mb_snapshot;
void mb_snapshot_take(qmc_modbus_session *s, const qmc_modbus_env *env, mb_snapshot *out);

/* Numbers in registers: u32 and u64 high word first; f32 and f64 in the
 * word order low_first (register 12). */
uint32_t mb_u32(const uint16_t *r);
uint64_t mb_u64(const uint16_t *r);
float mb_f32(const uint16_t *r, int low_first);
double mb_f64(const uint16_t *r, int low_first);
void mb_put_f32(uint16_t *r, float f, int low_first);

/* A device measuring f.  format and low_first must be what registers 5
 * and 12 say; fc23: one FC23 per point (write the value, read the next
 * point) instead of an FC04 and an FC16. */
typedef double (*mb_fn)(const double *x, uint32_t dims);
typedef struct mb_device {
    uint32_t dims;
    int format;
    int low_first;
    int fc23;
    mb_fn f;
} mb_device;

/* The point as the device reads it: a coordinate register (or pair) in
 * the format, decoded to the double it stands for. */
double mb_coord(const uint16_t *r, int format, int low_first, unsigned *regs);

/* Walks the session until its status is no longer WAITING, or until it
 * has written max_points values, checking that each request number is new and the
 * evaluation count grows by one per value.  Returns the values written. */
uint64_t mb_device_run(qmc_modbus_session *s, const qmc_modbus_env *env, const mb_device *d,
                       uint64_t max_points);

#endif
