/*
 * qmc_load.c - qmc-load, a load generator for qmcd, used by
 * bench/bench_daemon.sh to compare the daemon with Redis in the same run.
 *
 * Three modes:
 *
 *   load (default)  C connections, each keeping up to D requests in flight
 *                   (a sliding window: an answer frees a slot and the next
 *                   request goes out in the same write as its neighbours).
 *                   Requests are a weighted mix of PING (no data) and a
 *                   small POINTS (by default 1 point of Sobol, d = 8, f64).
 *                   Prints requests, rate, latency p50/p99/p99.9 (from the
 *                   moment a request is queued for sending to its final
 *                   answer) and errors.  Bounded by --requests or --seconds,
 *                   and always by --timeout.
 *   --bulk          one POINTS request (default Sobol d = 32, 2^22 points,
 *                   f64) over one connection, the whole stream read and
 *                   discarded; prints MB/s (10^6 bytes of point data) and
 *                   points/s.  With --rss-pid it samples that process's
 *                   VmRSS before, during (peak) and after the stream.
 *                   With --shm the points come through a shared-memory
 *                   ring (--slots, --slot-bytes; PROTOCOL.md section 10)
 *                   fetched by libqmcclient as any client would: each
 *                   chunk is touched (one byte read, as --inprocess does)
 *                   and its slot released.  With --into the stream is
 *                   qmc_client_points instead: every chunk copied into one
 *                   array of the whole result, allocated and faulted in
 *                   once before the runs and reused (what a program that
 *                   wants the points in memory does; the Python client's
 *                   bench, bench/bench_python.sh, compares its numpy path
 *                   with it).
 *   --inprocess     the same points generated here with qmc_seq_fill, in
 *                   chunks of the size the daemon uses, into one reused
 *                   buffer: the rate the socket path is measured against.
 *   --unix-ceiling  the same number of bytes through an AF_UNIX socketpair
 *                   between two threads, nothing generated: what the
 *                   transport alone allows on this machine.
 *
 * It speaks the protocol with the codec directly (qmc_proto_encode/decode)
 * over non-blocking sockets and one epoll loop per thread, so pipelining is
 * real and the client does not set the pace with one syscall per request.
 * The handshake (HELLO / HELLO_OK) is done on every connection, blocking,
 * before the clock starts.
 *
 * A benchmark tool only: it prints, exits and runs threads, and it asserts
 * nothing about speed (bench_daemon.sh reports ratios, never fails on them).
 * The last line of every mode is "RESULT key=value ..." for scripts.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <time.h>
#include <unistd.h>

#include "qmc/client.h"
#include "qmc/proto.h"
#include "qmc/seq.h"

/* The largest payload we accept; a POINTS_CHUNK carries at most 1 MiB of
 * data plus a 16-byte prefix, so every answer fits. */
#define MAX_FRAME (2u << 20)
#define FRAME_BUF (MAX_FRAME + QMC_PROTO_HEADER_BYTES)
/* Per-connection buffers start at these sizes; input grows to FRAME_BUF. */
#define IN_START_BYTES (64u << 10)
#define OUT_BYTES (64u << 10)
#define MAX_PIPELINE 1024u
#define MAX_THREADS 64u

/* ---- options ---------------------------------------------------------------- */

typedef struct opts {
    const char *endpoint;
    unsigned clients, pipeline, threads;
    uint64_t requests;          /* 0: use seconds */
    double seconds, timeout_s;
    unsigned w_ping, w_points;  /* the mix */
    qmc_seq_spec seq;
    qmc_format format;
    uint64_t count;             /* points per POINTS request */
    int bulk, inprocess, ceiling, dims_set, count_set;
    unsigned repeat;            /* bulk and inprocess: runs, median reported */
    long rss_pid;
    int shm;                    /* bulk through a shared-memory ring */
    int into;                   /* --shm: copied into one array, reused */
    uint32_t slots, slot_bytes; /* its geometry */
} opts;

static const char usage[] =
    "usage: qmc-load --connect unix:PATH|tcp:HOST:PORT [--clients C] [--threads T]\n"
    "                [--requests N | --seconds S] [--pipeline D] [--mix ping=W,points=W]\n"
    "                [--seq KIND] [--dims D] [--count N] [--format F] [--scramble S]\n"
    "                [--seed N] [--timeout S]\n"
    "       qmc-load --bulk --connect ENDPOINT [--dims D] [--count N] [--format F]\n"
    "                [--repeat R] [--rss-pid PID] [--shm [--slots S] [--slot-bytes B]\n"
    "                [--into]]\n"
    "       qmc-load --inprocess | --unix-ceiling [--dims D] [--count N] [--format F]\n"
    "                [--repeat R]\n"
    "Load defaults: 50 clients, 1 thread, pipeline 1, 100000 requests, mix ping=1,\n"
    "POINTS of 1 point of sobol d=8 f64.  Bulk and inprocess defaults: sobol d=32,\n"
    "4194304 points, f64, 3 runs (median).  --timeout (default 60 s) bounds any run;\n"
    "with both --requests and --seconds a run stops at whichever comes first.\n"
    "--unix-ceiling: the same bytes through a socketpair, no generation (the bound).\n"
    "--shm: bulk through a shared-memory ring (unix: only), default 8 slots of 1 MiB;\n"
    "--into: each run copies the points into one array (qmc_client_points).\n";

static void die(const char *what)
{
    fprintf(stderr, "qmc-load: %s\n", what);
    exit(2);
}

static uint64_t parse_u64(const char *s, const char *name)
{
    char *end;
    errno = 0;
    unsigned long long v = strtoull(s, &end, 0);
    if (errno || end == s || *end) {
        fprintf(stderr, "qmc-load: %s: '%s' is not a number\n", name, s);
        exit(2);
    }
    return v;
}

