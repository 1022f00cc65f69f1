/*
 * test_peers.c - the per-peer connection accounting behind
 * max-connections-per-peer (daemon/peers.c, linked as its object: the
 * Makefile gives this test build/daemon/peers.o): counts by peer, entries
 * that go when their count reaches zero, keys that collide in the hash
 * table, what counts as the same peer (an IPv4 host on either listener
 * family, a uid whatever its pid), and the peer of real sockets (a Unix
 * socket pair, loopback TCP over IPv4 and IPv6).  And the network rule
 * every budget that must not be split by choosing addresses counts by
 * (issue 22: Modbus's caps, the handshake budget) - all of loopback is
 * one network (127.0.0.0/8, ::1, and 127/8 IPv4-mapped), an IPv6 network
 * is its /64, an IPv4 address off loopback is a network of its own - the
 * names logs give them, a connection's key taken to its network, and the
 * default share (a quarter of the total, at least 1).  The oracle is the
 * rule written out by hand over literal addresses.
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
#include "peer_addr.h"

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

/* A qmcd-protocol connection's peer key, as qmcd_peer_key_of makes it. */
static qmcd_peer_key conn_key(const char *text)
{
    uint8_t b[4];
    return inet_pton(AF_INET, text, b) == 1 ? v4_key(text) : v6_key(text);
}

static void assert_same(const char *x, const char *y, int want)
{
    qmcd_ip a = peer_test_net(x), b = peer_test_net(y);
    if (qmcd_net_same(&a, &b) != want)
        fail_msg("%s and %s: same network %d, want %d", x, y, !want, want);
    /* A connection's key goes to the same network by the same rule. */
    qmcd_peer_key kx = conn_key(x), ky = conn_key(y), nx, ny;
    qmcd_peer_key_net(&kx, &nx);
    qmcd_peer_key_net(&ky, &ny);
    if ((memcmp(&nx, &ny, sizeof nx) == 0) != want)
        fail_msg("%s and %s as connection keys: same network %d, want %d", x, y, !want, want);
}

static void test_networks(void **state)
{
    (void)state;
    /* Loopback, whatever the address or the family, is one network. */
    assert_same("127.0.0.1", "127.0.0.2", 1);
    assert_same("127.255.3.4", "::1", 1);
    assert_same("::ffff:127.0.0.9", "127.0.0.1", 1);
    /* IPv6: the /64, and nothing past it. */
    assert_same("2001:db8:0:2::1", "2001:db8:0:2:ffff:ffff:ffff:ffff", 1);
    assert_same("2001:db8:0:2::1", "2001:db8:0:3::1", 0);
    assert_same("2001:db8::1", "::1", 0);
    /* IPv4 off loopback: each address; mapped or not is the same host. */
    assert_same("192.0.2.1", "192.0.2.2", 0);
    assert_same("192.0.2.1", "::ffff:192.0.2.1", 1);
    assert_same("192.0.2.1", "::ffff:c000:201", 1);
    /* The families never meet: ::c000:201 (not mapped) is IPv6, and
     * 2001:db8::/64 is not the IPv4 address of its first four bytes. */
    assert_same("192.0.2.1", "::c000:201", 0);
    assert_same("2001:db8::7", "32.1.13.184", 0);
    char name[64];
    qmcd_ip n = peer_test_net("127.0.0.5");
    qmcd_net_name(&n, name, sizeof name);
    assert_string_equal(name, "loopback");
    n = peer_test_net("2001:db8:0:2:1:2:3:4");
    qmcd_net_name(&n, name, sizeof name);
    assert_string_equal(name, "2001:db8:0:2::/64");
    n = peer_test_net("::ffff:192.0.2.7");
    qmcd_net_name(&n, name, sizeof name);
    assert_string_equal(name, "192.0.2.7");
}

static void test_key_names(void **state)
{
    (void)state;
    char name[64];
    const char *cases[][2] = {{"127.0.0.3", "loopback"}, {"::1", "loopback"},
                              {"2001:db8:0:2::9", "2001:db8:0:2::/64"},
                              {"192.0.2.7", "192.0.2.7"}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        qmcd_peer_key k = conn_key(cases[i][0]), nk;
        qmcd_peer_key_net(&k, &nk);
        assert_int_equal(nk.kind, QMCD_PEER_NET);
        qmcd_peer_key_name(&nk, name, sizeof name);
        assert_string_equal(name, cases[i][1]);
    }
    /* A uid is a peer of its own, network or not. */
    qmcd_peer_key u = uid_key(1000), un;
    qmcd_peer_key_net(&u, &un);
    assert_memory_equal(&u, &un, sizeof u);
    qmcd_peer_key_name(&un, name, sizeof name);
    assert_string_equal(name, "uid 1000");
    qmcd_peer_key ip = conn_key("192.0.2.7");
    qmcd_peer_key_name(&ip, name, sizeof name);
    assert_string_equal(name, "192.0.2.7");
}

static void test_share(void **state)
{
    (void)state;
    assert_int_equal(qmcd_peer_share(0, 256), 64);
    assert_int_equal(qmcd_peer_share(0, 1024), 256);
    assert_int_equal(qmcd_peer_share(0, 64), 16);
    assert_int_equal(qmcd_peer_share(0, 50), 12);
    assert_int_equal(qmcd_peer_share(0, 3), 1);
    assert_int_equal(qmcd_peer_share(0, 1), 1);
    assert_int_equal(qmcd_peer_share(7, 3), 7);
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
        cmocka_unit_test(test_networks),
        cmocka_unit_test(test_key_names),
        cmocka_unit_test(test_share),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
