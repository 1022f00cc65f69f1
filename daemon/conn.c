/*
 * conn.c - client connections: accepting, reading frames out of a bounded
 * input buffer, a bounded output buffer drained as the socket allows, and
 * the deadlines that keep a stuck peer from holding anything for long.
 *
 * Buffers.  Input holds at most one frame header plus max-frame bytes: the
 * header's payload_len is checked against max-frame before any payload is
 * buffered.  Output is one contiguous buffer capped by out-buffer-bytes.
 * Requests are read only while QMCD_OUT_RESERVE bytes of output are free,
 * so a peer that sends but never reads stops being read (TCP then pushes
 * back on it) instead of growing our memory; and POINTS data is generated
 * only into free space (points.c), never queued ahead of the socket.
 *
 * Descriptors.  Unix-socket connections are read with recvmsg, so that a
 * memfd passed with SCM_RIGHTS (SHM_ATTACH, PROTOCOL.md section 10) is
 * seen.  Linux hands a descriptor out with the read that reaches the first
 * byte of the sendmsg that carried it; that read may begin with bytes sent
 * before (never after), so all we know is that the descriptor's bytes lie
 * within the read.  It is kept, with the read's stream offsets, until the
 * first SHM_ATTACH frame that begins within them claims it.  A descriptor
 * whose bytes hold no SHM_ATTACH start, more than one at once, a truncated
 * control message: all are closed at once and the connection fails, so a
 * peer cannot leave descriptors in the daemon.
 *
 * Closing.  A connection that gets a fatal ERROR (malformed frame,
 * timeouts) stops reading requests, flushes the ERROR, shuts down its
 * write side and discards input until the peer closes or QMCD_LINGER_MS
 * passes: closing with unread input would send a TCP reset that can make
 * the peer lose the ERROR.  Freed memory is deferred to the end of the
 * loop round, since epoll may still hold events for it.
 *
 * This file must not interpret requests (dispatch.c does) or generate
 * points or run jobs (points.c, jobs.c).
 */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <netinet/tcp.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <sys/un.h>
#include <unistd.h>

#include "auth.h"
#include "conn.h"
#include "dispatch.h"
#include "jobs.h"
#include "listen.h"
#include "log.h"
#include "loop.h"
#include "points.h"

/* The input buffer starts this small and grows to the frame being read. */
#define IN_START_BYTES (16u << 10)
/* Fairness: how much one connection may read, or be sent, per event. */
#define READ_BUDGET_BYTES (1u << 20)
#define PUMP_ROUNDS 8
#define PRODUCE_LIMIT 256
#define PRODUCE_BATCH_BYTES (64u << 10)
/* Descriptors one recvmsg can take; a legitimate peer sends one at a time
 * (room for more only so that extras are seen and closed, not truncated). */
#define RECV_FDS_MAX 4

static void conn_on_event(qmcd_server *srv, qmcd_watch *w, uint32_t events);

/* ---- output buffer ---------------------------------------------------------- */

size_t qmcd_conn_out_room(const qmcd_conn *c)
{
    size_t pending = c->out_tail - c->out_head;
    size_t cap = (size_t)c->srv->cfg.out_buffer_bytes;
    return pending >= cap ? 0 : cap - pending;
}

