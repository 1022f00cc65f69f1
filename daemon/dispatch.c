/*
 * dispatch.c - routes each decoded request through the dispatch table (the
 * rows every module of modules.h exports, by message type; producer.h).
 * What a type is (a request answered under its id; one that starts a
 * producer, refused while draining and past max-inflight; one that may
 * carry a descriptor) is its row's, so the checks here hold for every
 * module, and a new message adds a row, not a branch here.
 * Producers answer later, tagged with the request id, so many requests
 * can be in flight on one connection and answers may come back out of
 * order (PROTOCOL.md, pipelining).
 *
 * This file must not block, touch sockets directly, answer a request
 * itself or name a producer kind: conn.c queues frames, the modules do
 * the work.
 */
#include <errno.h>
#include <string.h>
#include <unistd.h>

#include "dispatch.h"
#include "producer.h"

void qmcd_dispatch(qmcd_conn *c, const qmc_msg *m, int fd, int64_t t0_us)
{
    qmcd_server *srv = c->srv;
    if ((unsigned)m->type < QMCD_STATS_TYPES) /* every decoded type is (stats.c) */
        srv->stats.requests[m->type]++;
    /* No row: a server-to-client type (the decoder knows no others). */
    const qmcd_route *row = (unsigned)m->type < QMCD_ROUTE_TYPES ? srv->routes[m->type] : NULL;
    const unsigned flags = row ? row->flags : 0;
    /* conn_read.c passes a descriptor only with a type whose row takes
     * one; close any other. */
    if (fd >= 0 && (!(flags & QMCD_ROUTE_FD) || !c->hello_done)) {
        close(fd);
        fd = -1;
    }
    /* Before HELLO_OK only the handshake is welcome (c->auth: a challenge
     * awaits its AUTH_RESPONSE). */
    if (!c->hello_done && m->type != QMC_MSG_HELLO &&
        !(m->type == QMC_MSG_AUTH_RESPONSE && c->auth)) {
        qmcd_conn_fail(c, m->request_id, QMC_EPROTO, "the first frame must be HELLO, not %s",
                       qmc_msg_type_name(m->type));
        return;
    }
    /* Id 0 is the connection's (PROTOCOL.md section 3): an answer carrying
     * it could not be told from a connection error. */
    if (m->request_id == 0 && (flags & QMCD_ROUTE_REQUEST)) {
        if (fd >= 0)
            close(fd);
        srv->stats.malformed++;
        qmcd_conn_fail(c, 0, QMC_EPROTO, "%s with request id 0; id 0 is reserved for the "
                       "connection", qmc_msg_type_name(m->type));
        return;
    }
    /* An id already in flight (section 3): the ERROR is that id's final
     * answer, so it ends the request in flight as well, whatever the new
     * request is. */
    qmcd_producer *in_flight =
        (flags & QMCD_ROUTE_REQUEST) ? qmcd_producers_find(c, m->request_id) : NULL;
    if (in_flight) {
        if (fd >= 0)
            close(fd);
        qmcd_producers_end(c, in_flight, QMCD_END_ENDED);
        qmcd_conn_error(c, m->request_id, QMC_EINVAL,
                        "request id %llu is already in flight on this connection; this ERROR "
                        "ends both requests", (unsigned long long)m->request_id);
        return;
    }
    if (!row) {
        /* Well-formed, but the peer is confused about which side it is on. */
        srv->stats.malformed++;
        qmcd_conn_fail(c, m->request_id, QMC_EPROTO, "%s is sent by servers, not clients",
                       qmc_msg_type_name(m->type));
        return;
    }
    if ((flags & QMCD_ROUTE_STARTS) &&
        (srv->draining || c->n_producers >= srv->cfg.max_inflight)) {
        if (fd >= 0)
            close(fd);
        if (srv->draining) {
            qmcd_conn_error(c, m->request_id, -ESHUTDOWN,
                            "server shutting down: no new requests accepted");
            return;
        }
        qmcd_conn_error(c, m->request_id, QMC_ETOOBIG,
                        "max-inflight: %llu requests already in flight on this connection",
                        (unsigned long long)srv->cfg.max_inflight);
        return;
    }
    row->fn(c, m, fd, t0_us);
}
