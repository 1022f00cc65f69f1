/*
 * test_client.c - libqmcclient without a daemon: endpoint parsing, connect
 * and handshake timeouts, and the client's state machine against a
 * scripted fake server in a thread that speaks the real codec (HELLO_OK,
 * PONG, ERROR, chunks, job frames, and malformed or oversized frames).
 *
 * The fake server never asserts (cmocka is not thread-safe): it records
 * what it saw and the test checks after joining it.  For the shared-memory
 * ring it takes the client's memfd with recvmsg, checks its seals, maps it
 * and writes chunks into its slots, as qmcd does.
 */
#define _GNU_SOURCE
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/time.h>
#include <sys/uio.h>
#include <sys/un.h>
#include <netinet/in.h>
#include <arpa/inet.h>
#include <time.h>
#include <unistd.h>

#include "qmc/client.h"
#include "qmc/proto.h"
#include "../../client/lib/client_impl.h"

#define TIMEOUT_MS 5000

/* ---- endpoint parsing ------------------------------------------------------ */

static void test_endpoint_good(void **state)
{
    (void)state;
    qmc__endpoint ep;
    char why[256];
    assert_int_equal(qmc__client_endpoint_parse("unix:/run/qmcd.sock", &ep, why, sizeof why), 0);
    assert_int_equal(ep.kind, QMC__EP_UNIX);
    assert_string_equal(ep.path, "/run/qmcd.sock");
    assert_int_equal(qmc__client_endpoint_parse("unix:rel/x", &ep, why, sizeof why), 0);
    assert_string_equal(ep.path, "rel/x");
    assert_int_equal(qmc__client_endpoint_parse("tcp:127.0.0.1:7000", &ep, why, sizeof why), 0);
    assert_int_equal(ep.kind, QMC__EP_TCP);
    assert_string_equal(ep.host, "127.0.0.1");
    assert_string_equal(ep.port, "7000");
    assert_false(ep.bracketed);
    assert_int_equal(qmc__client_endpoint_parse("tcp:[::1]:65535", &ep, why, sizeof why), 0);
    assert_string_equal(ep.host, "::1");
    assert_string_equal(ep.port, "65535");
    assert_true(ep.bracketed);
    assert_int_equal(qmc__client_endpoint_parse("tcp:[fe80::1%eth0]:1", &ep, why, sizeof why), 0);
    assert_string_equal(ep.host, "fe80::1%eth0");
    assert_int_equal(qmc__client_endpoint_parse("tcp:qmcd.example.org:01", &ep, why, sizeof why), 0);
    assert_string_equal(ep.host, "qmcd.example.org");
    assert_string_equal(ep.port, "1");
}

static void test_endpoint_bad(void **state)
{
    (void)state;
    static const char *const bad[] = {
        "", "unix:", "tcp:", "udp:1.2.3.4:5", "http://host:80", "/run/qmcd.sock",
        "tcp:host", "tcp:host:", "tcp::80", "tcp:host:0", "tcp:host:65536",
        "tcp:host:123456", "tcp:host:12a", "tcp:host:-1", "tcp:host:+80", "tcp:host: 80",
        "tcp:::1:80", "tcp:[::1]80", "tcp:[::1]", "tcp:[::1:80", "tcp:[]:80",
        "tcp:ho st:80", "tcp:a/b:80", "TCP:host:80", "tcp:[::1]:",
    };
    qmc__endpoint ep;
    char why[256];
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        why[0] = '\0';
        int err = qmc__client_endpoint_parse(bad[i], &ep, why, sizeof why);
        if (err != QMC_EINVAL)
            fail_msg("'%s' parsed (%d)", bad[i], err);
        assert_non_null(strstr(why, "malformed endpoint"));
        assert_null(strchr(why, '\n'));
    }
    char longpath[200];
    memset(longpath, 'x', sizeof longpath - 1);
    longpath[sizeof longpath - 1] = '\0';
    memcpy(longpath, "unix:", 5);
    assert_int_equal(qmc__client_endpoint_parse(longpath, &ep, why, sizeof why), QMC_EINVAL);
    assert_int_equal(qmc__client_endpoint_parse(NULL, &ep, why, sizeof why), QMC_EINVAL);
    /* Through the public entry point: an error, a message, a client to close. */
    qmc_client *c = NULL;
    assert_int_equal(qmc_client_connect("tcp:[::1]80", 1000, &c), QMC_EINVAL);
    assert_non_null(c);
    assert_non_null(strstr(qmc_client_last_error(c), "malformed endpoint 'tcp:[::1]80'"));
    qmc_client_close(c);
    assert_int_equal(qmc_client_connect("unix:/x", 0, &c), QMC_EINVAL);
    qmc_client_close(c);
    qmc_client_close(NULL);
}

/* ---- a listening socket that never answers --------------------------------- */

static int64_t now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
}

static void test_handshake_timeout(void **state)
{
    (void)state;
    /* The kernel completes the TCP connect from the backlog; nobody ever
     * accepts or answers, so the handshake must time out. */
    int lfd = socket(AF_INET, SOCK_STREAM, 0);
    assert_true(lfd >= 0);
    struct sockaddr_in a;
    memset(&a, 0, sizeof a);
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    assert_int_equal(bind(lfd, (struct sockaddr *)&a, sizeof a), 0);
    assert_int_equal(listen(lfd, 4), 0);
    socklen_t len = sizeof a;
    assert_int_equal(getsockname(lfd, (struct sockaddr *)&a, &len), 0);
    char ep[64];
    snprintf(ep, sizeof ep, "tcp:127.0.0.1:%u", ntohs(a.sin_port));
    qmc_client *c = NULL;
    int64_t t0 = now_ms();
    assert_int_equal(qmc_client_connect(ep, 300, &c), -ETIMEDOUT);
    /* It waited for its own timer: a loaded machine can only make this
     * longer, so there is no upper bound to flake on. */
    int64_t took = now_ms() - t0;
    assert_true(took >= 250);
    assert_non_null(strstr(qmc_client_last_error(c), "no answer from the server within 300 ms"));
    assert_int_equal(qmc_client_max_frame(c), 0);
    qmc_client_close(c);
    /* Refused: nothing listens there any more. */
    close(lfd);
    assert_int_equal(qmc_client_connect(ep, 1000, &c), -ECONNREFUSED);
    assert_non_null(strstr(qmc_client_last_error(c), "connection refused"));
    qmc_client_close(c);
}

/* ---- the scripted fake server ------------------------------------------------ */

typedef struct fake fake;
typedef void (*script_fn)(fake *f, int fd);

struct fake {
    char dir[64], path[128], endpoint[160];
    int lfd;
    pthread_t th;
    script_fn script;
    int bad;                  /* the script saw something unexpected */
    char note[256];
    /* scratch for the script */
    uint8_t in[1 << 20];
    size_t in_len, in_used;
    uint8_t out[1 << 20];
    int arg;
    uint64_t max_points;      /* what HELLO_OK says */
    unsigned version;         /* what HELLO_OK chose: frames are laid out for it */
};

/* The fake's max_points unless a test asks for less (fake_start_limited). */
#define FAKE_MAX_POINTS (1u << 20)

static void fake_bad(fake *f, const char *what)
{
    if (!f->bad)
        snprintf(f->note, sizeof f->note, "%s", what);
    f->bad = 1;
}

