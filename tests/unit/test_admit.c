/*
 * test_admit.c - the connection budgets (daemon/admit.c, issue 22 finding
 * 1): a TCP connection counts in the handshake budget until HELLO_OK and
 * only then in max-connections; a newcomer whose network holds its share
 * names that network's oldest handshake to give way, one that finds the
 * budget full the oldest of the networks holding the most; a Unix-socket
 * connection counts in max-connections from its accept and is refused
 * there; at HELLO_OK max-connections and max-connections-per-peer hold;
 * refusing and closing give every place back.  The connections are bare
 * structs (admit.c reads nothing else of them); the oracle is the rule's
 * outcome worked out by hand for each step.
 */
#define _GNU_SOURCE
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <arpa/inet.h>
#include <string.h>

#include "../../daemon/admit.c"
#include "../../daemon/peers.c"

static qmcd_server srv;
static qmcd_conn conns[16];
static unsigned n_conns_made;

static void setup_server(void)
{
    memset(&srv, 0, sizeof srv);
    memset(conns, 0, sizeof conns);
    n_conns_made = 0;
    srv.cfg.max_connections = 3;
    srv.cfg.max_connections_per_peer = 2;
    srv.cfg.max_preauth_connections = 5;
    srv.cfg.max_preauth_connections_per_peer = 2;
    assert_int_equal(qmcd_peers_new(&srv.peers), 0);
    assert_int_equal(qmcd_peers_new(&srv.preauth_nets), 0);
}

static void teardown_server(void)
{
    qmcd_peers_free(srv.peers);
    qmcd_peers_free(srv.preauth_nets);
}

/* A connection from an address ("uid N" for a Unix socket), counted
 * nowhere yet. */
static qmcd_conn *conn_from(const char *who)
{
    qmcd_conn *c = &conns[n_conns_made++];
    c->srv = &srv;
    c->peer_key.kind = QMCD_PEER_IP;
    uint32_t uid;
    if (sscanf(who, "uid %u", &uid) == 1) {
        c->unix_socket = 1;
        c->peer_key.kind = QMCD_PEER_UID;
        memcpy(c->peer_key.addr, &uid, sizeof uid);
    } else if (inet_pton(AF_INET, who, c->peer_key.addr + 12) == 1) {
        c->peer_key.addr[10] = c->peer_key.addr[11] = 0xff;
    } else {
        assert_int_equal(inet_pton(AF_INET6, who, c->peer_key.addr), 1);
    }
    qmcd_peer_key_net(&c->peer_key, &c->net_key);
    return c;
}

/* A TCP newcomer as conn_accept.c admits it: the victim admit.c names
 * (returned) is refused first, then the newcomer is counted. */
static qmcd_conn *arrive(const char *who, char *why, size_t n)
{
    qmcd_conn *c = conn_from(who);
    why[0] = '\0';
    qmcd_conn *v = qmcd_admit_victim(c, why, n);
    if (v)
        qmcd_admit_refuse(v);
    assert_int_equal(qmcd_admit_take(c), 0);
    assert_int_equal(c->admit, QMCD_ADMIT_PREAUTH);
    return v;
}

/* The handshake list agrees with the count, oldest first. */
static void assert_list(unsigned n, qmcd_conn *const *want)
{
    assert_int_equal(srv.n_preauth, n);
    qmcd_conn *c = srv.preauth_head;
    for (unsigned i = 0; i < n; i++, c = c->pa_next)
        assert_ptr_equal(c, want[i]);
    assert_null(c);
}

static void test_handshake_budget(void **state)
{
    (void)state;
    setup_server();
    char why[240];
    /* Loopback is one network: its share is 2. */
    assert_null(arrive("127.0.0.2", why, sizeof why));
    assert_null(arrive("127.0.0.3", why, sizeof why));
    qmcd_conn *lo1 = &conns[0], *lo2 = &conns[1];
    qmcd_conn *v = arrive("::1", why, sizeof why);
    qmcd_conn *lo3 = &conns[2];
    assert_ptr_equal(v, lo1);
    assert_non_null(strstr(why, "max-preauth-connections-per-peer (2) reached for loopback"));
    assert_int_equal(lo1->admit, QMCD_ADMIT_REFUSED);
    assert_int_equal(srv.n_refusing, 1);
    assert_list(2, (qmcd_conn *[]){lo2, lo3});
    /* 192.0.2.3 and 192.0.2.4 are networks of their own. */
    assert_null(arrive("192.0.2.3", why, sizeof why));
    assert_null(arrive("192.0.2.3", why, sizeof why));
    assert_null(arrive("192.0.2.4", why, sizeof why));
    qmcd_conn *b1 = &conns[3], *b2 = &conns[4], *c1 = &conns[5];
    assert_list(5, (qmcd_conn *[]){lo2, lo3, b1, b2, c1});
    /* Full (5): a fresh /64 takes the place of the oldest handshake of
     * the networks holding the most (loopback's and 192.0.2.3's two):
     * loopback's lo2. */
    v = arrive("2001:db8::1", why, sizeof why);
    qmcd_conn *d1 = &conns[6];
    assert_ptr_equal(v, lo2);
    assert_non_null(strstr(why, "max-preauth-connections (5) reached"));
    assert_non_null(strstr(why, "oldest of loopback"));
    assert_list(5, (qmcd_conn *[]){lo3, b1, b2, c1, d1});
    /* Now 192.0.2.3 alone holds the most: the next fresh network takes
     * b1's place, and 192.0.2.4's handshake stays. */
    v = arrive("2001:db8:0:1::1", why, sizeof why);
    qmcd_conn *e1 = &conns[7];
    assert_ptr_equal(v, b1);
    assert_non_null(strstr(why, "oldest of 192.0.2.3"));
    assert_list(5, (qmcd_conn *[]){lo3, b2, c1, d1, e1});
    /* Closing gives every place back. */
    qmcd_conn *all[] = {lo1, lo2, lo3, b1, b2, c1, d1, e1};
    for (unsigned i = 0; i < sizeof all / sizeof all[0]; i++)
        qmcd_admit_release(all[i]);
    assert_list(0, NULL);
    assert_int_equal(srv.n_refusing, 0);
    assert_null(srv.preauth_tail);
    teardown_server();
}

