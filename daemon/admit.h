/*
 * admit.h - the connection budgets (admit.c): max-connections for clients
 * past the handshake and on Unix sockets, and a budget of its own, per
 * network, for TCP connections still in the handshake.
 */
#ifndef QMCD_ADMIT_H
#define QMCD_ADMIT_H

#include <stddef.h>

#include "server.h"

/* Where a connection counts (qmcd_conn.admit). */
enum {
    QMCD_ADMIT_NONE = 0,    /* nowhere yet (being accepted) */
    QMCD_ADMIT_PREAUTH,     /* a TCP connection in the handshake: max-preauth-connections */
    QMCD_ADMIT_FULL,        /* max-connections (and max-connections-per-peer) */
    QMCD_ADMIT_REFUSED,     /* refused or evicted, lingering: QMCD_REFUSING_MAX */
};

/* At accept, a Unix-socket connection: "" when it may come in, else why
 * not (max-connections, max-connections-per-peer; counted in STATS).  A
 * TCP connection is never refused here: see qmcd_admit_victim. */
void qmcd_admit_check(qmcd_conn *c, char *why, size_t why_bytes);

/* At accept, a TCP connection about to enter the handshake budget: the
 * handshake to evict first to make room for it (its network's oldest when
 * the network holds its share; else, the budget being full, the oldest of
 * the network that holds the most), with the reason to tell it in why; or
 * NULL when there is room. */
qmcd_conn *qmcd_admit_victim(const qmcd_conn *c, char *why, size_t why_bytes);

/* Counts c where it belongs: a Unix-socket connection in max-connections,
 * a TCP one in the handshake budget.  Returns 0 or -ENOMEM. */
int qmcd_admit_take(qmcd_conn *c);

/* The handshake is done (HELLO_OK is about to go): a TCP connection moves
 * from the handshake budget into max-connections.  Returns 0, or -1 with
 * why set when max-connections or max-connections-per-peer is reached (the
 * caller fails the connection; it keeps its handshake place until then). */
int qmcd_admit_done(qmcd_conn *c, char *why, size_t why_bytes);

/* c is refused (at accept) or evicted: it leaves its budget and lingers
 * among the refusing until it closes. */
void qmcd_admit_refuse(qmcd_conn *c);

/* c closes: gives back whatever it holds. */
void qmcd_admit_release(qmcd_conn *c);

#endif
