/*
 * qmc/client.h - libqmcclient: a thin, synchronous client for qmcd.
 *
 * One qmc_client is one connection.  qmc_client_connect opens it (a Unix
 * socket or TCP over IPv4/IPv6), performs the HELLO handshake and keeps
 * the server's identity and limits.  Every other call sends one request
 * and reads frames until its answer is complete; nothing runs in the
 * background and no thread is started.
 *
 * Errors: every fallible call returns 0 or a negative code: a QMC_E* code
 * (qmc/error.h), a server ERROR frame's code passed through unchanged, or
 * -errno for system errors (-ETIMEDOUT when the server does not answer in
 * time, -ECONNREFUSED, -ECONNRESET, -EPIPE, ...).  qmc_client_last_error
 * then gives a one-line message: the server's text for ERROR frames,
 * else the library's.  A server ERROR leaves the connection usable; an
 * I/O error, a timeout or a malformed frame closes it, and later calls
 * return -ENOTCONN.
 *
 * Timeouts: the timeout (qmc_client_connect's timeout_ms, changed with
 * qmc_client_set_timeout) bounds each wait for the server: to connect, to
 * accept our bytes, to send its next frame.  A long POINTS stream or a long
 * job is fine as long as the server keeps answering; qmc_client_wait and
 * qmc_client_integrate check that a quiet server is alive with JOB_STATUS.
 * -1 waits without limit.  Host names are resolved with getaddrinfo(3),
 * which has no timeout of its own.
 *
 * Memory: a client makes one allocation, at connect, holding its send
 * buffer, its receive buffer (QMC_CLIENT_MAX_FRAME plus a header: the
 * largest frame it accepts, announced in HELLO) and a table of up to
 * QMC_CLIENT_MAX_JOBS unfinished jobs.  Nothing else grows.  On a unix:
 * endpoint a shared-memory ring for POINTS data may be mapped besides
 * (qmc_client_attach_shm; 8 MiB when attached automatically), until the
 * client is closed or its connection fails.
 *
 * Shared memory: over a Unix socket to a server that speaks protocol
 * version 2, the points of a POINTS request (and the samples of a PIXELS
 * request, version 4) can travel through a ring of
 * slots in a memfd the client shares with the server (PROTOCOL.md section
 * 10) instead of through the socket: the server writes each chunk straight
 * into a slot, so the data is never copied through the kernel.  The first
 * qmc_client_points, qmc_client_pixels or *_stream call that asks for more
 * than one chunk (QMC_PROTO_CHUNK_BYTES) attaches a ring of 8 slots of
 * QMC_PROTO_CHUNK_BYTES by itself; if the server refuses (TCP, an older
 * server, its max-shm-bytes) or the system cannot (no memfd_create), the
 * points simply come inline, as they always do over TCP.  Once a ring is
 * attached every POINTS and PIXELS request on the client uses it (whose points fit a
 * slot).  The output is the same bytes either way.
 *
 * Authentication: a server that requires its key (protocol version 3,
 * PROTOCOL.md section 4.1) challenges the client in the handshake; the
 * client answers with an HMAC-SHA256 proof and checks the server's.  The
 * key is read from a file (mode 0600 or stricter, 16 to 1024 bytes):
 * qmc_client_connect_auth's key_file, else $QMC_AUTH_KEY_FILE - so every
 * program on this library, qmc_client_connect included, authenticates
 * when that variable is set.  With a key, a tcp: server that does not
 * challenge is refused (QMC_EAUTH): it could not prove it holds the key.
 * The key stays in the client's memory, wiped at qmc_client_close.
 *
 * Threads: a qmc_client is not thread-safe: use each from one thread at a
 * time (one per thread is simplest).  Different clients share nothing and
 * may be used concurrently.  The library never prints, exits or raises
 * SIGPIPE (sends use MSG_NOSIGNAL).
 */
#ifndef QMC_CLIENT_H
#define QMC_CLIENT_H

#include <stddef.h>
#include <stdint.h>

#include "qmc/error.h"
#include "qmc/integrate.h"
#include "qmc/job.h"
#include "qmc/pixel.h"
#include "qmc/proto.h"
#include "qmc/result.h"
#include "qmc/sampling.h"
#include "qmc/seq.h"
#include "qmc/session.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The largest payload the client accepts (announced in HELLO): one full
 * POINTS_CHUNK of QMC_PROTO_CHUNK_BYTES and its prefix, with room to spare. */
