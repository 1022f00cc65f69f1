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
 * independent.  A bank may hold an integration session (qmc/session.h):
 * its integrator runs inside the handler call that hands it values, up to
 * the next batch it asks for, and never between calls.
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

/*
 * The integration block (protocol/MODBUS.md section 9): a device
 * integrates a function it measures.  Holding registers 300..315 set up
 * and start an integration session (qmc/session.h) in the bank; the
 * device reads the point to measure and its request number from the
 * status block (input registers 400..495, also holding 400..495 for
 * FC23), and writes the request number and f at that point to holding
 * 320..323 in one write.
 *
 * Setup registers: X(name, address, min, max), max 0xFFFF for "any".
 * Floats (the tolerances) are IEEE binary32 in the bank's word order
 * (register 12); integers are high word first.
 */
#define QMC_MODBUS_SETUP_MAP(X)         \
    X(METHOD, 300, 1, 4)                \
    X(DIMS, 301, 1, 32)                 \
    X(SMOOTHNESS, 302, 0, 3)            \
    X(SEED_HI, 303, 0, 0xFFFF)          \
    X(SEED_LO, 304, 0, 0xFFFF)          \
    X(N_HI, 305, 0, 0xFFFF)             \
    X(N_LO, 306, 0, 0xFFFF)             \
    X(REPS, 307, 0, 4096)               \
    X(TOL_ABS_0, 308, 0, 0xFFFF)        \
    X(TOL_ABS_1, 309, 0, 0xFFFF)        \
    X(TOL_REL_0, 310, 0, 0xFFFF)        \
    X(TOL_REL_1, 311, 0, 0xFFFF)        \
    X(BUDGET_HI, 312, 0, 0xFFFF)        \
    X(BUDGET_LO, 313, 0, 0xFFFF)        \
    X(CONFIDENCE, 314, 1, 999)          \
    X(START, 315, 0, 0xFFFF)

enum {
#define QMC__MB_SETUP_ENUM(name, addr, lo, hi) QMC_MODBUS_SETUP_##name = (addr),
    QMC_MODBUS_SETUP_MAP(QMC__MB_SETUP_ENUM)
#undef QMC__MB_SETUP_ENUM
    QMC_MODBUS_SETUP_BASE = 300,
    QMC_MODBUS_SETUP_COUNT = 16,
    /* The value write: request number (u32, high word first) then f as
     * binary32 in the bank's word order; always these 4 registers at once. */
    QMC_MODBUS_VALUE_BASE = 320,
    QMC_MODBUS_VALUE_COUNT = 4,
    /* The status block: input registers 400.. (and holding 400.., read-only). */
    QMC_MODBUS_INTEG_BASE = 400,
    QMC_MODBUS_INTEG_COUNT = 96,
    /* Defaults of a new bank's setup registers. */
    QMC_MODBUS_DEFAULT_BUDGET = 1000000,
    QMC_MODBUS_DEFAULT_CONFIDENCE = 950,
    /* Points a session hands out per batch at most, and the cubature
     * regions' memory it may use (both fixed, so that the registers alone
     * decide every number; MODBUS.md says why). */
    QMC_MODBUS_SESSION_BATCH = 256,
    QMC_MODBUS_SESSION_REGION_BYTES = 1 << 20
};

/* Offsets in the status block.  u32 and u64 are high word first; f32 and
 * f64 follow the word order (register 12: 1 reverses the words). */