/* Reads one request; returns 0 or -1 (peer gone / malformed).  Views in
 * *m stay valid until the next read.  A descriptor passed beside the bytes
 * goes to *pass_fd (-1 when none came). */
static int srv_read_fd(fake *f, int fd, qmc_msg *m, int *pass_fd)
{
    *pass_fd = -1;
    memmove(f->in, f->in + f->in_used, f->in_len - f->in_used);
    f->in_len -= f->in_used;
    f->in_used = 0;
    for (;;) {
        int n = qmc_proto_decode(f->in, f->in_len, QMC_PROTO_MAX_PAYLOAD, m);
        if (n > 0) {
            f->in_used = (size_t)n;
            return 0;
        }
        if (n != QMC_EAGAIN)
            return -1;
        union {
            struct cmsghdr align;
            char bytes[CMSG_SPACE(sizeof(int))];
        } ctl;
        struct iovec iov = {f->in + f->in_len, sizeof f->in - f->in_len};
        struct msghdr mh;
        memset(&mh, 0, sizeof mh);
        mh.msg_iov = &iov;
        mh.msg_iovlen = 1;
        mh.msg_control = ctl.bytes;
        mh.msg_controllen = sizeof ctl.bytes;
        ssize_t r = recvmsg(fd, &mh, MSG_CMSG_CLOEXEC);
        if (r <= 0)
            return -1;
        for (struct cmsghdr *cm = CMSG_FIRSTHDR(&mh); cm; cm = CMSG_NXTHDR(&mh, cm))
            if (cm->cmsg_level == SOL_SOCKET && cm->cmsg_type == SCM_RIGHTS)
                memcpy(pass_fd, CMSG_DATA(cm), sizeof(int));
        f->in_len += (size_t)r;
    }
}

/* srv_read_fd for scripts that expect no descriptor: one that comes is
 * closed and noted. */
static int srv_read(fake *f, int fd, qmc_msg *m)
{
    int pfd;
    int rc = srv_read_fd(f, fd, m, &pfd);
    if (pfd >= 0) {
        close(pfd);
        fake_bad(f, "a descriptor came with a frame that carries none");
    }
    return rc;
}

static int write_all(int fd, const void *buf, size_t n)
{
    const uint8_t *p = buf;
    while (n) {
        ssize_t w = send(fd, p, n, MSG_NOSIGNAL);
        if (w <= 0)
            return -1;
        p += w;
        n -= (size_t)w;
    }
    return 0;
}

static void srv_send(fake *f, int fd, qmc_msg *m)
{
    int n = qmc_proto_encode_version(m, f->version ? f->version : QMC_PROTO_VERSION_MAX,
                                     f->out, sizeof f->out);
    if (n < 0) {
        fake_bad(f, "encode failed");
        return;
    }
    if (write_all(fd, f->out, (size_t)n))
        fake_bad(f, "write failed");
}

static void srv_error(fake *f, int fd, uint64_t id, int code, const char *text)
{
    qmc_msg m;
    memset(&m, 0, sizeof m);
    m.type = QMC_MSG_ERROR;
    m.request_id = id;
    m.u.error.code = code;
    m.u.error.message.ptr = text;
    m.u.error.message.len = (uint32_t)strlen(text);
    srv_send(f, fd, &m);
}

/* Expects a request of type t; returns 0 or -1 (noted). */
static int srv_expect(fake *f, int fd, qmc_msg *m, qmc_msg_type t)
{
    if (srv_read(f, fd, m) != 0) {
        fake_bad(f, "read failed");
        return -1;
    }
    if (m->type != t) {
        fake_bad(f, "unexpected request type");
        return -1;
    }
    return 0;
}

/* HELLO, answered with protocol version `version`. */
static int srv_hello_v(fake *f, int fd, uint16_t version)
{
    qmc_msg m;
    if (srv_expect(f, fd, &m, QMC_MSG_HELLO))
        return -1;
    if (m.u.hello.max_frame != QMC_CLIENT_MAX_FRAME || m.u.hello.version_min != 1 ||
        m.u.hello.version_max != QMC_PROTO_VERSION_MAX)
        fake_bad(f, "HELLO fields");
    uint64_t id = m.request_id;
    memset(&m, 0, sizeof m);
    m.type = QMC_MSG_HELLO_OK;
    m.request_id = id;
    m.u.hello_ok.version = version;
    m.u.hello_ok.max_frame = 1u << 20;
    f->version = version;
    m.u.hello_ok.max_inflight = 4;
    m.u.hello_ok.max_points = f->max_points;
    m.u.hello_ok.sobol_table_hash = 0x0123456789abcdefull;
    m.u.hello_ok.server = (qmc_str){"fake-qmcd", 9};
    m.u.hello_ok.engine = (qmc_str){"test 1.0", 8};
    srv_send(f, fd, &m);
    return 0;
}

static int srv_hello(fake *f, int fd)
{
    return srv_hello_v(f, fd, 1);
}

static void *fake_main(void *arg)
{
    fake *f = arg;
    int fd = accept(f->lfd, NULL, NULL);
    if (fd < 0) {
        fake_bad(f, "accept failed");
        return NULL;
    }
    /* Never hang the suite on a client bug. */
    struct timeval tv = {5, 0};
    setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    f->script(f, fd);
    close(fd);
    return NULL;
}

static fake *fake_start_limited(script_fn script, int arg, uint64_t max_points)
{
    fake *f = calloc(1, sizeof *f);
    assert_non_null(f);
    f->script = script;
    f->arg = arg;
    f->max_points = max_points;
    strcpy(f->dir, "/tmp/qmc-test-client-XXXXXX");
    assert_non_null(mkdtemp(f->dir));
    snprintf(f->path, sizeof f->path, "%s/s", f->dir);
    snprintf(f->endpoint, sizeof f->endpoint, "unix:%s", f->path);
    f->lfd = socket(AF_UNIX, SOCK_STREAM, 0);
    assert_true(f->lfd >= 0);
    struct sockaddr_un a;
    memset(&a, 0, sizeof a);
    a.sun_family = AF_UNIX;
    strcpy(a.sun_path, f->path);
    assert_int_equal(bind(f->lfd, (struct sockaddr *)&a, sizeof a), 0);
    assert_int_equal(listen(f->lfd, 4), 0);
    assert_int_equal(pthread_create(&f->th, NULL, fake_main, f), 0);
    return f;
}

static fake *fake_start(script_fn script, int arg)
{
    return fake_start_limited(script, arg, FAKE_MAX_POINTS);
}

static void fake_stop(fake *f)
{
    pthread_join(f->th, NULL);
    close(f->lfd);
    unlink(f->path);
    rmdir(f->dir);
    if (f->bad)
        fail_msg("fake server: %s", f->note);
    free(f);
}

/* ---- handshake, ping, errors --------------------------------------------------- */

