/*
 * modbus_bridge.h - the Modbus bridge as the rest of the daemon sees it: a
 * handful of lifecycle calls from main.c and loop.c, and its counters for
 * STATS (status.c), nothing else.  The
 * transports (modbus_tcp.c, modbus_rtu.c) keep their own connections and
 * counters and never touch the protocol connections of conn.c.
 */
#ifndef QMCD_MODBUS_BRIDGE_H
#define QMCD_MODBUS_BRIDGE_H

#include <stdint.h>
#include <stdio.h>

#include "qmc/proto.h"
#include "server.h"

/* Opens every configured Modbus transport (TCP listeners bound, serial
 * lines opened) without serving yet.  On error closes what it opened and
 * writes one line into why; returns 0 or -1. */
int qmcd_modbus_open(qmcd_server *srv, char *why, size_t why_bytes);

/* Registers the listeners with the loop and starts the serial threads.
 * Returns 0 or -errno. */
int qmcd_modbus_start(qmcd_server *srv);

/* Writes "modbus:tcp:127.0.0.1:1502"-style lines, one per transport. */
void qmcd_modbus_write_names(const qmcd_server *srv, FILE *f);

/* Loop tick: partial-frame and idle deadlines, paused listeners. */
void qmcd_modbus_tick(qmcd_server *srv, int64_t now_ms);

/* After each loop round: frees the connections closed during it. */
void qmcd_modbus_reap(qmcd_server *srv);

/* Draining: stop accepting, flush and close every Modbus connection (a
 * Modbus request is answered the moment it is complete: nothing is in
 * flight), stop the serial threads. */
void qmcd_modbus_drain(qmcd_server *srv);

/* STATS entries "modbus_requests", ... (static names) into e[0 .. cap);
 * returns how many, 0 when no Modbus transport is configured. */
uint32_t qmcd_modbus_stats(const qmcd_server *srv, qmc_stat *e, uint32_t cap);

/* Frees everything; safe after a failed open and when never opened. */
void qmcd_modbus_close(qmcd_server *srv);

#endif
