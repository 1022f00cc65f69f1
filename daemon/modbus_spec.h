/*
 * modbus_spec.h - the text of the Modbus settings: `modbus = tcp:HOST:PORT`
 * or `rtu:DEVICE:BAUD:PARITY:DATABITS:STOPBITS[:UNIT]`, and `modbus-allow =
 * CIDR,...`.  Parsing only: config.c calls these to reject bad values with
 * a one-line reason at load time, and the transports call them again to
 * get the values.
 */
#ifndef QMCD_MODBUS_SPEC_H
#define QMCD_MODBUS_SPEC_H

#include <stddef.h>
#include <stdint.h>

#include "config.h"

typedef struct qmcd_modbus_rtu_spec {
    char device[QMCD_PATH_BYTES];
    int baud;
    char parity;          /* 'N', 'E' or 'O' */
    int data_bits;        /* 5..8 */
    int stop_bits;        /* 1 or 2 */
    int unit;             /* 1..247; 1 when not given */
    int rs485;            /* 1: put the line in RS-485 mode (TIOCSRS485) */
} qmcd_modbus_rtu_spec;

/* "tcp:..." -> 1 with *hostport pointing after "tcp:"; "rtu:..." -> 2
 * with *rtu filled; otherwise -1 with the problem in why. */
int qmcd_modbus_spec_parse(const char *text, const char **hostport,
                           qmcd_modbus_rtu_spec *rtu, char *why, size_t why_bytes);

/* One allowed network: family AF_INET or AF_INET6, address bytes, prefix. */
typedef struct qmcd_cidr {
    int family;
    uint8_t addr[16];
    unsigned prefix;
} qmcd_cidr;

#define QMCD_MODBUS_MAX_ALLOW 64

/* Appends the comma-separated CIDRs of text ("10.0.0.0/8, ::1", a bare
 * address meaning one host) to list[*n].  Returns 0 or -1 with why. */
int qmcd_modbus_allow_parse(const char *text, qmcd_cidr *list, unsigned *n,
                            char *why, size_t why_bytes);

/* Does the socket address (struct sockaddr *) fall in one of the
 * networks?  IPv4-mapped IPv6 peers match IPv4 networks. */
int qmcd_modbus_allow_match(const qmcd_cidr *list, unsigned n, const void *sockaddr);

/* The host of "HOST:PORT" / "[V6]:PORT" as written: 1 a numeric loopback
 * address, 0 the wildcard or another numeric address, -1 a name (only
 * resolving can tell). */
int qmcd_modbus_host_loopback(const char *hostport);

/* With no modbus-allow, every tcp transport of c must bind loopback: the
 * numeric ones are checked here (a name is checked when it is resolved,
 * at start).  Returns 0 or -1 with why. */
int qmcd_modbus_check_exposure(const qmcd_config *c, char *why, size_t why_bytes);

/* Is the socket address a loopback one (127.0.0.0/8, ::1, mapped 127/8)? */
int qmcd_modbus_is_loopback(const void *sockaddr);

#endif
