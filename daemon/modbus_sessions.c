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
 * A bank unused for idle-timeout-ms is freed.  When modbus-max-sessions
 * banks are all in use a new client gets exception 06 (server busy) rather
 * than evicting someone's state.  Loop thread only.
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
    uint8_t unit;
    qmc_modbus_session *sess;
    int64_t used_ms;
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

qmc_modbus_session *qmcd__modbus_session(qmcd_modbus *mb, const qmcd_mb_peer *key,
                                         uint8_t unit, int64_t now_ms, unsigned *hint)
{
    qmcd_mb_session *e;
    if (*hint < mb->n_sessions && same(e = &mb->sessions[*hint], key, unit)) {
        e->used_ms = now_ms;
        return e->sess;
    }
    unsigned free_slot = mb->n_sessions;
    for (unsigned i = 0; i < mb->n_sessions; i++) {
        e = &mb->sessions[i];
        if (same(e, key, unit)) {
            *hint = i;
            e->used_ms = now_ms;
            return e->sess;
        }
        if (!e->sess && free_slot == mb->n_sessions)
            free_slot = i;
    }
    if (free_slot == mb->n_sessions) {
        uint64_t cap = mb->srv->cfg.modbus_max_sessions;
        if (mb->n_sessions >= cap)
            return NULL;
        if (mb->n_sessions == mb->cap_sessions) {
            unsigned grow = mb->cap_sessions ? 2 * mb->cap_sessions : 16;
            if (grow > cap)
                grow = (unsigned)cap;
            qmcd_mb_session *more = realloc(mb->sessions, grow * sizeof *more);
            if (!more)
                return NULL;
            memset(more + mb->cap_sessions, 0, (grow - mb->cap_sessions) * sizeof *more);
            mb->sessions = more;
            mb->cap_sessions = grow;
        }
        mb->n_sessions++;
    }
    e = &mb->sessions[free_slot];
    if (qmc_modbus_session_new(&e->sess) != 0)
        return NULL;
    e->key = *key;
    e->unit = unit;
    e->used_ms = now_ms;
    *hint = free_slot;
    return e->sess;
}

void qmcd__modbus_sessions_expire(qmcd_modbus *mb, int64_t now_ms, int64_t idle_ms)
{
    for (unsigned i = 0; i < mb->n_sessions; i++) {
        qmcd_mb_session *e = &mb->sessions[i];
        if (e->sess && now_ms - e->used_ms >= idle_ms) {
            qmc_modbus_session_free(e->sess);
            e->sess = NULL;
        }
    }
    while (mb->n_sessions && !mb->sessions[mb->n_sessions - 1].sess)
        mb->n_sessions--;
}

void qmcd__modbus_sessions_free(qmcd_modbus *mb)
{
    for (unsigned i = 0; i < mb->n_sessions; i++)
        qmc_modbus_session_free(mb->sessions[i].sess);
    free(mb->sessions);
    mb->sessions = NULL;
    mb->n_sessions = mb->cap_sessions = 0;
}
