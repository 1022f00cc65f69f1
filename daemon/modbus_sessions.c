/*
 * modbus_sessions.c - the register banks of Modbus TCP clients, one per
 * (client address, unit id).
 *
 * Why not one per connection: many Modbus TCP masters (mbpoll, SCADA
 * polling tools) open a connection per transaction, as the TCP
 * implementation guide permits, so a bank that died with its connection
 * would forget the request a moment after it was written.  Keyed by
 * address and unit id, a client keeps its bank across reconnects, and
 * clients sharing an address (behind a gateway, or processes on one host)
 * pick distinct unit ids for distinct banks, as on a serial line.
 *
 * A bank is made only by a request that writes (qmc_modbus_request_writes)
 * and that the handler accepts: reads, FC17 and FC43 from a client without
 * a bank are answered from a fresh bank that is never written
 * (mb->defaults, modbus_tcp.c), the same registers a new bank would show,
 * so a flood of reads holds no memory and takes no one's room (issue 22).
 * A peer (modbus_peer.c: loopback, an IPv6 /64, an IPv4 address) holds at
 * most modbus-max-sessions-per-peer banks, so one peer's writes cannot
 * fill modbus-max-sessions either.  Past either limit a new bank is
 * refused (exception 06) rather than evicting anyone's state: every bank
 * holds a write its client made.  A bank unused for idle-timeout-ms is
 * freed, with the integration session it may hold.  Each bank's
 * integration memory is counted here (its last qmc_modbus_usage), so that
 * a write is told its room within modbus-integration-memory, the peer's
 * share and the total.  Loop thread only.
 *
 * Must not: interpret registers.
 */
#define _GNU_SOURCE
#include <netinet/in.h>
#include <stdlib.h>
#include <string.h>

#include "log.h"
#include "modbus_srv.h"

struct qmcd_mb_session {
    qmcd_mb_peer key;
    qmcd_mb_peer net;            /* the peer whose share it is in */
    uint8_t unit;
    qmc_modbus_session *sess;
    int64_t used_ms;
    qmc_modbus_usage usage;      /* its integration's, as last counted */
};

void qmcd__modbus_peer_key(const struct sockaddr_storage *ss, qmcd_mb_peer *key)
{
    memset(key, 0, sizeof *key);
    if (ss->ss_family == AF_INET6) {
        const struct in6_addr *a = &((const struct sockaddr_in6 *)ss)->sin6_addr;
        if (IN6_IS_ADDR_V4MAPPED(a)) {
            key->family = AF_INET;
            memcpy(key->addr, a->s6_addr + 12, 4);
        } else {
            key->family = AF_INET6;
            memcpy(key->addr, a->s6_addr, 16);
        }
    } else {
        key->family = AF_INET;
        memcpy(key->addr, &((const struct sockaddr_in *)ss)->sin_addr, 4);
    }
}

static int same(const qmcd_mb_session *e, const qmcd_mb_peer *key, uint8_t unit)
{
    return e->sess && e->unit == unit && e->key.family == key->family &&
           memcmp(e->key.addr, key->addr, sizeof key->addr) == 0;
}

qmc_modbus_session *qmcd__modbus_session_find(qmcd_modbus *mb, const qmcd_mb_peer *key,
                                              uint8_t unit, int64_t now_ms, unsigned *hint)
{
    qmcd_mb_session *e;
    if (*hint < mb->n_sessions && same(e = &mb->sessions[*hint], key, unit)) {
        e->used_ms = now_ms;
        return e->sess;
    }
    for (unsigned i = 0; i < mb->n_sessions; i++) {
        e = &mb->sessions[i];
        if (same(e, key, unit)) {
            *hint = i;
            e->used_ms = now_ms;
            return e->sess;
        }
    }
    return NULL;
}

