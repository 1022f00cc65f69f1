/*
 * bulk.h - a bulk stream: `count` points of row_bytes each, numbered from
 * `first`, answered in POINTS_CHUNK frames (generated in place in the
 * output buffer) or, through the client's ring, POINTS_SHM_CHUNK frames,
 * then END - the answer PROTOCOL.md gives POINTS and PIXELS alike.  A
 * producer kind embeds one and supplies the fill; the stream does the
 * framing, the room and ring checks and the totals.
 */
#ifndef QMCD_BULK_H
#define QMCD_BULK_H

#include <stddef.h>
#include <stdint.h>

#include "producer.h"
#include "qmc/proto.h"

/* Writes points [first, first + points) in host byte order at dst (64-byte
 * aligned inline; a slot start in the ring).  Returns 0 or a QMC_E* code
 * (a bug: the range was checked when the stream began). */
typedef int (*qmcd_bulk_fill_fn)(void *ctx, uint64_t first, uint32_t points, uint8_t *dst);

typedef struct qmcd_bulk {
    uint64_t request_id;
    uint64_t next, end;           /* the next point to send, one past the last */
    uint64_t points_sent, bytes_sent;
    size_t row_bytes;             /* bytes of one point */
    size_t value_bytes;           /* bytes of one value (byte order) */
    size_t prefix_bytes;          /* a POINTS_CHUNK's bytes before its data */
    uint32_t chunk_points;        /* whole points per chunk */
    int shm;                      /* 1: through the connection's ring */
    int64_t t0_us;
    uint64_t *counter;            /* a STATS counter of points sent, or NULL */
    int end_follows;              /* 1: END goes right behind the last chunk when
                                     it fits, in the same pump (POINTS: a small
                                     request costs one turn, not two) */
    qmcd_bulk_fill_fn fill;
    void *ctx;
} qmcd_bulk;

/*
 * The transport half of qmcd_bulk_init, for a handler whose checks must
 * come in another order: QMC_TRANSPORT_SHM needs a ring on the
 * connection.  On a refusal answers ERROR for request_id, naming `what`,
 * and returns -1; else 0.
 */
int qmcd_bulk_check_transport(qmcd_conn *c, uint64_t request_id, const char *what,
                              qmc_points_transport transport);

/*
 * Sets up b for a request: transport (QMC_TRANSPORT_SHM needs a ring),
 * chunk size (a chunk never exceeds QMC_PROTO_CHUNK_BYTES, the client's
 * max_frame or a ring slot, and holds at least one point).  On a refusal
 * answers ERROR for request_id, naming `what` ("POINTS", "PIXELS") and the
 * point ("point", "sample"), and returns -1; else 0.
 */
int qmcd_bulk_init(qmcd_conn *c, qmcd_bulk *b, uint64_t request_id, const char *what,
                   const char *point, qmc_points_transport transport, size_t row_bytes,
                   size_t value_bytes, uint64_t first, uint64_t count, int64_t t0_us);

/* One frame: the next chunk, or END (and with end_follows, the last
 * chunk and END).  Returns a QMCD_PUMP_* status: SENT (| FLUSH for ring
 * chunks worth sending now), DONE after END (| FLUSH likewise), NO_ROOM,
 * WAIT (every ring slot held), FAILED after an ERROR or when the
 * connection closed. */
int qmcd_bulk_pump(qmcd_conn *c, qmcd_bulk *b);

/* QMCD_WAIT_RING while the stream's next chunk waits for a slot, else
 * QMCD_WAIT_NONE. */
qmcd_wait qmcd_bulk_waiting(const qmcd_conn *c, const qmcd_bulk *b);

/* The kinds' shutdown: a stream has no early end a client could wait
 * for, so at the drain deadline its connection is cut (returns 1). */
int qmcd_bulk_shutdown(qmcd_conn *c, qmcd_producer *p);

#endif
