/*
 * outfile.c - output files that never clobber what they should not: the
 * checks, the temporary file beside the target, fsync then rename, and the
 * signal handler that removes temporary files (the rules are in
 * outfile.h).  Must not: replace a device, FIFO or read-only file, leave a
 * temporary file behind, or print more than one line per error.
 */
/* realpath(3) and S_ISVTX are XSI. */
#define _XOPEN_SOURCE 700
#include "outfile.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cli.h"

/* ---- the signal cleanup table ----------------------------------------------
 * The one piece of global state in the CLI, because a signal handler can
 * reach nothing else.  A slot holds the name of a temporary file while it
 * exists; the handler unlinks each and lets the signal kill us.  Slots are
 * filled and emptied with these signals blocked, so the handler never sees
 * a half-made entry, and the strings stay allocated while registered. */
static char *volatile cleanup_paths[CLI_OUTFILE_MAX];
static volatile sig_atomic_t cleanup_installed;
static const int cleanup_signals[] = {SIGINT, SIGTERM, SIGHUP, SIGQUIT};
#define N_CLEANUP_SIGNALS (sizeof cleanup_signals / sizeof cleanup_signals[0])

static void on_fatal_signal(int sig)
{
    /* unlink, sigaction and raise are async-signal-safe (POSIX.1-2008
     * 2.4.3); nothing else is called here. */
    for (int i = 0; i < CLI_OUTFILE_MAX; i++) {
        char *p = cleanup_paths[i];
        if (p)
            unlink(p);
    }
    struct sigaction dfl;
    memset(&dfl, 0, sizeof dfl);
    dfl.sa_handler = SIG_DFL;
    sigemptyset(&dfl.sa_mask);
    sigaction(sig, &dfl, NULL);
    raise(sig); /* delivered, with the default action, once we return */
}

static void install_cleanup(void)
{
    if (cleanup_installed)
        return;
    cleanup_installed = 1;
    for (size_t i = 0; i < N_CLEANUP_SIGNALS; i++) {
        struct sigaction old, sa;
        /* A signal the caller ignores (nohup, a shell's background job)
         * stays ignored. */
        if (sigaction(cleanup_signals[i], NULL, &old) == 0 && old.sa_handler == SIG_IGN)
            continue;
        memset(&sa, 0, sizeof sa);
        sa.sa_handler = on_fatal_signal;
        sigemptyset(&sa.sa_mask);
        for (size_t k = 0; k < N_CLEANUP_SIGNALS; k++)
            sigaddset(&sa.sa_mask, cleanup_signals[k]);
        sigaction(cleanup_signals[i], &sa, NULL);
    }
}

static void block_signals(sigset_t *old)
{
    sigset_t set;
    sigemptyset(&set);
    for (size_t i = 0; i < N_CLEANUP_SIGNALS; i++)
        sigaddset(&set, cleanup_signals[i]);
    sigprocmask(SIG_BLOCK, &set, old);
}

static void restore_signals(const sigset_t *old)
{
    sigprocmask(SIG_SETMASK, old, NULL);
}

static void unregister(cli_outfile *o)
{
    if (o->slot >= 0)
        cleanup_paths[o->slot] = NULL;
    o->slot = -1;
}

/* ---- the checks ---------------------------------------------------------------- */

static mode_t new_file_mode(void)
{
    mode_t mask = umask(0);
    umask(mask);
    return 0666 & ~mask;
}

/* The directory part of path ("." when there is none), malloc'd. */
static char *dir_of(const char *path)
{
    const char *slash = strrchr(path, '/');
    if (!slash)
        return strdup(".");
    if (slash == path)
        return strdup("/");
    return strndup(path, (size_t)(slash - path));
}

/* May the regular file at path (stat st) be replaced?  0, or an error
 * printed and CLI_EXIT_FAIL. */