/* "ping=3,points=1" */
static void parse_mix(const char *s, opts *o)
{
    o->w_ping = o->w_points = 0;
    char buf[128];
    snprintf(buf, sizeof buf, "%s", s);
    for (char *tok = strtok(buf, ","); tok; tok = strtok(NULL, ",")) {
        char *eq = strchr(tok, '=');
        if (!eq)
            die("--mix: expected NAME=WEIGHT items");
        *eq = '\0';
        unsigned w = (unsigned)parse_u64(eq + 1, "--mix");
        if (strcmp(tok, "ping") == 0)
            o->w_ping = w;
        else if (strcmp(tok, "points") == 0)
            o->w_points = w;
        else
            die("--mix: names are ping and points");
    }
    if (o->w_ping + o->w_points == 0)
        die("--mix: all weights are zero");
}

static void parse_args(int argc, char **argv, opts *o)
{
    memset(o, 0, sizeof *o);
    o->clients = 50;
    o->pipeline = 1;
    o->threads = 1;
    o->timeout_s = 60;
    o->w_ping = 1;
    o->seq = (qmc_seq_spec){.kind = QMC_SEQ_SOBOL, .dims = 8, .scramble = QMC_SCRAMBLE_NONE};
    o->format = QMC_FORMAT_F64;
    o->count = 1;
    o->repeat = 3;
    o->slots = 8;
    o->slot_bytes = 1u << 20;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "--bulk") == 0) {
            o->bulk = 1;
            continue;
        }
        if (strcmp(a, "--inprocess") == 0) {
            o->inprocess = 1;
            continue;
        }
        if (strcmp(a, "--unix-ceiling") == 0) {
            o->ceiling = 1;
            continue;
        }
        if (strcmp(a, "--shm") == 0) {
            o->shm = 1;
            continue;
        }
        if (strcmp(a, "--into") == 0) {
            o->into = 1;
            continue;
        }
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            fputs(usage, stdout);
            exit(0);
        }
        if (i + 1 >= argc) {
            fputs(usage, stderr);
            exit(2);
        }
        const char *v = argv[++i];
        if (strcmp(a, "--connect") == 0)
            o->endpoint = v;
        else if (strcmp(a, "--clients") == 0)
            o->clients = (unsigned)parse_u64(v, a);
        else if (strcmp(a, "--threads") == 0)
            o->threads = (unsigned)parse_u64(v, a);
        else if (strcmp(a, "--requests") == 0)
            o->requests = parse_u64(v, a);
        else if (strcmp(a, "--seconds") == 0)
            o->seconds = strtod(v, NULL);
        else if (strcmp(a, "--timeout") == 0)
            o->timeout_s = strtod(v, NULL);
        else if (strcmp(a, "--pipeline") == 0)
            o->pipeline = (unsigned)parse_u64(v, a);
        else if (strcmp(a, "--mix") == 0)
            parse_mix(v, o);
        else if (strcmp(a, "--dims") == 0)
            o->seq.dims = (uint32_t)parse_u64(v, a), o->dims_set = 1;
        else if (strcmp(a, "--count") == 0)
            o->count = parse_u64(v, a), o->count_set = 1;
        else if (strcmp(a, "--seed") == 0)
            o->seq.seed = parse_u64(v, a);
        else if (strcmp(a, "--repeat") == 0)
            o->repeat = (unsigned)parse_u64(v, a);
        else if (strcmp(a, "--rss-pid") == 0)
            o->rss_pid = (long)parse_u64(v, a);
        else if (strcmp(a, "--slots") == 0)
            o->slots = (uint32_t)parse_u64(v, a);
        else if (strcmp(a, "--slot-bytes") == 0)
            o->slot_bytes = (uint32_t)parse_u64(v, a);
        else if (strcmp(a, "--seq") == 0) {
            if (qmc_seq_kind_parse(v, &o->seq.kind) != 0)
                die("--seq: unknown kind");
        } else if (strcmp(a, "--format") == 0) {
            if (qmc_format_parse(v, &o->format) != 0)
                die("--format: unknown format");
        } else if (strcmp(a, "--scramble") == 0) {
            if (qmc_scramble_parse(v, &o->seq.scramble) != 0)
                die("--scramble: unknown scramble");
        } else {
            fprintf(stderr, "qmc-load: unknown option %s\n%s", a, usage);
            exit(2);
        }
    }
    if (o->bulk || o->inprocess || o->ceiling) {
        if (!o->dims_set)
            o->seq.dims = 32;
        if (!o->count_set)
            o->count = 1u << 22;
        if (o->repeat == 0)
            o->repeat = 1;
    }
    if (!o->inprocess && !o->ceiling && !o->endpoint)
        die("--connect ENDPOINT is required");
    if (!o->requests && o->seconds <= 0)
        o->requests = 100000;
    if (o->clients == 0 || o->pipeline == 0 || o->pipeline > MAX_PIPELINE)
        die("--clients must be >= 1 and --pipeline 1..1024");
    if (o->threads == 0 || o->threads > MAX_THREADS)
        die("--threads must be 1..64");
    if (o->threads > o->clients)
        o->threads = o->clients;
    char why[256] = "";
    if (qmc_seq_spec_check(&o->seq, why, sizeof why) != 0) {
        fprintf(stderr, "qmc-load: sequence: %s\n", why);
        exit(2);
    }
}

/* ---- time and latency histogram -------------------------------------------- */

static uint64_t now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

/* Log-linear buckets (as HdrHistogram): values below 128 ns exactly, above
 * that 64 buckets per power of two, so any quantile is within 1 %. */
#define HIST_SUB 64u
#define HIST_BUCKETS (HIST_SUB * 60u)

