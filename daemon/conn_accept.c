/*
 * conn_accept.c - accepting client connections: who the peer is, where it
 * counts (admit.c: a Unix-socket client in max-connections at once, a TCP
 * one in the handshake budget until HELLO_OK), and a refusal it can read -
 * through the ordinary closing path (ERROR, linger, close), or at once
 * when QMCD_REFUSING_MAX refusals linger already.  A TCP newcomer is never
 * refused for room: the handshake admit.c names gives its place up here,
 * told why the same way.  A flood of refusals or evictions is one log line
 * a second.
 *
 * This file must not serve requests: an accepted connection is conn.c's.
 */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

#include "admit.h"
#include "conn.h"
#include "listen.h"
#include "log.h"
#include "loop.h"
#include "peers.h"

static void describe_peer(int fd, const qmcd_listener *l, char *out, size_t n)
{
    struct sockaddr_storage ss;
    socklen_t len = sizeof ss;
    char host[INET6_ADDRSTRLEN] = "?";
    if (getpeername(fd, (struct sockaddr *)&ss, &len) != 0 || ss.ss_family == AF_UNIX) {
        snprintf(out, n, "%.80s", l->name);
        return;
    }
    if (ss.ss_family == AF_INET6) {
        struct sockaddr_in6 *s6 = (struct sockaddr_in6 *)&ss;
        inet_ntop(AF_INET6, &s6->sin6_addr, host, sizeof host);
        snprintf(out, n, "[%s]:%u", host, ntohs(s6->sin6_port));
    } else {
        struct sockaddr_in *s4 = (struct sockaddr_in *)&ss;
        inet_ntop(AF_INET, &s4->sin_addr, host, sizeof host);
        snprintf(out, n, "%s:%u", host, ntohs(s4->sin_port));
    }
}

/* Draining, or a refusal when QMCD_REFUSING_MAX are lingering already:
 * tell the peer why, then close at once.
 * Whatever it already sent is read first so the close does not reset the
 * connection before the ERROR arrives. */
static void reject(qmcd_server *srv, int fd, const char *why)
{
    uint8_t junk[4096];
    while (recv(fd, junk, sizeof junk, MSG_DONTWAIT) > 0)
        ;
    char text[200];
    snprintf(text, sizeof text, "%s", why);
    qmc_msg m = {.type = QMC_MSG_ERROR, .request_id = 0};
    m.u.error.code = QMC_ETOOBIG;
    m.u.error.message.ptr = text;
    m.u.error.message.len = (uint32_t)strlen(text);
    uint8_t frame[512];
    int n = qmc_proto_encode(&m, frame, sizeof frame);
    if (n > 0 && send(fd, frame, (size_t)n, MSG_DONTWAIT | MSG_NOSIGNAL) == n)
        srv->stats.bytes_out += (uint64_t)n;
    shutdown(fd, SHUT_WR);
    close(fd);
    srv->stats.conns_rejected++;
    srv->stats.errors_sent++;
    srv->stats.limit_hits++;
}

/* A flood of refusals is one line a second, not one per socket.  what:
 * "refused a connection from", "closed a handshake of". */
static void log_refusal(qmcd_server *srv, const qmcd_listener *l, const qmcd_peer_key *key,
                        const char *what, const char *why)
{
    int64_t now = qmcd_now_ms();
    if (srv->refusal_log_ms && now - srv->refusal_log_ms < 1000) {
        srv->refusals_unlogged++;
        return;
    }
    char who[64];
    qmcd_peer_key_name(key, who, sizeof who);
    if (srv->refusals_unlogged)
        qmcd_warn("%s: %s %s: %s (and %llu more refusals in the last second)", l->name, what,
                  who, why, (unsigned long long)srv->refusals_unlogged);
    else
        qmcd_warn("%s: %s %s: %s", l->name, what, who, why);
    srv->refusal_log_ms = now;
    srv->refusals_unlogged = 0;
}

/* A TCP connection is about to enter the handshake budget: the handshake
 * admit.c names, if any, gives up its place first, told why (counted in
 * STATS handshakes_evicted).  One already failing has its ERROR out: it
 * is closed now, and not counted again. */
static void make_room(qmcd_server *srv, const qmcd_conn *c, const qmcd_listener *l)
{
    char why[240];
    qmcd_conn *v = qmcd_admit_victim(c, why, sizeof why);
    if (!v)
        return;
    if (v->closing) {
        qmcd_conn_close(v, "evicted from the handshake budget while closing");
        return;
    }
    srv->stats.handshakes_evicted++;
    log_refusal(srv, l, &v->net_key, "closed a handshake of", why);
    qmcd_admit_refuse(v);
    qmcd_conn_fail(v, 0, QMC_ETOOBIG, "%s", why);
    if (srv->n_refusing > QMCD_REFUSING_MAX && !v->dead) {
        /* Too many lingering already: the short way, its input read
         * first so that the close does not reset the ERROR away. */
        uint8_t junk[4096];
        while (recv(v->w.fd, junk, sizeof junk, MSG_DONTWAIT) > 0)
            ;
        qmcd_conn_close(v, "evicted from the handshake budget");
    }
}

