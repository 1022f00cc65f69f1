/*
 * modbus_counters.c - the counters every Modbus transport shares (requests,
 * exceptions, connections) and the environment the register handler
 * reports from them (uptime, version, the Sobol table's fingerprint).
 *
 * A leaf: the transports (modbus_tcp.c, modbus_rtu.c, on the loop and on
 * their own threads) count here without depending on the bridge that
 * starts them.  Atomics only: the RTU threads count too.
 */
#define _GNU_SOURCE
#include <string.h>

#include "modbus_srv.h"

#define QMCD_VERSION "0.1.0"

void qmcd__modbus_env(qmcd_modbus *mb, qmc_modbus_env *env)
{
    memset(env, 0, sizeof *env);
    int64_t up = qmcd_now_ms() - mb->started_ms;
    env->uptime_s = up > 0 ? (uint64_t)up / 1000 : 0;
    env->requests = atomic_load_explicit(&mb->ctr.requests, memory_order_relaxed);
    env->exceptions = atomic_load_explicit(&mb->ctr.exceptions, memory_order_relaxed);
    env->conns_accepted = atomic_load_explicit(&mb->ctr.conns_accepted, memory_order_relaxed);
    env->conns_refused = atomic_load_explicit(&mb->ctr.conns_refused, memory_order_relaxed);
    env->conns_open = atomic_load_explicit(&mb->ctr.conns_open, memory_order_relaxed);
    env->sobol_table_hash = mb->srv->sobol_table_hash;
    env->version = QMCD_VERSION;
}

void qmcd__modbus_count(qmcd_modbus *mb, const uint8_t *resp)
{
    atomic_fetch_add_explicit(&mb->ctr.requests, 1, memory_order_relaxed);
    if (resp[0] & 0x80)
        atomic_fetch_add_explicit(&mb->ctr.exceptions, 1, memory_order_relaxed);
}

/* total - (used - own), never below 0. */
static uint64_t left(uint64_t total, uint64_t used, uint64_t own)
{
    uint64_t others = used > own ? used - own : 0;
    return total > others ? total - others : 0;
}

uint64_t qmcd__modbus_room(qmcd_modbus *mb, uint64_t per_bank, uint64_t total, uint64_t own,
                           uint64_t peer_room)
{
    uint64_t used = atomic_load_explicit(&mb->ctr.integration_bytes, memory_order_relaxed);
    uint64_t room = left(total, used, own);
    if (room > per_bank)
        room = per_bank;
    return room < peer_room ? room : peer_room;
}

/* Adds now - was to a counter (the difference may be negative). */
static void move(atomic_uint_fast64_t *c, uint64_t was, uint64_t now)
{
    if (now >= was)
        atomic_fetch_add_explicit(c, now - was, memory_order_relaxed);
    else
        atomic_fetch_sub_explicit(c, was - now, memory_order_relaxed);
}

void qmcd__modbus_account(qmcd_modbus *mb, qmc_modbus_usage *was, const qmc_modbus_session *now)
{
    qmc_modbus_usage u;
    qmc_modbus_session_usage(now, &u);
    if (!now)
        u.integrations_refused = was->integrations_refused; /* a count: it stays */
    move(&mb->ctr.integration_bytes, was->integration_bytes, u.integration_bytes);
    move(&mb->ctr.integrations, (uint64_t)was->integrating, (uint64_t)u.integrating);
    move(&mb->ctr.integrations_refused, was->integrations_refused, u.integrations_refused);
    *was = u;
}

