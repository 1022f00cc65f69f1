/*
 * qmc/modbus.h - the Modbus register interface: a pure request handler.
 *
 * qmc_modbus_handle takes one request PDU (function code and data, as the
 * Modbus application protocol spec v1.1b3 section 4.1 defines it: no MBAP
 * header, no unit id, no CRC) and a session (one client's register bank),
 * and writes the response PDU or an exception response.  It does no I/O,
 * reads no clock and keeps no global state: transports (daemon/
 * modbus_tcp.c, daemon/modbus_rtu.c) frame the PDUs and pass the server's
 * counters in a qmc_modbus_env snapshot.  protocol/MODBUS.md documents the
 * register map, formats, word order, exceptions and status codes.
 *
 * A session is used by one thread at a time; distinct sessions are
 * independent.
 */
#ifndef QMC_MODBUS_H
#define QMC_MODBUS_H

#include <stddef.h>
#include <stdint.h>

#include "qmc/error.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The largest PDU (spec section 4.1: 256-byte serial ADU - address - CRC). */
#define QMC_MODBUS_MAX_PDU 253u

/* Function codes served.  X(name, code). */
#define QMC_MODBUS_FC_MAP(X)                 \
    X(READ_HOLDING, 0x03)                    \
    X(READ_INPUT, 0x04)                      \
    X(WRITE_SINGLE, 0x06)                    \
    X(WRITE_MULTIPLE, 0x10)                  \
    X(REPORT_SERVER_ID, 0x11)                \
    X(READ_WRITE_MULTIPLE, 0x17)             \
    X(ENCAPSULATED, 0x2B)

enum {
#define QMC__MB_FC_ENUM(name, code) QMC_MODBUS_FC_##name = (code),
    QMC_MODBUS_FC_MAP(QMC__MB_FC_ENUM)
#undef QMC__MB_FC_ENUM
    QMC_MODBUS_MEI_DEVICE_ID = 0x0E   /* FC43 MEI type 14 */
};

/* Exception codes sent (spec section 7).  X(name, code, meaning).  The
 * handler sends 01..04; a transport sends 06 when it has no bank to give. */
#define QMC_MODBUS_EXC_MAP(X)                                               \
    X(ILLEGAL_FUNCTION, 0x01, "function code not served")                   \
    X(ILLEGAL_ADDRESS, 0x02, "address not mapped or not writable")          \
    X(ILLEGAL_VALUE, 0x03, "bad quantity, length, value, or read past a block's end") \
    X(SERVER_FAILURE, 0x04, "the server could not build the sequence (memory)") \
    X(SERVER_BUSY, 0x06, "every register bank is in use (sent by the TCP transport)")

enum {
#define QMC__MB_EXC_ENUM(name, code, text) QMC_MODBUS_EX_##name = (code),
    QMC_MODBUS_EXC_MAP(QMC__MB_EXC_ENUM)
#undef QMC__MB_EXC_ENUM
};

/* Result-block status codes (result register +1).  X(name, code, meaning). */
#define QMC_MODBUS_STATUS_MAP(X)                                            \
    X(OK, 0, "the point at the echoed index")                               \
    X(NO_REQUEST, 1, "no request number written yet")                       \
    X(BAD_SPEC, 2, "kind, dims and scramble do not make a sequence")        \
    X(BAD_INDEX, 3, "index past the end of the sequence (2^32)")            \
    X(NO_MEMORY, 4, "the server ran out of memory building the sequence")

enum {
#define QMC__MB_ST_ENUM(name, code, text) QMC_MODBUS_STATUS_##name = (code),
    QMC_MODBUS_STATUS_MAP(QMC__MB_ST_ENUM)
#undef QMC__MB_ST_ENUM
};

/* Holding registers 0..12: the request.  X(name, address, min, max) with
 * max 0xFFFF for "any value". */
#define QMC_MODBUS_HOLDING_MAP(X)       \
    X(KIND, 0, 1, 3)                    \
    X(DIMS, 1, 1, 32)                   \
    X(SCRAMBLE, 2, 0, 4)                \
    X(SEED_HI, 3, 0, 0xFFFF)            \
    X(SEED_LO, 4, 0, 0xFFFF)            \
    X(FORMAT, 5, 0, 2)                  \
    X(INDEX_3, 6, 0, 0xFFFF)            \
    X(INDEX_2, 7, 0, 0xFFFF)            \
    X(INDEX_1, 8, 0, 0xFFFF)            \
    X(INDEX_0, 9, 0, 0xFFFF)            \
    X(REQUEST, 10, 0, 0xFFFF)           \
    X(AUTO_ADVANCE, 11, 0, 1)           \
    X(WORD_ORDER, 12, 0, 1)

