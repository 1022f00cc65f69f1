/*
 * conn_read.c - the input side of a client connection: reading the socket
 * into a bounded input buffer, taking passed descriptors on Unix sockets,
 * and cutting the buffer into frames for dispatch.c.
 *
 * Buffers.  Input holds at most one frame header plus max-frame bytes: the
 * header's payload_len is checked against max-frame before any payload is
 * buffered.  Requests are read only while QMCD_OUT_RESERVE bytes of output
 * are free, so a peer that sends but never reads stops being read (TCP then
 * pushes back on it) instead of growing our memory.
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
 * This file must not interpret requests (dispatch.c does), write to the
 * socket or decide a connection's lifetime (conn.c).
 */
#define _GNU_SOURCE
#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <unistd.h>

#include "conn.h"
#include "conn_read.h"
#include "dispatch.h"
#include "log.h"
#include "loop.h"

/* The input buffer starts this small and grows to the frame being read. */
#define IN_START_BYTES (16u << 10)
/* Fairness: how much one connection may read per event. */
#define READ_BUDGET_BYTES (1u << 20)
/* Descriptors one recvmsg can take; a legitimate peer sends one at a time
 * (room for more only so that extras are seen and closed, not truncated). */
#define RECV_FDS_MAX 4

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
            !(type == QMC_MSG_AUTH_RESPONSE && c->auth)) {
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

void qmcd_conn_parse(qmcd_conn *c)
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

void qmcd_conn_read(qmcd_conn *c)
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
         * off): qmcd_conn_parse grows the buffer for a frame still arriving,
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
            qmcd_conn_parse(c);
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
