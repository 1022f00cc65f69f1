/*
 * test_modbus_spec.c - the Modbus settings' text (daemon/modbus_spec.c):
 * tcp and rtu specs with every field's bad value, the modbus-allow CIDR
 * list, and matching peers against it (prefixes off byte boundaries,
 * /0, IPv4-mapped IPv6 peers and entries), and what counts as loopback.
 *
 * The daemon's objects are not in a library, so the file is compiled in.
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <string.h>

#include "../../daemon/modbus_spec.c"

static struct sockaddr_storage v4(const char *a)
{
    struct sockaddr_storage ss;
    memset(&ss, 0, sizeof ss);
    struct sockaddr_in *s = (struct sockaddr_in *)&ss;
    s->sin_family = AF_INET;
    assert_int_equal(inet_pton(AF_INET, a, &s->sin_addr), 1);
    return ss;
}

static struct sockaddr_storage v6(const char *a)
{
    struct sockaddr_storage ss;
    memset(&ss, 0, sizeof ss);
    struct sockaddr_in6 *s = (struct sockaddr_in6 *)&ss;
    s->sin6_family = AF_INET6;
    assert_int_equal(inet_pton(AF_INET6, a, &s->sin6_addr), 1);
    return ss;
}

static void test_specs(void **state)
{
    (void)state;
    char why[300];
    const char *hp = NULL;
    qmcd_modbus_rtu_spec r;
    assert_int_equal(qmcd_modbus_spec_parse("tcp:127.0.0.1:1502", &hp, &r, why, sizeof why), 1);
    assert_string_equal(hp, "127.0.0.1:1502");
    assert_int_equal(qmcd_modbus_spec_parse("tcp:[::1]:0", &hp, &r, why, sizeof why), 1);
    assert_int_equal(qmcd_modbus_spec_parse("rtu:/dev/ttyUSB0:19200:E:8:1", &hp, &r, why,
                                            sizeof why), 2);
    assert_string_equal(r.device, "/dev/ttyUSB0");
    assert_int_equal(r.baud, 19200);
    assert_int_equal(r.parity, 'E');
    assert_int_equal(r.data_bits, 8);
    assert_int_equal(r.stop_bits, 1);
    assert_int_equal(r.unit, 1);
    assert_int_equal(qmcd_modbus_spec_parse("rtu:/dev/x:9600:N:7:2:247", &hp, &r, why,
                                            sizeof why), 2);
    assert_int_equal(r.unit, 247);
    assert_int_equal(r.rs485, 0);
    assert_int_equal(qmcd_modbus_spec_parse("rtu:/dev/x:9600:N:8:1:rs485", &hp, &r, why,
                                            sizeof why), 2);
    assert_int_equal(r.unit, 1);
    assert_int_equal(r.rs485, 1);
    assert_int_equal(qmcd_modbus_spec_parse("rtu:/dev/x:9600:N:8:1:12:rs485", &hp, &r, why,
                                            sizeof why), 2);
    assert_int_equal(r.unit, 12);
    assert_int_equal(r.rs485, 1);
    static const char *const bad[] = {
        "rtu:/dev/x:9600:N:8:1:12:rs486", "rtu:/dev/x:9600:N:8:1:rs485:12",
        "rtu:/dev/x:9600:N:8:1:12:rs485:", "rtu:/dev/x:9600:N:8:rs485",
        "rtu:/dev/x:9600:N:8:1:12:rs485:rs485",
        "tcp:127.0.0.1", "tcp:127.0.0.1:65536", "tcp::1502x", "udp:1.2.3.4:5", "rtu:",
        "rtu:/dev/x:9600:E:8", "rtu:dev/x:9600:E:8:1", "rtu:/dev/x:9600:X:8:1",
        "rtu:/dev/x:9600:E:9:1", "rtu:/dev/x:9600:E:8:3", "rtu:/dev/x:10:E:8:1",
        "rtu:/dev/x:9600:E:8:1:0", "rtu:/dev/x:9600:E:8:1:248", "rtu:/dev/x:9600:E:8:1:5:6",
        "rtu:/dev/x:9600:E:8:1:", "rtu:/dev/x:9600::8:1", "rtu:/dev/x:9600:EE:8:1", ""};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        why[0] = '\0';
        assert_int_equal(qmcd_modbus_spec_parse(bad[i], &hp, &r, why, sizeof why), -1);
        assert_true(why[0] != '\0');
        assert_null(strchr(why, '\n'));
    }
}

static void test_allow(void **state)
{
    (void)state;
    char why[300];
    qmcd_cidr list[QMCD_MODBUS_MAX_ALLOW];
    unsigned n = 0;
    assert_int_equal(qmcd_modbus_allow_parse("10.1.0.0/16, 192.168.7.9,fd00::/8\t172.16.0.0/12",
                                             list, &n, why, sizeof why), 0);
    assert_int_equal(n, 4);
    struct sockaddr_storage a;
    a = v4("10.1.255.3");
    assert_true(qmcd_modbus_allow_match(list, n, &a));
    a = v4("10.2.0.1");
    assert_false(qmcd_modbus_allow_match(list, n, &a));
    a = v4("192.168.7.9");
    assert_true(qmcd_modbus_allow_match(list, n, &a));
    a = v4("192.168.7.10");
    assert_false(qmcd_modbus_allow_match(list, n, &a));
    /* /12 is off a byte boundary: 172.16.0.0 .. 172.31.255.255. */
    a = v4("172.31.255.255");
    assert_true(qmcd_modbus_allow_match(list, n, &a));
    a = v4("172.32.0.0");
    assert_false(qmcd_modbus_allow_match(list, n, &a));
    a = v4("172.15.255.255");
    assert_false(qmcd_modbus_allow_match(list, n, &a));
    a = v6("fd12::1");
    assert_true(qmcd_modbus_allow_match(list, n, &a));
    a = v6("fe80::1");
    assert_false(qmcd_modbus_allow_match(list, n, &a));
    /* An IPv4-mapped IPv6 peer matches the IPv4 networks. */
    a = v6("::ffff:10.1.2.3");
    assert_true(qmcd_modbus_allow_match(list, n, &a));
    a = v6("::ffff:10.9.2.3");
    assert_false(qmcd_modbus_allow_match(list, n, &a));
    /* /0 lets every address of its family in, and only that family. */
    unsigned m = 0;
    assert_int_equal(qmcd_modbus_allow_parse("0.0.0.0/0", list, &m, why, sizeof why), 0);
    a = v4("203.0.113.5");
    assert_true(qmcd_modbus_allow_match(list, m, &a));
    a = v6("2001:db8::1");
    assert_false(qmcd_modbus_allow_match(list, m, &a));
    static const char *const bad[] = {"10.0.0.0/33", "::/129", "10.0.0", "10.0.0.0/",
                                      "10.0.0.0/8x", "example.org", "/8"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        unsigned k = 0;
        why[0] = '\0';
        assert_int_equal(qmcd_modbus_allow_parse(bad[i], list, &k, why, sizeof why), -1);
        assert_non_null(strstr(why, "modbus-allow"));
    }
    /* The list is capped. */
    unsigned k = 0;
    for (int i = 0; i < QMCD_MODBUS_MAX_ALLOW; i++)
        assert_int_equal(qmcd_modbus_allow_parse("10.0.0.1", list, &k, why, sizeof why), 0);
    assert_int_equal(qmcd_modbus_allow_parse("10.0.0.1", list, &k, why, sizeof why), -1);
}