static void script_ping(fake *f, int fd)
{
    if (srv_hello(f, fd))
        return;
    qmc_msg m;
    /* 1: a PONG that echoes */
    if (srv_expect(f, fd, &m, QMC_MSG_PING))
        return;
    uint8_t data[QMC_PROTO_MAX_PING];
    memcpy(data, m.u.ping.data.ptr, m.u.ping.data.len);
    m.type = QMC_MSG_PONG;
    m.u.ping.data.ptr = (const char *)data;
    srv_send(f, fd, &m);
    /* 2: ERROR for the request: the connection stays up */
    if (srv_expect(f, fd, &m, QMC_MSG_PING))
        return;
    srv_error(f, fd, m.request_id, QMC_ETOOBIG, "too many requests in flight\n(two lines)");
    /* 3: STATS */
    if (srv_expect(f, fd, &m, QMC_MSG_STATS))
        return;
    qmc_stat st[3] = {{{"requests", 8}, 3}, {{"points", 6}, 12345}, {{"errors", 6}, 1}};
    m.type = QMC_MSG_STATS_REPLY;
    m.u.stats.count = 3;
    m.u.stats.entries = st;
    srv_send(f, fd, &m);
    /* 4: a PONG that does not echo: protocol error, connection closed */
    if (srv_expect(f, fd, &m, QMC_MSG_PING))
        return;
    m.type = QMC_MSG_PONG;
    m.u.ping.data = (qmc_str){"nope", 4};
    srv_send(f, fd, &m);
}

typedef struct stat_seen {
    int n;
    uint64_t points;
} stat_seen;

static int on_stat(void *ctx, const char *name, uint64_t value)
{
    stat_seen *s = ctx;
    s->n++;
    if (strcmp(name, "points") == 0)
        s->points = value;
    return 0;
}

static void test_ping_errors_stats(void **state)
{
    (void)state;
    fake *f = fake_start(script_ping, 0);
    qmc_client *c = NULL;
    assert_int_equal(qmc_client_connect(f->endpoint, TIMEOUT_MS, &c), 0);
    assert_string_equal(qmc_client_last_error(c), "");
    assert_string_equal(qmc_client_server_name(c), "fake-qmcd");
    assert_string_equal(qmc_client_engine(c), "test 1.0");
    assert_true(qmc_client_sobol_table_hash(c) == 0x0123456789abcdefull);
    assert_int_equal(qmc_client_max_frame(c), 1u << 20);
    assert_int_equal(qmc_client_max_inflight(c), 4);
    assert_true(qmc_client_max_points(c) == FAKE_MAX_POINTS);
    double rtt = -1;
    assert_int_equal(qmc_client_ping(c, &rtt), 0);
    assert_true(rtt > 0 && rtt < 5);
    /* The server's code and its message, kept on one line. */
    assert_int_equal(qmc_client_ping(c, &rtt), QMC_ETOOBIG);
    assert_string_equal(qmc_client_last_error(c), "too many requests in flight (two lines)");
    assert_true(rtt == 0);
    stat_seen s = {0, 0};
    assert_int_equal(qmc_client_stats(c, on_stat, &s), 0);
    assert_int_equal(s.n, 3);
    assert_true(s.points == 12345);
    assert_int_equal(qmc_client_ping(c, &rtt), QMC_EPROTO);
    assert_non_null(strstr(qmc_client_last_error(c), "PONG does not echo"));
    /* Closed after a protocol error. */
    assert_int_equal(qmc_client_ping(c, &rtt), -ENOTCONN);
    assert_int_equal(qmc_client_stats(c, on_stat, &s), -ENOTCONN);
    qmc_client_close(c);
    fake_stop(f);
}

static void script_refuse(fake *f, int fd)
{
    qmc_msg m;
    if (srv_expect(f, fd, &m, QMC_MSG_HELLO))
        return;
    srv_error(f, fd, m.request_id, QMC_ETOOBIG, "too many connections");
}

static void test_handshake_refused(void **state)
{
    (void)state;
    fake *f = fake_start(script_refuse, 0);
    qmc_client *c = NULL;
    assert_int_equal(qmc_client_connect(f->endpoint, TIMEOUT_MS, &c), QMC_ETOOBIG);
    assert_string_equal(qmc_client_last_error(c),
                        "the server refused the handshake: too many connections");
    qmc_client_close(c);
    fake_stop(f);
}

/* arg 0: not the protocol; 1: a header announcing a payload above our
 * limit; 2: hang up after HELLO; 3: connection-level ERROR (id 0). */
static void script_hostile(fake *f, int fd)
{
    qmc_msg m;
    if (f->arg < 2) {
        if (srv_expect(f, fd, &m, QMC_MSG_HELLO))
            return;
        if (f->arg == 0) {
            static const char http[] = "HTTP/1.1 400 Bad Request\r\n\r\n";
            write_all(fd, http, sizeof http - 1);
        } else {
            uint8_t h[QMC_PROTO_HEADER_BYTES] = {0x51, 0x4d, 0x43, 0x44, 1, QMC_MSG_HELLO_OK};
            uint32_t big = QMC_CLIENT_MAX_FRAME + 1;
            for (int i = 0; i < 4; i++)
                h[16 + i] = (uint8_t)(big >> (8 * i));
            h[8] = (uint8_t)m.request_id;
            write_all(fd, h, sizeof h);
        }
        /* wait for the client to hang up */
        (void)srv_read(f, fd, &m);
        return;
    }
    if (srv_hello(f, fd))
        return;
    if (srv_expect(f, fd, &m, QMC_MSG_PING))
        return;
    if (f->arg == 3)
        srv_error(f, fd, 0, -ECONNRESET, "server shutting down");
}

static void test_hostile_peers(void **state)
{
    (void)state;
    static const int want[] = {QMC_EPROTO, QMC_EPROTO, -ECONNRESET, -ECONNRESET};
    static const char *const text[] = {"does not speak the qmcd protocol",
                                       "larger than", "closed the connection",
                                       "server shutting down"};
    for (int arg = 0; arg < 4; arg++) {
        fake *f = fake_start(script_hostile, arg);
        qmc_client *c = NULL;
        int err = qmc_client_connect(f->endpoint, TIMEOUT_MS, &c);
        if (arg >= 2) {
            assert_int_equal(err, 0);
            double rtt;
            err = qmc_client_ping(c, &rtt);
        }
        assert_int_equal(err, want[arg]);
        if (!strstr(qmc_client_last_error(c), text[arg]))
            fail_msg("case %d: '%s'", arg, qmc_client_last_error(c));
        qmc_client_close(c);
        fake_stop(f);
    }
}

/* ---- POINTS streams -------------------------------------------------------------- */

static void send_chunk(fake *f, int fd, uint64_t id, uint64_t first, uint32_t points,
                       uint32_t dims)
{
    qmc_msg m;
    memset(&m, 0, sizeof m);
    m.type = QMC_MSG_POINTS_CHUNK;
    m.request_id = id;
    static uint8_t data[1 << 16];
    for (uint32_t p = 0; p < points; p++)
        for (uint32_t j = 0; j < dims; j++) {
            double v = (double)(first + p) + 0.125 * j;
            uint64_t bits;
            memcpy(&bits, &v, 8);
            for (int b = 0; b < 8; b++)
                data[(p * dims + j) * 8 + b] = (uint8_t)(bits >> (8 * b));
        }
    m.u.chunk.first = first;
    m.u.chunk.points = points;
    m.u.chunk.data = data;
    m.u.chunk.data_len = points * dims * 8;
    srv_send(f, fd, &m);
}

static void send_end(fake *f, int fd, uint64_t id, uint64_t points, uint64_t bytes)
{
    qmc_msg m;
    memset(&m, 0, sizeof m);
    m.type = QMC_MSG_END;
    m.request_id = id;
    m.u.end.points = points;
    m.u.end.bytes = bytes;
    srv_send(f, fd, &m);
}

