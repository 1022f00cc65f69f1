/*
 * modules.h - the daemon's request modules, one line each: every message
 * type a client may send is routed by the rows these export (producer.h,
 * qmcd_module).  A new producer kind adds its line here and nothing to
 * conn.c or dispatch.c.
 */
#ifndef QMCD_MODULES_H
#define QMCD_MODULES_H

#include "producer.h"

#define QMCD_MODULES(X)                                                               \
    X(qmcd_status_module) /* status.c: PING, STATS */                                 \
    X(qmcd_auth_module)   /* auth.c: HELLO, AUTH_RESPONSE (the handshake) */          \
    X(qmcd_shm_module)    /* shm.c: SHM_ATTACH, SHM_RELEASE (the client's ring) */    \
    X(qmcd_points_module) /* points.c: POINTS streams */                              \
    X(qmcd_jobs_module)   /* jobs.c: INTEGRATE jobs, JOB_STATUS, JOB_CANCEL */        \
    X(qmcd_session_module) /* session*.c: integration sessions (PROTOCOL.md 6.21) */ \
    X(qmcd_pixels_module) /* pixels.c: PIXELS tiles */

#define QMCD__MODULE_DECLARE(m) extern const qmcd_module m;
QMCD_MODULES(QMCD__MODULE_DECLARE)
#undef QMCD__MODULE_DECLARE

/* Fills srv's dispatch table with every module's rows and opens the
 * modules in order.  On error (two modules claiming one type, an open that
 * fails) closes what it opened, writes one line into why and returns -1. */
int qmcd_modules_open(qmcd_server *srv, char *why, size_t why_bytes);
/* Closes the opened modules in reverse order (after the connections). */
void qmcd_modules_close(qmcd_server *srv);

#endif
