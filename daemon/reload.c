/*
 * reload.c - SIGHUP's configuration reload (the new configuration is
 * checked whole, and the key file with it, before it replaces the running
 * one) and the readiness notes to systemd (sd_notify), which the loop and
 * main.c both send.
 *
 * This file must not touch connections: what a reload changes takes
 * effect through srv->cfg, read by each module when it next needs it.
 */
#define _GNU_SOURCE
#include <stdio.h>
#include <systemd/sd-daemon.h>

#include "auth.h"
#include "listen.h"
#include "log.h"
#include "pool.h"
#include "reload.h"

void qmcd_notify(qmcd_server *srv, const char *state)
{
    (void)srv;
    /* 0 when NOTIFY_SOCKET is unset: not under systemd, nothing to do. */
    (void)sd_notify(0, state);
}

/* SIGHUP re-reads the key file and re-checks it (mode, size), so a key
 * rotates without a restart and a key file opened up to others stops the
 * reload; a listener off loopback may never be left without a key. */
static int reload_key(qmcd_server *srv, const qmcd_config *fresh, char *why, size_t n)
{
    if (!fresh->auth_key[0]) {
        for (unsigned i = 0; i < srv->n_listeners; i++)
            if (srv->listeners[i].needs_key) {
                snprintf(why, n, "auth-key removed, but %s is off loopback and needs one",
                         srv->listeners[i].name);
                return -1;
            }
    }
    return qmcd_auth_load_key(srv->auth, fresh, why, n);
}

void qmcd_reload(qmcd_server *srv)
{
    qmcd_config fresh;
    char why[512], status[600];
    /* MONOTONIC_USEC lets a systemd with Type=notify-reload match this
     * RELOADING=1 to the signal it sent; older ones ignore it. */
    snprintf(status, sizeof status, "RELOADING=1\nMONOTONIC_USEC=%llu",
             (unsigned long long)qmcd_now_us());
    qmcd_notify(srv, status);
    if (qmcd_config_load(&srv->args, &fresh, why, sizeof why) != 0) {
        qmcd_err("reload rejected, keeping the running configuration: %s", why);
        snprintf(status, sizeof status, "READY=1\nSTATUS=serving; reload rejected: %s", why);
    } else if (reload_key(srv, &fresh, why, sizeof why) != 0) {
        qmcd_err("reload rejected, keeping the running configuration and key: %s", why);
        snprintf(status, sizeof status, "READY=1\nSTATUS=serving; reload rejected: %s", why);
    } else {
        qmcd_config_keep_fixed(&srv->cfg, &fresh);
        srv->cfg = fresh;
        qmcd_pool_set_memory_total(srv->pool, fresh.max_jobs_memory_total);
        qmcd_pool_set_overtakes(srv->pool, (unsigned)fresh.job_memory_overtakes);
        qmcd_log_set_level(fresh.log_level);
        srv->stats.reloads++;
        qmcd_notice("configuration reloaded%s%s", srv->args.config_path ? " from " : "",
                    srv->args.config_path ? srv->args.config_path : "");
        snprintf(status, sizeof status, "READY=1\nSTATUS=serving; configuration reloaded");
    }
    qmcd_notify(srv, status);
}