#define QMC_CLIENT_MAX_FRAME (QMC_PROTO_CHUNK_BYTES + 4096u)
/* Unfinished jobs (submitted, result not yet taken by qmc_client_wait) one
 * client tracks; the server's max_inflight may lower it. */
#define QMC_CLIENT_MAX_JOBS 16u
/* Bytes of qmc_client_last_error's message, NUL included. */
#define QMC_CLIENT_MESSAGE_BYTES (QMC_PROTO_MAX_MESSAGE + 128u)

typedef struct qmc_client qmc_client;

/* An integration result, copied out of the server's JOB_RESULT frame.
 * The caller allocates it, so its size is part of the ABI: while the
 * library is 0.x (soname libqmcclient.so.0) it may grow between releases
 * (version 6 added has_known_abs), and clients are rebuilt with it. */
typedef struct qmc_client_result {
    uint64_t job_id;
    qmc_result res;
    qmc_cv_report cv;
    qmc_method method_used;       /* auto's choice, else the method */
    qmc_sampling_spec sampling;   /* sampling methods: the spec that ran */
    double seconds;               /* the server's compute time */
    int reference_kind;           /* 0 none, 1 exact, 2 high-accuracy reference */
    double reference;
    char detail[QMC_PROTO_MAX_MESSAGE + 1];      /* NUL-terminated */
    char auto_reason[QMC_PROTO_MAX_MESSAGE + 1]; /* "" unless auto chose */
    /* The integral of |f| the integrand knows in closed form, which a
     * report judges errors against (res.abs_integral is the integrator's
     * estimate of it): has_known_abs 1 with known_abs, 0 when nothing is
     * known (a session's f), -1 when the server did not say (protocol
     * version 5 or older). */
    int has_known_abs;
    double known_abs;
} qmc_client_result;

/*
 * Connects to endpoint "unix:PATH", "tcp:HOST:PORT", "tcp:1.2.3.4:PORT" or
 * "tcp:[::1]:PORT", and performs the handshake.  timeout_ms > 0, or -1 for
 * no limit.  On success *out is a new client (free with qmc_client_close).
 * On failure the return is QMC_EINVAL (malformed endpoint or timeout), a
 * -errno (-ECONNREFUSED, -ENOENT, -ETIMEDOUT, ...), QMC_EPROTO (the peer
 * does not speak the protocol), a server ERROR code, or QMC_ENOMEM; *out
 * is then still a client, not connected, whose qmc_client_last_error says
 * what failed - close it too - or NULL when even that could not be
 * allocated (QMC_ENOMEM).
 */
QMC_MUST_CHECK int qmc_client_connect(const char *endpoint, int timeout_ms,
                                      qmc_client **out);

/*
 * As qmc_client_connect, with the key in key_file: NULL reads the file
 * named by $QMC_AUTH_KEY_FILE when it is set (what qmc_client_connect
 * does), "" uses no key whatever the environment says.  Also returns
 * QMC_EAUTH: a key file open to group or others or of the wrong size, a
 * server that requires a key when the client has none, a wrong key (the
 * server's ERROR), a server whose proof is wrong, or a tcp: server that
 * does not ask for the key the client holds.  The connection is then
 * closed, and qmc_client_last_error says which.
 */
QMC_MUST_CHECK int qmc_client_connect_auth(const char *endpoint, int timeout_ms,
                                           const char *key_file, qmc_client **out);

/* 1 when the handshake authenticated both sides (the server challenged
 * and proved the key), else 0. */
int qmc_client_authenticated(const qmc_client *c);

/* Closes the connection and frees the client; NULL is a no-op. */
void qmc_client_close(qmc_client *c);

/* The last call's one-line message ("" after success); never NULL, valid
 * until the next call on c.  NULL c: "out of memory". */
const char *qmc_client_last_error(const qmc_client *c);

/* Sets the timeout for later calls (as qmc_client_connect's).  Returns 0
 * or QMC_EINVAL. */
