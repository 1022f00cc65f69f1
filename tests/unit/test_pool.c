/*
 * test_pool.c - admission under max-jobs-memory-total in the worker pool
 * (daemon/pool.c, linked as its object with log.o: see the Makefile):
 * backfill (a job that fits starts while a bigger one waits for memory,
 * within one connection and across connections), the bound on it
 * (job-memory-overtakes: after that many jobs passed a waiting one, none
 * that takes memory starts before it, so a steady stream of small jobs
 * cannot starve a big one), strict turns at 0 overtakes, and a cancelled
 * waiter that lets the others go.
 *
 * The jobs are fake tasks whose run() notes its start and then blocks
 * until the test releases it, so every check is on the order in which the
 * pool admitted them and the state of the pool (what runs, what waits, the
 * counters), never on time.  The only clock is a hang guard: a wait that
 * never ends fails the test instead of hanging the suite.
 */
#define _GNU_SOURCE
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <poll.h>
#include <stdatomic.h>
#include <pthread.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "pool.h"

/* pool.c reads the clock through the loop's helper (loop.c, which this
 * test does not link); the same monotonic clock here. */
int64_t qmcd_now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
}

/* Not a time limit on the pool: only what keeps a broken pool from hanging
 * `make test` for ever. */
#define HANG_GUARD_S 120

typedef struct fake {
    qmcd_pool_task task;         /* first: the pool hands &task back */
    int id;
    int started, released, done;
    atomic_int cancelled;        /* read by the pool under its own mutex */
} fake;

static pthread_mutex_t mu = PTHREAD_MUTEX_INITIALIZER;
static pthread_cond_t cv = PTHREAD_COND_INITIALIZER;

static void fake_run(qmcd_pool_task *task)
{
    fake *f = (fake *)task;
    pthread_mutex_lock(&mu);
    f->started = 1;
    pthread_cond_broadcast(&cv);
    while (!f->released && !atomic_load(&f->cancelled))
        pthread_cond_wait(&cv, &mu);
    pthread_mutex_unlock(&mu);
}

static void fake_free(qmcd_pool_task *task)
{
    (void)task; /* the fakes live in the test's frames */
}

static int fake_must_stop(qmcd_pool_task *task)
{
    return atomic_load(&((fake *)task)->cancelled);
}

static void fake_init(fake *f, int id, uint64_t mem_bytes)
{
    memset(f, 0, sizeof *f);
    f->id = id;
    f->task.run = fake_run;
    f->task.free_fn = fake_free;
    f->task.must_stop = fake_must_stop;
    f->task.mem_bytes = mem_bytes;
    atomic_init(&f->cancelled, 0);
}

static void guard_deadline(struct timespec *ts)
{
    clock_gettime(CLOCK_REALTIME, ts);
    ts->tv_sec += HANG_GUARD_S;
}

static void wait_started(fake *f)
{
    struct timespec dl;
    guard_deadline(&dl);
    pthread_mutex_lock(&mu);
    int rc = 0;
    while (!f->started && rc == 0)
        rc = pthread_cond_timedwait(&cv, &mu, &dl);
    int ok = f->started;
    pthread_mutex_unlock(&mu);
    if (!ok)
        fail_msg("job %d never started", f->id);
}

static int started(fake *f)
{
    pthread_mutex_lock(&mu);
    int s = f->started;
    pthread_mutex_unlock(&mu);
    return s;
}

/* Whether a was put on a runner before b (both started): the pool's own
 * admission order, since two jobs admitted together may reach run() in
 * either order (slots go to tenants in turn). */
static int admitted_before(fake *a, fake *b)
{
    pthread_mutex_lock(&mu); /* both wrote their start under mu, after admission */
    int before = a->started && b->started && a->task.admitted < b->task.admitted;
    pthread_mutex_unlock(&mu);
    return before;
}

/* Releases f and waits until the pool has taken it back (its memory
 * returned: the runner posts it to the done list after that). */
static void finish(qmcd_pool *pool, fake *f)
{
    pthread_mutex_lock(&mu);
    f->released = 1;
    pthread_cond_broadcast(&cv);
    pthread_mutex_unlock(&mu);
    int64_t end = qmcd_now_ms() + HANG_GUARD_S * 1000;
    while (!f->done) {
        struct pollfd p = {.fd = qmcd_pool_eventfd(pool), .events = POLLIN};
        if (qmcd_now_ms() > end)
            fail_msg("job %d never came back", f->id);
        if (poll(&p, 1, 1000) > 0) {
            uint64_t n;
            if (read(p.fd, &n, sizeof n) < 0) {
                /* EAGAIN: another wake-up took it; look at the list anyway */
            }
        }
        for (qmcd_pool_task *t = qmcd_pool_take_done(pool); t; t = t->next)
            ((fake *)t)->done = 1;
    }
}

