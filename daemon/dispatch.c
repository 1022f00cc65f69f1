/*
 * dispatch.c - routes each decoded request to its handler and answers the
 * small ones (HELLO, PING, STATS) at once; SHM_ATTACH and SHM_RELEASE go to
 * the ring in points.c, with the descriptor that came with SHM_ATTACH.
 * POINTS and INTEGRATE only start here; their answers come later, tagged with the request id, so many
 * requests can be in flight on one connection and answers may come back
 * out of order (PROTOCOL.md, pipelining).
 *
 * This file must not block, touch sockets directly, or generate points or
 * run jobs: conn.c queues frames, points.c and jobs.c do the work.
 */
#include <errno.h>
#include <string.h>
#include <unistd.h>

#include "auth.h"
#include "dispatch.h"
#include "jobs.h"
#include "log.h"
#include "modbus_bridge.h"
#include "points.h"
#include "producer.h"
#include "qmc/seq.h"

/* HELLO: the highest version both sides speak (PROTOCOL.md section 4). */
#define SERVER_VERSION_MIN 1u
#define SERVER_VERSION_MAX QMC_PROTO_VERSION_MAX

/* The smallest max_frame a client may announce (PROTOCOL.md section 4):
 * every answer but a POINTS_CHUNK then fits. */
#define MIN_CLIENT_FRAME 65536u

/* The messages that are requests (answered under their id): every
 * client-to-server type but SHM_RELEASE and AUTH_RESPONSE. */
static int is_request(qmc_msg_type t)
{
    switch (t) {
    case QMC_MSG_HELLO:
    case QMC_MSG_PING:
    case QMC_MSG_POINTS:
    case QMC_MSG_INTEGRATE:
    case QMC_MSG_JOB_STATUS:
    case QMC_MSG_JOB_CANCEL:
    case QMC_MSG_STATS:
    case QMC_MSG_SHM_ATTACH:
        return 1;
    default:
        return 0;
    }
}

static void record(qmcd_conn *c, int64_t t0_us)
{
    qmcd_answered(c->srv, t0_us);
}

static void on_hello(qmcd_conn *c, const qmc_msg *m, int64_t t0)
{
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
    qmcd_dispatch_hello_ok(
        c, m->request_id,
        (uint16_t)(h->version_max < SERVER_VERSION_MAX ? h->version_max : SERVER_VERSION_MAX),
        h->max_frame, t0);
}

void qmcd_dispatch_hello_ok(qmcd_conn *c, uint64_t request_id, uint16_t version,
                            uint32_t client_max_frame, int64_t t0)
{
    c->hello_done = 1;
    c->version = version;
    c->client_max_frame = client_max_frame;
    const qmcd_config *cfg = &c->srv->cfg;
    static const char server[] = "qmcd", engine[] = "libqmc 0.1.0";
    qmc_msg r = {.type = QMC_MSG_HELLO_OK, .request_id = request_id};
    r.u.hello_ok.version = version;
    r.u.hello_ok.max_frame = (uint32_t)cfg->max_frame;
    c->server_max_frame = (uint32_t)cfg->max_frame;
    r.u.hello_ok.max_inflight = (uint32_t)cfg->max_inflight;
    r.u.hello_ok.max_points = cfg->max_points;
    r.u.hello_ok.sobol_table_hash = c->srv->sobol_table_hash;
    r.u.hello_ok.server.ptr = server;
    r.u.hello_ok.server.len = sizeof server - 1;
    r.u.hello_ok.engine.ptr = engine;
    r.u.hello_ok.engine.len = sizeof engine - 1;
    if (qmcd_conn_send(c, &r) == 0)
        record(c, t0);
}

static void on_ping(qmcd_conn *c, const qmc_msg *m, int64_t t0)
{
    qmc_msg r = {.type = QMC_MSG_PONG, .request_id = m->request_id};
    r.u.ping.data = m->u.ping.data;
    if (qmcd_conn_send(c, &r) == 0)
        record(c, t0);
}

static void on_stats(qmcd_conn *c, const qmc_msg *m, int64_t t0)
{
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

void qmcd_dispatch(qmcd_conn *c, const qmc_msg *m, int fd, int64_t t0_us)
{
    qmcd_server *srv = c->srv;
    srv->stats.requests[m->type & 31]++;
    /* conn.c passes descriptors only with SHM_ATTACH; close any other. */
    if (fd >= 0 && (m->type != QMC_MSG_SHM_ATTACH || !c->hello_done)) {
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
    if (m->request_id == 0 && is_request(m->type)) {
        srv->stats.malformed++;
        qmcd_conn_fail(c, 0, QMC_EPROTO, "%s with request id 0; id 0 is reserved for the "
                       "connection", qmc_msg_type_name(m->type));
        return;
    }
    /* An id already in flight (section 3): the ERROR is that id's final
     * answer, so it ends the request in flight as well, whatever the new
     * request is. */
    qmcd_producer *in_flight = is_request(m->type) ? qmcd_producers_find(c, m->request_id) : NULL;
    if (in_flight || (is_request(m->type) && qmcd_jobs_has_request(c, m->request_id))) {
        if (in_flight)
            qmcd_producers_end(c, in_flight, QMCD_END_ENDED);
        qmcd_jobs_end_request(c, m->request_id);
        qmcd_conn_error(c, m->request_id, QMC_EINVAL,
                        "request id %llu is already in flight on this connection; this ERROR "
                        "ends both requests", (unsigned long long)m->request_id);
        return;
    }
    switch (m->type) {
    case QMC_MSG_HELLO:
        on_hello(c, m, t0_us);
        return;
    case QMC_MSG_AUTH_RESPONSE:
        qmcd_auth_on_response(c, m, t0_us);
        return;
    case QMC_MSG_PING:
        on_ping(c, m, t0_us);
        return;
    case QMC_MSG_STATS:
        on_stats(c, m, t0_us);
        return;
    case QMC_MSG_JOB_STATUS:
        qmcd_jobs_status(c, m, t0_us);
        return;
    case QMC_MSG_JOB_CANCEL:
        qmcd_jobs_cancel(c, m, t0_us);
        return;
    case QMC_MSG_SHM_ATTACH:
        qmcd_points_shm_attach(c, m, fd, t0_us);
        return;
    case QMC_MSG_SHM_RELEASE:
        qmcd_points_shm_release(c, m);
        return;
    case QMC_MSG_POINTS:
    case QMC_MSG_INTEGRATE:
        break;
    default:
        /* A server-to-client type: well-formed, but the peer is confused
         * about which side it is on. */
        srv->stats.malformed++;
        qmcd_conn_fail(c, m->request_id, QMC_EPROTO, "%s is sent by servers, not clients",
                       qmc_msg_type_name(m->type));
        return;
    }
    if (srv->draining) {
        qmcd_conn_error(c, m->request_id, -ESHUTDOWN,
                        "server shutting down: no new requests accepted");
        return;
    }
    if (c->n_producers + c->n_jobs >= srv->cfg.max_inflight) {
        qmcd_conn_error(c, m->request_id, QMC_ETOOBIG,
                        "max-inflight: %llu requests already in flight on this connection",
                        (unsigned long long)srv->cfg.max_inflight);
        return;
    }
    if (m->type == QMC_MSG_POINTS)
        qmcd_points_start(c, m, t0_us);
    else
        qmcd_jobs_integrate(c, m, t0_us);
}
