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

