/*
 * modbus_tcp.c - Modbus TCP on the daemon's event loop: the listeners,
 * the modbus-allow check at accept, and per connection the MBAP framing
 * (Modbus Messaging on TCP/IP Implementation Guide v1.0b, section 3.1.3:
 * transaction id, protocol id 0, length 2..254 counting the unit id and
 * the PDU, unit id) read non-blocking into a bounded buffer.
 *
 * A complete frame is answered at once by the pure handler
 * (protocol/modbus.c) with the bank of (client address, unit id) (see
 * modbus_sessions.c for why not one per connection; a client without one
 * is answered from the never-written default bank unless it writes) and
 * the reply queued; frames are read only while a full reply still fits, so a
 * client that does not read its answers stops being read rather than
 * growing a buffer, and is closed once no reply has been taken for
 * write-timeout-ms.  A client that starts a frame and does not finish it
 * within modbus-frame-timeout-ms is closed; so is one idle for
 * idle-timeout-ms.  Nothing here blocks, so a client dribbling one byte
 * every 100 ms costs the others nothing (libmodbus's own server waits in
 * select() for the rest of the frame, stalling everyone).  At accept, a
 * peer (modbus_peer.c) holding modbus-max-connections-per-peer is closed,
 * so silent sockets from one peer cannot take modbus-max-connections.
 *
 * Must not: interpret registers, or touch conn.c's connections.
 */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <errno.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

#include "log.h"
#include "loop.h"
#include "modbus_srv.h"

/* The largest MBAP frame: 7 header bytes and a 253-byte PDU. */
#define ADU_MAX (7 + QMC_MODBUS_MAX_PDU)
/* Input holds a few pipelined requests; output a few replies. */
#define IN_BYTES (4 * ADU_MAX)
#define OUT_BYTES (16 * ADU_MAX)
/* Reads per readiness event, so one busy client cannot hog a round. */
#define READS_PER_EVENT 8

struct qmcd_mb_conn {
    qmcd_watch w;                /* first: epoll hands us &conn->w */
    qmcd_modbus *mb;
    qmcd_mb_conn *prev, *next;   /* mb->conns, or mb->dead */
    qmcd_mb_peer key;            /* whose banks (modbus_sessions.c) */
    qmcd_mb_peer net;            /* whose share (modbus_peer.c) */
    unsigned hint;               /* the slot of the last bank used */
    char peer[64];
    int dead;
    size_t in_len, out_head, out_tail;
    int64_t partial_ms;          /* when the unfinished frame began, or 0 */
    int64_t active_ms;           /* last byte read or written */
    int64_t stall_ms;            /* replies pending and none taken since, or 0 */
    uint8_t in[IN_BYTES];
    uint8_t out[OUT_BYTES];
};

static void peer_name(const struct sockaddr_storage *ss, char *out, size_t n)
{
    char host[INET6_ADDRSTRLEN] = "?";
    if (ss->ss_family == AF_INET6) {
        const struct sockaddr_in6 *s6 = (const struct sockaddr_in6 *)ss;
        inet_ntop(AF_INET6, &s6->sin6_addr, host, sizeof host);
        snprintf(out, n, "[%s]:%u", host, ntohs(s6->sin6_port));
    } else {
        const struct sockaddr_in *s4 = (const struct sockaddr_in *)ss;
        inet_ntop(AF_INET, &s4->sin_addr, host, sizeof host);
        snprintf(out, n, "%s:%u", host, ntohs(s4->sin_port));
    }
}

static void conn_close(qmcd_mb_conn *c, const char *why)
{
    if (c->dead)
        return;
    qmcd_modbus *mb = c->mb;
    qmcd_debug("modbus: %s closed: %s", c->peer, why);
    qmcd_loop_del(mb->srv, &c->w);
    close(c->w.fd);
    c->w.fd = -1;
    c->dead = 1;
    qmcd__modbus_net_conn_remove(mb, &c->net);
    if (c->prev)
        c->prev->next = c->next;
    else
        mb->conns = c->next;
    if (c->next)
        c->next->prev = c->prev;
    c->prev = NULL;
    c->next = mb->dead;
    mb->dead = c;
    atomic_fetch_sub_explicit(&mb->ctr.conns_open, 1, memory_order_relaxed);
}

static size_t out_room(const qmcd_mb_conn *c)
{
    return OUT_BYTES - (c->out_tail - c->out_head);
}