int qmcd__modbus_session_make(qmcd_modbus *mb, const qmcd_mb_peer *key,
                              const qmcd_mb_peer *net, uint8_t unit, int64_t now_ms,
                              unsigned *hint, qmc_modbus_session **out)
{
    *out = NULL;
    const qmcd_config *cfg = &mb->srv->cfg;
    unsigned free_slot = mb->n_sessions;
    uint64_t held = 0;
    for (unsigned i = 0; i < mb->n_sessions; i++) {
        qmcd_mb_session *e = &mb->sessions[i];
        if (!e->sess) {
            if (free_slot == mb->n_sessions)
                free_slot = i;
        } else if (qmcd__modbus_net_same(&e->net, net)) {
            held++;
        }
    }
    if (held >= qmcd__modbus_share(cfg->modbus_max_sessions_per_peer, cfg->modbus_max_sessions))
        return QMCD_MB_PEER_FULL;
    if (atomic_load_explicit(&mb->ctr.sessions, memory_order_relaxed) >=
        cfg->modbus_max_sessions)
        return QMCD_MB_TABLE_FULL; /* a SIGHUP may have lowered it below n_sessions */
    if (free_slot == mb->n_sessions) {
        if (mb->n_sessions == mb->cap_sessions) {
            unsigned grow = mb->cap_sessions ? 2 * mb->cap_sessions : 16;
            if (grow > cfg->modbus_max_sessions)
                grow = (unsigned)cfg->modbus_max_sessions;
            if (grow <= mb->cap_sessions)
                grow = mb->cap_sessions + 1;
            qmcd_mb_session *more = realloc(mb->sessions, grow * sizeof *more);
            if (!more)
                return QMCD_MB_NO_MEMORY;
            memset(more + mb->cap_sessions, 0, (grow - mb->cap_sessions) * sizeof *more);
            mb->sessions = more;
            mb->cap_sessions = grow;
        }
        mb->n_sessions++;
    }
    qmcd_mb_session *e = &mb->sessions[free_slot];
    if (qmc_modbus_session_new(&e->sess) != 0) {
        while (mb->n_sessions && !mb->sessions[mb->n_sessions - 1].sess)
            mb->n_sessions--;
        return QMCD_MB_NO_MEMORY;
    }
    e->key = *key;
    e->net = *net;
    e->unit = unit;
    memset(&e->usage, 0, sizeof e->usage);
    e->used_ms = now_ms;
    *hint = free_slot;
    *out = e->sess;
    atomic_fetch_add_explicit(&mb->ctr.sessions, 1, memory_order_relaxed);
    return QMCD_MB_MADE;
}

/*
 * The room of the bank in slot: modbus-integration-memory, and what the
 * other banks leave of modbus-integration-memory-total and of its peer's
 * share (modbus-integration-memory-per-peer; 0: a quarter of the total).
 * What the bank holds itself counts as room: a start closes its session
 * first.  A pass over the banks, for writes only (at most
 * modbus-max-sessions of them).
 */
uint64_t qmcd__modbus_session_room(qmcd_modbus *mb, unsigned slot)
{
    const qmcd_config *cfg = &mb->srv->cfg;
    if (slot >= mb->n_sessions || !mb->sessions[slot].sess)
        return 0;
    const qmcd_mb_session *me = &mb->sessions[slot];
    uint64_t peer = 0;
    for (unsigned i = 0; i < mb->n_sessions; i++) {
        const qmcd_mb_session *e = &mb->sessions[i];
        if (i != slot && e->sess && qmcd__modbus_net_same(&e->net, &me->net))
            peer += e->usage.integration_bytes;
    }
    uint64_t share = qmcd__modbus_share(cfg->modbus_integration_memory_per_peer,
                                        cfg->modbus_integration_memory_total);
    uint64_t peer_room = share > peer ? share - peer : 0;
    return qmcd__modbus_room(mb, cfg->modbus_integration_memory,
                             cfg->modbus_integration_memory_total,
                             me->usage.integration_bytes, peer_room);
}

void qmcd__modbus_session_account(qmcd_modbus *mb, unsigned slot)
{
    if (slot < mb->n_sessions && mb->sessions[slot].sess)
        qmcd__modbus_account(mb, &mb->sessions[slot].usage, mb->sessions[slot].sess);
}

static void drop(qmcd_modbus *mb, qmcd_mb_session *e)
{
    qmcd__modbus_account(mb, &e->usage, NULL);
    qmc_modbus_session_free(e->sess);
    e->sess = NULL;
    atomic_fetch_sub_explicit(&mb->ctr.sessions, 1, memory_order_relaxed);
}

void qmcd__modbus_session_drop(qmcd_modbus *mb, unsigned slot)
{
    if (slot < mb->n_sessions && mb->sessions[slot].sess)
        drop(mb, &mb->sessions[slot]);
    while (mb->n_sessions && !mb->sessions[mb->n_sessions - 1].sess)
        mb->n_sessions--;
}

void qmcd__modbus_sessions_expire(qmcd_modbus *mb, int64_t now_ms, int64_t idle_ms)
{
    for (unsigned i = 0; i < mb->n_sessions; i++) {
        qmcd_mb_session *e = &mb->sessions[i];
        if (e->sess && now_ms - e->used_ms >= idle_ms)
            drop(mb, e);
    }
    while (mb->n_sessions && !mb->sessions[mb->n_sessions - 1].sess)
        mb->n_sessions--;
}

void qmcd__modbus_sessions_free(qmcd_modbus *mb)
{
    for (unsigned i = 0; i < mb->n_sessions; i++)
        if (mb->sessions[i].sess)
            drop(mb, &mb->sessions[i]);
    free(mb->sessions);
    mb->sessions = NULL;
    mb->n_sessions = mb->cap_sessions = 0;
}
