/*
 * pool.c - the worker pool for INTEGRATE jobs, shared fairly between
 * connections, so that one client's endless jobs cannot starve another
 * client's small one.
 *
 * Compute is handed out in slots: `workers` of them, one per worker
 * thread, and a thread computes only while it holds one.  A slot goes to
 * the connections ("tenants") in turn, round robin, one piece of work at a
 * time: a sampling block (QMC_SAMPLING_BLOCK points) of one of the
 * tenant's open batches, or a quantum of a job that runs no blocks
 * (quadrature, cubature: the job's own thread computes, and hands its slot
 * on at the interrupt hook once it has held it for QUANTUM_MS and someone
 * waits).  Within a tenant, its batches take turns too.
 *
 * Jobs are driven by runner threads (twice the workers, at least workers
 * + RUNNERS_SPARE, so that several tenants can each fill the slots and a
 * newcomer still finds one free; not more, since each is a task under
 * the unit's TasksMax and each running job holds its memory): a
 * runner calls qmc_job_run, which hands its blocks to the pool through
 * qmcd_pool_run_blocks and waits for them without a slot.  A tenant may
 * have as many jobs on runners as there are workers (enough to fill every
 * slot by itself when alone); further jobs of it wait, and runners are
 * given to tenants in turn too, so a newcomer's job starts as soon as a
 * runner is free even while another tenant has a long queue.  The tenants
 * of one peer (one address, one uid: peers.h) hold at most all runners but
 * `workers`, so that a peer with many connections leaves runners free for
 * every other peer.
 *
 * Job memory: each task states what it may allocate (mem_bytes, from
 * qmc_integrate_memory_bytes_for) and reserves it when it takes a runner; the
 * reservations of the tasks on runners stay within mem_total
 * (max-jobs-memory-total).  An integration session's opening task keeps
 * its reservation past its run (qmcd_pool_memory_keep), for as long as
 * the session lives, so sessions and jobs share the one total.  The first task whose turn comes while its
 * memory does not fit becomes the waiter; it starts as soon as its memory
 * fits, before anyone else.  Meanwhile the tenants go on in turn with
 * their first queued task that does fit (backfill: a small job need not
 * wait behind a big one), but only max_overtakes of them
 * (job-memory-overtakes): then admission drains, nothing that reserves
 * memory starts until the waiter has, and the waiter starts once enough
 * running jobs have ended (each within the job time limit).  So a stream
 * of small jobs cannot starve a big one, and a big one delays the small
 * ones no more than it must.  The default of 8 overtakes is below the
 * smallest number of runners (workers + RUNNERS_SPARE >= 9), so the jobs
 * that overtake a waiter can all run at once: they delay its start by at
 * most the longest of them, not by a chain of them one after another.
 * Cancelled tasks start past all this: they allocate nothing.
 *
 * Determinism: a block's sums depend only on (job, block index) and are
 * written to out[i]; qmc_sampling_finish combines them in block order.  So
 * which thread ran which block, and in what order, never changes a bit of
 * the result; a job that runs no blocks runs wholly on its runner, only
 * paused at the hook.
 *
 * Threads never touch connections, sockets or the loop: finished tasks go
 * on a done list and the pool's eventfd wakes the loop.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include "log.h"
#include "pool.h"

/* How long a job that runs no blocks keeps its slot when others wait: a
 * few block times, so hand-overs cost nothing measurable. */
#define QUANTUM_MS 20
#define RUNNERS_SPARE 8
/* A worker keeps its block workspace between blocks (one allocation per
 * job, not per block), but not one this large while it idles. */
#define WORKSPACE_KEEP_BYTES (1u << 20)

typedef struct batch batch;

struct batch {
    batch *next;                 /* the tenant's open batches */
    qmcd_pool_task *task;
    const qmc_sampling_job *sj;
    uint64_t first, count;
    uint64_t next_block;         /* pool mutex: the next block to hand out */
    uint64_t done;               /* pool mutex: blocks finished */
    unsigned in_flight;          /* pool mutex: blocks being computed */
    int err;                     /* pool mutex: the first error, or 0 */
    qmc_sampling_sums *out;
    int (*stop)(void *ctx);
    void *ctx;
    atomic_uint_fast64_t *evals;
};