enum {
    QMC_MODBUS_IB_STATUS = 0,      /* QMC_MODBUS_INTEG_STATUS_* */
    QMC_MODBUS_IB_START = 1,       /* the start number the block is about */
    QMC_MODBUS_IB_REQUEST = 2,     /* u32: the point's request number; 0: none */
    QMC_MODBUS_IB_POINT = 4,       /* dims coordinates in the format of register 5 */
    QMC_MODBUS_IB_EVALS = 68,      /* u64: values received */
    QMC_MODBUS_IB_FLAGS = 72,      /* u32: QMC_FLAG_* (docs/FLAGS.md) */
    QMC_MODBUS_IB_ESTIMATE_F32 = 74,
    QMC_MODBUS_IB_BAR_F32 = 76,    /* half-width of the confidence interval */
    QMC_MODBUS_IB_ESTIMATE_F64 = 78,
    QMC_MODBUS_IB_BAR_F64 = 82,
    QMC_MODBUS_IB_NONFINITE = 86,  /* u64: values received that were NaN or infinite */
    QMC_MODBUS_IB_ERROR = 90,      /* -QMC_E* of a failed or refused session, else 0 */
    QMC_MODBUS_IB_METHOD_USED = 91, /* qmc_method + 1 once known (auto's pick), else 0 */
    QMC_MODBUS_IB_BYTES = 92       /* u64: memory held; refused for memory: needed */
};

/* The method register. */
enum {
    QMC_MODBUS_METHOD_MC = 1,
    QMC_MODBUS_METHOD_QMC = 2,
    QMC_MODBUS_METHOD_RQMC = 3,
    QMC_MODBUS_METHOD_AUTO = 4
};

/* The status block's status register.  X(name, code, meaning).  From
 * CONVERGED on, the session is over. */
#define QMC_MODBUS_INTEG_STATUS_MAP(X)                                            \
    X(NONE, 0, "no integration started, or it was closed")                        \
    X(WAITING, 1, "running: waiting for f at the point shown")                    \
    X(CONVERGED, 2, "done: the tolerance was met")                                \
    X(COMPLETE, 3, "done: every point of the fixed n was evaluated")              \
    X(BUDGET, 4, "done: the budget ran out before the tolerance was met")         \
    X(CANNOT_TELL, 5, "done, but the error bar cannot be trusted (see the flags)") \
    X(FAILED, 6, "the integrator stopped with an error (error register)")         \
    X(BAD_SETUP, 7, "the setup registers do not make a session (error register)") \
    X(NO_MEMORY, 8, "the session would hold more memory than the bank may (bytes register)")

enum {
#define QMC__MB_IST_ENUM(name, c, text) QMC_MODBUS_INTEG_##name = (c),
    QMC_MODBUS_INTEG_STATUS_MAP(QMC__MB_IST_ENUM)
#undef QMC__MB_IST_ENUM
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
    /* The most bytes the bank's integration session may hold after this
     * request (its qmc_session_memory_bytes and the values it collects):
     * a start that needs more is refused (status NO_MEMORY), a batch that
     * would grow it past this fails the session.  The transport computes
     * it from its caps and what the other banks hold; 0 (and a NULL env)
     * lets no session start. */
    uint64_t integration_bytes_max;
} qmc_modbus_env;

typedef struct qmc_modbus_session qmc_modbus_session;

/*
 * Creates a session with the default registers (sobol, 2 dims, no
 * scramble, seed 0, float32, index 0, auto-advance off, high word first;
 * status NO_REQUEST).  *out owns it (qmc_modbus_session_free) or is NULL.
 * Errors: QMC_ENOMEM.
 */
QMC_MUST_CHECK int qmc_modbus_session_new(qmc_modbus_session **out);

/* Frees a session, the sequence it caches and its integration session;
 * NULL is a no-op. */
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

/* What a bank's integration holds, for the transport's accounting. */
typedef struct qmc_modbus_usage {
    uint64_t integration_bytes;     /* held now (the session's bound and its values) */
    uint64_t integrations_refused;  /* starts refused for memory, in the bank's life */
    int integrating;                /* 1 while a session is open (not yet done) */
} qmc_modbus_usage;

/* Fills *out for s (zeros for NULL). */
void qmc_modbus_session_usage(const qmc_modbus_session *s, qmc_modbus_usage *out);

/* Names for logs and tests: "illegal data address", "" if unknown. */
const char *qmc_modbus_exception_name(int code);
const char *qmc_modbus_status_name(int code);
const char *qmc_modbus_integ_status_name(int code);

#ifdef __cplusplus
}
#endif
#endif /* QMC_MODBUS_H */