static void flush(qmcd_mb_conn *c)
{
    while (c->out_head < c->out_tail) {
        ssize_t n = send(c->w.fd, c->out + c->out_head, c->out_tail - c->out_head,
                         MSG_NOSIGNAL | MSG_DONTWAIT);
        if (n > 0) {
            c->out_head += (size_t)n;
            c->active_ms = qmcd_now_ms();
            c->stall_ms = 0;
            continue;
        }
        if (n < 0 && errno == EINTR)
            continue;
        if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
            if (c->stall_ms == 0)
                c->stall_ms = qmcd_now_ms();
            return;
        }
        conn_close(c, n < 0 ? strerror(errno) : "send returned 0");
        return;
    }
    c->out_head = c->out_tail = 0;
}

/* Appends one reply; the caller checked out_room. */
static void queue(qmcd_mb_conn *c, const uint8_t *adu, size_t n)
{
    if (OUT_BYTES - c->out_tail < n) {
        memmove(c->out, c->out + c->out_head, c->out_tail - c->out_head);
        c->out_tail -= c->out_head;
        c->out_head = 0;
    }
    memcpy(c->out + c->out_tail, adu, n);
    c->out_tail += n;
}

/*
 * Answers one request PDU into resp (QMC_MODBUS_MAX_PDU bytes) with the
 * client's bank.  A client without one is answered from mb->defaults
 * unless the request writes; a write makes its bank, within the peer's
 * share and modbus-max-sessions (else exception 06, server busy: spec
 * section 7), and a write the handler refuses stores nothing, so the bank
 * made for it goes again.  A write is told the integration memory its bank
 * may hold (modbus_sessions.c), and what the bank holds after it is
 * counted.  Returns the response length.
 */
static int answer(qmcd_mb_conn *c, uint8_t unit, const uint8_t *req, size_t n,
                  const qmc_modbus_env *base, uint8_t *resp)
{
    qmcd_modbus *mb = c->mb;
    int64_t now = qmcd_now_ms();
    qmc_modbus_env env = *base; /* integration_bytes_max 0: reads start nothing */
    const int writes = qmc_modbus_request_writes(req, n);
    qmc_modbus_session *sess = qmcd__modbus_session_find(mb, &c->key, unit, now, &c->hint);
    if (!writes)
        return qmc_modbus_handle(sess ? sess : mb->defaults, &env, req, n, resp,
                                 QMC_MODBUS_MAX_PDU);
    if (sess) {
        env.integration_bytes_max = qmcd__modbus_session_room(mb, c->hint);
        int r = qmc_modbus_handle(sess, &env, req, n, resp, QMC_MODBUS_MAX_PDU);
        qmcd__modbus_session_account(mb, c->hint);
        return r;
    }
    int made = qmcd__modbus_session_make(mb, &c->key, &c->net, unit, now, &c->hint, &sess);
    if (made != QMCD_MB_MADE) {
        if (made == QMCD_MB_PEER_FULL)
            atomic_fetch_add_explicit(&mb->ctr.sessions_refused_per_peer, 1,
                                      memory_order_relaxed);
        else
            atomic_fetch_add_explicit(&mb->ctr.sessions_refused, 1, memory_order_relaxed);
        resp[0] = (uint8_t)(req[0] | 0x80);
        resp[1] = QMC_MODBUS_EX_SERVER_BUSY;
        return 2;
    }
    env.integration_bytes_max = qmcd__modbus_session_room(mb, c->hint);
    int r = qmc_modbus_handle(sess, &env, req, n, resp, QMC_MODBUS_MAX_PDU);
    if (r <= 0 || (resp[0] & 0x80))
        qmcd__modbus_session_drop(mb, c->hint);
    else
        qmcd__modbus_session_account(mb, c->hint);
    return r;
}

/* Answers every complete frame in c->in while replies fit; keeps the
 * rest.  Closes the connection on a header no Modbus TCP client sends
 * (the stream cannot be resynchronised after it). */