/* Request 1: good (2 chunks + END); 2: refused; 3: a chunk at the wrong
 * index. */
static void script_points(fake *f, int fd)
{
    if (srv_hello(f, fd))
        return;
    qmc_msg m;
    if (srv_expect(f, fd, &m, QMC_MSG_POINTS))
        return;
    if (m.u.points.start != 10 || m.u.points.count != 5 || m.u.points.seq.dims != 3 ||
        m.u.points.format != QMC_FORMAT_F64)
        fake_bad(f, "POINTS fields");
    uint64_t id = m.request_id;
    send_chunk(f, fd, id, 10, 3, 3);
    send_chunk(f, fd, id, 13, 2, 3);
    send_end(f, fd, id, 5, 5 * 3 * 8);
    if (srv_expect(f, fd, &m, QMC_MSG_POINTS))
        return;
    srv_error(f, fd, m.request_id, QMC_ETOOBIG, "count 5000 exceeds max-points 1000");
    if (srv_expect(f, fd, &m, QMC_MSG_POINTS))
        return;
    send_chunk(f, fd, m.request_id, 10, 2, 3);
    send_chunk(f, fd, m.request_id, 13, 3, 3); /* skips index 12 */
}

static void test_points(void **state)
{
    (void)state;
    fake *f = fake_start(script_points, 0);
    qmc_client *c = NULL;
    assert_int_equal(qmc_client_connect(f->endpoint, TIMEOUT_MS, &c), 0);
    qmc_seq_spec spec = {QMC_SEQ_SOBOL, 3, QMC_SCRAMBLE_NONE, 0, 0, 0};
    double out[15];
    /* Too small a buffer: refused before anything is sent. */
    assert_int_equal(qmc_client_points(c, &spec, 10, 5, QMC_FORMAT_F64, out, sizeof out - 1),
                     QMC_EINVAL);
    assert_int_equal(qmc_client_points(c, &spec, 10, 5, QMC_FORMAT_F64, out, sizeof out), 0);
    for (int p = 0; p < 5; p++)
        for (int j = 0; j < 3; j++)
            assert_true(out[p * 3 + j] == 10 + p + 0.125 * j);
    /* The server refuses the next request: its code and message. */
    assert_int_equal(qmc_client_points(c, &spec, 10, 5, QMC_FORMAT_F64, out, sizeof out),
                     QMC_ETOOBIG);
    assert_string_equal(qmc_client_last_error(c), "count 5000 exceeds max-points 1000");
    assert_int_equal(qmc_client_points(c, &spec, 10, 5, QMC_FORMAT_F64, out, sizeof out),
                     QMC_EPROTO);
    assert_non_null(strstr(qmc_client_last_error(c), "expected index 12"));
    qmc_client_close(c);
    fake_stop(f);
}

/* A stream the callback stops: the connection closes. */
static void script_stream_stop(fake *f, int fd)
{
    if (srv_hello(f, fd))
        return;
    qmc_msg m;
    if (srv_expect(f, fd, &m, QMC_MSG_POINTS))
        return;
    send_chunk(f, fd, m.request_id, 0, 2, 1);
    send_chunk(f, fd, m.request_id, 2, 2, 1);
    /* No END: the client stops on the second chunk and hangs up, so a
     * write after it would race with the close (EPIPE under load). */
}

static int stop_after_one(void *ctx, uint64_t first, uint32_t points, const void *data,
                          size_t bytes)
{
    int *calls = ctx;
    (void)first, (void)points, (void)data, (void)bytes;
    return ++*calls == 1 ? 0 : 7;
}

static void test_stream_stop(void **state)
{
    (void)state;
    fake *f = fake_start(script_stream_stop, 0);
    qmc_client *c = NULL;
    assert_int_equal(qmc_client_connect(f->endpoint, TIMEOUT_MS, &c), 0);
    qmc_seq_spec spec = {QMC_SEQ_SOBOL, 1, QMC_SCRAMBLE_NONE, 0, 0, 0};
    int calls = 0;
    assert_int_equal(qmc_client_points_stream(c, &spec, 0, 4, QMC_FORMAT_F64,
                                              stop_after_one, &calls), 7);
    assert_int_equal(calls, 2);
    double rtt;
    assert_int_equal(qmc_client_ping(c, &rtt), -ENOTCONN);
    qmc_client_close(c);
    fake_stop(f);
}

/* This fake's HELLO_OK says max_points 1000: a request of 2500 goes as
 * three requests (1000, 1000, 500); then a split stream whose server hangs
 * up after 1500 points. */
static void script_split(fake *f, int fd)
{
    if (srv_hello(f, fd))
        return;
    qmc_msg m;
    static const uint64_t parts[3][2] = {{5, 1000}, {1005, 1000}, {2005, 500}};
    for (int i = 0; i < 3; i++) {
        if (srv_expect(f, fd, &m, QMC_MSG_POINTS))
            return;
        if (m.u.points.start != parts[i][0] || m.u.points.count != parts[i][1])
            fake_bad(f, "split POINTS fields");
        uint32_t half = (uint32_t)parts[i][1] / 2;
        send_chunk(f, fd, m.request_id, parts[i][0], half, 1);
        send_chunk(f, fd, m.request_id, parts[i][0] + half, (uint32_t)parts[i][1] - half, 1);
        send_end(f, fd, m.request_id, parts[i][1], parts[i][1] * 8);
    }
    if (srv_expect(f, fd, &m, QMC_MSG_POINTS))
        return;
    send_chunk(f, fd, m.request_id, 0, 1000, 1);
    send_end(f, fd, m.request_id, 1000, 8000);
    if (srv_expect(f, fd, &m, QMC_MSG_POINTS))
        return;
    send_chunk(f, fd, m.request_id, 1000, 500, 1);
    /* and the daemon dies: the fake closes the connection on return */
}

static void test_points_split(void **state)
{
    (void)state;
    fake *f = fake_start_limited(script_split, 0, 1000);
    qmc_client *c = NULL;
    assert_int_equal(qmc_client_connect(f->endpoint, TIMEOUT_MS, &c), 0);
    qmc_seq_spec spec = {QMC_SEQ_SOBOL, 1, QMC_SCRAMBLE_NONE, 0, 0, 0};
    static double out[2500];
    assert_int_equal(qmc_client_points(c, &spec, 5, 2500, QMC_FORMAT_F64, out, sizeof out), 0);
    for (int p = 0; p < 2500; p++)
        assert_true(out[p] == 5 + p);
    int err = qmc_client_points(c, &spec, 0, 2500, QMC_FORMAT_F64, out, sizeof out);
    assert_int_equal(err, -ECONNRESET);
    assert_string_equal(qmc_client_last_error(c),
                        "the daemon closed the connection after 1500 of 2500 points");
    qmc_client_close(c);
    fake_stop(f);
}

/* ---- jobs -------------------------------------------------------------------------- */

