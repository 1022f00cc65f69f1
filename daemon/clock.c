/*
 * clock.c - the daemon's clock (CLOCK_MONOTONIC, in milliseconds and
 * microseconds) and the latency record of an answered request; declared
 * in server.h.
 *
 * A leaf: every other file may call it, it calls only stats.c, so that
 * reading the clock makes no file depend on the loop.
 */
#define _GNU_SOURCE
#include <time.h>

#include "server.h"

int64_t qmcd_now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
}

int64_t qmcd_now_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000 + ts.tv_nsec / 1000;
}

void qmcd_answered(qmcd_server *srv, int64_t t0_us)
{
    if (qmcd_stats_answered(&srv->stats, t0_us))
        qmcd_stats_end_turn(&srv->stats, qmcd_now_us());
}
