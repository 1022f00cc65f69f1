/*
 * dispatch.c - routes each decoded request through the dispatch table (the
 * rows every module of modules.h exports, by message type; producer.h) and
 * answers the small ones of its own at once: HELLO, PING, STATS.  What a
 * type is (a request answered under its id; one that starts a producer,
 * refused while draining and past max-inflight; one that may carry a
 * descriptor) is its row's, so the checks here hold for every module.
 * Producers answer later, tagged with the request id, so many requests
 * can be in flight on one connection and answers may come back out of
 * order (PROTOCOL.md, pipelining).
 *
 * This file must not block, touch sockets directly, or name a producer
 * kind: conn.c queues frames, the modules do the work.
 */
#include <errno.h>
#include <string.h>
#include <unistd.h>

#include "auth.h"
#include "dispatch.h"
#include "log.h"
#include "modbus_bridge.h"
#include "pool.h"
#include "producer.h"
#include "qmc/seq.h"

/* HELLO: the highest version both sides speak (PROTOCOL.md section 4). */
#define SERVER_VERSION_MIN 1u
#define SERVER_VERSION_MAX QMC_PROTO_VERSION_MAX

/* The smallest max_frame a client may announce (PROTOCOL.md section 4):
 * every answer but a POINTS_CHUNK then fits. */
#define MIN_CLIENT_FRAME 65536u

static void record(qmcd_conn *c, int64_t t0_us)
{
    qmcd_answered(c->srv, t0_us);
}

static void on_hello(qmcd_conn *c, const qmc_msg *m, int fd, int64_t t0)
{
    (void)fd;
    const qmc_msg_hello *h = &m->u.hello;
    if (c->hello_done || qmcd_auth_pending(c)) {
        qmcd_conn_fail(c, m->request_id, QMC_EPROTO, "HELLO sent twice");
        return;
    }
    if (h->version_min > SERVER_VERSION_MAX || h->version_max < SERVER_VERSION_MIN) {
        qmcd_conn_fail(c, m->request_id, QMC_ENOTSUP,
                       "no common protocol version: client speaks %u..%u, server %u..%u",
                       h->version_min, h->version_max, SERVER_VERSION_MIN, SERVER_VERSION_MAX);
        return;
    }
    if (h->max_frame < MIN_CLIENT_FRAME) {
        qmcd_conn_fail(c, m->request_id, QMC_EINVAL,
                       "HELLO max_frame %u is below the minimum of %u bytes", h->max_frame,
                       MIN_CLIENT_FRAME);
        return;
    }
    qmcd_debug("conn %llu: HELLO from '%.*s'", (unsigned long long)c->id,
               (int)h->client.len, h->client.ptr ? h->client.ptr : "");
    /* A listener that requires the key: auth.c challenges, and answers
     * HELLO_OK itself once the proof is good. */
    if (qmcd_auth_on_hello(c, m, t0))
        return;
    qmcd_auth_hello_ok(
        c, m->request_id,
        (uint16_t)(h->version_max < SERVER_VERSION_MAX ? h->version_max : SERVER_VERSION_MAX),
        h->max_frame, t0);
}

static void on_ping(qmcd_conn *c, const qmc_msg *m, int fd, int64_t t0)
{
    (void)fd;
    qmc_msg r = {.type = QMC_MSG_PONG, .request_id = m->request_id};
    r.u.ping.data = m->u.ping.data;
    if (qmcd_conn_send(c, &r) == 0)
        record(c, t0);
}

static void on_stats(qmcd_conn *c, const qmc_msg *m, int fd, int64_t t0)
{
    (void)fd;
    qmcd_server *srv = c->srv;
    qmc_stat entries[QMC_PROTO_MAX_STATS];
    qmc_msg r = {.type = QMC_MSG_STATS_REPLY, .request_id = m->request_id};
    qmcd_pool_counts pc; /* the pool's own, kept under its mutex */
    qmcd_pool_counts_get(srv->pool, &pc);
    srv->stats.memory_waits = pc.memory_waits;
    srv->stats.memory_backfills = pc.memory_backfills;
    srv->stats.memory_reserved = pc.memory_reserved;
    srv->stats.memory_waiting = (uint64_t)pc.memory_waiting;
    r.u.stats.count = qmcd_stats_entries(&srv->stats, srv->n_conns, srv->n_jobs, entries,
                                         QMC_PROTO_MAX_STATS);
    r.u.stats.count += qmcd_modbus_stats(srv, entries + r.u.stats.count,
                                         QMC_PROTO_MAX_STATS - r.u.stats.count);
    r.u.stats.entries = entries;
    if (qmcd_conn_send(c, &r) == 0)
        record(c, t0);
}

const qmcd_module qmcd_basic_module = {
    .name = "basic",
    .routes = (const qmcd_route[]){
        {QMC_MSG_HELLO, QMCD_ROUTE_REQUEST, on_hello},
        {QMC_MSG_PING, QMCD_ROUTE_REQUEST, on_ping},
        {QMC_MSG_STATS, QMCD_ROUTE_REQUEST, on_stats},
        {0, 0, NULL},
    },
};

void qmcd_dispatch(qmcd_conn *c, const qmc_msg *m, int fd, int64_t t0_us)
{
    qmcd_server *srv = c->srv;
    srv->stats.requests[m->type & 31]++;
    /* No row: a server-to-client type (the decoder knows no others). */
    const qmcd_route *row = (unsigned)m->type < QMCD_ROUTE_TYPES ? srv->routes[m->type] : NULL;
    const unsigned flags = row ? row->flags : 0;
    /* conn_read.c passes a descriptor only with a type whose row takes
     * one; close any other. */
    if (fd >= 0 && (!(flags & QMCD_ROUTE_FD) || !c->hello_done)) {
        close(fd);
        fd = -1;
    }
    if (!c->hello_done && m->type != QMC_MSG_HELLO &&
        !(m->type == QMC_MSG_AUTH_RESPONSE && qmcd_auth_pending(c))) {
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
