/*
 * modbus_load.c - the Modbus TCP load generator of bench/bench_modbus.sh.
 *
 *   modbus-load HOST PORT CONNS SECONDS DRIBBLERS [--setup]
 *
 * CONNS - DRIBBLERS connections each send FC04 reads of input registers
 * 0..13 (the result block of a 4-dim float32 point: echo, status, index,
 * 8 coordinate registers) back to back, one outstanding request each,
 * for SECONDS, timing every request from its send to its full answer.
 * DRIBBLERS more connections send the same request one byte every 100 ms,
 * frame after frame.  --setup first writes the point's request (sobol, 4
 * dims, float32, index 1, request 1) with FC16, for qmcd; a static server
 * ignores it.
 *
 * Prints one line: requests, the rate over the prompt connections, the
 * 50th/99th/max latency in microseconds, errors, and dribbled frames
 * answered.  Frames are built here from the MBAP spec; raw sockets, so the
 * dribble is exactly one byte per write.
 */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#define MAX_SAMPLES (1u << 22)
#define READ_REGS 14

static const char *host;
static int port;
static atomic_int stop;
static int64_t stop_at_us;

typedef struct worker {
    pthread_t t;
    int fd;
    int dribble;
    uint32_t *lat_us;      /* this worker's samples */
    uint32_t n;
    uint64_t errors, frames;
} worker;

static int64_t now_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000 + ts.tv_nsec / 1000;
}

static int dial(void)
{
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in sa = {.sin_family = AF_INET, .sin_port = htons((uint16_t)port)};
    if (fd < 0 || inet_pton(AF_INET, host, &sa.sin_addr) != 1 ||
        connect(fd, (struct sockaddr *)&sa, sizeof sa) != 0) {
        fprintf(stderr, "modbus-load: connect %s:%d: %s\n", host, port, strerror(errno));
        exit(1);
    }
    int one = 1;
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    struct timeval tv = {10, 0};
    setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    return fd;
}

static size_t fc04(uint8_t *b, uint16_t tid)
{
    const uint8_t f[12] = {(uint8_t)(tid >> 8), (uint8_t)tid, 0, 0, 0, 6, 1, 4, 0, 0, 0,
                           READ_REGS};
    memcpy(b, f, sizeof f);
    return sizeof f;
}

static int recv_all(int fd, uint8_t *b, size_t n)
{
    size_t got = 0;
    while (got < n) {
        ssize_t r = recv(fd, b + got, n - got, 0);
        if (r <= 0)
            return -1;
        got += (size_t)r;
    }
    return 0;
}

/* The answer: MBAP, FC04, byte count 28, the registers. */
static int answer_ok(int fd, uint16_t tid)
{
    uint8_t b[7 + 2 + 2 * READ_REGS];
    if (recv_all(fd, b, sizeof b) != 0)
        return 0;
    return b[0] == (uint8_t)(tid >> 8) && b[1] == (uint8_t)tid && b[7] == 4 &&
           b[8] == 2 * READ_REGS;
}

static void *run(void *arg)
{
    worker *w = arg;
    uint8_t req[12];
    uint16_t tid = 0;
    while (!atomic_load(&stop)) {
        size_t n = fc04(req, ++tid);
        if (w->dribble) {
            for (size_t i = 0; i < n && !atomic_load(&stop); i++) {
                if (send(w->fd, req + i, 1, MSG_NOSIGNAL) != 1) {
                    w->errors++;
                    return NULL;
                }
                usleep(100000);
            }
            if (atomic_load(&stop))
                break;
            if (answer_ok(w->fd, tid))
                w->frames++;
            else
                w->errors++;
            continue;
        }
        int64_t t0 = now_us();
        if (send(w->fd, req, n, MSG_NOSIGNAL) != (ssize_t)n || !answer_ok(w->fd, tid)) {
            w->errors++;
            return NULL;
        }
        int64_t t1 = now_us();
        if (t1 <= stop_at_us && w->n < MAX_SAMPLES)
            w->lat_us[w->n++] = (uint32_t)(t1 - t0);
    }
    return NULL;
}