typedef struct hist {
    uint64_t n[HIST_BUCKETS];
    uint64_t total, max_ns;
} hist;

static void hist_add(hist *h, uint64_t v)
{
    unsigned b;
    if (v < 2 * HIST_SUB) {
        b = (unsigned)v;
    } else {
        unsigned msb = 63u - (unsigned)__builtin_clzll(v);
        unsigned shift = msb - 6u;
        b = (shift + 1u) * HIST_SUB + (unsigned)((v >> shift) - HIST_SUB);
    }
    if (b >= HIST_BUCKETS)
        b = HIST_BUCKETS - 1;
    h->n[b]++;
    h->total++;
    if (v > h->max_ns)
        h->max_ns = v;
}

static double bucket_mid(unsigned b)
{
    if (b < 2 * HIST_SUB)
        return b;
    unsigned shift = b / HIST_SUB - 1u;
    double lo = (double)((uint64_t)(b % HIST_SUB + HIST_SUB) << shift);
    return lo + (double)(1ull << shift) / 2;
}

/* The q-quantile in microseconds (0 when empty). */
static double hist_quantile_us(const hist *h, double q)
{
    if (!h->total)
        return 0;
    uint64_t want = (uint64_t)(q * (double)h->total + 0.999999);
    if (want == 0)
        want = 1;
    uint64_t seen = 0;
    for (unsigned b = 0; b < HIST_BUCKETS; b++) {
        seen += h->n[b];
        if (seen >= want)
            return bucket_mid(b) / 1e3;
    }
    return (double)h->max_ns / 1e3;
}

/* ---- connecting and the handshake ------------------------------------------- */

/* Connects (blocking) to unix:PATH or tcp:HOST:PORT (HOST may be [v6]).
 * Returns the fd, or -1 with a message printed. */
static int connect_endpoint(const char *ep)
{
    int fd = -1;
    if (strncmp(ep, "unix:", 5) == 0) {
        struct sockaddr_un sa = {.sun_family = AF_UNIX};
        if (strlen(ep + 5) >= sizeof sa.sun_path) {
            fprintf(stderr, "qmc-load: socket path too long\n");
            return -1;
        }
        strcpy(sa.sun_path, ep + 5);
        fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
        if (fd < 0 || connect(fd, (struct sockaddr *)&sa, sizeof sa) != 0) {
            fprintf(stderr, "qmc-load: %s: %s\n", ep, strerror(errno));
            if (fd >= 0)
                close(fd);
            return -1;
        }
        return fd;
    }
    if (strncmp(ep, "tcp:", 4) != 0) {
        fprintf(stderr, "qmc-load: endpoint must be unix:PATH or tcp:HOST:PORT\n");
        return -1;
    }
    char host[256];
    snprintf(host, sizeof host, "%s", ep + 4);
    char *colon = strrchr(host, ':');
    if (!colon) {
        fprintf(stderr, "qmc-load: %s: no port\n", ep);
        return -1;
    }
    *colon = '\0';
    const char *port = colon + 1, *h = host;
    if (host[0] == '[' && colon > host && colon[-1] == ']') {
        colon[-1] = '\0';
        h = host + 1;
    }
    struct addrinfo hints = {.ai_socktype = SOCK_STREAM}, *res = NULL;
    int rc = getaddrinfo(h, port, &hints, &res);
    if (rc != 0) {
        fprintf(stderr, "qmc-load: %s: %s\n", ep, gai_strerror(rc));
        return -1;
    }
    for (struct addrinfo *ai = res; ai; ai = ai->ai_next) {
        fd = socket(ai->ai_family, ai->ai_socktype | SOCK_CLOEXEC, ai->ai_protocol);
        if (fd >= 0 && connect(fd, ai->ai_addr, ai->ai_addrlen) == 0)
            break;
        if (fd >= 0)
            close(fd);
        fd = -1;
    }
    freeaddrinfo(res);
    if (fd < 0) {
        fprintf(stderr, "qmc-load: %s: %s\n", ep, strerror(errno));
        return -1;
    }
    int one = 1;
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    return fd;
}

static int send_all(int fd, const uint8_t *p, size_t n)
{
    while (n) {
        ssize_t k = send(fd, p, n, MSG_NOSIGNAL);
        if (k < 0 && errno == EINTR)
            continue;
        if (k <= 0)
            return -1;
        p += k;
        n -= (size_t)k;
    }
    return 0;
}

/* Reads one whole frame (blocking) into buf (FRAME_BUF bytes) and decodes
 * it.  Returns 0, or -1 with a message printed. */
static int read_frame(int fd, uint8_t *buf, qmc_msg *m)
{
    ssize_t k = recv(fd, buf, QMC_PROTO_HEADER_BYTES, MSG_WAITALL);
    if (k != (ssize_t)QMC_PROTO_HEADER_BYTES) {
        fprintf(stderr, "qmc-load: reading a frame: %s\n", k < 0 ? strerror(errno) : "closed");
        return -1;
    }
    qmc_msg_type type;
    uint64_t id;
    uint32_t plen;
    int rc = qmc_proto_peek(buf, QMC_PROTO_HEADER_BYTES, MAX_FRAME, &type, &id, &plen);
    if (rc < 0) {
        fprintf(stderr, "qmc-load: bad frame header: %s\n", qmc_strerror(rc));
        return -1;
    }
    if (plen) {
        k = recv(fd, buf + QMC_PROTO_HEADER_BYTES, plen, MSG_WAITALL);
        if (k != (ssize_t)plen) {
            fprintf(stderr, "qmc-load: reading a payload: %s\n",
                    k < 0 ? strerror(errno) : "closed");
            return -1;
        }
    }
    rc = qmc_proto_decode(buf, QMC_PROTO_HEADER_BYTES + plen, MAX_FRAME, m);
    if (rc < 0) {
        fprintf(stderr, "qmc-load: bad %s frame: %s\n", qmc_msg_type_name(type),
                qmc_strerror(rc));
        return -1;
    }
    return 0;
}