static void send_result(fake *f, int fd, uint64_t id, uint64_t job_id, double estimate)
{
    qmc_msg m;
    memset(&m, 0, sizeof m);
    m.type = QMC_MSG_JOB_RESULT;
    m.request_id = id;
    qmc_msg_job_result *r = &m.u.result;
    r->job_id = job_id;
    qmc_result_init(&r->res);
    r->res.estimate = estimate;
    r->res.n = 4096;
    r->res.evals = 65536;
    r->res.dims = 2;
    r->method_used = QMC_METHOD_RQMC;
    qmc_sampling_spec_init(&r->sampling, QMC_SAMPLER_RQMC);
    r->seconds = 0.25;
    r->reference_kind = 1;
    r->reference = 0.5;
    r->detail = (qmc_str){"sobol owen, 16 x 4096 points", 28};
    srv_send(f, fd, &m);
}

static void send_accepted(fake *f, int fd, uint64_t id, uint64_t job_id)
{
    qmc_msg m;
    memset(&m, 0, sizeof m);
    m.type = QMC_MSG_JOB_ACCEPTED;
    m.request_id = id;
    m.u.job.job_id = job_id;
    srv_send(f, fd, &m);
}

static void send_state(fake *f, int fd, uint64_t id, uint64_t job_id, qmc_job_state st)
{
    qmc_msg m;
    memset(&m, 0, sizeof m);
    m.type = QMC_MSG_JOB_STATE;
    m.request_id = id;
    m.u.state.job_id = job_id;
    m.u.state.state = st;
    m.u.state.evals = 1000;
    srv_send(f, fd, &m);
}

static void script_jobs(fake *f, int fd)
{
    if (srv_hello(f, fd))
        return;
    qmc_msg m;
    /* Job 41: accepted; its result arrives in the middle of a PING. */
    if (srv_expect(f, fd, &m, QMC_MSG_INTEGRATE))
        return;
    if (strcmp(m.u.integrate.spec.integrand, "genz-gaussian") != 0 ||
        m.u.integrate.a.count != 2 || qmc_proto_f64_at(&m.u.integrate.a, 1) != 2.5)
        fake_bad(f, "INTEGRATE fields");
    uint64_t job41 = m.request_id;
    send_accepted(f, fd, job41, 41);
    if (srv_expect(f, fd, &m, QMC_MSG_PING))
        return;
    send_result(f, fd, job41, 41, 0.49);
    m.type = QMC_MSG_PONG;
    srv_send(f, fd, &m);
    /* Job 42: refused at once. */
    if (srv_expect(f, fd, &m, QMC_MSG_INTEGRATE))
        return;
    srv_error(f, fd, m.request_id, QMC_EBUDGET, "the request needs 1e12 evaluations");
    /* Job 43: quiet until polled; wait times out, then the result comes. */
    if (srv_expect(f, fd, &m, QMC_MSG_INTEGRATE))
        return;
    uint64_t job43 = m.request_id;
    send_accepted(f, fd, job43, 43);
    if (srv_expect(f, fd, &m, QMC_MSG_JOB_STATUS))
        return;
    send_state(f, fd, m.request_id, 43, QMC_JOB_RUNNING);
    /* the client's keep-alive probe during its wait(-1) */
    if (srv_expect(f, fd, &m, QMC_MSG_JOB_STATUS))
        return;
    send_state(f, fd, m.request_id, 43, QMC_JOB_RUNNING);
    send_result(f, fd, job43, 43, 0.51);
    /* Job 44: cancelled; its INTEGRATE ends in an ERROR. */
    if (srv_expect(f, fd, &m, QMC_MSG_INTEGRATE))
        return;
    uint64_t job44 = m.request_id;
    send_accepted(f, fd, job44, 44);
    if (srv_expect(f, fd, &m, QMC_MSG_JOB_CANCEL))
        return;
    send_state(f, fd, m.request_id, 44, QMC_JOB_CANCELLED);
    srv_error(f, fd, job44, -ECANCELED, "job 44 cancelled");
}

static void test_jobs(void **state)
{
    (void)state;
    fake *f = fake_start(script_jobs, 0);
    qmc_client *c = NULL;
    assert_int_equal(qmc_client_connect(f->endpoint, TIMEOUT_MS, &c), 0);
    qmc_job_spec spec;
    qmc_job_spec_init(&spec);
    strcpy(spec.integrand, "genz-gaussian");
    spec.dims = 2;
    const double a[2] = {1.5, 2.5};
    spec.a = a;
    spec.n_a = 2;
    uint64_t id = 0;
    assert_int_equal(qmc_client_submit(c, &spec, &id), 0);
    assert_true(id == 41);
    double rtt;
    assert_int_equal(qmc_client_ping(c, &rtt), 0); /* the result is filed meanwhile */
    qmc_client_result *r = malloc(sizeof *r);
    assert_non_null(r);
    assert_int_equal(qmc_client_wait(c, 41, 1, r), 0);
    assert_true(r->job_id == 41 && r->res.estimate == 0.49 && r->seconds == 0.25);
    assert_int_equal(r->has_known_abs, -1); /* a version-1 server did not say */
    assert_int_equal(r->method_used, QMC_METHOD_RQMC);
    assert_int_equal(r->reference_kind, 1);
    assert_string_equal(r->detail, "sobol owen, 16 x 4096 points");
    assert_string_equal(r->auto_reason, "");
    /* Handed back once only. */
    assert_int_equal(qmc_client_wait(c, 41, 10, r), QMC_EINVAL);
    /* A refused job. */
    assert_int_equal(qmc_client_integrate(c, &spec, r), QMC_EBUDGET);
    assert_string_equal(qmc_client_last_error(c), "the request needs 1e12 evaluations");
    /* Poll, a short wait that times out without closing, then a probe. */
    assert_int_equal(qmc_client_submit(c, &spec, &id), 0);
    assert_true(id == 43);
    qmc_job_state st;
    uint64_t evals;
    assert_int_equal(qmc_client_poll(c, 43, &st, &evals), 0);
    assert_int_equal(st, QMC_JOB_RUNNING);
    assert_true(evals == 1000);
    assert_int_equal(qmc_client_wait(c, 43, 100, r), -ETIMEDOUT);
    assert_non_null(strstr(qmc_client_last_error(c), "no result within 100 ms"));
    /* wait(-1) probes after a whole quiet timeout, and the probe itself
     * must be answered within one: 1 s, not less, since the fake's thread
     * may wait that long for a CPU on a loaded machine under ASan. */
    assert_int_equal(qmc_client_set_timeout(c, 1000), 0);
    assert_int_equal(qmc_client_wait(c, 43, -1, r), 0);
    assert_true(r->res.estimate == 0.51);
    assert_int_equal(qmc_client_set_timeout(c, TIMEOUT_MS), 0);
    /* Cancel. */
    assert_int_equal(qmc_client_submit(c, &spec, &id), 0);
    assert_int_equal(qmc_client_cancel(c, 44), 0);
    assert_int_equal(qmc_client_wait(c, 44, 1000, r), -ECANCELED);
    assert_string_equal(qmc_client_last_error(c), "job 44 cancelled");
    free(r);
    qmc_client_close(c);
    fake_stop(f);
}

/* ---- the shared-memory ring ----------------------------------------------------------- */

static void script_hello_ping(fake *f, int fd);
static void script_hello_ping_tail(fake *f, int fd);

/* Expects SHM_ATTACH with a descriptor of the given geometry, checks the
 * memfd as qmcd would (sealed, long enough, populated) and maps it.
 * Returns the mapping (closing the descriptor) or NULL, noted. */