static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

/* FC16: holding 0..10 = sobol, 4 dims, no scramble, seed 0, float32,
 * index 1, request 1. */
static void setup(void)
{
    int fd = dial();
    const uint8_t f[] = {0, 1, 0, 0, 0, 7 + 22, 1, 0x10, 0, 0, 0, 11, 22,
                         0, 1, 0, 4, 0, 0, 0, 0, 0, 0, 0, 0,
                         0, 0, 0, 0, 0, 0, 0, 1, 0, 1};
    uint8_t b[12];
    if (send(fd, f, sizeof f, 0) != (ssize_t)sizeof f || recv_all(fd, b, 12) != 0 ||
        b[7] != 0x10) {
        fprintf(stderr, "modbus-load: setup write refused\n");
        exit(1);
    }
    close(fd);
}

int main(int argc, char **argv)
{
    if (argc < 6) {
        fprintf(stderr, "usage: modbus-load HOST PORT CONNS SECONDS DRIBBLERS [--setup]\n");
        return 2;
    }
    host = argv[1];
    port = atoi(argv[2]);
    int conns = atoi(argv[3]), dribblers = atoi(argv[5]);
    double seconds = atof(argv[4]);
    if (conns < 1 || conns > 1000 || dribblers < 0 || dribblers >= conns || seconds <= 0)
        return 2;
    if (argc > 6 && strcmp(argv[6], "--setup") == 0)
        setup();
    worker *w = calloc((size_t)conns, sizeof *w);
    for (int i = 0; i < conns; i++) {
        w[i].fd = dial();
        w[i].dribble = i < dribblers;
        if (!w[i].dribble)
            w[i].lat_us = malloc(MAX_SAMPLES * sizeof *w[i].lat_us);
    }
    int64_t t0 = now_us();
    stop_at_us = t0 + (int64_t)(seconds * 1e6);
    for (int i = 0; i < conns; i++)
        pthread_create(&w[i].t, NULL, run, &w[i]);
    while (now_us() < stop_at_us)
        usleep(10000);
    atomic_store(&stop, 1);
    double elapsed = (double)(stop_at_us - t0) / 1e6;
    for (int i = 0; i < conns; i++) {
        /* A thread stuck in recv behind a stalled server is released by
         * closing its socket after its receive timeout at worst. */
        pthread_join(w[i].t, NULL);
        close(w[i].fd);
    }
    size_t total = 0;
    uint64_t errors = 0, frames = 0;
    for (int i = 0; i < conns; i++) {
        total += w[i].n;
        errors += w[i].errors;
        frames += w[i].frames;
    }
    uint32_t *all = malloc((total ? total : 1) * sizeof *all);
    size_t k = 0;
    for (int i = 0; i < conns; i++) {
        memcpy(all + k, w[i].lat_us, w[i].n * sizeof *all);
        k += w[i].n;
    }
    qsort(all, total, sizeof *all, cmp_u32);
    uint32_t p50 = total ? all[total / 2] : 0;
    uint32_t p99 = total ? all[(size_t)((double)total * 0.99)] : 0;
    uint32_t p999 = total ? all[(size_t)((double)total * 0.999)] : 0;
    uint32_t max = total ? all[total - 1] : 0;
    printf("requests=%zu rate=%.0f p50_us=%u p99_us=%u p999_us=%u max_us=%u errors=%llu "
           "dribbled_frames=%llu\n",
           total, (double)total / elapsed, p50, p99, p999, max, (unsigned long long)errors,
           (unsigned long long)frames);
    for (int i = 0; i < conns; i++)
        free(w[i].lat_us);
    free(w);
    free(all);
    return errors ? 1 : 0;
}
