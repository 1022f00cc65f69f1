/*
 * server.h - the daemon's one context object, passed to every handler (no
 * globals), and the epoll watch every registered descriptor carries.
 */
#ifndef QMCD_SERVER_H
#define QMCD_SERVER_H

#include <stdint.h>

#include "config.h"
#include "stats.h"

typedef struct qmcd_server qmcd_server;
typedef struct qmcd_watch qmcd_watch;
typedef struct qmcd_conn qmcd_conn;
typedef struct qmcd_pool qmcd_pool;
typedef struct qmcd_seqcache qmcd_seqcache;
typedef struct qmcd_listener qmcd_listener;
typedef struct qmcd_auth qmcd_auth;
typedef struct qmcd_peers qmcd_peers;
typedef struct qmcd_modbus qmcd_modbus;
typedef struct qmcd_route qmcd_route;
typedef struct qmcd_module qmcd_module;
typedef struct qmcd_sessions qmcd_sessions;

/* The dispatch table's size: message type codes are below this. */
#define QMCD_ROUTE_TYPES 64

/* epoll_event.data.ptr points at one of these: the handler runs on the
 * loop thread with the events epoll reported. */
struct qmcd_watch {
    int fd;
    uint32_t events;           /* what is registered now */
    void (*on_event)(qmcd_server *srv, qmcd_watch *w, uint32_t events);
};

struct qmcd_server {
    qmcd_config cfg;           /* replaced whole on SIGHUP */
    qmcd_args args;
    int epfd;
    qmcd_watch sig, tick, done;   /* signalfd, timerfd, the pool's eventfd */
    qmcd_listener *listeners;
    unsigned n_listeners;
    qmcd_conn *conns;          /* doubly linked, newest first */
    qmcd_conn *dead_conns;     /* closed this round; freed after it */
    uint64_t n_conns, next_conn_id, next_job_id;
    qmcd_peers *peers;         /* connections by peer (peers.c) */
    unsigned n_refusing;       /* refused connections still lingering */
    uint64_t out_over_bytes;   /* output buffers beyond their floors (conn.c) */
    unsigned n_out_waiting;    /* connections whose streams wait for them */
    int out_wake;              /* some came free: wake the waiters */
    int shm_seal_probe;        /* ring.c: 1 sealed memfds resist punching, -1 not, 0 untried */
    int64_t refusal_log_ms;    /* last refusal logged (one line a second) */
    uint64_t refusals_unlogged;
    uint64_t sobol_table_hash;  /* computed once: it hashes the whole table */
    uint64_t n_jobs;           /* queued + running, all connections */
    qmcd_pool *pool;
    qmcd_seqcache *seqs;
    uint64_t pixel_table_bytes; /* pixels.c: sampler tables open tiles hold (max-seq-memory) */
    qmcd_sessions *sessions;   /* integration sessions, attached or parked (session_store.c) */
    qmcd_stats stats;
    qmcd_auth *auth;           /* the key and the lockout table (auth.c) */
    qmcd_modbus *modbus;       /* the Modbus bridge (modbus_bridge.h), or NULL */
    /* The dispatch table by message type, and the modules whose rows it
     * holds (producer.h; filled by modules.c from modules.h). */
    const qmcd_route *routes[QMCD_ROUTE_TYPES];
    const qmcd_module *const *modules;
    unsigned n_modules;
    int draining;              /* SIGTERM seen: no new work */
    int64_t drain_deadline_ms; /* then cancel what still runs */
    int jobs_cancelled_for_exit;
    int quit;                  /* leave the loop */
    int64_t watchdog_ms;       /* WATCHDOG=1 this often from the tick; 0: off */
    int64_t watchdog_next_ms;
};

/* CLOCK_MONOTONIC in milliseconds and microseconds. */
int64_t qmcd_now_ms(void);
int64_t qmcd_now_us(void);
/* A request received at t0_us (its read's timestamp) got its final answer
 * in this loop turn; the latency is recorded when the turn ends, one clock
 * read for every request of the turn (on pipelined small requests a clock
 * read per request was 5% of the daemon's CPU). */
void qmcd_answered(qmcd_server *srv, int64_t t0_us);

#endif
