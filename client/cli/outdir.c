/*
 * outdir.c - stage files in a private directory inside an output
 * directory, then rename them all into place (see outdir.h).  Must not:
 * follow a link pathwalk.c refuses, write anything into DIR itself before
 * the renames, or leave the staging directory after a commit or an abort.
 */
/* O_PATH */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cli.h"
#include "outdir.h"
#include "pathwalk.h"

/* Closes what cli_outdir_open opened (the staging directory must be gone
 * or given up on by now). */
static void close_dirs(cli_outdir *od)
{
    if (!od->is_open)
        return;
    close(od->stagefd);
    close(od->dirfd);
    close(od->parentfd);
    free(od->dirname);
    od->dirname = NULL;
    od->is_open = 0;
}

int cli_outdir_open(cli_outdir *od, const char *dir)
{
    memset(od, 0, sizeof *od);
    if (!dir || !dir[0])
        return cli_error("--out: empty directory name"), -1;
    if (strlen(dir) + 64 >= sizeof od->dir)
        return cli_error("--out: directory name too long"), -1;
    strcpy(od->dir, dir);
    cli_pathwalk w;
    if (cli_pathwalk_open(&w, dir, "--out") != 0)
        return -1;
    if (w.exists && !S_ISDIR(w.st.st_mode)) {
        cli_pathwalk_close(&w);
        return cli_error("--out %s: exists and is not a directory", dir), -1;
    }
    if (!w.exists && w.through_link) {
        cli_pathwalk_close(&w);
        return cli_error("--out %s: is a symbolic link to a missing directory", dir), -1;
    }
    if (!w.exists) {
        if (mkdirat(w.dirfd, w.name, 0777) != 0) {
            int e = errno;
            cli_pathwalk_close(&w);
            return cli_error("--out %s: cannot create: %s", dir, strerror(e)), -1;
        }
        od->created = 1;
    }
    int e = 0;
    const char *doing = "not writable";
    int dfd = openat(w.dirfd, w.name, O_PATH | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
    if (dfd < 0 || faccessat(w.dirfd, w.name, W_OK | X_OK, 0) != 0)
        e = errno;
    /* The staging directory: a fresh random name, made by us (mkdirat
     * fails rather than use anything already there), 0700. */
    int sfd = -1;
    memcpy(od->stagename, ".qmc-", 5);
    for (int attempt = 0; !e && attempt < 100; attempt++) {
        cli_pathwalk_random(od->stagename + 5, 6);
        od->stagename[11] = '\0';
        if (mkdirat(dfd, od->stagename, 0700) == 0)
            break;
        if (errno != EEXIST || attempt == 99) {
            e = errno;
            doing = "cannot make a staging directory in it";
        }
    }
    if (!e) {
        sfd = openat(dfd, od->stagename, O_PATH | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
        if (sfd < 0) {
            e = errno;
            doing = "cannot open its staging directory";
            unlinkat(dfd, od->stagename, AT_REMOVEDIR);
        }
    }
    if (e) {
        if (dfd >= 0)
            close(dfd);
        if (od->created)
            unlinkat(w.dirfd, w.name, AT_REMOVEDIR);
        od->created = 0;
        cli_pathwalk_close(&w);
        return cli_error("--out %s: %s: %s", dir, doing, strerror(e)), -1;
    }
    snprintf(od->stage, sizeof od->stage, "%s/%s", dir, od->stagename);
    od->parentfd = w.dirfd;
    od->dirname = w.name;
    w.name = NULL; /* ours now, with parentfd */
    cli_pathwalk_close(&w);
    od->dirfd = dfd;
    od->stagefd = sfd;
    od->is_open = 1;
    return 0;
}

const char *cli_outdir_path(cli_outdir *od, const char *name)
{
    for (int i = 0; i < od->n; i++)
        if (strcmp(od->final[i], name) == 0)
            return od->temp[i];
    if (od->n == CLI_OUTDIR_MAX_FILES)
        return cli_error("--out: too many output files"), NULL;
    size_t len = strlen(od->stage) + strlen(name) + 2;
    char *fin = strdup(name), *tmp = malloc(len);
    if (!fin || !tmp) {
        free(fin), free(tmp);
        return cli_error("out of memory"), NULL;
    }
    snprintf(tmp, len, "%s/%s", od->stage, name);
    od->final[od->n] = fin;
    od->temp[od->n] = tmp;
    od->n++;
    return tmp;
}

FILE *cli_outdir_fopen(cli_outdir *od, const char *name)
{
    if (!cli_outdir_path(od, name))
        return NULL;
    /* Relative to the staging directory's descriptor: the path is not
     * walked again. */
    int fd = openat(od->stagefd, name, O_WRONLY | O_CREAT | O_TRUNC | O_NOFOLLOW | O_CLOEXEC,
                    0666);
    FILE *f = fd >= 0 ? fdopen(fd, "w") : NULL;
    if (!f) {
        cli_error("%s/%s: %s", od->dir, name, strerror(errno));
        if (fd >= 0)
            close(fd);
    }
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
        if (faccessat(od->stagefd, od->final[i], F_OK, AT_SYMLINK_NOFOLLOW) != 0) {
            cli_error("%s/%s was not written", od->dir, od->final[i]);
            cli_outdir_abort(od);
            return -1;
        }
    }
    for (int i = 0; i < od->n; i++) {
        if (renameat(od->stagefd, od->final[i], od->dirfd, od->final[i]) != 0) {
            cli_error("%s/%s: %s", od->dir, od->final[i], strerror(errno));
            cli_outdir_abort(od);
            return -1;
        }
    }
    unlinkat(od->dirfd, od->stagename, AT_REMOVEDIR);
    release(od);
    close_dirs(od);
    return 0;
}

void cli_outdir_abort(cli_outdir *od)
{
    if (od->is_open) {
        for (int i = 0; i < od->n; i++)
            unlinkat(od->stagefd, od->final[i], 0);
        unlinkat(od->dirfd, od->stagename, AT_REMOVEDIR);
        if (od->created)
            unlinkat(od->parentfd, od->dirname, AT_REMOVEDIR);
    }
    release(od);
    close_dirs(od);
    od->created = 0;
}