static void test_after_the_handshake(void **state)
{
    (void)state;
    setup_server();
    char why[240];
    /* Unix sockets count in max-connections from their accept. */
    qmcd_conn *u1 = conn_from("uid 7"), *u2 = conn_from("uid 7"), *u3 = conn_from("uid 7");
    qmcd_admit_check(u1, why, sizeof why);
    assert_string_equal(why, "");
    assert_int_equal(qmcd_admit_take(u1), 0);
    assert_int_equal(u1->admit, QMCD_ADMIT_FULL);
    assert_int_equal(qmcd_admit_take(u2), 0);
    qmcd_admit_check(u3, why, sizeof why);
    assert_non_null(strstr(why, "max-connections-per-peer (2) reached for uid 7"));
    assert_int_equal(srv.stats.peer_conn_refusals, 1);
    qmcd_admit_refuse(u3);
    assert_int_equal(srv.n_conns, 2);
    /* TCP: in the handshake budget, not in max-connections, until done;
     * admit_done of a Unix connection changes nothing. */
    assert_null(arrive("192.0.2.3", why, sizeof why));
    assert_null(arrive("192.0.2.3", why, sizeof why));
    qmcd_conn *t1 = &conns[3], *t2 = &conns[4];
    assert_int_equal(srv.n_conns, 2);
    assert_int_equal(qmcd_admit_done(u1, why, sizeof why), 0);
    assert_int_equal(srv.n_conns, 2);
    assert_int_equal(qmcd_admit_done(t1, why, sizeof why), 0);
    assert_int_equal(t1->admit, QMCD_ADMIT_FULL);
    assert_int_equal(srv.n_conns, 3);
    assert_int_equal(srv.n_preauth, 1);
    /* max-connections (3) is reached: t2 is refused at HELLO_OK and
     * keeps its handshake place until it closes. */
    assert_int_equal(qmcd_admit_done(t2, why, sizeof why), -1);
    assert_non_null(strstr(why, "max-connections (3) reached"));
    assert_int_equal(srv.stats.conns_rejected, 1);
    assert_int_equal(t2->admit, QMCD_ADMIT_PREAUTH);
    qmcd_admit_release(u2);
    /* Room again: t2 becomes 192.0.2.3's second connection (its
     * max-connections-per-peer); a third from it is refused. */
    assert_int_equal(qmcd_admit_done(t2, why, sizeof why), 0);
    qmcd_admit_release(u1);
    assert_null(arrive("192.0.2.3", why, sizeof why));
    qmcd_conn *t3 = &conns[5];
    assert_int_equal(qmcd_admit_done(t3, why, sizeof why), -1);
    assert_non_null(strstr(why, "max-connections-per-peer (2) reached for 192.0.2.3"));
    qmcd_conn *all[] = {u3, t1, t2, t3};
    for (unsigned i = 0; i < sizeof all / sizeof all[0]; i++)
        qmcd_admit_release(all[i]);
    assert_int_equal(srv.n_conns, 0);
    assert_int_equal(srv.n_preauth, 0);
    assert_int_equal(srv.n_refusing, 0);
    teardown_server();
}

/* Left at 0, a network's share is a quarter of the total. */
static void test_default_share(void **state)
{
    (void)state;
    setup_server();
    srv.cfg.max_preauth_connections = 8;
    srv.cfg.max_preauth_connections_per_peer = 0;
    char why[240];
    assert_null(arrive("127.0.0.2", why, sizeof why));
    assert_null(arrive("127.0.0.2", why, sizeof why));
    assert_ptr_equal(arrive("127.0.0.9", why, sizeof why), &conns[0]);
    assert_non_null(strstr(why, "max-preauth-connections-per-peer (2)"));
    for (unsigned i = 0; i < n_conns_made; i++)
        qmcd_admit_release(&conns[i]);
    teardown_server();
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_handshake_budget),
        cmocka_unit_test(test_after_the_handshake),
        cmocka_unit_test(test_default_share),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