static uint8_t *srv_attach(fake *f, int fd, uint32_t slots, uint32_t slot_bytes,
                           uint64_t *request_id)
{
    qmc_msg m;
    int pfd;
    if (srv_read_fd(f, fd, &m, &pfd) != 0 || m.type != QMC_MSG_SHM_ATTACH || pfd < 0) {
        fake_bad(f, "expected SHM_ATTACH with a descriptor");
        if (pfd >= 0)
            close(pfd);
        return NULL;
    }
    *request_id = m.request_id;
    if (m.u.shm.slots != slots || m.u.shm.slot_bytes != slot_bytes)
        fake_bad(f, "SHM_ATTACH geometry");
    const size_t bytes = (size_t)slots * slot_bytes;
    int seals = fcntl(pfd, F_GET_SEALS);
    struct stat st;
    /* Sealed against shrinking and growing, and not F_SEAL_SEAL: the server
     * adds F_SEAL_FUTURE_WRITE after mapping it (PROTOCOL.md section 10). */
    if (seals < 0 || (seals & (F_SEAL_SHRINK | F_SEAL_GROW | F_SEAL_SEAL)) !=
                         (F_SEAL_SHRINK | F_SEAL_GROW))
        fake_bad(f, "the memfd is not sealed as the protocol asks");
    if (fstat(pfd, &st) != 0 || (size_t)st.st_size < bytes)
        fake_bad(f, "the memfd is too small");
    void *p = mmap(NULL, bytes, PROT_READ | PROT_WRITE, MAP_SHARED, pfd, 0);
    close(pfd);
    if (p == MAP_FAILED) {
        fake_bad(f, "cannot map the memfd");
        return NULL;
    }
    unsigned char vec[16];
    if (mincore(p, 4096, vec) != 0 || !(vec[0] & 1))
        fake_bad(f, "the memfd is not populated");
    return p;
}

static void srv_shm_ok(fake *f, int fd, uint64_t id, uint32_t slots, uint32_t slot_bytes)
{
    qmc_msg m;
    memset(&m, 0, sizeof m);
    m.type = QMC_MSG_SHM_OK;
    m.request_id = id;
    m.u.shm.slots = slots;
    m.u.shm.slot_bytes = slot_bytes;
    srv_send(f, fd, &m);
}

/* Points first .. first + points of `dims` coordinates as send_chunk makes
 * them, into a slot; then the frame naming it. */
static void send_shm_chunk(fake *f, int fd, uint8_t *ring, uint32_t slot_bytes, uint64_t id,
                           uint64_t first, uint32_t points, uint32_t dims, uint32_t slot)
{
    uint8_t *data = ring + (size_t)slot * slot_bytes;
    for (uint32_t p = 0; p < points; p++)
        for (uint32_t j = 0; j < dims; j++) {
            double v = (double)(first + p) + 0.125 * j;
            uint64_t bits;
            memcpy(&bits, &v, 8);
            for (int b = 0; b < 8; b++)
                data[((size_t)p * dims + j) * 8 + b] = (uint8_t)(bits >> (8 * b));
        }
    qmc_msg m;
    memset(&m, 0, sizeof m);
    m.type = QMC_MSG_POINTS_SHM_CHUNK;
    m.request_id = id;
    m.u.shm_chunk.first = first;
    m.u.shm_chunk.points = points;
    m.u.shm_chunk.data_len = points * dims * 8;
    m.u.shm_chunk.slot = slot;
    srv_send(f, fd, &m);
}

/* Reads SHM_RELEASE frames until at most `keep` slots are held. */
static int srv_take_releases(fake *f, int fd, uint32_t *held, uint32_t keep)
{
    while (*held > keep) {
        qmc_msg m;
        if (srv_expect(f, fd, &m, QMC_MSG_SHM_RELEASE))
            return -1;
        if (m.request_id != 0 || m.u.release.slots > *held) {
            fake_bad(f, "SHM_RELEASE with an id, or of more than held");
            return -1;
        }
        *held -= m.u.release.slots;
        f->arg++; /* releases seen */
    }
    return 0;
}

/* An explicit 2 x 64 KiB ring; a stream of 10000 points (4 dims, f64:
 * 2048 a slot, 5 chunks) served only as slots come back; then a chunk in
 * the wrong slot. */
enum { SHM_SLOT = 64 << 10, SHM_DIMS = 4, SHM_COUNT = 10000 };

static void script_shm(fake *f, int fd)
{
    if (srv_hello_v(f, fd, 2))
        return;
    uint64_t id;
    uint8_t *ring = srv_attach(f, fd, 2, SHM_SLOT, &id);
    if (!ring)
        return;
    srv_shm_ok(f, fd, id, 2, SHM_SLOT);
    qmc_msg m;
    if (srv_expect(f, fd, &m, QMC_MSG_POINTS))
        goto out;
    if (m.u.points.transport != QMC_TRANSPORT_SHM || m.u.points.count != SHM_COUNT)
        fake_bad(f, "POINTS not through the ring");
    id = m.request_id;
    const uint32_t per = SHM_SLOT / (SHM_DIMS * 8);
    uint32_t held = 0, slot = 0;
    uint64_t sent = 0;
    while (sent < SHM_COUNT) {
        if (srv_take_releases(f, fd, &held, 1) != 0)
            goto out;
        uint32_t pts = SHM_COUNT - sent < per ? (uint32_t)(SHM_COUNT - sent) : per;
        send_shm_chunk(f, fd, ring, SHM_SLOT, id, 10 + sent, pts, SHM_DIMS, slot);
        slot ^= 1;
        held++;
        sent += pts;
    }
    send_end(f, fd, id, SHM_COUNT, (uint64_t)SHM_COUNT * SHM_DIMS * 8);
    /* After END the client hands back what it still holds. */
    if (srv_take_releases(f, fd, &held, 0) != 0)
        goto out;
    /* The next stream: a chunk naming the wrong slot (slot 1 is next). */
    if (srv_expect(f, fd, &m, QMC_MSG_POINTS))
        goto out;
    send_shm_chunk(f, fd, ring, SHM_SLOT, m.request_id, 0, 2, SHM_DIMS, slot ^ 1);
out:
    munmap(ring, 2 * SHM_SLOT);
}

