/*
 * pathwalk.c - the component-by-component walk of pathwalk.h: each
 * directory opened from the one before with O_NOFOLLOW, each symbolic link
 * judged by the protected_symlinks rule in the directory that holds it,
 * then its target walked from there.  Must not: create, open for writing
 * or change anything; follow a link without judging it; print more than
 * one line.
 */
/* O_PATH: a descriptor that only names a directory, so that walking needs
 * search (x) permission only, as the kernel's own walk does. */
#define _GNU_SOURCE
#include "pathwalk.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdlib.h>
#include <string.h>
#include <sys/random.h>
#include <unistd.h>

#include "cli.h"

/* The kernel's limit on links in one walk (MAXSYMLINKS, Linux 4.2 on). */
#define MAX_LINKS 40

/* The directories walked so far, as text for messages: "" (the current
 * directory), "/" or "a/b/" - always ending in "/" unless empty.  Only
 * real directories are appended, so ".." may simply drop the last one. */
typedef struct shown_buf {
    char *s;
    size_t len, cap;
} shown_buf;

static int shown_put(shown_buf *b, const char *text, size_t n)
{
    if (b->len + n + 1 > b->cap) {
        size_t cap = (b->len + n + 1) * 2;
        char *s = realloc(b->s, cap);
        if (!s)
            return -1;
        b->s = s;
        b->cap = cap;
    }
    memcpy(b->s + b->len, text, n);
    b->len += n;
    b->s[b->len] = '\0';
    return 0;
}

static void shown_up(shown_buf *b)
{
    if (b->len == 0 || (b->len >= 3 && memcmp(b->s + b->len - 3, "../", 3) == 0 &&
                        (b->len == 3 || b->s[b->len - 4] == '/'))) {
        (void)shown_put(b, "../", 3); /* above where we started: say so */
        return;
    }
    if (b->len == 1) /* "/": its ".." is itself */
        return;
    size_t i = b->len - 1; /* the trailing '/' */
    while (i > 0 && b->s[i - 1] != '/')
        i--;
    b->len = i;
    b->s[i] = '\0';
}

/* "dir" for a message: the walked directories without the last '/'. */
static const char *shown_dir(shown_buf *b)
{
    if (b->len == 0)
        return ".";
    if (b->len > 1 && b->s[b->len - 1] == '/')
        b->s[b->len - 1] = '\0'; /* only ever used just before failing */
    return b->s;
}

void cli_pathwalk_close(cli_pathwalk *w)
{
    if (w->name)
        close(w->dirfd);
    free(w->name);
    free(w->shown);
    w->name = NULL;
    w->shown = NULL;
    w->dirfd = -1;
}

void cli_pathwalk_random(char *out, size_t n)
{
    static const char letters[] =
        "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789";
    static unsigned long calls;
    unsigned char r[64];
    if (n > sizeof r)
        n = sizeof r;
    if (getrandom(r, n, 0) != (ssize_t)n) {
        /* Never expected.  O_EXCL needs names that differ, not secret
         * ones, so a weaker source only risks a retry. */
        unsigned long x = (unsigned long)getpid() * 2654435761ul + ++calls * 40503ul;
        for (size_t i = 0; i < n; i++, x = x * 6364136223846793005ul + 1442695040888963407ul)
            r[i] = (unsigned char)(x >> 33);
    }
    for (size_t i = 0; i < n; i++)
        out[i] = letters[r[i] % (sizeof letters - 1)];
}

/* Would the kernel's protected_symlinks rule follow the link (lstat lst)
 * that sits in directory dfd?  1 yes, 0 no (*ds then holds the directory's
 * stat), -errno when the directory cannot be looked at. */
static int link_may_be_followed(int dfd, const struct stat *lst, struct stat *ds)
{
    if (fstat(dfd, ds) != 0)
        return -errno;
    if (!(ds->st_mode & S_ISVTX) || !(ds->st_mode & S_IWOTH))
        return 1;
    return lst->st_uid == geteuid() || lst->st_uid == ds->st_uid;
}