enum {
#define QMC__MB_HR_ENUM(name, addr, lo, hi) QMC_MODBUS_HR_##name = (addr),
    QMC_MODBUS_HOLDING_MAP(QMC__MB_HR_ENUM)
#undef QMC__MB_HR_ENUM
    QMC_MODBUS_HOLDING_COUNT = 13,
    QMC_MODBUS_MAX_DIMS = 32,
    /* The result block: echo, status, index (4), then up to 32 coordinates
     * of two registers.  Input registers 0.., holding registers 100... */
    QMC_MODBUS_RESULT_REGS = 6 + 2 * 32,
    QMC_MODBUS_RESULT_HOLDING = 100,
    /* The server's counters: input registers 200.., each a u64 in four
     * registers, high word first. */
    QMC_MODBUS_COUNTERS_INPUT = 200
};

/* Register values of the kind, scramble and format registers. */
enum { QMC_MODBUS_KIND_SOBOL = 1, QMC_MODBUS_KIND_HALTON = 2, QMC_MODBUS_KIND_RANDOM = 3 };
enum {
    QMC_MODBUS_SCRAMBLE_NONE = 0,
    QMC_MODBUS_SCRAMBLE_OWEN = 1,
    QMC_MODBUS_SCRAMBLE_SHIFT = 2,
    QMC_MODBUS_SCRAMBLE_FAURE = 3,
    QMC_MODBUS_SCRAMBLE_FAST_OWEN = 4
};
enum { QMC_MODBUS_FORMAT_F32 = 0, QMC_MODBUS_FORMAT_U16 = 1, QMC_MODBUS_FORMAT_U32 = 2 };

/* The counters, in register order.  X(name, field). */
#define QMC_MODBUS_COUNTER_MAP(X)  \
    X(UPTIME_S, uptime_s)          \
    X(REQUESTS, requests)          \
    X(EXCEPTIONS, exceptions)      \
    X(CONNS_ACCEPTED, conns_accepted) \
    X(CONNS_REFUSED, conns_refused)   \
    X(CONNS_OPEN, conns_open)

/* What the server tells the handler: a snapshot taken by the transport. */
typedef struct qmc_modbus_env {
#define QMC__MB_CTR_FIELD(name, field) uint64_t field;
    QMC_MODBUS_COUNTER_MAP(QMC__MB_CTR_FIELD)
#undef QMC__MB_CTR_FIELD
    uint64_t sobol_table_hash;  /* qmc_sobol_table_hash() */
    const char *version;        /* "0.1.0"; NULL reads as "" */
} qmc_modbus_env;

typedef struct qmc_modbus_session qmc_modbus_session;

/*
 * Creates a session with the default registers (sobol, 2 dims, no
 * scramble, seed 0, float32, index 0, auto-advance off, high word first;
 * status NO_REQUEST).  *out owns it (qmc_modbus_session_free) or is NULL.
 * Errors: QMC_ENOMEM.
 */
QMC_MUST_CHECK int qmc_modbus_session_new(qmc_modbus_session **out);

/* Frees a session and the sequence it caches; NULL is a no-op. */
void qmc_modbus_session_free(qmc_modbus_session *s);

/*
 * Handles one request PDU req[0 .. req_bytes) and writes the response PDU
 * into resp[0 .. resp_bytes).  Returns the response length (> 0: a normal
 * response, or a 2-byte exception response whose first byte has bit 7
 * set), or QMC_EINVAL when req_bytes is 0 or above QMC_MODBUS_MAX_PDU or
 * resp_bytes is below QMC_MODBUS_MAX_PDU (nothing is written).  env may be
 * NULL (counters read 0).
 */
QMC_MUST_CHECK int qmc_modbus_handle(qmc_modbus_session *s, const qmc_modbus_env *env,
                                     const uint8_t *req, size_t req_bytes, uint8_t *resp,
                                     size_t resp_bytes);

/*
 * Whether the request PDU req[0 .. req_bytes) may change a session: 1 for
 * the writes (FC06, FC16, FC23), 0 for everything else (FC03, FC04, FC17,
 * FC43, and codes answered with exception 01).  qmc_modbus_handle never
 * changes a session for a request this returns 0 for, nor for one it
 * answers with an exception, so a transport may answer such requests from
 * one shared session that is never written (the TCP transport does, for
 * clients that have no bank of their own).
 */
int qmc_modbus_request_writes(const uint8_t *req, size_t req_bytes);

/* Names for logs and tests: "illegal data address", "" if unknown. */
const char *qmc_modbus_exception_name(int code);
const char *qmc_modbus_status_name(int code);

#ifdef __cplusplus
}
#endif
#endif /* QMC_MODBUS_H */