uint8_t *qmcd_conn_out_reserve(qmcd_conn *c, size_t bytes, size_t align_at)
{
    if (bytes > qmcd_conn_out_room(c))
        return NULL;
    size_t pending = c->out_tail - c->out_head;
    /* Where the new bytes start must make out + start + align_at a multiple
     * of 64.  The buffer itself is 64-byte aligned. */
    size_t start = c->out_tail;
    /* Only POINTS data asks for alignment (QMCD_NO_ALIGN otherwise): were
     * every small answer realigned, filling the buffer would move all the
     * pending bytes once per frame - quadratic in the backlog. */
    const int wants_align = align_at != QMCD_NO_ALIGN;
    int misaligned = wants_align && ((start + align_at) & 63u) != 0;
    if (!misaligned && start + bytes <= c->out_alloc)
        return c->out + start;
    /* Move pending bytes to the front, at the offset (< 64) that aligns the
     * new frame; grow if needed (up to the cap plus the 64-byte slack). */
    size_t head = wants_align ? (64u - ((pending + align_at) & 63u)) & 63u : 0;
    size_t need = head + pending + bytes;
    if (need > c->out_alloc) {
        size_t n = c->out_alloc ? c->out_alloc : 64u << 10;
        while (n < need)
            n *= 2;
        size_t max = (size_t)c->srv->cfg.out_buffer_bytes + 128;
        if (n > max)
            n = max < need ? need : max;
        void *p = NULL;
        if (posix_memalign(&p, 64, n) != 0)
            return NULL;
        if (pending)
            memcpy((uint8_t *)p + head, c->out + c->out_head, pending);
        free(c->out);
        c->out = p;
        c->out_alloc = n;
    } else if (pending && head != c->out_head) {
        memmove(c->out + head, c->out + c->out_head, pending);
    }
    c->out_head = head;
    c->out_tail = head + pending;
    return c->out + c->out_tail;
}

void qmcd_conn_out_commit(qmcd_conn *c, size_t bytes)
{
    if (c->out_tail == c->out_head && c->stall_ms == 0)
        c->stall_ms = qmcd_now_ms();
    c->out_tail += bytes;
    c->srv->stats.frames_out++;
}

int qmcd_conn_send(qmcd_conn *c, const qmc_msg *m)
{
    if (c->dead)
        return -1;
    size_t size = qmc_proto_encoded_size(m);
    if (size == 0) {
        qmcd_err("conn %llu: cannot encode a %s frame", (unsigned long long)c->id,
                 qmc_msg_type_name(m->type));
        return -1;
    }
    uint8_t *p = qmcd_conn_out_reserve(c, size, QMCD_NO_ALIGN);
    if (!p) {
        /* Cannot happen for small answers while the reserve rule holds;
         * if it does, the peer is far behind: let it go. */
        qmcd_conn_close(c, "output buffer full");
        return -1;
    }
    int n = qmc_proto_encode(m, p, size);
    if (n < 0) {
        qmcd_err("conn %llu: encoding %s: %s", (unsigned long long)c->id,
                 qmc_msg_type_name(m->type), qmc_strerror(n));
        return -1;
    }
    qmcd_conn_out_commit(c, (size_t)n);
    return 0;
}

__attribute__((format(printf, 4, 0))) static int verror(qmcd_conn *c, uint64_t request_id,
                                                       int code, const char *fmt, va_list ap)
{
    char text[QMC_PROTO_MAX_MESSAGE];
    vsnprintf(text, sizeof text, fmt, ap);
    /* One line of valid UTF-8: control characters become spaces, and
     * only ASCII survives (library reasons are ASCII; anything else came
     * from the peer). */
    for (char *p = text; *p; p++)
        if ((unsigned char)*p < 0x20 || (unsigned char)*p >= 0x7f)
            *p = ' ';
    qmc_msg m = {.type = QMC_MSG_ERROR, .request_id = request_id};
    m.u.error.code = code < 0 ? code : QMC_EINVAL;
    m.u.error.message.ptr = text;
    m.u.error.message.len = (uint32_t)strlen(text);
    c->srv->stats.errors_sent++;
    if (code == QMC_ETOOBIG)
        c->srv->stats.limit_hits++;
    qmcd_debug("conn %llu: request %llu: ERROR %s: %s", (unsigned long long)c->id,
               (unsigned long long)request_id, qmc_err_name(code), text);
    return qmcd_conn_send(c, &m);
}

int qmcd_conn_error(qmcd_conn *c, uint64_t request_id, int code, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int rc = verror(c, request_id, code, fmt, ap);
    va_end(ap);
    return rc;
}

/* ---- lifecycle ------------------------------------------------------------------ */