QMC_MUST_CHECK int qmc_client_set_timeout(qmc_client *c, int timeout_ms);

/* What HELLO_OK said (strings "" and numbers 0 before a handshake). */
const char *qmc_client_server_name(const qmc_client *c);
const char *qmc_client_engine(const qmc_client *c);
uint64_t qmc_client_sobol_table_hash(const qmc_client *c);
uint32_t qmc_client_max_frame(const qmc_client *c);     /* server accepts */
uint32_t qmc_client_max_inflight(const qmc_client *c);
uint64_t qmc_client_max_points(const qmc_client *c);   /* per POINTS request */

/* Round trip of one PING; *rtt_seconds is set (0 on error). */
QMC_MUST_CHECK int qmc_client_ping(qmc_client *c, double *rtt_seconds);

/*
 * Called once per chunk, in index order: `points` points starting at index
 * `first`, data = points x dims values of the format, row-major,
 * little-endian, not necessarily aligned; bytes is at most
 * QMC_PROTO_CHUNK_BYTES, or the ring's slot size when a ring with larger
 * slots was attached (qmc_client_attach_shm).  data (in the receive buffer,
 * or in a ring slot) is valid only during the call: the slot goes back to
 * the server after it.  Return 0 to go on; any other value stops the
 * stream, is returned by qmc_client_points_stream, and closes the
 * connection (the protocol has no way to stop a stream halfway).
 */
typedef int (*qmc_client_chunk_fn)(void *ctx, uint64_t first, uint32_t points,
                                   const void *data, size_t bytes);

/*
 * Fetches points [start, start + count) of spec's sequence in format fmt,
 * calling on_chunk for each chunk.  Every chunk's first index and size are
 * checked against the request, and END's totals against what arrived
 * (QMC_EPROTO otherwise).  The server's checks (spec, range) come back
 * as its ERROR code and message.  A count above the server's max_points
 * (qmc_client_max_points) is sent as consecutive requests of at most
 * max_points each and reaches on_chunk as one stream, the same points as
 * one request: check the range first if a later request's ERROR must not
 * come after earlier chunks.  When the connection is lost mid-stream the
 * message says how far it got ("the daemon closed the connection after N
 * of M points").
 */
QMC_MUST_CHECK int qmc_client_points_stream(qmc_client *c, const qmc_seq_spec *spec,
                                            uint64_t start, uint64_t count,
                                            qmc_format fmt, qmc_client_chunk_fn on_chunk,
                                            void *ctx);

/*
 * As qmc_client_points_stream, into out: count x dims values of fmt in
 * host byte order (double, float or uint32_t), row-major.  out_bytes must
 * be at least that (else QMC_EINVAL before anything is sent).  On error
 * out may hold part of the points.
 */
QMC_MUST_CHECK int qmc_client_points(qmc_client *c, const qmc_seq_spec *spec,
                                     uint64_t start, uint64_t count, qmc_format fmt,
                                     void *out, size_t out_bytes);

/*
 * Fetches a tile of a pixel sampler (qmc/pixel.h) from the server, as
 * qmc_pixels_fill computes it in-process: for each pixel of the tile in
 * row order (y, then x), samples tile->sample_start .. + sample_count - 1,
 * spec->dims values each, in format fmt.  on_chunk is called as for
 * qmc_client_points_stream, with `first` the index of the chunk's first
 * sample in that order (0 for the tile's first) and `points` its samples;
 * data is little-endian.  The server checks spec and tile with
 * qmc_pixel_spec_check and qmc_pixels_tile_check, and its refusal comes
 * back as its ERROR code and one-line reason (the connection stays
 * usable).  A tile of more samples than the server's max_points is sent
 * as several requests, each a part of the tile whose output is
 * contiguous, and reaches on_chunk as one stream, the same bytes: check
 * the tile first if a later request's ERROR must not come after earlier
 * chunks.  The ring is used as for POINTS.
 *
 * Errors besides the server's and those of qmc_client_points_stream:
 * QMC_ENOTSUP when the server chose a protocol version below
 * QMC_PROTO_VERSION_PIXELS (an older qmcd: nothing is sent), QMC_ERANGE
 * for a tile of more than 2^64 samples, QMC_EFORMAT for an unknown fmt.
 */