static void parse(qmcd_mb_conn *c)
{
    qmcd_modbus *mb = c->mb;
    size_t off = 0;
    int incomplete = 0, consumed = 0;
    while (!c->dead) {
        size_t have = c->in_len - off;
        const uint8_t *p = c->in + off;
        if (have < 7) {
            incomplete = have > 0;
            break;
        }
        unsigned proto = (unsigned)p[2] << 8 | p[3], len = (unsigned)p[4] << 8 | p[5];
        if (proto != 0 || len < 2 || len > 254) {
            atomic_fetch_add_explicit(&mb->ctr.malformed, 1, memory_order_relaxed);
            qmcd_info("modbus: %s: MBAP header with protocol id %u, length %u (want 0, "
                      "2..254); closing", c->peer, proto, len);
            conn_close(c, "malformed MBAP header");
            return;
        }
        if (have < 6 + (size_t)len) {
            incomplete = 1;
            break;
        }
        if (out_room(c) < ADU_MAX)
            break; /* resumes when the client reads its answers */
        qmc_modbus_env env;
        qmcd__modbus_env(mb, &env);
        uint8_t adu[ADU_MAX];
        int n = answer(c, p[6], p + 7, len - 1, &env, adu + 7);
        if (n <= 0) { /* cannot happen: len - 1 is 1..253 */
            conn_close(c, "handler refused a PDU");
            return;
        }
        memcpy(adu, p, 2);     /* transaction id, echoed */
        adu[2] = adu[3] = 0;   /* protocol id */
        adu[4] = (uint8_t)((n + 1) >> 8);
        adu[5] = (uint8_t)(n + 1);
        adu[6] = p[6];         /* unit id, echoed */
        queue(c, adu, 7 + (size_t)n);
        qmcd__modbus_count(mb, adu + 7);
        off += 6 + (size_t)len;
        consumed = 1;
    }
    if (c->dead)
        return;
    memmove(c->in, c->in + off, c->in_len - off);
    c->in_len -= off;
    if (!incomplete)
        c->partial_ms = 0;
    else if (consumed || c->partial_ms == 0)
        c->partial_ms = qmcd_now_ms(); /* a new frame began with this read */
    flush(c);
}

static void read_some(qmcd_mb_conn *c)
{
    for (int i = 0; i < READS_PER_EVENT && !c->dead; i++) {
        if (out_room(c) < ADU_MAX || c->in_len == IN_BYTES)
            return;
        size_t want = IN_BYTES - c->in_len;
        ssize_t n = recv(c->w.fd, c->in + c->in_len, want, MSG_DONTWAIT);
        if (n > 0) {
            c->in_len += (size_t)n;
            c->active_ms = qmcd_now_ms();
            parse(c);
            /* A short read drained the socket: epoll (level-triggered)
             * says when more comes, which saves a recv() that would only
             * return EAGAIN, a third of the syscalls of a request. */
            if ((size_t)n < want)
                return;
            continue;
        }
        if (n == 0) {
            conn_close(c, "peer closed");
            return;
        }
        if (errno == EINTR)
            continue;
        if (errno != EAGAIN && errno != EWOULDBLOCK)
            conn_close(c, strerror(errno));
        return;
    }
}

static void rearm(qmcd_mb_conn *c)
{
    uint32_t ev = 0;
    if (out_room(c) >= ADU_MAX && c->in_len < IN_BYTES)
        ev |= EPOLLIN;
    if (c->out_head < c->out_tail)
        ev |= EPOLLOUT;
    if (qmcd_loop_mod(c->mb->srv, &c->w, ev) != 0)
        conn_close(c, "epoll_ctl failed");
}

static void on_conn_event(qmcd_server *srv, qmcd_watch *w, uint32_t events)
{
    (void)srv;
    qmcd_mb_conn *c = (qmcd_mb_conn *)w;
    if (c->dead)
        return;
    if (events & EPOLLERR) {
        conn_close(c, "socket error");
        return;
    }
    if (events & EPOLLOUT) {
        flush(c);
        if (!c->dead && c->in_len >= 7)
            parse(c); /* frames held back while the replies did not fit */
    }
    if (!c->dead && (events & (EPOLLIN | EPOLLHUP)))
        read_some(c);
    if (!c->dead)
        rearm(c);
}

/* Closes an accepted socket we will not serve, and counts it.  Logged at
 * most once a second, with the count of the refusals not logged since, so
 * a flood of sockets cannot flood the log. */
static void refuse(qmcd_modbus *mb, int fd, const qmcd_listener *l, const char *peer,
                   const char *why)
{
    close(fd);
    atomic_fetch_add_explicit(&mb->ctr.conns_refused, 1, memory_order_relaxed);
    int64_t now = qmcd_now_ms();
    if (mb->refusal_logged_ms && now - mb->refusal_logged_ms < 1000) {
        mb->refusals_unlogged++;
        return;
    }
    if (mb->refusals_unlogged)
        qmcd_info("modbus: %s: refused %s: %s (and %llu other refusal(s) in the last "
                  "second)", l->name, peer, why, (unsigned long long)mb->refusals_unlogged);
    else
        qmcd_info("modbus: %s: refused %s: %s", l->name, peer, why);
    mb->refusal_logged_ms = now;
    mb->refusals_unlogged = 0;
}