static void drop_passed_fd(qmcd_conn *c)
{
    if (c->passed_fd >= 0)
        close(c->passed_fd);
    c->passed_fd = -1;
}

static void unlink_conn(qmcd_conn *c)
{
    qmcd_server *srv = c->srv;
    if (c->prev)
        c->prev->next = c->next;
    else
        srv->conns = c->next;
    if (c->next)
        c->next->prev = c->prev;
    c->prev = c->next = NULL;
}

void qmcd_conn_close(qmcd_conn *c, const char *why)
{
    if (c->dead)
        return;
    qmcd_server *srv = c->srv;
    /* Ordinary goodbyes are debug; anything else is worth a line. */
    qmcd_log(strcmp(why, "peer closed") == 0 ? QMCD_LOG_DEBUG : QMCD_LOG_INFO,
             "conn %llu (%s): closed: %s", (unsigned long long)c->id, c->peer, why);
    qmcd_points_drop_all(c);
    qmcd_jobs_drop_all(c);
    drop_passed_fd(c);
    qmcd_loop_del(srv, &c->w);
    close(c->w.fd);
    c->w.fd = -1;
    c->dead = 1;
    unlink_conn(c);
    srv->n_conns--;
    srv->stats.conns_closed++;
    c->next = srv->dead_conns;
    srv->dead_conns = c;
}

void qmcd_conns_reap(qmcd_server *srv)
{
    while (srv->dead_conns) {
        qmcd_conn *c = srv->dead_conns;
        srv->dead_conns = c->next;
        qmcd_auth_conn_free(c);
        free(c->in);
        free(c->out);
        free(c);
    }
}

void qmcd_conn_fail(qmcd_conn *c, uint64_t request_id, int code, const char *fmt, ...)
{
    if (c->dead || c->closing)
        return;
    va_list ap;
    va_start(ap, fmt);
    char why[200];
    va_list ap2;
    va_copy(ap2, ap);
    vsnprintf(why, sizeof why, fmt, ap2);
    va_end(ap2);
    int rc = verror(c, request_id, code, fmt, ap);
    va_end(ap);
    if (rc != 0)
        return; /* already closed */
    qmcd_info("conn %llu (%s): closing: %s", (unsigned long long)c->id, c->peer, why);
    c->closing = 1;
    c->close_by_ms = qmcd_now_ms() + QMCD_LINGER_MS;
    qmcd_points_drop_all(c);
    qmcd_jobs_drop_all(c);
    drop_passed_fd(c);
    c->in_len = 0;
    c->partial_ms = 0;
    qmcd_conn_kick(c);
}

/* ---- accept --------------------------------------------------------------------- */

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

/* Over max-connections (or draining): tell the peer why, then close.
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
        if (srv->n_conns >= srv->cfg.max_connections) {
            char why[120];
            snprintf(why, sizeof why, "max-connections (%llu) reached; try later",
                     (unsigned long long)srv->cfg.max_connections);
            qmcd_warn("%s: refused a connection: %s", l->name, why);
            reject(srv, fd, why);
            continue;
        }
        qmcd_conn *c = calloc(1, sizeof *c);
        if (!c) {
            reject(srv, fd, "out of memory");
            continue;
        }
        /* Answers are many small frames (a 1-point chunk, then END):
         * without TCP_NODELAY, Nagle holds the second until the peer's
         * delayed ACK, 40 ms later.  Unix sockets refuse the option:
         * harmless. */
        int one = 1;
        (void)setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
        c->srv = srv;
        c->w.fd = fd;
        c->w.on_event = conn_on_event;
        c->passed_fd = -1;
        struct sockaddr_storage own;
        socklen_t own_len = sizeof own;
        c->unix_socket = getsockname(fd, (struct sockaddr *)&own, &own_len) == 0 &&
                         own.ss_family == AF_UNIX;
        c->id = ++srv->next_conn_id;
        c->accepted_ms = c->active_ms = qmcd_now_ms();
        describe_peer(fd, l, c->peer, sizeof c->peer);
        if (qmcd_loop_add(srv, &c->w, EPOLLIN) != 0) {
            close(fd);
            free(c);
            continue;
        }
        c->next = srv->conns;
        if (srv->conns)
            srv->conns->prev = c;
        srv->conns = c;
        srv->n_conns++;
        srv->stats.conns_accepted++;
        qmcd_debug("conn %llu: accepted from %s", (unsigned long long)c->id, c->peer);
    }
}

