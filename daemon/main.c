/*
 * main.c - qmcd's process: configuration, signals, daemonizing, readiness
 * (log line, --ready-file, sd_notify READY=1), the loop, and an orderly
 * exit.  Exit status: 0 after SIGTERM/SIGINT, 1 when the service cannot
 * start (a listener, threads), 2 for bad usage or configuration.
 *
 * Without --foreground qmcd forks: the parent waits on a pipe until the
 * child is listening and then exits 0, or exits 1 if the child failed, so
 * `qmcd && client` never races; the child calls setsid and keeps stderr
 * for its log.  Under systemd the unit runs `qmcd --foreground` with
 * Type=notify instead.
 *
 * This file must not serve requests; it wires the modules together.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <malloc.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <systemd/sd-daemon.h>
#include <unistd.h>

#include "auth.h"
#include "conn.h"
#include "listen.h"
#include "log.h"
#include "loop.h"
#include "modbus_bridge.h"
#include "modules.h"
#include "peers.h"
#include "pool.h"
#include "reload.h"

/* Writes the bound addresses, one per line, to path via a rename so that a
 * reader never sees a half-written file.  The temporary file is made by
 * mkstemp (O_EXCL, a random name): a fixed "PATH.tmp" opened with fopen
 * followed whatever link another user had planted under that name when
 * the ready file sits in a shared directory such as /tmp, and qmcd (often
 * root) wrote through it (issue 22, finding 6's daemon side). */
static int write_ready_file(const qmcd_server *srv, const char *path)
{
    char tmp[QMCD_PATH_BYTES + 8];
    int len = snprintf(tmp, sizeof tmp, "%s.XXXXXX", path);
    if (len < 0 || (size_t)len >= sizeof tmp) {
        errno = ENAMETOOLONG;
        return -1;
    }
    int fd = mkstemp(tmp);
    if (fd < 0)
        return -1;
    /* mkstemp makes it 0600; the ready file keeps what fopen gave it. */
    mode_t mask = umask(0);
    umask(mask);
    FILE *f = fchmod(fd, 0666 & ~mask) == 0 ? fdopen(fd, "w") : NULL;
    if (!f) {
        int err = errno;
        close(fd);
        unlink(tmp);
        errno = err;
        return -1;
    }
    fprintf(f, "pid %ld\n", (long)getpid());
    for (unsigned i = 0; i < srv->n_listeners; i++)
        fprintf(f, "%s\n", srv->listeners[i].name);
    qmcd_modbus_write_names(srv, f);
    if (fclose(f) != 0 || rename(tmp, path) != 0) {
        unlink(tmp);
        return -1;
    }
    return 0;
}

/* Forks; returns in the child with *ready_fd set, or exits in the parent
 * once the child reports (one byte: ready) or dies (EOF: failed). */
/* Makes a relative path absolute against the current directory, in place
 * (bytes long); returns -1 if it would not fit.  Done before daemonize()
 * changes directory to "/". */
static int absolutize(char *path, size_t bytes)
{
    if (path[0] == '\0' || path[0] == '/')
        return 0;
    char cwd[QMCD_PATH_BYTES], tmp[QMCD_PATH_BYTES];
    if (!getcwd(cwd, sizeof cwd))
        return -1;
    int n = snprintf(tmp, sizeof tmp, "%s/%s", cwd, path);
    if (n < 0 || (size_t)n >= bytes || (size_t)n >= sizeof tmp)
        return -1;
    memcpy(path, tmp, (size_t)n + 1);
    return 0;
}

static void daemonize(int *ready_fd)
{
    int p[2];
    if (pipe2(p, O_CLOEXEC) != 0) {
        fprintf(stderr, "qmcd: pipe: %s\n", strerror(errno));
        exit(1);
    }
    pid_t pid = fork();
    if (pid < 0) {
        fprintf(stderr, "qmcd: fork: %s\n", strerror(errno));
        exit(1);
    }
    if (pid > 0) {
        close(p[1]);
        char c;
        ssize_t n;
        do
            n = read(p[0], &c, 1);
        while (n < 0 && errno == EINTR);
        _exit(n == 1 ? 0 : 1);
    }
    close(p[0]);
    setsid();
    if (chdir("/") != 0) {
        /* Not fatal: relative paths were made absolute before. */
    }
    int null = open("/dev/null", O_RDWR | O_CLOEXEC);
    if (null >= 0) {
        dup2(null, STDIN_FILENO);
        dup2(null, STDOUT_FILENO);
        if (null > STDERR_FILENO)
            close(null);
    }
    *ready_fd = p[1];
}

