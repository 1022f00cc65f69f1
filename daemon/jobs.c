/*
 * jobs.c - INTEGRATE jobs: requests, cancellation, time limits, progress
 * and answers, on the fair worker pool of pool.c.
 *
 * The loop thread validates a request (qmc_job_new builds the integrand
 * exactly as the CLI does), answers JOB_ACCEPTED at once and submits the
 * job under its connection's tenant.  A runner thread runs qmc_job_run
 * with our block runner, which hands the blocks to the pool; blocks are
 * independent and qmc_sampling_finish combines them in block order, so the
 * numbers are bit-identical to the CLI's whatever thread ran which block.
 *
 * Cancellation is cooperative: before every block the pool asks the job's
 * cancel flag (set by JOB_CANCEL, the connection closing, shutdown) and its
 * time limit, and the batch returns -ECANCELED.  Methods that run no blocks
 * (tensor rules and their Gauss-Legendre nodes, Gauss-Kronrod, cubature)
 * poll the same check through the spec's interrupt hook about every
 * QMC_INTERRUPT_EVALS evaluations and stop with QMC_ECANCELED (the hook is
 * also where they hand their slot to other connections' work); either way
 * the answer follows from the cancel flag, never from a partial result.
 *
 * Finished jobs come back through the pool's done list and eventfd; the
 * loop then answers JOB_RESULT or ERROR, tagged with the INTEGRATE's
 * request id.  Runner threads never touch connections, sockets or the
 * loop's state; the loop never runs blocks.
 *
 * On its connection a job is a producer (producer.h): it waits on its
 * worker (QMCD_WAIT_WORK), and its pump answers once the worker is done.
 * INTEGRATE, JOB_STATUS and JOB_CANCEL reach it through the rows of
 * qmcd_jobs_module; the connection only through conn_services.h.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <math.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <unistd.h>

#include "conn_services.h"
#include "log.h"
#include "loop.h"
#include "modules.h"
#include "peers.h"
#include "pool.h"
#include "result_msg.h"

enum { CANCEL_NONE = 0, CANCEL_CLIENT, CANCEL_TIMEOUT, CANCEL_SHUTDOWN, CANCEL_GONE };

typedef struct job {
    qmcd_pool_task task;         /* first: the pool hands &job->task back */
    qmcd_producer p;             /* loop: one producer of its connection until
                                    answered (producer.h) */
    qmcd_conn *conn;             /* loop: NULL once the connection is gone */
    qmcd_peer_key peer;          /* whose max-jobs-per-peer share it is in */
    uint64_t id;
    uint32_t progress_ms;
    int64_t t0_us;               /* request decoded (latency) */
    int64_t last_progress_ms;
    uint64_t time_limit_ms;
    qmc_job *job;
    qmc_integrate_spec spec;
    atomic_int state;            /* QMC_JOB_QUEUED .. */
    atomic_int cancel;           /* CANCEL_* */
    atomic_uint_fast64_t evals;
    atomic_llong start_ms;       /* 0 until a worker starts it */
    unsigned polls;              /* the job's worker: interrupt hook calls */
    /* Written by the worker before it posts the job, read by the loop
     * after (the pool mutex orders the two). */
    int err;
    char why[256];
    qmc_integrate_report rep;
    double seconds;
    double reference;            /* qmc_job_reference, taken on the worker */
    int reference_kind;          /* 0 none, 1 exact, 2 high-accuracy */
    int finished;                /* loop: the worker is done with it */
} job;

/* The job whose producer p is. */
#define JOB_OF(prod) ((job *)(void *)((char *)(prod) - offsetof(job, p)))

static const qmcd_producer_kind job_kind;
static void job_done(qmcd_server *srv, qmcd_pool_task *task);

/* ---- the block runner (worker threads) ------------------------------------------ */

static int64_t wall_ms(void)
{
    return qmcd_now_ms();
}

/* 1 when the job must stop: cancelled, or past its time limit (which we
 * turn into a cancel so every thread of the job sees it). */
static int must_stop(job *j)
{
    if (atomic_load(&j->cancel) != CANCEL_NONE)
        return 1;
    long long start = atomic_load(&j->start_ms);
    if (start && wall_ms() - start >= (int64_t)j->time_limit_ms) {
        int none = CANCEL_NONE;
        atomic_compare_exchange_strong(&j->cancel, &none, CANCEL_TIMEOUT);
        return 1;
    }
    return 0;
}

