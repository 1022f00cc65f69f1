/*
 * test_cli_files.c - unit tests of the CLI's file pieces that need no
 * process around them: the line splitter, the CSV points reader, the
 * --part reader (fed whole and byte by byte), and outfile.c's and
 * pathwalk.c's rules on a temporary directory (where the walk ends is
 * checked against stat(2) of the path the kernel resolves).  The digests in the part tests come from libsodium
 * here, and the e2e suite checks the writer's against sha256sum.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmocka.h>

#include "csv_read.h"
#include "linebuf.h"
#include "outfile.h"
#include "part_read.h"
#include "pathwalk.h"

/* ---- linebuf ------------------------------------------------------------------ */

typedef struct lines_seen {
    char text[256];
    int unterminated;
} lines_seen;

static int collect(void *ctx, char *line, size_t len, int terminated)
{
    lines_seen *s = ctx;
    assert_int_equal(strlen(line), len);
    strncat(s->text, line, sizeof s->text - strlen(s->text) - 2);
    strcat(s->text, "|");
    s->unterminated += !terminated;
    return 0;
}

static void test_linebuf(void **state)
{
    (void)state;
    static const char in[] = "ab\n\ncdef\ngh";
    for (size_t piece = 1; piece <= sizeof in; piece++) {
        cli_linebuf lb;
        lines_seen s = {"", 0};
        assert_int_equal(cli_linebuf_init(&lb, 8), 0);
        for (size_t off = 0; off < sizeof in - 1; off += piece)
            assert_int_equal(cli_linebuf_feed(&lb, in + off,
                                              sizeof in - 1 - off < piece ? sizeof in - 1 - off
                                                                          : piece,
                                              collect, &s), 0);
        assert_int_equal(cli_linebuf_end(&lb, collect, &s), 0);
        assert_string_equal(s.text, "ab||cdef|gh|");
        assert_int_equal(s.unterminated, 1);
        cli_linebuf_close(&lb);
    }
    /* 4 bytes fit a cap of 4, 5 do not; a NUL inside the cap wins over
     * the length, however the bytes are split. */
    cli_linebuf lb;
    lines_seen s = {"", 0};
    assert_int_equal(cli_linebuf_init(&lb, 4), 0);
    assert_int_equal(cli_linebuf_feed(&lb, "abcd\n", 5, collect, &s), 0);
    assert_int_equal(cli_linebuf_feed(&lb, "abcde\n", 6, collect, &s), CLI_LINE_TOO_LONG);
    cli_linebuf_close(&lb);
    assert_int_equal(cli_linebuf_init(&lb, 4), 0);
    assert_int_equal(cli_linebuf_feed(&lb, "ab", 2, collect, &s), 0);
    assert_int_equal(cli_linebuf_feed(&lb, "\0cdefgh", 7, collect, &s), CLI_LINE_NUL);
    cli_linebuf_close(&lb);
    assert_int_equal(cli_linebuf_init(&lb, 4), 0);
    assert_int_equal(cli_linebuf_feed(&lb, "ab\0cdefgh", 9, collect, &s), CLI_LINE_NUL);
    cli_linebuf_close(&lb);
}

/* ---- the CSV reader ---------------------------------------------------------------- */

static int csv(const char *text, cli_csv_reader *r)
{
    assert_int_equal(cli_csv_init(r, "input", 3, 4, 32), 0);
    int rc = cli_csv_feed(r, text, strlen(text));
    return rc ? rc : cli_csv_finish(r);
}

static void csv_fails(const char *text, const char *why)
{
    cli_csv_reader r;
    assert_int_equal(csv(text, &r), -1);
    assert_string_equal(r.why, why);
    cli_csv_close(&r);
}

