/*
 * client_impl.h - libqmcclient internals shared by its files (private).
 *
 * endpoint.c parses endpoints and opens sockets; conn.c moves frames
 * (bounded buffers, deadlines, error text); client.c is the handshake,
 * ping, stats and accessors; points.c the POINTS stream (and the stream
 * of one request, which PIXELS shares); pixels.c PIXELS tiles; shm.c the
 * shared-memory ring; jobs.c the INTEGRATE family; session.c integration
 * sessions.  Cross-file names are qmc__client_*; nothing here is
 * public API, but the unit test includes it to reach the parser and the
 * allocator seam.
 */
#ifndef QMC_CLIENT_IMPL_H
#define QMC_CLIENT_IMPL_H

#include <stddef.h>
#include <stdint.h>

#include "qmc/auth.h"
#include "qmc/client.h"

/* ---- endpoints ------------------------------------------------------------ */

enum { QMC__EP_UNIX = 1, QMC__EP_TCP = 2 };
/* sizeof(((struct sockaddr_un *)0)->sun_path) on Linux. */
enum { QMC__EP_PATH_BYTES = 108, QMC__EP_HOST_BYTES = 256 };

typedef struct qmc__endpoint {
    int kind;                         /* QMC__EP_UNIX or QMC__EP_TCP */
    char path[QMC__EP_PATH_BYTES];    /* unix */
    char host[QMC__EP_HOST_BYTES];    /* tcp: without the IPv6 brackets */
    char port[6];                     /* tcp: 1 .. 65535, decimal */
    int bracketed;                    /* tcp: host was [an IPv6 literal] */
} qmc__endpoint;

/* Parses an endpoint.  Returns 0 or QMC_EINVAL with a reason in why. */
int qmc__client_endpoint_parse(const char *text, qmc__endpoint *ep, char *why,
                               size_t why_bytes);

/* Opens a non-blocking, close-on-exec stream socket connected to ep,
 * waiting until deadline_ms (qmc__client_now_ms clock; -1: none).  Returns
 * the descriptor, or a negative code with a reason in why. */
int qmc__client_endpoint_open(const qmc__endpoint *ep, int64_t deadline_ms,
                              char *why, size_t why_bytes);

/* ---- the client ------------------------------------------------------------- */

/* Send buffer: the largest request we build, an INTEGRATE with both
 * parameter lists full and the largest scene (plus one byte the scene
 * parser uses to see oversize input), and the fixed fields. */
#define QMC__CLIENT_SEND_BYTES                                                   \
    (QMC_PROTO_HEADER_BYTES + 1024u + 2u * 8u * QMC_PROTO_MAX_LIST +             \
     QMC_SCENE_MAX_BYTES + 1u)
#define QMC__CLIENT_RECV_BYTES (QMC_PROTO_HEADER_BYTES + QMC_CLIENT_MAX_FRAME)

/* A job this client submitted and has not yet handed back. */
typedef struct qmc__client_job {
    int used;
    uint64_t request_id;              /* of its INTEGRATE */
    uint64_t job_id;
    int finished;                     /* result or err below is final */
    int err;                          /* 0 or the job's error */
    qmc_client_result result;
    char message[QMC_PROTO_MAX_MESSAGE + 1];
} qmc__client_job;

/* The shared-memory ring (shm.c): slots are filled by the server in order
 * and released by us oldest first, so `next` and a count say it all. */
typedef struct qmc__client_ring {
    uint8_t *base;                    /* the mapping, NULL when none */
    size_t bytes;
    uint32_t slots, slot_bytes;
    uint32_t next;                    /* the slot the next chunk must name */
    uint32_t held;                    /* chunks received, not yet released */
    uint32_t pinned;                  /* of them, slots a session's batch still
                                         needs (its values go there): while any
                                         is, nothing is released */
} qmc__client_ring;

/* The ring qmc_client_points* attach by themselves on a Unix socket: 8
 * slots of one chunk's size (a chunk is never larger than inline; the
 * server sends half a ring at a time, so 8 lets it fill 4 while we read 4). */
#define QMC__CLIENT_AUTO_SLOTS 8u
#define QMC__CLIENT_AUTO_SLOT_BYTES QMC_PROTO_CHUNK_BYTES

struct qmc_client {
    int fd;                           /* -1 when not connected */
    int unix_socket;                  /* connected to a unix: endpoint */
    int timeout_ms;                   /* > 0, or -1 */
    uint64_t next_request_id;
    char message[QMC_CLIENT_MESSAGE_BYTES];
    /* the server, from HELLO_OK */
    char server[QMC_PROTO_MAX_NAME + 1];
    char engine[QMC_PROTO_MAX_NAME + 1];
    uint64_t sobol_table_hash;
    uint32_t max_frame, max_inflight;
    uint64_t max_points;
    uint16_t version;                 /* the protocol version HELLO_OK chose */
    /* the ring; shm_off: attach no more (refused, failed, or turned off) */
    qmc__client_ring ring;
    int shm_off;
    /* receive buffer: bytes [rpos, rlen) are unread */
    uint8_t *rbuf;
    size_t rcap, rpos, rlen;
    uint8_t *sbuf;
    size_t scap;
    uint32_t max_jobs;
    qmc__client_job jobs[QMC_CLIENT_MAX_JOBS];
    /* the key (auth.c), wiped at close; authenticated: both proofs held */
    uint8_t auth_key[QMC_AUTH_KEY_MAX_BYTES];
    size_t auth_key_bytes;
    int authenticated;
    /* open session handles (session.c), whose frames are filed as they come */
    qmc_client_session *sessions;
};

