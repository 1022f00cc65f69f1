/*
 * test_client_pixels.c - libqmcclient's PIXELS calls against a forked
 * fake server that speaks the real codec: a tile larger than the server's
 * max_points is asked for in pieces whose outputs, in order, are the
 * whole tile's output (for limits from 1 sample to the whole tile, the
 * pieces are checked to lie inside the tile and to follow each other);
 * the chunks land where qmc_pixels_fill would write them; a server ERROR
 * comes back with its code and text; a server that chose protocol
 * version 3 is never sent a PIXELS nor a fast-owen POINTS (QMC_ENOTSUP, the
 * connection usable).
 *
 * The fake answers a piece with values that name their place, v = x <<
 * 20 | y << 12 | sample << 4 | dim, so the test's oracle is that formula
 * over the tile in row order, written here apart from the client's code.
 * The fake never asserts; it exits 0 only if every request was as it
 * should be.
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "fake_server.h"
#include "qmc/client.h"
#include "qmc/proto.h"

#define TIMEOUT_MS 5000
/* The fake cuts each answer into chunks of at most this many samples. */
#define CHUNK_SAMPLES 4u

static const qmc_pixel_tile TILE = {.x = 2, .y = 1, .width = 5, .height = 3,
                                    .sample_start = 3, .sample_count = 7};
#define DIMS 2u
#define TILE_SAMPLES (5u * 3u * 7u)

static uint32_t value_at(uint32_t x, uint32_t y, uint64_t s, uint32_t d)
{
    return x << 20 | y << 12 | (uint32_t)s << 4 | d;
}

static int send_frame(int fd, const qmc_msg *m)
{
    static uint8_t buf[1 << 16];
    int n = qmc_proto_encode(m, buf, sizeof buf);
    return n > 0 && write(fd, buf, (size_t)n) == n ? 0 : -1;
}

/* Answers one PIXELS piece: chunks of the formula's values, then END.
 * `next` is where the piece must start in the whole tile's output.
 * Returns 0, or a code for the exit status. */
static int answer_piece(int fd, const qmc_msg *m, uint64_t *next)
{
    const qmc_msg_pixels *p = &m->u.pixels;
    const qmc_pixel_tile *t = &p->tile;
    if (p->spec.sampler != QMC_PIXEL_ZSOBOL || p->spec.width != 64 || p->spec.height != 32 ||
        p->spec.spp != 16 || p->spec.dims != DIMS || p->format != QMC_FORMAT_U32 ||
        p->transport != QMC_TRANSPORT_INLINE)
        return 10;
    /* Inside the tile, not empty, and starting where the last one ended. */
    if (t->width == 0 || t->height == 0 || t->sample_count == 0 || t->x < TILE.x ||
        t->y < TILE.y || t->x + t->width > TILE.x + TILE.width ||
        t->y + t->height > TILE.y + TILE.height || t->sample_start < TILE.sample_start ||
        t->sample_start + t->sample_count > TILE.sample_start + TILE.sample_count)
        return 11;
    const uint64_t at = (((uint64_t)(t->y - TILE.y) * TILE.width + (t->x - TILE.x)) *
                         TILE.sample_count) + (t->sample_start - TILE.sample_start);
    if (at != *next)
        return 12;
    /* Its output is contiguous in the tile's: a piece of several rows or
     * pixels takes whole ones. */
    if ((t->height > 1 && t->width != TILE.width) ||
        ((t->width > 1 || t->height > 1) && t->sample_count != TILE.sample_count))
        return 13;
    const uint64_t samples = (uint64_t)t->width * t->height * t->sample_count;
    static uint8_t data[CHUNK_SAMPLES * DIMS * 4];
    uint64_t k = 0;
    while (k < samples) {
        uint32_t n = samples - k < CHUNK_SAMPLES ? (uint32_t)(samples - k) : CHUNK_SAMPLES;
        for (uint32_t i = 0; i < n; i++) {
            uint64_t pixel = (k + i) / t->sample_count, s = (k + i) % t->sample_count;
            uint32_t x = t->x + (uint32_t)(pixel % t->width);
            uint32_t y = t->y + (uint32_t)(pixel / t->width);
            for (uint32_t d = 0; d < DIMS; d++) {
                uint32_t v = value_at(x, y, t->sample_start + s, d);
                for (int b = 0; b < 4; b++)
                    data[(i * DIMS + d) * 4 + (uint32_t)b] = (uint8_t)(v >> (8 * b));
            }
        }
        qmc_msg c = {.type = QMC_MSG_POINTS_CHUNK, .request_id = m->request_id};
        c.u.chunk.first = k;
        c.u.chunk.points = n;
        c.u.chunk.data = data;
        c.u.chunk.data_len = n * DIMS * 4;
        if (send_frame(fd, &c))
            return 14;
        k += n;
    }
    qmc_msg e = {.type = QMC_MSG_END, .request_id = m->request_id};
    e.u.end.points = samples;
    e.u.end.bytes = samples * DIMS * 4;
    if (send_frame(fd, &e))
        return 15;
    *next = at + samples;
    return 0;
}

