/*
 * dispatch.h - one decoded request in, its answer (or the start of it) out.
 */
#ifndef QMCD_DISPATCH_H
#define QMCD_DISPATCH_H

#include "conn.h"

/* Handles one decoded frame; t0_us is when it was decoded (latency).  fd
 * is a descriptor that arrived with the frame (only SHM_ATTACH carries
 * one), or -1; dispatch always takes it: the ring keeps it or it is
 * closed. */
void qmcd_dispatch(qmcd_conn *c, const qmc_msg *m, int fd, int64_t t0_us);

/* Ends the handshake: HELLO_OK with version and our limits, after HELLO
 * (no authentication required) or a good AUTH_RESPONSE (auth.c). */
void qmcd_dispatch_hello_ok(qmcd_conn *c, uint64_t request_id, uint16_t version,
                            uint32_t client_max_frame, int64_t t0_us);

#endif
