/*
 * modbus_srv.h - state shared by the Modbus bridge's files (private to
 * daemon/modbus*.c).
 *
 * Threads: the TCP transport runs on the loop thread.  Each serial line
 * runs a thread of its own that owns its libmodbus context and its
 * session and calls the pure handler itself; the only state it shares
 * with the loop is the counters below, which are atomics.  It reads no
 * configuration (copied at open) and no loop structure, so a SIGHUP or a
 * connection closing cannot race with it.
 */
#ifndef QMCD_MODBUS_SRV_H
#define QMCD_MODBUS_SRV_H

#include <stdatomic.h>
#include <stdint.h>

#include "listen.h"
#include "modbus_bridge.h"
#include "modbus_spec.h"
#include "qmc/modbus.h"

typedef struct qmcd_mb_conn qmcd_mb_conn;
typedef struct qmcd_mb_rtu qmcd_mb_rtu;
typedef struct qmcd_mb_session qmcd_mb_session;

/* A client's address: IPv4 (mapped ones included) or IPv6. */
typedef struct qmcd_mb_peer {
    int family;
    uint8_t addr[16];
} qmcd_mb_peer;

typedef struct qmcd_mb_counters {
    atomic_uint_fast64_t requests, exceptions, malformed;
    atomic_uint_fast64_t conns_accepted, conns_refused, conns_open;
} qmcd_mb_counters;

typedef struct qmcd_modbus {
    qmcd_server *srv;
    int64_t started_ms;            /* for the uptime counter */
    qmcd_mb_counters ctr;
    qmcd_cidr allow[QMCD_MODBUS_MAX_ALLOW];
    unsigned n_allow;              /* 0: loopback listeners only, all let in */
    qmcd_listener *listeners;      /* TCP */
    unsigned n_listeners;
    qmcd_mb_conn *conns, *dead;    /* open; closed this round */
    qmcd_mb_session *sessions;     /* TCP banks (modbus_sessions.c) */
    unsigned n_sessions, cap_sessions;
    qmcd_mb_rtu *rtus[QMCD_MAX_LISTEN]; /* serial lines */
    unsigned n_rtus;
    int draining;
} qmcd_modbus;

/* The counters as the handler reports them, taken now. */
void qmcd__modbus_env(qmcd_modbus *mb, qmc_modbus_env *env);

/* Counts one answered request: resp is the response PDU. */
void qmcd__modbus_count(qmcd_modbus *mb, const uint8_t *resp);

/* modbus_sessions.c: the bank of (peer, unit), made on first use; NULL
 * when modbus-max-sessions are in use or memory is short.  *hint caches
 * the slot between calls of one connection. */
struct sockaddr_storage;
void qmcd__modbus_peer_key(const struct sockaddr_storage *ss, qmcd_mb_peer *key);
qmc_modbus_session *qmcd__modbus_session(qmcd_modbus *mb, const qmcd_mb_peer *key,
                                         uint8_t unit, int64_t now_ms, unsigned *hint);
void qmcd__modbus_sessions_expire(qmcd_modbus *mb, int64_t now_ms, int64_t idle_ms);
void qmcd__modbus_sessions_free(qmcd_modbus *mb);

/* modbus_tcp.c */
int qmcd__modbus_tcp_open(qmcd_modbus *mb, const char *hostport, qmcd_listener *l,
                          char *why, size_t why_bytes);
int qmcd__modbus_tcp_start(qmcd_modbus *mb);
void qmcd__modbus_tcp_tick(qmcd_modbus *mb, int64_t now_ms);
void qmcd__modbus_tcp_reap(qmcd_modbus *mb);
void qmcd__modbus_tcp_close_all(qmcd_modbus *mb, const char *why);
void qmcd__modbus_tcp_close_listeners(qmcd_modbus *mb);

/* modbus_rtu.c */
int qmcd__modbus_rtu_open(qmcd_modbus *mb, const qmcd_modbus_rtu_spec *spec,
                          qmcd_mb_rtu **out, char *why, size_t why_bytes);
int qmcd__modbus_rtu_start(qmcd_mb_rtu *rtu);
const char *qmcd__modbus_rtu_name(const qmcd_mb_rtu *rtu);
/* Stops the thread (if started) and frees; NULL is a no-op. */
void qmcd__modbus_rtu_free(qmcd_mb_rtu *rtu);

#endif
