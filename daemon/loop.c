/*
 * loop.c - the event loop: one epoll instance, level-triggered, on one
 * thread.  Every descriptor is non-blocking; handlers never wait.
 *
 * Signals arrive as readable data on a signalfd (so a handler never runs
 * in signal context); the worker pool reports finished jobs through an
 * eventfd; a timerfd ticks every QMCD_TICK_MS for deadlines (handshake,
 * idle, partial frame, write stall, job time limit, shutdown) and for
 * JOB_PROGRESS, and for the systemd watchdog ping.  A sweep per tick over the connections is O(connections),
 * which at the configured maximum is still far cheaper than a timer heap's
 * bookkeeping per byte received.
 *
 * The watchdog ping (WATCHDOG=1, when systemd set WatchdogSec=) is sent
 * from the tick handler, so it stops when the loop stops turning: a loop
 * wedged in a handler is killed and restarted by systemd, which a ping
 * from a thread of its own would hide.
 *
 * Registering a descriptor (qmcd_loop_add, _mod, _del) is watch.c's, so
 * the files that register one do not depend on this one.
 *
 * This file must not know the protocol: it dispatches events to watches
 * and decides when the process stops.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/signalfd.h>
#include <sys/timerfd.h>
#include <systemd/sd-daemon.h>
#include <time.h>
#include <unistd.h>

#include "conn.h"
#include "listen.h"
#include "log.h"
#include "loop.h"
#include "modbus_bridge.h"
#include "reload.h"

/* Stops accepting, drops the socket files, and gives running work until
 * shutdown-timeout-ms before it is cancelled. */
static void begin_drain(qmcd_server *srv, const char *why)
{
    if (srv->draining)
        return;
    srv->draining = 1;
    srv->drain_deadline_ms = qmcd_now_ms() + (int64_t)srv->cfg.shutdown_timeout_ms;
    qmcd_notice("%s: stopping; %llu job(s) and %llu connection(s) get %llu ms to finish", why,
                (unsigned long long)srv->n_jobs, (unsigned long long)srv->n_conns,
                (unsigned long long)srv->cfg.shutdown_timeout_ms);
    qmcd_listeners_close(srv);
    qmcd_modbus_drain(srv);
    char status[160];
    snprintf(status, sizeof status, "STOPPING=1\nSTATUS=stopping (%s): %llu job(s) get %llu ms",
             why, (unsigned long long)srv->n_jobs,
             (unsigned long long)srv->cfg.shutdown_timeout_ms);
    qmcd_notify(srv, status);
}

static void on_signal(qmcd_server *srv, qmcd_watch *w, uint32_t events)
{
    (void)events;
    struct signalfd_siginfo si;
    while (read(w->fd, &si, sizeof si) == (ssize_t)sizeof si) {
        if (si.ssi_signo == SIGHUP)
            qmcd_reload(srv);
        else if (si.ssi_signo == SIGTERM || si.ssi_signo == SIGINT)
            begin_drain(srv, si.ssi_signo == SIGTERM ? "SIGTERM" : "SIGINT");
    }
}

/* While draining: connections close as soon as nothing is in flight on
 * them; at the deadline jobs are cancelled (their clients still get the
 * ERROR) and POINTS streams are cut; a second later whatever is left is
 * closed, and the loop ends once no job runs and no connection is open. */
static void drain_step(qmcd_server *srv, int64_t now)
{
    if (!srv->jobs_cancelled_for_exit && now >= srv->drain_deadline_ms) {
        srv->jobs_cancelled_for_exit = 1;
        if (srv->n_jobs)
            qmcd_warn("shutdown deadline: cancelling %llu job(s)",
                      (unsigned long long)srv->n_jobs);
        qmcd_conns_deadline(srv, "server shutting down: stream cut");
    }
    if (now >= srv->drain_deadline_ms + 1000)
        qmcd_conns_close_all(srv, "server shutting down");
    qmcd_conns_close_idle(srv);
    if (srv->n_jobs == 0 && srv->n_conns == 0 && srv->n_preauth == 0)
        srv->quit = 1;
    /* Every method sees a cancel within a few thousand evaluations, but a
     * job stuck inside one integrand call must still not hold the exit
     * hostage forever. */
    if (now >= srv->drain_deadline_ms + 2000) {
        if (srv->n_jobs)
            qmcd_warn("exiting with %llu job(s) that ignored their cancel still running",
                      (unsigned long long)srv->n_jobs);
        srv->quit = 1;
    }
}