static void test_csv(void **state)
{
    (void)state;
    cli_csv_reader r;
    assert_int_equal(csv("# a comment\n0.5, 0.25\r\n\n  \n1,0\n0x1p-2,1e-1", &r), 0);
    assert_int_equal(r.n, 3);
    assert_int_equal(r.dims, 2);
    const double want[6] = {0.5, 0.25, 1, 0, 0.25, 0.1};
    for (int i = 0; i < 6; i++)
        assert_true(r.v[i] == want[i]);
    cli_csv_close(&r);
    csv_fails("0.5,x\n", "line 1: coordinate 2: 'x' is not a number");
    csv_fails("0.5,\n", "line 1: coordinate 2 is empty");
    csv_fails("0.5\n1.5\n", "line 2: coordinate 1.5 outside [0,1]");
    csv_fails("nan\n", "line 1: coordinate 1: 'nan' is not finite");
    csv_fails("0.5\n0.5,0.5\n", "line 2: 2 coordinates, expected 1");
    csv_fails("0,0,0,0,0\n", "line 1: more than 4 coordinates (the limit)");
    csv_fails("0\n0\n0\n0\n", "more than 3 points (the limit that keeps the O(n^2) work "
                              "bounded)");
    csv_fails("0\n0.000000000000000000000000000000001\n", "line 2: longer than 32 bytes");
    csv_fails("# only\n\n", "input holds no points");
    static const char nul[] = "0.5\n0.\0" "5\n";
    assert_int_equal(cli_csv_init(&r, "input", 3, 4, 32), 0);
    assert_int_equal(cli_csv_feed(&r, nul, sizeof nul - 1), -1);
    assert_string_equal(r.why, "line 2: a NUL byte (not a text file?)");
    cli_csv_close(&r);
}

/* ---- the --part reader -------------------------------------------------------------- */

/* body + its digest line + "end\n", in buf. */
static size_t make_part(const char *body, char *buf, size_t bytes)
{
    unsigned char d[crypto_hash_sha256_BYTES];
    char hex[65];
    assert_true(sodium_init() >= 0);
    crypto_hash_sha256(d, (const unsigned char *)body, strlen(body));
    cli_part_hex(d, hex);
    int n = snprintf(buf, bytes, "%sdigest sha256 %s\nend\n", body, hex);
    assert_true(n > 0 && (size_t)n < bytes);
    return (size_t)n;
}

typedef struct part_seen {
    int headers, args, sums, done;
    char words[128];
    uint64_t blocks[4];
} part_seen;

static int on_item(void *ctx, const cli_part_item *it)
{
    part_seen *s = ctx;
    switch (it->event) {
    case CLI_PART_HEADER: s->headers++; break;
    case CLI_PART_ARG:
        strcat(s->words, it->word);
        strcat(s->words, "|");
        s->args++;
        break;
    case CLI_PART_SUMS: s->blocks[s->sums++ & 3] = it->sums.block; break;
    case CLI_PART_DONE: s->done++; break;
    }
    return 0;
}

/* Reads text fed in pieces of `piece` bytes; returns 0 or -1, why in why. */
static int read_part(const char *text, size_t n, size_t piece, part_seen *s, char *why)
{
    static cli_part_reader r;
    memset(s, 0, sizeof *s);
    assert_int_equal(cli_part_init(&r, on_item, s), 0);
    int rc = 0;
    for (size_t off = 0; off < n && rc == 0; off += piece)
        rc = cli_part_feed(&r, text + off, n - off < piece ? n - off : piece);
    if (rc == 0)
        rc = cli_part_finish(&r);
    strcpy(why, r.why);
    cli_part_close(&r);
    return rc;
}

static const char part_head[] =
    "qmc-partial 2\nfingerprint 00000000deadbeef\nblocks 4\nseconds 1.5\n"
    "arg --integrand\narg a%20b%25\n";
#define SUMS_1 "sums 1 4096 1 0x1p+0 0 0 0 0 0 0 0 0 0 0 2 0x1p+0 0x1p-1\n"
#define SUMS_2 "sums 2 10 0 1 2 3 4 5 6 7 8 9 10 11 0\n"

static void part_fails(const char *body_tail, const char *why_part)
{
    char body[1024], buf[1200], why[256];
    snprintf(body, sizeof body, "%s%s", part_head, body_tail);
    size_t n = make_part(body, buf, sizeof buf);
    part_seen s;
    assert_int_equal(read_part(buf, n, n, &s, why), -1);
    if (!strstr(why, why_part))
        fail_msg("'%s' does not say '%s'", why, why_part);
    assert_int_equal(s.done, 0);
}

