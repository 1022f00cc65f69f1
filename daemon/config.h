/*
 * config.h - qmcd's settings: defaults, `key = value` files, flags.
 */
#ifndef QMCD_CONFIG_H
#define QMCD_CONFIG_H

#include <stddef.h>
#include <stdint.h>

#define QMCD_MAX_LISTEN 16
#define QMCD_PATH_BYTES 256
#define QMCD_MODBUS_ALLOW_BYTES 2048
/* A config file larger than this is refused (the example is ~4 KiB). */
#define QMCD_CONFIG_MAX_BYTES (1 << 20)
/* The file --check-config reads when no --config is given. */
#define QMCD_DEFAULT_CONFIG "/etc/qmcd/qmcd.conf"

/* Numeric settings: X(key, field, default, min, max, reloadable).  The key
 * is both the config-file key and the flag (--key). */
#define QMCD_CONFIG_NUM_MAP(X)                                                  \
    X("threads", threads, 0, 0, 1024, 0)                                        \
    X("max-frame", max_frame, 1u << 20, 4096, 16u << 20, 1)                     \
    X("max-connections", max_connections, 1024, 1, 1u << 20, 1)                 \
    X("max-inflight", max_inflight, 32, 1, 4096, 1)                             \
    X("max-points", max_points, 1u << 26, 1, 1ull << 32, 1)                     \
    X("max-jobs", max_jobs, 64, 1, 1u << 16, 1)                                 \
    X("max-jobs-per-conn", max_jobs_per_conn, 8, 1, 1u << 16, 1)                \
    X("job-time-limit-ms", job_time_limit_ms, 600000, 1, 86400000ull * 7, 1)    \
    X("max-job-evals", max_job_evals, 1000000000ull, 1, 1ull << 50, 1)           \
    X("max-job-memory", max_job_memory, 256u << 20, 1u << 16, 1ull << 40, 1)     \
    X("max-seq-memory", max_seq_memory, 256u << 20, 1u << 20, 1ull << 40, 1)     \
    X("idle-timeout-ms", idle_timeout_ms, 300000, 100, 86400000ull * 7, 1)      \
    X("handshake-timeout-ms", handshake_timeout_ms, 10000, 100, 3600000, 1)     \
    X("frame-timeout-ms", frame_timeout_ms, 10000, 100, 3600000, 1)             \
    X("write-timeout-ms", write_timeout_ms, 60000, 100, 86400000ull, 1)         \
    X("out-buffer-bytes", out_buffer_bytes, 4u << 20, 2u << 20, 1u << 30, 1)    \
    X("max-shm-bytes", max_shm_bytes, 64u << 20, 0, 1u << 30, 1)                \
    X("shutdown-timeout-ms", shutdown_timeout_ms, 10000, 0, 3600000, 1)         \
    X("modbus-max-connections", modbus_max_connections, 256, 1, 1u << 16, 1)   \
    X("modbus-frame-timeout-ms", modbus_frame_timeout_ms, 5000, 50, 3600000, 1) \
    X("modbus-max-sessions", modbus_max_sessions, 1024, 1, 1u << 16, 1)         \
    X("modbus-max-connections-per-peer", modbus_max_connections_per_peer, 0, 0, 1u << 16, 1) \
    X("modbus-max-sessions-per-peer", modbus_max_sessions_per_peer, 0, 0, 1u << 16, 1) \
    X("max-connections-per-peer", max_connections_per_peer, 64, 1, 1u << 20, 1)  \
    X("out-buffer-total-bytes", out_buffer_total_bytes, 128u << 20, 1u << 20, 1ull << 40, 1) \
    X("max-cancels-per-conn", max_cancels_per_conn, 64, 1, 1u << 20, 1)         \
    X("auth-unix", auth_unix, 0, 0, 1, 1)                                       \
    X("auth-max-failures", auth_max_failures, 5, 1, 1000000, 1)                 \
    X("auth-lockout-ms", auth_lockout_ms, 60000, 1, 86400000ull * 7, 1)         \
    X("max-jobs-memory-total", max_jobs_memory_total, 1ull << 30, 1u << 20, 1ull << 44, 1) \
    X("job-memory-overtakes", job_memory_overtakes, 8, 0, 1u << 16, 1)           \
    X("max-sessions", max_sessions, 256, 1, 1u << 16, 1)                        \
    X("max-sessions-per-peer", max_sessions_per_peer, 32, 1, 1u << 16, 1)       \
    X("max-sessions-memory", max_sessions_memory, 512u << 20, 1u << 20, 1ull << 44, 1) \
    X("max-sessions-memory-per-peer", max_sessions_memory_per_peer, 128u << 20, 1u << 20, \
      1ull << 44, 1)                                                            \
    X("session-idle-timeout-ms", session_idle_timeout_ms, 300000, 100, 86400000ull * 7, 1)

