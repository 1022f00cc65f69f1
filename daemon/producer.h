/*
 * producer.h - the producer interface: what a connection pumps without
 * knowing what it makes (docs/STYLE.md section 11, HAProxy's applets), and
 * the dispatch table that routes requests to the files that make them
 * (Redis's command table).
 *
 * A producer is one request in flight that answers over time: a POINTS
 * stream (points.c), an INTEGRATE job (jobs.c), a PIXELS tile, an
 * integration session.  Its kind is a const table of functions
 * (qmcd_producer_kind); the producer itself is a qmcd_producer embedded
 * in the kind's own struct (first, so a cast finds the struct; jobs.c,
 * whose first member is the pool's, uses offsetof).  A connection holds its producers in one
 * list, in turn order, and
 *   - pumps them when its output buffer may have room: each pump queues at
 *     most one frame and says how the producer stands (qmcd_pump);
 *   - asks what they wait on (a ring slot, a worker), to decide whether a
 *     writable socket matters and whether a full ring has stalled;
 *   - ticks them (time limits, progress), tells them when the shutdown
 *     deadline passes, and releases them: when they are done, when a
 *     duplicate request id ends them, when the connection goes.
 * conn.c and dispatch.c never learn a kind's name; a kind reaches the
 * connection only through conn_services.h.
 *
 * Requests reach a kind through the dispatch table.  A module (the file
 * of a kind, or one that answers some messages without a producer, like
 * shm.c) exports a qmcd_module with its rows (qmcd_route: message type,
 * what the type is, handler), listed once in modules.h; modules.c puts
 * the rows into the server's table at start.
 *
 * Adding a kind (PIXELS, issue 20; sessions, issue 21), in its own file:
 *   1. struct tile { qmcd_producer p; ...its state... };  p first.
 *   2. static const qmcd_producer_kind tile_kind = {
 *          .name = "pixels", .flags = QMCD_PRODUCER_BULK,
 *          .pump = tile_pump, .waiting = tile_waiting,
 *          .shutdown = tile_shutdown, .release = tile_release };
 *   3. the PIXELS handler validates the request (ERROR through
 *      qmcd_conn_error), allocates a tile and calls
 *      qmcd_producer_attach(c, &t->p, &tile_kind, m->request_id).
 *   4. const qmcd_module qmcd_pixels_module = {
 *          .name = "pixels", .routes = (const qmcd_route[]){
 *              {QMC_MSG_PIXELS, QMCD_ROUTE_REQUEST | QMCD_ROUTE_STARTS, on_pixels},
 *              {0}},
 *          .open = ..., .close = ... };   (server-wide state, if any)
 *   5. one line in modules.h: X(qmcd_pixels_module).
 * A kind that streams through the client's shared-memory ring fills its
 * slots with ring.h (qmcd_ring_full, _next, _hand_out on qmcd_conn_ring).
 * A session waiting for its caller's values answers QMCD_WAIT_WORK from
 * waiting and QMCD_PUMP_WAIT from pump, holds no thread, and is woken by
 * qmcd_conn_kick when the values arrive; a tile through the client's ring
 * answers QMCD_WAIT_RING while every slot is held, like a POINTS stream.
 *
 * This header must not name a kind; the kinds must not reach into a
 * connection's fields (conn.h) - conn_services.h is their door.
 */
#ifndef QMCD_PRODUCER_H
#define QMCD_PRODUCER_H

#include <stdint.h>

#include "conn_services.h"
#include "qmc/proto.h"
#include "server.h"

typedef struct qmcd_producer qmcd_producer;
typedef struct qmcd_producer_kind qmcd_producer_kind;

