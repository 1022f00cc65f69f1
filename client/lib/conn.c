/*
 * conn.c - frames over the client's socket: whole sends, bounded reads,
 * deadlines, and the one-line error text.
 *
 * The receive buffer is fixed at connect (a header plus the largest
 * payload announced in HELLO); the codec rejects a longer payload_len from
 * the header alone, so a hostile peer cannot make us buffer more.  Frames
 * are decoded in place and handed out as views; the bytes are reclaimed at
 * the next read.  Ring slots (shm.c) are handed back the same way: when a
 * read finds no whole frame left in the buffer, every chunk it handed out
 * has been handled, so one SHM_RELEASE returns them all before we wait.
 * Must not: block past a deadline, raise SIGPIPE, print, or keep reading a
 * stream after it went wrong (errors close it).
 */
#include <errno.h>
#include <poll.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <time.h>
#include <unistd.h>

#include "client_impl.h"

int64_t qmc__client_now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
}

int64_t qmc__client_deadline(const qmc_client *c)
{
    return c->timeout_ms < 0 ? -1 : qmc__client_now_ms() + c->timeout_ms;
}

static void set_message(qmc_client *c, const char *fmt, va_list ap)
    __attribute__((format(printf, 2, 0)));
static void set_message(qmc_client *c, const char *fmt, va_list ap)
{
    vsnprintf(c->message, sizeof c->message, fmt, ap);
}

int qmc__client_fail(qmc_client *c, int err, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    set_message(c, fmt, ap);
    va_end(ap);
    return err;
}

int qmc__client_break(qmc_client *c, int err, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    set_message(c, fmt, ap);
    va_end(ap);
    if (c->fd >= 0)
        close(c->fd);
    c->fd = -1;
    c->rpos = c->rlen = 0;
    qmc__client_shm_unmap(c);
    return err;
}

void qmc__client_copy_str(char *dst, size_t bytes, qmc_str s)
{
    if (bytes == 0)
        return;
    size_t n = s.len < bytes - 1 ? s.len : bytes - 1;
    for (size_t i = 0; i < n; i++) {
        unsigned char ch = (unsigned char)s.ptr[i];
        dst[i] = ch < 0x20 || ch == 0x7f ? ' ' : (char)ch;
    }
    dst[n] = '\0';
}

int qmc__client_server_error(qmc_client *c, const qmc_msg *m)
{
    int code = m->u.error.code;
    qmc__client_copy_str(c->message, sizeof c->message, m->u.error.message);
    if (code >= 0)
        return qmc__client_break(c, QMC_EPROTO, "protocol error: the server sent "
                                 "ERROR with code %d, which is not an error", code);
    if (c->message[0] == '\0')
        snprintf(c->message, sizeof c->message, "server error: %s", qmc_strerror(code));
    return code;
}

int qmc__client_ready(qmc_client *c)
{
    c->message[0] = '\0';
    if (c->fd < 0)
        return qmc__client_fail(c, -ENOTCONN, "not connected to a server (the "
                                "connection was closed after an earlier error)");
    return 0;
}

int qmc__client_wait_fd(int fd, short events, int64_t deadline_ms)
{
    for (;;) {
        int wait_ms = -1;
        if (deadline_ms >= 0) {
            int64_t left = deadline_ms - qmc__client_now_ms();
            if (left <= 0)
                return -ETIMEDOUT;
            wait_ms = left > 1000000 ? 1000000 : (int)left;
        }
        struct pollfd p = {fd, events, 0};
        int n = poll(&p, 1, wait_ms);
        if (n < 0 && errno == EINTR)
            continue;
        if (n < 0)
            return -errno;
        if (n > 0)
            return 0; /* ready, or an error/hangup the next call reports */
    }
}

int qmc__client_send(qmc_client *c, qmc_msg *msg, uint64_t *request_id)
{
    msg->request_id = c->next_request_id++;
    if (request_id)
        *request_id = msg->request_id;
    return qmc__client_send_frame(c, msg, -1);
}

