/*
 * admit.c - the connection budgets: where a connection counts, and which
 * one gives up its place when a budget is full.
 *
 * Two budgets, so that clients without the key can never take the places
 * of the others (issue 22, finding 1):
 *   - max-connections, and max-connections-per-peer by peer (an address,
 *     or a uid): connections past the handshake, and every Unix-socket
 *     connection from its accept (the socket file's permissions let it in
 *     already, and a uid is a peer that cannot multiply itself);
 *   - max-preauth-connections, and a share of it per network (peers.h:
 *     all of loopback, an IPv6 /64, an IPv4 address off loopback): TCP
 *     connections still in the handshake, that is before HELLO_OK - with a
 *     key, before a good proof.  A TCP connection moves from this budget
 *     into the first at HELLO_OK, when the first has room (else it is
 *     refused then, like a Unix client at accept).
 * The handshake budget never refuses a newcomer: when the newcomer's
 * network holds its share, that network's oldest handshake is closed to
 * make room; when the whole budget is full, the oldest handshake of the
 * network holding the most.  A flood thus evicts itself, and a client
 * from another network - a key holder, say - always gets a place and keeps
 * it through its handshake: only a network at its share, or the busiest,
 * loses places.  A client of the flooding network (another local user,
 * when the flood comes from loopback) competes with the flood: its
 * handshake survives unless a share's worth of newer ones arrive from its
 * network before its proof does.
 *
 * The handshakes are kept on one list, oldest first, so the choice is a
 * walk of at most max-preauth-connections entries, made only when a
 * budget is full.
 *
 * This file counts and chooses; it never sends to, fails or closes a
 * connection (conn_accept.c evicts, auth.c refuses at HELLO_OK, conn.c
 * closes), and calls nothing of theirs.
 */
#include <errno.h>
#include <stdio.h>
#include <string.h>

#include "admit.h"
#include "conn.h"
#include "peers.h"

/* ---- the handshake list ------------------------------------------------------ */

static void preauth_append(qmcd_conn *c)
{
    qmcd_server *srv = c->srv;
    c->pa_next = NULL;
    c->pa_prev = srv->preauth_tail;
    if (srv->preauth_tail)
        srv->preauth_tail->pa_next = c;
    else
        srv->preauth_head = c;
    srv->preauth_tail = c;
    srv->n_preauth++;
}

/* c leaves the handshake budget (done, refused or closed). */
static void preauth_leave(qmcd_conn *c)
{
    qmcd_server *srv = c->srv;
    if (c->pa_prev)
        c->pa_prev->pa_next = c->pa_next;
    else
        srv->preauth_head = c->pa_next;
    if (c->pa_next)
        c->pa_next->pa_prev = c->pa_prev;
    else
        srv->preauth_tail = c->pa_prev;
    c->pa_prev = c->pa_next = NULL;
    srv->n_preauth--;
    qmcd_peers_remove(srv->preauth_nets, &c->net_key);
    c->admit = QMCD_ADMIT_NONE;
}

/* ---- accept ------------------------------------------------------------------------ */

/* The refusal of max-connections or max-connections-per-peer ("" when c
 * fits); the second is counted in STATS here, every refusal where it is
 * made. */
static void check_full(qmcd_conn *c, char *why, size_t n)
{
    qmcd_server *srv = c->srv;
    why[0] = '\0';
    if (srv->n_conns >= srv->cfg.max_connections) {
        snprintf(why, n, "max-connections (%llu) reached; try later",
                 (unsigned long long)srv->cfg.max_connections);
    } else if (qmcd_peers_count(srv->peers, &c->peer_key) >=
               srv->cfg.max_connections_per_peer) {
        srv->stats.peer_conn_refusals++;
        char who[64];
        qmcd_peer_key_name(&c->peer_key, who, sizeof who);
        snprintf(why, n, "max-connections-per-peer (%llu) reached for %s; close some "
                 "connections or try later",
                 (unsigned long long)srv->cfg.max_connections_per_peer, who);
    }
}

