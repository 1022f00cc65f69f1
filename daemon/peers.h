/*
 * peers.h - who a connection comes from, the network that is (for the
 * budgets an address cannot be chosen around), and how many connections
 * (or jobs, or handshakes) each holds.
 */
#ifndef QMCD_PEERS_H
#define QMCD_PEERS_H

#include <stddef.h>
#include <stdint.h>

/* A peer: an IP address for TCP (IPv4 stored as IPv4-mapped IPv6, so one
 * host is one peer on either listener family), a user id for Unix sockets
 * (SO_PEERCRED: the only identity a local client cannot vary at will; a
 * pid changes with every fork).  A key of kind QMCD_PEER_NET is a network
 * (qmcd_net_key): what the budgets that must not be split by choosing
 * addresses count by. */
enum { QMCD_PEER_IP = 1, QMCD_PEER_UID = 2, QMCD_PEER_NET = 3 };

typedef struct qmcd_peer_key {
    uint32_t kind;               /* QMCD_PEER_IP, QMCD_PEER_UID or QMCD_PEER_NET */
    uint8_t addr[16];            /* the address, the uid in the first 4, or a
                                    network (its family in the last byte) */
} qmcd_peer_key;

/*
 * Networks (issue 22).  A client that can choose its address must not get
 * one share per address: all of loopback is one network, since any local
 * user can bind any address of 127.0.0.0/8 (and ::1); an IPv6 network is
 * the /64, the smallest a host is handed (RFC 4291's interface identifier
 * is the low 64 bits, so a single host may use all of them); an IPv4
 * address off loopback is a network of its own.  IPv4-mapped IPv6
 * addresses are IPv4.  Modbus's per-peer caps and the handshake budget of
 * the qmcd protocol (admit.c) both count by it.
 */
typedef struct qmcd_ip {
    int family;                  /* AF_INET (4 bytes), AF_INET6, or for a
                                    network also QMCD_NET_LOOPBACK */
    uint8_t addr[16];            /* a network: IPv4 4 bytes, IPv6 8, rest 0 */
} qmcd_ip;

#define QMCD_NET_LOOPBACK 0xFF

/* The network of an address (an address whose family is AF_INET or
 * AF_INET6, never mapped). */
void qmcd_net_of(const qmcd_ip *addr, qmcd_ip *net);
/* 1 when a and b are the same network. */
int qmcd_net_same(const qmcd_ip *a, const qmcd_ip *b);
/* "loopback", "192.0.2.7", "2001:db8::/64": for logs and ERRORs. */
void qmcd_net_name(const qmcd_ip *net, char *out, size_t n);
/* The table key of a network (kind QMCD_PEER_NET), for qmcd_peers_*. */
void qmcd_net_key(const qmcd_ip *net, qmcd_peer_key *key);
/* What a connection's peer counts against where networks count: its
 * network for an IP peer, itself (one uid) otherwise. */
void qmcd_peer_key_net(const qmcd_peer_key *peer, qmcd_peer_key *net);

/* A peer's share of total: the setting, or with 0 (the default) a quarter
 * of total, at least 1, so that lowering the total keeps room for three
 * other peers whatever it is set to. */
uint64_t qmcd_peer_share(uint64_t setting, uint64_t total);

typedef struct qmcd_peers qmcd_peers;

int qmcd_peers_new(qmcd_peers **out);
void qmcd_peers_free(qmcd_peers *peers);

/* The peer of an accepted socket.  Returns 0, or -errno when the kernel
 * cannot say (the connection is then refused). */
int qmcd_peer_key_of(int fd, qmcd_peer_key *key);

/* "uid 1000" or "127.0.0.1" / "::1" (a network key: as qmcd_net_name),
 * for logs and ERROR messages. */
void qmcd_peer_key_name(const qmcd_peer_key *key, char *out, size_t n);

/* Connections the peer holds now. */
uint64_t qmcd_peers_count(const qmcd_peers *peers, const qmcd_peer_key *key);

/* Counts one more connection of the peer: 0, or -ENOMEM. */
int qmcd_peers_add(qmcd_peers *peers, const qmcd_peer_key *key);

/* Counts one connection less (the entry goes when it reaches zero). */
void qmcd_peers_remove(qmcd_peers *peers, const qmcd_peer_key *key);

#endif
