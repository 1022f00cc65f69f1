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
#include "peer_addr.h"

static void test_counts(void **state)
{
    (void)state;
    qmcd_modbus mb;
    memset(&mb, 0, sizeof mb);
    assert_int_equal(qmcd_peers_new(&mb.net_conns), 0);
    qmcd_mb_peer lo1 = peer_test_net("127.0.0.2"), lo2 = peer_test_net("::1"),
                 v6 = peer_test_net("2001:db8::7"), v4 = peer_test_net("192.0.2.7");
    assert_int_equal(qmcd__modbus_net_conn_add(&mb, &lo1), 0);
    assert_int_equal(qmcd__modbus_net_conn_add(&mb, &lo2), 0);
    assert_int_equal(qmcd__modbus_net_conn_add(&mb, &v6), 0);
    assert_int_equal(qmcd__modbus_net_conns(&mb, &lo1), 2);
    assert_int_equal(qmcd__modbus_net_conns(&mb, &v6), 1);
    assert_int_equal(qmcd__modbus_net_conns(&mb, &v4), 0);
    /* 2001:db8::/64 and the IPv4 address 32.1.13.184 (its first four
     * bytes) are different peers. */
    qmcd_mb_peer look = peer_test_net("32.1.13.184");
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