static void test_shm(void **state)
{
    (void)state;
    fake *f = fake_start(script_shm, 0);
    qmc_client *c = NULL;
    assert_int_equal(qmc_client_connect(f->endpoint, TIMEOUT_MS, &c), 0);
    assert_int_equal(qmc_client_shm_slots(c), 0);
    /* Refused here, before anything is sent. */
    assert_int_equal(qmc_client_attach_shm(c, 1, SHM_SLOT), QMC_EINVAL);
    assert_int_equal(qmc_client_attach_shm(c, 65, SHM_SLOT), QMC_EINVAL);
    assert_int_equal(qmc_client_attach_shm(c, 2, SHM_SLOT + 8), QMC_EINVAL);
    assert_int_equal(qmc_client_attach_shm(c, 2, 8u << 20), QMC_EINVAL);
    assert_non_null(strstr(qmc_client_last_error(c), "slots"));
    assert_int_equal(qmc_client_attach_shm(c, 2, SHM_SLOT), 0);
    assert_int_equal(qmc_client_shm_slots(c), 2);
    assert_int_equal(qmc_client_shm_slot_bytes(c), SHM_SLOT);
    assert_int_equal(qmc_client_attach_shm(c, 2, SHM_SLOT), QMC_EINVAL);
    assert_non_null(strstr(qmc_client_last_error(c), "already attached"));
    qmc_seq_spec spec = {QMC_SEQ_SOBOL, SHM_DIMS, QMC_SCRAMBLE_NONE, 0, 0, 0};
    static double out[SHM_COUNT * SHM_DIMS];
    assert_int_equal(qmc_client_points(c, &spec, 10, SHM_COUNT, QMC_FORMAT_F64, out,
                                       sizeof out), 0);
    for (int p = 0; p < SHM_COUNT; p++)
        for (int j = 0; j < SHM_DIMS; j++)
            if (out[p * SHM_DIMS + j] != 10 + p + 0.125 * j)
                fail_msg("point %d coordinate %d: %g", p, j, out[p * SHM_DIMS + j]);
    /* A chunk in the wrong slot closes the connection and unmaps the ring. */
    assert_int_equal(qmc_client_points(c, &spec, 0, 2, QMC_FORMAT_F64, out, sizeof out),
                     QMC_EPROTO);
    assert_non_null(strstr(qmc_client_last_error(c), "ring slot 0; expected slot 1"));
    assert_int_equal(qmc_client_shm_slots(c), 0);
    double rtt;
    assert_int_equal(qmc_client_ping(c, &rtt), -ENOTCONN);
    qmc_client_close(c);
    int releases = f->arg;
    fake_stop(f);
    assert_true(releases >= 3); /* 5 chunks in a 2-slot ring, the last after END */
}

/* The automatic ring, refused: the points come inline, and it is not
 * offered again; an explicit one is refused too, the connection lives. */
static void script_shm_refused(fake *f, int fd)
{
    if (srv_hello_v(f, fd, 2))
        return;
    qmc_msg m;
    int pfd;
    if (srv_read_fd(f, fd, &m, &pfd) != 0 || m.type != QMC_MSG_SHM_ATTACH || pfd < 0 ||
        m.u.shm.slots != 8 || m.u.shm.slot_bytes != QMC_PROTO_CHUNK_BYTES) {
        fake_bad(f, "expected the automatic SHM_ATTACH (8 x 1 MiB) with a descriptor");
        if (pfd >= 0)
            close(pfd);
        return;
    }
    close(pfd);
    srv_error(f, fd, m.request_id, QMC_ENOTSUP, "shared memory is off here");
    for (int round = 0; round < 2; round++) {
        if (srv_expect(f, fd, &m, QMC_MSG_POINTS))
            return;
        if (m.u.points.transport != QMC_TRANSPORT_INLINE)
            fake_bad(f, "POINTS through a ring that was refused");
        uint64_t id = m.request_id, count = m.u.points.count, sent = 0;
        while (sent < count) {
            uint32_t pts = count - sent < 2048 ? (uint32_t)(count - sent) : 2048;
            send_chunk(f, fd, id, sent, pts, 3);
            sent += pts;
        }
        send_end(f, fd, id, count, count * 24);
    }
    if (srv_read_fd(f, fd, &m, &pfd) != 0 || m.type != QMC_MSG_SHM_ATTACH || pfd < 0) {
        fake_bad(f, "expected the explicit SHM_ATTACH");
        return;
    }
    close(pfd);
    srv_error(f, fd, m.request_id, QMC_ETOOBIG, "max-shm-bytes: too big");
    script_hello_ping_tail(f, fd);
}

static void test_shm_refused(void **state)
{
    (void)state;
    fake *f = fake_start(script_shm_refused, 0);
    qmc_client *c = NULL;
    assert_int_equal(qmc_client_connect(f->endpoint, TIMEOUT_MS, &c), 0);
    qmc_seq_spec spec = {QMC_SEQ_SOBOL, 3, QMC_SCRAMBLE_NONE, 0, 0, 0};
    enum { N = 50000 }; /* 1.2 MB: more than a chunk, so a ring is tried */
    static double out[N * 3];
    for (int round = 0; round < 2; round++) {
        assert_int_equal(qmc_client_points(c, &spec, 0, N, QMC_FORMAT_F64, out, sizeof out), 0);
        assert_string_equal(qmc_client_last_error(c), "");
        assert_true(out[(N - 1) * 3 + 2] == N - 1 + 0.25);
        assert_int_equal(qmc_client_shm_slots(c), 0);
    }
    assert_int_equal(qmc_client_attach_shm(c, 2, SHM_SLOT), QMC_ETOOBIG);
    assert_string_equal(qmc_client_last_error(c), "max-shm-bytes: too big");
    double rtt;
    assert_int_equal(qmc_client_ping(c, &rtt), 0);
    qmc_client_close(c);
    fake_stop(f);
}

/* A version-1 server: no ring is offered or can be asked for. */
static void test_shm_v1(void **state)
{
    (void)state;
    fake *f = fake_start(script_hello_ping, 0);
    qmc_client *c = NULL;
    assert_int_equal(qmc_client_connect(f->endpoint, TIMEOUT_MS, &c), 0);
    assert_int_equal(qmc_client_attach_shm(c, 2, SHM_SLOT), QMC_ENOTSUP);
    assert_non_null(strstr(qmc_client_last_error(c), "protocol version 1"));
    /* Turning the automatic ring off is always fine. */
    assert_int_equal(qmc_client_attach_shm(c, 0, 0), 0);
    double rtt;
    assert_int_equal(qmc_client_ping(c, &rtt), 0);
    qmc_client_close(c);
    fake_stop(f);
}

/* ---- authentication (protocol version 3) ---------------------------------------- */

static const uint8_t fake_key[32] = {'q', 'm', 'c', 'd', ' ', 'e', 'x', 'a', 'm', 'p', 'l',
                                     'e', ' ', 'k', 'e', 'y', ',', ' ', '3', '2', ' ', 'b',
                                     'y', 't', 'e', 's', ' ', 'l', 'o', 'n', 'g', '!'};

/* A server holding fake_key, through the same state machine as qmcd.
 * arg 0: honest; 1: a wrong proof in AUTH_OK; 2: challenges, and the
 * client (without a key) must hang up. */