/* Connects and does HELLO; returns the fd (still blocking) or -1.
 * *max_inflight gets the server's limit. */
static int open_session(const char *ep, uint8_t *buf, uint32_t *max_inflight)
{
    int fd = connect_endpoint(ep);
    if (fd < 0)
        return -1;
    static const char name[] = "qmc-load/1";
    qmc_msg m = {.type = QMC_MSG_HELLO, .request_id = 1};
    m.u.hello.version_min = 1;
    m.u.hello.version_max = QMC_PROTO_VERSION_MAX;
    m.u.hello.max_frame = MAX_FRAME;
    m.u.hello.client = (qmc_str){name, sizeof name - 1};
    int n = qmc_proto_encode(&m, buf, FRAME_BUF);
    if (n < 0 || send_all(fd, buf, (size_t)n) != 0 || read_frame(fd, buf, &m) != 0)
        goto fail;
    if (m.type != QMC_MSG_HELLO_OK) {
        fprintf(stderr, "qmc-load: HELLO answered by %s%s%.*s\n", qmc_msg_type_name(m.type),
                m.type == QMC_MSG_ERROR ? ": " : "",
                m.type == QMC_MSG_ERROR ? (int)m.u.error.message.len : 0,
                m.type == QMC_MSG_ERROR ? m.u.error.message.ptr : "");
        goto fail;
    }
    if (max_inflight)
        *max_inflight = m.u.hello_ok.max_inflight;
    return fd;
fail:
    close(fd);
    return -1;
}

/* ---- load mode --------------------------------------------------------------- */

typedef struct slot {
    uint64_t t0_ns;
    int busy;
} slot;

typedef struct conn {
    int fd, dead, want_out;
    uint8_t *in, *out;
    size_t in_len, in_cap, out_off, out_len;
    unsigned inflight;
    uint64_t next_seq, rng;
    slot *slots;                 /* pipeline entries; id = seq * D + i + 1 */
    unsigned free_top;
    unsigned *free_slots;
} conn;

typedef struct worker {
    pthread_t th;
    const opts *o;
    conn *conns;
    unsigned n_conns;
    int epfd;
    uint64_t quota, issued, done, errors;
    uint64_t t_start_ns, stop_ns, hard_ns;
    int timed_out;
    hist h;
} worker;

static uint64_t xorshift(uint64_t *s)
{
    uint64_t x = *s;
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    return *s = x;
}

/* May this worker start another request now?  Both bounds apply when both
 * are given: whichever comes first. */
static int may_issue(const worker *w, uint64_t now)
{
    if (w->o->requests && w->issued >= w->quota)
        return 0;
    return w->o->seconds <= 0 || now < w->stop_ns;
}

/* Encodes one request into the connection's output buffer. */
static int issue(worker *w, conn *c, uint64_t now)
{
    const opts *o = w->o;
    unsigned i = c->free_slots[--c->free_top];
    uint64_t seq = c->next_seq++;
    qmc_msg m = {.request_id = seq * o->pipeline + i + 1};
    unsigned pick = (unsigned)(xorshift(&c->rng) % (o->w_ping + o->w_points));
    if (pick < o->w_ping) {
        m.type = QMC_MSG_PING;
    } else {
        m.type = QMC_MSG_POINTS;
        m.u.points.seq = o->seq;
        m.u.points.format = o->format;
        m.u.points.start = (seq & 0xfffff) * o->count;
        m.u.points.count = o->count;
    }
    int n = qmc_proto_encode(&m, c->out + c->out_len, OUT_BYTES - c->out_len);
    if (n < 0) {
        c->free_slots[c->free_top++] = i;
        return -1;
    }
    c->out_len += (size_t)n;
    c->slots[i].busy = 1;
    c->slots[i].t0_ns = now;
    c->inflight++;
    w->issued++;
    return 0;
}

static void conn_fail(worker *w, conn *c, const char *why)
{
    if (c->dead)
        return;
    fprintf(stderr, "qmc-load: connection lost (%s); %u request(s) in flight\n", why,
            c->inflight);
    w->errors += c->inflight;
    c->inflight = 0;
    c->dead = 1;
    epoll_ctl(w->epfd, EPOLL_CTL_DEL, c->fd, NULL);
    close(c->fd);
    c->fd = -1;
}

/* Tops up the window, then writes what is queued.  Keeps EPOLLOUT on only
 * while output is left over. */
static void conn_fill_and_flush(worker *w, conn *c)
{
    if (c->dead)
        return;
    uint64_t now = now_ns();
    while (c->inflight < w->o->pipeline && may_issue(w, now) &&
           OUT_BYTES - c->out_len >= 256)
        if (issue(w, c, now) != 0)
            break;
    while (c->out_off < c->out_len) {
        ssize_t k = send(c->fd, c->out + c->out_off, c->out_len - c->out_off,
                         MSG_NOSIGNAL | MSG_DONTWAIT);
        if (k > 0) {
            c->out_off += (size_t)k;
            continue;
        }
        if (k < 0 && errno == EINTR)
            continue;
        if (k < 0 && errno == EAGAIN)
            break;
        conn_fail(w, c, k < 0 ? strerror(errno) : "send returned 0");
        return;
    }
    if (c->out_off == c->out_len)
        c->out_off = c->out_len = 0;
    int want = c->out_off < c->out_len;
    if (want != c->want_out) {
        struct epoll_event ev = {.events = EPOLLIN | (want ? EPOLLOUT : 0), .data.ptr = c};
        epoll_ctl(w->epfd, EPOLL_CTL_MOD, c->fd, &ev);
        c->want_out = want;
    }
}

