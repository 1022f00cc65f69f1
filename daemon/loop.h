/*
 * loop.h - the epoll loop: registration and the run loop.
 */
#ifndef QMCD_LOOP_H
#define QMCD_LOOP_H

#include "server.h"

/* Creates the epoll instance, the signalfd (SIGTERM, SIGINT, SIGHUP) and
 * the timer tick.  Signals must already be blocked.  Returns 0 or
 * -errno. */
int qmcd_loop_init(qmcd_server *srv);
void qmcd_loop_close(qmcd_server *srv);

/* Registers w for events (EPOLLIN/EPOLLOUT...), changes or removes it
 * (watch.c).  Return 0 or -errno. */
int qmcd_loop_add(qmcd_server *srv, qmcd_watch *w, uint32_t events);
int qmcd_loop_mod(qmcd_server *srv, qmcd_watch *w, uint32_t events);
void qmcd_loop_del(qmcd_server *srv, qmcd_watch *w);

/* Runs until srv->quit.  Returns 0. */
int qmcd_loop_run(qmcd_server *srv);

/* The tick period: timeouts and progress are checked this often. */
#define QMCD_TICK_MS 50

#endif
