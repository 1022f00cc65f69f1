/*
 * codec.h - internals shared by the codec's files (private to protocol/;
 * the unit test includes it to check the layout table).
 *
 * Each payload layout is written once, as a function over a qmc__io that
 * runs in one of two directions (the XDR habit): decoding fills a message
 * from a read cursor, encoding writes a message to a write cursor.  The
 * field helpers below apply the same limit and range checks either way, so
 * whatever the decoder accepts the encoder reproduces byte for byte, and
 * whatever the encoder refuses the decoder rejects.  A failed check makes
 * the whole message QMC_EPROTO when decoding and QMC_EINVAL when encoding.
 */
#ifndef QMC_PROTOCOL_CODEC_H
#define QMC_PROTOCOL_CODEC_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "qmc/proto.h"
#include "wire.h"

typedef struct qmc__io {
    int decode;         /* 1: rd -> message; 0: message -> wr */
    qmc__rd rd;
    qmc__wr wr;
    int err;            /* 0 or the first field error (EPROTO / EINVAL) */
    unsigned version;   /* the negotiated protocol version: which result
                           flag bits are defined (result_flags.c) */
} qmc__io;

/*
 * The fixed-width fields, inline: a small request is a handful of them,
 * and as calls into fields.c they were a fifth of the daemon's CPU on
 * pipelined 1-point POINTS.  Marks: qmc__io_invalid makes the message
 * invalid (first call wins); qmc__io_f64 carries any binary64 bit pattern,
 * qmc__io_f64_finite only finite ones; qmc__io_zero is n reserved bytes
 * (zeros, and must read as zeros); qmc__io_code8 an enumeration code in a
 * byte, ok() saying which exist; qmc__io_bool 0 or 1 (encoding sends any
 * nonzero int as 1).
 */
static inline void qmc__io_invalid(qmc__io *io)
{
    if (io->err == 0)
        io->err = io->decode ? QMC_EPROTO : QMC_EINVAL;
}

/* The decoder's short reads are malformed payloads: the whole frame is in
 * the buffer by then, so missing bytes mean a length field lied. */
static inline int qmc__io_rd_ok(qmc__io *io)
{
    if (io->rd.bad)
        qmc__io_invalid(io);
    return io->err == 0;
}

static inline void qmc__io_u16(qmc__io *io, uint16_t *v)
{
    if (io->decode)
        *v = qmc__rd_u16(&io->rd);
    else
        qmc__wr_u16(&io->wr, *v);
}

static inline void qmc__io_u32(qmc__io *io, uint32_t *v)
{
    if (io->decode)
        *v = qmc__rd_u32(&io->rd);
    else
        qmc__wr_u32(&io->wr, *v);
}

static inline void qmc__io_i32(qmc__io *io, int32_t *v)
{
    uint32_t u = (uint32_t)*v;
    qmc__io_u32(io, &u);
    /* Two's complement by arithmetic, not by an implementation-defined
     * conversion of a large unsigned value. */
    if (io->decode)
        *v = u <= INT32_MAX ? (int32_t)u : -(int32_t)(~u) - 1;
}

static inline void qmc__io_u64(qmc__io *io, uint64_t *v)
{
    if (io->decode)
        *v = qmc__rd_u64(&io->rd);
    else
        qmc__wr_u64(&io->wr, *v);
}

static inline void qmc__io_f64(qmc__io *io, double *v)
{
    uint64_t bits;
    memcpy(&bits, v, sizeof bits);
    qmc__io_u64(io, &bits);
    if (io->decode)
        memcpy(v, &bits, sizeof bits);
}

static inline void qmc__io_f64_finite(qmc__io *io, double *v)
{
    qmc__io_f64(io, v);
    if (qmc__io_rd_ok(io) && !isfinite(*v))
        qmc__io_invalid(io);
}

