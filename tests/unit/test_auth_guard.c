/*
 * test_auth_guard.c - how fast a network's key proofs are checked
 * (daemon/auth_guard.c, issue 22 finding 3): no wait below
 * auth-max-failures, then 100 ms after the last wrong proof doubling per
 * failure up to auth-delay-max-ms; failures older than auth-lockout-ms
 * forgotten; networks apart; the held-proof count; and the fixed table,
 * which recycles the network whose wait is over and whose last failure is
 * oldest, never one still waiting while another is free to go.  The
 * oracle is the rule's numbers written out by hand; time is passed in.
 */
#define _GNU_SOURCE
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <stdlib.h>
#include <string.h>

#include "../../daemon/auth_guard.c"

static qmcd_config cfg_of(uint64_t max_failures, uint64_t delay_max_ms, uint64_t window_ms)
{
    qmcd_config c;
    memset(&c, 0, sizeof c);
    c.auth_max_failures = max_failures;
    c.auth_delay_max_ms = delay_max_ms;
    c.auth_lockout_ms = window_ms;
    return c;
}

static qmcd_peer_key net_n(uint32_t n)
{
    qmcd_peer_key k;
    memset(&k, 0, sizeof k);
    k.kind = QMCD_PEER_NET;
    memcpy(k.addr, &n, sizeof n);
    k.addr[15] = 2; /* AF_INET */
    return k;
}

static void test_delay_curve(void **state)
{
    (void)state;
    qmcd_config c = cfg_of(5, 2000, 60000);
    const int64_t want[] = {0, 0, 0, 0, 0, 100, 200, 400, 800, 1600, 2000, 2000};
    for (uint64_t k = 0; k < sizeof want / sizeof want[0]; k++)
        assert_int_equal(qmcd_auth_guard_delay_ms(k, &c), want[k]);
    assert_int_equal(qmcd_auth_guard_delay_ms(1000000, &c), 2000); /* no overflow */
    c = cfg_of(1, 150, 60000);
    assert_int_equal(qmcd_auth_guard_delay_ms(1, &c), 100);
    assert_int_equal(qmcd_auth_guard_delay_ms(2, &c), 150);
    c = cfg_of(1, 0, 60000); /* auth-delay-max-ms 0: never wait */
    assert_int_equal(qmcd_auth_guard_delay_ms(9, &c), 0);
    c = cfg_of(1, 50, 60000); /* a maximum below the first step */
    assert_int_equal(qmcd_auth_guard_delay_ms(1, &c), 50);
}

static void test_open_and_window(void **state)
{
    (void)state;
    qmcd_config c = cfg_of(3, 2000, 10000);
    qmcd_auth_guard *g = calloc(1, sizeof *g);
    assert_non_null(g);
    qmcd_peer_key a = net_n(1), b = net_n(2);
    int64_t d;
    assert_int_equal(qmcd_auth_guard_open_ms(g, &a, &c, 1000), 1000);
    assert_int_equal(qmcd_auth_guard_failed(g, &a, &c, 1000, &d), 1);
    assert_int_equal(d, 0);
    assert_int_equal(qmcd_auth_guard_failed(g, &a, &c, 1010, &d), 2);
    assert_int_equal(qmcd_auth_guard_open_ms(g, &a, &c, 1011), 1011);
    assert_int_equal(qmcd_auth_guard_failed(g, &a, &c, 1020, &d), 3);
    assert_int_equal(d, 100);
    /* Waits until 100 ms after its last failure; b is not affected. */
    assert_int_equal(qmcd_auth_guard_open_ms(g, &a, &c, 1050), 1120);
    assert_int_equal(qmcd_auth_guard_open_ms(g, &a, &c, 1120), 1120);
    assert_int_equal(qmcd_auth_guard_open_ms(g, &a, &c, 1500), 1500);
    assert_int_equal(qmcd_auth_guard_open_ms(g, &b, &c, 1050), 1050);
    assert_int_equal(qmcd_auth_guard_failed(g, &a, &c, 1200, &d), 4);
    assert_int_equal(d, 200);
    assert_int_equal(qmcd_auth_guard_open_ms(g, &a, &c, 1201), 1400);
    /* Held proofs are counted since the last failure. */
    assert_int_equal(qmcd_auth_guard_held(g, &a), 1);
    assert_int_equal(qmcd_auth_guard_held(g, &a), 2);
    assert_int_equal(qmcd_auth_guard_held(g, &b), 0); /* no entry: never held */
    /* A failure more than the window after the last starts over. */
    assert_int_equal(qmcd_auth_guard_failed(g, &a, &c, 1200 + 10001, &d), 1);
    assert_int_equal(d, 0);
    assert_int_equal(qmcd_auth_guard_held(g, &a), 1);
    /* A long-past failure no longer delays anything. */
    for (int i = 0; i < 5; i++)
        (void)qmcd_auth_guard_failed(g, &b, &c, 50000, &d);
    assert_int_equal(qmcd_auth_guard_open_ms(g, &b, &c, 50001), 50000 + 400);
    assert_int_equal(qmcd_auth_guard_open_ms(g, &b, &c, 50000 + 10001), 60001);
    free(g);
}

static void test_table_recycles(void **state)
{
    (void)state;
    qmcd_config c = cfg_of(1, 60000, 3600000);
    qmcd_auth_guard *g = calloc(1, sizeof *g);
    assert_non_null(g);
    int64_t d;
    /* Network 0: ten failures at time 0, so it waits until 51200.  The
     * others one each at time i: each waits until i + 100. */
    for (int i = 0; i < 10; i++) {
        qmcd_peer_key k0 = net_n(0);
        (void)qmcd_auth_guard_failed(g, &k0, &c, 0, &d);
    }
    for (uint32_t i = 1; i < QMCD_AUTH_GUARD_NETS; i++) {
        qmcd_peer_key k = net_n(i);
        (void)qmcd_auth_guard_failed(g, &k, &c, (int64_t)i, &d);
    }
    qmcd_peer_key k0 = net_n(0), k1 = net_n(1), k2 = net_n(2), fresh = net_n(1000);
    assert_int_equal(qmcd_auth_guard_open_ms(g, &k0, &c, 150), 51200);
    /* The table is full: a new network at 150 takes network 1's slot
     * (its wait ended at 101; network 0, older, still waits). */
    assert_int_equal(qmcd_auth_guard_failed(g, &fresh, &c, 150, &d), 1);
    assert_int_equal(qmcd_auth_guard_open_ms(g, &k0, &c, 150), 51200);
    assert_int_equal(qmcd_auth_guard_open_ms(g, &k1, &c, 150), 150);
    assert_int_equal(qmcd_auth_guard_open_ms(g, &k2, &c, 101), 102);
    assert_int_equal(qmcd_auth_guard_open_ms(g, &fresh, &c, 151), 250);
    free(g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_delay_curve),
        cmocka_unit_test(test_open_and_window),
        cmocka_unit_test(test_table_recycles),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
