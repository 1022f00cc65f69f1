/*
 * modbus_peer.c - who a Modbus TCP client is, for its share of the
 * server: the *peer* that modbus-max-connections-per-peer and
 * modbus-max-sessions-per-peer count, and the count of connections each
 * peer holds.
 *
 * A peer is the part of an address one party controls (issue 22): all of
 * loopback is one peer, since any local user can bind any address of
 * 127.0.0.0/8 (and ::1); an IPv6 peer is its /64, the smallest network a
 * host is handed (RFC 4291's interface identifier is the low 64 bits, so a
 * single host may use all of them); an IPv4 address off loopback is a peer
 * of its own.  IPv4-mapped IPv6 addresses are IPv4, so one host is one
 * peer on either listener family.
 *
 * The connection counts live in a peers.c table keyed by the peer's
 * network bytes: its size follows the open connections, never the history
 * of who connected.
 *
 * Must not: accept, refuse or close anything (modbus_tcp.c does), or
 * interpret registers.
 */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <netinet/in.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>

#include "modbus_srv.h"

void qmcd__modbus_net_of(const qmcd_mb_peer *addr, qmcd_mb_peer *net)
{
    memset(net, 0, sizeof *net);
    static const uint8_t v6_loop[16] = {[15] = 1};
    if ((addr->family == AF_INET && addr->addr[0] == 127) ||
        (addr->family == AF_INET6 && memcmp(addr->addr, v6_loop, 16) == 0)) {
        net->family = QMCD_MB_NET_LOOPBACK;
        return;
    }
    net->family = addr->family;
    if (addr->family == AF_INET6)
        memcpy(net->addr, addr->addr, 8); /* the /64 */
    else
        memcpy(net->addr, addr->addr, 4);
}

uint64_t qmcd__modbus_share(uint64_t setting, uint64_t total)
{
    if (setting)
        return setting;
    return total / 4 ? total / 4 : 1;
}

int qmcd__modbus_net_same(const qmcd_mb_peer *a, const qmcd_mb_peer *b)
{
    return a->family == b->family && memcmp(a->addr, b->addr, sizeof a->addr) == 0;
}

void qmcd__modbus_net_name(const qmcd_mb_peer *net, char *out, size_t n)
{
    char host[INET6_ADDRSTRLEN] = "?";
    if (net->family == QMCD_MB_NET_LOOPBACK) {
        snprintf(out, n, "loopback");
    } else if (net->family == AF_INET6) {
        inet_ntop(AF_INET6, net->addr, host, sizeof host);
        snprintf(out, n, "%s/64", host);
    } else {
        inet_ntop(AF_INET, net->addr, host, sizeof host);
        snprintf(out, n, "%s", host);
    }
}

/* The peers.c key of a network: its family in the address's last byte,
 * which no network uses (IPv6 keeps 8 bytes, IPv4 4). */
static void table_key(const qmcd_mb_peer *net, qmcd_peer_key *key)
{
    memset(key, 0, sizeof *key);
    key->kind = QMCD_PEER_IP;
    memcpy(key->addr, net->addr, 8);
    key->addr[15] = (uint8_t)net->family;
}

uint64_t qmcd__modbus_net_conns(const qmcd_modbus *mb, const qmcd_mb_peer *net)
{
    qmcd_peer_key key;
    table_key(net, &key);
    return qmcd_peers_count(mb->net_conns, &key);
}

int qmcd__modbus_net_conn_add(qmcd_modbus *mb, const qmcd_mb_peer *net)
{
    qmcd_peer_key key;
    table_key(net, &key);
    return qmcd_peers_add(mb->net_conns, &key);
}

void qmcd__modbus_net_conn_remove(qmcd_modbus *mb, const qmcd_mb_peer *net)
{
    qmcd_peer_key key;
    table_key(net, &key);
    qmcd_peers_remove(mb->net_conns, &key);
}
