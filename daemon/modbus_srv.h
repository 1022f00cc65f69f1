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
#include "peers.h"
#include "qmc/modbus.h"

typedef struct qmcd_mb_conn qmcd_mb_conn;
typedef struct qmcd_mb_rtu qmcd_mb_rtu;
typedef struct qmcd_mb_session qmcd_mb_session;

/* A client's address: IPv4 (mapped ones included) or IPv6.  The same
 * struct holds a peer's network (modbus_peer.c): family AF_INET (the
 * address), AF_INET6 (the /64, the rest zero) or QMCD_MB_NET_LOOPBACK. */
typedef struct qmcd_mb_peer {
    int family;
    uint8_t addr[16];
} qmcd_mb_peer;

#define QMCD_MB_NET_LOOPBACK 0xFF

typedef struct qmcd_mb_counters {
    atomic_uint_fast64_t requests, exceptions, malformed;
    atomic_uint_fast64_t conns_accepted, conns_refused, conns_open;
    /* Connections refused for modbus-max-connections-per-peer (also in
     * conns_refused); banks held now; new banks refused for
     * modbus-max-sessions-per-peer and for modbus-max-sessions. */
    atomic_uint_fast64_t conns_refused_per_peer, sessions;
    atomic_uint_fast64_t sessions_refused_per_peer, sessions_refused;
    /* Integration sessions (MODBUS.md section 9): banks with one open now,
     * the bytes they hold, and starts refused for memory. */
    atomic_uint_fast64_t integrations, integration_bytes, integrations_refused;
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
    /* A fresh bank that is never written: the answers to requests that
     * change no bank (qmc_modbus_request_writes) from clients without one. */
    qmc_modbus_session *defaults;
    qmcd_peers *net_conns;         /* connections per peer (modbus_peer.c) */
    int64_t refusal_logged_ms;     /* refusals are logged once a second */
    uint64_t refusals_unlogged;    /* ... and the others counted */
    qmcd_mb_rtu *rtus[QMCD_MAX_LISTEN]; /* serial lines */
    unsigned n_rtus;
    int draining;
} qmcd_modbus;

/* The counters as the handler reports them, taken now. */
void qmcd__modbus_env(qmcd_modbus *mb, qmc_modbus_env *env);

/* Counts one answered request: resp is the response PDU. */
void qmcd__modbus_count(qmcd_modbus *mb, const uint8_t *resp);

/* Integration memory (modbus_counters.c).  room: what a bank holding own
 * bytes may hold after a request, within per_bank and what the others
 * leave of total (the TCP transport also passes its peer's room; none:
 * UINT64_MAX).  account: counts the change from *was to the bank's usage
 * now and stores it in *was (now NULL: the bank is going, its usage goes
 * to zero). */
uint64_t qmcd__modbus_room(qmcd_modbus *mb, uint64_t per_bank, uint64_t total, uint64_t own,
                           uint64_t peer_room);
void qmcd__modbus_account(qmcd_modbus *mb, qmc_modbus_usage *was, const qmc_modbus_session *now);

/* modbus_peer.c: the peer (network) an address counts against, its name
 * for logs ("loopback", "192.0.2.7", "2001:db8::/64"), and the connections
 * each peer holds (0, or -ENOMEM from add). */
void qmcd__modbus_net_of(const qmcd_mb_peer *addr, qmcd_mb_peer *net);
/* A peer's share of total: the setting, or with 0 (the default) a quarter
 * of total, at least 1, so that lowering the total keeps room for others. */
uint64_t qmcd__modbus_share(uint64_t setting, uint64_t total);
int qmcd__modbus_net_same(const qmcd_mb_peer *a, const qmcd_mb_peer *b);
void qmcd__modbus_net_name(const qmcd_mb_peer *net, char *out, size_t n);
uint64_t qmcd__modbus_net_conns(const qmcd_modbus *mb, const qmcd_mb_peer *net);
int qmcd__modbus_net_conn_add(qmcd_modbus *mb, const qmcd_mb_peer *net);
void qmcd__modbus_net_conn_remove(qmcd_modbus *mb, const qmcd_mb_peer *net);

/* modbus_sessions.c: the banks of (address, unit).  find returns the bank,
 * or NULL when the client has none (it is never made there).  make makes
 * one for a request that writes: QMCD_MB_MADE (*slot is the new bank's),
 * or QMCD_MB_PEER_FULL (the peer holds modbus-max-sessions-per-peer),
 * QMCD_MB_TABLE_FULL (modbus-max-sessions are in use) or QMCD_MB_NO_MEMORY.
 * drop frees the bank in *slot (one made for a write the handler refused:
 * it stores nothing).  *hint caches the slot between calls of one
 * connection. */
enum { QMCD_MB_MADE = 0, QMCD_MB_PEER_FULL, QMCD_MB_TABLE_FULL, QMCD_MB_NO_MEMORY };
struct sockaddr_storage;
void qmcd__modbus_peer_key(const struct sockaddr_storage *ss, qmcd_mb_peer *key);
qmc_modbus_session *qmcd__modbus_session_find(qmcd_modbus *mb, const qmcd_mb_peer *key,
                                              uint8_t unit, int64_t now_ms, unsigned *hint);
int qmcd__modbus_session_make(qmcd_modbus *mb, const qmcd_mb_peer *key,
                              const qmcd_mb_peer *net, uint8_t unit, int64_t now_ms,
                              unsigned *hint, qmc_modbus_session **out);
void qmcd__modbus_session_drop(qmcd_modbus *mb, unsigned slot);
void qmcd__modbus_sessions_expire(qmcd_modbus *mb, int64_t now_ms, int64_t idle_ms);
/* The integration memory the bank in slot may hold after a write
 * (qmc_modbus_env.integration_bytes_max), and the accounting of what it
 * holds after one. */
uint64_t qmcd__modbus_session_room(qmcd_modbus *mb, unsigned slot);
void qmcd__modbus_session_account(qmcd_modbus *mb, unsigned slot);
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
