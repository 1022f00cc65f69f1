/*
 * stats.h - the daemon's counters and request-latency histogram, reported
 * by STATS as (name, u64) entries.  Loop-thread only: no locks.
 */
#ifndef QMCD_STATS_H
#define QMCD_STATS_H

#include <stdint.h>

#include "qmc/proto.h"

/* Plain counters: X(field, wire name). */
#define QMCD_STATS_MAP(X)                                   \
    X(conns_accepted, "connections_accepted")               \
    X(conns_rejected, "connections_rejected")               \
    X(conns_closed, "connections_closed")                   \
    X(conns_timed_out, "connections_timed_out")             \
    X(bytes_in, "bytes_in")                                 \
    X(bytes_out, "bytes_out")                               \
    X(frames_in, "frames_in")                               \
    X(frames_out, "frames_out")                             \
    X(malformed, "malformed_frames")                        \
    X(errors_sent, "errors_sent")                           \
    X(limit_hits, "limit_refusals")                         \
    X(points_sent, "points_sent")                           \
    X(pixel_samples_sent, "pixel_samples_sent")             \
    X(jobs_accepted, "jobs_accepted")                       \
    X(jobs_done, "jobs_done")                               \
    X(jobs_failed, "jobs_failed")                           \
    X(jobs_cancelled, "jobs_cancelled")                     \
    X(jobs_timed_out, "jobs_timed_out")                     \
    X(reloads, "config_reloads")                            \
    X(jobs_dropped, "jobs_dropped")                         \
    X(auth_failures, "auth_failures")                       \
    X(auth_lockouts, "auth_lockouts")                       \
    X(peer_conn_refusals, "refused_connections_per_peer")   \
    X(out_waits, "out_buffer_waits")                        \
    X(jobs_conn_refusals, "refused_jobs_per_conn")          \
    X(jobs_refusals, "refused_jobs")                        \
    X(cancel_refusals, "refused_cancels_per_conn")          \
    X(memory_refusals, "refused_job_memory")                \
    X(memory_waits, "job_memory_waits")                     \
    X(memory_backfills, "job_memory_backfills")             \
    X(sessions_opened, "sessions_opened")                   \
    X(sessions_done, "sessions_done")                       \
    X(sessions_failed, "sessions_failed")                   \
    X(sessions_closed, "sessions_closed")                   \
    X(sessions_parked, "sessions_parked")                   \
    X(sessions_resumed, "sessions_resumed")                 \
    X(sessions_expired, "sessions_expired")                 \
    X(sessions_refused, "refused_sessions")                 \
    X(session_values_refused, "refused_session_values")     \
    X(session_batches, "session_batches")                   \
    X(session_values, "session_values")                     \
    X(session_nonfinite, "session_nonfinite_values")

/* Message type codes counted in requests[]: every code is below it
 * (stats.c asserts it for each message of QMC_MSG_MAP), the same bound
 * as the dispatch table's (server.h, QMCD_ROUTE_TYPES). */
#define QMCD_STATS_TYPES 64

/* Requests answered in one loop turn whose latency is recorded when the
 * turn ends, with one clock read for all of them (qmcd_stats_end_turn). */
#define QMCD_LAT_PENDING 256

/* Latency buckets: 8 per power of two of microseconds, up to 2^40 us. */
#define QMCD_LAT_SUB 8
#define QMCD_LAT_BUCKETS (41 * QMCD_LAT_SUB)

typedef struct qmcd_stats {
#define QMCD__STAT_FIELD(field, name) uint64_t field;
    QMCD_STATS_MAP(QMCD__STAT_FIELD)
#undef QMCD__STAT_FIELD
    /* Gauge: bytes max-jobs-memory-total has reserved for running jobs
     * (the pool's; copied in, like memory_waits, when STATS is asked). */
    uint64_t memory_reserved;
    uint64_t memory_waiting;   /* gauge: 1 while a job waits for its memory */
    /* Gauges kept by session_store.c: sessions open (attached or parked),
     * of them parked, and the bytes they reserve. */
    uint64_t sessions_open, sessions_parked_now, sessions_memory;
    uint64_t requests[QMCD_STATS_TYPES]; /* by message type code */
    uint64_t lat[QMCD_LAT_BUCKETS];
    uint64_t lat_count;
    uint64_t lat_sum_us;       /* sum of the recorded latencies */
    int64_t pending[QMCD_LAT_PENDING]; /* start times answered this loop turn */
    uint32_t n_pending;
} qmcd_stats;

/* Records one request's handling time, from its frame being decoded to its
 * final answer being queued. */
void qmcd_stats_latency(qmcd_stats *s, int64_t micros);

/*
 * A request answered now, received at t0_us: its latency ends with the
 * current loop turn.  Returns 1 when the pending list is full and the
 * caller must call qmcd_stats_end_turn before the next one.
 */
int qmcd_stats_answered(qmcd_stats *s, int64_t t0_us);

/* Records every pending request's latency as now_us - its start. */
void qmcd_stats_end_turn(qmcd_stats *s, int64_t now_us);

/* The latency below which a fraction q (0..1) of requests fell: the upper
 * edge of the bucket holding that rank, 0 with no requests. */
uint64_t qmcd_stats_quantile_us(const qmcd_stats *s, double q);

/* STATS also reports the histogram coarsely, for Prometheus
 * (`qmc stats --format prometheus`): latency_le_us_T counts the requests
 * of at most T microseconds, for T = 2^k - 1, k = 4, 6, ..., 34, each an
 * exact edge of the fine buckets; latency_count is the +Inf bucket. */
#define QMCD_LAT_EXPORT_BUCKETS 16

/*
 * Fills entries (names point at static strings) with every counter and the
 * gauges given; returns the number filled (<= cap).
 */
uint32_t qmcd_stats_entries(const qmcd_stats *s, uint64_t conns_open, uint64_t jobs_open,
                            qmc_stat *entries, uint32_t cap);

#endif