int cli_pathwalk_open(cli_pathwalk *w, const char *path, const char *what)
{
    memset(w, 0, sizeof *w);
    w->dirfd = -1;
    shown_buf sb = {0};
    char comp[NAME_MAX + 1], target[PATH_MAX];
    char *todo = strdup(path); /* what is left to walk; links splice into it */
    int dfd = open(path[0] == '/' ? "/" : ".", O_PATH | O_DIRECTORY | O_CLOEXEC);
    int err = 0, links = 0, rc = CLI_EXIT_FAIL;
    if (!todo || dfd < 0 || shown_put(&sb, "/", path[0] == '/') != 0) {
        err = todo && dfd < 0 ? errno : ENOMEM;
        goto fail;
    }
    const char *p = todo;
    for (;;) {
        while (*p == '/')
            p++;
        size_t n = strcspn(p, "/");
        const char *after = p + n, *q = after;
        while (*q == '/')
            q++;
        const int last = *q == '\0';
        const int trailing = last && *after == '/'; /* "x/" must be a directory */
        if (n > NAME_MAX) {
            err = ENAMETOOLONG;
            goto fail;
        }
        memcpy(comp, p, n);
        comp[n] = '\0';
        if (n == 0 || strcmp(comp, ".") == 0 || strcmp(comp, "..") == 0) {
            if (n == 2) {
                int up = openat(dfd, "..", O_PATH | O_DIRECTORY | O_CLOEXEC);
                if (up < 0) {
                    err = errno;
                    goto fail;
                }
                close(dfd);
                dfd = up;
                shown_up(&sb);
            }
            if (last) {
                strcpy(comp, ".");
                break;
            }
            p = after;
            continue;
        }
        struct stat st;
        if (fstatat(dfd, comp, &st, AT_SYMLINK_NOFOLLOW) != 0) {
            if (errno == ENOENT && last) {
                w->dir_only = trailing; /* "new/": only a directory fits */
                break;                  /* a new name: w->exists stays 0 */
            }
            err = errno;
            goto fail;
        }
        if (S_ISLNK(st.st_mode)) {
            struct stat ds;
            int may = link_may_be_followed(dfd, &st, &ds);
            if (may < 0) {
                err = -may;
                goto fail;
            }
            if (!may) {
                char *link = malloc(sb.len + n + 1);
                if (link)
                    snprintf(link, sb.len + n + 1, "%s%s", sb.len ? sb.s : "", comp);
                cli_error("%s: '%s' is a symbolic link of uid %u in the sticky, "
                          "world-writable directory '%s' (owned by uid %u): refusing to "
                          "follow it (only your own links and the directory owner's are "
                          "followed there)", what, link ? link : comp, (unsigned)st.st_uid,
                          shown_dir(&sb), (unsigned)ds.st_uid);
                free(link);
                goto done;
            }
            if (++links > MAX_LINKS) {
                err = ELOOP;
                goto fail;
            }
            ssize_t len = readlinkat(dfd, comp, target, sizeof target);
            if (len < 0 || (size_t)len >= sizeof target || len == 0) {
                err = len < 0 ? errno : len == 0 ? ENOENT : ENAMETOOLONG;
                goto fail;
            }
            /* The target, then whatever followed the link in the path. */
            size_t rest = strlen(after);
            char *spliced = malloc((size_t)len + rest + 1);
            if (!spliced) {
                err = ENOMEM;
                goto fail;
            }
            memcpy(spliced, target, (size_t)len);
            memcpy(spliced + len, after, rest + 1);
            free(todo);
            todo = spliced;
            p = todo;
            if (last)
                w->through_link = 1;
            if (target[0] == '/') {
                int root = open("/", O_PATH | O_DIRECTORY | O_CLOEXEC);
                if (root < 0) {
                    err = errno;
                    goto fail;
                }
                close(dfd);
                dfd = root;
                sb.len = 0;
                if (shown_put(&sb, "/", 1) != 0) {
                    err = ENOMEM;
                    goto fail;
                }
            }
            continue;
        }
        if (last && !trailing) {
            w->exists = 1;
            w->st = st;
            break;
        }
        if (!S_ISDIR(st.st_mode)) {
            err = ENOTDIR;
            goto fail;
        }
        /* O_NOFOLLOW: a directory swapped for a link since the fstatat
         * fails here instead of being followed unjudged. */
        int sub = openat(dfd, comp, O_PATH | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
        if (sub < 0) {
            err = errno;
            goto fail;
        }
        close(dfd);
        dfd = sub;
        if (shown_put(&sb, comp, n) != 0 || shown_put(&sb, "/", 1) != 0) {
            err = ENOMEM;
            goto fail;
        }
        if (last) {
            strcpy(comp, ".");
            break;
        }
        p = after;
    }
    if (strcmp(comp, ".") == 0) {
        if (fstatat(dfd, ".", &w->st, AT_SYMLINK_NOFOLLOW) != 0) {
            err = errno;
            goto fail;
        }
        w->exists = 1;
        w->shown = strdup(shown_dir(&sb));
    } else {
        size_t n = sb.len + strlen(comp) + 1;
        w->shown = malloc(n);
        if (w->shown)
            snprintf(w->shown, n, "%s%s", sb.len ? sb.s : "", comp);
    }
    w->name = strdup(comp);
    if (!w->name || !w->shown) {
        err = ENOMEM;
        goto fail;
    }
    w->dirfd = dfd;
    dfd = -1;
    rc = 0;
    goto done;
fail:
    cli_error("%s: cannot use '%s': %s", what, path, strerror(err));
done:
    if (dfd >= 0)
        close(dfd);
    free(todo);
    free(sb.s);
    if (rc != 0)
        cli_pathwalk_close(w);
    return rc;
}