/* ---- reading ------------------------------------------------------------------- */

static int in_reserve(qmcd_conn *c, size_t need)
{
    if (need <= c->in_alloc)
        return 0;
    size_t n = c->in_alloc ? c->in_alloc : IN_START_BYTES;
    while (n < need)
        n *= 2;
    uint8_t *p = realloc(c->in, n);
    if (!p)
        return -1;
    c->in = p;
    c->in_alloc = n;
    return 0;
}

/* The largest payload we accept now (max-frame may change on SIGHUP). */
/* The largest payload we accept from this peer: what HELLO_OK promised
 * it, or before that the current configuration. */
static uint32_t max_payload(const qmcd_conn *c)
{
    return c->server_max_frame ? c->server_max_frame : (uint32_t)c->srv->cfg.max_frame;
}

/* Decodes and dispatches the complete frames in the input buffer, while
 * there is output room for their answers. */
static void parse_frames_inner(qmcd_conn *c)
{
    size_t off = 0;
    /* Frames parsed together arrived together: one clock read serves as
     * every request's start time (the latency statistics' t0). */
    const int64_t t0_us = qmcd_now_us();
    while (!c->dead && !c->closing && qmcd_conn_out_room(c) >= QMCD_OUT_RESERVE) {
        const uint8_t *p = c->in + off;
        size_t avail = c->in_len - off;
        /* Every frame that began within a passed descriptor's bytes has
         * been read, and none claimed it. */
        if (c->passed_fd >= 0 && c->in_offset + off >= c->passed_fd_to) {
            c->srv->stats.malformed++;
            qmcd_conn_fail(c, 0, QMC_EPROTO, "a file descriptor came without an SHM_ATTACH "
                           "frame; only SHM_ATTACH carries one");
            return;
        }
        if (avail == 0)
            break;
        qmc_msg_type type;
        uint64_t id;
        uint32_t plen;
        int rc = qmc_proto_peek(p, avail, max_payload(c), &type, &id, &plen);
        if (rc == QMC_EAGAIN)
            break;
        if (rc == QMC_ETOOBIG) {
            uint32_t said = avail >= 20 ? (uint32_t)p[16] | (uint32_t)p[17] << 8 |
                                              (uint32_t)p[18] << 16 | (uint32_t)p[19] << 24
                                        : 0;
            c->srv->stats.malformed++;
            qmcd_conn_fail(c, avail >= 16 ? id : 0, QMC_ETOOBIG,
                           "frame payload of %u bytes exceeds max-frame (%u bytes)", said,
                           max_payload(c));
            return;
        }
        if (rc < 0) {
            c->srv->stats.malformed++;
            qmcd_conn_fail(c, 0, QMC_EPROTO, "malformed frame header (magic, version, "
                                             "type, flags or length): %s",
                           qmc_strerror(rc));
            return;
        }
        /* Decided from the header, before buffering any payload: before
         * HELLO only HELLO is welcome (PROTOCOL.md), and a server-only
         * type is never a request.  The handler would refuse them too,
         * but only after up to max-frame bytes had been buffered. */
        if (!c->hello_done && type != QMC_MSG_HELLO &&
            !(type == QMC_MSG_AUTH_RESPONSE && qmcd_auth_pending(c))) {
            c->srv->stats.malformed++;
            qmcd_conn_fail(c, id, QMC_EPROTO, "the first frame must be HELLO, not %s",
                           qmc_msg_type_name(type));
            return;
        }
        size_t frame = QMC_PROTO_HEADER_BYTES + (size_t)plen;
        if (avail < frame) {
            if (in_reserve(c, off + frame) != 0) {
                qmcd_conn_fail(c, id, QMC_ENOMEM, "out of memory for a %zu-byte frame", frame);
                return;
            }
            break;
        }
        /* The first SHM_ATTACH that begins within the bytes a passed
         * descriptor came with takes it. */
        int fd = -1;
        const uint64_t at = c->in_offset + off;
        if (c->passed_fd >= 0 && type == QMC_MSG_SHM_ATTACH && at >= c->passed_fd_from) {
            fd = c->passed_fd;
            c->passed_fd = -1;
        }
        qmc_msg m;
        rc = qmc_proto_decode(p, frame, max_payload(c), &m);
        if (rc < 0) {
            if (fd >= 0)
                close(fd);
            c->srv->stats.malformed++;
            qmcd_conn_fail(c, id, rc, "malformed %s payload: %s", qmc_msg_type_name(type),
                           qmc_strerror(rc));
            return;
        }
        c->srv->stats.frames_in++;
        qmcd_dispatch(c, &m, fd, t0_us);
        off += frame;
    }
    if (c->dead)
        return;
    if (c->closing) {
        c->in_len = 0; /* nothing more of this peer's input is read */
        return;
    }
    if (off) {
        memmove(c->in, c->in + off, c->in_len - off);
        c->in_len -= off;
        c->in_offset += off;
        c->partial_ms = 0;
    }
    if (c->in_len && !c->partial_ms)
        c->partial_ms = qmcd_now_ms();
    if (!c->in_len) {
        c->partial_ms = 0;
        if (c->in_alloc > IN_START_BYTES) { /* the big frame is gone: give it back */
            free(c->in);
            c->in = NULL;
            c->in_alloc = 0;
        }
    }
}

