/*
 * conn.h - one client connection: bounded input and output buffers, the
 * requests in flight, and the deadlines that guard them.
 */
#ifndef QMCD_CONN_H
#define QMCD_CONN_H

#include <stddef.h>
#include <stdint.h>

#include "conn_services.h"
#include "peers.h"
#include "qmc/proto.h"
#include "server.h"

typedef struct qmcd_auth_conn qmcd_auth_conn;
typedef struct qmcd_producer qmcd_producer;

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
    uint8_t key_id[QMCD_KEY_ID_BYTES]; /* the key the handshake proved (auth.c),
                                    or zeros */
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
    qmcd_producer *producers;    /* requests answering over time, in turn order
                                    (producer.h, producer.c) */
    unsigned n_producers;        /* on that list */
    unsigned n_bulk;             /* of them QMCD_PRODUCER_BULK */
    qmcd_pool_tenant *tenant;    /* its share of the worker pool (pool.c), or NULL */
    uint64_t cancel_tokens;      /* max-cancels-per-conn bucket, in 1/60000ths
                                    (producer.c) */
    int64_t cancel_refill_ms;    /* when it was last refilled, or 0: full */
    qmcd_ring *ring;             /* the client's shared-memory ring (ring.h),
                                    or NULL */
    qmcd_auth_conn *auth;        /* a handshake awaiting AUTH_RESPONSE
                                    (auth.c), or NULL */
};

/* Accept handler for a listening socket's watch (conn_accept.c). */
void qmcd_conn_on_accept(qmcd_server *srv, qmcd_watch *w, uint32_t events);
/* A connection's own watch handler (conn.c), set by conn_accept.c. */
void qmcd__conn_on_event(qmcd_server *srv, qmcd_watch *w, uint32_t events);

/* Loop housekeeping (see loop.c). */
void qmcd_conns_tick(qmcd_server *srv, int64_t now_ms);
void qmcd_conns_reap(qmcd_server *srv);
void qmcd_conns_close_all(qmcd_server *srv, const char *why);
/* Draining, at the deadline: tells every producer (a job cancels itself
 * and answers ERROR), and closes the connections whose producers cannot
 * end by themselves (streams), with why. */
void qmcd_conns_deadline(qmcd_server *srv, const char *why);
/* Draining: closes connections with nothing in flight. */
void qmcd_conns_close_idle(qmcd_server *srv);

#endif
