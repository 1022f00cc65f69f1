/*
 * auth.c - key authentication in the daemon (PROTOCOL.md section 4.1):
 * loading and checking the key file, deciding which connections must
 * authenticate, and running the server's half of the handshake through
 * the pure state machine of protocol/auth.c: HELLO (version and frame
 * size), the challenge when a key is required, the proof, HELLO_OK.
 * HELLO and AUTH_RESPONSE reach it through its rows of the dispatch table
 * (qmcd_auth_module), which also frees a connection's handshake state
 * when the connection goes.  At HELLO_OK a TCP connection leaves the
 * handshake budget for max-connections (admit.c), or is refused there.
 *
 * Who must authenticate: with a key loaded, every TCP connection (loopback
 * too: every local user can reach it), and Unix-socket connections when
 * auth-unix is 1 (otherwise the socket file's permissions are the access
 * control).  Without a key nobody is asked; listen.c refuses to open a
 * non-loopback TCP listener then, so only this host can connect.
 *
 * Guessing (auth_guard.c, docs/SECURITY.md): wrong proofs are counted per
 * network where they are checked, and make the network's next proofs
 * wait before they are checked.  A proof that must wait is held by a
 * producer (producer.h) of the HELLO's request id until its time - the
 * same time for every proof that arrived while the network waited - and
 * then checked like any other: the right key is served, never refused
 * for anyone else's wrong ones.
 *
 * This file must not touch sockets; frames go out through conn.c.
 */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <sodium.h>

#include "admit.h"
#include "auth.h"
#include "auth_guard.h"
#include "conn.h"
#include "log.h"
#include "modules.h"
#include "regular_file.h"
#include "qmc/auth.h"

struct qmcd_auth {
    uint8_t key[QMC_AUTH_KEY_MAX_BYTES];
    size_t key_bytes;             /* 0: no key */
    qmcd_auth_guard guard;        /* failures by network (auth_guard.c) */
};

/* Where a handshake that must prove the key stands. */
enum { PROOF_AWAITED = 0, PROOF_HELD, PROOF_OK_SENT };

struct qmcd_auth_conn {
    qmc_auth_server st;
    uint64_t request_id;          /* the HELLO's */
    uint32_t client_max_frame;
    int stage;                    /* PROOF_* */
    /* A proof held back (PROOF_HELD): checked at release_ms, by the
     * producer p, with the time it arrived (latency). */
    qmcd_producer p;
    qmc_msg_auth_response response;
    int64_t release_ms;
    int64_t t0_us;
    qmc_msg_auth_ok ok;           /* PROOF_OK_SENT: sent; HELLO_OK follows */
};

int qmcd_auth_new(qmcd_auth **out)
{
    *out = NULL;
    /* Seeds libsodium's generator (getrandom) once, before any thread. */
    if (sodium_init() < 0)
        return -EIO;
    qmcd_auth *a = calloc(1, sizeof *a);
    if (!a)
        return -ENOMEM;
    *out = a;
    return 0;
}

void qmcd_auth_free(qmcd_auth *a)
{
    if (!a)
        return;
    sodium_memzero(a->key, sizeof a->key);
    free(a);
}

int qmcd_auth_has_key(const qmcd_auth *a)
{
    return a && a->key_bytes > 0;
}

int qmcd_auth_load_key(qmcd_auth *a, const qmcd_config *cfg, char *why, size_t n)
{
    const char *path = cfg->auth_key;
    if (!path[0]) {
        sodium_memzero(a->key, sizeof a->key);
        a->key_bytes = 0;
        return 0;
    }
    /* O_NOFOLLOW is not used: a key kept through a symlink is fine, and
     * fstat below checks the file actually opened.  A FIFO is refused
     * without waiting for a writer (regular_file.h). */
    int fd = qmcd_open_regular("auth-key", path, why, n);
    if (fd < 0)
        return -1;
    struct stat st;
    const char *bad = NULL;
    uint8_t key[QMC_AUTH_KEY_MAX_BYTES + 1];
    size_t got = 0;
    int rc = -1;
    if (fstat(fd, &st) != 0) {
        snprintf(why, n, "auth-key %s: fstat: %s", path, strerror(errno));
        goto out;
    }
    if (qmc_auth_key_file_check((uint32_t)st.st_mode, (uint64_t)st.st_size, &bad) != 0) {
        snprintf(why, n, "auth-key %s: %s", path, bad);
        goto out;
    }
    /* One byte more than a key may have, to see a file that grew. */
    while (got < sizeof key) {
        ssize_t r = read(fd, key + got, sizeof key - got);
        if (r < 0 && errno == EINTR)
            continue;
        if (r < 0) {
            snprintf(why, n, "auth-key %s: read: %s", path, strerror(errno));
            goto out;
        }
        if (r == 0)
            break;
        got += (size_t)r;
    }
    if (got < QMC_AUTH_KEY_MIN_BYTES || got > QMC_AUTH_KEY_MAX_BYTES) {
        snprintf(why, n, "auth-key %s: holds %zu bytes; a key is %u to %u bytes", path, got,
                 QMC_AUTH_KEY_MIN_BYTES, QMC_AUTH_KEY_MAX_BYTES);
        goto out;
    }
    sodium_memzero(a->key, sizeof a->key);
    memcpy(a->key, key, got);
    a->key_bytes = got;
    rc = 0;
out:
    sodium_memzero(key, sizeof key);
    close(fd);
    return rc;
}