/* One decoded answer. */
static void on_answer(worker *w, conn *c, const qmc_msg *m, uint64_t now)
{
    int final;
    switch (m->type) {
    case QMC_MSG_PONG:
    case QMC_MSG_END:
        final = 1;
        break;
    case QMC_MSG_ERROR:
        final = 1;
        if (w->errors < 3)
            fprintf(stderr, "qmc-load: ERROR %d: %.*s\n", m->u.error.code,
                    (int)m->u.error.message.len, m->u.error.message.ptr);
        w->errors++;
        break;
    case QMC_MSG_POINTS_CHUNK:
        final = 0;
        break;
    default:
        final = 0;
        w->errors++;
        break;
    }
    if (!final)
        return;
    if (m->request_id == 0) { /* about the connection: it is closing */
        conn_fail(w, c, "server ERROR for the connection");
        return;
    }
    unsigned i = (unsigned)((m->request_id - 1) % w->o->pipeline);
    if (!c->slots[i].busy) {
        w->errors++;
        return;
    }
    c->slots[i].busy = 0;
    c->free_slots[c->free_top++] = i;
    c->inflight--;
    if (m->type != QMC_MSG_ERROR) {
        w->done++;
        hist_add(&w->h, now - c->slots[i].t0_ns);
    }
}

static void conn_read(worker *w, conn *c)
{
    for (;;) {
        if (c->in_len == c->in_cap) {
            size_t n = c->in_cap * 2;
            if (n > FRAME_BUF)
                n = FRAME_BUF;
            uint8_t *p = n > c->in_cap ? realloc(c->in, n) : NULL;
            if (!p) {
                conn_fail(w, c, "input buffer full");
                return;
            }
            c->in = p;
            c->in_cap = n;
        }
        size_t asked = c->in_cap - c->in_len;
        ssize_t k = recv(c->fd, c->in + c->in_len, asked, MSG_DONTWAIT);
        if (k < 0 && errno == EINTR)
            continue;
        if (k < 0 && errno == EAGAIN)
            return;
        if (k <= 0) {
            conn_fail(w, c, k == 0 ? "closed by the server" : strerror(errno));
            return;
        }
        c->in_len += (size_t)k;
        uint64_t now = now_ns();
        size_t off = 0;
        for (;;) {
            qmc_msg m;
            int rc = qmc_proto_decode(c->in + off, c->in_len - off, MAX_FRAME, &m);
            if (rc == QMC_EAGAIN)
                break;
            if (rc < 0) {
                conn_fail(w, c, qmc_strerror(rc));
                return;
            }
            on_answer(w, c, &m, now);
            if (c->dead)
                return;
            off += (size_t)rc;
        }
        if (off) {
            memmove(c->in, c->in + off, c->in_len - off);
            c->in_len -= off;
        }
        if ((size_t)k < asked)
            return; /* a short read: the socket is drained, skip the EAGAIN */
    }
}

static void *worker_run(void *arg)
{
    worker *w = arg;
    struct epoll_event evs[256];
    for (unsigned i = 0; i < w->n_conns; i++)
        conn_fill_and_flush(w, &w->conns[i]);
    for (;;) {
        unsigned busy = 0;
        for (unsigned i = 0; i < w->n_conns; i++)
            busy += w->conns[i].inflight;
        uint64_t now = now_ns();
        if (busy == 0 && !may_issue(w, now))
            break;
        if (now >= w->hard_ns) {
            w->timed_out = 1;
            w->errors += busy;
            break;
        }
        int n = epoll_wait(w->epfd, evs, 256, 100);
        if (n < 0 && errno != EINTR) {
            perror("qmc-load: epoll_wait");
            break;
        }
        for (int e = 0; e < n; e++) {
            conn *c = evs[e].data.ptr;
            if (!c->dead && (evs[e].events & (EPOLLIN | EPOLLERR | EPOLLHUP)))
                conn_read(w, c);
            conn_fill_and_flush(w, c);
        }
    }
    return NULL;
}

