/*
 * peers.c - who a client is, for its share of the server: its peer key
 * (an address, or a uid), the network an address belongs to (the one rule
 * for every budget an address must not be chosen around: Modbus's caps,
 * the qmcd handshake's), a share's default, and counts by key - so that
 * max-connections-per-peer keeps one host (or one local user) from taking
 * every slot of max-connections: a peer opening a thousand sockets is
 * refused past its own limit while everyone else still gets in.
 *
 * A hash table of counts, chained, with an entry only while the key holds
 * something: its size follows the live connections (or jobs), never the
 * history of who connected.
 *
 * This file must not accept, refuse or close anything (conn_accept.c,
 * admit.c and modbus_tcp.c do).
 */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>

#include "peers.h"

#define N_BUCKETS 1024u

typedef struct peer_entry {
    struct peer_entry *next;
    qmcd_peer_key key;
    uint64_t conns;
} peer_entry;

struct qmcd_peers {
    peer_entry *buckets[N_BUCKETS];
};

int qmcd_peers_new(qmcd_peers **out)
{
    *out = calloc(1, sizeof **out);
    return *out ? 0 : -ENOMEM;
}

void qmcd_peers_free(qmcd_peers *peers)
{
    if (!peers)
        return;
    for (unsigned i = 0; i < N_BUCKETS; i++)
        while (peers->buckets[i]) {
            peer_entry *e = peers->buckets[i];
            peers->buckets[i] = e->next;
            free(e);
        }
    free(peers);
}

int qmcd_peer_key_of(int fd, qmcd_peer_key *key)
{
    memset(key, 0, sizeof *key);
    struct sockaddr_storage ss;
    socklen_t len = sizeof ss;
    if (getpeername(fd, (struct sockaddr *)&ss, &len) != 0)
        return -errno;
    if (ss.ss_family == AF_UNIX) {
        struct ucred cred;
        socklen_t clen = sizeof cred;
        if (getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cred, &clen) != 0)
            return -errno;
        key->kind = QMCD_PEER_UID;
        uint32_t uid = (uint32_t)cred.uid;
        memcpy(key->addr, &uid, sizeof uid);
        return 0;
    }
    key->kind = QMCD_PEER_IP;
    if (ss.ss_family == AF_INET6) {
        memcpy(key->addr, &((struct sockaddr_in6 *)&ss)->sin6_addr, 16);
        return 0;
    }
    if (ss.ss_family == AF_INET) {
        key->addr[10] = key->addr[11] = 0xff; /* ::ffff:a.b.c.d */
        memcpy(key->addr + 12, &((struct sockaddr_in *)&ss)->sin_addr, 4);
        return 0;
    }
    return -EAFNOSUPPORT;
}

void qmcd_peer_key_name(const qmcd_peer_key *key, char *out, size_t n)
{
    if (key->kind == QMCD_PEER_UID) {
        uint32_t uid;
        memcpy(&uid, key->addr, sizeof uid);
        snprintf(out, n, "uid %u", uid);
        return;
    }
    if (key->kind == QMCD_PEER_NET) {
        qmcd_ip net;
        memset(&net, 0, sizeof net);
        net.family = key->addr[15];
        memcpy(net.addr, key->addr, 8);
        qmcd_net_name(&net, out, n);
        return;
    }
    static const uint8_t v4_prefix[12] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0xff, 0xff};
    char host[INET6_ADDRSTRLEN] = "?";
    if (memcmp(key->addr, v4_prefix, sizeof v4_prefix) == 0)
        inet_ntop(AF_INET, key->addr + 12, host, sizeof host);
    else
        inet_ntop(AF_INET6, key->addr, host, sizeof host);
    snprintf(out, n, "%s", host);
}

/* ---- networks (peers.h) ------------------------------------------------------- */

