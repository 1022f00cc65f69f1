/*
 * dispatch.h - one decoded request in, its answer (or the start of it) out.
 */
#ifndef QMCD_DISPATCH_H
#define QMCD_DISPATCH_H

#include "conn.h"

/* Handles one decoded frame through the dispatch table (srv->routes);
 * t0_us is when it was decoded (latency).  fd is a descriptor that arrived
 * with the frame (only a QMCD_ROUTE_FD type may carry one), or -1;
 * dispatch always takes it: its handler keeps it or it is closed. */
void qmcd_dispatch(qmcd_conn *c, const qmc_msg *m, int fd, int64_t t0_us);

#endif
