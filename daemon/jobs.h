/*
 * jobs.h - INTEGRATE jobs on the worker pool: submission, the block
 * runner, cancellation, time limits, progress, and the answers.
 */
#ifndef QMCD_JOBS_H
#define QMCD_JOBS_H

#include <stdint.h>

#include "conn.h"
#include "pool.h"
#include "qmc/proto.h"

/* The pool itself (qmcd_pool_new, _eventfd, _free) is pool.h's. */
/* Request handlers. */
void qmcd_jobs_integrate(qmcd_conn *c, const qmc_msg *m, int64_t t0_us);
void qmcd_jobs_status(qmcd_conn *c, const qmc_msg *m, int64_t t0_us);
void qmcd_jobs_cancel(qmcd_conn *c, const qmc_msg *m, int64_t t0_us);

/* 1 when an unanswered job of the connection came from request_id. */
int qmcd_jobs_has_request(const qmcd_conn *c, uint64_t request_id);
/* Ends the job of request_id, if any, without an answer (the caller sends
 * the ERROR that ends it): the job is cancelled and counted so. */
void qmcd_jobs_end_request(qmcd_conn *c, uint64_t request_id);

/* The eventfd watch: finished jobs come back to the loop here. */
void qmcd_jobs_on_done(qmcd_server *srv, qmcd_watch *w, uint32_t events);

/* Queues answers of finished jobs while there is room; returns 1 if it
 * queued anything. */
int qmcd_jobs_pump(qmcd_conn *c);
/* Per tick: time limits and JOB_PROGRESS. */
void qmcd_jobs_tick(qmcd_conn *c, int64_t now_ms);
/* The connection is closing: cancel its jobs and forget them (the pool
 * frees them when they stop). */
void qmcd_jobs_drop_all(qmcd_conn *c);
/* Shutdown deadline: cancel every job. */
void qmcd_jobs_cancel_all(qmcd_server *srv);

#endif