/* The fake: HELLO_OK with `version` and `max_points`; then PIXELS pieces
 * until the whole tile is served, then one PIXELS answered with ERROR,
 * then (any version) a PING answered with PONG; then EOF. */
static int fake_server(int lfd, unsigned version, uint64_t max_points, unsigned *pieces)
{
    int fd = accept(lfd, NULL, NULL);
    if (fd < 0)
        return 1;
    static uint8_t buf[1 << 16];
    qmc_msg m;
    if (fake_read_frame(fd, buf, sizeof buf, &m) || m.type != QMC_MSG_HELLO ||
        m.u.hello.version_max != QMC_PROTO_VERSION_MAX)
        return 2;
    qmc_msg r = fake_hello_ok(m.request_id, version, max_points);
    if (send_frame(fd, &r))
        return 3;
    uint64_t next = 0;
    *pieces = 0;
    while (version >= QMC_PROTO_VERSION_PIXELS && next < TILE_SAMPLES) {
        if (fake_read_frame(fd, buf, sizeof buf, &m) || m.type != QMC_MSG_PIXELS)
            return 4;
        int rc = answer_piece(fd, &m, &next);
        if (rc)
            return rc;
        if (max_points && m.u.pixels.tile.width * (uint64_t)m.u.pixels.tile.height *
                                  m.u.pixels.tile.sample_count > max_points)
            return 5;
        ++*pieces;
    }
    if (version >= QMC_PROTO_VERSION_PIXELS) {
        if (fake_read_frame(fd, buf, sizeof buf, &m) || m.type != QMC_MSG_PIXELS)
            return 6;
        static const char why[] = "tile 60,0,8,8 lies outside the 64 x 32 image";
        qmc_msg e = {.type = QMC_MSG_ERROR, .request_id = m.request_id};
        e.u.error.code = QMC_ERANGE;
        e.u.error.message = (qmc_str){why, sizeof why - 1};
        if (send_frame(fd, &e))
            return 7;
    }
    if (fake_read_frame(fd, buf, sizeof buf, &m) || m.type != QMC_MSG_PING)
        return 8;
    m.type = QMC_MSG_PONG;
    if (send_frame(fd, &m))
        return 9;
    while (read(fd, buf, sizeof buf) > 0)
        ;
    close(fd);
    return 0;
}

/* Runs the fake's script against the client; returns how many pieces the
 * tile took (the fake's exit status must be 0). */