int qmcd_auth_is_loopback(const struct sockaddr *sa)
{
    if (sa->sa_family == AF_INET) {
        const struct sockaddr_in *s4 = (const struct sockaddr_in *)(const void *)sa;
        return (ntohl(s4->sin_addr.s_addr) >> 24) == 127;
    }
    if (sa->sa_family == AF_INET6) {
        const struct sockaddr_in6 *s6 = (const struct sockaddr_in6 *)(const void *)sa;
        const uint8_t *b = s6->sin6_addr.s6_addr;
        static const uint8_t lo[16] = {[15] = 1};
        static const uint8_t mapped[12] = {[10] = 0xff, [11] = 0xff};
        if (memcmp(b, lo, 16) == 0)
            return 1;
        return memcmp(b, mapped, 12) == 0 && b[12] == 127;
    }
    return 0;
}

/* ---- who is asking ------------------------------------------------------------ */

static int must_authenticate(const qmcd_conn *c)
{
    const qmcd_server *srv = c->srv;
    if (!qmcd_auth_has_key(srv->auth))
        return 0;
    return !c->unix_socket || srv->cfg.auth_unix;
}

/* ---- the hooks ------------------------------------------------------------------ */

/* Frees c's handshake state (done, or the connection is going away). */
static void auth_conn_free(qmcd_conn *c)
{
    free(c->auth);
    c->auth = NULL;
}

/* Ends the handshake: HELLO_OK with version and our limits, after HELLO
 * (no authentication required) or a good proof. */
static void hello_ok(qmcd_conn *c, uint64_t request_id, uint16_t version,
                     uint32_t client_max_frame, int64_t t0)
{
    c->hello_done = 1;
    c->handshake_wait = NULL;
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
        qmcd_answered(c->srv, t0);
}

/* The handshake is over: a TCP connection takes its place in
 * max-connections (admit.c).  Returns 0, or -1 after failing c when there
 * is none. */
static int admitted(qmcd_conn *c, uint64_t request_id)
{
    char why[200];
    if (qmcd_admit_done(c, why, sizeof why) == 0)
        return 0;
    qmcd_conn_fail(c, request_id, QMC_ETOOBIG, "%s", why);
    return -1;
}

/* After HELLO's checks: 0 when this connection needs no authentication
 * (the caller answers HELLO_OK), 1 when the handshake is taken over: we
 * sent AUTH_CHALLENGE, or failed the connection (a client that cannot
 * speak version 3).  No network is ever refused a challenge: what limits
 * the challenges one holds is the handshake budget (admit.c), and its
 * guesses wait at the proof (on_response). */
static int challenge(qmcd_conn *c, const qmc_msg *m)
{
    if (!must_authenticate(c))
        return 0;
    const qmc_msg_hello *h = &m->u.hello;
    qmcd_auth_conn *ac = calloc(1, sizeof *ac);
    if (!ac) {
        qmcd_conn_fail(c, m->request_id, QMC_ENOMEM, "out of memory for the handshake");
        return 1;
    }
    uint8_t nonce[QMC_PROTO_AUTH_NONCE_BYTES];
    randombytes_buf(nonce, sizeof nonce);
    qmc_msg r = {.type = QMC_MSG_AUTH_CHALLENGE, .request_id = m->request_id};
    int err = qmc_auth_server_challenge(&ac->st, h, QMC_PROTO_VERSION_MAX, nonce,
                                        &r.u.challenge);
    if (err) {
        free(ac);
        qmcd_conn_fail(c, m->request_id, QMC_EAUTH,
                       "this server requires authentication (protocol version %u); the "
                       "client speaks %u..%u: use a newer client with the key (--auth-key)",
                       QMC_PROTO_VERSION_AUTH, h->version_min, h->version_max);
        return 1;
    }
    ac->request_id = m->request_id;
    ac->client_max_frame = h->max_frame;
    c->auth = ac;
    c->handshake_wait = "AUTH_RESPONSE to its AUTH_CHALLENGE (the proof of the key)";
    qmcd_debug("conn %llu: HELLO from '%.*s': challenged", (unsigned long long)c->id,
               (int)h->client.len, h->client.ptr ? h->client.ptr : "");
    (void)qmcd_conn_send(c, &r);
    return 1;
}

