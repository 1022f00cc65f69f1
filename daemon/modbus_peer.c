/*
 * modbus_peer.c - the connections each Modbus TCP peer holds, for
 * modbus-max-connections-per-peer.
 *
 * A peer is the network of an address, by peers.h's one rule (issue 22):
 * all of loopback, an IPv6 /64, an IPv4 address off loopback.  The counts
 * live in a peers.c table keyed by the network: its size follows the open
 * connections, never the history of who connected.
 *
 * Must not: accept, refuse or close anything (modbus_tcp.c does), or
 * interpret registers.
 */
#include "modbus_srv.h"

uint64_t qmcd__modbus_net_conns(const qmcd_modbus *mb, const qmcd_mb_peer *net)
{
    qmcd_peer_key key;
    qmcd_net_key(net, &key);
    return qmcd_peers_count(mb->net_conns, &key);
}

int qmcd__modbus_net_conn_add(qmcd_modbus *mb, const qmcd_mb_peer *net)
{
    qmcd_peer_key key;
    qmcd_net_key(net, &key);
    return qmcd_peers_add(mb->net_conns, &key);
}

void qmcd__modbus_net_conn_remove(qmcd_modbus *mb, const qmcd_mb_peer *net)
{
    qmcd_peer_key key;
    qmcd_net_key(net, &key);
    qmcd_peers_remove(mb->net_conns, &key);
}
