/*
 * qmc/proto.h - the qmcd wire protocol: frames, messages, and a codec that
 * does no I/O.  protocol/PROTOCOL.md is the normative spec; this header is
 * its C binding, shared by the daemon and the client library.
 *
 * A frame is a fixed 24-byte little-endian header and a payload:
 *
 *   offset size field
 *        0    4 magic        "QMCD" (0x51 0x4d 0x43 0x44)
 *        4    1 version      QMC_PROTO_VERSION
 *        5    1 type         QMC_MSG_* (one X-macro table below)
 *        6    2 flags        0 (reserved; receivers reject other values)
 *        8    8 request_id   chosen by the client; answers carry it back
 *       16    4 payload_len  bytes after the header
 *       20    4 reserved     0
 *
 * Decoding (picohttpparser's habit): qmc_proto_decode(buf, len, max, &msg)
 * returns the bytes consumed (> 0), QMC_EAGAIN when the frame is not all
 * there yet, or a negative error: QMC_EPROTO (malformed), QMC_ETOOBIG
 * (payload_len above max - checked before anything else, so nothing is
 * allocated for a hostile length).  Decoded strings, lists and point data
 * are views into buf: valid while buf is.
 *
 * Encoding: qmc_proto_encode(&msg, buf, cap) writes one frame and returns
 * its length, or QMC_ETOOBIG when cap is too small (nothing useful is
 * written then).  Encoders never send.
 *
 * The shared-memory transport (protocol version 2: SHM_ATTACH, SHM_OK,
 * POINTS_SHM_CHUNK, SHM_RELEASE) passes a file descriptor beside a frame;
 * the descriptor is the sender's and receiver's business (sendmsg and
 * recvmsg with SCM_RIGHTS), never the codec's: it only sees the frames.
 */
#ifndef QMC_PROTO_H
#define QMC_PROTO_H

#include <stddef.h>
#include <stdint.h>

#include "qmc/error.h"
#include "qmc/integrate.h"
#include "qmc/job.h"
#include "qmc/pixel.h"
#include "qmc/seq.h"
#include "qmc/session.h"

