/*
 * listen.c - opening the listening sockets: unix:PATH (mode 0660, a stale
 * file from a crashed run replaced, a live one refused), tcp:HOST:PORT on
 * IPv4 or IPv6 (tcp:[::1]:0 - port 0 asks the kernel for a free port and
 * we report the one bound), and sockets passed by systemd socket
 * activation (sd_listen_fds).
 *
 * This file must not accept or serve connections (conn.c does); it only
 * creates, names, registers and removes listeners.
 */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/file.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <systemd/sd-daemon.h>
#include <unistd.h>

#include "auth.h"
#include "conn.h"
#include "listen.h"
#include "log.h"
#include "loop.h"

#define BACKLOG 511

static void name_of(int fd, char *out, size_t n)
{
    struct sockaddr_storage ss;
    socklen_t len = sizeof ss;
    char host[INET6_ADDRSTRLEN] = "?";
    if (getsockname(fd, (struct sockaddr *)&ss, &len) != 0) {
        snprintf(out, n, "fd:%d", fd);
    } else if (ss.ss_family == AF_UNIX) {
        const struct sockaddr_un *su = (const struct sockaddr_un *)&ss;
        snprintf(out, n, "unix:%s", su->sun_path[0] ? su->sun_path : "@abstract");
    } else if (ss.ss_family == AF_INET6) {
        const struct sockaddr_in6 *s6 = (const struct sockaddr_in6 *)&ss;
        inet_ntop(AF_INET6, &s6->sin6_addr, host, sizeof host);
        snprintf(out, n, "tcp:[%s]:%u", host, ntohs(s6->sin6_port));
    } else {
        const struct sockaddr_in *s4 = (const struct sockaddr_in *)&ss;
        inet_ntop(AF_INET, &s4->sin_addr, host, sizeof host);
        snprintf(out, n, "tcp:%s:%u", host, ntohs(s4->sin_port));
    }
}

/* Is someone accepting on this Unix socket path?  1 live, 0 stale (the
 * file exists but nothing listens: ECONNREFUSED), -1 with errno.  The
 * probe does not block: a live server whose backlog is full answers
 * EAGAIN, which also means live. */
static int unix_live(const struct sockaddr_un *sa)
{
    int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd < 0)
        return -1;
    int rc = connect(fd, (const struct sockaddr *)sa, sizeof *sa);
    int e = errno;
    close(fd);
    if (rc == 0 || e == EAGAIN || e == EINPROGRESS)
        return 1;
    if (e == ECONNREFUSED)
        return 0;
    errno = e;
    return -1;
}

/*
 * Serializes "probe, remove a stale file, bind, listen" between qmcd
 * instances starting on the same path at once: without it, one instance's
 * socket that is bound but not yet listening answers ECONNREFUSED and
 * would be taken for stale by the other.
 *
 * The holder removes the lock file (PATH.lock) before it lets go
 * (unlock_path), so nothing is left beside the socket.  That is safe only
 * because a waiter, once it holds the lock, checks that the file it locked
 * is still the one at PATH.lock: a waiter that had opened the file before
 * the holder removed it would otherwise hold a lock on a dead inode while a
 * third instance locks a new file, and both would go on.  Returns the
 * locked descriptor (its path in lock, of lock_bytes), or -1 with a reason.
 */
static int lock_path(const char *path, char *lock, size_t lock_bytes, char *why, size_t n)
{
    if (snprintf(lock, lock_bytes, "%s.lock", path) >= (int)lock_bytes) {
        snprintf(why, n, "unix:%s: path too long for its lock file", path);
        return -1;
    }
    for (;;) {
        int fd = open(lock, O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0600);
        if (fd < 0) {
            snprintf(why, n, "unix:%s: cannot open %s: %s", path, lock, strerror(errno));
            return -1;
        }
        if (flock(fd, LOCK_EX) != 0) {
            snprintf(why, n, "unix:%s: cannot lock %s: %s", path, lock, strerror(errno));
            close(fd);
            return -1;
        }
        struct stat held, named;
        if (fstat(fd, &held) == 0 && stat(lock, &named) == 0 &&
            held.st_dev == named.st_dev && held.st_ino == named.st_ino)
            return fd;
        close(fd); /* the holder removed it while we waited: lock the new one */
    }
}

