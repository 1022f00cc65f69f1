/*
 * modbus_spec.c - parsing the Modbus transport specs and the modbus-allow
 * address list, and matching peers against it (see modbus_spec.h).
 *
 * Must not: open anything.  These are text-to-value functions that config
 * validation and the transports share, so a value that loads also opens.
 */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <ctype.h>
#include <errno.h>
#include <netinet/in.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>

#include "modbus_spec.h"

/* A decimal integer in [lo, hi] taking all of text. */
static int parse_int(const char *text, long lo, long hi, int *out)
{
    if (!isdigit((unsigned char)text[0]))
        return -1;
    errno = 0;
    char *end;
    long v = strtol(text, &end, 10);
    if (errno || *end || v < lo || v > hi)
        return -1;
    *out = (int)v;
    return 0;
}

static int parse_rtu(const char *spec, qmcd_modbus_rtu_spec *rtu, char *why, size_t n)
{
    char buf[QMCD_PATH_BYTES + 64];
    if (strlen(spec) >= sizeof buf) {
        snprintf(why, n, "modbus: rtu spec longer than %zu bytes", sizeof buf - 1);
        return -1;
    }
    strcpy(buf, spec);
    /* The device may not contain ':'; the fields after it are fixed, then
     * an optional unit and an optional "rs485" flag, in that order. */
    char *field[7] = {0};
    int nf = 0;
    for (char *p = buf, *save = NULL; nf < 7; p = NULL) {
        char *t = strtok_r(p, ":", &save);
        if (!t)
            break;
        field[nf++] = t;
    }
    static const char usage[] =
        "want rtu:DEVICE:BAUD:PARITY:DATABITS:STOPBITS[:UNIT][:rs485], "
        "e.g. rtu:/dev/ttyUSB0:19200:E:8:1";
    size_t colons = 0;
    for (const char *p = spec; *p; p++)
        colons += *p == ':';
    int rs485 = nf >= 6 && strcmp(field[nf - 1], "rs485") == 0;
    if (nf < 5 || colons > (size_t)(5 + rs485) || !spec[0] || spec[strlen(spec) - 1] == ':' ||
        strstr(spec, "::")) {
        snprintf(why, n, "modbus: rtu:%s: %s", spec, usage);
        return -1;
    }
    nf -= rs485;
    memset(rtu, 0, sizeof *rtu);
    rtu->rs485 = rs485;
    if (field[0][0] != '/' || strlen(field[0]) >= sizeof rtu->device) {
        snprintf(why, n, "modbus: rtu:%s: the device must be an absolute path", spec);
        return -1;
    }
    strcpy(rtu->device, field[0]);
    if (parse_int(field[1], 50, 4000000, &rtu->baud) != 0) {
        snprintf(why, n, "modbus: rtu:%s: baud '%s' is not a number in 50..4000000", spec,
                 field[1]);
        return -1;
    }
    if (strlen(field[2]) != 1 || !strchr("NEO", field[2][0])) {
        snprintf(why, n, "modbus: rtu:%s: parity '%s' is not N, E or O", spec, field[2]);
        return -1;
    }
    rtu->parity = field[2][0];
    if (parse_int(field[3], 5, 8, &rtu->data_bits) != 0) {
        snprintf(why, n, "modbus: rtu:%s: data bits '%s' is not 5..8", spec, field[3]);
        return -1;
    }
    if (parse_int(field[4], 1, 2, &rtu->stop_bits) != 0) {
        snprintf(why, n, "modbus: rtu:%s: stop bits '%s' is not 1 or 2", spec, field[4]);
        return -1;
    }
    rtu->unit = 1;
    if (nf == 6) {
        if (parse_int(field[5], 1, 247, &rtu->unit) != 0) {
            snprintf(why, n, "modbus: rtu:%s: unit '%s' is not 1..247 (the spec's unicast range)",
                     spec, field[5]);
            return -1;
        }
    }
    return 0;
}