/* How often the interrupt hook reads the clock.  The hook runs every
 * QMC_INTERRUPT_EVALS evaluations or so (tens of microseconds apart for the
 * cheapest integrands, a few hundred for Gauss-Legendre nodes at the
 * largest n), the flag is one atomic load, and the loop's tick (every
 * QMCD_TICK_MS) turns a passed time limit into a cancel anyway; so a clock
 * read every 16th call costs nothing measurable and still catches the
 * limit within a few milliseconds of work. */
enum { POLL_CLOCK_EVERY = 16 };

/* The interrupt hook qmc_integrate polls (spec.interrupt), on the job's own
 * worker thread only: the cancel flag on every call, the time limit on
 * every POLL_CLOCK_EVERY-th. */
static int job_interrupt(void *ctx)
{
    job *j = ctx;
    if (atomic_load(&j->cancel) != CANCEL_NONE)
        return 1;
    if (++j->polls % POLL_CLOCK_EVERY != 0)
        return 0;
    if (must_stop(j))
        return 1;
    qmcd_pool_yield(&j->task); /* other connections' work may want the slot */
    return 0;
}

static int stop_cb(void *ctx)
{
    return must_stop(ctx);
}

/* Pool mutex held: only atomics. */
static int task_must_stop(qmcd_pool_task *task)
{
    return atomic_load(&((job *)task)->cancel) != CANCEL_NONE;
}

static int run_blocks(void *ctx, const qmc_sampling_job *sj, uint64_t first, uint64_t count,
                      qmc_sampling_sums *out)
{
    job *j = ctx;
    return qmcd_pool_run_blocks(&j->task, sj, first, count, out, stop_cb, j, &j->evals);
}

/* ---- on a runner --------------------------------------------------------------------- */

static double seconds_since(int64_t start_ms)
{
    return start_ms ? (double)(wall_ms() - start_ms) / 1000.0 : 0.0;
}

static void run_job(qmcd_pool_task *task)
{
    job *j = (job *)task;
    atomic_store(&j->start_ms, (long long)wall_ms());
    if (must_stop(j)) {
        j->err = -ECANCELED;
    } else {
        atomic_store(&j->state, QMC_JOB_RUNNING);
        j->err = qmc_job_run(j->job, &j->spec, run_blocks, j, &j->rep, j->why, sizeof j->why);
        /* A scene's reference is a quadrature of its own: here, on the
         * worker, never on the loop thread that answers. */
        int exact = 0;
        if (!j->err && qmc_job_reference(j->job, &j->reference, &exact) == 0)
            j->reference_kind = exact ? 1 : 2;
    }
    j->seconds = seconds_since(atomic_load(&j->start_ms));
    int cancel = atomic_load(&j->cancel);
    /* Finished past the limit between two checks (the hook reads the clock
     * every POLL_CLOCK_EVERY calls): it still timed out. */
    if (cancel == CANCEL_NONE && (int64_t)(j->seconds * 1000) >= (int64_t)j->time_limit_ms)
        cancel = CANCEL_TIMEOUT;
    if (cancel != CANCEL_NONE) {
        atomic_store(&j->cancel, cancel);
        atomic_store(&j->state, QMC_JOB_CANCELLED);
    } else {
        atomic_store(&j->state, j->err ? QMC_JOB_FAILED : QMC_JOB_DONE);
    }
}

/* ---- loop side --------------------------------------------------------------------- */

static void job_free(job *j)
{
    qmc_job_free(j->job);
    free(j);
}

static void task_free(qmcd_pool_task *task)
{
    job_free((job *)task);
}

/* c's unanswered job with job id `id`, or NULL. */
static job *find_job(qmcd_conn *c, uint64_t id)
{
    for (qmcd_producer *p = qmcd_producer_first(c); p; p = p->next)
        if (p->kind == &job_kind && JOB_OF(p)->id == id)
            return JOB_OF(p);
    return NULL;
}

/* Detaches j from its connection unanswered: a running job is told to
 * stop and freed by on_done, a finished one now. */
static void detach(job *j)
{
    if (j->finished) {
        job_free(j);
        return;
    }
    int none = CANCEL_NONE;
    atomic_compare_exchange_strong(&j->cancel, &none, CANCEL_GONE);
    j->conn = NULL;
}

/* Copies a decoded list (raw little-endian bytes) into doubles. */
static double *copy_list(const qmc_f64s *l)
{
    double *v = malloc((l->count ? l->count : 1) * sizeof *v);
    for (uint32_t i = 0; v && i < l->count; i++)
        v[i] = qmc_proto_f64_at(l, i);
    return v;
}

