/*
 * shm.c - SHM_ATTACH and SHM_RELEASE (PROTOCOL.md section 10): a client on
 * a Unix socket lends its connection a shared-memory ring for bulk data,
 * and hands its slots back as it has read them.  What the server checks
 * and how it maps the memfd is ring.c's; this file decides whether this
 * connection may attach one, and answers.
 *
 * The ring belongs to the connection, not to one producer kind: POINTS
 * streams fill it today, and any kind that streams bulk data may (ring.h).
 *
 * This file must not generate data or reach into a connection's fields:
 * conn_services.h is its way to the connection.
 */
#define _GNU_SOURCE
#include <stdio.h>
#include <unistd.h>

#include "conn_services.h"
#include "log.h"
#include "modules.h"
#include "ring.h"

/* Whether this kernel stops hole punching under our seal: probed once per
 * daemon, with one line when it does not. */
static int shm_safe(qmcd_server *srv)
{
    if (srv->shm_seal_probe == 0) {
        srv->shm_seal_probe = qmcd_ring_seal_stops_punching() ? 1 : -1;
        if (srv->shm_seal_probe < 0)
            qmcd_warn("shared memory: this kernel lets a client punch holes in a memfd "
                      "sealed with F_SEAL_FUTURE_WRITE; SHM_ATTACH is refused (clients "
                      "use inline chunks)");
    }
    return srv->shm_seal_probe > 0;
}

/* SHM_ATTACH: checks the client's memfd (fd: the descriptor that came with
 * the frame, or -1; always consumed), maps it as the connection's ring and
 * answers SHM_OK, or answers ERROR. */
static void on_attach(qmcd_conn *c, const qmc_msg *m, int fd, int64_t t0_us)
{
    qmcd_server *srv = qmcd_conn_server(c);
    const qmc_msg_shm *a = &m->u.shm;
    const qmcd_config *cfg = &srv->cfg;
    const uint64_t bytes = (uint64_t)a->slots * a->slot_bytes;
    char why[256] = "";
    int err = 0;
    qmcd_ring *r = NULL;
    if (!qmcd_conn_is_unix(c)) {
        err = QMC_ENOTSUP;
        snprintf(why, sizeof why, "SHM_ATTACH needs a Unix-socket connection (the memfd "
                                  "travels with SCM_RIGHTS)");
    } else if (cfg->max_shm_bytes == 0) {
        err = QMC_ENOTSUP;
        snprintf(why, sizeof why, "the shared-memory transport is off on this server "
                                  "(max-shm-bytes = 0)");
    } else if (qmcd_conn_ring(c)) {
        err = QMC_EINVAL;
        snprintf(why, sizeof why, "SHM_ATTACH: a ring is already attached to this connection");
    } else if (fd < 0) {
        err = QMC_EINVAL;
        snprintf(why, sizeof why, "SHM_ATTACH came without a file descriptor (send the memfd "
                                  "with SCM_RIGHTS in the sendmsg that carries the frame)");
    } else if (!shm_safe(srv)) {
        err = QMC_ENOTSUP;
        snprintf(why, sizeof why, "the shared-memory transport is off on this server: its "
                                  "kernel does not stop hole punching in a sealed memfd");
    } else if (bytes > cfg->max_shm_bytes) {
        err = QMC_ETOOBIG;
        snprintf(why, sizeof why, "max-shm-bytes: a ring of %u x %u bytes exceeds the "
                                  "%llu-byte limit", a->slots, a->slot_bytes,
                 (unsigned long long)cfg->max_shm_bytes);
    } else {
        err = qmcd_ring_map(fd, a->slots, a->slot_bytes, &r, why, sizeof why);
    }
    if (fd >= 0)
        close(fd); /* the mapping keeps the memory; the descriptor is not needed */
    if (err) {
        qmcd_conn_error(c, m->request_id, err, "%s", why);
        return;
    }
    qmcd_conn_set_ring(c, r);
    qmcd_debug("conn %llu: ring of %u x %u bytes attached", (unsigned long long)qmcd_conn_id(c),
               a->slots, a->slot_bytes);
    qmc_msg ok = {.type = QMC_MSG_SHM_OK, .request_id = m->request_id};
    ok.u.shm = *a;
    if (qmcd_conn_send(c, &ok) == 0)
        qmcd_answered(srv, t0_us);
}

/* SHM_RELEASE: frees the oldest slots the client holds.  A release of more
 * than it holds, without a ring, or with a request id is fatal. */
static void on_release(qmcd_conn *c, const qmc_msg *m, int fd, int64_t t0_us)
{
    (void)fd, (void)t0_us; /* not a request: nothing answers it */
    qmcd_ring *r = qmcd_conn_ring(c);
    uint32_t n = m->u.release.slots;
    if (m->request_id != 0) {
        qmcd_conn_fail(c, m->request_id, QMC_EPROTO,
                       "SHM_RELEASE must carry request id 0, not %llu",
                       (unsigned long long)m->request_id);
        return;
    }
    if (!r) {
        qmcd_conn_fail(c, 0, QMC_EPROTO, "SHM_RELEASE without an attached ring");
        return;
    }
    if (qmcd_ring_take_back(r, n) != 0)
        qmcd_conn_fail(c, 0, QMC_EPROTO, "SHM_RELEASE of %u slots, but the client holds only %u",
                       n, r->held);
}

const qmcd_module qmcd_shm_module = {
    .name = "shm",
    .routes = (const qmcd_route[]){
        {QMC_MSG_SHM_ATTACH, QMCD_ROUTE_REQUEST | QMCD_ROUTE_FD, on_attach},
        {QMC_MSG_SHM_RELEASE, 0, on_release},
        {0, 0, NULL},
    },
};
