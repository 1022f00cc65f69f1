/*
 * session_step.c - moving a session's integrator on (session.h): the
 * opening (qmc_session_new runs the integrator to its first batch) and
 * each step after a batch's values are in (qmc_session_tell runs it to
 * the next batch or to its end).
 *
 * The integrator runs on the session's fiber (core/fiber.c), so a step may
 * run on any thread: the opening always on the worker pool (it may set up
 * a method's tables, or a sequence of thousands of dimensions), a step on
 * the pool too unless the session's last step took under INLINE_STEP_US
 * of CPU time, when it runs at once on the loop thread, reading its values
 * where they arrived - a round trip through the pool (four thread
 * wake-ups: runner, worker slot, runner, loop) would cost more than such a
 * step, and the loop stays responsive because only cheap steps run there,
 * each measured again.  CPU time, not wall time: on a loaded machine a
 * step preempted halfway would otherwise look expensive and move to the
 * pool, where it is slower still.  Between steps a session holds no
 * thread.
 *
 * The opening task reserves the session's memory against
 * max-jobs-memory-total as a job does (it waits for it in the pool's
 * turn), and keeps it after its run for the session's life
 * (qmcd_pool_memory_keep).  The interrupt hook stops a step that runs past
 * job-time-limit-ms or whose session is being closed or shut down, and
 * hands the pool slot to other tenants' work (qmcd_pool_yield), as a job's
 * hook does.
 *
 * Must not: touch a connection or send anything (session.c answers when
 * the step is back: the pool hands the task to its done callback, which
 * session.c sets), call into session.c, or read the configuration from a
 * worker (what a step needs is copied into the session on the loop).
 */
#define _GNU_SOURCE
#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

#include "log.h"
#include "session.h"

/* A step under this much CPU time (measured on the last one) runs on the
 * loop thread: a 65536-point sampling batch in 4 dimensions takes about
 * 0.9 ms (bench_session_wire), which still lets the loop answer others
 * within a few milliseconds. */
#define INLINE_STEP_US 20000
/* The hook reads the clock (and offers the pool slot) every so many
 * calls: as jobs.c does, a few milliseconds of work apart at most. */
#define POLL_CLOCK_EVERY 16

/* The calling thread's CPU time, in microseconds. */
static int64_t cpu_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return (int64_t)ts.tv_sec * 1000000 + ts.tv_nsec / 1000;
}

/* The interrupt hook of the session's integrator (spec.integrate.interrupt),
 * polled about every QMC_INTERRUPT_EVALS evaluations while a step runs. */
static int sess_interrupt(void *ctx)
{
    qmcd_sess *s = ctx;
    if (atomic_load(&s->cancel) != SESS_GO)
        return 1;
    if (++s->polls % POLL_CLOCK_EVERY != 0)
        return 0;
    if (qmcd_now_ms() - s->step_start_ms >= s->step_limit_ms) {
        int go = SESS_GO;
        atomic_compare_exchange_strong(&s->cancel, &go, SESS_CANCEL_TIMEOUT);
        return 1;
    }
    if (s->on_pool)
        qmcd_pool_yield(&s->task); /* other connections' work may want the slot */
    return 0;
}

/* One step, on whichever thread runs it; values: the batch's values
 * (s->vals, or where they arrived for a step run at once); next, when not
 * NULL, where the next batch of whole blocks is to be assembled (a ring
 * slot: qmc_session_tell_to), room for next_points points.  Told whole,
 * not ahead (qmc_session_tell_ahead): the report that follows must take
 * this batch in (PROTOCOL.md 6.21; docs/SESSIONS.md says what telling
 * ahead would need). */
