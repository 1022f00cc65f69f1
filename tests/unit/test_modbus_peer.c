/*
 * test_modbus_peer.c - the connection counts per Modbus TCP peer
 * (daemon/modbus_peer.c), which follow the open connections; a peer is a
 * network by peers.c's rule (tests/unit/test_peers.c tests the rule).
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
    qmcd_net_of(&a, &n);
    return n;
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
        cmocka_unit_test(test_counts),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
