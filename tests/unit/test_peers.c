/*
 * test_peers.c - the per-peer connection accounting behind
 * max-connections-per-peer (daemon/peers.c, linked as its object: the
 * Makefile gives this test build/daemon/peers.o): counts by peer, entries
 * that go when their count reaches zero, keys that collide in the hash
 * table, what counts as the same peer (an IPv4 host on either listener
 * family, a uid whatever its pid), and the peer of real sockets (a Unix
 * socket pair, loopback TCP over IPv4 and IPv6).
 */
#define _GNU_SOURCE
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "peers.h"

static qmcd_peer_key uid_key(uint32_t uid)
{
    qmcd_peer_key k;
    memset(&k, 0, sizeof k);
    k.kind = QMCD_PEER_UID;
    memcpy(k.addr, &uid, sizeof uid);
    return k;
}

/* An IPv4 address as peers.c stores it: IPv4-mapped IPv6. */
static qmcd_peer_key v4_key(const char *text)
{
    qmcd_peer_key k;
    memset(&k, 0, sizeof k);
    k.kind = QMCD_PEER_IP;
    k.addr[10] = k.addr[11] = 0xff;
    assert_int_equal(inet_pton(AF_INET, text, k.addr + 12), 1);
    return k;
}

static qmcd_peer_key v6_key(const char *text)
{
    qmcd_peer_key k;
    memset(&k, 0, sizeof k);
    k.kind = QMCD_PEER_IP;
    assert_int_equal(inet_pton(AF_INET6, text, k.addr), 1);
    return k;
}

static void test_counts_by_peer(void **state)
{
    (void)state;
    qmcd_peers *p = NULL;
    assert_int_equal(qmcd_peers_new(&p), 0);
    qmcd_peer_key a = v4_key("127.0.0.2"), b = v4_key("127.0.0.3"), u = uid_key(1000);
    assert_int_equal(qmcd_peers_count(p, &a), 0);
    for (int i = 0; i < 3; i++)
        assert_int_equal(qmcd_peers_add(p, &a), 0);
    assert_int_equal(qmcd_peers_add(p, &u), 0);
    assert_int_equal(qmcd_peers_count(p, &a), 3);
    assert_int_equal(qmcd_peers_count(p, &b), 0);
    assert_int_equal(qmcd_peers_count(p, &u), 1);
    qmcd_peers_remove(p, &a);
    assert_int_equal(qmcd_peers_count(p, &a), 2);
    qmcd_peers_remove(p, &a);
    qmcd_peers_remove(p, &a);
    assert_int_equal(qmcd_peers_count(p, &a), 0);
    /* Gone at zero: one more remove is a no-op, not a wrap to 2^64 - 1. */
    qmcd_peers_remove(p, &a);
    assert_int_equal(qmcd_peers_count(p, &a), 0);
    qmcd_peers_remove(p, &b); /* never added */
    assert_int_equal(qmcd_peers_count(p, &u), 1);
    /* ... and it comes back from zero as a fresh entry. */
    assert_int_equal(qmcd_peers_add(p, &a), 0);
    assert_int_equal(qmcd_peers_count(p, &a), 1);
    qmcd_peers_free(p);
    qmcd_peers_free(NULL);
}

/* Far more peers than the table has buckets (1024): every chain holds
 * several, and removing some from the middle of a chain keeps the rest. */
static void test_many_peers_share_buckets(void **state)
{
    (void)state;
    enum { N = 5000 };
    qmcd_peers *p = NULL;
    assert_int_equal(qmcd_peers_new(&p), 0);
    for (uint32_t i = 0; i < N; i++) {
        qmcd_peer_key k = uid_key(i);
        for (uint32_t j = 0; j <= i % 3; j++)
            assert_int_equal(qmcd_peers_add(p, &k), 0);
    }
    for (uint32_t i = 0; i < N; i += 2) { /* every other peer goes */
        qmcd_peer_key k = uid_key(i);
        for (uint32_t j = 0; j <= i % 3; j++)
            qmcd_peers_remove(p, &k);
    }
    for (uint32_t i = 0; i < N; i++) {
        qmcd_peer_key k = uid_key(i);
        assert_int_equal(qmcd_peers_count(p, &k), i % 2 ? i % 3 + 1 : 0);
    }
    qmcd_peers_free(p); /* frees the rest (ASan: no leak) */
}

/* A uid and an address with the same bytes are different peers; IPv4 on
 * an IPv6 listener (::ffff:a.b.c.d) is the IPv4 peer; ::1 is not
 * 127.0.0.1. */
