/*
 * client.c - connecting (endpoint, HELLO handshake), the server's
 * identity and limits, PING and STATS, closing.
 *
 * Must not: allocate more than the one block made at connect (the ring's
 * mapping, shm.c, is the only other memory a client holds), print, or keep
 * a connection whose handshake failed.
 */
#include <errno.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "client_impl.h"

#define CLIENT_NAME "libqmcclient 0.1.0"

static void *plain_alloc(void *ctx, size_t bytes)
{
    (void)ctx;
    return malloc(bytes);
}

/* The handshake: HELLO out, HELLO_OK (or ERROR) back. */
static int hello(qmc_client *c)
{
    qmc_msg m;
    memset(&m, 0, sizeof m);
    m.type = QMC_MSG_HELLO;
    m.u.hello.version_min = 1;
    m.u.hello.version_max = QMC_PROTO_VERSION_MAX;
    m.u.hello.max_frame = QMC_CLIENT_MAX_FRAME;
    m.u.hello.client.ptr = CLIENT_NAME;
    m.u.hello.client.len = (uint32_t)strlen(CLIENT_NAME);
    uint64_t id;
    int err = qmc__client_send(c, &m, &id);
    if (err)
        return err;
    err = qmc__client_await(c, id, qmc__client_deadline(c), 0, &m);
    /* A server that requires the key challenges (PROTOCOL.md 4.1); after
     * the proofs m holds what followed AUTH_OK. */
    if (err == 0 && m.type == QMC_MSG_AUTH_CHALLENGE)
        err = qmc__client_authenticate(c, id, 1, QMC_PROTO_VERSION_MAX, &m);
    if (err == QMC_EPROTO) {
        char text[QMC_CLIENT_MESSAGE_BYTES];
        memcpy(text, c->message, sizeof text);
        return qmc__client_break(c, err, "handshake failed: the peer does not speak "
                                 "the qmcd protocol (%.200s)", text);
    }
    if (err)
        return err;
    if (m.type == QMC_MSG_ERROR) {
        err = qmc__client_server_error(c, &m);
        char text[QMC_CLIENT_MESSAGE_BYTES];
        memcpy(text, c->message, sizeof text);
        return qmc__client_break(c, err, "the server refused the handshake: %s", text);
    }
    if (m.type != QMC_MSG_HELLO_OK)
        return qmc__client_break(c, QMC_EPROTO, "handshake failed: %s instead of HELLO_OK",
                                 qmc_msg_type_name(m.type));
    /* Over TCP a key means: talk only to a server that proves it holds
     * it.  One that never asked cannot; a Unix socket's permissions vouch
     * for its server. */
    if (c->auth_key_bytes && !c->authenticated && !c->unix_socket)
        return qmc__client_break(c, QMC_EAUTH, "the server did not ask for authentication, "
                                 "so it cannot prove it holds our key; refusing it (connect "
                                 "without --auth-key / QMC_AUTH_KEY_FILE to a server that "
                                 "has no key)");
    const qmc_msg_hello_ok *h = &m.u.hello_ok;
    if (h->version < 1 || h->version > QMC_PROTO_VERSION_MAX)
        return qmc__client_break(c, QMC_EPROTO, "handshake failed: the server chose "
                                 "protocol version %u; we speak 1..%u", h->version,
                                 QMC_PROTO_VERSION_MAX);
    c->version = h->version;
    if (h->max_frame < 64)
        return qmc__client_break(c, QMC_EPROTO, "handshake failed: the server accepts "
                                 "frames of only %u bytes", h->max_frame);
    c->max_frame = h->max_frame;
    c->max_inflight = h->max_inflight;
    c->max_points = h->max_points;
    c->sobol_table_hash = h->sobol_table_hash;
    qmc__client_copy_str(c->server, sizeof c->server, h->server);
    qmc__client_copy_str(c->engine, sizeof c->engine, h->engine);
    c->max_jobs = QMC_CLIENT_MAX_JOBS;
    if (h->max_inflight > 0 && h->max_inflight < c->max_jobs)
        c->max_jobs = h->max_inflight;
    return 0;
}

int qmc__client_connect_with(const char *endpoint, int timeout_ms,
                             qmc__client_alloc_fn alloc, void *alloc_ctx,
                             qmc_client **out)
{
    return qmc__client_connect_key_with(endpoint, timeout_ms, NULL, alloc, alloc_ctx, out);
}

int qmc__client_connect_key_with(const char *endpoint, int timeout_ms, const char *key_file,
                                 qmc__client_alloc_fn alloc, void *alloc_ctx,
                                 qmc_client **out)
{
    *out = NULL;
    const size_t bytes = sizeof(qmc_client) + QMC__CLIENT_SEND_BYTES + QMC__CLIENT_RECV_BYTES;
    qmc_client *c = alloc(alloc_ctx, bytes);
    if (!c)
        return QMC_ENOMEM;
    memset(c, 0, sizeof *c);
    c->fd = -1;
    c->timeout_ms = timeout_ms;
    c->next_request_id = 1;
    c->sbuf = (uint8_t *)(c + 1);
    c->scap = QMC__CLIENT_SEND_BYTES;
    c->rbuf = c->sbuf + c->scap;
    c->rcap = QMC__CLIENT_RECV_BYTES;
    c->max_frame = 4096; /* until HELLO_OK says; HELLO is far smaller */
    *out = c;
    if (timeout_ms == 0 || timeout_ms < -1)
        return qmc__client_fail(c, QMC_EINVAL, "timeout %d ms: want > 0, or -1 for none",
                                timeout_ms);
    if (!key_file) {
        const char *env = getenv("QMC_AUTH_KEY_FILE");
        key_file = env ? env : "";
    }
    int err;
    if (key_file[0] && (err = qmc__client_load_key(c, key_file)) != 0)
        return err;
    qmc__endpoint ep;
    err = qmc__client_endpoint_parse(endpoint, &ep, c->message, sizeof c->message);
    if (err)
        return err;
    int fd = qmc__client_endpoint_open(&ep, qmc__client_deadline(c), c->message,
                                       sizeof c->message);
    if (fd < 0)
        return fd;
    c->fd = fd;
    c->unix_socket = ep.kind == QMC__EP_UNIX;
    err = hello(c);
    if (err == 0)
        c->message[0] = '\0';
    return err;
}

