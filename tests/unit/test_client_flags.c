/*
 * test_client_flags.c - libqmcclient decodes a result's flags as the
 * version HELLO_OK chose (PROTOCOL.md section 5).  A forked fake server
 * answers HELLO with version 2 or 3 and one INTEGRATE with a JOB_RESULT
 * that carries unresolved (bit 15), encoded for version 3 whatever it
 * negotiated, as a server that ignored the version would send it: after
 * version 2 the client must refuse the frame (bit 15 is undefined there),
 * after version 3 hand the flag back.  A result encoded for version 2 is
 * accepted, with error_unreliable in place of bit 15.
 *
 * The fake is a child process speaking the real codec over a Unix socket
 * in a fresh directory; it never asserts, and exits 0 only if the client
 * said what it should have.
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
#define RESULT_FLAGS (QMC_FLAG_UNRESOLVED | QMC_FLAG_ERROR_UNRELIABLE)

static int send_frame(int fd, const qmc_msg *m, unsigned version)
{
    uint8_t buf[4096];
    int n = qmc_proto_encode_version(m, version, buf, sizeof buf);
    return n > 0 && write(fd, buf, (size_t)n) == n ? 0 : -1;
}

/* The fake: HELLO -> HELLO_OK `version`, INTEGRATE -> JOB_ACCEPTED and a
 * JOB_RESULT encoded for `encode_for`. */
static int fake_server(int lfd, unsigned version, unsigned encode_for)
{
    int fd = accept(lfd, NULL, NULL);
    if (fd < 0)
        return 1;
    static uint8_t buf[1 << 16];
    qmc_msg m, r;
    if (fake_read_frame(fd, buf, sizeof buf, &m) || m.type != QMC_MSG_HELLO)
        return 2;
    r = fake_hello_ok(m.request_id, version, 1000);
    if (send_frame(fd, &r, version) || fake_read_frame(fd, buf, sizeof buf, &m) ||
        m.type != QMC_MSG_INTEGRATE)
        return 3;
    memset(&r, 0, sizeof r);
    r.type = QMC_MSG_JOB_ACCEPTED;
    r.request_id = m.request_id;
    r.u.job.job_id = 7;
    if (send_frame(fd, &r, version))
        return 4;
    memset(&r, 0, sizeof r);
    r.type = QMC_MSG_JOB_RESULT;
    r.request_id = m.request_id;
    r.u.result.job_id = 7;
    qmc_result_init(&r.u.result.res);
    r.u.result.res.error_kind = QMC_ERROR_ESTIMATE;
    r.u.result.res.flags = RESULT_FLAGS;
    r.u.result.res.dims = 2;
    r.u.result.method_used = QMC_METHOD_CLENSHAW_CURTIS;
    if (send_frame(fd, &r, encode_for))
        return 5;
    /* Until the client closes (after a refusal it closes at once). */
    while (read(fd, buf, sizeof buf) > 0)
        ;
    close(fd);
    return 0;
}

/* Runs one job against the fake; returns qmc_client_integrate's answer
 * and the flags it handed back. */
static int run(unsigned version, unsigned encode_for, uint32_t *flags, char *why, size_t bytes)
{
    fake_sock fs;
    fake_listen(&fs, "qmc-client-flags");
    pid_t child = fork();
    assert_true(child >= 0);
    if (child == 0) {
        alarm(60); /* never hang the suite on a client bug (a bound, not a wait) */
        _exit(fake_server(fs.lfd, version, encode_for));
    }
    close(fs.lfd);
    qmc_client *c = NULL;
    assert_int_equal(qmc_client_connect(fs.endpoint, TIMEOUT_MS, &c), 0);
    qmc_job_spec spec;
    qmc_job_spec_init(&spec);
    strcpy(spec.integrand, "genz-gaussian");
    spec.dims = 2;
    qmc_client_result *res = calloc(1, sizeof *res);
    assert_non_null(res);
    int rc = qmc_client_integrate(c, &spec, res);
    *flags = res->res.flags;
    snprintf(why, bytes, "%s", qmc_client_last_error(c));
    qmc_client_close(c);
    free(res);
    assert_int_equal(fake_wait(child), 0);
    fake_remove(&fs);
    return rc;
}

static void test_v2_refuses_bit15(void **state)
{
    (void)state;
    uint32_t flags;
    char why[256];
    assert_int_equal(run(2, 3, &flags, why, sizeof why), QMC_EPROTO);
    assert_int_equal(flags, 0);
    assert_non_null(strstr(why, "malformed frame"));
}

static void test_v2_accepts_v2_encoding(void **state)
{
    (void)state;
    uint32_t flags;
    char why[256];
    assert_int_equal(run(2, 2, &flags, why, sizeof why), 0);
    assert_int_equal(flags, QMC_FLAG_ERROR_UNRELIABLE);
}

static void test_v3_hands_back_bit15(void **state)
{
    (void)state;
    uint32_t flags;
    char why[256];
    assert_int_equal(run(3, 3, &flags, why, sizeof why), 0);
    assert_int_equal(flags, RESULT_FLAGS);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_v2_refuses_bit15),
        cmocka_unit_test(test_v2_accepts_v2_encoding),
        cmocka_unit_test(test_v3_hands_back_bit15),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