/* What a pump did; QMCD_PUMP_FLUSH may be or'ed into SENT and DONE. */
enum {
    /* Queued one frame; more to come.  It goes to the back of the turn. */
    QMCD_PUMP_SENT = 1,
    /* Queued its last frame: the connection unlinks and releases it
     * (QMCD_END_DONE). */
    QMCD_PUMP_DONE = 2,
    /* Queued an ERROR that ends it, or the connection closed under it:
     * unlinked and released (QMCD_END_FAILED) unless the connection is
     * gone, which released it already. */
    QMCD_PUMP_FAILED = 3,
    /* Its next frame needs more output room than is free now: the
     * producers behind it wait too, so that one with big frames is not
     * starved by small ones. */
    QMCD_PUMP_NO_ROOM = 4,
    /* Waits on something else (a ring slot, a worker, the peer's values):
     * the producers behind it go. */
    QMCD_PUMP_WAIT = 5,
    /* Or'ed in: the frame just queued is worth sending at once (a ring
     * chunk: the client starts on its slot while we fill the next). */
    QMCD_PUMP_FLUSH = 0x10,
};
#define QMCD_PUMP_STATUS(rc) ((rc) & 0x0f)

/* What a producer waits on now (kind->waiting). */
typedef enum qmcd_wait {
    QMCD_WAIT_NONE = 0,   /* only output room: EPOLLOUT matters */
    QMCD_WAIT_RING,       /* a slot of the connection's ring: SHM_RELEASE (EPOLLIN);
                             write-timeout-ms runs while the ring is full */
    QMCD_WAIT_WORK,       /* work elsewhere (a worker thread, the peer's values):
                             whoever finishes it calls qmcd_conn_kick */
} qmcd_wait;

/* Why a producer is released (kind->release). */
typedef enum qmcd_end {
    QMCD_END_DONE,        /* its pump said QMCD_PUMP_DONE */
    QMCD_END_FAILED,      /* its pump said QMCD_PUMP_FAILED */
    QMCD_END_ENDED,       /* a new request reused its id: the caller sends the
                             ERROR that ends both (PROTOCOL.md section 3) */
    QMCD_END_DROPPED,     /* the connection is closing, or failed: no answer */
} qmcd_end;

/* kind->flags */
/* Its frames are bulk data (chunks, tiles): while one is open, the
 * connection keeps the output buffer it grew for them. */
#define QMCD_PRODUCER_BULK 1u

struct qmcd_producer_kind {
    const char *name;     /* for logs: "points", "job" */
    unsigned flags;       /* QMCD_PRODUCER_* */
    /* Queues at most one frame (checking qmcd_conn_out_room first) and
     * returns a QMCD_PUMP_* status.  It may close the connection (a send
     * that fails); then every producer, p too, is already released. */
    int (*pump)(qmcd_conn *c, qmcd_producer *p);
    /* What p waits on now; never queues anything. */
    qmcd_wait (*waiting)(const qmcd_conn *c, const qmcd_producer *p);
    /* Every QMCD_TICK_MS, or NULL: time limits, advisory progress frames
     * (sent only with QMCD_OUT_RESERVE free).  Must not end p: a producer
     * that times out says so from its next pump. */
    void (*tick)(qmcd_conn *c, qmcd_producer *p, int64_t now_ms);
    /* The shutdown deadline passed (shutdown-timeout-ms after SIGTERM).
     * Returns 0 when p stops by itself and answers (a job cancelled, its
     * ERROR follows), 1 when it cannot end cleanly and its connection must
     * be cut (a stream).  Sends nothing.  NULL counts as 1. */
    int (*shutdown)(qmcd_conn *c, qmcd_producer *p);
    /* p is off the connection's list: free it (or hand it to whoever still
     * holds it, like a worker).  With QMCD_END_DROPPED the connection is
     * going away and must not be sent anything; with QMCD_END_ENDED the
     * caller sends the ERROR.  Never sends. */
    void (*release)(qmcd_conn *c, qmcd_producer *p, qmcd_end why);
};

/* The part of a producer the connection reads and writes; embedded in
 * the kind's own struct. */
struct qmcd_producer {
    const qmcd_producer_kind *kind;
    qmcd_producer *next;          /* the connection's list, in turn order */
    uint64_t request_id;          /* the request it answers */
};

/* ---- for the kinds --------------------------------------------------------------- */