/* INTEGRATE: validates the job, answers JOB_ACCEPTED and submits it, or
 * answers ERROR. */
static void on_integrate(qmcd_conn *c, const qmc_msg *m, int fd, int64_t t0_us)
{
    (void)fd;
    qmcd_server *srv = qmcd_conn_server(c);
    const qmc_msg_integrate *g = &m->u.integrate;
    if (qmcd_producer_count(c, &job_kind) >= srv->cfg.max_jobs_per_conn) {
        srv->stats.jobs_conn_refusals++;
        qmcd_conn_error(c, m->request_id, QMC_ETOOBIG,
                        "max-jobs-per-conn: %llu jobs already open on this connection",
                        (unsigned long long)srv->cfg.max_jobs_per_conn);
        return;
    }
    /* A peer's share before the server's: the peer at fault is the one
     * named, and one peer flooding leaves room for everyone else. */
    const qmcd_peer_key *peer = qmcd_conn_peer(c);
    const uint64_t share = qmcd_peer_share(srv->cfg.max_jobs_per_peer, srv->cfg.max_jobs);
    if (qmcd_peers_count(srv->peer_jobs, peer) >= share) {
        char who[64];
        qmcd_peer_key_name(peer, who, sizeof who);
        srv->stats.jobs_peer_refusals++;
        qmcd_conn_error(c, m->request_id, QMC_ETOOBIG,
                        "max-jobs-per-peer: %llu jobs already open for %s, on all its "
                        "connections; try later", (unsigned long long)share, who);
        return;
    }
    if (srv->n_jobs >= srv->cfg.max_jobs) {
        srv->stats.jobs_refusals++;
        qmcd_conn_error(c, m->request_id, QMC_ETOOBIG,
                        "max-jobs: %llu jobs already open on this server; try later",
                        (unsigned long long)srv->cfg.max_jobs);
        return;
    }
    qmcd_pool_tenant *tenant;
    if (qmcd_conn_tenant(c, &tenant) != 0) {
        qmcd_conn_error(c, m->request_id, QMC_ENOMEM, "out of memory");
        return;
    }
    qmc_job_spec spec = g->spec;
    double *a = g->a.count ? copy_list(&g->a) : NULL;
    double *u = g->u.count ? copy_list(&g->u) : NULL;
    job *j = calloc(1, sizeof *j);
    char why[256] = "";
    int err = (g->a.count && !a) || (g->u.count && !u) || !j ? QMC_ENOMEM : 0;
    if (!err) {
        spec.a = a;
        spec.n_a = g->a.count;
        spec.u = u;
        spec.n_u = g->u.count;
        spec.scene_text = g->scene.len ? g->scene.ptr : NULL;
        spec.scene_len = g->scene.len;
        err = qmc_job_new(&spec, &j->job, why, sizeof why);
    }
    free(a);
    free(u);
    if (err) {
        free(j);
        qmcd_conn_error(c, m->request_id, err, "%s", why[0] ? why : qmc_strerror(err));
        return;
    }
    j->conn = c;
    j->task.run = run_job;
    j->task.free_fn = task_free;
    j->task.must_stop = task_must_stop;
    j->task.done = job_done;
    j->id = ++srv->next_job_id;
    j->progress_ms = g->progress_ms;
    j->t0_us = t0_us;
    j->last_progress_ms = qmcd_now_ms();
    j->time_limit_ms = srv->cfg.job_time_limit_ms;
    j->spec = g->spec.integrate;
    j->spec.interrupt.fn = job_interrupt;
    j->spec.interrupt.ctx = j;
    /* A client states its own budget and cubature memory; the daemon's
     * limits cap both (the time limit and cancels stop every method; the
     * budget bounds what a job may cost at all). */
    if (j->spec.max_evals > srv->cfg.max_job_evals)
        j->spec.max_evals = srv->cfg.max_job_evals;
    if (j->spec.max_memory > srv->cfg.max_job_memory)
        j->spec.max_memory = srv->cfg.max_job_memory;
    /* max-jobs-memory-total: the job reserves its bound before it runs
     * (pool.c); one that could never fit is told so now, not queued. */
    j->task.mem_bytes = qmc_integrate_memory_bytes_for(&j->spec, qmc_job_integrand(j->job),
                                                       qmc_job_control(j->job));
    if (j->task.mem_bytes > srv->cfg.max_jobs_memory_total) {
        srv->stats.memory_refusals++;
        qmcd_conn_error(c, m->request_id, QMC_ETOOBIG,
                        "max-jobs-memory-total: this job may need %llu bytes, more than the "
                        "%llu all running jobs may hold; lower its max_memory or max_evals",
                        (unsigned long long)j->task.mem_bytes,
                        (unsigned long long)srv->cfg.max_jobs_memory_total);
        job_free(j);
        return;
    }
    atomic_init(&j->state, QMC_JOB_QUEUED);
    atomic_init(&j->cancel, CANCEL_NONE);
    atomic_init(&j->evals, 0);
    atomic_init(&j->start_ms, 0);
    j->peer = *peer;
    if (qmcd_peers_add(srv->peer_jobs, &j->peer) != 0) {
        job_free(j);
        qmcd_conn_error(c, m->request_id, QMC_ENOMEM, "out of memory");
        return;
    }
    qmc_msg r = {.type = QMC_MSG_JOB_ACCEPTED, .request_id = m->request_id};
    r.u.job.job_id = j->id;
    if (qmcd_conn_send(c, &r) != 0) {
        qmcd_peers_remove(srv->peer_jobs, &j->peer);
        job_free(j);
        return;
    }
    qmcd_producer_attach(c, &j->p, &job_kind, m->request_id);
    srv->n_jobs++;
    srv->stats.jobs_accepted++;
    qmcd_debug("conn %llu: job %llu accepted (%s, %u dims)",
               (unsigned long long)qmcd_conn_id(c), (unsigned long long)j->id,
               qmc_method_name(j->spec.method), g->spec.dims);
    qmcd_pool_submit(srv->pool, tenant, &j->task);
}

