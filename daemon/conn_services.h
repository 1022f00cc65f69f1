/*
 * conn_services.h - what a request handler or a producer may do with its
 * connection (Redis's addReply* API): reserve and commit output, send a
 * frame or an ERROR, fail or kick the connection, and read the few facts
 * about it that answers depend on.  conn.c implements it.
 *
 * Handlers and producers (points.c, jobs.c, shm.c, ...) include this, not
 * conn.h: a connection's fields are conn.c's and conn_read.c's business,
 * so a new kind cannot come to depend on them.
 */
#ifndef QMCD_CONN_SERVICES_H
#define QMCD_CONN_SERVICES_H

#include <stddef.h>
#include <stdint.h>

#include "peers.h"
#include "qmc/proto.h"
#include "server.h"

typedef struct qmcd_ring qmcd_ring;
typedef struct qmcd_pool_tenant qmcd_pool_tenant;
typedef struct qmcd_peer_key qmcd_peer_key;

/* Output space kept free for small answers (PONG, ERROR, STATS_REPLY,
 * JOB_RESULT): requests are read only while this much is free, and bulk
 * frames (POINTS chunks) are generated only when they leave it free.  The
 * largest small answer (a STATS_REPLY of QMC_PROTO_MAX_STATS entries) is
 * under 20 KiB. */
#define QMCD_OUT_RESERVE (64u << 10)

/* Bytes that may still be queued for output under out-buffer-bytes (and
 * what out-buffer-total-bytes leaves). */
size_t qmcd_conn_out_room(const qmcd_conn *c);

/* align_at for frames with no alignment wish (all but bulk data). */
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
 * interest.  Call after anything queued output, freed room, or finished
 * what a producer waited for (QMCD_WAIT_WORK). */
void qmcd_conn_kick(qmcd_conn *c);

/* ---- facts about the connection ---------------------------------------------------- */

qmcd_server *qmcd_conn_server(const qmcd_conn *c);
/* Its number, for log lines ("conn 12"). */
uint64_t qmcd_conn_id(const qmcd_conn *c);
/* 1 once it failed or closed: its producers are released, nothing more
 * may be queued for them. */
int qmcd_conn_gone(const qmcd_conn *c);
/* 1 on a Unix socket (descriptors may pass; the ring is possible). */
int qmcd_conn_is_unix(const qmcd_conn *c);
/* Its peer (peers.h): an address, or a uid - whose shares it draws on. */
const qmcd_peer_key *qmcd_conn_peer(const qmcd_conn *c);
/* The protocol version HELLO_OK chose (0 before it). */
unsigned qmcd_conn_version(const qmcd_conn *c);
/* The largest frame payload the client accepts (its HELLO). */
uint32_t qmcd_conn_client_max_frame(const qmcd_conn *c);
/* Who the client is, for what outlives a connection (an integration
 * session): its peer (peers.h: the uid on a Unix socket, the address over
 * TCP) and, when the handshake authenticated it, a digest of the key it
 * proved (all zero otherwise), so that a rotated key is another identity. */
#define QMCD_KEY_ID_BYTES 16
typedef struct qmcd_identity {
    qmcd_peer_key peer;
    uint8_t key_id[QMCD_KEY_ID_BYTES];
} qmcd_identity;
void qmcd_conn_identity(const qmcd_conn *c, qmcd_identity *out);
/* The client's shared-memory ring (ring.h), or NULL before SHM_ATTACH. */
qmcd_ring *qmcd_conn_ring(const qmcd_conn *c);
/* Attaches r as its ring (shm.c; the connection frees it when it goes). */
void qmcd_conn_set_ring(qmcd_conn *c, qmcd_ring *r);
/* Its share of the worker pool (pool.h), made on first use and released
 * when the connection goes.  Returns 0 or -ENOMEM. */
int qmcd_conn_tenant(qmcd_conn *c, qmcd_pool_tenant **out);

#endif