QMC_MUST_CHECK int qmc_client_pixels_stream(qmc_client *c, const qmc_pixel_spec *spec,
                                            const qmc_pixel_tile *tile, qmc_format fmt,
                                            qmc_client_chunk_fn on_chunk, void *ctx);

/*
 * As qmc_client_pixels_stream, into out: the tile's width x height x
 * sample_count x dims values of fmt in host byte order (double, float or
 * uint32_t), exactly as qmc_pixels_fill writes them.  out_bytes must be at
 * least that (else QMC_EINVAL before anything is sent).  On error out may
 * hold part of the tile.
 */
QMC_MUST_CHECK int qmc_client_pixels(qmc_client *c, const qmc_pixel_spec *spec,
                                     const qmc_pixel_tile *tile, qmc_format fmt, void *out,
                                     size_t out_bytes);

/*
 * Attaches a shared-memory ring of `slots` slots of `slot_bytes` bytes to
 * this connection for POINTS data (see "Shared memory" above): a sealed,
 * fully allocated memfd, mapped here and passed to the server, which must
 * answer SHM_OK.  slots in QMC_PROTO_SHM_MIN_SLOTS..QMC_PROTO_SHM_MAX_SLOTS,
 * slot_bytes a multiple of QMC_PROTO_SHM_SLOT_ALIGN in
 * QMC_PROTO_SHM_MIN_SLOT_BYTES..QMC_PROTO_SHM_MAX_SLOT_BYTES; more slots
 * let the server run further ahead of a slow callback.  slots = 0 attaches
 * nothing and turns the automatic ring off for this client (its points
 * then always come inline).  A connection keeps its ring until it closes.
 *
 * Returns 0; QMC_EINVAL (bad sizes, a ring already attached); QMC_ENOTSUP
 * (a tcp: endpoint, a server older than protocol version 2); -errno from
 * memfd_create, fallocate or mmap; or the server's ERROR code (QMC_ENOTSUP
 * when it has shared memory turned off, QMC_ETOOBIG over its max-shm-bytes,
 * ...).  All of these leave the connection usable, the points inline; an
 * I/O error or a timeout closes it, as for any call.
 */
QMC_MUST_CHECK int qmc_client_attach_shm(qmc_client *c, uint32_t slots,
                                         uint32_t slot_bytes);

/* The attached ring's slots and slot size; 0 when none is attached. */
uint32_t qmc_client_shm_slots(const qmc_client *c);
uint32_t qmc_client_shm_slot_bytes(const qmc_client *c);

/*
 * Runs a job and waits for its result (qmc_client_submit then
 * qmc_client_wait without a time limit).  spec's arrays and scene text are
 * sent, not kept.  *out is filled on success and zeroed otherwise; a
 * failed job returns the server's code (QMC_EBUDGET, QMC_EINVAL, ...).
 */
QMC_MUST_CHECK int qmc_client_integrate(qmc_client *c, const qmc_job_spec *spec,
                                        qmc_client_result *out);

/* Submits a job; *job_id (0 on error) names it for poll, wait and cancel.
 * QMC_ETOOBIG when this client already has QMC_CLIENT_MAX_JOBS (or the
 * server's max_inflight) unfinished jobs. */
QMC_MUST_CHECK int qmc_client_submit(qmc_client *c, const qmc_job_spec *spec,
                                     uint64_t *job_id);

/* Asks the server for a job's state and evaluations so far. */
QMC_MUST_CHECK int qmc_client_poll(qmc_client *c, uint64_t job_id,
                                   qmc_job_state *state, uint64_t *evals);

/*
 * Waits up to timeout_ms (-1: no limit) for the result of a job this
 * client submitted.  Returns 0 with *out filled, the job's error (the
 * server's code; a cancelled job's is the server's, typically -ECANCELED),
 * -ETIMEDOUT when the time runs out (the job goes on and may be waited
 * for again; the connection stays open), or QMC_EINVAL for a job id this
 * client is not waiting for.  Once a result or error is returned the job
 * is forgotten.
 */
QMC_MUST_CHECK int qmc_client_wait(qmc_client *c, uint64_t job_id, int timeout_ms,
                                   qmc_client_result *out);