static void on_accept(qmcd_server *srv, qmcd_watch *w, uint32_t events)
{
    (void)events;
    qmcd_modbus *mb = srv->modbus;
    qmcd_listener *l = (qmcd_listener *)w;
    for (int i = 0; i < 64; i++) {
        struct sockaddr_storage ss;
        socklen_t len = sizeof ss;
        int fd = accept4(w->fd, (struct sockaddr *)&ss, &len, SOCK_NONBLOCK | SOCK_CLOEXEC);
        if (fd < 0) {
            if (errno == EAGAIN || errno == EINTR || errno == ECONNABORTED)
                return;
            /* Out of descriptors: poll again on the next tick, not now. */
            if (!l->paused)
                qmcd_warn("modbus: %s: accept: %s; pausing for a tick", l->name,
                          strerror(errno));
            l->paused = 1;
            (void)qmcd_loop_mod(srv, &l->w, 0);
            return;
        }
        char peer[64];
        peer_name(&ss, peer, sizeof peer);
        if (mb->n_allow && !qmcd_modbus_allow_match(mb->allow, mb->n_allow, &ss)) {
            refuse(mb, fd, l, peer, "not in modbus-allow");
            continue;
        }
        qmcd_mb_peer key, net;
        qmcd__modbus_peer_key(&ss, &key);
        qmcd__modbus_net_of(&key, &net);
        /* The peer's cap first: the peer at fault is the one named. */
        uint64_t cap = qmcd__modbus_share(srv->cfg.modbus_max_connections_per_peer,
                                          srv->cfg.modbus_max_connections);
        if (!mb->draining && qmcd__modbus_net_conns(mb, &net) >= cap) {
            char why[128], name[64];
            qmcd__modbus_net_name(&net, name, sizeof name);
            snprintf(why, sizeof why, "modbus-max-connections-per-peer (%llu) reached for %s",
                     (unsigned long long)cap, name);
            atomic_fetch_add_explicit(&mb->ctr.conns_refused_per_peer, 1,
                                      memory_order_relaxed);
            refuse(mb, fd, l, peer, why);
            continue;
        }
        uint64_t open_now = atomic_load_explicit(&mb->ctr.conns_open, memory_order_relaxed);
        if (mb->draining || open_now >= srv->cfg.modbus_max_connections) {
            refuse(mb, fd, l, peer,
                   mb->draining ? "server shutting down" : "modbus-max-connections reached");
            continue;
        }
        qmcd_mb_conn *c = calloc(1, sizeof *c);
        if (!c || qmcd__modbus_net_conn_add(mb, &net) != 0) {
            free(c);
            refuse(mb, fd, l, peer, "out of memory");
            continue;
        }
        c->key = key;
        c->net = net;
        int one = 1;
        (void)setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
        c->w.fd = fd;
        c->w.on_event = on_conn_event;
        c->mb = mb;
        snprintf(c->peer, sizeof c->peer, "%s", peer);
        c->active_ms = qmcd_now_ms();
        if (qmcd_loop_add(srv, &c->w, EPOLLIN) != 0) {
            qmcd__modbus_net_conn_remove(mb, &net);
            free(c);
            refuse(mb, fd, l, peer, "epoll_ctl failed");
            continue;
        }
        c->next = mb->conns;
        if (mb->conns)
            mb->conns->prev = c;
        mb->conns = c;
        atomic_fetch_add_explicit(&mb->ctr.conns_accepted, 1, memory_order_relaxed);
        atomic_fetch_add_explicit(&mb->ctr.conns_open, 1, memory_order_relaxed);
        qmcd_debug("modbus: %s: accepted %s", l->name, peer);
    }
}

/* Would "HOST:PORT" bind a loopback address?  1 or 0; a name is resolved
 * as qmcd_listen_tcp resolves it (its first address), before anything is
 * bound, and one that does not resolve is -1 with why (not "off
 * loopback": nothing says where it would be). */
static int binds_loopback(const char *hostport, char *why, size_t why_bytes)
{
    int numeric = qmcd_modbus_host_loopback(hostport);
    if (numeric >= 0)
        return numeric;
    char host[256];
    const char *end = strrchr(hostport, ':');
    if (!end || (size_t)(end - hostport) >= sizeof host) {
        snprintf(why, why_bytes, "modbus tcp:%s: want tcp:HOST:PORT", hostport);
        return -1;
    }
    memcpy(host, hostport, (size_t)(end - hostport));
    host[end - hostport] = '\0';
    struct addrinfo hints = {.ai_family = AF_UNSPEC, .ai_socktype = SOCK_STREAM,
                             .ai_flags = AI_PASSIVE | AI_NUMERICSERV};
    struct addrinfo *res = NULL;
    int gai = getaddrinfo(host, "0", &hints, &res);
    if (gai != 0) {
        snprintf(why, why_bytes, "modbus tcp:%s: host '%s' does not resolve (%s); not starting",
                 hostport, host, gai_strerror(gai));
        return -1;
    }
    int loop = qmcd_modbus_is_loopback(res->ai_addr);
    freeaddrinfo(res);
    return loop;
}