static int run_load(const opts *o)
{
    unsigned T = o->threads;
    worker *ws = calloc(T, sizeof *ws);
    conn *cs = calloc(o->clients, sizeof *cs);
    uint8_t *buf = malloc(FRAME_BUF);
    if (!ws || !cs || !buf)
        die("out of memory");
    uint32_t max_inflight = 0;
    unsigned points_warned = 0;
    uint64_t t_setup = now_ns();
    for (unsigned i = 0; i < o->clients; i++) {
        conn *c = &cs[i];
        c->fd = open_session(o->endpoint, buf, &max_inflight);
        if (c->fd < 0)
            return 1;
        if (!points_warned && o->w_points && o->pipeline > max_inflight) {
            fprintf(stderr, "qmc-load: pipeline %u is above the server's max-inflight %u: "
                            "expect ERROR answers\n", o->pipeline, max_inflight);
            points_warned = 1;
        }
        fcntl(c->fd, F_SETFL, fcntl(c->fd, F_GETFL) | O_NONBLOCK);
        c->in_cap = IN_START_BYTES;
        c->in = malloc(c->in_cap);
        c->out = malloc(OUT_BYTES);
        c->slots = calloc(o->pipeline, sizeof *c->slots);
        c->free_slots = malloc(o->pipeline * sizeof *c->free_slots);
        if (!c->in || !c->out || !c->slots || !c->free_slots)
            die("out of memory");
        for (unsigned k = 0; k < o->pipeline; k++)
            c->free_slots[k] = o->pipeline - 1 - k;
        c->free_top = o->pipeline;
        c->rng = 0x9e3779b97f4a7c15ull * (i + 1);
    }
    uint64_t t0 = now_ns();
    double setup_ms = (double)(t0 - t_setup) / 1e6;
    for (unsigned t = 0; t < T; t++) {
        worker *w = &ws[t];
        w->o = o;
        w->conns = cs + (size_t)o->clients * t / T;
        w->n_conns = (unsigned)((size_t)o->clients * (t + 1) / T - (size_t)o->clients * t / T);
        w->quota = o->requests * (t + 1) / T - o->requests * t / T;
        w->t_start_ns = t0;
        w->stop_ns = t0 + (uint64_t)(o->seconds * 1e9);
        w->hard_ns = t0 + (uint64_t)(o->timeout_s * 1e9);
        w->epfd = epoll_create1(EPOLL_CLOEXEC);
        if (w->epfd < 0)
            die("epoll_create1 failed");
        for (unsigned i = 0; i < w->n_conns; i++) {
            struct epoll_event ev = {.events = EPOLLIN, .data.ptr = &w->conns[i]};
            if (epoll_ctl(w->epfd, EPOLL_CTL_ADD, w->conns[i].fd, &ev) != 0)
                die("epoll_ctl failed");
        }
    }
    int rc = 0;
    if (T == 1) {
        worker_run(&ws[0]);
    } else {
        for (unsigned t = 0; t < T; t++)
            if (pthread_create(&ws[t].th, NULL, worker_run, &ws[t]) != 0)
                die("pthread_create failed");
        for (unsigned t = 0; t < T; t++)
            pthread_join(ws[t].th, NULL);
    }
    double secs = (double)(now_ns() - t0) / 1e9;
    static hist all;
    uint64_t done = 0, errors = 0;
    int timed_out = 0;
    for (unsigned t = 0; t < T; t++) {
        for (unsigned b = 0; b < HIST_BUCKETS; b++)
            all.n[b] += ws[t].h.n[b];
        all.total += ws[t].h.total;
        if (ws[t].h.max_ns > all.max_ns)
            all.max_ns = ws[t].h.max_ns;
        done += ws[t].done;
        errors += ws[t].errors;
        timed_out |= ws[t].timed_out;
        close(ws[t].epfd);
    }
    if (timed_out) {
        fprintf(stderr, "qmc-load: --timeout %.0f s reached with requests in flight\n",
                o->timeout_s);
        rc = 1;
    }
    double rate = secs > 0 ? (double)done / secs : 0;
    double p50 = hist_quantile_us(&all, 0.5), p99 = hist_quantile_us(&all, 0.99),
           p999 = hist_quantile_us(&all, 0.999);
    printf("qmc-load: %s  clients %u  threads %u  pipeline %u  mix ping=%u,points=%u",
           o->endpoint, o->clients, T, o->pipeline, o->w_ping, o->w_points);
    if (o->w_points)
        printf(" (POINTS %s d=%u %s x%llu)", qmc_seq_kind_name(o->seq.kind), o->seq.dims,
               qmc_format_name(o->format), (unsigned long long)o->count);
    printf("\n  requests %llu in %.3f s: %.0f req/s\n", (unsigned long long)done, secs, rate);
    printf("  latency us: p50 %.1f  p99 %.1f  p99.9 %.1f  max %.1f\n", p50, p99, p999,
           (double)all.max_ns / 1e3);
    printf("  errors %llu\n", (unsigned long long)errors);
    printf("  setup: %u connections with HELLO in %.1f ms (%.3f ms each)\n", o->clients,
           setup_ms, setup_ms / o->clients);
    printf("RESULT mode=load requests=%llu seconds=%.4f rate=%.1f p50_us=%.2f p99_us=%.2f "
           "p999_us=%.2f max_us=%.2f errors=%llu setup_ms=%.2f\n",
           (unsigned long long)done, secs, rate, p50, p99, p999, (double)all.max_ns / 1e3,
           (unsigned long long)errors, setup_ms);
    for (unsigned i = 0; i < o->clients; i++) {
        if (!cs[i].dead)
            close(cs[i].fd);
        free(cs[i].in);
        free(cs[i].out);
        free(cs[i].slots);
        free(cs[i].free_slots);
    }
    free(cs);
    free(ws);
    free(buf);
    return rc;
}

/* ---- bulk and in-process ----------------------------------------------------------- */

/* VmRSS of pid in KiB, or -1. */
static long rss_kib(long pid)
{
    char path[64], line[256];
    snprintf(path, sizeof path, "/proc/%ld/status", pid);
    FILE *f = fopen(path, "r");
    if (!f)
        return -1;
    long kib = -1;
    while (fgets(line, sizeof line, f))
        if (sscanf(line, "VmRSS: %ld", &kib) == 1)
            break;
    fclose(f);
    return kib;
}

/* The daemon's VmRSS after a stream, once its loop has had a moment to
 * flush and free after END; -1 without --rss-pid. */
