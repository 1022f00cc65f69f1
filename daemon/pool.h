/*
 * pool.h - the worker pool that runs INTEGRATE jobs and the compute steps
 * of integration sessions, shared fairly between connections ("tenants",
 * one a connection: conn_services.h); see pool.c.  jobs.c and
 * session_step.c submit to it; jobs.c watches its eventfd and hands every
 * finished task to its done callback.
 */
#ifndef QMCD_POOL_H
#define QMCD_POOL_H

#include <stdatomic.h>
#include <stdint.h>

#include "peers.h"
#include "qmc/sampling.h"
#include "server.h"

typedef struct qmcd_pool_tenant qmcd_pool_tenant;
typedef struct qmcd_pool_task qmcd_pool_task;

/* One job as the pool sees it, embedded in the caller's job.  The caller
 * sets run and free_fn; the rest is the pool's. */
struct qmcd_pool_task {
    void (*run)(qmcd_pool_task *task);      /* on a runner, holding a slot */
    void (*free_fn)(qmcd_pool_task *task);  /* pool_free: a done task left over */
    int (*must_stop)(qmcd_pool_task *task); /* cancelled: starts past the limits */
    /* Loop thread: the task came back from the done list (jobs.c's eventfd
     * watch calls it for every finished task, whoever submitted it). */
    void (*done)(qmcd_server *srv, qmcd_pool_task *task);
    qmcd_pool_task *next;                   /* pool mutex: queue or done list */
    qmcd_pool_tenant *tenant;
    qmcd_pool *pool;
    uint64_t mem_bytes;                     /* caller: what the job may allocate */
    int mem_held;                           /* pool mutex: memory held it back */
    uint64_t admitted;                      /* pool mutex: 1, 2, ... in order of start */
    int granted;                            /* pool mutex: a slot was handed over */
    int64_t slot_ms;                        /* runner: when it took its slot */
};

/* Starts `workers` compute slots (and their threads) plus the runner
 * threads that drive jobs.  Signals must already be blocked. */
int qmcd_pool_new(unsigned workers, qmcd_pool **out);
int qmcd_pool_eventfd(const qmcd_pool *pool);
/* Stops and joins the threads; with jobs still running at exit it leaves
 * them be and frees nothing they use. */
void qmcd_pool_free(qmcd_pool *pool, int jobs_running);

/* A connection's share of the pool, counted with the other connections of
 * its peer.  Loop thread.  The tenant lives until the connection released
 * it and its last task is done. */
int qmcd_pool_tenant_new(qmcd_pool *pool, const qmcd_peer_key *peer, qmcd_pool_tenant **out);
void qmcd_pool_tenant_release(qmcd_pool *pool, qmcd_pool_tenant *tenant);

/* Queues a task of the tenant.  Loop thread. */
void qmcd_pool_submit(qmcd_pool *pool, qmcd_pool_tenant *tenant, qmcd_pool_task *task);

/* Some queued task's must_stop turned true: a free runner starts it now,
 * past its tenant's limit, so that its answer does not wait.  Loop thread. */
void qmcd_pool_cancelled(qmcd_pool *pool);

/* max-jobs-memory-total: tasks on runners together reserve at most this
 * many bytes of mem_bytes (a task that alone exceeds it must be refused
 * before it is submitted).  Loop thread, at start and on SIGHUP. */
void qmcd_pool_set_memory_total(qmcd_pool *pool, uint64_t bytes);

/* job-memory-overtakes: how many tasks may start ahead of one that waits
 * for its memory (backfill) before admission drains for it; 0 keeps strict
 * turns (nothing passes a waiting task).  Loop thread, at start and on
 * SIGHUP. */
void qmcd_pool_set_overtakes(qmcd_pool *pool, unsigned overtakes);

/* Isolation counters, for STATS: tasks that waited for job memory, tasks
 * that started ahead of one waiting for memory (backfill), the bytes
 * reserved now by the tasks on runners, and whether a task waits now. */
typedef struct qmcd_pool_counts {
    uint64_t memory_waits;
    uint64_t memory_backfills;
    uint64_t memory_reserved;
    int memory_waiting;          /* a queued task waits for its memory now */
} qmcd_pool_counts;
void qmcd_pool_counts_get(qmcd_pool *pool, qmcd_pool_counts *out);

/* From a task's run: the memory it reserved (mem_bytes) stays reserved
 * when the task ends, for what outlives the run (an integration session's
 * state between its steps), until qmcd_pool_memory_release.  Returns the
 * bytes kept (0 for a task started past the limits, which reserved none). */
uint64_t qmcd_pool_memory_keep(qmcd_pool_task *task);

/* Gives back bytes a task kept (qmcd_pool_memory_keep).  Loop thread. */
void qmcd_pool_memory_release(qmcd_pool *pool, uint64_t bytes);

/* Takes the list of finished tasks (linked by next).  Loop thread. */
qmcd_pool_task *qmcd_pool_take_done(qmcd_pool *pool);

/* From a task's run: computes sampling blocks first .. first + count - 1
 * into out[0 .. count), spread over the slots in turn with every other
 * tenant's work.  stop(ctx) is asked before each block; once it says 1 the
 * rest is skipped and -ECANCELED returned.  Each block's evaluation count
 * is added to *evals.  Returns 0 or the first error. */
int qmcd_pool_run_blocks(qmcd_pool_task *task, const qmc_sampling_job *sj, uint64_t first,
                         uint64_t count, qmc_sampling_sums *out, int (*stop)(void *ctx),
                         void *ctx, atomic_uint_fast64_t *evals);

/* From a task's run, between two pieces of work that run no blocks: once
 * the task has held its slot for a quantum and other work waits for one,
 * hands the slot on and waits for its turn again. */
void qmcd_pool_yield(qmcd_pool_task *task);

#endif