/* Asks the server to cancel a job.  Its result (usually an error) is then
 * collected with qmc_client_wait. */
QMC_MUST_CHECK int qmc_client_cancel(qmc_client *c, uint64_t job_id);

/*
 * Fetches the server's counters and calls on_stat(ctx, name, value) for
 * each, in the server's order; name is NUL-terminated and valid during the
 * call.  A non-zero return from on_stat stops the walk and is returned
 * (the connection stays usable: the reply is already read).
 */
typedef int (*qmc_client_stat_fn)(void *ctx, const char *name, uint64_t value);
QMC_MUST_CHECK int qmc_client_stats(qmc_client *c, qmc_client_stat_fn on_stat,
                                    void *ctx);

/* ---- integration sessions: the caller evaluates f (protocol version 5) -------------- */

/*
 * A session is an integration whose integrand this program evaluates: the
 * server hands out batches of points, the program returns f at them, and
 * the server keeps the estimate, the error bar, the flags and the stopping
 * rule (docs/SESSIONS.md; PROTOCOL.md section 6.21).  It is the in-process
 * ask/tell API of qmc/session.h across a connection, with the same bytes:
 *
 *     qmc_client_session *s;
 *     if (qmc_client_session_open(c, &spec, &s) != 0) ...
 *     for (;;) {
 *         qmc_session_batch b;
 *         if (qmc_client_session_next(s, &b) != 0) ...   // the connection failed
 *         if (b.count == 0) break;                        // done: b.end says why
 *         double *v = qmc_client_session_values(s);       // room for b.count values
 *         for (size_t i = 0; i < b.count; i++) v[i] = my_f(b.points + i * b.dims);
 *         if (qmc_client_session_tell(s, b.seq, v, b.count) != 0) ...
 *     }
 *     qmc_client_session_result(s, &res);                 // as qmc_client_integrate's
 *     qmc_client_session_close(s);
 *
 * or, with a callback, qmc_client_session_run.  Over a unix: endpoint the
 * batches travel through a shared-memory ring (attached by itself, sized
 * for the session's batches, unless the client has one or has turned it
 * off with qmc_client_attach_shm(c, 0, 0)); points then sit in the ring
 * and the values buffer too, so nothing is copied through the socket.
 * Over TCP, and for batches that do not fit the ring, they come inline.
 *
 * A session belongs to the identity that opened it (the user on a Unix
 * socket, the address and the key over TCP) and outlives its connection:
 * when the connection is lost, the server keeps it for a while (the
 * OPENED park_ms) and qmc_client_session_resume takes it up from another
 * connection with its ticket; the batch it waits for is served again.
 *
 * A qmc_client_session belongs to its qmc_client and is used from the same
 * thread; it must be freed (qmc_client_session_close or _free) by the
 * caller, before or after qmc_client_close (which detaches it).  It holds
 * one allocation for itself and, for batches that do not sit in the ring
 * whole, buffers for a batch's points and values (at most the OPENED
 * max_batch points).
 */
typedef struct qmc_client_session qmc_client_session;

/* What resumes a session: its id and its token (keep it secret: with the
 * identity that opened the session, it is the session). */
typedef struct qmc_client_session_ticket {
    uint64_t session_id;
    uint8_t token[QMC_PROTO_SESSION_TOKEN_BYTES];
} qmc_client_session_ticket;

/*
 * Opens a session on the server: spec as qmc_session_new takes it
 * (spec->integrate.interrupt is not sent).  On success *out is the
 * session, whose first batch is on its way.  A part session (part_p != 0)
 * needs protocol version 6: its answer is its block sums
 * (qmc_client_session_part).  Errors: QMC_ENOTSUP (a server older than
 * protocol version 5, or 6 for a part), QMC_EINVAL (no spec), the server's refusal with its
 * reason (QMC_EINVAL, QMC_EDIMS, QMC_EBUDGET, ... as qmc_session_new;
 * QMC_ETOOBIG for its session and memory limits), QMC_ENOMEM, or a
 * connection error.  *out is NULL on error.
 */
QMC_MUST_CHECK int qmc_client_session_open(qmc_client *c, const qmc_session_spec *spec,
                                           qmc_client_session **out);

