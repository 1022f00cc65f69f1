/*
 * peer_addr.h - addresses from text for the unit tests of the network
 * rule (daemon/peers.c) and of its users (daemon/modbus_peer.c): the key
 * Modbus makes from an accepted socket, written out apart from the
 * daemon's code so that it can be its oracle.  It must not call the
 * daemon to make an address: only the rule under test is the daemon's.
 *
 * Static inline, so each test that includes it (after cmocka.h and
 * peers.h, or peers.c compiled in) needs nothing more linked.
 */
#ifndef QMC_TEST_PEER_ADDR_H
#define QMC_TEST_PEER_ADDR_H

#include <arpa/inet.h>
#include <netinet/in.h>
#include <stdint.h>
#include <string.h>

/* The address of text as Modbus keys an accepted socket: IPv4-mapped IPv6
 * addresses become IPv4.  Fails the test on text that is no address. */
static inline qmcd_ip peer_test_addr(const char *text)
{
    qmcd_ip a;
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

/* The network text's address belongs to, by the rule under test. */
static inline qmcd_ip peer_test_net(const char *text)
{
    qmcd_ip a = peer_test_addr(text), n;
    qmcd_net_of(&a, &n);
    return n;
}

#endif