/* One sendmsg carrying pass_fd beside the first bytes of buf. */
static ssize_t send_with_fd(int fd, const uint8_t *buf, size_t n, int pass_fd)
{
    union {
        struct cmsghdr align;
        char bytes[CMSG_SPACE(sizeof(int))];
    } ctl;
    memset(&ctl, 0, sizeof ctl);
    struct iovec iov = {(void *)(uintptr_t)buf, n};
    struct msghdr mh;
    memset(&mh, 0, sizeof mh);
    mh.msg_iov = &iov;
    mh.msg_iovlen = 1;
    mh.msg_control = ctl.bytes;
    mh.msg_controllen = sizeof ctl.bytes;
    struct cmsghdr *cm = CMSG_FIRSTHDR(&mh);
    cm->cmsg_level = SOL_SOCKET;
    cm->cmsg_type = SCM_RIGHTS;
    cm->cmsg_len = CMSG_LEN(sizeof(int));
    memcpy(CMSG_DATA(cm), &pass_fd, sizeof pass_fd);
    return sendmsg(fd, &mh, MSG_NOSIGNAL);
}

/* After a send that moved nothing (w <= 0, errno as the send left it):
 * 0 to send again (interrupted, or the socket has room once more), or the
 * error, with the connection broken and c->message naming what was sent. */
static int send_stalled(qmc_client *c, ssize_t w, int64_t deadline, const char *what)
{
    int err = w < 0 ? errno : EPIPE;
    if (err == EINTR)
        return 0;
    if (err == EAGAIN || err == EWOULDBLOCK)
        err = -qmc__client_wait_fd(c->fd, POLLOUT, deadline);
    if (err)
        return qmc__client_break(c, -err, "sending %s: %s%s", what, qmc_strerror(-err),
                                 err == ETIMEDOUT ? " (the server does not read)" : "");
    return 0;
}

int qmc__client_send_frame(qmc_client *c, const qmc_msg *msg, int pass_fd)
{
    /* An older server would take a newer field for a malformed frame and
     * hang up: say so here instead. */
    const unsigned needs = qmc_proto_msg_min_version(msg);
    if (c->version && c->version < needs)
        return qmc__client_fail(c, QMC_ENOTSUP, "%s: this request needs protocol version %u; "
                                "the server speaks %u (a newer qmcd)",
                                qmc_msg_type_name(msg->type), needs, (unsigned)c->version);
    size_t need = qmc_proto_encoded_size(msg);
    if (need == 0)
        return qmc__client_fail(c, QMC_EINVAL, "%s: a field is past its protocol limit",
                                qmc_msg_type_name(msg->type));
    if (need > c->scap || need - QMC_PROTO_HEADER_BYTES > c->max_frame)
        return qmc__client_fail(c, QMC_ETOOBIG, "%s: the request is %zu bytes, more "
                                "than the server accepts (%u)", qmc_msg_type_name(msg->type),
                                need - QMC_PROTO_HEADER_BYTES, c->max_frame);
    int n = qmc_proto_encode(msg, c->sbuf, c->scap);
    if (n < 0)
        return qmc__client_fail(c, n, "%s: cannot encode the request: %s",
                                qmc_msg_type_name(msg->type), qmc_strerror(n));
    const int64_t deadline = qmc__client_deadline(c);
    size_t done = 0;
    while (done < (size_t)n) {
        /* The descriptor rides with the first byte; if only part of the
         * frame goes, the rest follows without it. */
        ssize_t w = pass_fd >= 0 && done == 0
                        ? send_with_fd(c->fd, c->sbuf, (size_t)n, pass_fd)
                        : send(c->fd, c->sbuf + done, (size_t)n - done, MSG_NOSIGNAL);
        if (w > 0) {
            done += (size_t)w;
            continue;
        }
        int err = send_stalled(c, w, deadline, qmc_msg_type_name(msg->type));
        if (err)
            return err;
    }
    return 0;
}

int qmc__client_send_parts(qmc_client *c, const void *head, size_t head_len, const void *data,
                           size_t data_len, const char *what)
{
    const int64_t deadline = qmc__client_deadline(c);
    size_t done = 0;
    const size_t total = head_len + data_len;
    while (done < total) {
        struct iovec iov[2];
        int n = 0;
        if (done < head_len) {
            iov[n].iov_base = (char *)(uintptr_t)head + done;
            iov[n++].iov_len = head_len - done;
        }
        size_t in_data = done > head_len ? done - head_len : 0;
        if (data_len > in_data) {
            iov[n].iov_base = (char *)(uintptr_t)data + in_data;
            iov[n++].iov_len = data_len - in_data;
        }
        struct msghdr mh;
        memset(&mh, 0, sizeof mh);
        mh.msg_iov = iov;
        mh.msg_iovlen = (size_t)n;
        ssize_t w = sendmsg(c->fd, &mh, MSG_NOSIGNAL);
        if (w > 0) {
            done += (size_t)w;
            continue;
        }
        int err = send_stalled(c, w, deadline, what);
        if (err)
            return err;
    }
    return 0;
}