int qmcd_modbus_spec_parse(const char *text, const char **hostport, qmcd_modbus_rtu_spec *rtu,
                           char *why, size_t why_bytes)
{
    if (strncmp(text, "tcp:", 4) == 0) {
        const char *hp = text + 4;
        const char *colon = strrchr(hp, ':');
        int port;
        if (!colon || colon == hp || parse_int(colon + 1, 0, 65535, &port) != 0) {
            snprintf(why, why_bytes,
                     "modbus: '%s': want tcp:HOST:PORT or tcp:[IPV6]:PORT (port 0..65535)", text);
            return -1;
        }
        if (hostport)
            *hostport = hp;
        return 1;
    }
    if (strncmp(text, "rtu:", 4) == 0) {
        qmcd_modbus_rtu_spec tmp;
        if (parse_rtu(text + 4, rtu ? rtu : &tmp, why, why_bytes) != 0)
            return -1;
        return 2;
    }
    snprintf(why, why_bytes, "modbus: '%s' is neither tcp:HOST:PORT nor rtu:DEVICE:...", text);
    return -1;
}

/* One network; -1 for text that is not one, -2 for an IPv4-mapped IPv6
 * network shorter than /96 (it would reach past the mapped addresses). */
static int parse_cidr(const char *text, qmcd_cidr *c)
{
    char addr[INET6_ADDRSTRLEN + 8];
    const char *slash = strchr(text, '/');
    size_t alen = slash ? (size_t)(slash - text) : strlen(text);
    if (alen == 0 || alen >= sizeof addr)
        return -1;
    memcpy(addr, text, alen);
    addr[alen] = '\0';
    memset(c, 0, sizeof *c);
    unsigned max;
    if (inet_pton(AF_INET, addr, c->addr) == 1) {
        c->family = AF_INET;
        max = 32;
    } else if (inet_pton(AF_INET6, addr, c->addr) == 1) {
        c->family = AF_INET6;
        max = 128;
    } else {
        return -1;
    }
    int prefix = (int)max;
    if (slash && parse_int(slash + 1, 0, max, &prefix) != 0)
        return -1;
    c->prefix = (unsigned)prefix;
    /* Peers are matched IPv4-mapped ones as IPv4 (peer_bytes), so an
     * entry written ::ffff:a.b.c.d/N is the IPv4 network a.b.c.d/(N-96):
     * kept as IPv6 it could never match anyone. */
    static const uint8_t mapped[12] = {[10] = 0xff, [11] = 0xff};
    if (c->family == AF_INET6 && memcmp(c->addr, mapped, sizeof mapped) == 0) {
        if (c->prefix < 96)
            return -2;
        memmove(c->addr, c->addr + 12, 4);
        memset(c->addr + 4, 0, 12);
        c->family = AF_INET;
        c->prefix -= 96;
    }
    return 0;
}

int qmcd_modbus_allow_parse(const char *text, qmcd_cidr *list, unsigned *n, char *why,
                            size_t why_bytes)
{
    const char *p = text;
    while (*p) {
        while (*p == ' ' || *p == '\t' || *p == ',')
            p++;
        if (!*p)
            break;
        size_t len = strcspn(p, ", \t");
        char item[80];
        if (len >= sizeof item) {
            snprintf(why, why_bytes, "modbus-allow: '%.40s...' is too long for an address", p);
            return -1;
        }
        memcpy(item, p, len);
        item[len] = '\0';
        if (*n == QMCD_MODBUS_MAX_ALLOW) {
            snprintf(why, why_bytes, "modbus-allow: more than %d networks",
                     QMCD_MODBUS_MAX_ALLOW);
            return -1;
        }
        int bad = parse_cidr(item, &list[*n]);
        if (bad == -2) {
            snprintf(why, why_bytes,
                     "modbus-allow: '%s': an IPv4-mapped network needs a prefix of /96 or "
                     "more; write the IPv4 network (a.b.c.d/N) instead", item);
            return -1;
        }
        if (bad != 0) {
            snprintf(why, why_bytes,
                     "modbus-allow: '%s' is not an address or CIDR (10.0.0.0/8, fd00::/8)",
                     item);
            return -1;
        }
        (*n)++;
        p += len;
    }
    return 0;
}

