/*
 * conn.h - one client connection: bounded input and output buffers, the
 * requests in flight, and the deadlines that guard them.
 */
#ifndef QMCD_CONN_H
#define QMCD_CONN_H

#include <stddef.h>
#include <stdint.h>

#include "peers.h"
#include "qmc/proto.h"
#include "server.h"

typedef struct qmcd_stream qmcd_stream;
typedef struct qmcd_job qmcd_job;
typedef struct qmcd_ring qmcd_ring;
typedef struct qmcd_auth_conn qmcd_auth_conn;
typedef struct qmcd_pool_tenant qmcd_pool_tenant;

/* Output space kept free for small answers (PONG, ERROR, STATS_REPLY,
 * JOB_RESULT): requests are read only while this much is free, and POINTS
 * chunks are generated only when they leave it free.  The largest small
 * answer (a STATS_REPLY of QMC_PROTO_MAX_STATS entries) is under 20 KiB. */
#define QMCD_OUT_RESERVE (64u << 10)
/* Output buffer every connection may allocate whatever the other
 * connections hold: room for the small answers (twice the reserve), so
 * HELLO, PING and STATS are served when out-buffer-total-bytes is spent.
 * Allocation beyond it counts against out-buffer-total-bytes. */
#define QMCD_OUT_FLOOR_BYTES (2 * QMCD_OUT_RESERVE)
/* After an ERROR that ends a connection, how long we keep flushing it and
 * draining the peer's input before closing regardless. */
#define QMCD_LINGER_MS 2000
/* Refused connections (max-connections, max-connections-per-peer) linger
 * like failed ones, so the peer reads the ERROR instead of a reset; past
 * this many lingering at once, further refusals are closed at once. */
#define QMCD_REFUSING_MAX 64

struct qmcd_conn {
    qmcd_watch w;                /* first: epoll hands us &conn->w */
    qmcd_server *srv;
    qmcd_conn *prev, *next;      /* srv->conns, or the dead list */
    uint64_t id;
    char peer[96];
    qmcd_peer_key peer_key;      /* counted in srv->peers unless refused */
    int refused;                 /* over a connection limit: ERROR, linger, close */
    int dead;                    /* fd closed; freed after this loop round */
    int hello_done;
    uint16_t version;            /* the protocol version HELLO_OK chose, or 0
                                    before it: what our frames are encoded for */
    int peer_eof;                /* the peer half-closed: answer, then close */
    int closing;                 /* ERROR sent: flush, shut down, close */
    int wr_shut;                 /* shutdown(SHUT_WR) done: only draining */
    int parsing;                 /* inside qmcd_conn_parse (no re-entry) */
    int unix_socket;             /* AF_UNIX: read with recvmsg, may pass fds */
    uint32_t client_max_frame;   /* HELLO: the largest payload it accepts */
    uint32_t server_max_frame;   /* HELLO_OK: what we promised to accept; a
                                    SIGHUP does not change it for this peer */
    uint8_t *in;                 /* received bytes, in[0 .. in_len) */
    size_t in_len, in_alloc;
    uint64_t in_offset;          /* stream offset of in[0] (bytes consumed) */
    int passed_fd;               /* a descriptor received with SCM_RIGHTS and
                                    not yet claimed by its SHM_ATTACH, or -1 */
    uint64_t passed_fd_from;     /* the stream offsets of the bytes that came
                                    with it: [from, to) */
    uint64_t passed_fd_to;
    uint8_t *out;                /* pending output, out[out_head .. out_tail) */
    size_t out_head, out_tail, out_alloc;
    int out_waiting;             /* a stream waits for out-buffer-total-bytes */
    int64_t accepted_ms, active_ms;
    int64_t partial_ms;          /* when the unfinished frame began, or 0 */
    int64_t stall_ms;            /* output pending and none written since, or 0 */
    int64_t close_by_ms;         /* closing: the linger deadline */
    qmcd_stream *streams;        /* POINTS in progress, round robin */
    unsigned n_streams;
    qmcd_job *jobs;              /* INTEGRATE jobs not yet answered */
    unsigned n_jobs;
    qmcd_pool_tenant *tenant;    /* its share of the worker pool (pool.c), or NULL */
    uint64_t cancel_tokens;      /* max-cancels-per-conn bucket, in 1/60000ths */
    int64_t cancel_refill_ms;    /* when it was last refilled, or 0: full */
    qmcd_ring *ring;             /* the client's shared-memory ring (points.c),
                                    or NULL */
    qmcd_auth_conn *auth;        /* a handshake awaiting AUTH_RESPONSE
                                    (auth.c), or NULL */
};

/* Accept handler for a listening socket's watch. */
void qmcd_conn_on_accept(qmcd_server *srv, qmcd_watch *w, uint32_t events);

/* Bytes that may still be queued for output under out-buffer-bytes. */
size_t qmcd_conn_out_room(const qmcd_conn *c);

/* align_at for frames with no alignment wish (all but POINTS data). */
#define QMCD_NO_ALIGN ((size_t)-1)

/*
 * Reserves `bytes` of output space whose byte at offset `align_at` lies on
 * a 64-byte boundary (so point data can be written in place with aligned
 * stores); returns where to write, or NULL when out-buffer-bytes would be
 * exceeded or memory is short.  qmcd_conn_out_commit then queues them.
 */
uint8_t *qmcd_conn_out_reserve(qmcd_conn *c, size_t bytes, size_t align_at);
void qmcd_conn_out_commit(qmcd_conn *c, size_t bytes);

/* Encodes and queues one frame.  Returns 0, or -1 when the frame does not
 * fit (the connection is then closed: see conn.c). */
int qmcd_conn_send(qmcd_conn *c, const qmc_msg *m);

/* Queues an ERROR frame for request_id with a printf-style one-line
 * message.  Returns as qmcd_conn_send. */
int qmcd_conn_error(qmcd_conn *c, uint64_t request_id, int code, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));

/* ERROR then close: stops reading requests, drops the connection's work,
 * flushes, shuts down and closes within QMCD_LINGER_MS. */
void qmcd_conn_fail(qmcd_conn *c, uint64_t request_id, int code, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));

/* Closes at once (no goodbye): peer gone or not reading. */
void qmcd_conn_close(qmcd_conn *c, const char *why);

/* Flushes output, produces more (results, chunks) and updates the epoll
 * interest.  Call after anything queued output or freed room. */
void qmcd_conn_kick(qmcd_conn *c);

/* Loop housekeeping (see loop.c). */
void qmcd_conns_tick(qmcd_server *srv, int64_t now_ms);
void qmcd_conns_reap(qmcd_server *srv);
void qmcd_conns_close_all(qmcd_server *srv, const char *why);
/* Draining: closes connections with POINTS streams still going. */
void qmcd_conns_close_streams(qmcd_server *srv, const char *why);
/* Draining: closes connections with nothing in flight. */
void qmcd_conns_close_idle(qmcd_server *srv);

#endif