/* The allocator seam: qmc_client_connect passes malloc; the unit test
 * passes one that fails on request. */
typedef void *(*qmc__client_alloc_fn)(void *ctx, size_t bytes);
int qmc__client_connect_with(const char *endpoint, int timeout_ms,
                             qmc__client_alloc_fn alloc, void *alloc_ctx,
                             qmc_client **out);
/* The same, with a key file (NULL: $QMC_AUTH_KEY_FILE if set; "": none). */
int qmc__client_connect_key_with(const char *endpoint, int timeout_ms, const char *key_file,
                                 qmc__client_alloc_fn alloc, void *alloc_ctx,
                                 qmc_client **out);

/* ---- conn.c ------------------------------------------------------------------- */

/* Monotonic milliseconds. */
int64_t qmc__client_now_ms(void);

/* Waits until fd is ready for events or the deadline (qmc__client_now_ms
 * clock; -1: none) passes.  Returns 0 (ready, or an error or hangup the
 * next call reports), -ETIMEDOUT or -errno. */
int qmc__client_wait_fd(int fd, short events, int64_t deadline_ms);
/* now + c->timeout_ms, or -1 without a timeout. */
int64_t qmc__client_deadline(const qmc_client *c);

/* Sets c->message (printf-style) and returns err. */
int qmc__client_fail(qmc_client *c, int err, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
/* As qmc__client_fail, and closes the connection: the stream is no
 * longer in a known state. */
int qmc__client_break(qmc_client *c, int err, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
/* Copies a server ERROR into c->message and returns its code (QMC_EPROTO
 * for a code that is not an error). */
int qmc__client_server_error(qmc_client *c, const qmc_msg *m);
/* Copies a wire string into dst[0 .. bytes), NUL-terminated, control
 * characters replaced so that it stays one line. */
void qmc__client_copy_str(char *dst, size_t bytes, qmc_str s);

/* Checks that the client may send; returns 0 or -ENOTCONN. */
int qmc__client_ready(qmc_client *c);
/* Encodes msg (request_id set here, returned in *request_id) and sends it
 * whole before the deadline. */
int qmc__client_send(qmc_client *c, qmc_msg *msg, uint64_t *request_id);
/* Encodes msg as it is (its request_id included) and sends it whole; with
 * pass_fd >= 0 the descriptor goes with the frame's first byte
 * (SCM_RIGHTS, in the same sendmsg).  Errors close the connection, except
 * an encoding error. */
int qmc__client_send_frame(qmc_client *c, const qmc_msg *msg, int pass_fd);
/* Reads the next frame into *msg (views into the receive buffer, valid
 * until the next read).  Errors close the connection, except -ETIMEDOUT
 * when keep_on_timeout is set. */
int qmc__client_read(qmc_client *c, int64_t deadline_ms, int keep_on_timeout,
                     qmc_msg *msg);
/* A frame that is not the answer being waited for: files it for its job
 * (0), or fails and closes (a connection-level ERROR, a stray frame). */
int qmc__client_other(qmc_client *c, const qmc_msg *msg, uint64_t waiting_for);
/* Reads until a frame for request_id arrives; frames for this client's
 * jobs are filed on the way (qmc__client_file_job).  Same errors. */
int qmc__client_await(qmc_client *c, uint64_t request_id, int64_t deadline_ms,
                      int keep_on_timeout, qmc_msg *msg);

/* ---- points.c --------------------------------------------------------------------- */

/* How far a whole (possibly split) stream has got, for messages. */
typedef struct qmc__client_progress {
    uint64_t done;                /* points handed to the callback */
    uint64_t total;               /* points the caller asked for */
    const char *noun;             /* what a point is called: "points", "samples" */
    const char *what;             /* the request, for messages: "points", "pixels" */
} qmc__client_progress;

/*
 * Sends req (a POINTS or PIXELS whose answer is `count` points numbered
 * from `start`, `row_bytes` each) and reads its stream: chunks, checked
 * and handed to on_chunk, then END.  *transport (the request's transport
 * field) is set here: the ring when one is attached (or worth attaching
 * and attached now) and a point fits a slot.  Errors as
 * qmc_client_points_stream; pr says how far the whole stream got.
 */
int qmc__client_stream_one(qmc_client *c, qmc_msg *req, qmc_points_transport *transport,
                           uint64_t start, uint64_t count, uint64_t row_bytes,
                           qmc_client_chunk_fn on_chunk, void *ctx, qmc__client_progress *pr);

/* A qmc_client_chunk_fn that copies each chunk into a caller's buffer,
 * in host byte order: point `first` goes to out + (first - start) *
 * row_bytes. */
typedef struct qmc__client_copy {
    uint8_t *out;
    uint64_t start;
    size_t row_bytes, value_bytes;
} qmc__client_copy;
int qmc__client_copy_chunk(void *ctx, uint64_t first, uint32_t points, const void *data,
                           size_t bytes);

/* ---- shm.c ---------------------------------------------------------------------- */

/* Sends SHM_RELEASE for every slot held (nothing when none).  Returns 0 or
 * a send error (the connection is then closed). */
int qmc__client_shm_release(qmc_client *c);
/* Attaches the automatic ring if this client should and can: a Unix
 * socket, a version-2 server, not attached, not turned off.  A refusal or
 * a local failure turns it off for this client and returns 0 (the points
 * then travel inline); only a broken connection is an error. */
int qmc__client_shm_auto(qmc_client *c);
/* Unmaps the ring (the connection is gone). */
void qmc__client_shm_unmap(qmc_client *c);

/* ---- auth.c ---------------------------------------------------------------------- */

/* Reads and checks a key file into c.  Returns 0, QMC_EAUTH (mode, size)
 * or -errno, with the reason in c->message. */
int qmc__client_load_key(qmc_client *c, const char *path);
/* Wipes the key from c. */
void qmc__client_wipe_key(qmc_client *c);
/* m holds the AUTH_CHALLENGE answering HELLO hello_id (which offered
 * version_min..version_max): answers it, checks AUTH_OK, and leaves in m
 * the frame after it (HELLO_OK, or ERROR).  Errors close the connection. */
int qmc__client_authenticate(qmc_client *c, uint64_t hello_id, uint16_t version_min,
                             uint16_t version_max, qmc_msg *m);

/* ---- shm.c, for sessions -------------------------------------------------------- */

/* Attaches a ring of slots x slot_bytes if this client should and can (as
 * qmc__client_shm_auto, which it is with other sizes). */
int qmc__client_shm_attach_sized(qmc_client *c, uint32_t slots, uint32_t slot_bytes);

/* ---- conn.c, for sessions ------------------------------------------------------- */

/* Sends head[0 .. head_len) then data[0 .. data_len) as one frame's bytes
 * (a zero-copy prefix and its data), whole, before the deadline.  Errors
 * close the connection. */
int qmc__client_send_parts(qmc_client *c, const void *head, size_t head_len, const void *data,
                           size_t data_len, const char *what);

/* ---- session.c ------------------------------------------------------------------ */

/* If msg belongs to one of this client's sessions (its request, or the
 * values it sent), files it and returns 1; 0 for other frames; a negative
 * error for a frame that breaks the protocol (the connection is closed). */
int qmc__client_file_session(qmc_client *c, const qmc_msg *msg);
/* qmc_client_close: the sessions lose their connection (handles freed by
 * the caller stay freed). */
void qmc__client_sessions_detach(qmc_client *c);

/* ---- session_part.c ------------------------------------------------------------- */

/* A part session's answer as it arrives (protocol version 6): SESSION_PART,
 * then its block sums, gathered in a buffer grown as they come (never
 * larger than what the server sent, at most QMC_SAMPLING_MAX_BLOCKS). */
typedef struct qmc__client_part {
    uint32_t part_k, part_p;       /* as opened (0 0: a whole job, or a resume) */
    int have_head;
    qmc_msg_session_part head;
    qmc_sampling_sums *sums;
    uint64_t got, cap;
} qmc__client_part;

/* Files a SESSION_PART or SESSION_PART_SUMS of session session_id: 0, or
 * a reason in why (a frame out of turn, or past its part; QMC_ENOMEM: no
 * room for the sums) with the error to break the connection with. */
int qmc__client_part_file(qmc__client_part *p, uint64_t session_id, const qmc_msg *m,
                          char *why, size_t why_bytes);
/* SESSION_RESULT came: 0 when the part (if any) is whole, else why. */
int qmc__client_part_end(const qmc__client_part *p, char *why, size_t why_bytes);
/* As qmc_client_session_part. */
int qmc__client_part_get(const qmc__client_part *p, qmc_session_part_sums *out);
void qmc__client_part_free(qmc__client_part *p);

/* ---- jobs.c --------------------------------------------------------------------- */

/* A JOB_RESULT's (or SESSION_RESULT's) fields into a result. */
void qmc__client_copy_result(qmc_client_result *r, const qmc_msg_job_result *m);


/* If msg belongs to one of this client's jobs, files it and returns 1;
 * returns 0 for other frames, or a negative error (malformed result). */
int qmc__client_file_job(qmc_client *c, const qmc_msg *msg);

#endif
