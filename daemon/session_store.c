/*
 * session_store.c - the server's integration sessions (session.h): the
 * registry every session is in from SESSION_OPEN to its end, attached to
 * a connection or parked; the ids and tokens; who owns what; the caps per
 * peer and in all (sessions and memory, parked ones included); parking
 * and expiry after session-idle-timeout-ms; and the STATS gauges.
 *
 * A token is 32 bytes from libsodium's generator (seeded once by auth.c's
 * sodium_init, before any thread), and a lookup checks the identity and
 * the token both, the token with sodium_memcmp, so that how far a guess
 * matched never shows in the time taken; every miss is the same answer.
 * The registry is a list: max-sessions bounds it (65536 at most), and it
 * is walked only to open, resume, close and expire.
 *
 * This file must not send frames or step an integrator: session.c and
 * session_step.c do.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/timerfd.h>
#include <unistd.h>

#include <sodium.h>

#include "log.h"
#include "loop.h"
#include "session.h"

struct qmcd_sessions {
    qmcd_sess *all;
    uint64_t n, next_id;
    qmcd_watch timer;             /* expiry sweep, once a second */
};

/* The expiry sweep's period: parked sessions live session-idle-timeout-ms
 * (at least 100 ms) to within this. */
#define SWEEP_MS 250

static int same_peer(const qmcd_identity *a, const qmcd_identity *b)
{
    return memcmp(&a->peer, &b->peer, sizeof a->peer) == 0;
}

static void gauges(qmcd_server *srv)
{
    uint64_t parked = 0, mem = 0;
    for (qmcd_sess *s = srv->sessions->all; s; s = s->next) {
        parked += s->a == NULL && !s->orphan;
        mem += s->mem_bytes;
    }
    srv->stats.sessions_open = srv->sessions->n;
    srv->stats.sessions_parked_now = parked;
    srv->stats.sessions_memory = mem;
}

int qmcd__sessions_admit(qmcd_server *srv, const qmcd_identity *who, uint64_t bytes, char *why,
                         size_t n)
{
    const qmcd_config *cfg = &srv->cfg;
    uint64_t mine = 0, mine_bytes = 0, all_bytes = 0;
    for (qmcd_sess *s = srv->sessions->all; s; s = s->next) {
        all_bytes += s->mem_bytes;
        if (same_peer(&s->who, who)) {
            mine++;
            mine_bytes += s->mem_bytes;
        }
    }
    char peer[96];
    qmcd_peer_key_name(&who->peer, peer, sizeof peer);
    int refused = 1;
    if (srv->sessions->n >= cfg->max_sessions)
        snprintf(why, n, "max-sessions: %llu sessions already open on this server (parked "
                 "ones count until they expire); try later",
                 (unsigned long long)cfg->max_sessions);
    else if (mine >= cfg->max_sessions_per_peer)
        snprintf(why, n, "max-sessions-per-peer: %s already has %llu sessions open (parked "
                 "ones count); close one first", peer, (unsigned long long)mine);
    else if (bytes > cfg->max_jobs_memory_total)
        snprintf(why, n, "max-jobs-memory-total: this session may need %llu bytes, more than "
                 "the %llu all running jobs and sessions may hold; lower its max_batch, "
                 "max_memory or max_evals", (unsigned long long)bytes,
                 (unsigned long long)cfg->max_jobs_memory_total);
    else if (mine_bytes + bytes > cfg->max_sessions_memory_per_peer)
        snprintf(why, n, "max-sessions-memory-per-peer: this session may need %llu bytes and "
                 "%s's sessions hold %llu of %llu", (unsigned long long)bytes, peer,
                 (unsigned long long)mine_bytes,
                 (unsigned long long)cfg->max_sessions_memory_per_peer);
    else if (all_bytes + bytes > cfg->max_sessions_memory)
        snprintf(why, n, "max-sessions-memory: this session may need %llu bytes and the open "
                 "sessions hold %llu of %llu; try later", (unsigned long long)bytes,
                 (unsigned long long)all_bytes, (unsigned long long)cfg->max_sessions_memory);
    else
        refused = 0;
    if (!refused)
        return 0;
    srv->stats.sessions_refused++;
    return QMC_ETOOBIG;
}

qmcd_sess *qmcd__sessions_add(qmcd_server *srv, const qmcd_identity *who, uint64_t bytes)
{
    qmcd_sess *s = calloc(1, sizeof *s);
    if (!s)
        return NULL;
    s->srv = srv;
    s->who = *who;
    s->mem_bytes = bytes;
    s->id = ++srv->sessions->next_id;
    randombytes_buf(s->token, sizeof s->token);
    atomic_init(&s->cancel, SESS_GO);
    s->next = srv->sessions->all;
    srv->sessions->all = s;
    srv->sessions->n++;
    srv->stats.sessions_opened++;
    gauges(srv);
    return s;
}

