/*
 * outdir.h - an output directory written all at once (private to the CLI).
 *
 * `qmc stability --out DIR` and `qmc compare --out DIR` write several
 * files (CSV, REPORT.md, charts).  They are written into a private staging
 * directory inside DIR (DIR/.qmc-XXXXXX, mode 0700, made with a random
 * name that must not exist yet) and renamed into DIR only when every one
 * of them is complete, so a failure (bad input found late, gnuplot
 * missing, a full disk) leaves DIR as it was: nothing half-written.  (A
 * signal that kills qmc may leave the staging directory; nothing in DIR
 * itself is touched before the renames.)
 *
 * DIR is walked by pathwalk.h's rule (no other user's link in a sticky,
 * world-writable directory is followed), and the staging directory is
 * ours alone: another user who may write to DIR (DIR is /tmp, say) can
 * plant nothing where the files are written.  The renames are made
 * relative to descriptors of both directories.
 */
#ifndef QMC_CLI_OUTDIR_H
#define QMC_CLI_OUTDIR_H

#include <stdio.h>

enum { CLI_OUTDIR_MAX_FILES = 32 };

typedef struct cli_outdir {
    char dir[4096];                   /* DIR as given, for messages */
    char stage[4096];                 /* DIR/.qmc-XXXXXX: files until commit */
    int is_open;                      /* the descriptors below are open */
    int parentfd;                     /* the directory holding DIR */
    char *dirname;                    /* DIR's name in parentfd */
    int dirfd, stagefd;               /* DIR and the staging directory */
    char stagename[16];               /* ".qmc-XXXXXX" */
    int created;                      /* we made DIR (removed on abort) */
    int n;
    char *final[CLI_OUTDIR_MAX_FILES]; /* names in DIR (and in the stage) */
    char *temp[CLI_OUTDIR_MAX_FILES];  /* their paths in the stage */
} cli_outdir;

/* Checks that DIR is (or can be made as) a writable directory, creating
 * it (one level) when missing, and makes the staging directory.  Prints
 * an error and returns -1 (with nothing left behind). */
int cli_outdir_open(cli_outdir *od, const char *dir);
/* The temporary path for DIR/name, registered for commit; NULL (after an
 * error message) when out of room or memory. */
const char *cli_outdir_path(cli_outdir *od, const char *name);
/* Opens cli_outdir_path(od, name) for writing. */
FILE *cli_outdir_fopen(cli_outdir *od, const char *name);
/* Renames every registered file into place and removes the staging
 * directory.  Prints an error and returns -1 (after removing what is
 * left) on failure. */
int cli_outdir_commit(cli_outdir *od);
/* Removes every temporary file and the staging directory (and DIR when we
 * created it and it is empty).  Safe after commit or a failed open (then
 * a no-op but for freeing). */
void cli_outdir_abort(cli_outdir *od);

/* Closes f, checking for write errors; prints one and returns -1. */
int cli_outdir_fclose(FILE *f, const char *name);

#endif