typedef struct qmcd_config {
#define QMCD__CFG_FIELD(key, field, def, min, max, reload) uint64_t field;
    QMCD_CONFIG_NUM_MAP(QMCD__CFG_FIELD)
#undef QMCD__CFG_FIELD
    int log_level;                 /* log.h levels; reloadable */
    int foreground;
    char ready_file[QMCD_PATH_BYTES];
    char auth_key[QMCD_PATH_BYTES];  /* key file (auth.c), "" for none; reloadable */
    char listen[QMCD_MAX_LISTEN][QMCD_PATH_BYTES];
    unsigned n_listen;
    /* Modbus transports (daemon/modbus*.c): tcp:HOST:PORT or rtu:...; and
     * the clients allowed in, as the `modbus-allow` text (validated). */
    char modbus[QMCD_MAX_LISTEN][QMCD_PATH_BYTES];
    unsigned n_modbus;
    char modbus_allow[QMCD_MODBUS_ALLOW_BYTES];
} qmcd_config;

/* Flags as given, kept so SIGHUP can re-apply them over the re-read file
 * (flags win over the file, on every load). */
typedef struct qmcd_args {
    const char *config_path;       /* NULL: no file */
    int check_only;                /* --check-config: validate and exit */
    int argc;
    char **argv;                   /* the option words, re-parsed on reload */
    const char *base_dir;          /* where relative auth-key paths start (the
                                      directory qmcd started in: a daemon has
                                      moved to "/" by the time SIGHUP re-reads
                                      them), or NULL */
} qmcd_args;

void qmcd_config_defaults(qmcd_config *c);

/*
 * Parses argv into *args (only --config and --help/--version are acted on
 * here).  Returns 0, 1 when --help or --version printed and the program
 * should exit 0, or -1 after printing one line (exit 2).
 */
int qmcd_args_parse(int argc, char **argv, qmcd_args *args);

/*
 * Builds a configuration: defaults, then the file (if any), then the
 * flags.  On error writes one line ("FILE:LINE: problem") into why and
 * returns -1; *c is then unspecified.
 */
int qmcd_config_load(const qmcd_args *args, qmcd_config *c, char *why, size_t why_bytes);

/* Logs the settings that differ between old and fresh but need a restart,
 * and copies those from old into fresh (a reload never changes them). */
void qmcd_config_keep_fixed(const qmcd_config *old, qmcd_config *fresh);

/*
 * Parses config text (len bytes, not necessarily NUL-terminated; name is
 * the file name used in messages) over *c, which holds defaults or an
 * earlier layer.  No I/O: the fuzz target calls it on raw bytes.  Returns
 * 0, or -1 with one line ("NAME:LINE: problem") in why; *c may then hold
 * the keys before the bad line.
 */
int qmcd_config_parse(const char *name, const char *text, size_t len, qmcd_config *c,
                      char *why, size_t why_bytes);

void qmcd_usage(void);

#endif