static int check_replaceable(const cli_outfile *o, const char *path, const struct stat *st)
{
    if ((st->st_mode & 0222) == 0)
        return cli_error("%s: '%s' is read-only (mode %04o): refusing to replace it",
                         o->what, path, (unsigned)(st->st_mode & 07777));
    if (faccessat(AT_FDCWD, path, W_OK, AT_EACCESS) != 0)
        return cli_error("%s: '%s' is not writable by you: %s", o->what, path,
                         strerror(errno));
    if (st->st_uid == geteuid())
        return 0;
    if (geteuid() != 0)
        return cli_error("%s: '%s' belongs to uid %u: replacing it would take it from "
                         "its owner (write to a new name)", o->what, path,
                         (unsigned)st->st_uid);
    char *dir = dir_of(path);
    struct stat ds;
    int sticky = dir && stat(dir, &ds) == 0 && (ds.st_mode & S_ISVTX);
    int rc = 0;
    if (sticky)
        rc = cli_error("%s: '%s' belongs to uid %u in the sticky directory '%s': "
                       "refusing to replace it", o->what, path, (unsigned)st->st_uid, dir);
    free(dir);
    return rc;
}

/* A device or FIFO: opened and written in place. */
static int open_in_place(cli_outfile *o, const char *path, const struct stat *st)
{
    if (S_ISDIR(st->st_mode))
        return cli_error("%s: '%s' is a directory", o->what, path);
    if (!S_ISCHR(st->st_mode) && !S_ISFIFO(st->st_mode))
        return cli_error("%s: '%s' is not a regular file, a character device or a FIFO",
                         o->what, path);
    int fd = open(path, O_WRONLY | O_NOCTTY | O_CLOEXEC);
    if (fd < 0)
        return cli_error("%s: cannot open '%s': %s", o->what, path, strerror(errno));
    o->target = strdup(path);
    o->f = o->target ? fdopen(fd, "wb") : NULL;
    if (!o->f) {
        close(fd);
        free(o->target);
        o->target = NULL;
        return cli_error("%s: out of memory", o->what);
    }
    return 0;
}

int cli_outfile_open(cli_outfile *o, const char *path, const char *what)
{
    memset(o, 0, sizeof *o);
    o->slot = -1;
    o->what = what;
    if (!path || !path[0])
        return cli_error("%s: the file name is empty", what);
    struct stat st;
    mode_t mode;
    int exists = stat(path, &st) == 0;
    if (!exists && errno != ENOENT)
        return cli_error("%s: cannot use '%s': %s", what, path, strerror(errno));
    if (exists && !S_ISREG(st.st_mode))
        return open_in_place(o, path, &st);
    if (exists) {
        /* Replace the file a symbolic link names, keeping the link. */
        o->target = realpath(path, NULL);
        if (!o->target)
            return cli_error("%s: cannot resolve '%s': %s", what, path, strerror(errno));
        if (check_replaceable(o, o->target, &st) != 0) {
            cli_outfile_abort(o);
            return CLI_EXIT_FAIL;
        }
        mode = st.st_mode & 0777;
    } else {
        struct stat ls;
        if (lstat(path, &ls) == 0)
            return cli_error("%s: '%s' is a symbolic link to a missing file", what, path);
        o->target = strdup(path);
        if (!o->target)
            return cli_error("%s: out of memory", what);
        mode = new_file_mode();
    }
    size_t len = strlen(o->target);
    o->tmp = malloc(len + 12);
    if (!o->tmp) {
        cli_outfile_abort(o);
        return cli_error("%s: out of memory", what);
    }
    memcpy(o->tmp, o->target, len);
    memcpy(o->tmp + len, ".tmp.XXXXXX", 12);
    install_cleanup();
    /* Create and register with the signals held off: a signal between the
     * two would leave the file. */
    sigset_t old;
    block_signals(&old);
    int fd = mkstemp(o->tmp);
    int err = errno;
    if (fd >= 0)
        for (int i = 0; i < CLI_OUTFILE_MAX && o->slot < 0; i++)
            if (!cleanup_paths[i]) {
                cleanup_paths[i] = o->tmp;
                o->slot = i;
            }
    restore_signals(&old);
    if (fd < 0) {
        free(o->tmp);
        o->tmp = NULL;
        cli_outfile_abort(o);
        return cli_error("%s: cannot create a file beside '%s': %s", what, path,
                         strerror(err));
    }
    if (o->slot < 0) {
        close(fd);
        cli_outfile_abort(o);
        return cli_error("%s: more than %d output files at once", what, CLI_OUTFILE_MAX);
    }
    /* Root replacing another user's file (outside a sticky directory)
     * keeps its owner; fchown first, as it may clear mode bits. */
    if (exists && st.st_uid != geteuid() && fchown(fd, st.st_uid, st.st_gid) != 0) {
        err = errno;
        close(fd);
        cli_outfile_abort(o);
        return cli_error("%s: cannot give the new '%s' its owner: %s", what, path,
                         strerror(err));
    }
    if (fchmod(fd, mode) != 0 || !(o->f = fdopen(fd, "wb"))) {
        err = errno;
        close(fd);
        cli_outfile_abort(o);
        return cli_error("%s: cannot set up '%s': %s", what, path, strerror(err));
    }
    return 0;
}