/* Removes the lock file while still holding it, then lets go. */
static void unlock_path(int fd, const char *lock)
{
    unlink(lock);
    close(fd);
}

static int open_unix(const char *path, qmcd_listener *l, char *why, size_t n)
{
    struct sockaddr_un sa = {.sun_family = AF_UNIX};
    /* An empty path would bind Linux's abstract autobind namespace: a
     * socket no file permission protects.  Refuse it. */
    if (!path[0]) {
        snprintf(why, n, "unix: needs a socket path (unix:/run/qmcd/qmcd.sock)");
        return -1;
    }
    if (strlen(path) >= sizeof sa.sun_path) {
        snprintf(why, n, "unix:%s: path longer than %zu bytes", path, sizeof sa.sun_path - 1);
        return -1;
    }
    strcpy(sa.sun_path, path);
    char lock_file[QMCD_PATH_BYTES + 8];
    int lock = lock_path(path, lock_file, sizeof lock_file, why, n);
    if (lock < 0)
        return -1;
    int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd < 0) {
        snprintf(why, n, "unix:%s: socket: %s", path, strerror(errno));
        unlock_path(lock, lock_file);
        return -1;
    }
    for (int attempt = 0;; attempt++) {
        /* 0660 from the start: no window in which the socket is wider. */
        mode_t old = umask(0117);
        int rc = bind(fd, (struct sockaddr *)&sa, sizeof sa);
        int e = errno;
        umask(old);
        if (rc == 0)
            break;
        if (e != EADDRINUSE || attempt > 0) {
            snprintf(why, n, "unix:%s: bind: %s", path, strerror(e));
            goto fail;
        }
        int live = unix_live(&sa);
        if (live == 1) {
            snprintf(why, n, "unix:%s: another server is listening there; not starting", path);
            goto fail;
        }
        struct stat st;
        if (live < 0 && errno != ENOENT) {
            snprintf(why, n, "unix:%s: in use and cannot be probed: %s", path, strerror(errno));
            goto fail;
        }
        if (lstat(path, &st) == 0) {
            if (!S_ISSOCK(st.st_mode)) {
                snprintf(why, n, "unix:%s: exists and is not a socket; not touching it", path);
                goto fail;
            }
            if (unlink(path) != 0 && errno != ENOENT) {
                snprintf(why, n, "unix:%s: removing the stale socket: %s", path,
                         strerror(errno));
                goto fail;
            }
            qmcd_notice("unix:%s: replaced a stale socket file (nothing was listening)", path);
        }
    }
    if (listen(fd, BACKLOG) != 0) {
        snprintf(why, n, "unix:%s: listen: %s", path, strerror(errno));
        unlink(path);
        goto fail;
    }
    l->w.fd = fd;
    snprintf(l->path, sizeof l->path, "%s", path);
    snprintf(l->name, sizeof l->name, "unix:%s", path);
    unlock_path(lock, lock_file); /* listening now: the live socket speaks for itself */
    return 0;
fail:
    close(fd);
    unlock_path(lock, lock_file);
    return -1;
}

/* "HOST:PORT" or "[V6HOST]:PORT" into host and port strings. */
static int split_host_port(const char *spec, char *host, size_t hn, char *port, size_t pn)
{
    const char *colon;
    if (spec[0] == '[') {
        const char *close = strchr(spec, ']');
        if (!close || close[1] != ':')
            return -1;
        if ((size_t)(close - spec - 1) >= hn)
            return -1;
        memcpy(host, spec + 1, (size_t)(close - spec - 1));
        host[close - spec - 1] = '\0';
        colon = close + 1;
    } else {
        colon = strrchr(spec, ':');
        if (!colon || (size_t)(colon - spec) >= hn)
            return -1;
        memcpy(host, spec, (size_t)(colon - spec));
        host[colon - spec] = '\0';
    }
    if (strlen(colon + 1) >= pn || !colon[1])
        return -1;
    /* Decimal 0..65535 only: getaddrinfo would take 70000 and bind port
     * 70000 mod 65536 without a word. */
    unsigned long v = 0;
    for (const char *c = colon + 1; *c; c++) {
        if (*c < '0' || *c > '9' || (v = v * 10 + (unsigned long)(*c - '0')) > 65535)
            return -1;
    }
    strcpy(port, colon + 1);
    return 0;
}