int main(int argc, char **argv)
{
    qmcd_server srv;
    memset(&srv, 0, sizeof srv);
    int rc = qmcd_args_parse(argc, argv, &srv.args);
    if (rc != 0)
        return rc > 0 ? 0 : 2;
    char why[512];
    qmcd_log_init();
    static char base_dir[QMCD_PATH_BYTES]; /* read again on every SIGHUP */
    if (getcwd(base_dir, sizeof base_dir))
        srv.args.base_dir = base_dir;
    if (qmcd_config_load(&srv.args, &srv.cfg, why, sizeof why) != 0) {
        fprintf(stderr, "qmcd: %s\n", why);
        return 2;
    }
    if (srv.args.check_only) {
        /* The key file's rule (mode, size) is checked too; whether a TCP
         * listener is off loopback is only known once it is resolved, at
         * start. */
        qmcd_auth *a = NULL;
        const char *problem = NULL;
        if (qmcd_auth_new(&a) != 0)
            problem = "cannot initialise libsodium";
        else if (qmcd_auth_load_key(a, &srv.cfg, why, sizeof why) != 0)
            problem = why;
        qmcd_auth_free(a);
        if (problem) {
            fprintf(stderr, "qmcd: %s\n", problem);
            return 2;
        }
        printf("qmcd: %s: configuration is valid\n",
               srv.args.config_path ? srv.args.config_path : QMCD_DEFAULT_CONFIG);
        return 0;
    }
    qmcd_log_set_level(srv.cfg.log_level);
    /* Signals are read from a signalfd: block them before any thread
     * exists so every worker inherits the mask. */
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGTERM);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGHUP);
    sigprocmask(SIG_BLOCK, &set, NULL);
    signal(SIGPIPE, SIG_IGN);
    srv.epfd = srv.sig.fd = srv.tick.fd = srv.done.fd = -1;
    /* An FNV pass over all 21201 dimensions' numbers: once, not per HELLO. */
    srv.sobol_table_hash = qmc_sobol_table_hash();
    /* The key before the listeners: a listener off loopback is refused
     * without one, before it is bound. */
    if (qmcd_auth_new(&srv.auth) != 0) {
        fprintf(stderr, "qmcd: cannot initialise libsodium\n");
        return 1;
    }
    if (qmcd_auth_load_key(srv.auth, &srv.cfg, why, sizeof why) != 0) {
        fprintf(stderr, "qmcd: %s\n", why);
        qmcd_auth_free(srv.auth);
        return 2;
    }
    if (qmcd_listeners_open(&srv, why, sizeof why) != 0) {
        fprintf(stderr, "qmcd: %s\n", why);
        free(srv.listeners);
        qmcd_auth_free(srv.auth);
        return 1;
    }
    if (qmcd_modbus_open(&srv, why, sizeof why) != 0) {
        fprintf(stderr, "qmcd: %s\n", why);
        qmcd_listeners_close(&srv);
        free(srv.listeners);
        qmcd_auth_free(srv.auth);
        return 1;
    }
    /* Under systemd (a notify socket is given) qmcd never forks: the unit
     * tracks the process it started, and a forked child's notifications
     * would come from a PID that NotifyAccess=main ignores. */
    if (!srv.cfg.foreground && getenv("NOTIFY_SOCKET")) {
        qmcd_info("NOTIFY_SOCKET is set: staying in the foreground");
        srv.cfg.foreground = 1;
    }
    int ready_fd = -1;
    static char config_abs[QMCD_PATH_BYTES]; /* outlives main's frame use */
    if (!srv.cfg.foreground) {
        /* daemonize() moves to "/": the config file (reloaded on SIGHUP),
         * the ready file and the socket files we remove at exit must not
         * be relative any more. */
        int bad = absolutize(srv.cfg.ready_file, sizeof srv.cfg.ready_file);
        for (unsigned i = 0; i < srv.n_listeners && !bad; i++)
            bad = absolutize(srv.listeners[i].path, sizeof srv.listeners[i].path);
        if (!bad && srv.args.config_path) {
            if (strlen(srv.args.config_path) >= sizeof config_abs)
                bad = -1;
            else {
                strcpy(config_abs, srv.args.config_path);
                bad = absolutize(config_abs, sizeof config_abs);
                srv.args.config_path = config_abs;
            }
        }
        if (bad) {
            fprintf(stderr, "qmcd: a path is too long to make absolute before detaching\n");
            qmcd_modbus_close(&srv);
            qmcd_listeners_close(&srv);
            return 1;
        }
        daemonize(&ready_fd);
    }
    /* Job workspaces (cubature regions, block sums) are large, short-lived
     * and freed on runner threads.  After the first such free glibc raises
     * its mmap threshold (up to 32 MiB), and serves the next ones from
     * per-thread arenas that keep their pages once freed: RSS would then
     * follow the most jobs each runner ever held, not the ones running
     * (seen: 7 jobs of 24 MiB, 2 at a time, left VmRSS +194 MB).  A fixed
     * threshold turns the dynamic one off: 1 MiB and up is always mapped
     * and goes back to the kernel on free, so max-jobs-memory-total and
     * out-buffer-total-bytes bound what qmcd really holds. */
    if (mallopt(M_MMAP_THRESHOLD, 1 << 20) != 1) /* AddressSanitizer's allocator */
        qmcd_info("mallopt(M_MMAP_THRESHOLD) refused: freed job memory may stay in RSS");
    long cpus = sysconf(_SC_NPROCESSORS_ONLN);
    unsigned threads = srv.cfg.threads ? (unsigned)srv.cfg.threads
                                       : (unsigned)(cpus > 0 ? cpus : 1);
    int err = qmcd_pool_new(threads, &srv.pool);
    if (!err) {
        qmcd_pool_set_memory_total(srv.pool, srv.cfg.max_jobs_memory_total);
        qmcd_pool_set_overtakes(srv.pool, (unsigned)srv.cfg.job_memory_overtakes);
    }
    if (!err)
        err = qmcd_peers_new(&srv.peers);
    if (!err)
        err = qmcd_peers_new(&srv.preauth_nets);
    if (!err)
        err = qmcd_loop_init(&srv);
    /* The request modules (modules.h) after the loop: some watch a
     * descriptor. */
    if (!err && qmcd_modules_open(&srv, why, sizeof why) != 0) {
        qmcd_err("cannot start: %s", why);
        rc = 1;
        goto out;
    }
    if (!err)
        err = qmcd_listeners_start(&srv);
    if (!err) /* after the fork: the serial threads start here */
        err = qmcd_modbus_start(&srv);
    if (err) {
        qmcd_err("cannot start: %s", strerror(-err));
        rc = 1;
        goto out;
    }
    if (srv.cfg.ready_file[0] && write_ready_file(&srv, srv.cfg.ready_file) != 0) {
        qmcd_err("--ready-file %s: %s", srv.cfg.ready_file, strerror(errno));
        rc = 1;
        goto out;
    }
    qmcd_notice("ready: pid %ld, %u worker threads, max-connections %llu", (long)getpid(),
                threads, (unsigned long long)srv.cfg.max_connections);
    qmcd_notify(&srv, "READY=1\nSTATUS=serving");
    if (ready_fd >= 0) {
        if (write(ready_fd, "r", 1) != 1) {
            /* The parent is gone; carry on. */
        }
        close(ready_fd);
        ready_fd = -1;
    }
    rc = qmcd_loop_run(&srv) == 0 ? 0 : 1;
    qmcd_notice("exiting (%s)", rc == 0 ? "clean" : "loop error");
out:
    qmcd_listeners_close(&srv);
    if (srv.conns)
        qmcd_conns_close_all(&srv, "exiting");
    while (srv.conns)
        qmcd_conn_close(srv.conns, "exiting");
    qmcd_conns_reap(&srv);
    qmcd_modbus_close(&srv);
    qmcd_modules_close(&srv);
    qmcd_pool_free(srv.pool, srv.n_jobs != 0);
    qmcd_peers_free(srv.peers);
    qmcd_peers_free(srv.preauth_nets);
    qmcd_loop_close(&srv);
    free(srv.listeners);
    qmcd_auth_free(srv.auth);
    if (srv.cfg.ready_file[0])
        unlink(srv.cfg.ready_file);
    return rc;
}