/* The tenants of one peer (peers.h: an address, or a uid): they share a
 * cap on runners, so that a peer opening many connections cannot take
 * every runner from the other peers. */
typedef struct peer_group {
    struct peer_group *next;
    qmcd_peer_key key;
    unsigned refs;                        /* tenants */
    unsigned running;                     /* their tasks on runners */
} peer_group;

struct qmcd_pool_tenant {
    qmcd_pool_tenant *next, *prev;        /* the ring of tenants */
    peer_group *group;
    qmcd_pool_task *queue_head, *queue_tail; /* submitted, not yet on a runner */
    qmcd_pool_task *wait_head, *wait_tail;   /* runners waiting for a slot */
    batch *batches;
    unsigned running;                     /* tasks on runners */
    unsigned refs;                        /* the connection + tasks not done */
    int prefer_batch;                     /* alternate blocks and quanta */
};

struct qmcd_pool {
    pthread_mutex_t mu;
    pthread_cond_t work_cv;      /* workers: a free slot and work for it */
    pthread_cond_t runner_cv;    /* runners: a task may start */
    pthread_cond_t task_cv;      /* running tasks: a slot granted, a batch done */
    pthread_t *threads;
    unsigned n_threads, n_workers, n_runners;
    unsigned slots_free;
    unsigned tenant_running_max;
    unsigned peer_running_max;   /* runners one peer's tenants may hold */
    uint64_t mem_total;          /* max-jobs-memory-total */
    uint64_t mem_used;           /* reserved by the tasks on runners */
    uint64_t mem_waits;          /* tasks whose start memory held back */
    uint64_t mem_backfills;      /* tasks that started ahead of a waiter */
    qmcd_pool_task *waiter;      /* queued: its turn came, its memory did not fit */
    unsigned overtakes;          /* tasks started ahead of the waiter */
    unsigned max_overtakes;      /* job-memory-overtakes: then admission drains */
    uint64_t admissions;         /* tasks put on runners */
    peer_group *groups;
    qmcd_pool_tenant *rr_compute; /* ring cursor: who gets the next slot */
    qmcd_pool_tenant *rr_admit;   /* ring cursor: who gets the next runner */
    qmcd_pool_task *done;
    int stop;
    int efd;
};

/* ---- tenants (pool mutex held) ---------------------------------------------- */

static void ring_insert(qmcd_pool *pool, qmcd_pool_tenant *t)
{
    qmcd_pool_tenant *at = pool->rr_compute;
    if (!at) {
        t->next = t->prev = t;
        pool->rr_compute = pool->rr_admit = t;
        return;
    }
    /* Just before the cursor: the newcomer's turn comes after everyone
     * already waiting. */
    t->next = at;
    t->prev = at->prev;
    at->prev->next = t;
    at->prev = t;
}

static void ring_remove(qmcd_pool *pool, qmcd_pool_tenant *t)
{
    if (t->next == t) {
        pool->rr_compute = pool->rr_admit = NULL;
        return;
    }
    if (pool->rr_compute == t)
        pool->rr_compute = t->next;
    if (pool->rr_admit == t)
        pool->rr_admit = t->next;
    t->prev->next = t->next;
    t->next->prev = t->prev;
}

static void tenant_unref(qmcd_pool *pool, qmcd_pool_tenant *t)
{
    if (--t->refs)
        return;
    ring_remove(pool, t);
    peer_group *g = t->group;
    if (--g->refs == 0) {
        for (peer_group **link = &pool->groups; *link; link = &(*link)->next)
            if (*link == g) {
                *link = g->next;
                break;
            }
        free(g);
    }
    free(t);
}

/* ---- picking work (pool mutex held) ----------------------------------------- */

/* The tenant's first batch with a block to hand out, rotated to the back
 * so its batches take turns; a batch whose job must stop is closed here. */