/* An entry written IPv4-mapped is the IPv4 network it maps (peers are
 * matched mapped-as-IPv4, so kept as IPv6 it would match no one): the
 * address ::ffff:a.b.c.d, ::ffff:a.b.0.0/112 = a.b.0.0/16, ::ffff:0:0/96 =
 * all of IPv4.  Shorter than /96 it is refused with one line. */
static void test_allow_mapped(void **state)
{
    (void)state;
    char why[300];
    qmcd_cidr list[QMCD_MODBUS_MAX_ALLOW];
    unsigned n = 0;
    assert_int_equal(qmcd_modbus_allow_parse("::ffff:127.0.0.3, ::ffff:10.1.0.0/112", list, &n,
                                             why, sizeof why), 0);
    assert_int_equal(n, 2);
    struct sockaddr_storage a;
    a = v4("127.0.0.3");
    assert_true(qmcd_modbus_allow_match(list, n, &a));
    a = v6("::ffff:127.0.0.3");
    assert_true(qmcd_modbus_allow_match(list, n, &a));
    a = v4("127.0.0.4");
    assert_false(qmcd_modbus_allow_match(list, n, &a));
    a = v4("10.1.255.255");
    assert_true(qmcd_modbus_allow_match(list, n, &a));
    a = v4("10.2.0.0");
    assert_false(qmcd_modbus_allow_match(list, n, &a));
    /* Not an IPv6 entry any more: the IPv6 address with the same low bits
     * (::a01:1, not mapped) stays out. */
    a = v6("::a01:1");
    assert_false(qmcd_modbus_allow_match(list, n, &a));
    unsigned m = 0;
    assert_int_equal(qmcd_modbus_allow_parse("::ffff:0:0/96", list, &m, why, sizeof why), 0);
    a = v4("203.0.113.5");
    assert_true(qmcd_modbus_allow_match(list, m, &a));
    a = v6("2001:db8::1");
    assert_false(qmcd_modbus_allow_match(list, m, &a));
    m = 0;
    why[0] = '\0';
    assert_int_equal(qmcd_modbus_allow_parse("::ffff:10.0.0.0/95", list, &m, why, sizeof why),
                     -1);
    assert_non_null(strstr(why, "'::ffff:10.0.0.0/95'"));
    assert_non_null(strstr(why, "IPv4-mapped"));
    assert_null(strchr(why, '\n'));
}

