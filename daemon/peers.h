/*
 * peers.h - who a connection comes from, and how many connections each
 * peer holds (max-connections-per-peer).
 */
#ifndef QMCD_PEERS_H
#define QMCD_PEERS_H

#include <stddef.h>
#include <stdint.h>

/* A peer: an IP address for TCP (IPv4 stored as IPv4-mapped IPv6, so one
 * host is one peer on either listener family), a user id for Unix sockets
 * (SO_PEERCRED: the only identity a local client cannot vary at will; a
 * pid changes with every fork). */
enum { QMCD_PEER_IP = 1, QMCD_PEER_UID = 2 };

typedef struct qmcd_peer_key {
    uint32_t kind;               /* QMCD_PEER_IP or QMCD_PEER_UID */
    uint8_t addr[16];            /* the address, or the uid in the first 4 */
} qmcd_peer_key;

typedef struct qmcd_peers qmcd_peers;

int qmcd_peers_new(qmcd_peers **out);
void qmcd_peers_free(qmcd_peers *peers);

/* The peer of an accepted socket.  Returns 0, or -errno when the kernel
 * cannot say (the connection is then refused). */
int qmcd_peer_key_of(int fd, qmcd_peer_key *key);

/* "uid 1000" or "127.0.0.1" / "::1", for logs and ERROR messages. */
void qmcd_peer_key_name(const qmcd_peer_key *key, char *out, size_t n);

/* Connections the peer holds now. */
uint64_t qmcd_peers_count(const qmcd_peers *peers, const qmcd_peer_key *key);

/* Counts one more connection of the peer: 0, or -ENOMEM. */
int qmcd_peers_add(qmcd_peers *peers, const qmcd_peer_key *key);

/* Counts one connection less (the entry goes when it reaches zero). */
void qmcd_peers_remove(qmcd_peers *peers, const qmcd_peer_key *key);

#endif
