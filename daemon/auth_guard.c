/*
 * auth_guard.c - slows key guessing without locking anyone out (issue 22,
 * finding 3; docs/SECURITY.md has the numbers).
 *
 * The lockout this replaces refused an address's HELLOs after
 * auth-max-failures wrong proofs: anyone who shares the address (every
 * local user on loopback, everyone behind a NAT) could lock a key holder
 * out with five bad proofs, and proofs for challenges collected before the
 * lockout were still checked.  Now failures are counted per *network*
 * (peers.h: loopback, an IPv6 /64, an IPv4 address) where proofs are
 * checked, and they never cause a refusal: from the auth-max-failures-th
 * wrong proof on, the network's next proofs wait before they are checked,
 * QMCD_AUTH_DELAY_FIRST_MS after its last failure, doubling with each
 * failure up to auth-delay-max-ms.  A right proof is checked like any
 * other once its wait is over, and accepted.  Every proof that arrives
 * while the network waits is checked at the same moment (auth.c holds each
 * until the time computed when it arrived), so the wait costs a key holder
 * at most auth-delay-max-ms, while a guesser gets at most one share of
 * outstanding handshakes (max-preauth-connections-per-peer: the challenges
 * a network can hold at once) checked per wait.
 *
 * Failures of a network more than auth-lockout-ms apart are forgotten; a
 * success clears nothing (the count is the network's, not one client's:
 * a key holder's success must not hand a guesser sharing its network
 * fresh free tries).  The table is fixed, QMCD_AUTH_GUARD_NETS networks,
 * so a flood of networks costs no memory: a new one takes a free slot, or
 * the one whose wait is over and whose last failure is oldest, or failing
 * that the one whose last failure is oldest.
 *
 * Pure bookkeeping: no clock (the caller passes now), no sockets, no
 * connections, no logging.
 */
#include <string.h>

#include "auth_guard.h"

int64_t qmcd_auth_guard_delay_ms(uint64_t failures, const qmcd_config *cfg)
{
    const uint64_t max = cfg->auth_delay_max_ms;
    if (failures < cfg->auth_max_failures || max == 0)
        return 0;
    uint64_t doublings = failures - cfg->auth_max_failures;
    uint64_t d = QMCD_AUTH_DELAY_FIRST_MS;
    while (doublings-- && d < max)
        d *= 2;
    return (int64_t)(d < max ? d : max);
}

static qmcd_auth_net *find(const qmcd_auth_guard *g, const qmcd_peer_key *net)
{
    for (unsigned i = 0; i < QMCD_AUTH_GUARD_NETS; i++)
        if (g->nets[i].net.kind && memcmp(&g->nets[i].net, net, sizeof *net) == 0)
            return (qmcd_auth_net *)&g->nets[i];
    return NULL;
}

/* The network's slot, or a new one (see the file comment). */
static qmcd_auth_net *take(qmcd_auth_guard *g, const qmcd_peer_key *net,
                           const qmcd_config *cfg, int64_t now)
{
    qmcd_auth_net *e = find(g, net);
    if (e)
        return e;
    qmcd_auth_net *open_oldest = NULL, *oldest = NULL;
    for (unsigned i = 0; i < QMCD_AUTH_GUARD_NETS; i++) {
        qmcd_auth_net *q = &g->nets[i];
        if (!q->net.kind) {
            e = q;
            break;
        }
        if (!oldest || q->last_fail_ms < oldest->last_fail_ms)
            oldest = q;
        if (q->last_fail_ms + qmcd_auth_guard_delay_ms(q->failures, cfg) <= now &&
            (!open_oldest || q->last_fail_ms < open_oldest->last_fail_ms))
            open_oldest = q;
    }
    if (!e)
        e = open_oldest ? open_oldest : oldest;
    memset(e, 0, sizeof *e);
    e->net = *net;
    return e;
}

int64_t qmcd_auth_guard_open_ms(const qmcd_auth_guard *g, const qmcd_peer_key *net,
                                const qmcd_config *cfg, int64_t now)
{
    const qmcd_auth_net *e = find(g, net);
    if (!e || !e->failures || now - e->last_fail_ms > (int64_t)cfg->auth_lockout_ms)
        return now;
    int64_t open = e->last_fail_ms + qmcd_auth_guard_delay_ms(e->failures, cfg);
    return open > now ? open : now;
}

uint64_t qmcd_auth_guard_held(qmcd_auth_guard *g, const qmcd_peer_key *net)
{
    qmcd_auth_net *e = find(g, net);
    return e ? ++e->held : 0;
}

uint64_t qmcd_auth_guard_failed(qmcd_auth_guard *g, const qmcd_peer_key *net,
                                const qmcd_config *cfg, int64_t now, int64_t *delay_ms)
{
    qmcd_auth_net *e = take(g, net, cfg, now);
    if (e->failures && now - e->last_fail_ms > (int64_t)cfg->auth_lockout_ms)
        e->failures = 0; /* the earlier ones are too old to count */
    e->failures++;
    e->last_fail_ms = now;
    e->held = 0;
    *delay_ms = qmcd_auth_guard_delay_ms(e->failures, cfg);
    return e->failures;
}