/* Who may reach a TCP listener: anyone on the network unless it is on
 * loopback, so off loopback the daemon runs only with a key - refused
 * here before the socket is even created. */
#define NEEDS_KEY_WHY                                                                  \
    "a TCP listener off loopback needs --auth-key FILE (anyone who can reach it "      \
    "could use the daemon; see docs/SECURITY.md); use tcp:127.0.0.1:PORT or tcp::PORT " \
    "for this host only"

/* key_rule: a qmcd listener (the key rule above applies, and tcp::PORT is
 * loopback); 0 for the Modbus listeners, which share the socket code but
 * not the rule - Modbus has no authentication, and modbus-allow
 * (modbus_tcp.c) guards them instead. */
static int open_tcp(const char *spec, qmcd_listener *l, int key_rule, int have_key, char *why,
                    size_t n)
{
    char host[256], port[32];
    if (split_host_port(spec, host, sizeof host, port, sizeof port) != 0) {
        snprintf(why, n, "tcp:%s: want tcp:HOST:PORT or tcp:[IPV6]:PORT, PORT 0..65535", spec);
        return -1;
    }
    /* tcp::PORT is loopback: every interface has to be asked for by
     * name (tcp:0.0.0.0:PORT, tcp:[::]:PORT), and then needs a key.  (The
     * Modbus listeners keep getaddrinfo's passive default.) */
    struct addrinfo hints = {.ai_family = AF_UNSPEC, .ai_socktype = SOCK_STREAM,
                             .ai_flags = (key_rule ? 0 : AI_PASSIVE) | AI_NUMERICSERV};
    struct addrinfo *res = NULL;
    int gai = getaddrinfo(host[0] ? host : key_rule ? "127.0.0.1" : NULL, port, &hints, &res);
    if (gai != 0) {
        snprintf(why, n, "tcp:%s: %s", spec, gai_strerror(gai));
        return -1;
    }
    l->needs_key = key_rule && !qmcd_auth_is_loopback(res->ai_addr);
    if (l->needs_key && !have_key) {
        snprintf(why, n, "tcp:%s: %s", spec, NEEDS_KEY_WHY);
        freeaddrinfo(res);
        return -1;
    }
    int fd = socket(res->ai_family, res->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC,
                    res->ai_protocol);
    if (fd < 0) {
        snprintf(why, n, "tcp:%s: socket: %s", spec, strerror(errno));
        freeaddrinfo(res);
        return -1;
    }
    int one = 1;
    setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    if (res->ai_family == AF_INET6) /* [::] means IPv6 only; list 0.0.0.0 too */
        setsockopt(fd, IPPROTO_IPV6, IPV6_V6ONLY, &one, sizeof one);
    if (bind(fd, res->ai_addr, res->ai_addrlen) != 0 || listen(fd, BACKLOG) != 0) {
        snprintf(why, n, "tcp:%s: %s", spec, strerror(errno));
        freeaddrinfo(res);
        close(fd);
        return -1;
    }
    freeaddrinfo(res);
    l->w.fd = fd;
    l->path[0] = '\0';
    name_of(fd, l->name, sizeof l->name);
    return 0;
}

int qmcd_listen_tcp(const char *hostport, qmcd_listener *l, char *why, size_t why_bytes)
{
    return open_tcp(hostport, l, 0, 0, why, why_bytes);
}

static const char *default_socket(char *buf, size_t n)
{
    /* systemd's RuntimeDirectory= (a colon-separated list; the first). */
    const char *rd = getenv("RUNTIME_DIRECTORY");
    if (rd && *rd) {
        size_t len = strcspn(rd, ":");
        snprintf(buf, n, "%.*s/qmcd.sock", (int)len, rd);
        return buf;
    }
    if (mkdir("/run/qmcd", 0755) != 0 && errno != EEXIST)
        qmcd_warn("mkdir /run/qmcd: %s", strerror(errno));
    snprintf(buf, n, "/run/qmcd/qmcd.sock");
    return buf;
}