static void job_state_msg(const job *j, uint64_t request_id, qmc_msg *r)
{
    memset(r, 0, sizeof *r);
    r->type = QMC_MSG_JOB_STATE;
    r->request_id = request_id;
    r->u.state.job_id = j->id;
    r->u.state.state = (qmc_job_state)atomic_load(&j->state);
    r->u.state.evals = atomic_load(&j->evals);
    r->u.state.seconds = j->finished ? j->seconds : seconds_since(atomic_load(&j->start_ms));
}

static void send_unknown(qmcd_conn *c, const qmc_msg *m)
{
    qmc_msg r = {.type = QMC_MSG_JOB_STATE, .request_id = m->request_id};
    r.u.state.job_id = m->u.job.job_id;
    r.u.state.state = QMC_JOB_UNKNOWN;
    qmcd_conn_send(c, &r);
}

static void on_status(qmcd_conn *c, const qmc_msg *m, int fd, int64_t t0_us)
{
    (void)fd;
    job *j = find_job(c, m->u.job.job_id);
    if (!j) {
        send_unknown(c, m);
    } else {
        qmc_msg r;
        job_state_msg(j, m->request_id, &r);
        qmcd_conn_send(c, &r);
    }
    qmcd_answered(qmcd_conn_server(c), t0_us);
}

static void on_cancel(qmcd_conn *c, const qmc_msg *m, int fd, int64_t t0_us)
{
    (void)fd;
    qmcd_server *srv = qmcd_conn_server(c);
    if (!qmcd_producer_cancel_allowed(c)) {
        srv->stats.cancel_refusals++;
        qmcd_conn_error(c, m->request_id, QMC_ETOOBIG,
                        "max-cancels-per-conn: more than %llu JOB_CANCEL a minute on this "
                        "connection; cancel less often",
                        (unsigned long long)srv->cfg.max_cancels_per_conn);
        qmcd_answered(srv, t0_us);
        return;
    }
    job *j = find_job(c, m->u.job.job_id);
    if (!j) {
        send_unknown(c, m);
    } else {
        qmc_msg r;
        int none = CANCEL_NONE;
        if (!j->finished && atomic_compare_exchange_strong(&j->cancel, &none, CANCEL_CLIENT)) {
            /* The worker sees the flag before its next block or at its
             * method's next interrupt poll; the INTEGRATE itself is
             * answered ERROR ECANCELED when it stops. */
            job_state_msg(j, m->request_id, &r);
            r.u.state.state = QMC_JOB_CANCELLED;
            if (atomic_load(&j->start_ms) == 0)
                qmcd_pool_cancelled(srv->pool); /* queued: start it to answer */
        } else {
            job_state_msg(j, m->request_id, &r);
        }
        qmcd_conn_send(c, &r);
    }
    qmcd_answered(srv, t0_us);
}

