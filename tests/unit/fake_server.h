/*
 * fake_server.h - a forked fake qmcd for the client library's unit tests
 * (test_client_flags.c, test_client_pixels.c): a listening Unix socket in
 * a fresh temporary directory, frames read with the real codec, the
 * HELLO_OK a fake answers with, and the child's exit status.  Each test's
 * fake says its own script.  Included after cmocka.h; static inline, so
 * the Makefile's UNIT_HELPER wildcard (every .c in tests/unit/ but the
 * tests) does not link it into every other unit test.
 */
#ifndef QMC_TEST_FAKE_SERVER_H
#define QMC_TEST_FAKE_SERVER_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include "qmc/proto.h"

typedef struct fake_sock {
    char dir[80];                 /* the temporary directory */
    struct sockaddr_un sa;        /* its socket, dir/s.sock */
    int lfd;                      /* listening, backlog 1 */
    char endpoint[sizeof(((struct sockaddr_un *)0)->sun_path) + 8]; /* "unix:..." */
} fake_sock;

/* A fresh $TMPDIR/NAME.XXXXXX with a listening socket in it. */
static inline void fake_listen(fake_sock *s, const char *name)
{
    const char *tmpdir = getenv("TMPDIR");
    int w = snprintf(s->dir, sizeof s->dir, "%s/%s.XXXXXX", tmpdir ? tmpdir : "/tmp", name);
    assert_true(w > 0 && (size_t)w < sizeof s->dir);
    assert_non_null(mkdtemp(s->dir));
    memset(&s->sa, 0, sizeof s->sa);
    s->sa.sun_family = AF_UNIX;
    assert_true(strlen(s->dir) + sizeof "/s.sock" <= sizeof s->sa.sun_path);
    memcpy(s->sa.sun_path, s->dir, strlen(s->dir));
    memcpy(s->sa.sun_path + strlen(s->dir), "/s.sock", sizeof "/s.sock");
    s->lfd = socket(AF_UNIX, SOCK_STREAM, 0);
    assert_true(s->lfd >= 0);
    assert_int_equal(bind(s->lfd, (struct sockaddr *)&s->sa, sizeof s->sa), 0);
    assert_int_equal(listen(s->lfd, 1), 0);
    snprintf(s->endpoint, sizeof s->endpoint, "unix:%s", s->sa.sun_path);
}

/* Removes the socket and its directory (the fake is gone). */
static inline void fake_remove(const fake_sock *s)
{
    unlink(s->sa.sun_path);
    rmdir(s->dir);
}

/* One frame from fd into buf (a client frame is small); 0 or -1. */
static inline int fake_read_frame(int fd, uint8_t *buf, size_t cap, qmc_msg *m)
{
    size_t len = 0;
    for (;;) {
        int n = qmc_proto_decode(buf, len, (uint32_t)cap, m);
        if (n > 0)
            return 0;
        if (n != QMC_EAGAIN || len == cap)
            return -1;
        ssize_t got = read(fd, buf + len, cap - len);
        if (got <= 0)
            return -1;
        len += (size_t)got;
    }
}

/* The fake's HELLO_OK to the HELLO request_id: protocol `version`,
 * max_points, a 1 MiB max_frame and 4 in flight, named fake-qmcd. */
static inline qmc_msg fake_hello_ok(uint64_t request_id, unsigned version, uint64_t max_points)
{
    qmc_msg r;
    memset(&r, 0, sizeof r);
    r.type = QMC_MSG_HELLO_OK;
    r.request_id = request_id;
    r.u.hello_ok.version = (uint16_t)version;
    r.u.hello_ok.max_frame = 1u << 20;
    r.u.hello_ok.max_inflight = 4;
    r.u.hello_ok.max_points = max_points;
    r.u.hello_ok.server = (qmc_str){"fake-qmcd", 9};
    r.u.hello_ok.engine = (qmc_str){"test 1.0", 8};
    return r;
}

/* Waits for the fake and returns its exit status (it must have exited). */
static inline int fake_wait(pid_t child)
{
    int status = 0;
    assert_int_equal(waitpid(child, &status, 0), child);
    assert_true(WIFEXITED(status));
    return WEXITSTATUS(status);
}

#endif