void qmcd_conn_on_accept(qmcd_server *srv, qmcd_watch *w, uint32_t events)
{
    (void)events;
    qmcd_listener *l = (qmcd_listener *)w;
    for (int i = 0; i < 64; i++) {
        int fd = accept4(w->fd, NULL, NULL, SOCK_NONBLOCK | SOCK_CLOEXEC);
        if (fd < 0) {
            if (errno == EAGAIN || errno == EINTR || errno == ECONNABORTED)
                return;
            /* EMFILE and friends: the listener stays readable, so polling
             * it again would spin.  Stop polling it until the next tick
             * (qmcd_conns_tick re-arms it); the backlog holds the peer. */
            if (!l->paused)
                qmcd_warn("%s: accept: %s; pausing this listener for a tick", l->name,
                          strerror(errno));
            l->paused = 1;
            (void)qmcd_loop_mod(srv, &l->w, 0);
            return;
        }
        if (srv->draining) {
            reject(srv, fd, "server shutting down");
            continue;
        }
        /* Who it is decides where it counts: one peer (an address, or a
         * local user) may hold max-connections-per-peer, so that a greedy
         * one cannot fill max-connections for everyone; a TCP connection
         * waits for HELLO_OK in the handshake budget, by network. */
        qmcd_peer_key key;
        if (qmcd_peer_key_of(fd, &key) != 0) {
            reject(srv, fd, "cannot tell who this peer is");
            continue;
        }
        qmcd_conn *c = calloc(1, sizeof *c);
        if (!c) {
            reject(srv, fd, "out of memory");
            continue;
        }
        c->srv = srv;
        c->w.fd = fd;
        c->w.on_event = qmcd__conn_on_event;
        c->passed_fd = -1;
        c->peer_key = key;
        qmcd_peer_key_net(&key, &c->net_key);
        struct sockaddr_storage own;
        socklen_t own_len = sizeof own;
        c->unix_socket = getsockname(fd, (struct sockaddr *)&own, &own_len) == 0 &&
                         own.ss_family == AF_UNIX;
        char why[200];
        qmcd_admit_check(c, why, sizeof why);
        if (why[0] && srv->n_refusing >= QMCD_REFUSING_MAX) {
            /* Too many refusals already lingering: the short way. */
            free(c);
            reject(srv, fd, why);
            continue;
        }
        if (!why[0] && !c->unix_socket)
            make_room(srv, c, l);
        if (!why[0] && qmcd_admit_take(c) != 0) {
            free(c);
            reject(srv, fd, "out of memory");
            continue;
        }
        /* Answers are many small frames (a 1-point chunk, then END):
         * without TCP_NODELAY, Nagle holds the second until the peer's
         * delayed ACK, 40 ms later.  Unix sockets refuse the option:
         * harmless. */
        int one = 1;
        (void)setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
        c->id = ++srv->next_conn_id;
        c->accepted_ms = c->active_ms = qmcd_now_ms();
        describe_peer(fd, l, c->peer, sizeof c->peer);
        if (qmcd_loop_add(srv, &c->w, EPOLLIN) != 0) {
            qmcd_admit_release(c);
            close(fd);
            free(c);
            continue;
        }
        c->next = srv->conns;
        if (srv->conns)
            srv->conns->prev = c;
        srv->conns = c;
        if (why[0]) {
            /* Refused through the ordinary closing path: the ERROR is
             * queued, the peer's HELLO read and dropped, and the socket
             * closed once the peer has it or QMCD_LINGER_MS passed.  An
             * immediate close would reset a peer still sending its HELLO
             * (which then sees "broken pipe", not our reason). */
            qmcd_admit_refuse(c);
            srv->stats.conns_rejected++;
            log_refusal(srv, l, &key, "refused a connection from", why);
            qmcd_conn_fail(c, 0, QMC_ETOOBIG, "%s", why);
            continue;
        }
        srv->stats.conns_accepted++;
        qmcd_debug("conn %llu: accepted from %s", (unsigned long long)c->id, c->peer);
        /* Its HELLO is often here already (a client sends it with the
         * connect): read it now, so that a burst of honest clients
         * finishes its handshakes before the next accepts could evict
         * them from the handshake budget. */
        qmcd__conn_on_event(srv, &c->w, EPOLLIN);
    }
}