static void parse_frames(qmcd_conn *c)
{
    c->parsing = 1;
    parse_frames_inner(c);
    c->parsing = 0;
}

/* recv, or on a Unix socket recvmsg that also takes passed descriptors
 * (see the file comment).  Returns as recv, or -2 after failing the
 * connection for a descriptor it may not send. */
static ssize_t conn_recv(qmcd_conn *c, uint8_t *buf, size_t n)
{
    if (!c->unix_socket)
        return recv(c->w.fd, buf, n, 0);
    union {
        struct cmsghdr align;
        char bytes[CMSG_SPACE(sizeof(int) * RECV_FDS_MAX)];
    } ctl;
    struct iovec iov = {buf, n};
    struct msghdr mh;
    memset(&mh, 0, sizeof mh);
    mh.msg_iov = &iov;
    mh.msg_iovlen = 1;
    mh.msg_control = ctl.bytes;
    mh.msg_controllen = sizeof ctl.bytes;
    ssize_t r = recvmsg(c->w.fd, &mh, MSG_CMSG_CLOEXEC);
    if (r < 0)
        return r;
    int fds[RECV_FDS_MAX];
    size_t nfds = 0, extra = 0;
    for (struct cmsghdr *cm = CMSG_FIRSTHDR(&mh); cm; cm = CMSG_NXTHDR(&mh, cm)) {
        if (cm->cmsg_level != SOL_SOCKET || cm->cmsg_type != SCM_RIGHTS)
            continue;
        size_t k = (cm->cmsg_len - CMSG_LEN(0)) / sizeof(int);
        for (size_t i = 0; i < k; i++) {
            int fd;
            memcpy(&fd, CMSG_DATA(cm) + i * sizeof(int), sizeof fd);
            if (nfds < RECV_FDS_MAX) {
                fds[nfds++] = fd;
            } else {
                close(fd);
                extra++;
            }
        }
    }
    if (nfds == 0 && !(mh.msg_flags & MSG_CTRUNC))
        return r;
    const char *why = NULL;
    if (mh.msg_flags & MSG_CTRUNC)
        why = "more file descriptors than one message may carry";
    else if (nfds + extra > 1)
        why = "more than one file descriptor at once";
    else if (c->passed_fd >= 0)
        why = "a second file descriptor before the first was claimed";
    if (why) {
        for (size_t i = 0; i < nfds; i++)
            close(fds[i]);
        c->srv->stats.malformed++;
        qmcd_conn_fail(c, 0, QMC_EPROTO, "%s; only SHM_ATTACH carries one", why);
        return -2;
    }
    c->passed_fd = fds[0];
    c->passed_fd_from = c->in_offset + c->in_len;
    c->passed_fd_to = c->passed_fd_from + (uint64_t)r;
    return r;
}