int qmcd_listeners_open(qmcd_server *srv, char *why, size_t why_bytes)
{
    const qmcd_config *cfg = &srv->cfg;
    int passed = sd_listen_fds(1);
    if (passed < 0)
        passed = 0;
    unsigned want = (unsigned)passed + cfg->n_listen;
    char def[QMCD_PATH_BYTES];
    const char *default_path = NULL;
    if (want == 0) {
        default_path = default_socket(def, sizeof def);
        want = 1;
    }
    srv->listeners = calloc(want, sizeof *srv->listeners);
    if (!srv->listeners) {
        snprintf(why, why_bytes, "out of memory");
        return -1;
    }
    srv->n_listeners = 0;
    for (int i = 0; i < passed; i++) {
        qmcd_listener *l = &srv->listeners[srv->n_listeners++];
        l->w.fd = SD_LISTEN_FDS_START + i;
        /* systemd hands over blocking sockets; the loop needs non-blocking. */
        if (sd_is_socket(l->w.fd, AF_UNSPEC, SOCK_STREAM, 1) <= 0) {
            snprintf(why, why_bytes, "socket activation: fd %d is not a listening stream socket",
                     l->w.fd);
            goto fail;
        }
        int flags = fcntl(l->w.fd, F_GETFL);
        if (flags < 0 || fcntl(l->w.fd, F_SETFL, flags | O_NONBLOCK) != 0 ||
            fcntl(l->w.fd, F_SETFD, FD_CLOEXEC) != 0) {
            snprintf(why, why_bytes, "socket activation: fd %d: %s", l->w.fd, strerror(errno));
            goto fail;
        }
        name_of(l->w.fd, l->name, sizeof l->name);
        l->path[0] = '\0'; /* systemd owns the file */
        struct sockaddr_storage ss;
        socklen_t sl = sizeof ss;
        if (getsockname(l->w.fd, (struct sockaddr *)&ss, &sl) == 0 &&
            (ss.ss_family == AF_INET || ss.ss_family == AF_INET6))
            l->needs_key = !qmcd_auth_is_loopback((struct sockaddr *)&ss);
        if (l->needs_key && !qmcd_auth_has_key(srv->auth)) {
            snprintf(why, why_bytes, "socket activation: %s: %s", l->name, NEEDS_KEY_WHY);
            goto fail;
        }
    }
    for (unsigned i = 0; i < cfg->n_listen || default_path; i++) {
        const char *spec = default_path ? NULL : cfg->listen[i];
        qmcd_listener *l = &srv->listeners[srv->n_listeners];
        int rc;
        if (default_path)
            rc = open_unix(default_path, l, why, why_bytes);
        else if (strncmp(spec, "unix:", 5) == 0)
            rc = open_unix(spec + 5, l, why, why_bytes);
        else
            rc = open_tcp(spec + 4, l, 1, qmcd_auth_has_key(srv->auth), why, why_bytes);
        if (rc != 0)
            goto fail;
        srv->n_listeners++;
        if (default_path)
            break;
    }
    return 0;
fail:
    qmcd_listeners_close(srv);
    return -1;
}

int qmcd_listeners_start(qmcd_server *srv)
{
    for (unsigned i = 0; i < srv->n_listeners; i++) {
        qmcd_listener *l = &srv->listeners[i];
        l->w.on_event = qmcd_conn_on_accept;
        int err = qmcd_loop_add(srv, &l->w, EPOLLIN);
        if (err)
            return err;
        qmcd_info("listening on %s", l->name);
    }
    return 0;
}

void qmcd_listeners_close(qmcd_server *srv)
{
    for (unsigned i = 0; i < srv->n_listeners; i++) {
        qmcd_listener *l = &srv->listeners[i];
        if (l->w.fd < 0)
            continue;
        if (l->w.events)
            qmcd_loop_del(srv, &l->w);
        close(l->w.fd);
        l->w.fd = -1;
        if (l->path[0] && unlink(l->path) != 0 && errno != ENOENT)
            qmcd_warn("removing %s: %s", l->path, strerror(errno));
        l->path[0] = '\0';
    }
}
