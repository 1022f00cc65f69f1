/*
 * pathwalk.h - resolving a path qmc is about to write through, one
 * component at a time from directory descriptors, so that no symbolic
 * link planted by another user can redirect the write (private to the
 * CLI; outfile.c and outdir.c use it).
 *
 * The rule is the kernel's fs.protected_symlinks rule, applied by qmc
 * itself whatever the sysctl says (it is 0 on many machines): a symbolic
 * link that sits in a sticky, world-writable directory (/tmp) is followed
 * only when it belongs to us (the effective uid) or to the directory's
 * owner.  Every link met on the way is checked, the last component's and
 * the ones inside the path alike, and each link's target is walked the
 * same way, so a chain is only as trusted as its weakest link.
 *
 * The result is a descriptor of the directory that holds the last
 * component and that component's name in it.  Everything done with the
 * file afterwards (open, create, rename) is done relative to that
 * descriptor, so swapping a directory on the way for a link after the
 * check changes nothing: the walk is not repeated by the kernel.
 */
#ifndef QMC_CLI_PATHWALK_H
#define QMC_CLI_PATHWALK_H

#include <stddef.h>
#include <sys/stat.h>

typedef struct cli_pathwalk {
    int dirfd;          /* the directory holding name (an O_PATH descriptor);
                           valid while name is not NULL */
    char *name;         /* the last component, never a symbolic link; "."
                           when the path ends in "/", "." or ".." */
    char *shown;        /* the file as resolved (directories walked, then
                           name), for messages */
    int exists;         /* name exists in dirfd; st is then its lstat */
    int through_link;   /* the last component came from a link's target */
    int dir_only;       /* a missing name followed by "/" in the path: it
                           can only be made as a directory */
    struct stat st;
} cli_pathwalk;

/*
 * Walks path (relative paths from the current directory).  what names the
 * option in error lines ("--out").  Returns 0 with w filled, or
 * CLI_EXIT_FAIL after printing one error line: a link the rule refuses
 * (naming the link, its owner, the directory and its owner), more than 40
 * links, a component that is missing or not a directory, or a system error.
 * A missing last component is not an error (exists is 0; dir_only when
 * the path ends in "/" after it).  w is closed on failure.
 */
int cli_pathwalk_open(cli_pathwalk *w, const char *path, const char *what);

/* Closes the descriptor and frees the names.  Safe on a closed or zeroed
 * walk. */
void cli_pathwalk_close(cli_pathwalk *w);

/* Writes n random letters and digits to out (no terminator): the unique
 * part of a temporary name made beside a walked path with O_EXCL, so that
 * another user cannot make us fail by taking the name first. */
void cli_pathwalk_random(char *out, size_t n);

#endif
