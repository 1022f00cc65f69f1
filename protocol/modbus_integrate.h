/*
 * modbus_integrate.h - a register bank's integration session (private to
 * protocol/modbus*.c): the setup registers 300..315, the value write
 * 320..323 and the status block 400..495 of protocol/MODBUS.md section 9.
 *
 * modbus.c owns the bank and routes the addresses here; this part owns
 * the qmc_session and the values a device hands in one at a time.
 */
#ifndef QMC_PROTOCOL_MODBUS_INTEGRATE_H
#define QMC_PROTOCOL_MODBUS_INTEGRATE_H

#include <stddef.h>
#include <stdint.h>

#include "modbus_pdu.h"
#include "qmc/modbus.h"
#include "qmc/session.h"

typedef struct qmc__mb_integ {
    uint16_t setup[QMC_MODBUS_SETUP_COUNT];  /* holding 300..315 */
    uint16_t value[QMC_MODBUS_VALUE_COUNT];  /* holding 320..323: the last value taken */
    int has_value;                           /* value holds one (a retry is acknowledged) */
    uint32_t next_request;                   /* the number the next point gets, never 0 */
    int status;                              /* QMC_MODBUS_INTEG_* */
    int err;                                 /* FAILED, BAD_SETUP: the QMC_E* code */
    uint64_t bytes_needed;                   /* NO_MEMORY: what the start needed */
    uint64_t refused;                        /* starts refused for memory */

    /* While WAITING: the session and the batch the device walks through. */
    qmc_session *sess;
    uint64_t sess_bytes;                     /* qmc_session_memory_bytes of its spec */
    qmc_session_batch batch;
    size_t cursor;                           /* the batch's point shown */
    uint32_t request;                        /* that point's request number */
    double *vals;                            /* the batch's values so far */
    size_t vals_cap;
    uint64_t evals, nonfinite;               /* values taken in this session */

    /* Once over: the final result (the session is freed). */
    int has_final;
    qmc_result final;
    int method_used;                         /* qmc_method + 1, 0: not known */
} qmc__mb_integ;

/* A new bank's registers (MODBUS.md section 9) and no session. */
void qmc__mb_integ_init(qmc__mb_integ *g);

/* Frees the session and its values. */
void qmc__mb_integ_close(qmc__mb_integ *g);

/* Whether holding register addr is one of the block's writable ones. */
int qmc__mb_integ_writable(unsigned addr);

/*
 * Stores count registers (big-endian in v) from addr on, addr being
 * writable (qmc__mb_integ_writable): the setup registers, or the value
 * write.  hr is the bank's holding registers 0..12 (word order, format).
 * Returns 0 or an exception code; on an exception nothing changed.  A
 * write that carries the start register with a new number starts a
 * session after every register is stored (0 closes it); a value write
 * hands the value to the session, running the integrator to its next
 * batch when it completes one.
 */
int qmc__mb_integ_write(qmc__mb_integ *g, const uint16_t *hr, const qmc_modbus_env *env,
                        unsigned addr, unsigned count, qmc__mb_rd *v);

/* The status block as registers, in the format and word order hr says. */
void qmc__mb_integ_render(const qmc__mb_integ *g, const uint16_t *hr,
                          uint16_t out[QMC_MODBUS_INTEG_COUNT]);

/* What it holds, for qmc_modbus_session_usage. */
void qmc__mb_integ_usage(const qmc__mb_integ *g, qmc_modbus_usage *out);

#endif
