/*
 * outfile.c - output files that never clobber what they should not: the
 * checks, the temporary file beside the target, fsync then rename, and the
 * signal handler that removes temporary files (the rules are in
 * outfile.h).  Must not: replace a device, FIFO or read-only file, follow
 * a link pathwalk.c refuses, touch the target by name once the walk has
 * found its directory, leave a temporary file behind, or print more than
 * one line per error.
 */
/* realpath(3) and S_ISVTX. */
#define _GNU_SOURCE
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
#include "pathwalk.h"

/* ---- the signal cleanup table ----------------------------------------------
 * The one piece of global state in the CLI, because a signal handler can
 * reach nothing else.  A slot holds the name of a temporary file while it
 * exists, and the directory descriptor it is in; the handler unlinks each
 * and lets the signal kill us.  Slots are filled and emptied with these
 * signals blocked, so the handler never sees a half-made entry, and the
 * strings and descriptors stay valid while registered. */
static char *volatile cleanup_paths[CLI_OUTFILE_MAX];
static volatile int cleanup_dirs[CLI_OUTFILE_MAX];
static volatile sig_atomic_t cleanup_installed;
static const int cleanup_signals[] = {SIGINT, SIGTERM, SIGHUP, SIGQUIT};
#define N_CLEANUP_SIGNALS (sizeof cleanup_signals / sizeof cleanup_signals[0])