static void test_what_is_one_peer(void **state)
{
    (void)state;
    qmcd_peers *p = NULL;
    assert_int_equal(qmcd_peers_new(&p), 0);
    qmcd_peer_key u = uid_key(0x0100007f); /* the bytes of 127.0.0.1 */
    qmcd_peer_key ip;
    memset(&ip, 0, sizeof ip);
    ip.kind = QMCD_PEER_IP;
    memcpy(ip.addr, u.addr, sizeof u.addr);
    assert_int_equal(qmcd_peers_add(p, &u), 0);
    assert_int_equal(qmcd_peers_count(p, &ip), 0);
    qmcd_peer_key v4 = v4_key("127.0.0.1"), mapped = v6_key("::ffff:127.0.0.1");
    assert_int_equal(qmcd_peers_add(p, &v4), 0);
    assert_int_equal(qmcd_peers_count(p, &mapped), 1);
    qmcd_peer_key lo6 = v6_key("::1");
    assert_int_equal(qmcd_peers_count(p, &lo6), 0);
    qmcd_peers_free(p);
}

static void test_names(void **state)
{
    (void)state;
    char name[64];
    qmcd_peer_key k = uid_key(1000);
    qmcd_peer_key_name(&k, name, sizeof name);
    assert_string_equal(name, "uid 1000");
    k = v4_key("127.0.0.2");
    qmcd_peer_key_name(&k, name, sizeof name);
    assert_string_equal(name, "127.0.0.2"); /* not ::ffff:127.0.0.2 */
    k = v6_key("2001:db8::7");
    qmcd_peer_key_name(&k, name, sizeof name);
    assert_string_equal(name, "2001:db8::7");
    qmcd_peer_key_name(&k, name, 5); /* truncated, still terminated */
    assert_string_equal(name, "2001");
}

static void test_key_of_unix_socket(void **state)
{
    (void)state;
    int sv[2];
    assert_int_equal(socketpair(AF_UNIX, SOCK_STREAM, 0, sv), 0);
    qmcd_peer_key got, want = uid_key((uint32_t)getuid());
    assert_int_equal(qmcd_peer_key_of(sv[0], &got), 0);
    assert_memory_equal(&got, &want, sizeof got);
    close(sv[0]);
    close(sv[1]);
}

/* Accepts one loopback connection on a port the kernel picks; the
 * accepted socket's peer key goes to *key.  Returns 0, or -1 when the
 * family is not available here (no IPv6). */
static int loopback_peer(int family, qmcd_peer_key *key)
{
    struct sockaddr_storage ss;
    memset(&ss, 0, sizeof ss);
    socklen_t len;
    if (family == AF_INET) {
        struct sockaddr_in *s = (struct sockaddr_in *)&ss;
        s->sin_family = AF_INET;
        s->sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        len = sizeof *s;
    } else {
        struct sockaddr_in6 *s = (struct sockaddr_in6 *)&ss;
        s->sin6_family = AF_INET6;
        s->sin6_addr = in6addr_loopback;
        len = sizeof *s;
    }
    int l = socket(family, SOCK_STREAM, 0);
    if (l < 0)
        return -1;
    if (bind(l, (struct sockaddr *)&ss, len) != 0) {
        close(l);
        return -1;
    }
    assert_int_equal(listen(l, 1), 0);
    assert_int_equal(getsockname(l, (struct sockaddr *)&ss, &len), 0);
    int c = socket(family, SOCK_STREAM, 0);
    assert_true(c >= 0);
    assert_int_equal(connect(c, (struct sockaddr *)&ss, len), 0);
    int a = accept(l, NULL, NULL);
    assert_true(a >= 0);
    assert_int_equal(qmcd_peer_key_of(a, key), 0);
    close(a);
    close(c);
    close(l);
    return 0;
}

static void test_key_of_tcp(void **state)
{
    (void)state;
    qmcd_peer_key got, want = v4_key("127.0.0.1");
    assert_int_equal(loopback_peer(AF_INET, &got), 0);
    assert_memory_equal(&got, &want, sizeof got);
    if (loopback_peer(AF_INET6, &got) == 0) {
        want = v6_key("::1");
        assert_memory_equal(&got, &want, sizeof got);
    }
}

/* Not a socket, or one with no peer: the kernel cannot say who it is, and
 * the caller refuses the connection. */
static void test_key_of_fails(void **state)
{
    (void)state;
    int fds[2];
    assert_int_equal(pipe(fds), 0);
    qmcd_peer_key k;
    assert_int_equal(qmcd_peer_key_of(fds[0], &k), -ENOTSOCK);
    close(fds[0]);
    close(fds[1]);
    int s = socket(AF_INET, SOCK_STREAM, 0);
    assert_true(s >= 0);
    assert_int_equal(qmcd_peer_key_of(s, &k), -ENOTCONN);
    close(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_counts_by_peer),
        cmocka_unit_test(test_many_peers_share_buckets),
        cmocka_unit_test(test_what_is_one_peer),
        cmocka_unit_test(test_names),
        cmocka_unit_test(test_key_of_unix_socket),
        cmocka_unit_test(test_key_of_tcp),
        cmocka_unit_test(test_key_of_fails),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