static void script_auth(fake *f, int fd)
{
    qmc_msg m;
    if (srv_expect(f, fd, &m, QMC_MSG_HELLO))
        return;
    const uint64_t id = m.request_id;
    qmc_auth_server st;
    memset(&st, 0, sizeof st);
    uint8_t nonce[QMC_PROTO_AUTH_NONCE_BYTES];
    memset(nonce, 0x5c, sizeof nonce);
    qmc_msg ch;
    memset(&ch, 0, sizeof ch);
    ch.type = QMC_MSG_AUTH_CHALLENGE;
    ch.request_id = id;
    if (qmc_auth_server_challenge(&st, &m.u.hello, QMC_PROTO_VERSION_MAX, nonce,
                                  &ch.u.challenge) != 0) {
        fake_bad(f, "the client's HELLO cannot be challenged");
        return;
    }
    srv_send(f, fd, &ch);
    if (f->arg == 2) {
        if (srv_read(f, fd, &m) == 0)
            fake_bad(f, "a client without a key answered the challenge");
        return;
    }
    if (srv_expect(f, fd, &m, QMC_MSG_AUTH_RESPONSE))
        return;
    qmc_msg ok;
    memset(&ok, 0, sizeof ok);
    ok.type = QMC_MSG_AUTH_OK;
    ok.request_id = id;
    if (qmc_auth_server_verify(&st, fake_key, sizeof fake_key, &m.u.response,
                               &ok.u.auth_ok) != 0) {
        fake_bad(f, "the client's proof is wrong");
        return;
    }
    if (f->arg == 1)
        ok.u.auth_ok.mac[7] ^= 0x10;
    srv_send(f, fd, &ok);
    if (f->arg == 0) {
        memset(&m, 0, sizeof m);
        m.type = QMC_MSG_HELLO_OK;
        m.request_id = id;
        m.u.hello_ok.version = st.version;
        m.u.hello_ok.max_frame = 1u << 20;
        m.u.hello_ok.max_inflight = 4;
        m.u.hello_ok.max_points = 1000;
        m.u.hello_ok.server = (qmc_str){"fake-qmcd", 9};
        m.u.hello_ok.engine = (qmc_str){"test 1.0", 8};
        srv_send(f, fd, &m);
    }
    (void)srv_read(f, fd, &m); /* until the client hangs up */
}

static void test_auth(void **state)
{
    (void)state;
    char key_path[] = "/tmp/qmc-test-key-XXXXXX";
    int kfd = mkstemp(key_path);
    assert_true(kfd >= 0);
    assert_int_equal(write(kfd, fake_key, sizeof fake_key), (ssize_t)sizeof fake_key);
    assert_int_equal(fchmod(kfd, 0600), 0);
    close(kfd);
    unsetenv("QMC_AUTH_KEY_FILE");

    fake *f = fake_start(script_auth, 0);
    qmc_client *c = NULL;
    assert_int_equal(qmc_client_connect_auth(f->endpoint, TIMEOUT_MS, key_path, &c), 0);
    assert_int_equal(qmc_client_authenticated(c), 1);
    assert_string_equal(qmc_client_server_name(c), "fake-qmcd");
    qmc_client_close(c);
    fake_stop(f);

    /* The environment is what qmc_client_connect reads. */
    assert_int_equal(setenv("QMC_AUTH_KEY_FILE", key_path, 1), 0);
    f = fake_start(script_auth, 0);
    assert_int_equal(qmc_client_connect(f->endpoint, TIMEOUT_MS, &c), 0);
    assert_int_equal(qmc_client_authenticated(c), 1);
    qmc_client_close(c);
    fake_stop(f);
    unsetenv("QMC_AUTH_KEY_FILE");

    /* A server whose proof is wrong does not hold our key. */
    f = fake_start(script_auth, 1);
    assert_int_equal(qmc_client_connect_auth(f->endpoint, TIMEOUT_MS, key_path, &c), QMC_EAUTH);
    assert_non_null(strstr(qmc_client_last_error(c), "could not prove it holds our key"));
    assert_int_equal(qmc_client_authenticated(c), 0);
    assert_int_equal(qmc_client_max_frame(c), 0); /* closed */
    qmc_client_close(c);
    fake_stop(f);

    /* No key ("" overrides the environment) where one is required. */
    assert_int_equal(setenv("QMC_AUTH_KEY_FILE", key_path, 1), 0);
    f = fake_start(script_auth, 2);
    assert_int_equal(qmc_client_connect_auth(f->endpoint, TIMEOUT_MS, "", &c), QMC_EAUTH);
    assert_non_null(strstr(qmc_client_last_error(c), "requires authentication"));
    qmc_client_close(c);
    fake_stop(f);
    unsetenv("QMC_AUTH_KEY_FILE");

    /* A key file others can read is refused before any connection. */
    assert_int_equal(chmod(key_path, 0640), 0);
    assert_int_equal(qmc_client_connect_auth("unix:/nonexistent/qmcd.sock", TIMEOUT_MS,
                                             key_path, &c),
                     QMC_EAUTH);
    assert_non_null(strstr(qmc_client_last_error(c), "chmod 600"));
    qmc_client_close(c);
    assert_int_equal(qmc_client_connect_auth("unix:/nonexistent/qmcd.sock", TIMEOUT_MS,
                                             "/nonexistent/key", &c),
                     -ENOENT);
    qmc_client_close(c);
    unlink(key_path);
}

/* ---- allocation failure --------------------------------------------------------------- */

typedef struct alloc_ctl {
    int calls, fail_at;
} alloc_ctl;

static void *failing_alloc(void *ctx, size_t bytes)
{
    alloc_ctl *a = ctx;
    return a->calls++ == a->fail_at ? NULL : malloc(bytes);
}

static void script_hello_ping(fake *f, int fd)
{
    if (srv_hello(f, fd))
        return;
    script_hello_ping_tail(f, fd);
}

static void script_hello_ping_tail(fake *f, int fd)
{
    qmc_msg m;
    if (srv_expect(f, fd, &m, QMC_MSG_PING))
        return;
    uint8_t data[QMC_PROTO_MAX_PING];
    memcpy(data, m.u.ping.data.ptr, m.u.ping.data.len);
    m.type = QMC_MSG_PONG;
    m.u.ping.data.ptr = (const char *)data;
    srv_send(f, fd, &m);
}

static void test_alloc_failures(void **state)
{
    (void)state;
    /* Fail the Nth allocation in turn until a run makes no allocation
     * that fails; every failing run must end in QMC_ENOMEM, no client. */
    for (int n = 0;; n++) {
        alloc_ctl a = {0, n};
        fake *f = fake_start(script_hello_ping, 0);
        qmc_client *c = (qmc_client *)&a; /* must be overwritten */
        int err = qmc__client_connect_with(f->endpoint, TIMEOUT_MS, failing_alloc, &a, &c);
        if (a.calls > n) {
            assert_int_equal(err, QMC_ENOMEM);
            assert_null(c);
            assert_string_equal(qmc_client_last_error(c), "out of memory");
            /* unblock the fake server, which waits for a connection */
            qmc_client *c2 = NULL;
            assert_int_equal(qmc_client_connect(f->endpoint, TIMEOUT_MS, &c2), 0);
            double rtt;
            assert_int_equal(qmc_client_ping(c2, &rtt), 0);
            qmc_client_close(c2);
            fake_stop(f);
            continue;
        }
        assert_int_equal(err, 0);
        double rtt;
        assert_int_equal(qmc_client_ping(c, &rtt), 0);
        qmc_client_close(c);
        fake_stop(f);
        assert_true(n >= 1); /* at least the one block was tried */
        break;
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_endpoint_good),
        cmocka_unit_test(test_endpoint_bad),
        cmocka_unit_test(test_handshake_timeout),
        cmocka_unit_test(test_ping_errors_stats),
        cmocka_unit_test(test_handshake_refused),
        cmocka_unit_test(test_hostile_peers),
        cmocka_unit_test(test_points),
        cmocka_unit_test(test_stream_stop),
        cmocka_unit_test(test_points_split),
        cmocka_unit_test(test_jobs),
        cmocka_unit_test(test_shm),
        cmocka_unit_test(test_shm_refused),
        cmocka_unit_test(test_shm_v1),
        cmocka_unit_test(test_auth),
        cmocka_unit_test(test_alloc_failures),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