static void test_loopback(void **state)
{
    (void)state;
    struct sockaddr_storage a;
    a = v4("127.0.0.1");
    assert_true(qmcd_modbus_is_loopback(&a));
    a = v4("127.255.0.9");
    assert_true(qmcd_modbus_is_loopback(&a));
    a = v4("0.0.0.0");
    assert_false(qmcd_modbus_is_loopback(&a));
    a = v4("10.0.0.1");
    assert_false(qmcd_modbus_is_loopback(&a));
    a = v6("::1");
    assert_true(qmcd_modbus_is_loopback(&a));
    a = v6("::");
    assert_false(qmcd_modbus_is_loopback(&a));
    a = v6("::ffff:127.0.0.1");
    assert_true(qmcd_modbus_is_loopback(&a));
}

static void test_exposure(void **state)
{
    (void)state;
    assert_int_equal(qmcd_modbus_host_loopback("127.0.0.1:1502"), 1);
    assert_int_equal(qmcd_modbus_host_loopback("127.1.2.3:0"), 1);
    assert_int_equal(qmcd_modbus_host_loopback("[::1]:1502"), 1);
    assert_int_equal(qmcd_modbus_host_loopback("0.0.0.0:1502"), 0);
    assert_int_equal(qmcd_modbus_host_loopback("[::]:1502"), 0);
    assert_int_equal(qmcd_modbus_host_loopback(":1502"), 0);
    assert_int_equal(qmcd_modbus_host_loopback("10.0.0.1:1502"), 0);
    assert_int_equal(qmcd_modbus_host_loopback("localhost:1502"), -1);
    qmcd_config c;
    memset(&c, 0, sizeof c);
    char why[300];
    strcpy(c.modbus[c.n_modbus++], "tcp:127.0.0.1:1502");
    strcpy(c.modbus[c.n_modbus++], "rtu:/dev/ttyS0:9600:N:8:1");
    strcpy(c.modbus[c.n_modbus++], "tcp:plc-gateway:1502"); /* judged at start */
    assert_int_equal(qmcd_modbus_check_exposure(&c, why, sizeof why), 0);
    strcpy(c.modbus[c.n_modbus++], "tcp:[::]:1502");
    assert_int_equal(qmcd_modbus_check_exposure(&c, why, sizeof why), -1);
    assert_non_null(strstr(why, "needs modbus-allow"));
    strcpy(c.modbus_allow, "10.0.0.0/8");
    assert_int_equal(qmcd_modbus_check_exposure(&c, why, sizeof why), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_specs),
        cmocka_unit_test(test_allow),
        cmocka_unit_test(test_allow_mapped),
        cmocka_unit_test(test_loopback),
        cmocka_unit_test(test_exposure),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
