/*
 * modbus_bridge.c - the Modbus bridge's lifecycle: reading its settings, opening
 * and starting the transports, and an orderly stop.  The counters every
 * transport shares are modbus_counters.c.  The transports themselves are modbus_tcp.c (the MBAP
 * framing, non-blocking, on the loop) and modbus_rtu.c (a serial line
 * through libmodbus, on a thread of its own).
 *
 * Must not: interpret registers (protocol/modbus.c does), or reach into
 * the protocol connections of conn.c.
 */
#define _GNU_SOURCE
#include <stdlib.h>
#include <string.h>

#include "log.h"
#include "modbus_srv.h"
#include "qmc/seq.h"

int qmcd_modbus_open(qmcd_server *srv, char *why, size_t why_bytes)
{
    const qmcd_config *cfg = &srv->cfg;
    if (cfg->n_modbus == 0)
        return 0;
    qmcd_modbus *mb = calloc(1, sizeof *mb);
    if (!mb) {
        snprintf(why, why_bytes, "modbus: out of memory");
        return -1;
    }
    srv->modbus = mb;
    mb->srv = srv;
    mb->started_ms = qmcd_now_ms();
    if (qmc_modbus_session_new(&mb->defaults) != 0 || qmcd_peers_new(&mb->net_conns) != 0) {
        snprintf(why, why_bytes, "modbus: out of memory");
        goto fail;
    }
    if (qmcd_modbus_allow_parse(cfg->modbus_allow, mb->allow, &mb->n_allow, why, why_bytes))
        goto fail;
    mb->listeners = calloc(cfg->n_modbus, sizeof *mb->listeners);
    if (!mb->listeners) {
        snprintf(why, why_bytes, "modbus: out of memory");
        goto fail;
    }
    for (unsigned i = 0; i < cfg->n_modbus; i++) {
        const char *hostport = NULL;
        qmcd_modbus_rtu_spec rtu;
        int kind = qmcd_modbus_spec_parse(cfg->modbus[i], &hostport, &rtu, why, why_bytes);
        if (kind == 1) {
            qmcd_listener *l = &mb->listeners[mb->n_listeners];
            if (qmcd__modbus_tcp_open(mb, hostport, l, why, why_bytes) != 0)
                goto fail;
            mb->n_listeners++;
        } else if (kind == 2) {
            if (qmcd__modbus_rtu_open(mb, &rtu, &mb->rtus[mb->n_rtus], why, why_bytes) != 0)
                goto fail;
            mb->n_rtus++;
        } else {
            goto fail;
        }
    }
    return 0;
fail:
    qmcd_modbus_close(srv);
    return -1;
}

int qmcd_modbus_start(qmcd_server *srv)
{
    qmcd_modbus *mb = srv->modbus;
    if (!mb)
        return 0;
    mb->started_ms = qmcd_now_ms();
    int err = qmcd__modbus_tcp_start(mb);
    for (unsigned i = 0; !err && i < mb->n_rtus; i++)
        if ((err = qmcd__modbus_rtu_start(mb->rtus[i])) == 0)
            qmcd_info("modbus: serving %s", qmcd__modbus_rtu_name(mb->rtus[i]));
    return err;
}

void qmcd_modbus_write_names(const qmcd_server *srv, FILE *f)
{
    const qmcd_modbus *mb = srv->modbus;
    if (!mb)
        return;
    for (unsigned i = 0; i < mb->n_listeners; i++)
        fprintf(f, "modbus:%s\n", mb->listeners[i].name);
    for (unsigned i = 0; i < mb->n_rtus; i++)
        fprintf(f, "modbus:%s\n", qmcd__modbus_rtu_name(mb->rtus[i]));
}

uint32_t qmcd_modbus_stats(const qmcd_server *srv, qmc_stat *e, uint32_t cap)
{
    qmcd_modbus *mb = srv->modbus;
    if (!mb)
        return 0;
    const struct {
        const char *name;
        const atomic_uint_fast64_t *v;
    } rows[] = {
        {"modbus_requests", &mb->ctr.requests},
        {"modbus_exceptions", &mb->ctr.exceptions},
        {"modbus_malformed_frames", &mb->ctr.malformed},
        {"modbus_connections_accepted", &mb->ctr.conns_accepted},
        {"modbus_connections_refused", &mb->ctr.conns_refused},
        {"modbus_connections_open", &mb->ctr.conns_open},
        {"modbus_refused_connections_per_peer", &mb->ctr.conns_refused_per_peer},
        {"modbus_sessions", &mb->ctr.sessions},
        {"modbus_refused_sessions_per_peer", &mb->ctr.sessions_refused_per_peer},
        {"modbus_refused_sessions", &mb->ctr.sessions_refused},
        {"modbus_integrations", &mb->ctr.integrations},
        {"modbus_integration_bytes", &mb->ctr.integration_bytes},
        {"modbus_refused_integrations", &mb->ctr.integrations_refused},
    };
    uint32_t n = 0;
    for (size_t i = 0; i < sizeof rows / sizeof rows[0] && n < cap; i++, n++) {
        e[n].name.ptr = rows[i].name;
        e[n].name.len = (uint32_t)strlen(rows[i].name);
        e[n].value = atomic_load_explicit(rows[i].v, memory_order_relaxed);
    }
    return n;
}

void qmcd_modbus_tick(qmcd_server *srv, int64_t now_ms)
{
    if (srv->modbus)
        qmcd__modbus_tcp_tick(srv->modbus, now_ms);
}

void qmcd_modbus_reap(qmcd_server *srv)
{
    if (srv->modbus)
        qmcd__modbus_tcp_reap(srv->modbus);
}

void qmcd_modbus_drain(qmcd_server *srv)
{
    qmcd_modbus *mb = srv->modbus;
    if (!mb || mb->draining)
        return;
    mb->draining = 1;
    qmcd__modbus_tcp_close_listeners(mb);
    qmcd__modbus_tcp_close_all(mb, "server shutting down");
    for (unsigned i = 0; i < mb->n_rtus; i++) {
        qmcd__modbus_rtu_free(mb->rtus[i]);
        mb->rtus[i] = NULL;
    }
    mb->n_rtus = 0;
}

void qmcd_modbus_close(qmcd_server *srv)
{
    qmcd_modbus *mb = srv->modbus;
    if (!mb)
        return;
    qmcd__modbus_tcp_close_listeners(mb);
    qmcd__modbus_tcp_close_all(mb, "exiting");
    qmcd__modbus_tcp_reap(mb);
    qmcd__modbus_sessions_free(mb);
    for (unsigned i = 0; i < mb->n_rtus; i++)
        qmcd__modbus_rtu_free(mb->rtus[i]);
    qmc_modbus_session_free(mb->defaults);
    qmcd_peers_free(mb->net_conns);
    free(mb->listeners);
    free(mb);
    srv->modbus = NULL;
}