void qmcd_net_of(const qmcd_ip *addr, qmcd_ip *net)
{
    memset(net, 0, sizeof *net);
    static const uint8_t v6_loop[16] = {[15] = 1};
    if ((addr->family == AF_INET && addr->addr[0] == 127) ||
        (addr->family == AF_INET6 && memcmp(addr->addr, v6_loop, 16) == 0)) {
        net->family = QMCD_NET_LOOPBACK;
        return;
    }
    net->family = addr->family;
    if (addr->family == AF_INET6)
        memcpy(net->addr, addr->addr, 8); /* the /64 */
    else
        memcpy(net->addr, addr->addr, 4);
}

int qmcd_net_same(const qmcd_ip *a, const qmcd_ip *b)
{
    return a->family == b->family && memcmp(a->addr, b->addr, sizeof a->addr) == 0;
}

void qmcd_net_name(const qmcd_ip *net, char *out, size_t n)
{
    char host[INET6_ADDRSTRLEN] = "?";
    if (net->family == QMCD_NET_LOOPBACK) {
        snprintf(out, n, "loopback");
    } else if (net->family == AF_INET6) {
        inet_ntop(AF_INET6, net->addr, host, sizeof host);
        snprintf(out, n, "%s/64", host);
    } else {
        inet_ntop(AF_INET, net->addr, host, sizeof host);
        snprintf(out, n, "%s", host);
    }
}

/* A network's family rides in the key's last byte, which no network uses
 * (IPv6 keeps 8 bytes, IPv4 4). */
void qmcd_net_key(const qmcd_ip *net, qmcd_peer_key *key)
{
    memset(key, 0, sizeof *key);
    key->kind = QMCD_PEER_NET;
    memcpy(key->addr, net->addr, 8);
    key->addr[15] = (uint8_t)net->family;
}

void qmcd_peer_key_net(const qmcd_peer_key *peer, qmcd_peer_key *net)
{
    static const uint8_t v4_prefix[12] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0xff, 0xff};
    if (peer->kind != QMCD_PEER_IP) {
        *net = *peer;
        return;
    }
    qmcd_ip a, n;
    memset(&a, 0, sizeof a);
    if (memcmp(peer->addr, v4_prefix, sizeof v4_prefix) == 0) {
        a.family = AF_INET;
        memcpy(a.addr, peer->addr + 12, 4);
    } else {
        a.family = AF_INET6;
        memcpy(a.addr, peer->addr, 16);
    }
    qmcd_net_of(&a, &n);
    qmcd_net_key(&n, net);
}

uint64_t qmcd_peer_share(uint64_t setting, uint64_t total)
{
    if (setting)
        return setting;
    return total / 4 ? total / 4 : 1;
}

/* ---- counts ------------------------------------------------------------------------ */

/* FNV-1a over the key's bytes. */
static unsigned bucket_of(const qmcd_peer_key *key)
{
    uint64_t h = 1469598103934665603ull;
    const uint8_t *p = (const uint8_t *)key;
    for (size_t i = 0; i < sizeof *key; i++)
        h = (h ^ p[i]) * 1099511628211ull;
    return (unsigned)(h % N_BUCKETS);
}

static peer_entry **find(qmcd_peers *peers, const qmcd_peer_key *key)
{
    peer_entry **link = &peers->buckets[bucket_of(key)];
    while (*link && memcmp(&(*link)->key, key, sizeof *key) != 0)
        link = &(*link)->next;
    return link;
}

uint64_t qmcd_peers_count(const qmcd_peers *peers, const qmcd_peer_key *key)
{
    peer_entry **link = find((qmcd_peers *)peers, key);
    return *link ? (*link)->conns : 0;
}

int qmcd_peers_add(qmcd_peers *peers, const qmcd_peer_key *key)
{
    peer_entry **link = find(peers, key);
    if (!*link) {
        peer_entry *e = calloc(1, sizeof *e);
        if (!e)
            return -ENOMEM;
        e->key = *key;
        *link = e;
    }
    (*link)->conns++;
    return 0;
}

void qmcd_peers_remove(qmcd_peers *peers, const qmcd_peer_key *key)
{
    peer_entry **link = find(peers, key);
    peer_entry *e = *link;
    if (!e)
        return;
    if (--e->conns == 0) {
        *link = e->next;
        free(e);
    }
}
