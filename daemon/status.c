/*
 * status.c - the requests that ask how the server is: PING (PONG with the
 * same data) and STATS (every counter, as one STATS_REPLY).  Both are
 * answered at once, with no producer.
 *
 * This file must not change what it reports: it only gathers the
 * counters the other modules keep.
 */
#include "conn_services.h"
#include "modbus_bridge.h"
#include "modules.h"
#include "pool.h"

/* PING: PONG with the same data. */
static void on_ping(qmcd_conn *c, const qmc_msg *m, int fd, int64_t t0)
{
    (void)fd;
    qmcd_server *srv = qmcd_conn_server(c);
    qmc_msg r = {.type = QMC_MSG_PONG, .request_id = m->request_id};
    r.u.ping.data = m->u.ping.data;
    if (qmcd_conn_send(c, &r) == 0)
        qmcd_answered(srv, t0);
}

/* STATS: the server's counters (stats.c), the pool's and the Modbus
 * bridge's, as one STATS_REPLY. */
static void on_stats(qmcd_conn *c, const qmc_msg *m, int fd, int64_t t0)
{
    (void)fd;
    qmcd_server *srv = qmcd_conn_server(c);
    qmc_stat entries[QMC_PROTO_MAX_STATS];
    qmc_msg r = {.type = QMC_MSG_STATS_REPLY, .request_id = m->request_id};
    qmcd_pool_counts pc; /* the pool's own, kept under its mutex */
    qmcd_pool_counts_get(srv->pool, &pc);
    srv->stats.memory_waits = pc.memory_waits;
    srv->stats.memory_backfills = pc.memory_backfills;
    srv->stats.memory_reserved = pc.memory_reserved;
    srv->stats.memory_waiting = (uint64_t)pc.memory_waiting;
    srv->stats.handshakes_open = srv->n_preauth;
    r.u.stats.count = qmcd_stats_entries(&srv->stats, srv->n_conns, srv->n_jobs, entries,
                                         QMC_PROTO_MAX_STATS);
    r.u.stats.count += qmcd_modbus_stats(srv, entries + r.u.stats.count,
                                         QMC_PROTO_MAX_STATS - r.u.stats.count);
    r.u.stats.entries = entries;
    if (qmcd_conn_send(c, &r) == 0)
        qmcd_answered(srv, t0);
}

const qmcd_module qmcd_status_module = {
    .name = "status",
    .routes = (const qmcd_route[]){
        {QMC_MSG_PING, QMCD_ROUTE_REQUEST, on_ping},
        {QMC_MSG_STATS, QMCD_ROUTE_REQUEST, on_stats},
        {0, 0, NULL},
    },
};