qmcd_sess *qmcd__sessions_find(qmcd_server *srv, uint64_t id, const qmcd_identity *who,
                               const uint8_t *token)
{
    for (qmcd_sess *s = srv->sessions->all; s; s = s->next) {
        if (s->id != id || s->orphan)
            continue;
        /* Both checks, always: the identity (peer and key) and the token,
         * the token in constant time. */
        int same_who = memcmp(&s->who, who, sizeof *who) == 0;
        int same_token = sodium_memcmp(s->token, token, sizeof s->token) == 0;
        return same_who && same_token ? s : NULL;
    }
    return NULL;
}

void qmcd__sessions_park(qmcd_sess *s)
{
    s->a = NULL;
    s->parked_ms = qmcd_now_ms();
    s->srv->stats.sessions_parked++;
    gauges(s->srv);
    qmcd_debug("session %llu parked (kept %llu ms)", (unsigned long long)s->id,
               (unsigned long long)s->srv->cfg.session_idle_timeout_ms);
}

void qmcd__sessions_unpark(qmcd_sess *s)
{
    s->parked_ms = 0;
    gauges(s->srv);
}

void qmcd__sessions_free(qmcd_sess *s)
{
    qmc_session_free(s->core); /* unwinds a suspended integrator */
    if (s->pool_bytes)
        qmcd_pool_memory_release(s->srv->pool, s->pool_bytes);
    free(s->vals);
    free(s);
}

void qmcd__sessions_drop(qmcd_sess *s)
{
    qmcd_server *srv = s->srv;
    for (qmcd_sess **l = &srv->sessions->all; *l; l = &(*l)->next)
        if (*l == s) {
            *l = s->next;
            srv->sessions->n--;
            break;
        }
    s->next = NULL;
    s->a = NULL;
    gauges(srv);
    if (s->stepping) {
        /* The worker still has it: stop it there, free it when it is
         * back (session.c's done callback sees orphan). */
        atomic_store(&s->cancel, SESS_CANCEL_CLOSE);
        s->orphan = 1;
        qmcd_pool_cancelled(srv->pool);
        return;
    }
    qmcd__sessions_free(s);
}

/* Every SWEEP_MS: parked sessions past session-idle-timeout-ms go. */
static void on_sweep(qmcd_server *srv, qmcd_watch *w, uint32_t events)
{
    (void)events;
    uint64_t ticks;
    if (read(w->fd, &ticks, sizeof ticks) < 0 && errno != EAGAIN)
        qmcd_warn("session timer: %s", strerror(errno));
    const int64_t now = qmcd_now_ms();
    const int64_t idle = (int64_t)srv->cfg.session_idle_timeout_ms;
    qmcd_sess *s = srv->sessions->all;
    while (s) {
        qmcd_sess *next = s->next;
        if (!s->a && !s->stepping && s->parked_ms && now - s->parked_ms >= idle) {
            srv->stats.sessions_expired++;
            qmcd_info("session %llu expired: parked for %lld ms without a SESSION_RESUME "
                      "(session-idle-timeout-ms)", (unsigned long long)s->id,
                      (long long)(now - s->parked_ms));
            qmcd__sessions_drop(s);
        }
        s = next;
    }
}

int qmcd__sessions_open(qmcd_server *srv)
{
    qmcd_sessions *r = calloc(1, sizeof *r);
    if (!r)
        return -ENOMEM;
    r->timer.fd = timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
    struct itimerspec its = {.it_interval = {0, SWEEP_MS * 1000000L},
                             .it_value = {0, SWEEP_MS * 1000000L}};
    int err = 0;
    if (r->timer.fd < 0 || timerfd_settime(r->timer.fd, 0, &its, NULL) != 0)
        err = -errno;
    r->timer.on_event = on_sweep;
    if (!err)
        err = qmcd_loop_add(srv, &r->timer, EPOLLIN);
    if (err) {
        if (r->timer.fd >= 0)
            close(r->timer.fd);
        free(r);
        return err;
    }
    srv->sessions = r;
    return 0;
}

void qmcd__sessions_close(qmcd_server *srv)
{
    qmcd_sessions *r = srv->sessions;
    if (!r)
        return;
    while (r->all) {
        /* One whose step still runs is freed by the pool when it is
         * handed back (qmcd_pool_free: the task's free_fn). */
        qmcd__sessions_drop(r->all);
    }
    qmcd_loop_del(srv, &r->timer);
    close(r->timer.fd);
    free(r);
    srv->sessions = NULL;
}
