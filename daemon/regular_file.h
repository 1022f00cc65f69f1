/*
 * regular_file.h - opening the files qmcd reads its settings from (the
 * config file, the auth key) so that none of them can hang it.
 */
#ifndef QMCD_REGULAR_FILE_H
#define QMCD_REGULAR_FILE_H

#include <stddef.h>

/*
 * Opens path read-only if it is a regular file (a symbolic link to one is
 * fine), without ever waiting: a FIFO, a directory, a device or a socket
 * is refused before it is opened, and the open itself is non-blocking, so
 * a file swapped for a FIFO in between is found by the fstat after it and
 * refused too.  Returns the descriptor (blocking, close-on-exec), or -1
 * with one line in why: "WHAT PATH: is a FIFO, not a regular file" (what
 * may be "" for no prefix), "WHAT PATH: cannot open: ...".
 */
int qmcd_open_regular(const char *what, const char *path, char *why, size_t why_bytes);

#endif