/* Flushes, fsyncs (regular files) and closes o->f.  0 or printed error. */
static int finish(cli_outfile *o)
{
    FILE *f = o->f;
    o->f = NULL;
    int err = 0;
    errno = 0;
    if (fflush(f) != 0 || ferror(f))
        err = errno ? errno : EIO;
    if (!err && o->tmp && fsync(fileno(f)) != 0)
        err = errno;
    if (fclose(f) != 0 && !err)
        err = errno;
    if (err)
        return cli_error("%s: writing '%s': %s", o->what, o->target, strerror(err));
    return 0;
}

/* Renames the finished temporary file over the target. */
static int put_in_place(cli_outfile *o)
{
    if (!o->tmp)
        return 0;
    sigset_t old;
    block_signals(&old);
    int r = rename(o->tmp, o->target);
    int err = errno;
    if (r != 0)
        unlink(o->tmp);
    unregister(o);
    restore_signals(&old);
    free(o->tmp);
    o->tmp = NULL;
    if (r != 0)
        return cli_error("%s: cannot rename into '%s': %s", o->what, o->target,
                         strerror(err));
    /* The rename is durable once the directory is on disk too.  Best
     * effort: the new file is in place already, and some file systems
     * refuse fsync on a directory. */
    char *dir = dir_of(o->target);
    int dfd = dir ? open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC) : -1;
    if (dfd >= 0) {
        (void)fsync(dfd);
        close(dfd);
    }
    free(dir);
    return 0;
}

int cli_outfile_commit(cli_outfile *o)
{
    return cli_outfile_commit_all(o, 1);
}

int cli_outfile_commit_all(cli_outfile *o, size_t n)
{
    int rc = 0;
    for (size_t i = 0; i < n && rc == 0; i++)
        if (o[i].f && finish(&o[i]) != 0)
            rc = CLI_EXIT_FAIL;
    for (size_t i = 0; i < n && rc == 0; i++)
        if (put_in_place(&o[i]) != 0)
            rc = CLI_EXIT_FAIL;
    for (size_t i = 0; i < n; i++)
        cli_outfile_abort(&o[i]);
    return rc;
}

void cli_outfile_abort(cli_outfile *o)
{
    if (o->f)
        fclose(o->f);
    o->f = NULL;
    if (o->tmp) {
        sigset_t old;
        block_signals(&old);
        unlink(o->tmp);
        unregister(o);
        restore_signals(&old);
        free(o->tmp);
        o->tmp = NULL;
    }
    free(o->target);
    o->target = NULL;
}

/* dir_of(path) resolved, "/", and the last component: a name for a file
 * that may not exist yet.  NULL when the directory cannot be resolved. */
static char *canonical_name(const char *path)
{
    char *dir = dir_of(path);
    char *real = dir ? realpath(dir, NULL) : NULL;
    free(dir);
    if (!real)
        return NULL;
    const char *slash = strrchr(path, '/');
    const char *base = slash ? slash + 1 : path;
    size_t n = strlen(real) + strlen(base) + 2;
    char *out = malloc(n);
    if (out)
        snprintf(out, n, "%s/%s", real, base);
    free(real);
    return out;
}

int cli_outfile_same(const char *a, const char *b)
{
    struct stat sa, sb;
    int ea = stat(a, &sa) == 0, eb = stat(b, &sb) == 0;
    if (ea && eb)
        return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
    if (ea || eb)
        return 0;
    char *ca = canonical_name(a), *cb = canonical_name(b);
    int same = ca && cb ? strcmp(ca, cb) == 0 : strcmp(a, b) == 0;
    free(ca);
    free(cb);
    return same;
}
