/*
 * outfile.h - output files written the way a careful Unix tool writes
 * them (private to the CLI): every command that writes a named file
 * (points --out, spectrum --png/--csv, ...) goes through here.
 *
 * The rules, checked by cli_outfile_open before the first byte is made:
 *   - A target that exists and is not a regular file (a character device
 *     such as /dev/null, a FIFO) is opened and written in place, never
 *     replaced: /dev/null stays a device, even for root.  Directories,
 *     sockets and block devices are refused.
 *   - A regular target is replaced atomically: the bytes go to a temporary
 *     file beside it (same directory, so rename(2) cannot cross file
 *     systems), which is fsynced and then renamed over the target only
 *     when complete (and the directory fsynced after, best effort).  A symbolic link is followed: the file it names is
 *     replaced and the link stays.
 *   - ... except a link that pathwalk.h's rule refuses: another user's
 *     link in a sticky, world-writable directory (/tmp), anywhere on the
 *     way, whatever fs.protected_symlinks says.  The target's directory
 *     is found once, by that walk; the temporary file is created
 *     (O_EXCL, O_NOFOLLOW, a random name) and renamed relative to it.
 *   - "Could not open it for writing" decides whether a regular target may
 *     be replaced.  It is refused when
 *       * faccessat(W_OK, AT_EACCESS) says no (so a non-root user's 0444
 *         file or another user's 0644 file), or
 *       * its mode has no write bit at all (0444, 0400, ...): root could
 *         open it, but a file nobody may write is marked read-only on
 *         purpose, and we honour that for root too, or
 *       * it belongs to another user and (a) we are not root, because
 *         replacing it would change its owner, or (b) its directory is
 *         sticky (/tmp): a file in a sticky directory belongs to its
 *         owner, root included.  Root elsewhere gives the new file the
 *         old one's owner and group.
 *   - The new file keeps the target's permission bits (mode & 0777), or
 *     gets 0666 & ~umask when the target does not exist yet.
 *   - While a temporary file exists, SIGINT, SIGTERM, SIGHUP and SIGQUIT
 *     remove it before the process dies of the signal (an async-signal-
 *     safe handler that only calls unlink and re-raises), so no *.tmp.*
 *     file is left behind.
 *
 * Several files can be validated first and committed together
 * (cli_outfile_commit_all): a command with two outputs opens both, writes
 * both, fsyncs both, and only then renames them, so a bad second target
 * leaves neither file changed.
 */
#ifndef QMC_CLI_OUTFILE_H
#define QMC_CLI_OUTFILE_H

#include <stddef.h>
#include <stdio.h>
#include <sys/types.h>

/* Files one process may hold open at once (the signal handler's table). */
#define CLI_OUTFILE_MAX 8

typedef struct cli_outfile {
    FILE *f;                  /* write here; NULL when not open */
    char *target;             /* the file to replace (links resolved), or the
                                 device/FIFO written in place: for messages */
    char *name;               /* its name in dirfd */
    char *tmp;                /* the temporary file's name in dirfd, NULL
                                 when written in place */
    int dirfd;                /* the directory holding both (pathwalk.h);
                                 open while name is not NULL */
    const char *what;         /* "--out", "--png", ...: for error lines */
    int slot;                 /* signal-cleanup slot, -1 when none */
} cli_outfile;

/*
 * Checks path by the rules above and opens what the bytes go to.  what
 * names the option in error lines.  Returns 0 with o->f ready, or
 * CLI_EXIT_FAIL after printing one error line (o is then closed).
 */
int cli_outfile_open(cli_outfile *o, const char *path, const char *what);

/* Flushes, fsyncs and renames into place (or just flushes and closes a
 * device or FIFO).  Returns 0, or CLI_EXIT_FAIL after printing one error
 * line, with the temporary file removed and the target untouched. */
int cli_outfile_commit(cli_outfile *o);

/* Flushes and fsyncs every file, and only when all of them succeeded
 * renames them into place in order.  On failure every file not yet
 * renamed is removed.  Returns 0 or CLI_EXIT_FAIL (printed). */
int cli_outfile_commit_all(cli_outfile *o, size_t n);

/* Closes without committing: the temporary file is removed, the target is
 * left as it was.  Safe on a closed or zeroed cli_outfile. */
void cli_outfile_abort(cli_outfile *o);

/* 1 when paths a and b would name the same file (the same inode when it
 * exists; the same directory and name when it does not), else 0. */
int cli_outfile_same(const char *a, const char *b);

#endif