/* Queues the final answer of a finished job.  Returns 0, or -1 without
 * room (the pump retries). */
static int answer(qmcd_conn *c, job *j)
{
    if (qmcd_conn_out_room(c) < QMCD_OUT_RESERVE / 2)
        return -1;
    qmcd_server *srv = qmcd_conn_server(c);
    int cancel = atomic_load(&j->cancel);
    int rc;
    if (cancel == CANCEL_TIMEOUT) {
        /* A failure like any other (jobs_failed), counted apart too. */
        srv->stats.jobs_timed_out++;
        srv->stats.jobs_failed++;
        rc = qmcd_conn_error(c, j->p.request_id, -ETIMEDOUT,
                             "job-time-limit-ms: job %llu ran past %llu ms and was cancelled",
                             (unsigned long long)j->id, (unsigned long long)j->time_limit_ms);
    } else if (cancel == CANCEL_CLIENT) {
        srv->stats.jobs_cancelled++;
        rc = qmcd_conn_error(c, j->p.request_id, -ECANCELED, "job %llu cancelled by JOB_CANCEL",
                             (unsigned long long)j->id);
    } else if (cancel != CANCEL_NONE) {
        srv->stats.jobs_cancelled++;
        rc = qmcd_conn_error(c, j->p.request_id, -ESHUTDOWN,
                             "job %llu cancelled: the server is shutting down",
                             (unsigned long long)j->id);
    } else if (j->err) {
        srv->stats.jobs_failed++;
        rc = qmcd_conn_error(c, j->p.request_id, j->err, "%s",
                             j->why[0] ? j->why : qmc_strerror(j->err));
    } else {
        srv->stats.jobs_done++;
        qmc_msg r = {.type = QMC_MSG_JOB_RESULT, .request_id = j->p.request_id};
        qmc_msg_job_result *res = &r.u.result;
        qmcd_result_of(res, j->id, &j->rep);
        res->seconds = j->seconds;
        res->reference_kind = j->reference_kind;
        res->reference = j->reference_kind ? j->reference : 0;
        /* Version 6 tells the integral of |f| the integrand knows, which
         * `qmc integrate --json` judges errors against (none can be
         * negative or infinite; the codec refuses those). */
        const qmc_integrand *f = qmc_job_integrand(j->job);
        res->has_known_abs = f->has_abs_integral && isfinite(f->abs_integral) &&
                             f->abs_integral >= 0;
        res->known_abs = res->has_known_abs ? f->abs_integral : 0;
        rc = qmcd_conn_send(c, &r);
    }
    if (rc == 0)
        qmcd_answered(srv, j->t0_us);
    return 0; /* sent, or the connection is gone: either way it is done */
}

/* The producer's pump: the final answer once the worker is done. */
static int job_pump(qmcd_conn *c, qmcd_producer *p)
{
    job *j = JOB_OF(p);
    if (!j->finished)
        return QMCD_PUMP_WAIT; /* on_done kicks the connection */
    if (answer(c, j) != 0)
        return QMCD_PUMP_NO_ROOM;
    return QMCD_PUMP_DONE; /* sent, or the connection is gone */
}

static qmcd_wait job_waiting(const qmcd_conn *c, const qmcd_producer *p)
{
    (void)c;
    return JOB_OF(p)->finished ? QMCD_WAIT_NONE : QMCD_WAIT_WORK;
}

/* A finished job, back on the loop (its task's done callback). */
static void job_done(qmcd_server *srv, qmcd_pool_task *task)
{
    job *j = (job *)task;
    j->finished = 1;
    srv->n_jobs--;
    qmcd_peers_remove(srv->peer_jobs, &j->peer);
    qmcd_debug("job %llu finished: %s in %.3f s", (unsigned long long)j->id,
               qmc_job_state_name((qmc_job_state)atomic_load(&j->state)), j->seconds);
    if (!j->conn) {
        job_free(j); /* its connection is gone */
        return;
    }
    qmcd_conn_kick(j->conn); /* the pump answers it */
}

/* The pool's eventfd watch: finished tasks - jobs, session steps - come
 * back to the loop here, each to its own done callback. */
static void on_done(qmcd_server *srv, qmcd_watch *w, uint32_t events)
{
    (void)events;
    uint64_t n;
    if (read(w->fd, &n, sizeof n) < 0 && errno != EAGAIN)
        qmcd_warn("eventfd read: %s", strerror(errno));
    qmcd_pool_task *done = qmcd_pool_take_done(srv->pool);
    while (done) {
        qmcd_pool_task *task = done;
        done = done->next;
        task->done(srv, task);
    }
}