static void test_part(void **state)
{
    (void)state;
    char body[1024], buf[1200], why[256];
    snprintf(body, sizeof body, "%s" SUMS_1 SUMS_2, part_head);
    size_t n = make_part(body, buf, sizeof buf);
    part_seen s;
    for (size_t piece = 1; piece <= n; piece += piece < 8 ? 1 : 97) {
        assert_int_equal(read_part(buf, n, piece, &s, why), 0);
        assert_int_equal(s.headers, 1);
        assert_string_equal(s.words, "--integrand|a b%|");
        assert_int_equal(s.sums, 2);
        assert_true(s.blocks[0] == 1 && s.blocks[1] == 2);
        assert_int_equal(s.done, 1);
    }
    /* Any one byte changed in the body: refused (here by the digest or a
     * field check), never accepted. */
    for (size_t i = 0; i < strlen(body); i++) {
        char edited[1200];
        memcpy(edited, buf, n);
        edited[i] = edited[i] == '1' ? '2' : '1';
        assert_int_equal(read_part(edited, n, n, &s, why), -1);
        assert_int_equal(s.done, 0);
    }
    /* Cut anywhere: refused. */
    for (size_t cut = 0; cut < n; cut++)
        assert_int_equal(read_part(buf, cut, 7, &s, why), -1);
    part_fails(SUMS_1 "sums 2 10 11 0 0 0 0 0 0 0 0 0 0 0 0\n", "block 2: 10 points, 11");
    part_fails(SUMS_1 "sums 2 4097 0 0 0 0 0 0 0 0 0 0 0 0 0\n", "4097 points");
    part_fails(SUMS_1 "sums 2 1 0 0 0 0 0 0 0 0 0 0 0 0 2 0x1p-1 0x1p+0\n", "descending");
    part_fails(SUMS_1 "sums 2 1 0 0 0 0 0 0 0 0 0 0 0 0 1 -1\n", "descending");
    part_fails(SUMS_1 "sums 2 1 0 0 0 0 0 0 0 0 0 0 0 0 65\n", "largest values");
    part_fails(SUMS_1 "sums 2 1 0 0 0 0 0 0 0 0 0 0 0 0 0 \n", "largest values");
    part_fails(SUMS_1 "sums 2 1 0 0 0 0 0 0 0 0 0 0 0 x 0\n", "sum 11 is not a number");
    part_fails(SUMS_1 "sums 2 01 0 0 0 0 0 0 0 0 0 0 0 0 0\n", "malformed block sums");
    part_fails(SUMS_1 "sums 2 -1 0 0 0 0 0 0 0 0 0 0 0 0 0\n", "malformed block sums");
    part_fails(SUMS_1 "sums 4 1 0 0 0 0 0 0 0 0 0 0 0 0 0\n", "past the job's 4 blocks");
    part_fails(SUMS_2 SUMS_1, "block 1 where block 3 comes next");
    part_fails(SUMS_1 "arg late\n", "misplaced record 'arg late'");
    part_fails("arg bad%2\n" SUMS_1, "malformed argument");
    part_fails("", "no block sums");
    /* the header, field by field */
    static const char *const heads[][2] = {
        {"qmc-partial 1\n", "version-1"},
        {"qmc-partial 3\n", "not a qmc partial"},
        {"qmc-partial 2\nfingerprint DEADBEEF00000000\n", "16 lowercase hex"},
        {"qmc-partial 2\nfingerprint deadbeef0000000\n", "16 lowercase hex"},
        {"qmc-partial 2\nfingerprint 00000000deadbeef\nblocks 0\n", "1 .. 1048576"},
        {"qmc-partial 2\nfingerprint 00000000deadbeef\nblocks 1048577\n", "1 .. 1048576"},
        {"qmc-partial 2\nfingerprint 00000000deadbeef\nblocks 99999999999999999999\n", "1 .."},
        {"qmc-partial 2\nfingerprint 00000000deadbeef\nblocks 2\nseconds nan\n", "finite"},
        {"qmc-partial 2\nfingerprint 00000000deadbeef\nblocks 2\nseconds -1e308\n", "finite"},
        {"qmc-partial 2\nfingerprint 00000000deadbeef\nblocks 2\nseconds 1e13\n", "finite"},
        {"qmc-partial 2\nfingerprint 00000000deadbeef\nblocks 2\nseconds 1 \n", "finite"},
        {"qmc-partial 2\nblocks 2\n", "fingerprint"},
    };
    for (size_t i = 0; i < sizeof heads / sizeof heads[0]; i++) {
        snprintf(body, sizeof body, "%s" SUMS_1, heads[i][0]);
        n = make_part(body, buf, sizeof buf);
        assert_int_equal(read_part(buf, n, 3, &s, why), -1);
        if (!strstr(why, heads[i][1]))
            fail_msg("header %zu: '%s' does not say '%s'", i, why, heads[i][1]);
    }
    /* after the digest: only end, then nothing */
    snprintf(body, sizeof body, "%s" SUMS_1, part_head);
    n = make_part(body, buf, sizeof buf);
    buf[n++] = 'x';
    buf[n++] = '\n';
    assert_int_equal(read_part(buf, n, n, &s, why), -1);
    assert_non_null(strstr(why, "more after the end record"));
}

