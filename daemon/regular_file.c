/*
 * regular_file.c - qmcd's one way to open a file it reads settings from
 * (regular_file.h).  Found by issue 22: `qmcd --check-config --auth-key
 * FIFO` never returned, a FIFO key or config at start blocked in open()
 * with SIGTERM already blocked (only SIGKILL stopped it), and a SIGHUP
 * after a file was swapped for a FIFO froze the whole event loop until
 * someone wrote to it.  Opening a device can do things on its own (a
 * watchdog arms, a tape rewinds), so nothing but a regular file is opened
 * at all.  Must not: read, wait, or open anything but a regular file.
 */
/* O_CLOEXEC and S_ISSOCK, also where this is compiled without the
 * Makefile's -D_POSIX_C_SOURCE (the config fuzz target). */
#define _GNU_SOURCE
#include "regular_file.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* What a file that is not regular is, for the error line. */
static const char *kind(mode_t mode)
{
    if (S_ISFIFO(mode))
        return "a FIFO";
    if (S_ISDIR(mode))
        return "a directory";
    if (S_ISCHR(mode))
        return "a character device";
    if (S_ISBLK(mode))
        return "a block device";
    if (S_ISSOCK(mode))
        return "a socket";
    return "of an unknown type";
}

int qmcd_open_regular(const char *what, const char *path, char *why, size_t n)
{
    const char *sep = what[0] ? " " : "";
    struct stat st;
    /* stat first: a FIFO or a device is refused without being opened. */
    if (stat(path, &st) != 0) {
        snprintf(why, n, "%s%s%s: cannot open: %s", what, sep, path, strerror(errno));
        return -1;
    }
    if (!S_ISREG(st.st_mode)) {
        snprintf(why, n, "%s%s%s: is %s, not a regular file", what, sep, path,
                 kind(st.st_mode));
        return -1;
    }
    /* O_NONBLOCK: if the name was swapped for a FIFO since the stat, the
     * open returns at once instead of waiting for a writer, and the fstat
     * below refuses it. */
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
    if (fd < 0) {
        snprintf(why, n, "%s%s%s: cannot open: %s", what, sep, path, strerror(errno));
        return -1;
    }
    int flags;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode) || (flags = fcntl(fd, F_GETFL)) < 0 ||
        fcntl(fd, F_SETFL, flags & ~O_NONBLOCK) != 0) {
        int err = errno;
        close(fd);
        if (!S_ISREG(st.st_mode))
            snprintf(why, n, "%s%s%s: is %s, not a regular file", what, sep, path,
                     kind(st.st_mode));
        else
            snprintf(why, n, "%s%s%s: cannot open: %s", what, sep, path, strerror(err));
        return -1;
    }
    return fd;
}