static void do_read(qmcd_conn *c)
{
    size_t total = 0;
    while (!c->dead && total < READ_BUDGET_BYTES) {
        if (c->wr_shut || c->closing) {
            /* Only draining the peer's leftovers before closing. */
            uint8_t junk[16384];
            ssize_t n = recv(c->w.fd, junk, sizeof junk, 0);
            if (n > 0) {
                total += (size_t)n;
                continue;
            }
            if (n == 0 || (errno != EAGAIN && errno != EINTR))
                qmcd_conn_close(c, n == 0 ? "closed after error" : strerror(errno));
            return;
        }
        if (c->in_alloc == 0 && in_reserve(c, IN_START_BYTES) != 0)
            return;
        /* Full means complete frames wait for output room (EPOLLIN is then
         * off): parse_frames grows the buffer for a frame still arriving,
         * up to the header plus max-frame. */
        if (c->in_len == c->in_alloc)
            return;
        const size_t asked = c->in_alloc - c->in_len;
        ssize_t n = conn_recv(c, c->in + c->in_len, asked);
        if (n == -2)
            return; /* failed: a descriptor it may not pass */
        if (n > 0) {
            c->in_len += (size_t)n;
            total += (size_t)n;
            c->srv->stats.bytes_in += (uint64_t)n;
            c->active_ms = qmcd_now_ms();
            parse_frames(c);
            if (qmcd_conn_out_room(c) < QMCD_OUT_RESERVE)
                return; /* answers are backing up: stop reading */
            /* A short read took what was there: skip the recv that would
             * only say EAGAIN (a syscall per request on the small-request
             * path).  epoll is level-triggered, so whatever arrives later,
             * EOF included, is reported again. */
            if ((size_t)n < asked)
                return;
            continue;
        }
        if (n == 0) {
            c->peer_eof = 1;
            return;
        }
        if (errno == EAGAIN || errno == EINTR)
            return;
        qmcd_conn_close(c, strerror(errno));
        return;
    }
}

/* ---- writing ------------------------------------------------------------------- */

/* Sends what is pending.  Returns 0, or -1 if the connection closed. */
static int flush(qmcd_conn *c)
{
    while (c->out_tail > c->out_head) {
        ssize_t n = send(c->w.fd, c->out + c->out_head, c->out_tail - c->out_head,
                         MSG_DONTWAIT | MSG_NOSIGNAL);
        if (n > 0) {
            c->out_head += (size_t)n;
            c->srv->stats.bytes_out += (uint64_t)n;
            c->stall_ms = qmcd_now_ms();
            c->active_ms = c->stall_ms;
            continue;
        }
        if (n < 0 && (errno == EAGAIN || errno == EINTR))
            return 0;
        qmcd_conn_close(c, n < 0 ? strerror(errno) : "send returned 0");
        return -1;
    }
    c->out_head = c->out_tail = 0;
    c->stall_ms = 0;
    if (c->out_alloc > (256u << 10) && c->n_streams == 0) {
        /* The stream that needed a big buffer is over: give it back. */
        free(c->out);
        c->out = NULL;
        c->out_alloc = 0;
    }
    return 0;
}