static long rss_settled(const opts *o)
{
    if (!o->rss_pid)
        return -1;
    struct timespec ts = {0, 100 * 1000000L};
    nanosleep(&ts, NULL);
    return rss_kib(o->rss_pid);
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static void print_rate(const char *mode, const opts *o, double *secs, unsigned runs,
                       uint64_t bytes)
{
    qsort(secs, runs, sizeof *secs, cmp_double);
    double s = secs[runs / 2];
    double mbps = (double)bytes / s / 1e6, pps = (double)o->count / s;
    printf("qmc-load %s: %s d=%u %s, %llu points (%.1f MiB), median of %u: %.3f s, "
           "%.1f MB/s, %.3g points/s\n",
           mode, qmc_seq_kind_name(o->seq.kind), o->seq.dims, qmc_format_name(o->format),
           (unsigned long long)o->count, (double)bytes / 1048576.0, runs, s, mbps, pps);
    printf("RESULT mode=%s points=%llu bytes=%llu seconds=%.4f mbps=%.1f points_per_s=%.0f",
           mode, (unsigned long long)o->count, (unsigned long long)bytes, s, mbps, pps);
}

/* The chunk the daemon would cut (QMC_PROTO_CHUNK_BYTES of whole points),
 * so both sides do the same generation work per call. */
static int run_inprocess(const opts *o)
{
    size_t row = (size_t)o->seq.dims * qmc_format_bytes(o->format);
    size_t chunk = QMC_PROTO_CHUNK_BYTES / row;
    if (chunk == 0)
        die("one point is larger than a chunk");
    void *buf = aligned_alloc(64, (chunk * row + 63) / 64 * 64);
    qmc_seq *seq = NULL;
    if (!buf || qmc_seq_new(&o->seq, &seq) != 0)
        die("cannot make the sequence");
    double secs[64];
    unsigned runs = o->repeat > 64 ? 64 : o->repeat;
    volatile uint8_t sink = 0;
    for (unsigned r = 0; r < runs; r++) {
        uint64_t t0 = now_ns();
        for (uint64_t i = 0; i < o->count; i += chunk) {
            uint64_t n = o->count - i < chunk ? o->count - i : chunk;
            if (qmc_seq_fill(seq, i, n, o->format, buf) != 0)
                die("qmc_seq_fill failed");
            sink ^= ((uint8_t *)buf)[n * row / 2];
        }
        secs[r] = (double)(now_ns() - t0) / 1e9;
    }
    (void)sink;
    print_rate("inprocess", o, secs, runs, (uint64_t)o->count * row);
    printf(" chunk_points=%zu\n", chunk);
    qmc_seq_free(seq);
    free(buf);
    return 0;
}

static int run_bulk(const opts *o)
{
    uint8_t *buf = aligned_alloc(64, FRAME_BUF);
    if (!buf)
        die("out of memory");
    int fd = open_session(o->endpoint, buf, NULL);
    if (fd < 0)
        return 1;
    size_t row = (size_t)o->seq.dims * qmc_format_bytes(o->format);
    uint64_t want_bytes = (uint64_t)o->count * row;
    long rss_before = o->rss_pid ? rss_kib(o->rss_pid) : -1, rss_peak = rss_before;
    double secs[64];
    unsigned runs = o->repeat > 64 ? 64 : o->repeat;
    uint64_t frames = 0;
    for (unsigned r = 0; r < runs; r++) {
        qmc_msg m = {.type = QMC_MSG_POINTS, .request_id = 2 + r};
        m.u.points.seq = o->seq;
        m.u.points.format = o->format;
        m.u.points.start = 0;
        m.u.points.count = o->count;
        int n = qmc_proto_encode(&m, buf, FRAME_BUF);
        uint64_t t0 = now_ns(), next_sample = t0, bytes = 0, points = 0;
        if (n < 0 || send_all(fd, buf, (size_t)n) != 0)
            die("sending POINTS failed");
        for (;;) {
            if (read_frame(fd, buf, &m) != 0)
                return 1;
            frames++;
            if (o->rss_pid) {
                uint64_t now = now_ns();
                if (now >= next_sample) { /* every 2 ms: /proc reads are not free */
                    long k = rss_kib(o->rss_pid);
                    if (k > rss_peak)
                        rss_peak = k;
                    next_sample = now + 2000000;
                }
            }
            if (m.type == QMC_MSG_POINTS_CHUNK) {
                if (m.u.chunk.first != points) {
                    fprintf(stderr, "qmc-load: chunk out of order: first %llu, expected %llu\n",
                            (unsigned long long)m.u.chunk.first, (unsigned long long)points);
                    return 1;
                }
                points += m.u.chunk.points;
                bytes += m.u.chunk.data_len;
                continue;
            }
            if (m.type == QMC_MSG_END)
                break;
            if (m.type == QMC_MSG_ERROR)
                fprintf(stderr, "qmc-load: ERROR %d: %.*s\n", m.u.error.code,
                        (int)m.u.error.message.len, m.u.error.message.ptr);
            else
                fprintf(stderr, "qmc-load: unexpected %s\n", qmc_msg_type_name(m.type));
            return 1;
        }
        secs[r] = (double)(now_ns() - t0) / 1e9;
        if (points != o->count || bytes != want_bytes || m.u.end.bytes != bytes) {
            fprintf(stderr, "qmc-load: stream short: %llu points, %llu bytes\n",
                    (unsigned long long)points, (unsigned long long)bytes);
            return 1;
        }
    }
    long rss_after = rss_settled(o);
    close(fd);
    free(buf);
    print_rate("bulk", o, secs, runs, want_bytes);
    printf(" frames=%llu rss_before_kib=%ld rss_peak_kib=%ld rss_after_kib=%ld\n",
           (unsigned long long)frames, rss_before, rss_peak, rss_after);
    return 0;
}

/* What a client does with each chunk: reads a byte of it (as --inprocess
 * does with its buffer), and samples the daemon's VmRSS now and then. */
typedef struct shm_sink {
    long rss_pid, rss_peak;
    uint64_t next_sample_ns, chunks;
    uint8_t sink;
} shm_sink;

static int touch_chunk(void *ctx, uint64_t first, uint32_t points, const void *data,
                       size_t bytes)
{
    shm_sink *k = ctx;
    (void)first, (void)points;
    k->sink ^= ((const volatile uint8_t *)data)[bytes / 2];
    k->chunks++;
    if (k->rss_pid) {
        uint64_t now = now_ns();
        if (now >= k->next_sample_ns) { /* every 2 ms: /proc reads are not free */
            long kib = rss_kib(k->rss_pid);
            if (kib > k->rss_peak)
                k->rss_peak = kib;
            k->next_sample_ns = now + 2000000;
        }
    }
    return 0;
}

/* --bulk --shm: libqmcclient with a ring attached, one stream per run. */
static int run_bulk_shm(const opts *o)
{
    /* Before connecting: the ring the daemon maps is part of what it holds
     * during the stream (its RssShmem; the pages are the client's). */
    long rss_before = o->rss_pid ? rss_kib(o->rss_pid) : -1;
    qmc_client *c = NULL;
    int ms = o->timeout_s > 0 && o->timeout_s < 2e6 ? (int)(o->timeout_s * 1000) : -1;
    int err = qmc_client_connect(o->endpoint, ms, &c);
    if (!err)
        err = qmc_client_attach_shm(c, o->slots, o->slot_bytes);
    if (err) {
        fprintf(stderr, "qmc-load: %s: %s\n", o->endpoint, qmc_client_last_error(c));
        qmc_client_close(c);
        return 1;
    }
    size_t row = (size_t)o->seq.dims * qmc_format_bytes(o->format);
    shm_sink k = {.rss_pid = o->rss_pid};
    k.rss_peak = rss_before;
    double secs[64];
    unsigned runs = o->repeat > 64 ? 64 : o->repeat;
    /* --into: the array is allocated and faulted in before the clock, so
     * the runs time the client and not the kernel's page faults (which
     * on a virtual machine vary by 10x from run to run). */
    uint8_t *out = NULL;
    if (o->into && !(out = malloc((size_t)o->count * row))) {
        fprintf(stderr, "qmc-load: no memory for %llu points\n", (unsigned long long)o->count);
        qmc_client_close(c);
        return 1;
    }
    if (out)
        memset(out, 0, (size_t)o->count * row);
    for (unsigned r = 0; r < runs; r++) {
        uint64_t t0 = now_ns();
        if (o->into) {
            err = qmc_client_points(c, &o->seq, 0, o->count, o->format, out,
                                    (size_t)o->count * row);
            k.sink ^= ((volatile uint8_t *)out)[(size_t)o->count * row / 2];
        } else {
            err = qmc_client_points_stream(c, &o->seq, 0, o->count, o->format, touch_chunk,
                                           &k);
        }
        secs[r] = (double)(now_ns() - t0) / 1e9;
        if (err) {
            fprintf(stderr, "qmc-load: %s\n", qmc_client_last_error(c));
            free(out);
            qmc_client_close(c);
            return 1;
        }
    }
    free(out);
    long rss_after = rss_settled(o);
    qmc_client_close(c);
    print_rate(o->into ? "bulk-shm-into" : "bulk-shm", o, secs, runs,
               (uint64_t)o->count * row);
    if (!o->into) /* qmc_client_points hands no chunk to count */
        printf(" frames=%llu", (unsigned long long)k.chunks);
    printf(" slots=%u slot_bytes=%u rss_before_kib=%ld rss_peak_kib=%ld rss_after_kib=%ld\n",
           o->slots, o->slot_bytes, rss_before, k.rss_peak, rss_after);
    return 0;
}

/* The transport's ceiling: the same bytes through an AF_UNIX socketpair,
 * written in chunk-sized sends by one thread and read by another, with no
 * generation and no protocol.  No daemon can stream faster than this. */
typedef struct ceiling_job {
    int fd;
    uint64_t bytes;
    const uint8_t *buf;
    size_t chunk;
} ceiling_job;

static void *ceiling_writer(void *arg)
{
    ceiling_job *j = arg;
    for (uint64_t sent = 0; sent < j->bytes;) {
        size_t n = j->bytes - sent < j->chunk ? (size_t)(j->bytes - sent) : j->chunk;
        if (send_all(j->fd, j->buf, n) != 0)
            break;
        sent += n;
    }
    return NULL;
}

static int run_ceiling(const opts *o)
{
    size_t row = (size_t)o->seq.dims * qmc_format_bytes(o->format);
    uint64_t bytes = (uint64_t)o->count * row;
    uint8_t *wbuf = calloc(1, QMC_PROTO_CHUNK_BYTES + 40), *rbuf = malloc(FRAME_BUF);
    if (!wbuf || !rbuf)
        die("out of memory");
    double secs[64];
    unsigned runs = o->repeat > 64 ? 64 : o->repeat;
    for (unsigned r = 0; r < runs; r++) {
        int sv[2];
        if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sv) != 0)
            die("socketpair failed");
        ceiling_job j = {.fd = sv[0], .bytes = bytes, .buf = wbuf,
                         .chunk = QMC_PROTO_CHUNK_BYTES + 40};
        pthread_t th;
        uint64_t t0 = now_ns(), got = 0;
        if (pthread_create(&th, NULL, ceiling_writer, &j) != 0)
            die("pthread_create failed");
        while (got < bytes) {
            ssize_t k = recv(sv[1], rbuf, FRAME_BUF, 0);
            if (k <= 0)
                break;
            got += (uint64_t)k;
        }
        secs[r] = (double)(now_ns() - t0) / 1e9;
        pthread_join(th, NULL);
        close(sv[0]);
        close(sv[1]);
        if (got != bytes)
            die("socketpair stream short");
    }
    print_rate("unix-ceiling", o, secs, runs, bytes);
    printf("\n");
    free(wbuf);
    free(rbuf);
    return 0;
}

int main(int argc, char **argv)
{
    opts o;
    parse_args(argc, argv, &o);
    if (o.inprocess)
        return run_inprocess(&o);
    if (o.ceiling)
        return run_ceiling(&o);
    if (o.bulk)
        return o.shm ? run_bulk_shm(&o) : run_bulk(&o);
    return run_load(&o);
}
