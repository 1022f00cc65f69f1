/*
 * points.h - POINTS streams: validation, chunk generation under
 * backpressure (inline, or through a client's shared-memory ring), and the
 * cache of sequence instances they share.
 */
#ifndef QMCD_POINTS_H
#define QMCD_POINTS_H

#include <stdint.h>

#include "conn_services.h"
#include "qmc/proto.h"

/* Validates a POINTS request and starts its stream, or answers ERROR. */
void qmcd_points_start(qmcd_conn *c, const qmc_msg *m, int64_t t0_us);

/* SHM_ATTACH: checks the client's memfd (fd: the descriptor that came with
 * the frame, or -1; always consumed), maps it as the connection's ring and
 * answers SHM_OK, or answers ERROR. */
void qmcd_points_shm_attach(qmcd_conn *c, const qmc_msg *m, int fd, int64_t t0_us);

/* SHM_RELEASE: frees the oldest slots the client holds.  A release of more
 * than it holds, without a ring, or with a request id is fatal. */
void qmcd_points_shm_release(qmcd_conn *c, const qmc_msg *m);

int qmcd_seqcache_new(qmcd_seqcache **out);
void qmcd_seqcache_free(qmcd_seqcache *cache);

#endif