static void on_tick(qmcd_server *srv, qmcd_watch *w, uint32_t events)
{
    (void)events;
    uint64_t expirations;
    if (read(w->fd, &expirations, sizeof expirations) < 0 && errno != EAGAIN)
        qmcd_warn("timerfd read: %s", strerror(errno));
    int64_t now = qmcd_now_ms();
    /* Listeners paused for lack of descriptors get another chance. */
    for (unsigned i = 0; i < srv->n_listeners; i++)
        if (srv->listeners[i].paused && !srv->draining &&
            qmcd_loop_mod(srv, &srv->listeners[i].w, EPOLLIN) == 0)
            srv->listeners[i].paused = 0;
    qmcd_conns_tick(srv, now);
    qmcd_modbus_tick(srv, now);
    if (srv->draining)
        drain_step(srv, now);
    if (srv->watchdog_ms && now >= srv->watchdog_next_ms) {
        qmcd_notify(srv, "WATCHDOG=1");
        srv->watchdog_next_ms = now + srv->watchdog_ms;
    }
}

/* WATCHDOG_USEC (and WATCHDOG_PID, if set, naming us) turn the pings on, at
 * half the timeout as sd_watchdog_enabled(3) advises, never below a tick. */
static void watchdog_init(qmcd_server *srv)
{
    uint64_t usec = 0;
    srv->watchdog_ms = 0;
    if (sd_watchdog_enabled(0, &usec) <= 0 || usec == 0)
        return;
    int64_t ms = (int64_t)(usec / 2000);
    srv->watchdog_ms = ms < QMCD_TICK_MS ? QMCD_TICK_MS : ms;
    srv->watchdog_next_ms = qmcd_now_ms();
    qmcd_info("systemd watchdog: WATCHDOG=1 every %lld ms", (long long)srv->watchdog_ms);
}

int qmcd_loop_init(qmcd_server *srv)
{
    int err;
    srv->sig.fd = srv->tick.fd = -1;
    srv->epfd = epoll_create1(EPOLL_CLOEXEC);
    if (srv->epfd < 0)
        return -errno;
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGTERM);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGHUP);
    srv->sig.fd = signalfd(-1, &set, SFD_NONBLOCK | SFD_CLOEXEC);
    if (srv->sig.fd < 0)
        return -errno;
    srv->sig.on_event = on_signal;
    if ((err = qmcd_loop_add(srv, &srv->sig, EPOLLIN)) != 0)
        return err;
    srv->tick.fd = timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
    if (srv->tick.fd < 0)
        return -errno;
    struct itimerspec its = {
        .it_interval = {0, QMCD_TICK_MS * 1000000L},
        .it_value = {0, QMCD_TICK_MS * 1000000L},
    };
    if (timerfd_settime(srv->tick.fd, 0, &its, NULL) != 0)
        return -errno;
    srv->tick.on_event = on_tick;
    if ((err = qmcd_loop_add(srv, &srv->tick, EPOLLIN)) != 0)
        return err;
    watchdog_init(srv);
    return 0;
}

void qmcd_loop_close(qmcd_server *srv)
{
    if (srv->sig.fd >= 0)
        close(srv->sig.fd);
    if (srv->tick.fd >= 0)
        close(srv->tick.fd);
    if (srv->epfd >= 0)
        close(srv->epfd);
    srv->sig.fd = srv->tick.fd = srv->epfd = -1;
}

int qmcd_loop_run(qmcd_server *srv)
{
    struct epoll_event evs[64];
    while (!srv->quit) {
        int n = epoll_wait(srv->epfd, evs, 64, -1);
        if (n < 0) {
            if (errno == EINTR)
                continue;
            qmcd_err("epoll_wait: %s", strerror(errno));
            return -errno;
        }
        for (int i = 0; i < n; i++) {
            qmcd_watch *w = evs[i].data.ptr;
            w->on_event(srv, w, evs[i].events);
        }
        /* Handlers may free connections; deferred frees happen here, after
         * every event of this round has been dispatched. */
        qmcd_conns_reap(srv);
        qmcd_modbus_reap(srv);
        if (srv->stats.n_pending)
            qmcd_stats_end_turn(&srv->stats, qmcd_now_us());
    }
    return 0;
}