static void on_fatal_signal(int sig)
{
    /* unlinkat, sigaction and raise are async-signal-safe (POSIX.1-2008
     * 2.4.3); nothing else is called here. */
    for (int i = 0; i < CLI_OUTFILE_MAX; i++) {
        char *p = cleanup_paths[i];
        if (p)
            unlinkat(cleanup_dirs[i], p, 0);
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

/* May the regular file o->name in o->dirfd (stat st) be replaced?  0, or
 * an error printed and CLI_EXIT_FAIL. */
static int check_replaceable(const cli_outfile *o, const struct stat *st)
{
    const char *path = o->target;
    if ((st->st_mode & 0222) == 0)
        return cli_error("%s: '%s' is read-only (mode %04o): refusing to replace it",
                         o->what, path, (unsigned)(st->st_mode & 07777));
    if (faccessat(o->dirfd, o->name, W_OK, AT_EACCESS) != 0)
        return cli_error("%s: '%s' is not writable by you: %s", o->what, path,
                         strerror(errno));
    if (st->st_uid == geteuid())
        return 0;
    if (geteuid() != 0)
        return cli_error("%s: '%s' belongs to uid %u: replacing it would take it from "
                         "its owner (write to a new name)", o->what, path,
                         (unsigned)st->st_uid);
    struct stat ds;
    if (fstat(o->dirfd, &ds) == 0 && (ds.st_mode & S_ISVTX)) {
        char *dir = dir_of(path);
        cli_error("%s: '%s' belongs to uid %u in the sticky directory '%s': "
                  "refusing to replace it", o->what, path, (unsigned)st->st_uid,
                  dir ? dir : "?");
        free(dir);
        return CLI_EXIT_FAIL;
    }
    return 0;
}

/* A device or FIFO: opened and written in place. */
static int open_in_place(cli_outfile *o, const struct stat *st)
{
    const char *path = o->target;
    if (S_ISDIR(st->st_mode))
        return cli_error("%s: '%s' is a directory", o->what, path);
    if (!S_ISCHR(st->st_mode) && !S_ISFIFO(st->st_mode))
        return cli_error("%s: '%s' is not a regular file, a character device or a FIFO",
                         o->what, path);
    /* O_NOFOLLOW: the walk found no link here; one put here since is not
     * followed.  (Blocking on a FIFO until a reader comes is the point.) */
    int fd = openat(o->dirfd, o->name, O_WRONLY | O_NOCTTY | O_NOFOLLOW | O_CLOEXEC);
    if (fd < 0)
        return cli_error("%s: cannot open '%s': %s", o->what, path, strerror(errno));
    struct stat now;
    if (fstat(fd, &now) != 0 || (now.st_mode & S_IFMT) != (st->st_mode & S_IFMT)) {
        close(fd);
        return cli_error("%s: '%s' changed while it was opened", o->what, path);
    }
    o->f = fdopen(fd, "wb");
    if (!o->f) {
        close(fd);
        return cli_error("%s: out of memory", o->what);
    }
    return 0;
}

/* Creates a new, empty file "NAME.tmp.XXXXXX" (six random letters, the
 * mkstemp(3) pattern) beside the target with mode 0600, its name in
 * *name.  O_EXCL and O_NOFOLLOW: nothing already there - a link another
 * user guessed the name for - is ever opened.  fd or -errno. */
static int create_temp(const cli_outfile *o, char **name)
{
    size_t len = strlen(o->name);
    char *t = malloc(len + 12);
    if (!t)
        return -ENOMEM;
    memcpy(t, o->name, len);
    memcpy(t + len, ".tmp.", 5);
    t[len + 11] = '\0';
    for (int attempt = 0; attempt < 100; attempt++) {
        cli_pathwalk_random(t + len + 5, 6);
        int fd = openat(o->dirfd, t, O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC,
                        0600);
        if (fd >= 0) {
            *name = t;
            return fd;
        }
        if (errno != EEXIST) {
            int err = errno;
            free(t);
            return -err;
        }
    }
    free(t);
    return -EEXIST;
}

int cli_outfile_open(cli_outfile *o, const char *path, const char *what)
{
    memset(o, 0, sizeof *o);
    o->slot = -1;
    o->dirfd = -1;
    o->what = what;
    if (!path || !path[0])
        return cli_error("%s: the file name is empty", what);
    cli_pathwalk w;
    if (cli_pathwalk_open(&w, path, what) != 0)
        return CLI_EXIT_FAIL;
    /* The walk's directory and names are ours now. */
    o->dirfd = w.dirfd;
    o->name = w.name;
    o->target = w.shown;
    w.name = w.shown = NULL;
    const struct stat st = w.st;
    const int exists = w.exists;
    mode_t mode;
    if (!exists && w.through_link) {
        cli_outfile_abort(o);
        return cli_error("%s: '%s' is a symbolic link to a missing file", what, path);
    }
    if (!exists && w.dir_only) {
        cli_outfile_abort(o);
        return cli_error("%s: '%s' ends in '/', so it names a directory, not a file", what,
                         path);
    }
    if (exists && !S_ISREG(st.st_mode)) {
        if (open_in_place(o, &st) != 0) {
            cli_outfile_abort(o);
            return CLI_EXIT_FAIL;
        }
        return 0;
    }
    if (exists) {
        /* A link was followed to get here: the file it names is replaced,
         * the link kept. */
        if (check_replaceable(o, &st) != 0) {
            cli_outfile_abort(o);
            return CLI_EXIT_FAIL;
        }
        mode = st.st_mode & 0777;
    } else {
        mode = new_file_mode();
    }
    install_cleanup();
    /* Create and register with the signals held off: a signal between the
     * two would leave the file. */
    sigset_t old;
    block_signals(&old);
    int fd = create_temp(o, &o->tmp);
    int err = fd < 0 ? -fd : 0;
    if (fd >= 0)
        for (int i = 0; i < CLI_OUTFILE_MAX && o->slot < 0; i++)
            if (!cleanup_paths[i]) {
                cleanup_dirs[i] = o->dirfd;
                cleanup_paths[i] = o->tmp;
                o->slot = i;
            }
    restore_signals(&old);
    if (fd < 0) {
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
    /* Both names relative to the directory the walk found: nothing on the
     * way is looked up again, and rename(2) never follows the last
     * component (a link put there since is replaced, not followed). */
    int r = renameat(o->dirfd, o->tmp, o->dirfd, o->name);
    int err = errno;
    if (r != 0)
        unlinkat(o->dirfd, o->tmp, 0);
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
    int dfd = openat(o->dirfd, ".", O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (dfd >= 0) {
        (void)fsync(dfd);
        close(dfd);
    }
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
        unlinkat(o->dirfd, o->tmp, 0);
        unregister(o);
        restore_signals(&old);
        free(o->tmp);
        o->tmp = NULL;
    }
    if (o->name)
        close(o->dirfd);
    free(o->name);
    o->name = NULL;
    o->dirfd = -1;
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
