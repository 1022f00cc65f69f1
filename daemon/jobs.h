/*
 * jobs.h - INTEGRATE jobs on the worker pool: submission, the block
 * runner, cancellation, time limits, progress, and the answers.
 */
#ifndef QMCD_JOBS_H
#define QMCD_JOBS_H

#include <stdint.h>

#include "conn_services.h"
#include "pool.h"
#include "qmc/proto.h"

/* The pool itself (qmcd_pool_new, _eventfd, _free) is pool.h's. */
/* Request handlers. */
void qmcd_jobs_integrate(qmcd_conn *c, const qmc_msg *m, int64_t t0_us);
void qmcd_jobs_status(qmcd_conn *c, const qmc_msg *m, int64_t t0_us);
void qmcd_jobs_cancel(qmcd_conn *c, const qmc_msg *m, int64_t t0_us);

/* The eventfd watch: finished jobs come back to the loop here. */
void qmcd_jobs_on_done(qmcd_server *srv, qmcd_watch *w, uint32_t events);

#endif