static inline void qmc__io_zero(qmc__io *io, size_t n)
{
    if (!io->decode) {
        uint8_t *p = qmc__wr_take(&io->wr, n);
        if (p)
            memset(p, 0, n);
        return;
    }
    const uint8_t *p = qmc__rd_take(&io->rd, n);
    if (!qmc__io_rd_ok(io))
        return;
    for (size_t i = 0; i < n; i++)
        if (p[i] != 0)
            qmc__io_invalid(io);
}

static inline void qmc__io_code8(qmc__io *io, uint32_t *v, int (*ok)(uint32_t))
{
    if (io->decode) {
        *v = qmc__rd_u8(&io->rd);
        if (qmc__io_rd_ok(io) && !ok(*v))
            qmc__io_invalid(io);
        return;
    }
    if (*v > 255 || !ok(*v)) {
        qmc__io_invalid(io);
        return;
    }
    qmc__wr_u8(&io->wr, (uint8_t)*v);
}

static inline void qmc__io_bool(qmc__io *io, int *v)
{
    if (io->decode) {
        uint8_t b = qmc__rd_u8(&io->rd);
        if (qmc__io_rd_ok(io) && b > 1)
            qmc__io_invalid(io);
        *v = b;
        return;
    }
    qmc__wr_u8(&io->wr, *v != 0);
}


/* Strings: QMC__STR_TEXT means UTF-8 without NUL bytes (else opaque
 * bytes); QMC__STR_LEN32 means a u32 length prefix (else u16). */
enum { QMC__STR_TEXT = 1, QMC__STR_LEN32 = 2 };
void qmc__io_str(qmc__io *io, qmc_str *s, uint32_t max, int flags);
/* A text string held in a char[QMC_JOB_NAME_BYTES] (NUL-terminated in
 * memory, at most QMC_JOB_NAME_BYTES - 1 bytes on the wire). */
void qmc__io_name(qmc__io *io, char *name);
/* A u32 count then count binary64 values; finite: each must be. */
void qmc__io_f64s(qmc__io *io, qmc_f64s *list, uint32_t max, int finite);
/* len bytes whose length was sent earlier: a view when decoding. */
void qmc__io_blob(qmc__io *io, const uint8_t **data, uint32_t len);

/* known_abs.c: JOB_RESULT's version-6 tail, the integral of |f| known in
 * closed form (QMC__KNOWN_ABS_BYTES on the wire from version 6 on; none
 * before, and a decoded message's has_known_abs is then -1). */
enum { QMC__KNOWN_ABS_BYTES = 16 };
void qmc__io_known_abs(qmc__io *io, qmc_msg_job_result *r);

/* 1 when p[0 .. n) is well-formed UTF-8 (RFC 3629) with no NUL byte. */
int qmc__utf8_ok(const uint8_t *p, size_t n);

/* qmc_sampling_spec, shared by INTEGRATE, JOB_RESULT and SESSION_PART
 * (40 bytes); finite: confidence must be (a request's). */
void qmc__io_sampling(qmc__io *io, qmc_sampling_spec *s, int finite);

/* The part-session messages of version 6 (messages_part.c) and the bytes
 * before their variable fields. */
enum { QMC__FIXED_SESSION_PART = 88, QMC__FIXED_PART_SUMS = 24 };
void qmc__io_session_part(qmc__io *io, qmc_msg *m);
void qmc__io_session_part_sums(qmc__io *io, qmc_msg *m);

/* One entry per QMC_MSG_MAP message. */
typedef struct qmc__layout {
    const char *name;           /* "HELLO" */
    char dir;                   /* 'C' client to server, 'S' the reverse */
    uint32_t min_payload;       /* bounds implied by the field limits */
    uint32_t max_payload;
    void (*io)(qmc__io *io, qmc_msg *m);
} qmc__layout;

/* The layout of a type code, or NULL for a code no message has. */
const qmc__layout *qmc__proto_layout(uint32_t type);

#endif /* QMC_PROTOCOL_CODEC_H */