int qmcd__modbus_tcp_open(qmcd_modbus *mb, const char *hostport, qmcd_listener *l, char *why,
                          size_t why_bytes)
{
    l->w.fd = -1;
    /* Modbus has no authentication: its security guide's answer is to
     * filter by address, so off loopback the operator must name who may
     * connect.  Checked before binding, so nothing is ever exposed. */
    int loop = binds_loopback(hostport, why, why_bytes);
    if (loop < 0)
        return -1;
    if (mb->n_allow == 0 && !loop) {
        snprintf(why, why_bytes,
                 "modbus tcp:%s: listening off loopback needs modbus-allow = CIDR,... "
                 "(Modbus has no authentication); not starting", hostport);
        return -1;
    }
    if (qmcd_listen_tcp(hostport, l, why, why_bytes) != 0) {
        l->w.fd = -1;
        return -1;
    }
    return 0;
}

int qmcd__modbus_tcp_start(qmcd_modbus *mb)
{
    for (unsigned i = 0; i < mb->n_listeners; i++) {
        qmcd_listener *l = &mb->listeners[i];
        l->w.on_event = on_accept;
        int err = qmcd_loop_add(mb->srv, &l->w, EPOLLIN);
        if (err)
            return err;
        qmcd_info("modbus: listening on %s%s", l->name,
                  mb->n_allow ? " (modbus-allow applies)" : "");
    }
    return 0;
}

void qmcd__modbus_tcp_tick(qmcd_modbus *mb, int64_t now_ms)
{
    const qmcd_config *cfg = &mb->srv->cfg;
    for (unsigned i = 0; i < mb->n_listeners; i++) {
        qmcd_listener *l = &mb->listeners[i];
        if (l->paused && !mb->draining && l->w.fd >= 0 &&
            qmcd_loop_mod(mb->srv, &l->w, EPOLLIN) == 0)
            l->paused = 0;
    }
    for (qmcd_mb_conn *c = mb->conns, *next; c; c = next) {
        next = c->next;
        if (c->stall_ms && now_ms - c->stall_ms >= (int64_t)cfg->write_timeout_ms) {
            /* It sends requests but takes no answers: reading it stopped
             * when its replies filled the buffer; now it goes. */
            qmcd_info("modbus: %s: no reply taken for %llu ms; closing", c->peer,
                      (unsigned long long)cfg->write_timeout_ms);
            conn_close(c, "write stall");
        } else if (c->partial_ms &&
                   now_ms - c->partial_ms >= (int64_t)cfg->modbus_frame_timeout_ms) {
            qmcd_info("modbus: %s: frame unfinished after %llu ms; closing", c->peer,
                      (unsigned long long)cfg->modbus_frame_timeout_ms);
            conn_close(c, "partial frame deadline");
        } else if (now_ms - c->active_ms >= (int64_t)cfg->idle_timeout_ms) {
            conn_close(c, "idle");
        }
    }
    if (mb->refusals_unlogged && now_ms - mb->refusal_logged_ms >= 1000) {
        qmcd_info("modbus: %llu more connection(s) refused in the last second",
                  (unsigned long long)mb->refusals_unlogged);
        mb->refusals_unlogged = 0;
        mb->refusal_logged_ms = now_ms;
    }
    qmcd__modbus_sessions_expire(mb, now_ms, (int64_t)cfg->idle_timeout_ms);
}

void qmcd__modbus_tcp_reap(qmcd_modbus *mb)
{
    while (mb->dead) {
        qmcd_mb_conn *c = mb->dead;
        mb->dead = c->next;
        free(c);
    }
}

void qmcd__modbus_tcp_close_all(qmcd_modbus *mb, const char *why)
{
    while (mb->conns) {
        qmcd_mb_conn *c = mb->conns;
        flush(c); /* the last answers, if the socket takes them now */
        conn_close(c, why);
    }
}

void qmcd__modbus_tcp_close_listeners(qmcd_modbus *mb)
{
    for (unsigned i = 0; mb->listeners && i < mb->n_listeners; i++) {
        qmcd_listener *l = &mb->listeners[i];
        if (l->w.fd < 0)
            continue;
        if (l->w.events)
            qmcd_loop_del(mb->srv, &l->w);
        close(l->w.fd);
        l->w.fd = -1;
    }
}
