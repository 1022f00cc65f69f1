/*
 * watch.c - registering descriptors with the loop's epoll instance
 * (qmcd_loop_add, _mod, _del; declared in loop.h).  Level-triggered;
 * epoll_event.data.ptr is the watch, whose on_event the loop calls.
 *
 * A leaf: connections, listeners, the Modbus transports and the job
 * module register their descriptors here without depending on the loop
 * that runs them (loop.c).
 */
#include <errno.h>
#include <sys/epoll.h>

#include "loop.h"

int qmcd_loop_add(qmcd_server *srv, qmcd_watch *w, uint32_t events)
{
    struct epoll_event ev = {.events = events, .data.ptr = w};
    if (epoll_ctl(srv->epfd, EPOLL_CTL_ADD, w->fd, &ev) != 0)
        return -errno;
    w->events = events;
    return 0;
}

int qmcd_loop_mod(qmcd_server *srv, qmcd_watch *w, uint32_t events)
{
    if (w->events == events)
        return 0;
    struct epoll_event ev = {.events = events, .data.ptr = w};
    if (epoll_ctl(srv->epfd, EPOLL_CTL_MOD, w->fd, &ev) != 0)
        return -errno;
    w->events = events;
    return 0;
}

void qmcd_loop_del(qmcd_server *srv, qmcd_watch *w)
{
    (void)epoll_ctl(srv->epfd, EPOLL_CTL_DEL, w->fd, NULL);
    w->events = 0;
}
