/*
 * peers.c - connection counts by peer, so that max-connections-per-peer
 * keeps one host (or one local user) from taking every slot of
 * max-connections: a peer opening a thousand sockets is refused past its
 * own limit while everyone else still gets in.
 *
 * A hash table of counts, chained, with an entry only while the peer holds
 * a connection: its size follows the live connections, never the history
 * of who connected.
 *
 * This file must not accept, refuse or close anything (conn.c does).
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
    static const uint8_t v4_prefix[12] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0xff, 0xff};
    char host[INET6_ADDRSTRLEN] = "?";
    if (memcmp(key->addr, v4_prefix, sizeof v4_prefix) == 0)
        inet_ntop(AF_INET, key->addr + 12, host, sizeof host);
    else
        inet_ntop(AF_INET6, key->addr, host, sizeof host);
    snprintf(out, n, "%s", host);
}

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