#ifdef __cplusplus
extern "C" {
#endif

#define QMC_PROTO_MAGIC 0x44434d51u   /* "QMCD" read as a little-endian u32 */
/* The frame format (the header's version byte): always 1. */
#define QMC_PROTO_VERSION 1u
/* Protocol versions negotiated by HELLO / HELLO_OK (the message set, not
 * the frame format): 1 is the base set; 2 adds the shared-memory transport
 * for POINTS.  This codec speaks 1 .. QMC_PROTO_VERSION_MAX. */
#define QMC_PROTO_VERSION_MAX 6u
#define QMC_PROTO_VERSION_SHM 2u
/* Version 3 adds the key-based authentication of the handshake
 * (AUTH_CHALLENGE, AUTH_RESPONSE, AUTH_OK; qmc/auth.h). */
#define QMC_PROTO_VERSION_AUTH 3u
/* Version 3 also adds result flag bits 12-16 (few_nonzero .. mis_undersampled,
 * qmc/result.h); versions 1 and 2 define bits 0-11.  A peer of an older
 * version rejects a bit it does not define, so a result is encoded for the
 * version the connection negotiated (qmc_proto_result_flags_for). */
#define QMC_PROTO_VERSION_FLAGS3 3u
#define QMC_PROTO_RESULT_FLAGS_V1 0x00000fffu   /* versions 1 and 2 */
#define QMC_PROTO_RESULT_FLAGS_V3 0x0001ffffu   /* versions 3 to 6 */
/* Version 4 adds PIXELS (a tile of a pixel sampler, qmc/pixel.h),
 * answered by the chunk and END frames POINTS uses. */
#define QMC_PROTO_VERSION_PIXELS 4u
/* Version 4 also adds scramble 4, fast-owen, to POINTS and INTEGRATE. */
#define QMC_PROTO_VERSION_FAST_OWEN 4u
/* Version 5 adds integration sessions (SESSION_OPEN .. SESSION_CLOSE,
 * qmc/session.h): the client evaluates f at the points the server hands
 * out, the server keeps the estimate and the stopping rule. */
#define QMC_PROTO_VERSION_SESSIONS 5u
/* Version 6 adds to JOB_RESULT (and SESSION_RESULT, its layout) the
 * integral of |f| the integrand knows in closed form (has_known_abs,
 * known_abs), so a client judges errors against the daemon's knowledge
 * instead of a copy of libqmc's rules; and the answer of a part session
 * (part_p != 0): its block sums, SESSION_PART and SESSION_PART_SUMS,
 * before SESSION_RESULT. */
#define QMC_PROTO_VERSION_KNOWN_ABS 6u
#define QMC_PROTO_VERSION_PARTS 6u
/* Bytes of one block's sums in SESSION_PART_SUMS (PROTOCOL.md 6.22):
 * count and nonfinite (u32 each), 11 sums and moments, the
 * QMC_SAMPLING_TOP largest |f| (f64 each). */
#define QMC_PROTO_PART_SUMS_BYTES (8u + 8u * (11u + QMC_SAMPLING_TOP))
/* Blocks in one SESSION_PART_SUMS: its data stays within a chunk's bytes. */
#define QMC_PROTO_PART_MAX_SUMS (QMC_PROTO_CHUNK_BYTES / QMC_PROTO_PART_SUMS_BYTES)
/* Bytes of a session's token (SESSION_OPENED): from the server's
 * cryptographic random number generator, 256 bits. */
#define QMC_PROTO_SESSION_TOKEN_BYTES 32u
/* SESSION_VALUES inline carries at most this many values (a frame's data,
 * like a chunk's, stays within QMC_PROTO_CHUNK_BYTES). */
#define QMC_PROTO_SESSION_MAX_VALUES (QMC_PROTO_CHUNK_BYTES / 8u)
/* Bytes of each side's nonce and of an HMAC-SHA256 tag in the handshake. */
#define QMC_PROTO_AUTH_NONCE_BYTES 32u
#define QMC_PROTO_AUTH_MAC_BYTES 32u
#define QMC_PROTO_HEADER_BYTES 24u
/* No frame is ever larger than this, whatever is negotiated. */
#define QMC_PROTO_MAX_PAYLOAD (16u << 20)
/* POINTS_CHUNK frames carry at most this many bytes of point data. */
#define QMC_PROTO_CHUNK_BYTES (1u << 20)
/* String and list limits, checked by encoder and decoder alike. */
#define QMC_PROTO_MAX_NAME 64u        /* client/server identity strings */
#define QMC_PROTO_MAX_MESSAGE 1024u   /* ERROR text, detail strings */
#define QMC_PROTO_MAX_PING 256u
#define QMC_PROTO_MAX_LIST 1024u      /* a, u parameter lists */
#define QMC_PROTO_MAX_STATS 256u      /* entries in a STATS_REPLY */
/* The shared-memory ring of SHM_ATTACH: slots, and bytes per slot (whole
 * pages, so every slot starts page-aligned in the mapping). */
#define QMC_PROTO_SHM_MIN_SLOTS 2u
#define QMC_PROTO_SHM_MAX_SLOTS 64u
#define QMC_PROTO_SHM_MIN_SLOT_BYTES (64u << 10)
#define QMC_PROTO_SHM_MAX_SLOT_BYTES (4u << 20)
#define QMC_PROTO_SHM_SLOT_ALIGN 4096u

/* Messages: X(name, type code, sent by: 'C' client or 'S' server). */
#define QMC_MSG_MAP(X)             \
    X(HELLO, 1, 'C')               \
    X(HELLO_OK, 2, 'S')            \
    X(PING, 3, 'C')                \
    X(PONG, 4, 'S')                \
    X(POINTS, 5, 'C')              \
    X(POINTS_CHUNK, 6, 'S')        \
    X(END, 7, 'S')                 \
    X(INTEGRATE, 8, 'C')           \
    X(JOB_ACCEPTED, 9, 'S')        \
    X(JOB_PROGRESS, 10, 'S')       \
    X(JOB_RESULT, 11, 'S')         \
    X(JOB_STATUS, 12, 'C')         \
    X(JOB_STATE, 13, 'S')          \
    X(JOB_CANCEL, 14, 'C')         \
    X(STATS, 15, 'C')              \
    X(STATS_REPLY, 16, 'S')        \
    X(ERROR, 17, 'S')              \
    X(SHM_ATTACH, 18, 'C')         \
    X(SHM_OK, 19, 'S')             \
    X(POINTS_SHM_CHUNK, 20, 'S')   \
    X(SHM_RELEASE, 21, 'C')        \
    X(AUTH_CHALLENGE, 22, 'S')     \
    X(AUTH_RESPONSE, 23, 'C')      \
    X(AUTH_OK, 24, 'S')            \
    X(PIXELS, 25, 'C')             \
    X(SESSION_OPEN, 26, 'C')       \
    X(SESSION_OPENED, 27, 'S')     \
    X(SESSION_BATCH, 28, 'S')      \
    X(SESSION_VALUES, 29, 'C')     \
    X(SESSION_REPORT, 30, 'S')     \
    X(SESSION_RESULT, 31, 'S')     \
    X(SESSION_RESUME, 32, 'C')     \
    X(SESSION_CLOSE, 33, 'C')      \
    X(SESSION_PART, 34, 'S')       \
    X(SESSION_PART_SUMS, 35, 'S')

typedef enum qmc_msg_type {
#define QMC__MSG_ENUM(name, code, dir) QMC_MSG_##name = (code),
    QMC_MSG_MAP(QMC__MSG_ENUM)
#undef QMC__MSG_ENUM
} qmc_msg_type;

/* A byte string view (not NUL-terminated). */
typedef struct qmc_str {
    const char *ptr;
    uint32_t len;
} qmc_str;

/* A list of doubles: encoders read `values`; decoders set `raw` (little-
 * endian bytes, possibly unaligned) - read it with qmc_proto_f64_at. */
typedef struct qmc_f64s {
    const double *values;
    const uint8_t *raw;
    uint32_t count;
} qmc_f64s;

typedef struct qmc_msg_hello {
    uint16_t version_min, version_max;
    uint32_t max_frame;       /* the largest payload the client accepts */
    qmc_str client;           /* <= QMC_PROTO_MAX_NAME bytes */
} qmc_msg_hello;

typedef struct qmc_msg_hello_ok {
    uint16_t version;
    uint32_t max_frame;       /* the largest payload the server accepts */
    uint32_t max_inflight;    /* requests in flight per connection */
    uint64_t max_points;      /* points per POINTS request */
    uint64_t sobol_table_hash;/* qmc_sobol_table_hash() of the server */
    qmc_str server;           /* server identity, <= QMC_PROTO_MAX_NAME */
    qmc_str engine;           /* engine version, <= QMC_PROTO_MAX_NAME */
} qmc_msg_hello_ok;

typedef struct qmc_msg_ping {
    qmc_str data;             /* echoed by PONG; <= QMC_PROTO_MAX_PING */
} qmc_msg_ping;

/* How POINTS and PIXELS data travels (their transport byte): in
 * POINTS_CHUNK frames, or through the connection's shared-memory ring
 * (POINTS_SHM_CHUNK). */
typedef enum qmc_points_transport {
    QMC_TRANSPORT_INLINE = 0,
    QMC_TRANSPORT_SHM = 1
} qmc_points_transport;

typedef struct qmc_msg_points {
    qmc_seq_spec seq;
    qmc_format format;
    qmc_points_transport transport;
    uint64_t start, count;
} qmc_msg_points;

/* PIXELS (version 4): the tile of the pixel sampler `spec` as
 * qmc_pixels_fill writes it, answered like POINTS.  The answer's points
 * are the tile's samples in output order, numbered from 0: point k is
 * sample tile.sample_start + k % tile.sample_count of the tile's pixel
 * k / tile.sample_count (row order), spec.dims values in `format`. */
typedef struct qmc_msg_pixels {
    qmc_pixel_spec spec;
    qmc_pixel_tile tile;
    qmc_format format;
    qmc_points_transport transport;
} qmc_msg_pixels;

typedef struct qmc_msg_points_chunk {
    uint64_t first;           /* index of the chunk's first point */
    uint32_t points;          /* points in the chunk */
    const uint8_t *data;      /* points * dims * format bytes, row-major LE */
    uint32_t data_len;
} qmc_msg_points_chunk;

/* SHM_ATTACH (the ring the client offers; the memfd travels beside the
 * frame) and SHM_OK (the same values, accepted). */
typedef struct qmc_msg_shm {
    uint32_t slots;           /* QMC_PROTO_SHM_MIN_SLOTS .. _MAX_SLOTS */
    uint32_t slot_bytes;      /* a multiple of QMC_PROTO_SHM_SLOT_ALIGN in
                                 [QMC_PROTO_SHM_MIN_SLOT_BYTES, _MAX_SLOT_BYTES] */
} qmc_msg_shm;

/* POINTS_SHM_CHUNK: the data is in the ring, at slot * slot_bytes. */
typedef struct qmc_msg_shm_chunk {
    uint64_t first;           /* index of the chunk's first point */
    uint32_t points;          /* points in the chunk, >= 1 */
    uint32_t data_len;        /* bytes in the slot, <= slot_bytes */
    uint32_t slot;            /* < slots */
} qmc_msg_shm_chunk;

/* SHM_RELEASE: hands back the `slots` oldest slots the client holds. */
typedef struct qmc_msg_shm_release {
    uint32_t slots;           /* 1 .. QMC_PROTO_SHM_MAX_SLOTS */
} qmc_msg_shm_release;

/* Protocol version 3, the authenticated handshake (PROTOCOL.md section
 * 4.1): HELLO, AUTH_CHALLENGE (the server's nonce), AUTH_RESPONSE (the
 * client's nonce and its proof), AUTH_OK (the server's proof), HELLO_OK.
 * All carry the HELLO's request id. */
typedef struct qmc_msg_auth_challenge {
    uint16_t version;         /* the version HELLO_OK will choose, >= 3 */
    uint8_t nonce[QMC_PROTO_AUTH_NONCE_BYTES];   /* the server's */
} qmc_msg_auth_challenge;

typedef struct qmc_msg_auth_response {
    uint8_t nonce[QMC_PROTO_AUTH_NONCE_BYTES];   /* the client's */
    uint8_t mac[QMC_PROTO_AUTH_MAC_BYTES];       /* the client's proof */
} qmc_msg_auth_response;

typedef struct qmc_msg_auth_ok {
    uint8_t mac[QMC_PROTO_AUTH_MAC_BYTES];       /* the server's proof */
} qmc_msg_auth_ok;

typedef struct qmc_msg_end {
    uint64_t points;          /* points sent for the request */
    uint64_t bytes;           /* data bytes sent */
} qmc_msg_end;

typedef struct qmc_msg_integrate {
    /* The job: the fields of qmc_job_spec, with views for the lists and
     * scene text.  spec.a/u/scene_text are NOT used on the wire; a, u and
     * scene are. */
    qmc_job_spec spec;
    qmc_f64s a, u;
    qmc_str scene;
    uint32_t progress_ms;     /* 0: no JOB_PROGRESS; else at most this often */
} qmc_msg_integrate;

typedef struct qmc_msg_job_id {
    uint64_t job_id;          /* JOB_ACCEPTED, JOB_STATUS, JOB_CANCEL */
} qmc_msg_job_id;

typedef struct qmc_msg_job_progress {
    uint64_t job_id;
    uint64_t evals;           /* evaluations done so far */
    double seconds;           /* since the job started */
} qmc_msg_job_progress;

/* Job states in JOB_STATE. */
#define QMC_JOB_STATE_MAP(X) \
    X(QUEUED, 1, "queued")   \
    X(RUNNING, 2, "running") \
    X(DONE, 3, "done")       \
    X(CANCELLED, 4, "cancelled") \
    X(FAILED, 5, "failed")   \
    X(UNKNOWN, 6, "unknown")

typedef enum qmc_job_state {
#define QMC__JOB_STATE_ENUM(name, code, text) QMC_JOB_##name = (code),
    QMC_JOB_STATE_MAP(QMC__JOB_STATE_ENUM)
#undef QMC__JOB_STATE_ENUM
} qmc_job_state;

typedef struct qmc_msg_job_state {
    uint64_t job_id;
    qmc_job_state state;
    uint64_t evals;
    double seconds;
} qmc_msg_job_state;

typedef struct qmc_msg_job_result {
    uint64_t job_id;
    qmc_result res;
    qmc_cv_report cv;
    qmc_method method_used;
    qmc_sampling_spec sampling;   /* what ran, for sampling methods */
    double seconds;               /* server compute time */
    int reference_kind;           /* 0 none, 1 exact, 2 high-accuracy reference */
    double reference;
    qmc_str detail;               /* <= QMC_PROTO_MAX_MESSAGE */
    qmc_str auto_reason;          /* <= QMC_PROTO_MAX_MESSAGE */
    /* Version 6: the integral of |f| known in closed form (the
     * integrand's has_abs_integral and abs_integral, qmc/integrand.h; not
     * res.abs_integral, the integrator's estimate of it).  has_known_abs
     * is 1 (known_abs: finite, >= 0) or 0 (unknown, known_abs 0); decoded
     * at version 5 or older, where the wire has no such field, it is -1. */
    int has_known_abs;
    double known_abs;
} qmc_msg_job_result;

/* Integration sessions (protocol version 5, PROTOCOL.md section 6.21):
 * SESSION_OPEN starts one; every frame the server sends about it carries
 * the SESSION_OPEN's request id (or the SESSION_RESUME's that took it
 * over): SESSION_OPENED, then per batch its SESSION_BATCH pieces, and
 * after the values a SESSION_REPORT; at the end SESSION_RESULT (or
 * ERROR) ends the request.  SESSION_VALUES is not a request in flight:
 * it names its session by id, and only a refusal answers it (ERROR with
 * the SESSION_VALUES' own request id; the session goes on). */

/* SESSION_OPEN: what qmc_session_new takes (spec.integrate.interrupt is
 * not on the wire), and how batches should travel. */
typedef struct qmc_msg_session_open {
    qmc_session_spec spec;
    qmc_points_transport transport;   /* the ring when one is attached */
} qmc_msg_session_open;

/* SESSION_OPENED: the session's name and the capability to resume it. */
typedef struct qmc_msg_session_opened {
    uint64_t session_id;
    uint8_t token[QMC_PROTO_SESSION_TOKEN_BYTES];
    uint32_t dims;
    uint64_t max_batch;           /* the most points one batch may hold */
    uint64_t memory_bytes;        /* what the server reserved for it */
    uint64_t park_ms;             /* how long it waits for a SESSION_RESUME
                                     once its connection is gone */
} qmc_msg_session_opened;

/* SESSION_BATCH: points [first, first + points) of batch seq, which has
 * count points of dims coordinates (f64), inline (data) or in a ring slot
 * (the same bytes at the slot's start; the values go right after them). */
typedef struct qmc_msg_session_batch {
    uint64_t seq, count, first;
    uint32_t points, dims;
    qmc_points_transport transport;
    uint32_t slot;                /* ring: < QMC_PROTO_SHM_MAX_SLOTS; inline 0 */
    uint32_t data_len;            /* points x dims x 8 */
    const uint8_t *data;          /* inline: the coordinates (LE f64); ring: NULL */
} qmc_msg_session_batch;

/* SESSION_VALUES: f at points [first, first + count) of batch seq of
 * session session_id, inline (data, count LE f64) or in the ring slot
 * that carried those points, right after them. */
typedef struct qmc_msg_session_values {
    uint64_t session_id, seq, first;
    uint32_t count;
    qmc_points_transport transport;
    uint32_t slot;                /* ring; inline 0 */
    uint32_t data_len;            /* inline: count x 8; ring: 0 */
    const uint8_t *data;
} qmc_msg_session_values;

/* SESSION_REPORT: the session's state after a batch (qmc_session_status). */
typedef struct qmc_msg_session_report {
    uint64_t session_id;
    qmc_session_report report;
} qmc_msg_session_report;

/* SESSION_RESUME (transport as in SESSION_OPEN) and SESSION_CLOSE (no
 * transport): a session of this identity, by id and token. */
typedef struct qmc_msg_session_ref {
    uint64_t session_id;
    uint8_t token[QMC_PROTO_SESSION_TOKEN_BYTES];
    qmc_points_transport transport;
} qmc_msg_session_ref;

/* Part sessions (protocol version 6, PROTOCOL.md section 6.22): after
 * the last SESSION_REPORT, one SESSION_PART and then the part's block
 * sums in SESSION_PART_SUMS frames, in block order, before SESSION_RESULT
 * - what qmc_session_part gives in-process. */
typedef struct qmc_msg_session_part {
    uint64_t session_id;
    uint64_t fingerprint;         /* qmc_sampling_fingerprint of the whole job */
    uint64_t blocks;              /* the whole job's: 1 .. QMC_SAMPLING_MAX_BLOCKS */
    uint64_t first, count;        /* this part's blocks; first + count <= blocks */
    uint32_t part_k, part_p;      /* 1 <= part_k <= part_p */
    qmc_sampling_spec sampling;   /* the job as run (n, reps) */
} qmc_msg_session_part;

/* SESSION_PART_SUMS: blocks [first, first + n) of the part.  Encoders
 * read sums (n of them, sums[i].block == first + i); decoders set raw
 * (n records of QMC_PROTO_PART_SUMS_BYTES) - read it with
 * qmc_proto_part_sums_at. */
typedef struct qmc_msg_session_part_sums {
    uint64_t session_id;
    uint64_t first;               /* the first record's block number */
    uint32_t n;                   /* 1 .. QMC_PROTO_PART_MAX_SUMS */
    const qmc_sampling_sums *sums;
    const uint8_t *raw;
} qmc_msg_session_part_sums;

typedef struct qmc_stat {
    qmc_str name;                 /* <= QMC_PROTO_MAX_NAME */
    uint64_t value;
} qmc_stat;

typedef struct qmc_msg_stats_reply {
    uint32_t count;               /* <= QMC_PROTO_MAX_STATS */
    const qmc_stat *entries;      /* encoder: caller's array */
    const uint8_t *raw;           /* decoder: read with qmc_proto_stat_at */
    uint32_t raw_len;
} qmc_msg_stats_reply;

typedef struct qmc_msg_error {
    int32_t code;                 /* a QMC_E* code or -errno */
    qmc_str message;              /* one line, <= QMC_PROTO_MAX_MESSAGE */
} qmc_msg_error;

typedef struct qmc_msg {
    qmc_msg_type type;
    uint64_t request_id;
    union {
        qmc_msg_hello hello;
        qmc_msg_hello_ok hello_ok;
        qmc_msg_ping ping;            /* PING and PONG */
        qmc_msg_points points;
        qmc_msg_pixels pixels;
        qmc_msg_points_chunk chunk;
        qmc_msg_end end;
        qmc_msg_integrate integrate;
        qmc_msg_job_id job;           /* JOB_ACCEPTED, JOB_STATUS, JOB_CANCEL */
        qmc_msg_job_progress progress;
        qmc_msg_job_state state;
        qmc_msg_job_result result;    /* JOB_RESULT and SESSION_RESULT (job_id:
                                         the session's id) */
        qmc_msg_stats_reply stats;    /* STATS has no payload */
        qmc_msg_error error;
        qmc_msg_shm shm;              /* SHM_ATTACH and SHM_OK */
        qmc_msg_shm_chunk shm_chunk;
        qmc_msg_shm_release release;
        qmc_msg_auth_challenge challenge;
        qmc_msg_auth_response response;
        qmc_msg_auth_ok auth_ok;
        qmc_msg_session_open session_open;
        qmc_msg_session_opened session_opened;
        qmc_msg_session_batch session_batch;
        qmc_msg_session_values session_values;
        qmc_msg_session_report session_report;
        qmc_msg_session_ref session_ref;  /* SESSION_RESUME, SESSION_CLOSE */
        qmc_msg_session_part session_part;
        qmc_msg_session_part_sums part_sums;
    } u;
} qmc_msg;

/* Decodes one frame (see the file comment) as protocol version
 * QMC_PROTO_VERSION_MAX defines it. */
QMC_MUST_CHECK int qmc_proto_decode(const uint8_t *buf, size_t len,
                                    uint32_t max_payload, qmc_msg *out);

/*
 * The same for a connection that negotiated `version` (1 ..
 * QMC_PROTO_VERSION_MAX; anything else is QMC_EINVAL): a JOB_RESULT whose
 * flags carry a bit that version does not define is malformed.  A peer
 * decodes with the version HELLO_OK chose.
 */
QMC_MUST_CHECK int qmc_proto_decode_version(const uint8_t *buf, size_t len,
                                            uint32_t max_payload, unsigned version,
                                            qmc_msg *out);

/* Only the header: returns QMC_PROTO_HEADER_BYTES, QMC_EAGAIN, or an
 * error; sets *type, *request_id and *payload_len. */
QMC_MUST_CHECK int qmc_proto_peek(const uint8_t *buf, size_t len,
                                  uint32_t max_payload, qmc_msg_type *type,
                                  uint64_t *request_id, uint32_t *payload_len);

/* Encodes one frame into buf; returns its length or QMC_ETOOBIG /
 * QMC_EINVAL (a field past its limit, an unknown type). */
QMC_MUST_CHECK int qmc_proto_encode(const qmc_msg *msg, uint8_t *buf,
                                    size_t cap);

/* The oldest protocol version whose peers can decode msg (1 for anything
 * version 1 had): PIXELS and a fast-owen scramble need 4, SHM_ATTACH 2.  A
 * client compares it with the version HELLO_OK chose before sending; the
 * session messages need 5, and a SESSION_OPEN of a part 6. */
unsigned qmc_proto_msg_min_version(const qmc_msg *msg);

/* The frame length qmc_proto_encode would produce, or 0 if invalid. */
size_t qmc_proto_encoded_size(const qmc_msg *msg);

/*
 * Encoding for a connection that negotiated `version` (1 ..
 * QMC_PROTO_VERSION_MAX; else QMC_EINVAL): a JOB_RESULT's flags go out as
 * qmc_proto_result_flags_for(version, flags).  qmc_proto_encode is this
 * at QMC_PROTO_VERSION_MAX.
 */
QMC_MUST_CHECK int qmc_proto_encode_version(const qmc_msg *msg, unsigned version,
                                            uint8_t *buf, size_t cap);
size_t qmc_proto_encoded_size_version(const qmc_msg *msg, unsigned version);

/* The result flag bits protocol `version` defines (PROTOCOL.md section 5),
 * or 0 for a version this codec does not speak. */
uint32_t qmc_proto_result_flags_defined(unsigned version);

/*
 * Result flags as a peer of `version` is told them: the defined bits as
 * they are; the bits added after that version dropped, and
 * QMC_FLAG_ERROR_UNRELIABLE raised when any was, since each of them says
 * that the bar rests on evidence it cannot vouch for and error_unreliable
 * is how an older peer hears that.  Bits no version defines are left for
 * the encoder to refuse.  For an unknown version, flags unchanged.
 */
uint32_t qmc_proto_result_flags_for(unsigned version, uint32_t flags);

/*
 * Zero-copy POINTS_CHUNK: writes the frame header and the chunk prefix for
 * `points` points of `data_len` bytes; the caller then writes the data at
 * buf + the returned length.  Returns the prefix length or QMC_ETOOBIG.
 */
QMC_MUST_CHECK int qmc_proto_encode_chunk_prefix(uint64_t request_id, uint64_t first,
                                                 uint32_t points, uint32_t data_len,
                                                 uint8_t *buf, size_t cap);

/*
 * Zero-copy SESSION_VALUES (inline): writes the frame header and the fixed
 * fields of *v (its data pointer is not read); the caller then sends
 * v->data_len bytes of values (count little-endian f64) right after the
 * returned length.  Returns the prefix length, QMC_EINVAL (a field the
 * decoder would reject, or v not inline) or QMC_ETOOBIG.
 */
QMC_MUST_CHECK int qmc_proto_encode_session_values_prefix(uint64_t request_id,
                                                          const qmc_msg_session_values *v,
                                                          uint8_t *buf, size_t cap);

/* Element i of a decoded (or encoder-side) list. */
double qmc_proto_f64_at(const qmc_f64s *list, uint32_t i);
/* Record i of a SESSION_PART_SUMS (i < n), decoded or encoder-side, as
 * qmc_session_part gives it (block = first + i). */
void qmc_proto_part_sums_at(const qmc_msg_session_part_sums *p, uint32_t i,
                            qmc_sampling_sums *out);
/* Entry i of a decoded STATS_REPLY (i < count). */
qmc_stat qmc_proto_stat_at(const qmc_msg_stats_reply *r, uint32_t i);

const char *qmc_msg_type_name(qmc_msg_type type);
const char *qmc_job_state_name(qmc_job_state state);

#ifdef __cplusplus
}
#endif
#endif /* QMC_PROTO_H */
