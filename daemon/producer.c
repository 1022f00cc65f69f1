/*
 * producer.c - a connection's producers (producer.h): the list in turn
 * order, the turn that pumps them, and the questions the connection asks
 * them (what they wait on, whether the shutdown deadline cuts them).
 *
 * Fairness.  A turn pumps the producers from the front of the list; the
 * first that queues a frame goes to the back, so producers take turns one
 * frame each.  One that waits on something else (a ring slot, a worker)
 * lets the others pass; one that finds no output room for its next frame
 * stops the turn, so that a producer with big frames is not starved by
 * small ones that always fit.
 *
 * This file must not name a kind, send frames or decide a connection's
 * lifetime (conn.c): it only keeps the list and calls the kinds' tables.
 */
#include <stddef.h>

#include "conn.h"
#include "producer.h"

void qmcd_producer_attach(qmcd_conn *c, qmcd_producer *p, const qmcd_producer_kind *kind,
                          uint64_t request_id)
{
    p->kind = kind;
    p->request_id = request_id;
    p->next = NULL;
    /* Appended last, so producers take turns in arrival order. */
    qmcd_producer **link = &c->producers;
    while (*link)
        link = &(*link)->next;
    *link = p;
    c->n_producers++;
    if (kind->flags & QMCD_PRODUCER_BULK)
        c->n_bulk++;
}

qmcd_producer *qmcd_producer_first(const qmcd_conn *c)
{
    return c->producers;
}

unsigned qmcd_producer_count(const qmcd_conn *c, const qmcd_producer_kind *kind)
{
    if (!kind)
        return c->n_producers;
    unsigned n = 0;
    for (const qmcd_producer *p = c->producers; p; p = p->next)
        n += p->kind == kind;
    return n;
}

/* Takes *link (p) off the list. */
static void unlink_at(qmcd_conn *c, qmcd_producer **link)
{
    qmcd_producer *p = *link;
    *link = p->next;
    p->next = NULL;
    c->n_producers--;
    if (p->kind->flags & QMCD_PRODUCER_BULK)
        c->n_bulk--;
}

int qmcd_producers_turn(qmcd_conn *c)
{
    for (qmcd_producer **link = &c->producers; *link;) {
        qmcd_producer *p = *link;
        int rc = p->kind->pump(c, p);
        /* Closing released every producer, p too. */
        if (c->dead || c->closing)
            return QMCD_TURN_SENT;
        int turn = QMCD_TURN_SENT | ((rc & QMCD_PUMP_FLUSH) ? QMCD_TURN_FLUSH : 0);
        switch (QMCD_PUMP_STATUS(rc)) {
        case QMCD_PUMP_WAIT:
            link = &p->next;
            continue;
        case QMCD_PUMP_SENT:
            /* Round robin: p goes to the back. */
            if (p->next) {
                *link = p->next;
                qmcd_producer *last = *link;
                while (last->next)
                    last = last->next;
                last->next = p;
                p->next = NULL;
            }
            return turn;
        case QMCD_PUMP_DONE:
        case QMCD_PUMP_FAILED:
            unlink_at(c, link);
            p->kind->release(c, p, QMCD_PUMP_STATUS(rc) == QMCD_PUMP_DONE ? QMCD_END_DONE
                                                                          : QMCD_END_FAILED);
            return turn;
        default: /* QMCD_PUMP_NO_ROOM: everyone behind it waits too */
            return 0;
        }
    }
    return 0;
}

int qmcd_producers_waiting(const qmcd_conn *c, qmcd_wait w)
{
    for (const qmcd_producer *p = c->producers; p; p = p->next)
        if (p->kind->waiting(c, p) == w)
            return 1;
    return 0;
}

qmcd_producer *qmcd_producers_find(const qmcd_conn *c, uint64_t request_id)
{
    for (qmcd_producer *p = c->producers; p; p = p->next)
        if (p->request_id == request_id)
            return p;
    return NULL;
}

void qmcd_producers_end(qmcd_conn *c, qmcd_producer *p, qmcd_end why)
{
    for (qmcd_producer **link = &c->producers; *link; link = &(*link)->next)
        if (*link == p) {
            unlink_at(c, link);
            p->kind->release(c, p, why);
            return;
        }
}

void qmcd_producers_drop_all(qmcd_conn *c)
{
    while (c->producers) {
        qmcd_producer *p = c->producers;
        unlink_at(c, &c->producers);
        p->kind->release(c, p, QMCD_END_DROPPED);
    }
}

void qmcd_producers_tick(qmcd_conn *c, int64_t now_ms)
{
    for (qmcd_producer *p = c->producers; p;) {
        /* A tick never unlinks p, but a send it makes may close the
         * connection, which releases every producer: next is read first
         * and used only while the connection stands. */
        qmcd_producer *next = p->next;
        if (p->kind->tick)
            p->kind->tick(c, p, now_ms);
        if (c->dead || c->closing)
            return;
        p = next;
    }
}

int qmcd_producers_shutdown(qmcd_conn *c)
{
    int cut = 0;
    for (qmcd_producer *p = c->producers; p; p = p->next)
        cut |= p->kind->shutdown ? p->kind->shutdown(c, p) != 0 : 1;
    return cut;
}

/* max-cancels-per-conn: tokens are kept in 1/60000ths so that the refill
 * is exact in whole milliseconds.  Cancels are cheap, but they make churn
 * cheap too (start a job, cancel it, again): this bounds its rate per
 * connection. */
int qmcd_producer_cancel_allowed(qmcd_conn *c)
{
    const uint64_t cap = c->srv->cfg.max_cancels_per_conn;
    const uint64_t full = cap * 60000u;
    int64_t now = qmcd_now_ms();
    if (c->cancel_refill_ms == 0) {
        c->cancel_tokens = full;
    } else if (now > c->cancel_refill_ms) {
        uint64_t add = (uint64_t)(now - c->cancel_refill_ms) * cap;
        c->cancel_tokens = full - c->cancel_tokens <= add ? full : c->cancel_tokens + add;
    }
    if (c->cancel_tokens > full) /* the limit shrank on SIGHUP */
        c->cancel_tokens = full;
    c->cancel_refill_ms = now;
    if (c->cancel_tokens < 60000u)
        return 0;
    c->cancel_tokens -= 60000u;
    return 1;
}
