/*
 * test_modbus_peer.c - who a Modbus TCP client is for its share of the
 * server (daemon/modbus_peer.c): all of loopback is one peer (127.0.0.0/8,
 * ::1, and 127/8 IPv4-mapped), an IPv6 peer is its /64, an IPv4 address
 * off loopback is a peer of its own; the names logs give them; the default
 * share (a quarter of the total, at least 1); and the connection counts
 * per peer, which follow the open connections.
 *
 * The daemon's objects are not in a library, so the files are compiled in.
 */
#define _GNU_SOURCE
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <string.h>

#include "../../daemon/modbus_peer.c"
#include "../../daemon/peers.c"

/* The peer key of a textual address, as modbus_sessions.c makes it from
 * an accepted socket: IPv4-mapped addresses become IPv4. */
static qmcd_mb_peer addr_of(const char *text)
{
    qmcd_mb_peer a;
    memset(&a, 0, sizeof a);
    uint8_t b[16];
    if (inet_pton(AF_INET, text, b) == 1) {
        a.family = AF_INET;
        memcpy(a.addr, b, 4);
    } else {
        assert_int_equal(inet_pton(AF_INET6, text, b), 1);
        static const uint8_t mapped[12] = {[10] = 0xff, [11] = 0xff};
        if (memcmp(b, mapped, 12) == 0) {
            a.family = AF_INET;
            memcpy(a.addr, b + 12, 4);
        } else {
            a.family = AF_INET6;
            memcpy(a.addr, b, 16);
        }
    }
    return a;
}

static qmcd_mb_peer net(const char *text)
{
    qmcd_mb_peer a = addr_of(text), n;
    qmcd__modbus_net_of(&a, &n);
    return n;
}

static void assert_same(const char *x, const char *y, int want)
{
    qmcd_mb_peer a = net(x), b = net(y);
    if (qmcd__modbus_net_same(&a, &b) != want)
        fail_msg("%s and %s: same peer %d, want %d", x, y, !want, want);
}

static void test_peers(void **state)
{
    (void)state;
    /* Loopback, whatever the address or the family, is one peer. */
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
    /* The families never meet: ::c000:201 (not mapped) is IPv6. */
    assert_same("192.0.2.1", "::c000:201", 0);
    char name[64];
    qmcd_mb_peer n = net("127.0.0.5");
    qmcd__modbus_net_name(&n, name, sizeof name);
    assert_string_equal(name, "loopback");
    n = net("2001:db8:0:2:1:2:3:4");
    qmcd__modbus_net_name(&n, name, sizeof name);
    assert_string_equal(name, "2001:db8:0:2::/64");
    n = net("::ffff:192.0.2.7");
    qmcd__modbus_net_name(&n, name, sizeof name);
    assert_string_equal(name, "192.0.2.7");
}

static void test_share(void **state)
{
    (void)state;
    assert_int_equal(qmcd__modbus_share(0, 256), 64);
    assert_int_equal(qmcd__modbus_share(0, 1024), 256);
    assert_int_equal(qmcd__modbus_share(0, 50), 12);
    assert_int_equal(qmcd__modbus_share(0, 3), 1);
    assert_int_equal(qmcd__modbus_share(0, 1), 1);
    assert_int_equal(qmcd__modbus_share(7, 3), 7);
}

static void test_counts(void **state)
{
    (void)state;
    qmcd_modbus mb;
    memset(&mb, 0, sizeof mb);
    assert_int_equal(qmcd_peers_new(&mb.net_conns), 0);
    qmcd_mb_peer lo1 = net("127.0.0.2"), lo2 = net("::1"), v6 = net("2001:db8::7"),
                 v4 = net("192.0.2.7");
    assert_int_equal(qmcd__modbus_net_conn_add(&mb, &lo1), 0);
    assert_int_equal(qmcd__modbus_net_conn_add(&mb, &lo2), 0);
    assert_int_equal(qmcd__modbus_net_conn_add(&mb, &v6), 0);
    assert_int_equal(qmcd__modbus_net_conns(&mb, &lo1), 2);
    assert_int_equal(qmcd__modbus_net_conns(&mb, &v6), 1);
    assert_int_equal(qmcd__modbus_net_conns(&mb, &v4), 0);
    /* 2001:db8::/64 and the IPv4 address 32.1.13.184 (its first four
     * bytes) are different peers. */
    qmcd_mb_peer look = net("32.1.13.184");
    assert_int_equal(qmcd__modbus_net_conns(&mb, &look), 0);
    qmcd__modbus_net_conn_remove(&mb, &lo2);
    qmcd__modbus_net_conn_remove(&mb, &lo1);
    qmcd__modbus_net_conn_remove(&mb, &v6);
    assert_int_equal(qmcd__modbus_net_conns(&mb, &lo1), 0);
    assert_int_equal(qmcd__modbus_net_conns(&mb, &v6), 0);
    qmcd_peers_free(mb.net_conns);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_peers),
        cmocka_unit_test(test_share),
        cmocka_unit_test(test_counts),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