/* The peer's family and address bytes, IPv4-mapped IPv6 as IPv4. */
static int peer_bytes(const void *sockaddr, uint8_t out[16])
{
    const struct sockaddr *sa = sockaddr;
    if (sa->sa_family == AF_INET) {
        memcpy(out, &((const struct sockaddr_in *)sockaddr)->sin_addr, 4);
        return AF_INET;
    }
    if (sa->sa_family == AF_INET6) {
        const struct in6_addr *a = &((const struct sockaddr_in6 *)sockaddr)->sin6_addr;
        if (IN6_IS_ADDR_V4MAPPED(a)) {
            memcpy(out, a->s6_addr + 12, 4);
            return AF_INET;
        }
        memcpy(out, a->s6_addr, 16);
        return AF_INET6;
    }
    return -1;
}

static int in_net(const qmcd_cidr *c, const uint8_t *a)
{
    unsigned full = c->prefix / 8, rest = c->prefix % 8;
    if (memcmp(c->addr, a, full) != 0)
        return 0;
    if (rest == 0)
        return 1;
    uint8_t mask = (uint8_t)(0xFF << (8 - rest));
    return (c->addr[full] & mask) == (a[full] & mask);
}

int qmcd_modbus_allow_match(const qmcd_cidr *list, unsigned n, const void *sockaddr)
{
    uint8_t a[16];
    int fam = peer_bytes(sockaddr, a);
    for (unsigned i = 0; i < n; i++)
        if (list[i].family == fam && in_net(&list[i], a))
            return 1;
    return 0;
}

int qmcd_modbus_is_loopback(const void *sockaddr)
{
    uint8_t a[16];
    int fam = peer_bytes(sockaddr, a);
    static const uint8_t v6_loop[16] = {[15] = 1};
    if (fam == AF_INET)
        return a[0] == 127;
    return fam == AF_INET6 && memcmp(a, v6_loop, 16) == 0;
}

int qmcd_modbus_host_loopback(const char *hostport)
{
    char host[INET6_ADDRSTRLEN + 8];
    const char *start = hostport, *end;
    if (hostport[0] == '[') {
        start = hostport + 1;
        end = strchr(start, ']');
    } else {
        end = strrchr(hostport, ':');
    }
    if (!end || (size_t)(end - start) >= sizeof host)
        return -1;
    memcpy(host, start, (size_t)(end - start));
    host[end - start] = '\0';
    if (!host[0])
        return 0; /* the wildcard */
    struct sockaddr_in s4 = {.sin_family = AF_INET};
    struct sockaddr_in6 s6 = {.sin6_family = AF_INET6};
    if (inet_pton(AF_INET, host, &s4.sin_addr) == 1)
        return qmcd_modbus_is_loopback(&s4);
    if (inet_pton(AF_INET6, host, &s6.sin6_addr) == 1)
        return qmcd_modbus_is_loopback(&s6);
    return -1;
}

int qmcd_modbus_check_exposure(const qmcd_config *c, char *why, size_t why_bytes)
{
    if (c->modbus_allow[0])
        return 0;
    for (unsigned i = 0; i < c->n_modbus; i++) {
        const char *hp = NULL;
        if (strncmp(c->modbus[i], "tcp:", 4) != 0)
            continue;
        hp = c->modbus[i] + 4;
        if (qmcd_modbus_host_loopback(hp) == 0) {
            snprintf(why, why_bytes,
                     "modbus tcp:%s: listening off loopback needs modbus-allow = CIDR,... "
                     "(Modbus has no authentication)", hp);
            return -1;
        }
    }
    return 0;
}
