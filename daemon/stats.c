/*
 * stats.c - counters and a log-linear latency histogram (8 buckets per
 * power of two, so a percentile is within 12.5% of the true value) in
 * fixed memory: recording is O(1) and nothing grows with traffic.
 *
 * This file must not do I/O or read the clock; callers pass durations.
 */
#include <string.h>

#include "stats.h"

static unsigned bucket_of(uint64_t us)
{
    if (us < QMCD_LAT_SUB)
        return (unsigned)us;
    unsigned msb = 63u - (unsigned)__builtin_clzll(us); /* >= 3 */
    unsigned sub = (unsigned)(us >> (msb - 3)) & (QMCD_LAT_SUB - 1);
    unsigned b = (msb - 2) * QMCD_LAT_SUB + sub;
    return b < QMCD_LAT_BUCKETS ? b : QMCD_LAT_BUCKETS - 1;
}

/* The largest value that falls in bucket b. */
static uint64_t bucket_top(unsigned b)
{
    if (b < QMCD_LAT_SUB)
        return b;
    unsigned msb = b / QMCD_LAT_SUB + 2, sub = b % QMCD_LAT_SUB;
    return (((uint64_t)(QMCD_LAT_SUB + sub + 1)) << (msb - 3)) - 1;
}

void qmcd_stats_latency(qmcd_stats *s, int64_t micros)
{
    uint64_t us = micros < 0 ? 0 : (uint64_t)micros;
    s->lat[bucket_of(us)]++;
    s->lat_count++;
    s->lat_sum_us += us;
}

int qmcd_stats_answered(qmcd_stats *s, int64_t t0_us)
{
    s->pending[s->n_pending++] = t0_us;
    return s->n_pending == QMCD_LAT_PENDING;
}

void qmcd_stats_end_turn(qmcd_stats *s, int64_t now_us)
{
    for (uint32_t i = 0; i < s->n_pending; i++)
        qmcd_stats_latency(s, now_us - s->pending[i]);
    s->n_pending = 0;
}

uint64_t qmcd_stats_quantile_us(const qmcd_stats *s, double q)
{
    if (s->lat_count == 0)
        return 0;
    /* rank = ceil(q * count), at least 1 */
    uint64_t rank = (uint64_t)(q * (double)s->lat_count);
    if ((double)rank < q * (double)s->lat_count)
        rank++;
    if (rank == 0)
        rank = 1;
    uint64_t seen = 0;
    for (unsigned b = 0; b < QMCD_LAT_BUCKETS; b++) {
        seen += s->lat[b];
        if (seen >= rank)
            return bucket_top(b);
    }
    return bucket_top(QMCD_LAT_BUCKETS - 1);
}

static const struct {
    int code;
    char dir;
    const char *name;
} request_names[] = {
#define QMCD__REQ_NAME(name, code, dir) {code, dir, "requests_" #name},
    QMC_MSG_MAP(QMCD__REQ_NAME)
#undef QMCD__REQ_NAME
};

#define QMCD__REQ_FITS(name, code, dir) \
    _Static_assert((code) < QMCD_STATS_TYPES, "qmcd_stats.requests is indexed by message type");
QMC_MSG_MAP(QMCD__REQ_FITS)
#undef QMCD__REQ_FITS

/* The names of the exported cumulative buckets, 2^k - 1 us for k = 4, 6,
 * ..., 34 (QMCD_LAT_EXPORT_BUCKETS of them). */
static const char *const export_bucket_names[QMCD_LAT_EXPORT_BUCKETS] = {
    "latency_le_us_15",         "latency_le_us_63",         "latency_le_us_255",
    "latency_le_us_1023",       "latency_le_us_4095",       "latency_le_us_16383",
    "latency_le_us_65535",      "latency_le_us_262143",     "latency_le_us_1048575",
    "latency_le_us_4194303",    "latency_le_us_16777215",   "latency_le_us_67108863",
    "latency_le_us_268435455",  "latency_le_us_1073741823", "latency_le_us_4294967295",
    "latency_le_us_17179869183",
};

/* Requests of at most 2^k - 1 us: the fine buckets whose top is <= that
 * (2^k - 1 is the top of bucket (k - 3) * 8 + 7, so the count is exact). */
static uint64_t count_at_most(const qmcd_stats *s, unsigned k)
{
    uint64_t edge = (1ull << k) - 1, n = 0;
    for (unsigned b = 0; b < QMCD_LAT_BUCKETS && bucket_top(b) <= edge; b++)
        n += s->lat[b];
    return n;
}

uint32_t qmcd_stats_entries(const qmcd_stats *s, uint64_t conns_open, uint64_t jobs_open,
                            qmc_stat *e, uint32_t cap)
{
    uint32_t n = 0;
#define QMCD__PUT(text, v)                                                     \
    do {                                                                       \
        if (n < cap) {                                                         \
            e[n].name.ptr = (text);                                            \
            e[n].name.len = (uint32_t)strlen(text);                            \
            e[n].value = (v);                                                  \
            n++;                                                               \
        }                                                                      \
    } while (0)
#define QMCD__STAT_PUT(field, name) QMCD__PUT(name, s->field);
    QMCD_STATS_MAP(QMCD__STAT_PUT)
#undef QMCD__STAT_PUT
    QMCD__PUT("connections_open", conns_open);
    QMCD__PUT("jobs_open", jobs_open);
    QMCD__PUT("job_memory_reserved_bytes", s->memory_reserved);
    QMCD__PUT("job_memory_waiting", s->memory_waiting);
    QMCD__PUT("sessions_open", s->sessions_open);
    QMCD__PUT("sessions_parked_now", s->sessions_parked_now);
    QMCD__PUT("session_memory_reserved_bytes", s->sessions_memory);
    for (size_t i = 0; i < sizeof request_names / sizeof request_names[0]; i++) {
        /* only what clients send: requests_HELLO, requests_PING, ...,
         * requests_SHM_RELEASE; a message added to the map appears here */
        if (request_names[i].dir == 'C')
            QMCD__PUT(request_names[i].name, s->requests[request_names[i].code]);
    }
    QMCD__PUT("latency_count", s->lat_count);
    QMCD__PUT("latency_p50_us", qmcd_stats_quantile_us(s, 0.50));
    QMCD__PUT("latency_p99_us", qmcd_stats_quantile_us(s, 0.99));
    QMCD__PUT("latency_p999_us", qmcd_stats_quantile_us(s, 0.999));
    QMCD__PUT("latency_sum_us", s->lat_sum_us);
    for (unsigned i = 0; i < QMCD_LAT_EXPORT_BUCKETS; i++)
        QMCD__PUT(export_bucket_names[i], count_at_most(s, 4 + 2 * i));
#undef QMCD__PUT
    return n;
}