static void update_interest(qmcd_conn *c)
{
    uint32_t ev = 0;
    int pending = c->out_tail > c->out_head;
    if (c->closing) {
        if (pending)
            ev |= EPOLLOUT;
        else
            ev |= EPOLLIN; /* drain until the peer closes */
    } else {
        if (!c->peer_eof && qmcd_conn_out_room(c) >= QMCD_OUT_RESERVE)
            ev |= EPOLLIN;
        /* Streams waiting for ring slots wait for SHM_RELEASE (EPOLLIN):
         * a writable socket alone would only spin the loop. */
        if (pending || qmcd_points_want_output(c))
            ev |= EPOLLOUT;
    }
    if (qmcd_loop_mod(c->srv, &c->w, ev) != 0)
        qmcd_conn_close(c, "epoll_ctl failed");
}

void qmcd_conn_kick(qmcd_conn *c)
{
    for (int round = 0; round < PUMP_ROUNDS && !c->dead; round++) {
        int produced = 0;
        /* Requests left in the input buffer when output ran short: with
         * room again, parse them now - no new bytes may ever arrive to
         * trigger a read. */
        if (!c->closing && !c->parsing && c->in_len && qmcd_conn_out_room(c) >= QMCD_OUT_RESERVE)
            parse_frames(c);
        if (c->dead)
            return;
        /* Produce every frame that fits (each pump adds at most one frame
         * per job or stream and only when it fits), then write them with
         * one send: a pipeline of small answers is one syscall, not two
         * per request.  PRODUCE_LIMIT keeps one connection from holding
         * the loop. */
        for (int k = 0; k < PRODUCE_LIMIT && !c->closing && !c->dead; k++) {
            int p = qmcd_jobs_pump(c);
            p |= qmcd_points_pump(c);
            if (!p)
                break;
            produced = 1;
            /* Batching pays for small frames; a bulk chunk is a full send
             * by itself, and unsent bytes get moved when the next frame is
             * reserved - so stop once a batch is worth a send.  Ring
             * chunks go out half a ring at a time (points.c): the client
             * reads one half while we fill the other. */
            if ((p & QMCD_PUMP_FLUSH) || c->out_tail - c->out_head >= PRODUCE_BATCH_BYTES)
                break;
        }
        if (c->dead || flush(c) != 0)
            return;
        if (!produced || c->out_tail > c->out_head)
            break;
    }
    if (c->dead)
        return;
    if (c->closing && c->out_tail == c->out_head && !c->wr_shut) {
        shutdown(c->w.fd, SHUT_WR);
        c->wr_shut = 1;
    }
    /* A peer that half-closed cannot release slots: a stream waiting for
     * one would wait forever. */
    if (c->peer_eof && !c->closing && c->in_len == 0 && qmcd_points_ring_stalled_ms(c)) {
        qmcd_conn_close(c, "peer closed while holding every ring slot");
        return;
    }
    /* A peer that half-closed gets its answers, then we close. */
    if (c->peer_eof && !c->closing && c->n_streams == 0 && c->n_jobs == 0 &&
        c->out_tail == c->out_head) {
        qmcd_conn_close(c, "peer closed");
        return;
    }
    if (c->peer_eof && c->closing) {
        if (c->out_tail == c->out_head) {
            qmcd_conn_close(c, "peer closed");
            return;
        }
    }
    update_interest(c);
}

static void conn_on_event(qmcd_server *srv, qmcd_watch *w, uint32_t events)
{
    (void)srv;
    qmcd_conn *c = (qmcd_conn *)w;
    if (c->dead)
        return;
    if (events & EPOLLERR) {
        qmcd_conn_close(c, "socket error (peer reset?)");
        return;
    }
    if (events & (EPOLLIN | EPOLLHUP | EPOLLRDHUP))
        do_read(c);
    if (c->dead)
        return;
    if ((events & EPOLLHUP) && !(events & EPOLLIN)) {
        qmcd_conn_close(c, "peer hung up");
        return;
    }
    qmcd_conn_kick(c);
}

/* ---- timers -------------------------------------------------------------------- */