/* The session's id and token, for qmc_client_session_resume. */
void qmc_client_session_ticket_get(const qmc_client_session *s, qmc_client_session_ticket *out);

/*
 * Takes up a session of this identity from connection c (after its own
 * connection was lost, or to take it over from one that still runs):
 * *out is a new handle, whose next batch is the one the session waits
 * for.  Errors: -ENOENT (no such session for this identity and token:
 * unknown, ended, expired, or another's), QMC_ENOTSUP, a connection error.
 */
QMC_MUST_CHECK int qmc_client_session_resume(qmc_client *c,
                                             const qmc_client_session_ticket *ticket,
                                             qmc_client_session **out);

/*
 * The batch the session waits for, waiting for it to arrive: as
 * qmc_session_ask, count 0 once the session is done (batch->end says why;
 * then qmc_client_session_result).  Asking again before telling returns
 * the same batch.  batch->points (count x dims, row-major) is valid until
 * the next tell, close or free.  Errors: a connection error (the session
 * is then parked on the server: resume it), -ENOTCONN.
 */
QMC_MUST_CHECK int qmc_client_session_next(qmc_client_session *s, qmc_session_batch *batch);

/* Room for the current batch's count values, valid until the next tell:
 * in the ring slot that holds the batch when there is one, so that tell
 * sends nothing but a small frame.  NULL when no batch is waiting. */
double *qmc_client_session_values(qmc_client_session *s);

/*
 * f at the points of batch seq, values[0 .. count) (from anywhere; from
 * qmc_client_session_values nothing is copied).  Sends them and waits for
 * the server's report on them (qmc_client_session_report).  NaN and
 * infinities are sent as they are: the server counts and flags them.
 * Errors: QMC_EINVAL for a seq or count that is not the waiting batch's
 * (nothing sent), the server's refusal with its reason (the batch still
 * waits), a connection error.
 */
QMC_MUST_CHECK int qmc_client_session_tell(qmc_client_session *s, uint64_t seq,
                                           const double *values, size_t count);

/* The server's last report (zeroed before the first). */
void qmc_client_session_report(const qmc_client_session *s, qmc_session_report *out);

/*
 * The final answer once next said done: 0 with *out as
 * qmc_client_integrate fills it, or the session's error (the server's
 * code and reason: a failed integrator, a session closed or taken over
 * elsewhere).  QMC_EAGAIN while it runs (*out zeroed).
 */
QMC_MUST_CHECK int qmc_client_session_result(const qmc_client_session *s,
                                             qmc_client_result *out);

/*
 * A part session's answer once next said done, as qmc_session_part gives
 * it in-process (the same bytes; out->sums is the handle's, valid until
 * close or free): 0, QMC_EAGAIN while it runs, QMC_EINVAL for a session
 * that is not a part, or the session's error.
 */
QMC_MUST_CHECK int qmc_client_session_part(const qmc_client_session *s,
                                           qmc_session_part_sums *out);

/*
 * Ends the session on the server (SESSION_CLOSE, when it still runs there
 * and its connection is up) and frees s.  Returns 0 or the error of that
 * exchange (s is freed whatever it returns).  NULL is a no-op.
 */
int qmc_client_session_close(qmc_client_session *s);

/* Frees s without telling the server, which keeps the session (resumable
 * by its ticket: once this connection is gone, or at once as a takeover).
 * Frames still coming for it on this connection are dropped.  NULL is a
 * no-op. */
void qmc_client_session_free(qmc_client_session *s);

/* f at count points of dims coordinates (row-major) into values[0 ..
 * count); return 0 to go on, anything else to stop. */
typedef int (*qmc_client_integrand_fn)(void *ctx, const double *points, size_t count,
                                       uint32_t dims, double *values);

/*
 * Runs a whole session with a callback: open, f on every batch, result,
 * close.  Returns 0 with *out filled, or the first error: the server's,
 * a connection's, or f's own non-zero return (the session is then closed
 * on the server).  *out is zeroed on error.
 */
QMC_MUST_CHECK int qmc_client_session_run(qmc_client *c, const qmc_session_spec *spec,
                                          qmc_client_integrand_fn f, void *ctx,
                                          qmc_client_result *out);

#ifdef __cplusplus
}
#endif
#endif /* QMC_CLIENT_H */
