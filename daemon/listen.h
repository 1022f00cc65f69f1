/*
 * listen.h - listening sockets: unix:PATH, tcp:HOST:PORT, and sockets
 * handed over by systemd.
 */
#ifndef QMCD_LISTEN_H
#define QMCD_LISTEN_H

#include "server.h"

struct qmcd_listener {
    qmcd_watch w;
    char name[QMCD_PATH_BYTES + 16];  /* "unix:/run/qmcd/qmcd.sock", "tcp:[::1]:4711" */
    char path[QMCD_PATH_BYTES];       /* a unix socket file we created, or "" */
    int paused;                       /* out of descriptors: not polled until
                                         the next tick (see qmcd_conn_on_accept) */
    int needs_key;                    /* TCP on a non-loopback address: may only
                                         run with an auth-key (auth.c) */
};

/*
 * Opens every configured listener (or the default Unix socket when none is
 * configured and systemd passed none).  On error closes what it opened and
 * writes one line into why.  Returns 0 or -1.
 */
int qmcd_listeners_open(qmcd_server *srv, char *why, size_t why_bytes);
/* Binds and listens on "HOST:PORT" / "[V6]:PORT" (port 0: the kernel's
 * choice) into l->w.fd and l->name; the Modbus listeners share it.
 * Returns 0, or -1 with one line in why. */
int qmcd_listen_tcp(const char *hostport, qmcd_listener *l, char *why, size_t why_bytes);
/* Registers the listeners with the loop. */
int qmcd_listeners_start(qmcd_server *srv);
/* Closes the listeners and removes the socket files we created. */
void qmcd_listeners_close(qmcd_server *srv);

#endif