/* Reads more bytes into the buffer; 0, or a negative error (not yet
 * reported to c). */
static int fill(qmc_client *c, int64_t deadline_ms)
{
    if (c->rpos > 0) {
        memmove(c->rbuf, c->rbuf + c->rpos, c->rlen - c->rpos);
        c->rlen -= c->rpos;
        c->rpos = 0;
    }
    if (c->rlen == c->rcap)
        return QMC_ETOOBIG; /* cannot happen: the codec bounds frames first */
    for (;;) {
        ssize_t r = recv(c->fd, c->rbuf + c->rlen, c->rcap - c->rlen, 0);
        if (r > 0) {
            c->rlen += (size_t)r;
            return 0;
        }
        if (r == 0)
            return -ECONNRESET;
        if (errno == EINTR)
            continue;
        if (errno != EAGAIN && errno != EWOULDBLOCK)
            return -errno;
        int err = qmc__client_wait_fd(c->fd, POLLIN, deadline_ms);
        if (err)
            return err;
    }
}

int qmc__client_read(qmc_client *c, int64_t deadline_ms, int keep_on_timeout,
                     qmc_msg *msg)
{
    if (c->fd < 0)
        return qmc__client_fail(c, -ENOTCONN, "not connected to a server");
    for (;;) {
        /* As the version HELLO_OK chose defines the frames (a result flag
         * bit past it is malformed); before HELLO_OK, the newest. */
        int n = qmc_proto_decode_version(c->rbuf + c->rpos, c->rlen - c->rpos,
                                         QMC_CLIENT_MAX_FRAME,
                                         c->version ? c->version : QMC_PROTO_VERSION_MAX, msg);
        if (n > 0) {
            c->rpos += (size_t)n;
            return 0;
        }
        if (n == QMC_ETOOBIG)
            return qmc__client_break(c, QMC_EPROTO, "protocol error: the server sent a "
                                     "frame larger than the %u bytes we accept",
                                     QMC_CLIENT_MAX_FRAME);
        if (n != QMC_EAGAIN)
            return qmc__client_break(c, QMC_EPROTO, "protocol error: malformed frame "
                                     "from the server (%s)", qmc_strerror(n));
        /* Nothing whole left to hand out: the chunks handed out so far are
         * handled, and their slots go back before we wait for more. */
        int err = qmc__client_shm_release(c);
        if (err)
            return err;
        err = fill(c, deadline_ms);
        if (err == -ETIMEDOUT && keep_on_timeout)
            return qmc__client_fail(c, err, "no answer from the server within %d ms",
                                    c->timeout_ms);
        if (err == -ETIMEDOUT)
            return qmc__client_break(c, err, "no answer from the server within %d ms",
                                     c->timeout_ms);
        if (err == -ECONNRESET)
            return qmc__client_break(c, err, "the server closed the connection");
        if (err)
            return qmc__client_break(c, err, "receiving: %s", qmc_strerror(err));
    }
}

int qmc__client_other(qmc_client *c, const qmc_msg *msg, uint64_t waiting_for)
{
    int filed = qmc__client_file_job(c, msg);
    if (filed == 0)
        filed = qmc__client_file_session(c, msg);
    if (filed != 0)
        return filed < 0 ? filed : 0;
    if (msg->type == QMC_MSG_ERROR && msg->request_id == 0) {
        /* Not about one request: the server is giving up on us. */
        int code = qmc__client_server_error(c, msg);
        char text[QMC_CLIENT_MESSAGE_BYTES];
        memcpy(text, c->message, sizeof text);
        return qmc__client_break(c, code, "%s", text);
    }
    return qmc__client_break(c, QMC_EPROTO, "protocol error: unexpected %s for "
                             "request %llu while waiting for request %llu",
                             qmc_msg_type_name(msg->type),
                             (unsigned long long)msg->request_id,
                             (unsigned long long)waiting_for);
}

int qmc__client_await(qmc_client *c, uint64_t request_id, int64_t deadline_ms,
                      int keep_on_timeout, qmc_msg *msg)
{
    for (;;) {
        int err = qmc__client_read(c, deadline_ms, keep_on_timeout, msg);
        if (err)
            return err;
        if (msg->request_id == request_id)
            return 0;
        if ((err = qmc__client_other(c, msg, request_id)) != 0)
            return err;
    }
}