int qmc_client_connect(const char *endpoint, int timeout_ms, qmc_client **out)
{
    return qmc__client_connect_with(endpoint, timeout_ms, plain_alloc, NULL, out);
}

int qmc_client_connect_auth(const char *endpoint, int timeout_ms, const char *key_file,
                            qmc_client **out)
{
    return qmc__client_connect_key_with(endpoint, timeout_ms, key_file, plain_alloc, NULL,
                                        out);
}

int qmc_client_authenticated(const qmc_client *c)
{
    return c && c->fd >= 0 && c->authenticated;
}

void qmc_client_close(qmc_client *c)
{
    if (!c)
        return;
    if (c->fd >= 0)
        close(c->fd);
    qmc__client_sessions_detach(c);
    qmc__client_shm_unmap(c);
    qmc__client_wipe_key(c);
    free(c);
}

const char *qmc_client_last_error(const qmc_client *c)
{
    return c ? c->message : "out of memory";
}

int qmc_client_set_timeout(qmc_client *c, int timeout_ms)
{
    if (timeout_ms == 0 || timeout_ms < -1)
        return qmc__client_fail(c, QMC_EINVAL, "timeout %d ms: want > 0, or -1 for none",
                                timeout_ms);
    c->timeout_ms = timeout_ms;
    c->message[0] = '\0';
    return 0;
}

const char *qmc_client_server_name(const qmc_client *c) { return c->server; }
const char *qmc_client_engine(const qmc_client *c) { return c->engine; }
uint64_t qmc_client_sobol_table_hash(const qmc_client *c) { return c->sobol_table_hash; }
uint32_t qmc_client_max_frame(const qmc_client *c) { return c->fd >= 0 ? c->max_frame : 0; }
uint32_t qmc_client_max_inflight(const qmc_client *c) { return c->max_inflight; }
uint64_t qmc_client_max_points(const qmc_client *c) { return c->max_points; }

static double seconds_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Reads the answer to request id: a frame of type `want`, or ERROR. */
static int answer(qmc_client *c, uint64_t id, qmc_msg_type want, qmc_msg *m)
{
    int err = qmc__client_await(c, id, qmc__client_deadline(c), 0, m);
    if (err)
        return err;
    if (m->type == QMC_MSG_ERROR)
        return qmc__client_server_error(c, m);
    if (m->type != want)
        return qmc__client_break(c, QMC_EPROTO, "protocol error: %s instead of %s",
                                 qmc_msg_type_name(m->type), qmc_msg_type_name(want));
    return 0;
}

int qmc_client_ping(qmc_client *c, double *rtt_seconds)
{
    *rtt_seconds = 0.0;
    int err = qmc__client_ready(c);
    if (err)
        return err;
    /* A payload the PONG must echo: proof the answer is to this PING. */
    uint8_t token[8];
    uint64_t t = c->next_request_id * UINT64_C(0x9e3779b97f4a7c15);
    for (int i = 0; i < 8; i++)
        token[i] = (uint8_t)(t >> (8 * i));
    qmc_msg m;
    memset(&m, 0, sizeof m);
    m.type = QMC_MSG_PING;
    m.u.ping.data.ptr = (const char *)token;
    m.u.ping.data.len = sizeof token;
    uint64_t id;
    double t0 = seconds_now();
    if ((err = qmc__client_send(c, &m, &id)) != 0 ||
        (err = answer(c, id, QMC_MSG_PONG, &m)) != 0)
        return err;
    double t1 = seconds_now();
    if (m.u.ping.data.len != sizeof token || memcmp(m.u.ping.data.ptr, token, sizeof token))
        return qmc__client_break(c, QMC_EPROTO, "protocol error: PONG does not echo "
                                 "the PING's data");
    *rtt_seconds = t1 - t0;
    return 0;
}

int qmc_client_stats(qmc_client *c, qmc_client_stat_fn on_stat, void *ctx)
{
    int err = qmc__client_ready(c);
    if (err)
        return err;
    if (!on_stat)
        return qmc__client_fail(c, QMC_EINVAL, "stats: no callback");
    qmc_msg m;
    memset(&m, 0, sizeof m);
    m.type = QMC_MSG_STATS;
    uint64_t id;
    if ((err = qmc__client_send(c, &m, &id)) != 0 ||
        (err = answer(c, id, QMC_MSG_STATS_REPLY, &m)) != 0)
        return err;
    /* The reply stays in the receive buffer until the next read, and the
     * callback cannot read: walk it in place. */
    for (uint32_t i = 0; i < m.u.stats.count; i++) {
        qmc_stat s = qmc_proto_stat_at(&m.u.stats, i);
        char name[QMC_PROTO_MAX_NAME + 1];
        qmc__client_copy_str(name, sizeof name, s.name);
        int r = on_stat(ctx, name, s.value);
        if (r)
            return r;
    }
    return 0;
}