void qmcd_admit_check(qmcd_conn *c, char *why, size_t n)
{
    if (c->unix_socket)
        check_full(c, why, n);
    else
        why[0] = '\0';
}

qmcd_conn *qmcd_admit_victim(const qmcd_conn *c, char *why, size_t n)
{
    qmcd_server *srv = c->srv;
    const uint64_t total = srv->cfg.max_preauth_connections;
    const uint64_t share = qmcd_peer_share(srv->cfg.max_preauth_connections_per_peer, total);
    char name[64];
    if (qmcd_peers_count(srv->preauth_nets, &c->net_key) >= share) {
        qmcd_conn *v = srv->preauth_head;
        while (v && memcmp(&v->net_key, &c->net_key, sizeof v->net_key) != 0)
            v = v->pa_next;
        if (v) {
            qmcd_peer_key_name(&v->net_key, name, sizeof name);
            snprintf(why, n, "max-preauth-connections-per-peer (%llu) reached for %s: this "
                     "handshake, its oldest, is closed to make room for a newer one; "
                     "connect again", (unsigned long long)share, name);
            return v;
        }
    }
    if (srv->n_preauth < total || !srv->preauth_head)
        return NULL;
    /* Full: the oldest handshake of the network that holds the most. */
    uint64_t most = 0;
    for (qmcd_conn *v = srv->preauth_head; v; v = v->pa_next) {
        uint64_t held = qmcd_peers_count(srv->preauth_nets, &v->net_key);
        if (held > most)
            most = held;
    }
    qmcd_conn *v = srv->preauth_head;
    while (v->pa_next && qmcd_peers_count(srv->preauth_nets, &v->net_key) < most)
        v = v->pa_next;
    qmcd_peer_key_name(&v->net_key, name, sizeof name);
    snprintf(why, n, "max-preauth-connections (%llu) reached: this handshake, the oldest of "
             "%s, the network holding the most, is closed to make room; connect again",
             (unsigned long long)total, name);
    return v;
}

int qmcd_admit_take(qmcd_conn *c)
{
    qmcd_server *srv = c->srv;
    if (c->unix_socket) {
        if (qmcd_peers_add(srv->peers, &c->peer_key) != 0)
            return -ENOMEM;
        srv->n_conns++;
        c->admit = QMCD_ADMIT_FULL;
        return 0;
    }
    if (qmcd_peers_add(srv->preauth_nets, &c->net_key) != 0)
        return -ENOMEM;
    preauth_append(c);
    c->admit = QMCD_ADMIT_PREAUTH;
    return 0;
}

/* ---- later -------------------------------------------------------------------------- */

int qmcd_admit_done(qmcd_conn *c, char *why, size_t n)
{
    if (c->admit != QMCD_ADMIT_PREAUTH)
        return 0; /* a Unix socket: counted since its accept */
    qmcd_server *srv = c->srv;
    check_full(c, why, n);
    if (why[0]) {
        srv->stats.conns_rejected++;
        return -1;
    }
    if (qmcd_peers_add(srv->peers, &c->peer_key) != 0) {
        snprintf(why, n, "out of memory");
        return -1;
    }
    preauth_leave(c);
    srv->n_conns++;
    c->admit = QMCD_ADMIT_FULL;
    return 0;
}

void qmcd_admit_refuse(qmcd_conn *c)
{
    qmcd_admit_release(c);
    c->admit = QMCD_ADMIT_REFUSED;
    c->srv->n_refusing++;
}

void qmcd_admit_release(qmcd_conn *c)
{
    qmcd_server *srv = c->srv;
    switch (c->admit) {
    case QMCD_ADMIT_PREAUTH:
        preauth_leave(c);
        break;
    case QMCD_ADMIT_FULL:
        srv->n_conns--;
        qmcd_peers_remove(srv->peers, &c->peer_key);
        break;
    case QMCD_ADMIT_REFUSED:
        srv->n_refusing--;
        break;
    default:
        break;
    }
    c->admit = QMCD_ADMIT_NONE;
}