static batch *claimable(qmcd_pool *pool, qmcd_pool_tenant *t)
{
    for (batch **link = &t->batches; *link; link = &(*link)->next) {
        batch *b = *link;
        if (b->err || b->next_block >= b->count)
            continue;
        if (b->stop(b->ctx)) {
            b->err = -ECANCELED;
            if (b->in_flight == 0)
                pthread_cond_broadcast(&pool->task_cv);
            continue;
        }
        if (b->next) {
            *link = b->next;
            batch *last = *link;
            while (last->next)
                last = last->next;
            last->next = b;
            b->next = NULL;
        }
        return b;
    }
    return NULL;
}

typedef struct pick {
    batch *b;                    /* a block of b (index i), or */
    uint64_t i;
    qmcd_pool_task *granted;     /* a slot for this waiting task */
} pick;

/* The next piece of work, round robin over the tenants: 1 and *p, or 0. */
static int pick_work(qmcd_pool *pool, pick *p)
{
    qmcd_pool_tenant *first = pool->rr_compute;
    if (!first)
        return 0;
    qmcd_pool_tenant *t = first;
    do {
        batch *b = claimable(pool, t);
        qmcd_pool_task *w = t->wait_head;
        if (b || w) {
            int use_batch = b && (!w || t->prefer_batch);
            t->prefer_batch = !use_batch;
            pool->rr_compute = t->next;
            memset(p, 0, sizeof *p);
            if (use_batch) {
                p->b = b;
                p->i = b->next_block++;
                b->in_flight++;
            } else {
                t->wait_head = w->next;
                if (!t->wait_head)
                    t->wait_tail = NULL;
                w->next = NULL;
                p->granted = w;
            }
            return 1;
        }
        t = t->next;
    } while (t != first);
    return 0;
}

/* 1 when some tenant's work waits for a slot. */
static int work_waiting(qmcd_pool *pool)
{
    qmcd_pool_tenant *first = pool->rr_compute;
    if (!first)
        return 0;
    qmcd_pool_tenant *t = first;
    do {
        if (t->wait_head)
            return 1;
        for (batch *b = t->batches; b; b = b->next)
            if (!b->err && b->next_block < b->count)
                return 1;
        t = t->next;
    } while (t != first);
    return 0;
}

/* Whether the task's reservation fits now.  With nothing reserved it runs
 * whatever it needs: jobs over the total are refused at submission, so
 * that is one queued before SIGHUP lowered the total, and it must not wait
 * for ever. */
static int fits(const qmcd_pool *pool, const qmcd_pool_task *task)
{
    uint64_t room = pool->mem_used < pool->mem_total ? pool->mem_total - pool->mem_used : 0;
    return task->mem_bytes <= room || pool->mem_used == 0;
}

/* Whether the tenant may put another task on a runner. */
static int may_run(const qmcd_pool *pool, const qmcd_pool_tenant *t)
{
    return t->running < pool->tenant_running_max && t->group->running < pool->peer_running_max;
}

/* Moves *link (prev before it in t's queue, or NULL) onto a runner. */
static qmcd_pool_task *admit(qmcd_pool *pool, qmcd_pool_tenant *t, qmcd_pool_task **link,
                             qmcd_pool_task *prev)
{
    qmcd_pool_task *task = *link;
    if (task == pool->waiter) {
        pool->waiter = NULL;
        pool->overtakes = 0;
    } else if (pool->waiter && task->mem_bytes > 0) {
        pool->overtakes++; /* backfill: it takes memory while the waiter waits */
        pool->mem_backfills++;
    }
    if (task->mem_held)
        pool->mem_waits++;
    pool->mem_used += task->mem_bytes;
    task->admitted = ++pool->admissions;
    *link = task->next;
    if (t->queue_tail == task)
        t->queue_tail = prev;
    task->next = NULL;
    t->running++;
    t->group->running++;
    return task;
}