static void step(qmcd_sess *s, const double *values, double *next, size_t next_points)
{
    const int64_t t0 = qmcd_now_us(), c0 = cpu_us();
    s->polls = 0;
    s->step_start_ms = t0 / 1000;
    if (s->opening) {
        s->spec.integrate.interrupt.fn = sess_interrupt;
        s->spec.integrate.interrupt.ctx = s;
        s->err = atomic_load(&s->cancel) != SESS_GO
                     ? -ECANCELED
                     : qmc_session_new(&s->spec, &s->core, s->why, sizeof s->why);
    } else {
        s->err = next ? qmc_session_tell_to(s->core, s->batch.seq, values, s->batch.count,
                                            next, next_points, s->why, sizeof s->why)
                      : QMC_EINVAL;
        /* Without a buffer of its own to stand in for (a rule), or one too
         * small, the refusal took nothing: the session's own buffer then. */
        if (s->err == QMC_EINVAL)
            s->err = qmc_session_tell(s->core, s->batch.seq, values, s->batch.count, s->why,
                                      sizeof s->why);
    }
    s->last_step_us = cpu_us() - c0;
    s->compute_s += (double)(qmcd_now_us() - t0) / 1e6;
}

static void task_run(qmcd_pool_task *task)
{
    qmcd_sess *s = (qmcd_sess *)task;
    s->on_pool = 1;
    if (s->opening)
        s->pool_bytes = qmcd_pool_memory_keep(task); /* for the session's life */
    step(s, s->vals, NULL, 0);
    s->on_pool = 0;
}

/* Pool mutex held: only atomics. */
static int task_must_stop(qmcd_pool_task *task)
{
    return atomic_load(&((qmcd_sess *)task)->cancel) != SESS_GO;
}

/* At exit, back from the pool after the registry let go of it. */
static void task_free(qmcd_pool_task *task)
{
    qmcd__sessions_free((qmcd_sess *)task);
}

static void submit(qmcd_sess *s, qmcd_pool_tenant *tenant, uint64_t mem_bytes)
{
    s->task.run = task_run;
    s->task.must_stop = task_must_stop;
    s->task.free_fn = task_free; /* task.done is session.c's */
    s->task.mem_bytes = mem_bytes;
    s->stepping = 1;
    s->step_limit_ms = (int64_t)s->srv->cfg.job_time_limit_ms;
    qmcd_pool_submit(s->srv->pool, tenant, &s->task);
}

void qmcd__sess_start_open(qmcd_sess *s, qmcd_pool_tenant *tenant)
{
    s->opening = 1;
    submit(s, tenant, s->mem_bytes);
}

int qmcd__sess_tell_now(const qmcd_sess *s)
{
    return s->last_step_us >= 0 && s->last_step_us < INLINE_STEP_US;
}

int qmcd__sess_start_tell(qmcd_sess *s, qmcd_pool_tenant *tenant, const double *values,
                          double *next, size_t next_points)
{
    s->opening = 0;
    if (qmcd__sess_tell_now(s)) {
        s->stepping = 1;
        s->step_limit_ms = (int64_t)s->srv->cfg.job_time_limit_ms;
        step(s, values ? values : s->vals, next, next_points);
        return 1;
    }
    submit(s, tenant, 0);
    return 0;
}

void qmcd__sess_settle(qmcd_sess *s)
{
    s->have_batch = 0;
    s->sent = 0;
    s->got = 0;
    s->n_pieces = 0;
    if (!s->core) {
        s->finished = 1; /* the opening failed: its error is owed */
        return;
    }
    if (s->err) {
        /* tell refused what session.c checked already: a bug, said as such. */
        qmcd_err("session %llu: the integrator refused a batch the server accepted: %s",
                 (unsigned long long)s->id, s->why);
        s->finished = 1;
        return;
    }
    qmc_session_batch b;
    if (qmc_session_ask(s->core, &b) != 0)
        b.count = 0; /* only for NULL arguments */
    if (b.count == 0) {
        s->finished = 1;
        s->err = qmc_session_result(s->core, &s->rep, s->why, sizeof s->why);
        return;
    }
    if (b.count > s->max_batch) {
        qmcd_err("session %llu: a batch of %zu points, more than the %llu announced",
                 (unsigned long long)s->id, b.count, (unsigned long long)s->max_batch);
        s->finished = 1;
        s->err = QMC_ETOOBIG;
        snprintf(s->why, sizeof s->why, "the integrator asked for a batch of %zu points, more "
                 "than the %llu this session announced (a server bug)", b.count,
                 (unsigned long long)s->max_batch);
        return;
    }
    s->batch = b;
    s->have_batch = 1;
}