void qmcd_conns_tick(qmcd_server *srv, int64_t now)
{
    const qmcd_config *cfg = &srv->cfg;
    qmcd_conn *next;
    for (qmcd_conn *c = srv->conns; c; c = next) {
        next = c->next;
        if (c->closing) {
            if (now >= c->close_by_ms)
                qmcd_conn_close(c, "linger deadline");
            continue;
        }
        if (c->stall_ms && c->out_tail > c->out_head &&
            now - c->stall_ms >= (int64_t)cfg->write_timeout_ms) {
            srv->stats.conns_timed_out++;
            qmcd_warn("conn %llu (%s): not reading: no output taken for %llu ms "
                      "(write-timeout-ms)", (unsigned long long)c->id, c->peer,
                      (unsigned long long)cfg->write_timeout_ms);
            qmcd_conn_close(c, "write-timeout-ms");
            continue;
        }
        int64_t ring_ms = qmcd_points_ring_stalled_ms(c);
        if (ring_ms && now - ring_ms >= (int64_t)cfg->write_timeout_ms) {
            srv->stats.conns_timed_out++;
            qmcd_warn("conn %llu (%s): no SHM_RELEASE for %llu ms with every ring slot held "
                      "(write-timeout-ms)", (unsigned long long)c->id, c->peer,
                      (unsigned long long)cfg->write_timeout_ms);
            qmcd_conn_fail(c, 0, -ETIMEDOUT, "write-timeout-ms: no SHM_RELEASE for %llu ms "
                           "while a stream waits for a ring slot",
                           (unsigned long long)cfg->write_timeout_ms);
            continue;
        }
        if (!c->hello_done && now - c->accepted_ms >= (int64_t)cfg->handshake_timeout_ms) {
            srv->stats.conns_timed_out++;
            qmcd_conn_fail(c, 0, -ETIMEDOUT, "handshake-timeout-ms: no HELLO within %llu ms",
                           (unsigned long long)cfg->handshake_timeout_ms);
            continue;
        }
        if (c->partial_ms && now - c->partial_ms >= (int64_t)cfg->frame_timeout_ms) {
            srv->stats.conns_timed_out++;
            qmcd_conn_fail(c, 0, -ETIMEDOUT,
                           "frame-timeout-ms: a partial frame (%zu bytes) was not completed "
                           "within %llu ms", c->in_len,
                           (unsigned long long)cfg->frame_timeout_ms);
            continue;
        }
        if (c->n_streams == 0 && c->n_jobs == 0 && c->out_tail == c->out_head &&
            c->in_len == 0 && now - c->active_ms >= (int64_t)cfg->idle_timeout_ms) {
            srv->stats.conns_timed_out++;
            qmcd_conn_fail(c, 0, -ETIMEDOUT, "idle-timeout-ms: idle for %llu ms",
                           (unsigned long long)cfg->idle_timeout_ms);
            continue;
        }
        qmcd_jobs_tick(c, now);
        if (!c->dead)
            qmcd_conn_kick(c);
    }
}

void qmcd_conns_close_all(qmcd_server *srv, const char *why)
{
    qmcd_conn *next;
    for (qmcd_conn *c = srv->conns; c; c = next) {
        next = c->next;
        if (!c->closing)
            qmcd_conn_fail(c, 0, -ESHUTDOWN, "%s", why);
    }
}

void qmcd_conns_close_idle(qmcd_server *srv)
{
    qmcd_conn *next;
    for (qmcd_conn *c = srv->conns; c; c = next) {
        next = c->next;
        if (!c->closing && c->n_streams == 0 && c->n_jobs == 0 &&
            c->out_tail == c->out_head)
            qmcd_conn_fail(c, 0, -ESHUTDOWN, "server shutting down");
    }
}

void qmcd_conns_close_streams(qmcd_server *srv, const char *why)
{
    qmcd_conn *next;
    for (qmcd_conn *c = srv->conns; c; c = next) {
        next = c->next;
        if (!c->closing && c->n_streams)
            qmcd_conn_fail(c, 0, -ESHUTDOWN, "%s", why);
    }
}
