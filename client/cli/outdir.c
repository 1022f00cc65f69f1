/*
 * outdir.c - stage files in an output directory, then rename them all
 * into place (see outdir.h).
 */
#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cli.h"
#include "outdir.h"

int cli_outdir_open(cli_outdir *od, const char *dir)
{
    memset(od, 0, sizeof *od);
    if (!dir || !dir[0])
        return cli_error("--out: empty directory name"), -1;
    if (strlen(dir) + 64 >= sizeof od->dir)
        return cli_error("--out: directory name too long"), -1;
    strcpy(od->dir, dir);
    struct stat st;
    if (stat(dir, &st) == 0) {
        if (!S_ISDIR(st.st_mode))
            return cli_error("--out %s: exists and is not a directory", dir), -1;
    } else if (errno == ENOENT) {
        if (mkdir(dir, 0777) != 0)
            return cli_error("--out %s: cannot create: %s", dir, strerror(errno)), -1;
        od->created = 1;
    } else {
        return cli_error("--out %s: %s", dir, strerror(errno)), -1;
    }
    if (access(dir, W_OK | X_OK) != 0) {
        int e = errno;
        cli_outdir_abort(od);
        return cli_error("--out %s: not writable: %s", dir, strerror(e)), -1;
    }
    return 0;
}

const char *cli_outdir_path(cli_outdir *od, const char *name)
{
    for (int i = 0; i < od->n; i++)
        if (strcmp(od->final[i] + strlen(od->dir) + 1, name) == 0)
            return od->temp[i];
    if (od->n == CLI_OUTDIR_MAX_FILES)
        return cli_error("--out: too many output files"), NULL;
    size_t len = strlen(od->dir) + strlen(name) + 64;
    char *fin = malloc(len), *tmp = malloc(len);
    if (!fin || !tmp) {
        free(fin), free(tmp);
        return cli_error("out of memory"), NULL;
    }
    snprintf(fin, len, "%s/%s", od->dir, name);
    /* The temporary name keeps the extension (gnuplot does not care, but
     * a reader of a half-finished directory can tell what it is). */
    snprintf(tmp, len, "%s/.%s.tmp%ld", od->dir, name, (long)getpid());
    od->final[od->n] = fin;
    od->temp[od->n] = tmp;
    od->n++;
    return tmp;
}

FILE *cli_outdir_fopen(cli_outdir *od, const char *name)
{
    const char *p = cli_outdir_path(od, name);
    if (!p)
        return NULL;
    FILE *f = fopen(p, "w");
    if (!f)
        cli_error("%s/%s: %s", od->dir, name, strerror(errno));
    return f;
}

int cli_outdir_fclose(FILE *f, const char *name)
{
    int bad = ferror(f);
    if (fclose(f) != 0 || bad)
        return cli_error("writing %s failed", name), -1;
    return 0;
}

static void release(cli_outdir *od)
{
    for (int i = 0; i < od->n; i++) {
        free(od->final[i]);
        free(od->temp[i]);
    }
    od->n = 0;
}

int cli_outdir_commit(cli_outdir *od)
{
    for (int i = 0; i < od->n; i++) {
        if (access(od->temp[i], F_OK) != 0) {
            cli_error("%s was not written", od->final[i]);
            cli_outdir_abort(od);
            return -1;
        }
    }
    for (int i = 0; i < od->n; i++) {
        if (rename(od->temp[i], od->final[i]) != 0) {
            cli_error("%s: %s", od->final[i], strerror(errno));
            cli_outdir_abort(od);
            return -1;
        }
    }
    release(od);
    return 0;
}

void cli_outdir_abort(cli_outdir *od)
{
    for (int i = 0; i < od->n; i++)
        unlink(od->temp[i]);
    release(od);
    if (od->created)
        rmdir(od->dir);
    od->created = 0;
}