/* Puts p at the back of c's turn order, answering request_id.  The
 * connection owns it from here: kind->release is called exactly once. */
void qmcd_producer_attach(qmcd_conn *c, qmcd_producer *p, const qmcd_producer_kind *kind,
                          uint64_t request_id);

/* c's producers in turn order (follow ->next); do not unlink them. */
qmcd_producer *qmcd_producer_first(const qmcd_conn *c);

/* How many producers of kind c holds (NULL: of every kind). */
unsigned qmcd_producer_count(const qmcd_conn *c, const qmcd_producer_kind *kind);

/* max-cancels-per-conn: a bucket of that many cancels, refilled at that
 * many a minute, per connection.  Returns 1 when this cancel may go on
 * (and takes a token), 0 when the client cancels too often. */
int qmcd_producer_cancel_allowed(qmcd_conn *c);

/* ---- the dispatch table --------------------------------------------------------- */

/* What a message type is (qmcd_route.flags). */
/* A request: answered under its id, so id 0 is refused and an id already
 * in flight on the connection ends both. */
#define QMCD_ROUTE_REQUEST 1u
/* Starts a producer: refused while the server drains and at
 * max-inflight producers on the connection. */
#define QMCD_ROUTE_STARTS 2u
/* May arrive with a descriptor (SCM_RIGHTS); for every other type a
 * descriptor is closed before the handler runs. */
#define QMCD_ROUTE_FD 4u

/* A handler: m decoded at t0_us (latency starts there); fd is the
 * descriptor that came with it (QMCD_ROUTE_FD rows only) or -1, and the
 * handler always takes it (keeps or closes it). */
typedef void qmcd_handler(qmcd_conn *c, const qmc_msg *m, int fd, int64_t t0_us);

typedef struct qmcd_route {
    qmc_msg_type type;
    unsigned flags;               /* QMCD_ROUTE_* */
    qmcd_handler *fn;             /* NULL ends a module's rows */
} qmcd_route;

typedef struct qmcd_module {
    const char *name;
    const qmcd_route *routes;     /* its rows, ended by one with fn NULL; or NULL */
    /* With the server, in modules.h order after the loop exists (its
     * server-wide state: a cache, a watch); NULL: nothing.  Returns 0 or
     * -errno. */
    int (*open)(qmcd_server *srv);
    /* At exit, in reverse order, after every connection closed; NULL. */
    void (*close)(qmcd_server *srv);
    /* A connection is failing or closing (possibly twice): drop what the
     * module keeps for it outside its producers; NULL. */
    void (*conn_drop)(qmcd_conn *c);
} qmcd_module;

/* ---- for the connection (conn.c, dispatch.c) ------------------------------------- */

/* One turn: pumps c's producers in order until one queues a frame (it then
 * goes to the back, or is released when done), one finds no room, or all
 * wait.  Returns 0 when nothing was queued, else 1 | (2 when the frame
 * asks to be sent at once). */
#define QMCD_TURN_SENT 1
#define QMCD_TURN_FLUSH 2
int qmcd_producers_turn(qmcd_conn *c);

/* 1 when some producer of c waits on w now (QMCD_WAIT_NONE: wants output). */
int qmcd_producers_waiting(const qmcd_conn *c, qmcd_wait w);

/* The producer answering request_id, or NULL. */
qmcd_producer *qmcd_producers_find(const qmcd_conn *c, uint64_t request_id);
/* Unlinks p and releases it with why. */
void qmcd_producers_end(qmcd_conn *c, qmcd_producer *p, qmcd_end why);
/* Releases every producer (QMCD_END_DROPPED). */
void qmcd_producers_drop_all(qmcd_conn *c);
/* Ticks every producer that has a tick, until the connection closes. */
void qmcd_producers_tick(qmcd_conn *c, int64_t now_ms);
/* The shutdown deadline: tells every producer; 1 when one says that the
 * connection must be cut. */
int qmcd_producers_shutdown(qmcd_conn *c);

#endif