/* HELLO: the highest version both sides speak (PROTOCOL.md section 4). */
#define SERVER_VERSION_MIN 1u
#define SERVER_VERSION_MAX QMC_PROTO_VERSION_MAX

/* The smallest max_frame a client may announce (PROTOCOL.md section 4):
 * every answer but a POINTS_CHUNK then fits. */
#define MIN_CLIENT_FRAME 65536u

/* HELLO: the version both speak and the client's frame size, then a
 * challenge or HELLO_OK. */
static void on_hello(qmcd_conn *c, const qmc_msg *m, int fd, int64_t t0)
{
    (void)fd;
    const qmc_msg_hello *h = &m->u.hello;
    if (c->hello_done || c->auth) {
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
    /* A listener that requires the key: we challenge, and answer HELLO_OK
     * once the proof is good (check_proof). */
    if (challenge(c, m))
        return;
    if (admitted(c, m->request_id) != 0)
        return;
    hello_ok(
        c, m->request_id,
        (uint16_t)(h->version_max < SERVER_VERSION_MAX ? h->version_max : SERVER_VERSION_MAX),
        h->max_frame, t0);
}

/* Checks c's proof: a wrong one is counted against its network and fails
 * c; a good one takes c's place in max-connections (else fails c) and
 * queues AUTH_OK.  Returns 0 when AUTH_OK went out (HELLO_OK is next),
 * -1 when c failed. */
static int check_proof(qmcd_conn *c, const qmc_msg_auth_response *resp)
{
    qmcd_server *srv = c->srv;
    qmcd_auth_conn *ac = c->auth;
    const uint64_t id = ac->request_id;
    int err = qmc_auth_server_verify(&ac->st, srv->auth->key, srv->auth->key_bytes, resp,
                                     &ac->ok);
    if (err == QMC_EAUTH) {
        int64_t delay_ms;
        char net[64];
        qmcd_peer_key_name(&c->net_key, net, sizeof net);
        uint64_t k = qmcd_auth_guard_failed(&srv->auth->guard, &c->net_key, &srv->cfg,
                                            qmcd_now_ms(), &delay_ms);
        srv->stats.auth_failures++;
        if (delay_ms)
            qmcd_warn("conn %llu (%s): authentication failed: wrong key (failure %llu from "
                      "%s within auth-lockout-ms); proofs from %s now wait %lld ms",
                      (unsigned long long)c->id, c->peer, (unsigned long long)k, net, net,
                      (long long)delay_ms);
        else
            qmcd_warn("conn %llu (%s): authentication failed: wrong key (failure %llu from "
                      "%s within auth-lockout-ms; its proofs wait from failure %llu on)",
                      (unsigned long long)c->id, c->peer, (unsigned long long)k, net,
                      (unsigned long long)srv->cfg.auth_max_failures);
        qmcd_conn_fail(c, id, QMC_EAUTH,
                       "authentication failed: the client's key is not the server's");
        return -1;
    }
    if (err) {
        qmcd_conn_fail(c, id, err, "authentication: %s", qmc_strerror(err));
        return -1;
    }
    if (admitted(c, id) != 0)
        return -1;
    qmcd_debug("conn %llu (%s): authenticated", (unsigned long long)c->id, c->peer);
    /* What outlives the connection (a session) belongs to this key: a
     * digest of it names the identity (conn_services.h). */
    crypto_generichash(c->key_id, sizeof c->key_id, srv->auth->key, srv->auth->key_bytes,
                       (const unsigned char *)"qmcd key id", 11);
    qmc_msg ok = {.type = QMC_MSG_AUTH_OK, .request_id = id};
    ok.u.auth_ok = ac->ok;
    if (qmcd_conn_send(c, &ok) != 0)
        return -1;
    ac->stage = PROOF_OK_SENT;
    return 0;
}

/* After AUTH_OK: HELLO_OK, and the handshake state goes. */
static void finish(qmcd_conn *c, int64_t t0_us)
{
    qmcd_auth_conn *ac = c->auth;
    const uint64_t id = ac->request_id;
    const uint16_t version = ac->st.version;
    const uint32_t max_frame = ac->client_max_frame;
    hello_ok(c, id, version, max_frame, t0_us);
}

/* ---- a proof held back: a producer of the HELLO's id ----------------------------- */

#define AUTH_OF(prod) ((qmcd_auth_conn *)(void *)((char *)(prod) - offsetof(qmcd_auth_conn, p)))

/* Waits until its time; then checks the proof (AUTH_OK, or the
 * connection fails), then HELLO_OK: one frame a pump. */
static int held_pump(qmcd_conn *c, qmcd_producer *p)
{
    qmcd_auth_conn *ac = AUTH_OF(p);
    if (ac->stage == PROOF_HELD && qmcd_now_ms() < ac->release_ms)
        return QMCD_PUMP_WAIT; /* the tick kicks the connection */
    if (qmcd_conn_out_room(c) < QMCD_OUT_RESERVE / 2)
        return QMCD_PUMP_NO_ROOM;
    if (ac->stage == PROOF_HELD) {
        /* A failure fails c, which releases p and frees ac. */
        return check_proof(c, &ac->response) == 0 ? QMCD_PUMP_SENT : QMCD_PUMP_FAILED;
    }
    finish(c, ac->t0_us);
    return QMCD_PUMP_DONE;
}

static qmcd_wait held_waiting(const qmcd_conn *c, const qmcd_producer *p)
{
    (void)c;
    return AUTH_OF(p)->stage == PROOF_HELD ? QMCD_WAIT_WORK : QMCD_WAIT_NONE;
}

/* Done (HELLO_OK sent): the handshake state goes.  Dropped or failed:
 * the module's conn_drop frees it with the connection. */
static void held_release(qmcd_conn *c, qmcd_producer *p, qmcd_end why)
{
    (void)p;
    if (why == QMCD_END_DONE)
        auth_conn_free(c);
}

static const qmcd_producer_kind held_kind = {
    .name = "auth-proof",
    .pump = held_pump,
    .waiting = held_waiting,
    .release = held_release,
};

static void on_response(qmcd_conn *c, const qmc_msg *m, int fd, int64_t t0_us)
{
    (void)fd; /* only QMCD_ROUTE_FD rows get one */
    qmcd_server *srv = c->srv;
    qmcd_auth_conn *ac = c->auth;
    if (!ac || ac->stage != PROOF_AWAITED || ac->st.state != QMC_AUTH_CHALLENGED ||
        m->request_id != ac->request_id) {
        srv->stats.malformed++;
        qmcd_conn_fail(c, m->request_id, QMC_EPROTO,
                       "AUTH_RESPONSE that answers no AUTH_CHALLENGE");
        return;
    }
    const int64_t now = qmcd_now_ms();
    const int64_t open_ms = qmcd_auth_guard_open_ms(&srv->auth->guard, &c->net_key, &srv->cfg,
                                                    now);
    if (open_ms > now) {
        /* The network failed lately: this proof is checked at open_ms,
         * with every other that arrives before then. */
        ac->stage = PROOF_HELD;
        ac->response = m->u.response;
        ac->release_ms = open_ms;
        ac->t0_us = t0_us;
        srv->stats.auth_delays++;
        uint64_t n = qmcd_auth_guard_held(&srv->auth->guard, &c->net_key);
        if ((n & (n - 1)) == 0) { /* one line at 1, 2, 4, ...: no flood */
            char net[64];
            qmcd_peer_key_name(&c->net_key, net, sizeof net);
            qmcd_warn("conn %llu (%s): proof held back %lld ms: %s made wrong proofs lately "
                      "(%llu held since its last)", (unsigned long long)c->id, c->peer,
                      (long long)(open_ms - now), net, (unsigned long long)n);
        }
        qmcd_producer_attach(c, &ac->p, &held_kind, ac->request_id);
        return;
    }
    if (check_proof(c, &m->u.response) != 0)
        return;
    finish(c, t0_us);
    auth_conn_free(c);
}

const qmcd_module qmcd_auth_module = {
    .name = "auth",
    .routes = (const qmcd_route[]){
        {QMC_MSG_HELLO, QMCD_ROUTE_REQUEST, on_hello},
        {QMC_MSG_AUTH_RESPONSE, 0, on_response},
        {0, 0, NULL},
    },
    .conn_drop = auth_conn_free,
};