/* ---- outfile ------------------------------------------------------------------------- */

static char dir[64];

static char *path_in(const char *name)
{
    static char p[4][128];
    static int k;
    char *out = p[k++ & 3];
    snprintf(out, 128, "%s/%s", dir, name);
    return out;
}

static int count_temps(void)
{
    char cmd[200];
    snprintf(cmd, sizeof cmd, "find %s -name '*.tmp.*' | wc -l", dir);
    FILE *f = popen(cmd, "r");
    int n = -1;
    assert_non_null(f);
    assert_int_equal(fscanf(f, "%d", &n), 1);
    pclose(f);
    return n;
}

/* The directory is made and removed around the test, so a failed
 * assertion leaves nothing behind either. */
static mode_t saved_umask;

static int outfile_setup(void **state)
{
    (void)state;
    strcpy(dir, "/tmp/qmc-test-outfile-XXXXXX");
    saved_umask = umask(022);
    return mkdtemp(dir) ? 0 : -1;
}

static int outfile_teardown(void **state)
{
    (void)state;
    umask(saved_umask);
    char cmd[100];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    return system(cmd) == 0 ? 0 : -1;
}

static void test_outfile(void **state)
{
    (void)state;
    cli_outfile o;
    /* new: 0666 & ~umask; the target appears only on commit */
    assert_int_equal(cli_outfile_open(&o, path_in("a"), "--out"), 0);
    fputs("hello\n", o.f);
    struct stat st;
    assert_int_equal(stat(path_in("a"), &st), -1);
    assert_int_equal(count_temps(), 1);
    assert_int_equal(cli_outfile_commit(&o), 0);
    assert_int_equal(stat(path_in("a"), &st), 0);
    assert_int_equal(st.st_mode & 0777, 0644);
    assert_int_equal(st.st_size, 6);
    /* existing: its mode is kept */
    assert_int_equal(chmod(path_in("a"), 0602), 0);
    assert_int_equal(cli_outfile_open(&o, path_in("a"), "--out"), 0);
    assert_int_equal(cli_outfile_commit(&o), 0);
    assert_int_equal(stat(path_in("a"), &st), 0);
    assert_int_equal(st.st_mode & 0777, 0602);
    assert_int_equal(st.st_size, 0);
    /* abort: the target as it was, no temp */
    assert_int_equal(cli_outfile_open(&o, path_in("a"), "--out"), 0);
    fputs("lost\n", o.f);
    cli_outfile_abort(&o);
    assert_int_equal(stat(path_in("a"), &st), 0);
    assert_int_equal(st.st_size, 0);
    assert_int_equal(count_temps(), 0);
    /* read-only, a directory, a dangling link: refused */
    assert_int_equal(chmod(path_in("a"), 0444), 0);
    assert_int_not_equal(cli_outfile_open(&o, path_in("a"), "--out"), 0);
    assert_int_not_equal(cli_outfile_open(&o, dir, "--out"), 0);
    assert_int_equal(symlink("nowhere", path_in("dangling")), 0);
    assert_int_not_equal(cli_outfile_open(&o, path_in("dangling"), "--out"), 0);
    assert_int_not_equal(cli_outfile_open(&o, "", "--out"), 0);
    /* commit_all: a failing file (its directory gone) stops the rest */
    assert_int_equal(mkdir(path_in("sub"), 0700), 0);
    cli_outfile two[2];
    assert_int_equal(cli_outfile_open(&two[0], path_in("b"), "--csv"), 0);
    assert_int_equal(cli_outfile_open(&two[1], path_in("sub/c"), "--png"), 0);
    fclose(two[1].f); /* make its flush fail: a closed stream */
    two[1].f = fopen("/dev/full", "w");
    fputs("x", two[1].f);
    assert_int_not_equal(cli_outfile_commit_all(two, 2), 0);
    assert_int_equal(stat(path_in("b"), &st), -1);
    assert_int_equal(count_temps(), 0);
    /* the same file */
    assert_true(cli_outfile_same(path_in("a"), path_in("a")));
    assert_true(cli_outfile_same(path_in("x"), path_in("./x")));
    assert_true(cli_outfile_same(path_in("x"), path_in("sub/../x")));
    assert_false(cli_outfile_same(path_in("x"), path_in("y")));
    assert_false(cli_outfile_same(path_in("a"), path_in("x")));
    assert_int_equal(symlink("a", path_in("link")), 0);
    assert_true(cli_outfile_same(path_in("a"), path_in("link")));
}