static unsigned run(unsigned version, uint64_t max_points)
{
    fake_sock fs;
    fake_listen(&fs, "qmc-client-pixels");
    int pipefd[2];
    assert_int_equal(pipe(pipefd), 0);
    pid_t child = fork();
    assert_true(child >= 0);
    if (child == 0) {
        alarm(60); /* never hang the suite on a client bug (a bound, not a wait) */
        unsigned pieces = 0;
        int rc = fake_server(fs.lfd, version, max_points, &pieces);
        if (write(pipefd[1], &pieces, sizeof pieces) != sizeof pieces)
            rc = 99;
        _exit(rc);
    }
    close(fs.lfd);
    close(pipefd[1]);
    qmc_client *c = NULL;
    assert_int_equal(qmc_client_connect(fs.endpoint, TIMEOUT_MS, &c), 0);
    qmc_pixel_spec spec = {.sampler = QMC_PIXEL_ZSOBOL, .width = 64, .height = 32,
                           .spp = 16, .dims = DIMS};
    static uint32_t out[TILE_SAMPLES * DIMS];
    if (version < QMC_PROTO_VERSION_PIXELS) {
        assert_int_equal(qmc_client_pixels(c, &spec, &TILE, QMC_FORMAT_U32, out, sizeof out),
                         QMC_ENOTSUP);
        assert_non_null(strstr(qmc_client_last_error(c), "PIXELS needs 4"));
        /* fast-owen came with version 4 too: refused before it is sent,
         * which would make an older server hang up (the PING below). */
        const qmc_seq_spec fast_owen = {.kind = QMC_SEQ_SOBOL, .dims = 2,
                                        .scramble = QMC_SCRAMBLE_FAST_OWEN, .seed = 7};
        double pts[4];
        assert_int_equal(qmc_client_points(c, &fast_owen, 0, 2, QMC_FORMAT_F64, pts,
                                           sizeof pts), QMC_ENOTSUP);
        assert_non_null(strstr(qmc_client_last_error(c), "needs protocol version 4"));
    } else {
        /* Too small a buffer: refused before anything is sent. */
        assert_int_equal(qmc_client_pixels(c, &spec, &TILE, QMC_FORMAT_U32, out,
                                           sizeof out - 1), QMC_EINVAL);
        memset(out, 0xff, sizeof out);
        assert_int_equal(qmc_client_pixels(c, &spec, &TILE, QMC_FORMAT_U32, out, sizeof out),
                         0);
        size_t i = 0;
        for (uint32_t y = TILE.y; y < TILE.y + TILE.height; y++)
            for (uint32_t x = TILE.x; x < TILE.x + TILE.width; x++)
                for (uint64_t s = TILE.sample_start; s < TILE.sample_start + TILE.sample_count;
                     s++)
                    for (uint32_t d = 0; d < DIMS; d++, i++)
                        if (out[i] != value_at(x, y, s, d))
                            fail_msg("max_points %llu: value %zu is %#x, want %#x",
                                     (unsigned long long)max_points, i, out[i],
                                     value_at(x, y, s, d));
        const qmc_pixel_tile outside = {.x = 60, .y = 0, .width = 8, .height = 8,
                                        .sample_count = 1};
        assert_int_equal(qmc_client_pixels(c, &spec, &outside, QMC_FORMAT_U32, out,
                                           sizeof out), QMC_ERANGE);
        assert_string_equal(qmc_client_last_error(c),
                            "tile 60,0,8,8 lies outside the 64 x 32 image");
    }
    double rtt;
    assert_int_equal(qmc_client_ping(c, &rtt), 0); /* still usable */
    qmc_client_close(c);
    unsigned pieces = 0;
    assert_int_equal(read(pipefd[0], &pieces, sizeof pieces), (ssize_t)sizeof pieces);
    close(pipefd[0]);
    const int status = fake_wait(child);
    if (status != 0)
        fail_msg("max_points %llu: the fake server failed with %d",
                 (unsigned long long)max_points, status);
    fake_remove(&fs);
    return pieces;
}

static void test_split_by_max_points(void **state)
{
    (void)state;
    /* A row is 35 samples, a pixel 7, the tile 105.  The piece counts are
     * those of whole rows, else whole pixels, else runs of samples. */
    static const struct {
        uint64_t max;
        unsigned pieces;
    } cases[] = {
        {105, 1}, {1000, 1}, {0, 1},     /* 0: the server names no limit */
        {70, 2}, {35, 3}, {34, 6},       /* 4 + 1 pixels a row, 3 rows */
        {14, 9}, {7, 15}, {6, 30}, {3, 45}, {1, 105},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        unsigned got = run(QMC_PROTO_VERSION_PIXELS, cases[i].max);
        if (got != cases[i].pieces)
            fail_msg("max_points %llu: %u pieces, want %u", (unsigned long long)cases[i].max,
                     got, cases[i].pieces);
    }
}

static void test_older_server(void **state)
{
    (void)state;
    assert_int_equal(run(QMC_PROTO_VERSION_PIXELS - 1, 1000), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_split_by_max_points),
        cmocka_unit_test(test_older_server),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
