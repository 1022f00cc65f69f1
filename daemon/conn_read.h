/*
 * conn_read.h - the input side of a connection (conn_read.c), called by
 * conn.c's event handler and pump.
 */
#ifndef QMCD_CONN_READ_H
#define QMCD_CONN_READ_H

#include "conn.h"

/* Reads what the socket has (up to a per-event budget) and dispatches the
 * complete frames.  May fail or close the connection (check c->dead). */
void qmcd_conn_read(qmcd_conn *c);

/* Dispatches the complete frames already buffered, while output has room
 * for their answers.  Not re-entrant: c->parsing is set meanwhile. */
void qmcd_conn_parse(qmcd_conn *c);

#endif
