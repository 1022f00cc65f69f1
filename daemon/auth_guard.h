/*
 * auth_guard.h - how fast a network's key proofs are checked (auth_guard.c,
 * docs/SECURITY.md "Guessing"): wrong proofs make the next ones from the
 * same network wait, longer each time, and nobody is ever refused.
 */
#ifndef QMCD_AUTH_GUARD_H
#define QMCD_AUTH_GUARD_H

#include <stdint.h>

#include "config.h"
#include "peers.h"

/* Networks whose failures are remembered at once. */
#define QMCD_AUTH_GUARD_NETS 256

/* The first delay, once a network has made auth-max-failures wrong
 * proofs; each further failure doubles it, up to auth-delay-max-ms. */
#define QMCD_AUTH_DELAY_FIRST_MS 100

typedef struct qmcd_auth_net {
    qmcd_peer_key net;           /* kind 0: the slot is free */
    uint64_t failures;           /* within auth-lockout-ms of each other */
    int64_t last_fail_ms;
    uint64_t held;               /* proofs held back since the last failure
                                    (the log says so at powers of two) */
} qmcd_auth_net;

/* The table; zero it to start (caller-allocated, no heap). */
typedef struct qmcd_auth_guard {
    qmcd_auth_net nets[QMCD_AUTH_GUARD_NETS];
} qmcd_auth_guard;

/* The wait that `failures` wrong proofs within the window impose on the
 * network's next proof: 0 below auth-max-failures, then
 * QMCD_AUTH_DELAY_FIRST_MS doubling per failure, at most
 * auth-delay-max-ms. */
int64_t qmcd_auth_guard_delay_ms(uint64_t failures, const qmcd_config *cfg);

/* When a proof from net may be checked: now, or later while the
 * network's last wrong proof is more recent than its delay. */
int64_t qmcd_auth_guard_open_ms(const qmcd_auth_guard *g, const qmcd_peer_key *net,
                                const qmcd_config *cfg, int64_t now_ms);

/* A proof from net is held back until open_ms: counts it, and returns how
 * many were held back since the network's last failure. */
uint64_t qmcd_auth_guard_held(qmcd_auth_guard *g, const qmcd_peer_key *net);

/* A wrong proof from net at now_ms: counts it (failures more than
 * auth-lockout-ms older than it are forgotten first) and returns the
 * failures now counted; *delay_ms is the wait it imposes. */
uint64_t qmcd_auth_guard_failed(qmcd_auth_guard *g, const qmcd_peer_key *net,
                                const qmcd_config *cfg, int64_t now_ms, int64_t *delay_ms);

#endif
