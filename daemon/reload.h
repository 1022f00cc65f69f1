/*
 * reload.h - process-level actions the loop and main.c trigger
 * (reload.c).
 */
#ifndef QMCD_RELOAD_H
#define QMCD_RELOAD_H

#include "server.h"

/* SIGHUP: re-reads the configuration; keeps the old one if it is bad. */
void qmcd_reload(qmcd_server *srv);
/* sd_notify(3) when running under systemd; a no-op elsewhere. */
void qmcd_notify(qmcd_server *srv, const char *state);

#endif