/*
 * The next task to put on a runner.  In this order:
 *  1. a cancelled task, anywhere: past every limit and every wait, with
 *     nothing reserved (it only has to notice, and its answer should not
 *     wait for the tenant's running jobs to end);
 *  2. the waiter (the task whose turn came while its memory did not fit),
 *     as soon as its memory fits;
 *  3. the tenants in turn (rr_admit), each offering its first queued task
 *     that fits: backfill, so that a small job runs while a big one waits
 *     for memory.  The first task met that does not fit becomes the
 *     waiter.  Once max_overtakes tasks have started ahead of the waiter,
 *     admission drains for it: no task that reserves memory starts until
 *     the waiter has (running jobs give back memory and never take more,
 *     so it starts once enough of them end - each within the job time
 *     limit), and a stream of small jobs cannot starve a big one.
 */
static qmcd_pool_task *pick_task(qmcd_pool *pool)
{
    qmcd_pool_tenant *first = pool->rr_admit;
    if (!first)
        return NULL;
    qmcd_pool_tenant *t = first;
    do {
        qmcd_pool_task **link = &t->queue_head, *prev = NULL;
        while (*link && !(*link)->must_stop(*link))
            prev = *link, link = &(*link)->next;
        if (*link) {
            (*link)->mem_bytes = 0; /* it only has to notice */
            (*link)->mem_held = 0;
            return admit(pool, t, link, prev);
        }
        t = t->next;
    } while (t != first);

    qmcd_pool_task *w = pool->waiter;
    if (w && fits(pool, w)) {
        qmcd_pool_tenant *wt = w->tenant;
        if (may_run(pool, wt)) {
            qmcd_pool_task **link = &wt->queue_head, *prev = NULL;
            while (*link != w)
                prev = *link, link = &(*link)->next;
            return admit(pool, wt, link, prev);
        }
        /* Held by its own tenant's (or peer's) limit, not by memory: an
         * ordinary queued task again, which waits for its tenant's jobs
         * like any other. */
        pool->waiter = NULL;
        pool->overtakes = 0;
    }

    t = first;
    do {
        if (may_run(pool, t)) {
            qmcd_pool_task **link = &t->queue_head, *prev = NULL;
            for (; *link; prev = *link, link = &(*link)->next) {
                qmcd_pool_task *task = *link;
                if (task == pool->waiter)
                    continue;
                int drained = pool->waiter && pool->overtakes >= pool->max_overtakes;
                if (drained || !fits(pool, task)) {
                    /* Held back for memory: STATS job_memory_waits counts
                     * it when it starts. */
                    task->mem_held = 1;
                    if (!pool->waiter) {
                        pool->waiter = task;
                        pool->overtakes = 0;
                    }
                    if (drained)
                        break; /* the tenant's later tasks are held too */
                    continue;
                }
                pool->rr_admit = t->next;
                return admit(pool, t, link, prev);
            }
        }
        t = t->next;
    } while (t != first);
    return NULL;
}

/* ---- slots (pool mutex held) ------------------------------------------------ */

/* Waits in the tenant's line for a slot. */
static void acquire_slot(qmcd_pool *pool, qmcd_pool_task *task)
{
    qmcd_pool_tenant *t = task->tenant;
    task->next = NULL;
    if (t->wait_tail)
        t->wait_tail->next = task;
    else
        t->wait_head = task;
    t->wait_tail = task;
    pthread_cond_signal(&pool->work_cv);
    while (!task->granted && !pool->stop)
        pthread_cond_wait(&pool->task_cv, &pool->mu);
    task->granted = 0;
    task->slot_ms = qmcd_now_ms();
}

static void release_slot(qmcd_pool *pool)
{
    pool->slots_free++;
    pthread_cond_signal(&pool->work_cv);
}

/* ---- threads ------------------------------------------------------------------ */

static int grow(void **ws, size_t *have, size_t need)
{
    if (need <= *have)
        return 0;
    void *p = realloc(*ws, need);
    if (!p)
        return QMC_ENOMEM;
    *ws = p;
    *have = need;
    return 0;
}

