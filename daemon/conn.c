/*
 * conn.c - client connections: the bounded output buffer drained
 * as the socket allows, the pump that lets the connection's producers
 * (producer.h) turn their work into frames, and the deadlines that keep a
 * stuck peer from holding anything for long.  Reading and framing the
 * input is conn_read.c, accepting (and refusing) conn_accept.c.  What handlers and producers may do with a
 * connection (conn_services.h) is implemented here.
 *
 * Buffers.  Output is one contiguous buffer capped by out-buffer-bytes.
 * Bulk data (POINTS chunks) is generated only into free space, never
 * queued ahead of the socket.
 *
 * Closing.  A connection that gets a fatal ERROR (malformed frame,
 * timeouts) stops reading requests, flushes the ERROR, shuts down its
 * write side and discards input until the peer closes or QMCD_LINGER_MS
 * passes: closing with unread input would send a TCP reset that can make
 * the peer lose the ERROR.  Freed memory is deferred to the end of the
 * loop round, since epoll may still hold events for it.
 *
 * This file must not interpret requests (dispatch.c does) or know what a
 * producer makes: it pumps, asks and releases them through their kind's
 * table, and never names a kind.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

#include "admit.h"
#include "conn.h"
#include "conn_read.h"
#include "log.h"
#include "loop.h"
#include "peers.h"
#include "pool.h"
#include "producer.h"
#include "ring.h"

/* Fairness: how much one connection may be sent per event. */
#define PUMP_ROUNDS 8
#define PRODUCE_LIMIT 256
#define PRODUCE_BATCH_BYTES (64u << 10)

/* ---- output buffer ---------------------------------------------------------- */

/* What the connection's buffer takes from out-buffer-total-bytes: its
 * allocation beyond the floor every connection keeps. */
static size_t over_floor(size_t alloc)
{
    return alloc > QMCD_OUT_FLOOR_BYTES ? alloc - QMCD_OUT_FLOOR_BYTES : 0;
}

/* Records a new allocation size for the global account; a shrink wakes the
 * streams waiting for memory (at the end of the loop round). */
static void set_out_alloc(qmcd_conn *c, size_t n)
{
    qmcd_server *srv = c->srv;
    size_t before = over_floor(c->out_alloc), after = over_floor(n);
    srv->out_over_bytes = srv->out_over_bytes - before + after;
    if (after < before && srv->n_out_waiting)
        srv->out_wake = 1;
    c->out_alloc = n;
}

/* The largest allocation this connection may have now: the floor, plus
 * what it already holds beyond it, plus what out-buffer-total-bytes still
 * leaves unallocated. */
static size_t alloc_allowed(const qmcd_conn *c)
{
    const qmcd_server *srv = c->srv;
    uint64_t cap = srv->cfg.out_buffer_total_bytes;
    uint64_t free_bytes = cap > srv->out_over_bytes ? cap - srv->out_over_bytes : 0;
    return QMCD_OUT_FLOOR_BYTES + over_floor(c->out_alloc) + (size_t)free_bytes;
}

size_t qmcd_conn_out_room(const qmcd_conn *c)
{
    size_t pending = c->out_tail - c->out_head;
    size_t cap = (size_t)c->srv->cfg.out_buffer_bytes;
    size_t room = pending >= cap ? 0 : cap - pending;
    /* Less when memory across all connections is short (the 64 bytes are
     * the alignment slack a reservation may need). */
    size_t allowed = alloc_allowed(c);
    size_t global = allowed > pending + 64 ? allowed - pending - 64 : 0;
    return global < room ? global : room;
}

/* 1 when out-buffer-total-bytes, not the connection's own cap, is what
 * holds its output back. */
static int short_of_global_memory(const qmcd_conn *c)
{
    return alloc_allowed(c) < (size_t)c->srv->cfg.out_buffer_bytes + 64;
}