static qmcd_pool_tenant *tenant(qmcd_pool *pool, uint32_t uid)
{
    qmcd_peer_key k;
    memset(&k, 0, sizeof k);
    k.kind = QMCD_PEER_UID;
    memcpy(k.addr, &uid, sizeof uid);
    qmcd_pool_tenant *t = NULL;
    assert_int_equal(qmcd_pool_tenant_new(pool, &k, &t), 0);
    return t;
}

/* 8 workers: 16 runners and 8 slots, more than any case here keeps
 * running, so an admitted job reaches run() at once. */
static qmcd_pool *new_pool(uint64_t total, unsigned overtakes)
{
    qmcd_pool *pool = NULL;
    assert_int_equal(qmcd_pool_new(8, &pool), 0);
    qmcd_pool_set_memory_total(pool, total);
    qmcd_pool_set_overtakes(pool, overtakes);
    return pool;
}

static qmcd_pool_counts counts(qmcd_pool *pool)
{
    qmcd_pool_counts c;
    qmcd_pool_counts_get(pool, &c);
    return c;
}

/* Waits until the pool has seen that a job's memory does not fit (its
 * waiter is set), so that what the test submits next is sure to come after
 * the waiter in the pool's eyes. */
static void wait_waiting(qmcd_pool *pool)
{
    int64_t end = qmcd_now_ms() + HANG_GUARD_S * 1000;
    while (!counts(pool).memory_waiting) {
        if (qmcd_now_ms() > end)
            fail_msg("no job ever waited for memory");
        struct timespec ms = {0, 1000000};
        nanosleep(&ms, NULL);
    }
}

/* (a) A small job finishes while a big one waits for memory, from another
 * connection and from the big one's own. */
static void test_backfill(void **state)
{
    (void)state;
    qmcd_pool *pool = new_pool(100, 8);
    qmcd_pool_tenant *ta = tenant(pool, 1), *tb = tenant(pool, 2), *tc = tenant(pool, 3);
    fake hold, big, small_other, small_own;
    fake_init(&hold, 1, 60);
    fake_init(&big, 2, 80);
    fake_init(&small_other, 3, 10);
    fake_init(&small_own, 4, 30);
    qmcd_pool_submit(pool, ta, &hold.task);
    wait_started(&hold);
    qmcd_pool_submit(pool, tb, &big.task);       /* 80 > 40 free: waits */
    wait_waiting(pool);
    qmcd_pool_submit(pool, tb, &small_own.task); /* behind it, same tenant */
    qmcd_pool_submit(pool, tc, &small_other.task);
    wait_started(&small_other);
    wait_started(&small_own);
    assert_false(started(&big));
    assert_int_equal(counts(pool).memory_reserved, 100);
    finish(pool, &small_other);
    finish(pool, &small_own); /* done, and the big one still waits */
    assert_false(started(&big));
    assert_int_equal(counts(pool).memory_reserved, 60);
    finish(pool, &hold);
    wait_started(&big);
    assert_int_equal(counts(pool).memory_reserved, 80);
    assert_true(admitted_before(&small_other, &big));
    assert_true(admitted_before(&small_own, &big));
    qmcd_pool_counts c = counts(pool);
    assert_int_equal(c.memory_waits, 1);     /* the big one */
    assert_int_equal(c.memory_backfills, 2); /* the two small ones passed it */
    finish(pool, &big);
    assert_int_equal(counts(pool).memory_reserved, 0);
    qmcd_pool_tenant_release(pool, ta);
    qmcd_pool_tenant_release(pool, tb);
    qmcd_pool_tenant_release(pool, tc);
    qmcd_pool_free(pool, 0);
}

/* (b) A steady stream of small jobs from two connections, three always
 * running (so 30 of 100 are always taken and the big job's 80 never fit
 * while the stream flows): after job-memory-overtakes (3 here) of them
 * passed it, the next small job waits, and the big one starts as soon as
 * the running ones leave it room - before the small one that came after
 * the drain. */