static void *worker(void *arg)
{
    qmcd_pool *pool = arg;
    void *ws = NULL; /* grown to the largest workspace seen, kept */
    size_t ws_bytes = 0;
    pthread_mutex_lock(&pool->mu);
    while (!pool->stop) {
        pick p;
        if (pool->slots_free == 0 || !pick_work(pool, &p)) {
            if (ws_bytes > WORKSPACE_KEEP_BYTES) { /* idle: give a big one back */
                free(ws);
                ws = NULL;
                ws_bytes = 0;
            }
            pthread_cond_wait(&pool->work_cv, &pool->mu);
            continue;
        }
        pool->slots_free--;
        if (p.granted) {
            p.granted->granted = 1;
            pthread_cond_broadcast(&pool->task_cv);
            continue;
        }
        batch *b = p.b;
        pthread_mutex_unlock(&pool->mu);
        size_t need = qmc_sampling_workspace_bytes(b->sj);
        int err = grow(&ws, &ws_bytes, need ? need : 1);
        if (!err)
            err = qmc_sampling_run_block(b->sj, b->first + p.i, ws, ws_bytes, &b->out[p.i]);
        if (!err)
            atomic_fetch_add(b->evals, b->out[p.i].count);
        pthread_mutex_lock(&pool->mu);
        pool->slots_free++;
        b->in_flight--;
        b->done++;
        if (err && !b->err)
            b->err = err;
        if (b->in_flight == 0 && (b->done == b->count || b->err || pool->stop))
            pthread_cond_broadcast(&pool->task_cv);
    }
    pthread_mutex_unlock(&pool->mu);
    free(ws);
    return NULL;
}

static void *runner(void *arg)
{
    qmcd_pool *pool = arg;
    pthread_mutex_lock(&pool->mu);
    while (!pool->stop) {
        qmcd_pool_task *task = pick_task(pool);
        if (!task) {
            pthread_cond_wait(&pool->runner_cv, &pool->mu);
            continue;
        }
        acquire_slot(pool, task);
        pthread_mutex_unlock(&pool->mu);
        task->run(task);
        pthread_mutex_lock(&pool->mu);
        release_slot(pool);
        pool->mem_used -= task->mem_bytes;
        qmcd_pool_tenant *t = task->tenant;
        t->running--;
        t->group->running--;
        task->next = pool->done;
        pool->done = task;
        tenant_unref(pool, t);
        task->tenant = NULL;
        uint64_t one = 1;
        if (write(pool->efd, &one, sizeof one) < 0) {
            /* The counter cannot overflow at our rates; nothing to do. */
        }
        /* The tenant may start another task now, or someone else may. */
        pthread_cond_broadcast(&pool->runner_cv);
    }
    pthread_mutex_unlock(&pool->mu);
    return NULL;
}

int qmcd_pool_run_blocks(qmcd_pool_task *task, const qmc_sampling_job *sj, uint64_t first,
                         uint64_t count, qmc_sampling_sums *out, int (*stop)(void *ctx),
                         void *ctx, atomic_uint_fast64_t *evals)
{
    qmcd_pool *pool = task->pool;
    if (count == 0)
        return 0;
    if (count == 1) {
        /* One block: computed here, on the slot the task holds. */
        if (stop(ctx))
            return -ECANCELED;
        size_t bytes = qmc_sampling_workspace_bytes(sj);
        void *ws = malloc(bytes ? bytes : 1);
        if (!ws)
            return QMC_ENOMEM;
        int err = qmc_sampling_run_block(sj, first, ws, bytes, &out[0]);
        free(ws);
        if (!err)
            atomic_fetch_add(evals, out[0].count);
        return err;
    }
    batch b = {.task = task, .sj = sj, .first = first, .count = count, .out = out,
               .stop = stop, .ctx = ctx, .evals = evals};
    qmcd_pool_tenant *t = task->tenant;
    pthread_mutex_lock(&pool->mu);
    /* The blocks go to the slots in turn with everyone's work; this
     * thread only waits, so its slot goes back meanwhile. */
    b.next = t->batches;
    t->batches = &b;
    release_slot(pool);
    pthread_cond_broadcast(&pool->work_cv);
    /* Blocks being computed write into b and out: wait for them even when
     * the pool stops (its workers then start no more). */
    while (!(b.in_flight == 0 && (b.done == b.count || b.err || pool->stop)))
        pthread_cond_wait(&pool->task_cv, &pool->mu);
    if (b.done != b.count && !b.err)
        b.err = -ECANCELED;
    for (batch **link = &t->batches; *link; link = &(*link)->next)
        if (*link == &b) {
            *link = b.next;
            break;
        }
    acquire_slot(pool, task);
    pthread_mutex_unlock(&pool->mu);
    return b.err;
}