/* ---- pathwalk --------------------------------------------------------------------- */

/* 1 when w's directory is the directory at path (the same inode). */
static int walked_to(const cli_pathwalk *w, const char *path)
{
    struct stat a, b;
    return fstat(w->dirfd, &a) == 0 && stat(path, &b) == 0 && a.st_dev == b.st_dev &&
           a.st_ino == b.st_ino;
}

static void test_pathwalk(void **state)
{
    (void)state;
    cli_pathwalk w;
    assert_int_equal(mkdir(path_in("d"), 0755), 0);
    assert_int_equal(mkdir(path_in("d/e"), 0755), 0);
    FILE *f = fopen(path_in("d/e/file"), "w");
    assert_non_null(f);
    fclose(f);
    /* plain, "..", ".", doubled slashes */
    assert_int_equal(cli_pathwalk_open(&w, path_in("d/e/../e/.//file"), "--out"), 0);
    assert_true(walked_to(&w, path_in("d/e")));
    assert_string_equal(w.name, "file");
    assert_true(w.exists && S_ISREG(w.st.st_mode) && !w.through_link);
    assert_string_equal(w.shown, path_in("d/e/file"));
    cli_pathwalk_close(&w);
    /* a missing last component is a new file, not an error */
    assert_int_equal(cli_pathwalk_open(&w, path_in("d/new"), "--out"), 0);
    assert_true(walked_to(&w, path_in("d")) && !w.exists && !w.dir_only);
    cli_pathwalk_close(&w);
    assert_int_equal(cli_pathwalk_open(&w, path_in("d/newdir/"), "--out"), 0);
    assert_true(walked_to(&w, path_in("d")) && !w.exists && w.dir_only);
    assert_string_equal(w.name, "newdir");
    cli_pathwalk_close(&w);
    /* a trailing slash or "." names the directory itself */
    assert_int_equal(cli_pathwalk_open(&w, path_in("d/e/"), "--out"), 0);
    assert_true(walked_to(&w, path_in("d/e")) && w.exists && S_ISDIR(w.st.st_mode));
    assert_string_equal(w.name, ".");
    cli_pathwalk_close(&w);
    /* links: relative ones from the link's directory, a chain, an absolute
     * one, a link inside the path; where a link ends at a missing name */
    assert_int_equal(symlink("e/file", path_in("d/l1")), 0);
    assert_int_equal(symlink("l1", path_in("d/l2")), 0);
    assert_int_equal(symlink(path_in("d/e"), path_in("abs")), 0);
    assert_int_equal(symlink("e/none", path_in("d/dangling")), 0);
    assert_int_equal(cli_pathwalk_open(&w, path_in("d/l2"), "--out"), 0);
    assert_true(walked_to(&w, path_in("d/e")) && w.exists && w.through_link);
    assert_string_equal(w.name, "file");
    cli_pathwalk_close(&w);
    assert_int_equal(cli_pathwalk_open(&w, path_in("abs/../l1"), "--out"), 0);
    assert_true(walked_to(&w, path_in("d/e")) && w.exists); /* ".." of the target */
    cli_pathwalk_close(&w);
    assert_int_equal(cli_pathwalk_open(&w, path_in("d/dangling"), "--out"), 0);
    assert_true(!w.exists && w.through_link);
    cli_pathwalk_close(&w);
    /* refused: a loop, a file used as a directory, a missing directory */
    assert_int_equal(symlink("loop2", path_in("loop1")), 0);
    assert_int_equal(symlink("loop1", path_in("loop2")), 0);
    assert_int_not_equal(cli_pathwalk_open(&w, path_in("loop1"), "--out"), 0);
    assert_null(w.name);
    assert_int_not_equal(cli_pathwalk_open(&w, path_in("d/e/file/x"), "--out"), 0);
    assert_int_not_equal(cli_pathwalk_open(&w, path_in("nodir/x"), "--out"), 0);
    /* The protected_symlinks rule needs links of other owners: root only. */
    if (geteuid() != 0)
        return;
    const uid_t other = 54321, third = 54322;
    assert_int_equal(mkdir(path_in("st"), 0755), 0);
    assert_int_equal(chmod(path_in("st"), 01777), 0);
    assert_int_equal(symlink(path_in("d/e/file"), path_in("st/l")), 0);
    assert_int_equal(symlink(path_in("d/e"), path_in("st/dirlink")), 0);
    assert_int_equal(lchown(path_in("st/l"), other, (gid_t)-1), 0);
    assert_int_equal(lchown(path_in("st/dirlink"), other, (gid_t)-1), 0);
    assert_int_not_equal(cli_pathwalk_open(&w, path_in("st/l"), "--out"), 0);
    assert_int_not_equal(cli_pathwalk_open(&w, path_in("st/dirlink/file"), "--out"), 0);
    assert_int_not_equal(cli_pathwalk_open(&w, path_in("st/dirlink/new"), "--out"), 0);
    /* the directory's owner's link is followed; a third user's is not */
    assert_int_equal(chown(path_in("st"), other, (gid_t)-1), 0);
    assert_int_equal(cli_pathwalk_open(&w, path_in("st/dirlink/file"), "--out"), 0);
    assert_true(walked_to(&w, path_in("d/e")));
    cli_pathwalk_close(&w);
    assert_int_equal(lchown(path_in("st/l"), third, (gid_t)-1), 0);
    assert_int_not_equal(cli_pathwalk_open(&w, path_in("st/l"), "--out"), 0);
    /* ... and so is ours, and any link once the directory is closed to others */
    assert_int_equal(lchown(path_in("st/l"), 0, (gid_t)-1), 0);
    assert_int_equal(cli_pathwalk_open(&w, path_in("st/l"), "--out"), 0);
    cli_pathwalk_close(&w);
    assert_int_equal(lchown(path_in("st/l"), third, (gid_t)-1), 0);
    assert_int_equal(chmod(path_in("st"), 01770), 0);
    assert_int_equal(cli_pathwalk_open(&w, path_in("st/l"), "--out"), 0);
    cli_pathwalk_close(&w);
    /* sticky and world-writable both count: o+w without the sticky bit */
    assert_int_equal(chmod(path_in("st"), 0777), 0);
    assert_int_equal(cli_pathwalk_open(&w, path_in("st/l"), "--out"), 0);
    cli_pathwalk_close(&w);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_linebuf),
        cmocka_unit_test(test_csv),
        cmocka_unit_test(test_part),
        cmocka_unit_test_setup_teardown(test_outfile, outfile_setup, outfile_teardown),
        cmocka_unit_test_setup_teardown(test_pathwalk, outfile_setup, outfile_teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
