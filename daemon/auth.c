/*
 * auth.c - key authentication in the daemon (PROTOCOL.md section 4.1):
 * loading and checking the key file, deciding which connections must
 * authenticate, running the server's half of the handshake through the
 * pure state machine of protocol/auth.c, locking out an address after
 * repeated failures: the whole handshake, HELLO (version and frame size),
 * the challenge when a key is required, and HELLO_OK.  HELLO and
 * AUTH_RESPONSE reach it through its rows of the dispatch table
 * (qmcd_auth_module), which also frees a connection's handshake state
 * when the connection goes.
 *
 * Who must authenticate: with a key loaded, every TCP connection (loopback
 * too: every local user can reach it), and Unix-socket connections when
 * auth-unix is 1 (otherwise the socket file's permissions are the access
 * control).  Without a key nobody is asked; listen.c refuses to open a
 * non-loopback TCP listener then, so only this host can connect.
 *
 * Lockout: failures are counted per address (the peer's IP address; on a
 * Unix socket its uid) in a fixed table of AUTH_PEERS entries, so a flood
 * of addresses costs no memory - the entry with the oldest failure is
 * recycled.  auth-max-failures failures within auth-lockout-ms of each
 * other lock the address out for auth-lockout-ms after the last one;
 * while locked, its HELLOs are refused before any challenge, so no guess
 * can be tested.  A success clears the address's count.
 *
 * This file must not touch sockets beyond asking the kernel who the peer
 * is; frames go out through conn.c.
 */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <sodium.h>

#include "auth.h"
#include "conn.h"
#include "log.h"
#include "modules.h"
#include "regular_file.h"
#include "qmc/auth.h"

/* Addresses whose failures are remembered at once. */
#define AUTH_PEERS 256
#define AUTH_ADDR_BYTES 64

typedef struct peer_failures {
    char addr[AUTH_ADDR_BYTES];   /* "" when the slot is free */
    uint64_t failures;            /* within the current window */
    int64_t last_fail_ms;
    int64_t locked_until_ms;      /* 0: not locked */
    uint64_t refused;             /* HELLOs refused during this lockout */
} peer_failures;

struct qmcd_auth {
    uint8_t key[QMC_AUTH_KEY_MAX_BYTES];
    size_t key_bytes;             /* 0: no key */
    peer_failures peers[AUTH_PEERS];
};