void qmcd_pool_yield(qmcd_pool_task *task)
{
    qmcd_pool *pool = task->pool;
    if (qmcd_now_ms() - task->slot_ms < QUANTUM_MS)
        return;
    pthread_mutex_lock(&pool->mu);
    if (pool->slots_free == 0 && work_waiting(pool)) {
        release_slot(pool);
        acquire_slot(pool, task); /* behind the tenant's others, after every tenant's turn */
    } else {
        task->slot_ms = qmcd_now_ms();
    }
    pthread_mutex_unlock(&pool->mu);
}

/* ---- the loop side ---------------------------------------------------------------- */

int qmcd_pool_tenant_new(qmcd_pool *pool, const qmcd_peer_key *peer, qmcd_pool_tenant **out)
{
    qmcd_pool_tenant *t = calloc(1, sizeof *t);
    peer_group *fresh = calloc(1, sizeof *fresh);
    *out = NULL;
    if (!t || !fresh) {
        free(t);
        free(fresh);
        return -ENOMEM;
    }
    t->refs = 1;
    pthread_mutex_lock(&pool->mu);
    peer_group *g = pool->groups;
    while (g && memcmp(&g->key, peer, sizeof *peer) != 0)
        g = g->next;
    if (!g) {
        g = fresh;
        fresh = NULL;
        g->key = *peer;
        g->next = pool->groups;
        pool->groups = g;
    }
    g->refs++;
    t->group = g;
    ring_insert(pool, t);
    pthread_mutex_unlock(&pool->mu);
    free(fresh);
    *out = t;
    return 0;
}

void qmcd_pool_tenant_release(qmcd_pool *pool, qmcd_pool_tenant *tenant)
{
    if (!tenant)
        return;
    pthread_mutex_lock(&pool->mu);
    tenant_unref(pool, tenant);
    pthread_mutex_unlock(&pool->mu);
}

void qmcd_pool_submit(qmcd_pool *pool, qmcd_pool_tenant *t, qmcd_pool_task *task)
{
    task->pool = pool;
    task->tenant = t;
    task->granted = 0;
    task->next = NULL;
    pthread_mutex_lock(&pool->mu);
    task->mem_held = 0;
    t->refs++;
    if (t->queue_tail)
        t->queue_tail->next = task;
    else
        t->queue_head = task;
    t->queue_tail = task;
    pthread_cond_signal(&pool->runner_cv);
    pthread_mutex_unlock(&pool->mu);
}

void qmcd_pool_set_memory_total(qmcd_pool *pool, uint64_t bytes)
{
    pthread_mutex_lock(&pool->mu);
    pool->mem_total = bytes;
    /* A raised total may let a waiting task start now; a lowered one only
     * holds back later tasks (running ones keep what they reserved). */
    pthread_cond_broadcast(&pool->runner_cv);
    pthread_mutex_unlock(&pool->mu);
}

void qmcd_pool_set_overtakes(qmcd_pool *pool, unsigned overtakes)
{
    pthread_mutex_lock(&pool->mu);
    pool->max_overtakes = overtakes;
    /* A raised count may let a drained admission backfill again. */
    pthread_cond_broadcast(&pool->runner_cv);
    pthread_mutex_unlock(&pool->mu);
}

void qmcd_pool_counts_get(qmcd_pool *pool, qmcd_pool_counts *out)
{
    pthread_mutex_lock(&pool->mu);
    out->memory_waits = pool->mem_waits;
    out->memory_backfills = pool->mem_backfills;
    out->memory_reserved = pool->mem_used;
    out->memory_waiting = pool->waiter != NULL;
    pthread_mutex_unlock(&pool->mu);
}

uint64_t qmcd_pool_memory_keep(qmcd_pool_task *task)
{
    qmcd_pool *pool = task->pool;
    pthread_mutex_lock(&pool->mu);
    /* It stays in mem_used: the runner subtracts the task's mem_bytes when
     * the run ends, and that is now 0. */
    uint64_t kept = task->mem_bytes;
    task->mem_bytes = 0;
    pthread_mutex_unlock(&pool->mu);
    return kept;
}

