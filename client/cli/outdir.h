/*
 * outdir.h - an output directory written all at once (private to the CLI).
 *
 * `qmc stability --out DIR` and `qmc compare --out DIR` write several
 * files (CSV, REPORT.md, charts).  They are written under temporary names
 * in DIR and renamed into place only when every one of them is complete,
 * so a failure (bad input found late, gnuplot missing, a full disk, a
 * signal) leaves DIR as it was: nothing half-written.
 */
#ifndef QMC_CLI_OUTDIR_H
#define QMC_CLI_OUTDIR_H

#include <stdio.h>

enum { CLI_OUTDIR_MAX_FILES = 32 };

typedef struct cli_outdir {
    char dir[4096];
    int created;                      /* we made DIR (removed on abort) */
    int n;
    char *final[CLI_OUTDIR_MAX_FILES];
    char *temp[CLI_OUTDIR_MAX_FILES];
} cli_outdir;

/* Checks that DIR is (or can be made as) a writable directory, creating
 * it (one level) when missing.  Prints an error and returns -1. */
int cli_outdir_open(cli_outdir *od, const char *dir);
/* The temporary path for DIR/name, registered for commit; NULL (after an
 * error message) when out of room or memory. */
const char *cli_outdir_path(cli_outdir *od, const char *name);
/* Opens cli_outdir_path(od, name) for writing. */
FILE *cli_outdir_fopen(cli_outdir *od, const char *name);
/* Renames every registered file into place.  Prints an error and returns
 * -1 (after removing what is left) on failure. */
int cli_outdir_commit(cli_outdir *od);
/* Removes every temporary file (and DIR when we created it and it is
 * empty).  Safe after commit (then a no-op but for freeing). */
void cli_outdir_abort(cli_outdir *od);

/* Closes f, checking for write errors; prints one and returns -1. */
int cli_outdir_fclose(FILE *f, const char *name);

#endif