static void test_no_starvation(void **state)
{
    (void)state;
    enum { K = 3, STREAM = 7 };
    qmcd_pool *pool = new_pool(100, K);
    qmcd_pool_tenant *tb = tenant(pool, 2), *ts[2] = {tenant(pool, 3), tenant(pool, 4)};
    fake big, s[STREAM + 1];
    fake_init(&big, 100, 80);
    for (int i = 1; i <= STREAM; i++)
        fake_init(&s[i], i, 10);
    for (int i = 1; i <= 3; i++) {
        qmcd_pool_submit(pool, ts[i % 2], &s[i].task);
        wait_started(&s[i]);
    }
    qmcd_pool_submit(pool, tb, &big.task); /* 80 > 70 free: waits */
    wait_waiting(pool);
    /* The stream: one more small job in, the oldest one out. */
    for (int i = 4; i <= 3 + K; i++) {
        qmcd_pool_submit(pool, ts[i % 2], &s[i].task);
        wait_started(&s[i]);
        assert_false(started(&big));
        finish(pool, &s[i - 3]);
    }
    assert_int_equal(counts(pool).memory_backfills, K);
    /* The next small job fits the memory (70 free) but would pass the big
     * one a (K + 1)-th time: it waits. */
    fake *late = &s[STREAM];
    qmcd_pool_submit(pool, ts[0], &late->task);
    /* One running small job ends: 80 free, the big one's turn. */
    finish(pool, &s[4]);
    wait_started(&big);
    assert_false(started(late)); /* 100 of 100 reserved now */
    finish(pool, &s[5]);
    wait_started(late);
    assert_true(admitted_before(&big, late));
    qmcd_pool_counts c = counts(pool);
    assert_int_equal(c.memory_backfills, K); /* the late one passed no one */
    assert_int_equal(c.memory_waits, 2);     /* the big one and the late one */
    finish(pool, &s[6]);
    finish(pool, late);
    finish(pool, &big);
    assert_int_equal(counts(pool).memory_reserved, 0);
    qmcd_pool_tenant_release(pool, tb);
    qmcd_pool_tenant_release(pool, ts[0]);
    qmcd_pool_tenant_release(pool, ts[1]);
    qmcd_pool_free(pool, 0);
}

/* The strict-order scene, with job-memory-overtakes 0 and 100 of memory:
 * tenant 1's hold (60) runs, tenant 2's big job (80) waits for memory,
 * and tenant 3's small one (10) is queued behind it. */
static void hold_big_small(qmcd_pool *pool, qmcd_pool_tenant *t[3], fake *hold, fake *big,
                           fake *small)
{
    for (uint32_t i = 0; i < 3; i++)
        t[i] = tenant(pool, i + 1);
    fake_init(hold, 1, 60);
    fake_init(big, 2, 80);
    fake_init(small, 3, 10);
    qmcd_pool_submit(pool, t[0], &hold->task);
    wait_started(hold);
    qmcd_pool_submit(pool, t[1], &big->task);
    wait_waiting(pool);
    qmcd_pool_submit(pool, t[2], &small->task);
}

/* job-memory-overtakes 0: strict turns, nothing passes a waiting job. */
static void test_strict(void **state)
{
    (void)state;
    qmcd_pool *pool = new_pool(100, 0);
    qmcd_pool_tenant *t[3];
    fake hold, big, small;
    hold_big_small(pool, t, &hold, &big, &small);
    finish(pool, &hold);
    wait_started(&big);
    wait_started(&small);
    assert_true(admitted_before(&big, &small));
    assert_int_equal(counts(pool).memory_backfills, 0);
    finish(pool, &big);
    finish(pool, &small);
    for (int i = 0; i < 3; i++)
        qmcd_pool_tenant_release(pool, t[i]);
    qmcd_pool_free(pool, 0);
}

/* A waiting job that is cancelled starts at once (it only has to notice)
 * and reserves nothing; the jobs it held back by the drain go on. */
static void test_cancelled_waiter(void **state)
{
    (void)state;
    qmcd_pool *pool = new_pool(100, 0);
    qmcd_pool_tenant *t[3];
    fake hold, big, small; /* strict: small is held behind the big one */
    hold_big_small(pool, t, &hold, &big, &small);
    pthread_mutex_lock(&mu);
    atomic_store(&big.cancelled, 1);
    pthread_cond_broadcast(&cv);
    pthread_mutex_unlock(&mu);
    qmcd_pool_cancelled(pool);
    wait_started(&big);
    wait_started(&small);
    assert_int_equal(counts(pool).memory_reserved, 70); /* the cancelled one: 0 */
    finish(pool, &big);
    finish(pool, &small);
    finish(pool, &hold);
    assert_int_equal(counts(pool).memory_reserved, 0);
    for (int i = 0; i < 3; i++)
        qmcd_pool_tenant_release(pool, t[i]);
    qmcd_pool_free(pool, 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_backfill),
        cmocka_unit_test(test_no_starvation),
        cmocka_unit_test(test_strict),
        cmocka_unit_test(test_cancelled_waiter),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