void qmcd_pool_memory_release(qmcd_pool *pool, uint64_t bytes)
{
    if (!bytes)
        return;
    pthread_mutex_lock(&pool->mu);
    pool->mem_used = pool->mem_used > bytes ? pool->mem_used - bytes : 0;
    pthread_cond_broadcast(&pool->runner_cv); /* a waiter may fit now */
    pthread_mutex_unlock(&pool->mu);
}

void qmcd_pool_cancelled(qmcd_pool *pool)
{
    pthread_mutex_lock(&pool->mu);
    pthread_cond_broadcast(&pool->runner_cv);
    pthread_mutex_unlock(&pool->mu);
}

qmcd_pool_task *qmcd_pool_take_done(qmcd_pool *pool)
{
    pthread_mutex_lock(&pool->mu);
    qmcd_pool_task *done = pool->done;
    pool->done = NULL;
    pthread_mutex_unlock(&pool->mu);
    return done;
}

int qmcd_pool_new(unsigned workers, qmcd_pool **out)
{
    *out = NULL;
    if (workers == 0)
        workers = 1;
    qmcd_pool *pool = calloc(1, sizeof *pool);
    if (!pool)
        return -ENOMEM;
    pool->n_workers = workers;
    pool->n_runners = workers + (workers > RUNNERS_SPARE ? workers : RUNNERS_SPARE);
    pool->slots_free = workers;
    pool->mem_total = UINT64_MAX; /* until qmcd_pool_set_memory_total */
    pool->max_overtakes = 8;      /* until qmcd_pool_set_overtakes */
    pool->tenant_running_max = workers;
    /* One peer may hold every runner but `workers` of them: another peer's
     * job always finds one, however many connections the first opens. */
    pool->peer_running_max = pool->n_runners - workers;
    pool->efd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
    pool->threads = calloc(pool->n_workers + pool->n_runners, sizeof *pool->threads);
    if (pool->efd < 0 || !pool->threads) {
        if (pool->efd >= 0)
            close(pool->efd);
        free(pool->threads);
        free(pool);
        return -ENOMEM;
    }
    pthread_mutex_init(&pool->mu, NULL);
    pthread_cond_init(&pool->work_cv, NULL);
    pthread_cond_init(&pool->runner_cv, NULL);
    pthread_cond_init(&pool->task_cv, NULL);
    for (unsigned i = 0; i < pool->n_workers + pool->n_runners; i++) {
        int err = pthread_create(&pool->threads[i], NULL, i < workers ? worker : runner, pool);
        if (err) {
            qmcd_err("starting pool thread %u: %s", i, strerror(err));
            qmcd_pool_free(pool, 0);
            return -err;
        }
        pool->n_threads++;
    }
    *out = pool;
    return 0;
}

int qmcd_pool_eventfd(const qmcd_pool *pool)
{
    return pool->efd;
}

void qmcd_pool_free(qmcd_pool *pool, int jobs_running)
{
    if (!pool)
        return;
    pthread_mutex_lock(&pool->mu);
    pool->stop = 1;
    pthread_cond_broadcast(&pool->work_cv);
    pthread_cond_broadcast(&pool->runner_cv);
    pthread_cond_broadcast(&pool->task_cv);
    pthread_mutex_unlock(&pool->mu);
    if (jobs_running)
        return; /* exit() ends them; their memory must stay valid until then */
    for (unsigned i = 0; i < pool->n_threads; i++)
        pthread_join(pool->threads[i], NULL);
    while (pool->done) {
        qmcd_pool_task *task = pool->done;
        pool->done = task->next;
        task->free_fn(task);
    }
    pthread_mutex_destroy(&pool->mu);
    pthread_cond_destroy(&pool->work_cv);
    pthread_cond_destroy(&pool->runner_cv);
    pthread_cond_destroy(&pool->task_cv);
    close(pool->efd);
    free(pool->threads);
    free(pool);
}