uint8_t *qmcd_conn_out_reserve(qmcd_conn *c, size_t bytes, size_t align_at)
{
    /* Small answers (no alignment wish) are exempt from the global cap:
     * the reserve rule (requests are read only with QMCD_OUT_RESERVE
     * free) already bounds them, and refusing one would close the
     * connection. */
    const int wants_align = align_at != QMCD_NO_ALIGN;
    size_t pending = c->out_tail - c->out_head;
    size_t cap = (size_t)c->srv->cfg.out_buffer_bytes;
    if (bytes > (wants_align ? qmcd_conn_out_room(c) : pending >= cap ? 0 : cap - pending))
        return NULL;
    /* Where the new bytes start must make out + start + align_at a multiple
     * of 64.  The buffer itself is 64-byte aligned. */
    size_t start = c->out_tail;
    /* Only POINTS data asks for alignment (QMCD_NO_ALIGN otherwise): were
     * every small answer realigned, filling the buffer would move all the
     * pending bytes once per frame - quadratic in the backlog. */
    int misaligned = wants_align && ((start + align_at) & 63u) != 0;
    if (!misaligned && start + bytes <= c->out_alloc)
        return c->out + start;
    /* Move pending bytes to the front, at the offset (< 64) that aligns the
     * new frame; grow if needed (up to the cap plus the 64-byte slack, and
     * for POINTS data within what out-buffer-total-bytes allows). */
    size_t head = wants_align ? (64u - ((pending + align_at) & 63u)) & 63u : 0;
    size_t need = head + pending + bytes;
    if (need > c->out_alloc) {
        size_t n = c->out_alloc ? c->out_alloc : 64u << 10;
        while (n < need)
            n *= 2;
        size_t max = (size_t)c->srv->cfg.out_buffer_bytes + 128;
        if (wants_align && alloc_allowed(c) < max)
            max = alloc_allowed(c);
        if (n > max)
            n = max < need ? need : max;
        void *p = NULL;
        if (posix_memalign(&p, 64, n) != 0)
            return NULL;
        if (pending)
            memcpy((uint8_t *)p + head, c->out + c->out_head, pending);
        free(c->out);
        c->out = p;
        set_out_alloc(c, n);
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
    /* Frames go out as the negotiated version defines them (a result's
     * flags, PROTOCOL.md section 5).  Before HELLO_OK only the handshake
     * and ERROR are sent, which every version encodes alike. */
    const unsigned version = c->version ? c->version : QMC_PROTO_VERSION_MAX;
    size_t size = qmc_proto_encoded_size_version(m, version);
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
    int n = qmc_proto_encode_version(m, version, p, size);
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

/* The connection fails or closes: its producers, what it was lent (the
 * ring, a descriptor) and its share of the pool go. */
static void drop_work(qmcd_conn *c)
{
    qmcd_producers_drop_all(c);
    for (unsigned i = 0; i < c->srv->n_modules; i++)
        if (c->srv->modules[i]->conn_drop)
            c->srv->modules[i]->conn_drop(c);
    qmcd_pool_tenant_release(c->srv->pool, c->tenant);
    c->tenant = NULL;
    qmcd_ring_free(c->ring);
    c->ring = NULL;
    drop_passed_fd(c);
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
    drop_work(c);
    qmcd_loop_del(srv, &c->w);
    close(c->w.fd);
    c->w.fd = -1;
    c->dead = 1;
    unlink_conn(c);
    if (c->out_waiting) {
        c->out_waiting = 0;
        srv->n_out_waiting--;
    }
    if (c->admit != QMCD_ADMIT_REFUSED)
        srv->stats.conns_closed++;
    qmcd_admit_release(c);
    c->next = srv->dead_conns;
    srv->dead_conns = c;
}

void qmcd_conns_reap(qmcd_server *srv)
{
    while (srv->dead_conns) {
        qmcd_conn *c = srv->dead_conns;
        srv->dead_conns = c->next;
        free(c->in);
        free(c->out);
        set_out_alloc(c, 0);
        free(c);
    }
    /* Output memory came free this round: streams that waited for it go
     * on (a kick that finds nothing to do is cheap). */
    if (srv->out_wake) {
        srv->out_wake = 0;
        qmcd_conn *next;
        for (qmcd_conn *c = srv->conns; c; c = next) {
            next = c->next;
            if (c->out_waiting) {
                c->out_waiting = 0;
                srv->n_out_waiting--;
                qmcd_conn_kick(c);
            }
        }
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
    drop_work(c);
    c->in_len = 0;
    c->partial_ms = 0;
    qmcd_conn_kick(c);
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
    if (c->out_alloc > (256u << 10) && c->n_bulk == 0) {
        /* The stream that needed a big buffer is over: give it back. */
        free(c->out);
        c->out = NULL;
        set_out_alloc(c, 0);
    }
    return 0;
}

/* When the client's ring filled up while a producer waits for one of its
 * slots (write-timeout-ms runs from then), or 0. */
static int64_t ring_stalled_ms(const qmcd_conn *c)
{
    if (!c->ring || !c->ring->full_ms)
        return 0;
    return qmcd_producers_waiting(c, QMCD_WAIT_RING) ? c->ring->full_ms : 0;
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
        /* Streams waiting for ring slots wait for SHM_RELEASE (EPOLLIN),
         * and streams waiting for out-buffer-total-bytes for memory to
         * come free (qmcd_conns_reap wakes them, the tick retries): a
         * writable socket alone would only spin the loop. */
        int want = qmcd_producers_waiting(c, QMCD_WAIT_NONE);
        if (want && !pending && short_of_global_memory(c)) {
            want = 0;
            if (!c->out_waiting) {
                c->srv->stats.out_waits++;
                c->out_waiting = 1;
                c->srv->n_out_waiting++;
            }
        }
        if (pending || want)
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
            qmcd_conn_parse(c);
        if (c->dead)
            return;
        /* Produce every frame that fits (each turn adds at most one frame,
         * and only when it fits), then write them with
         * one send: a pipeline of small answers is one syscall, not two
         * per request.  PRODUCE_LIMIT keeps one connection from holding
         * the loop. */
        for (int k = 0; k < PRODUCE_LIMIT && !c->closing && !c->dead; k++) {
            int p = qmcd_producers_turn(c);
            if (!p)
                break;
            produced = 1;
            /* Batching pays for small frames; a bulk chunk is a full send
             * by itself, and unsent bytes get moved when the next frame is
             * reserved - so stop once a batch is worth a send.  Ring
             * chunks go out half a ring at a time (ring.c): the client
             * reads one half while we fill the other. */
            if ((p & QMCD_TURN_FLUSH) || c->out_tail - c->out_head >= PRODUCE_BATCH_BYTES)
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
    if (c->peer_eof && !c->closing && c->in_len == 0 && ring_stalled_ms(c)) {
        qmcd_conn_close(c, "peer closed while holding every ring slot");
        return;
    }
    /* A peer that half-closed gets its answers, then we close. */
    if (c->peer_eof && !c->closing && c->n_producers == 0 &&
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

void qmcd__conn_on_event(qmcd_server *srv, qmcd_watch *w, uint32_t events)
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
        qmcd_conn_read(c);
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
        int64_t ring_ms = ring_stalled_ms(c);
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
        /* The handshake's deadline is the peer's: it does not run while a
         * producer holds the server's answer (a proof held back, auth.c). */
        if (!c->hello_done && c->n_producers == 0 &&
            now - c->accepted_ms >= (int64_t)cfg->handshake_timeout_ms) {
            srv->stats.conns_timed_out++;
            qmcd_conn_fail(c, 0, -ETIMEDOUT, "handshake-timeout-ms: no %s within %llu ms",
                           c->handshake_wait ? c->handshake_wait : "HELLO",
                           (unsigned long long)cfg->handshake_timeout_ms);
            continue;
        }
        /* frame-timeout-ms is the peer's deadline for a frame it has
         * begun.  While its answers back up we read nothing more of it
         * (the rest of the frame may be waiting in the socket): the peer
         * is not the one late, and write-timeout-ms judges its reading.
         * Its frame's clock waits until we read again. */
        if (c->partial_ms && qmcd_conn_out_room(c) < QMCD_OUT_RESERVE)
            c->partial_ms = now;
        if (c->partial_ms && now - c->partial_ms >= (int64_t)cfg->frame_timeout_ms) {
            srv->stats.conns_timed_out++;
            qmcd_conn_fail(c, 0, -ETIMEDOUT,
                           "frame-timeout-ms: a partial frame (%zu bytes) was not completed "
                           "within %llu ms", c->in_len,
                           (unsigned long long)cfg->frame_timeout_ms);
            continue;
        }
        if (c->n_producers == 0 && c->out_tail == c->out_head &&
            c->in_len == 0 && now - c->active_ms >= (int64_t)cfg->idle_timeout_ms) {
            srv->stats.conns_timed_out++;
            qmcd_conn_fail(c, 0, -ETIMEDOUT, "idle-timeout-ms: idle for %llu ms",
                           (unsigned long long)cfg->idle_timeout_ms);
            continue;
        }
        qmcd_producers_tick(c, now);
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
        if (!c->closing && c->n_producers == 0 &&
            c->out_tail == c->out_head)
            qmcd_conn_fail(c, 0, -ESHUTDOWN, "server shutting down");
    }
}

void qmcd_conns_deadline(qmcd_server *srv, const char *why)
{
    qmcd_conn *next;
    for (qmcd_conn *c = srv->conns; c; c = next) {
        next = c->next;
        if (!c->closing && qmcd_producers_shutdown(c))
            qmcd_conn_fail(c, 0, -ESHUTDOWN, "%s", why);
    }
}

/* ---- facts for handlers and producers (conn_services.h) ---------------------------- */

qmcd_server *qmcd_conn_server(const qmcd_conn *c)
{
    return c->srv;
}

uint64_t qmcd_conn_id(const qmcd_conn *c)
{
    return c->id;
}

int qmcd_conn_gone(const qmcd_conn *c)
{
    return c->dead || c->closing;
}

int qmcd_conn_is_unix(const qmcd_conn *c)
{
    return c->unix_socket;
}

const qmcd_peer_key *qmcd_conn_peer(const qmcd_conn *c)
{
    return &c->peer_key;
}

void qmcd_conn_identity(const qmcd_conn *c, qmcd_identity *out)
{
    memset(out, 0, sizeof *out);
    out->peer = c->peer_key;
    memcpy(out->key_id, c->key_id, sizeof out->key_id);
}

unsigned qmcd_conn_version(const qmcd_conn *c)
{
    return c->version;
}

uint32_t qmcd_conn_client_max_frame(const qmcd_conn *c)
{
    return c->client_max_frame;
}

qmcd_ring *qmcd_conn_ring(const qmcd_conn *c)
{
    return c->ring;
}

void qmcd_conn_set_ring(qmcd_conn *c, qmcd_ring *r)
{
    c->ring = r;
}

int qmcd_conn_tenant(qmcd_conn *c, qmcd_pool_tenant **out)
{
    if (!c->tenant && qmcd_pool_tenant_new(c->srv->pool, &c->peer_key, &c->tenant) != 0) {
        *out = NULL;
        return -ENOMEM;
    }
    *out = c->tenant;
    return 0;
}
