/*
 * points.h - POINTS streams: validation, chunk generation under
 * backpressure (inline, or through a client's shared-memory ring), and the
 * cache of sequence instances they share.
 */
#ifndef QMCD_POINTS_H
#define QMCD_POINTS_H

#include <stdint.h>

#include "conn.h"
#include "qmc/proto.h"

/* Validates a POINTS request and starts its stream, or answers ERROR. */
void qmcd_points_start(qmcd_conn *c, const qmc_msg *m, int64_t t0_us);

/* Returned with 1 by qmcd_points_pump when the frame just queued is worth
 * sending at once (a POINTS_SHM_CHUNK: the client can start on its slot
 * while the next one is filled). */
#define QMCD_PUMP_FLUSH 2

/* Generates at most one chunk (or the END) for the first stream, in turn
 * order, that can go on: output room for its frame, and for a shm stream a
 * free slot.  Returns 1 (possibly | QMCD_PUMP_FLUSH) when it queued
 * something, 0 when there is nothing to do or no room. */
int qmcd_points_pump(qmcd_conn *c);

/* 1 when some stream waits only for output room (so EPOLLOUT matters), 0
 * when there are none or all wait for ring slots (SHM_RELEASE, on EPOLLIN). */
int qmcd_points_want_output(const qmcd_conn *c);

/* When the ring filled up while a shm stream still has points to send
 * (write-timeout-ms applies from then), or 0. */
int64_t qmcd_points_ring_stalled_ms(const qmcd_conn *c);

/* SHM_ATTACH: checks the client's memfd (fd: the descriptor that came with
 * the frame, or -1; always consumed), maps it as the connection's ring and
 * answers SHM_OK, or answers ERROR. */
void qmcd_points_shm_attach(qmcd_conn *c, const qmc_msg *m, int fd, int64_t t0_us);

/* SHM_RELEASE: frees the oldest slots the client holds.  A release of more
 * than it holds, without a ring, or with a request id is fatal. */
void qmcd_points_shm_release(qmcd_conn *c, const qmc_msg *m);

/* 1 when a stream of the connection answers request_id. */
int qmcd_points_has_request(const qmcd_conn *c, uint64_t request_id);
/* Stops the stream of request_id, if any, without END (the caller sends
 * the ERROR that ends it). */
void qmcd_points_end_request(qmcd_conn *c, uint64_t request_id);

/* Drops every stream of the connection and unmaps its ring (it is
 * closing). */
void qmcd_points_drop_all(qmcd_conn *c);

int qmcd_seqcache_new(qmcd_seqcache **out);
void qmcd_seqcache_free(qmcd_seqcache *cache);

#endif