struct qmcd_auth_conn {
    qmc_auth_server st;
    uint64_t request_id;          /* the HELLO's */
    uint32_t client_max_frame;
    char addr[AUTH_ADDR_BYTES];
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

/* The address failures are counted against: the peer's IP address (no
 * port: a new connection gets a new one), or on a Unix socket its uid. */
static void peer_address(const qmcd_conn *c, char *out, size_t n)
{
    if (c->unix_socket) {
        struct ucred cred;
        socklen_t len = sizeof cred;
        if (getsockopt(c->w.fd, SOL_SOCKET, SO_PEERCRED, &cred, &len) == 0)
            snprintf(out, n, "uid %u", (unsigned)cred.uid);
        else
            snprintf(out, n, "unix");
        return;
    }
    struct sockaddr_storage ss;
    socklen_t len = sizeof ss;
    char host[INET6_ADDRSTRLEN] = "?";
    if (getpeername(c->w.fd, (struct sockaddr *)&ss, &len) == 0) {
        if (ss.ss_family == AF_INET6)
            inet_ntop(AF_INET6, &((struct sockaddr_in6 *)&ss)->sin6_addr, host, sizeof host);
        else if (ss.ss_family == AF_INET)
            inet_ntop(AF_INET, &((struct sockaddr_in *)&ss)->sin_addr, host, sizeof host);
    }
    snprintf(out, n, "%s", host);
}

static peer_failures *find_peer(qmcd_auth *a, const char *addr)
{
    for (unsigned i = 0; i < AUTH_PEERS; i++)
        if (a->peers[i].addr[0] && strcmp(a->peers[i].addr, addr) == 0)
            return &a->peers[i];
    return NULL;
}

/* A slot for addr: its own, a free one, or the one whose last failure is
 * oldest (an unlocked one first: recycling a locked address would let a
 * flood of addresses lift its lockout). */
static peer_failures *take_peer(qmcd_auth *a, const char *addr, int64_t now)
{
    peer_failures *p = find_peer(a, addr), *oldest = NULL;
    if (p)
        return p;
    for (unsigned i = 0; i < AUTH_PEERS && !p; i++) {
        peer_failures *q = &a->peers[i];
        if (!q->addr[0])
            p = q;
        else if (q->locked_until_ms <= now &&
                 (!oldest || q->last_fail_ms < oldest->last_fail_ms))
            oldest = q;
    }
    if (!p)
        p = oldest ? oldest : &a->peers[0];
    memset(p, 0, sizeof *p);
    snprintf(p->addr, sizeof p->addr, "%s", addr);
    return p;
}

/* Milliseconds addr stays locked out, or 0. */
static int64_t locked_for(qmcd_auth *a, const char *addr, int64_t now)
{
    peer_failures *p = find_peer(a, addr);
    if (!p || p->locked_until_ms <= now)
        return 0;
    return p->locked_until_ms - now;
}

static void record_failure(qmcd_conn *c, const char *addr, int64_t now)
{
    qmcd_server *srv = c->srv;
    const uint64_t max = srv->cfg.auth_max_failures;
    const int64_t window = (int64_t)srv->cfg.auth_lockout_ms;
    peer_failures *p = take_peer(srv->auth, addr, now);
    if (p->failures && now - p->last_fail_ms > window)
        p->failures = 0; /* the earlier ones are too old to count */
    p->failures++;
    p->last_fail_ms = now;
    srv->stats.auth_failures++;
    qmcd_warn("conn %llu (%s): authentication failed: wrong key (failure %llu of %llu "
              "allowed from %s)", (unsigned long long)c->id, c->peer,
              (unsigned long long)p->failures, (unsigned long long)max, addr);
    if (p->failures >= max) {
        p->locked_until_ms = now + window;
        p->refused = 0;
        qmcd_warn("auth: %s locked out for %lld ms after %llu failed attempts", addr,
                  (long long)window, (unsigned long long)p->failures);
    }
}

static void record_success(qmcd_auth *a, const char *addr)
{
    peer_failures *p = find_peer(a, addr);
    if (p)
        memset(p, 0, sizeof *p);
}

/* ---- the hooks ------------------------------------------------------------------ */

/* Frees c's handshake state (done, or the connection is going away). */
static void auth_conn_free(qmcd_conn *c)
{
    free(c->auth);
    c->auth = NULL;
}

/* Ends the handshake: HELLO_OK with version and our limits, after HELLO
 * (no authentication required) or a good AUTH_RESPONSE. */
static void hello_ok(qmcd_conn *c, uint64_t request_id, uint16_t version,
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
        qmcd_answered(c->srv, t0);
}


/* After HELLO's checks: 0 when this connection needs no authentication
 * (the caller answers HELLO_OK), 1 when the handshake is taken over: we
 * sent AUTH_CHALLENGE, or failed the connection (locked-out address, a
 * client that cannot speak version 3). */
static int challenge(qmcd_conn *c, const qmc_msg *m)
{
    if (!must_authenticate(c))
        return 0;
    qmcd_server *srv = c->srv;
    const qmc_msg_hello *h = &m->u.hello;
    char addr[AUTH_ADDR_BYTES];
    peer_address(c, addr, sizeof addr);
    const int64_t now = qmcd_now_ms();
    int64_t wait_ms = locked_for(srv->auth, addr, now);
    if (wait_ms) {
        srv->stats.auth_lockouts++;
        peer_failures *p = find_peer(srv->auth, addr);
        /* One line per lockout and then at powers of two: a client
         * retrying in a loop must not flood the log. */
        p->refused++;
        if ((p->refused & (p->refused - 1)) == 0)
            qmcd_warn("conn %llu (%s): refused: %s is locked out after failed "
                      "authentication (%llu refused so far, %lld ms left)",
                      (unsigned long long)c->id, c->peer, addr,
                      (unsigned long long)p->refused, (long long)wait_ms);
        qmcd_conn_fail(c, m->request_id, QMC_EAUTH,
                       "too many failed authentication attempts from %s; try again in %lld s",
                       addr, (long long)((wait_ms + 999) / 1000));
        return 1;
    }
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
    memcpy(ac->addr, addr, sizeof ac->addr);
    c->auth = ac;
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
     * once the proof is good (on_response). */
    if (challenge(c, m))
        return;
    hello_ok(
        c, m->request_id,
        (uint16_t)(h->version_max < SERVER_VERSION_MAX ? h->version_max : SERVER_VERSION_MAX),
        h->max_frame, t0);
}

static void on_response(qmcd_conn *c, const qmc_msg *m, int fd, int64_t t0_us)
{
    (void)fd; /* only QMCD_ROUTE_FD rows get one */
    qmcd_server *srv = c->srv;
    qmcd_auth_conn *ac = c->auth;
    if (!ac || ac->st.state != QMC_AUTH_CHALLENGED || m->request_id != ac->request_id) {
        srv->stats.malformed++;
        qmcd_conn_fail(c, m->request_id, QMC_EPROTO,
                       "AUTH_RESPONSE that answers no AUTH_CHALLENGE");
        return;
    }
    qmc_msg ok = {.type = QMC_MSG_AUTH_OK, .request_id = ac->request_id};
    int err = qmc_auth_server_verify(&ac->st, srv->auth->key, srv->auth->key_bytes,
                                     &m->u.response, &ok.u.auth_ok);
    if (err == QMC_EAUTH) {
        record_failure(c, ac->addr, qmcd_now_ms());
        qmcd_conn_fail(c, ac->request_id, QMC_EAUTH,
                       "authentication failed: the client's key is not the server's");
        return;
    }
    if (err) {
        qmcd_conn_fail(c, ac->request_id, err, "authentication: %s", qmc_strerror(err));
        return;
    }
    record_success(srv->auth, ac->addr);
    /* What outlives the connection (a session) belongs to this key: a
     * digest of it names the identity (conn_services.h). */
    crypto_generichash(c->key_id, sizeof c->key_id, srv->auth->key, srv->auth->key_bytes,
                       (const unsigned char *)"qmcd key id", 11);
    const uint64_t id = ac->request_id;
    const uint16_t version = ac->st.version;
    const uint32_t max_frame = ac->client_max_frame;
    auth_conn_free(c);
    qmcd_debug("conn %llu (%s): authenticated", (unsigned long long)c->id, c->peer);
    if (qmcd_conn_send(c, &ok) == 0)
        hello_ok(c, id, version, max_frame, t0_us);
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