/* Per tick: the time limit, and JOB_PROGRESS. */
static void job_tick(qmcd_conn *c, qmcd_producer *p, int64_t now)
{
    job *j = JOB_OF(p);
    if (j->finished)
        return;
    long long start = atomic_load(&j->start_ms);
    if (start && now - start >= (int64_t)j->time_limit_ms) {
        int none = CANCEL_NONE;
        atomic_compare_exchange_strong(&j->cancel, &none, CANCEL_TIMEOUT);
    }
    if (j->progress_ms && start && atomic_load(&j->cancel) == CANCEL_NONE &&
        now - j->last_progress_ms >= (int64_t)j->progress_ms &&
        qmcd_conn_out_room(c) >= QMCD_OUT_RESERVE) {
        /* Advisory: skipped rather than queued when output is short. */
        qmc_msg r = {.type = QMC_MSG_JOB_PROGRESS, .request_id = j->p.request_id};
        r.u.progress.job_id = j->id;
        r.u.progress.evals = atomic_load(&j->evals);
        r.u.progress.seconds = (double)(now - start) / 1000.0;
        j->last_progress_ms = now;
        (void)qmcd_conn_send(c, &r);
    }
}

/* The shutdown deadline: the job is cancelled, and its client still gets
 * the ERROR when it stops. */
static int job_shutdown(qmcd_conn *c, qmcd_producer *p)
{
    job *j = JOB_OF(p);
    int none = CANCEL_NONE;
    atomic_compare_exchange_strong(&j->cancel, &none, CANCEL_SHUTDOWN);
    qmcd_pool_cancelled(qmcd_conn_server(c)->pool); /* a queued one starts, to answer */
    return 0;
}

static void job_release(qmcd_conn *c, qmcd_producer *p, qmcd_end why)
{
    job *j = JOB_OF(p);
    qmcd_server *srv = qmcd_conn_server(c);
    int queued;
    switch (why) {
    case QMCD_END_DONE:
    case QMCD_END_FAILED:
        job_free(j); /* answered */
        return;
    case QMCD_END_ENDED:
        /* Its id was reused: the ERROR that says so ends it. */
        srv->stats.jobs_cancelled++;
        detach(j);
        return;
    case QMCD_END_DROPPED:
        /* Accepted and never answered: neither done, failed nor cancelled,
         * so STATS counts it here (jobs_accepted = done + failed +
         * cancelled + dropped once none is open). */
        srv->stats.jobs_dropped++;
        queued = !j->finished && atomic_load(&j->start_ms) == 0;
        detach(j);
        if (queued)
            qmcd_pool_cancelled(srv->pool); /* let it end now, not in turn */
        return;
    }
}

static const qmcd_producer_kind job_kind = {
    .name = "job",
    .pump = job_pump,
    .waiting = job_waiting,
    .tick = job_tick,
    .shutdown = job_shutdown,
    .release = job_release,
};

/* The pool's finished jobs come back through its eventfd, on the loop;
 * the jobs open by peer are counted from here on. */
static int jobs_open(qmcd_server *srv)
{
    if (qmcd_peers_new(&srv->peer_jobs) != 0)
        return -ENOMEM;
    srv->done.fd = qmcd_pool_eventfd(srv->pool);
    srv->done.on_event = on_done;
    int err = qmcd_loop_add(srv, &srv->done, EPOLLIN);
    if (err) {
        qmcd_peers_free(srv->peer_jobs);
        srv->peer_jobs = NULL;
    }
    return err;
}

static void jobs_close(qmcd_server *srv)
{
    qmcd_peers_free(srv->peer_jobs);
    srv->peer_jobs = NULL;
}

const qmcd_module qmcd_jobs_module = {
    .name = "jobs",
    .routes = (const qmcd_route[]){
        {QMC_MSG_INTEGRATE, QMCD_ROUTE_REQUEST | QMCD_ROUTE_STARTS, on_integrate},
        {QMC_MSG_JOB_STATUS, QMCD_ROUTE_REQUEST, on_status},
        {QMC_MSG_JOB_CANCEL, QMCD_ROUTE_REQUEST, on_cancel},
        {0, 0, NULL},
    },
    .open = jobs_open,
    .close = jobs_close,
};
