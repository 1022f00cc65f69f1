/*
 * cmd_merge.c - `qmc merge [--json] FILE...`: combines --part files into
 * the result a single run would print (the same numbers, bit for bit;
 * seconds are the parts' sum).
 *
 * Every part must be intact (its SHA-256 digest matches, every field is
 * valid: part_read.c), describe the same job (same arguments and
 * fingerprint), and together the parts must hold every block exactly once;
 * anything else is an error naming the file and the block.
 */
#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "integrate.h"
#include "part_read.h"

typedef struct merge_state {
    char *args[CLI_MAX_ARGS + 1];
    int n_args;
    unsigned long long fingerprint, blocks;
    double seconds;
    qmc_sampling_sums *sums;
    unsigned char *seen;
    const char **seen_in;
} merge_state;

/* One part being read: what the reader hands on goes into the state. */
typedef struct part_ctx {
    merge_state *m;
    cli_part_reader *r;
    const char *path;
    int first_file;
    int n_args;
} part_ctx;

static int on_part_item(void *ctx, const cli_part_item *it)
{
    part_ctx *pc = ctx;
    merge_state *m = pc->m;
    cli_part_reader *r = pc->r;
    switch (it->event) {
    case CLI_PART_HEADER:
        if (pc->first_file) {
            m->blocks = r->blocks;
            m->fingerprint = r->fingerprint;
            m->sums = calloc(r->blocks, sizeof *m->sums);
            m->seen = calloc(r->blocks, 1);
            m->seen_in = calloc(r->blocks, sizeof *m->seen_in);
            if (!m->sums || !m->seen || !m->seen_in)
                return cli_part_refuse(r, "out of memory for %llu blocks",
                                       (unsigned long long)r->blocks);
        } else if (r->fingerprint != m->fingerprint) {
            return cli_part_refuse(r, "it is a part of a different job (fingerprint %016llx; "
                                   "the first part's is %016llx)",
                                   (unsigned long long)r->fingerprint, m->fingerprint);
        } else if (r->blocks != m->blocks) {
            return cli_part_refuse(r, "it is a part of a different job (%llu blocks; the "
                                   "first part's job has %llu)",
                                   (unsigned long long)r->blocks, m->blocks);
        }
        m->seconds += r->seconds;
        return 0;
    case CLI_PART_ARG:
        if (pc->first_file) {
            if (pc->n_args >= CLI_MAX_ARGS)
                return cli_part_refuse(r, "more than %d arguments", CLI_MAX_ARGS);
            if (!(m->args[1 + pc->n_args] = strdup(it->word)))
                return cli_part_refuse(r, "out of memory");
            m->n_args = ++pc->n_args;
        } else if (pc->n_args >= m->n_args || strcmp(it->word, m->args[1 + pc->n_args]) != 0) {
            return cli_part_refuse(r, "line %lu: argument '%.60s' differs from the first "
                                   "part's: not the same job", r->lineno, it->word);
        } else {
            pc->n_args++;
        }
        return 0;
    case CLI_PART_SUMS: {
        const qmc_sampling_sums *s = &it->sums;
        if (!pc->first_file && pc->n_args != m->n_args)
            return cli_part_refuse(r, "it has fewer arguments than the first part: not the "
                                   "same job");
        if (m->seen[s->block])
            return cli_part_refuse(r, "block %llu is in both %s and %s",
                                   (unsigned long long)s->block, m->seen_in[s->block],
                                   pc->path);
        m->sums[s->block] = *s;
        m->seen[s->block] = 1;
        m->seen_in[s->block] = pc->path;
        return 0;
    }
    case CLI_PART_DONE:
        return 0;
    }
    return 0;
}

/* Reads one part file; the first file sets the job.  Its records reach
 * the state as they are read, and a part whose digest fails at the end
 * fails the whole merge, so nothing of it is ever used. */
static int read_part(const char *path, merge_state *m, int first_file)
{
    FILE *f = fopen(path, "r");
    if (!f)
        return cli_error("merge: cannot open '%s': %s", path, strerror(errno));
    cli_part_reader *r = malloc(sizeof *r);
    part_ctx pc = {m, r, path, first_file, 0};
    int rc = 0;
    if (!r || cli_part_init(r, on_part_item, &pc) != 0) {
        rc = cli_error("merge: out of memory");
    } else {
        char buf[1 << 16];
        size_t n;
        int bad = 0;
        while (!bad && (n = fread(buf, 1, sizeof buf, f)) > 0)
            bad = cli_part_feed(r, buf, n) != 0;
        if (!bad && ferror(f))
            rc = cli_error("merge: reading %s: %s", path, strerror(errno));
        else if (bad || cli_part_finish(r) != 0)
            rc = cli_error("merge: %s: %s", path, r->why);
    }
    if (r)
        cli_part_close(r);
    free(r);
    fclose(f);
    return rc;
}

int cli_cmd_merge(int argc, char **argv)
{
    int json = 0, n_files = 0;
    merge_state m;
    memset(&m, 0, sizeof m);
    m.args[0] = "integrate";
    int rc = 0;
    for (int i = 1; i < argc && rc == 0; i++) {
        if (strcmp(argv[i], "--json") == 0) {
            json = 1;
        } else if (strcmp(argv[i], "--help") == 0) {
            fputs("usage: qmc merge [--json] FILE...\n\n"
                  "Combines the partial results that `qmc integrate --part K/P` printed\n"
                  "into the result of the whole job: the same numbers as one run, bit for\n"
                  "bit (seconds are the sum of the parts').  Every part must come from the\n"
                  "same job, and together they must hold every block exactly once.\n"
                  "Each part ends with a SHA-256 digest of its content: an edited or\n"
                  "damaged part is refused (the digest catches accidents and edits, not\n"
                  "forgery: whoever edits a part can write a new digest).\n",
                  stdout);
            return CLI_EXIT_OK;
        } else if (strncmp(argv[i], "--", 2) == 0) {
            rc = cli_error("merge: unknown option '%s' (try qmc merge --help)", argv[i]);
        } else {
            rc = read_part(argv[i], &m, n_files == 0);
            n_files++;
        }
    }
    if (rc == 0 && n_files == 0)
        rc = cli_error("merge: name the partial result files to combine");
    if (rc == 0 && !m.sums)
        rc = cli_error("merge: the first part names no job");
    for (unsigned long long b = 0; rc == 0 && b < m.blocks; b++)
        if (!m.seen[b]) {
            unsigned long long e = b;
            while (e + 1 < m.blocks && !m.seen[e + 1])
                e++;
            rc = cli_error("merge: blocks %llu..%llu of %llu are in no part: a part is missing",
                           b, e, m.blocks);
        }
    cli_integrate o;
    cli_problem p;
    int have_problem = 0;
    if (rc == 0) {
        int r = cli_integrate_parse(1 + m.n_args, m.args, &o);
        if (r != 0)
            rc = cli_error("merge: the parts' arguments do not parse");
    }
    if (rc == 0) {
        if (cli_problem_make(&o, &p) != 0)
            rc = CLI_EXIT_FAIL;
        else
            have_problem = 1;
    }
    if (rc == 0 && cli_integrate_defaults(&o, &p) != 0)
        rc = CLI_EXIT_FAIL;
    qmc_sampling_job *job = NULL;
    char why[256];
    if (rc == 0 && qmc_sampling_job_new(&o.spec, p.f, p.g, &job, why, sizeof why) != 0)
        rc = cli_error("merge: %s", why);
    /* A --command's f is a program merge does not run: its parts'
     * fingerprints (which hold f's values at four points) agree with each
     * other, and the job's shape is checked by its block count. */
    if (rc == 0 && o.command && qmc_sampling_blocks(job) != m.blocks)
        rc = cli_error("merge: the parts were made by a different qmc (%llu blocks; this "
                       "build makes %llu of the job)", m.blocks,
                       (unsigned long long)qmc_sampling_blocks(job));
    if (rc == 0 && !o.command && (qmc_sampling_fingerprint(job) != m.fingerprint ||
                                  qmc_sampling_blocks(job) != m.blocks))
        rc = cli_error("merge: the parts were made by a different qmc (job fingerprint "
                       "%016llx over %llu blocks; this build makes %016llx over %llu)",
                       m.fingerprint, m.blocks,
                       (unsigned long long)qmc_sampling_fingerprint(job),
                       (unsigned long long)qmc_sampling_blocks(job));
    cli_report rep;
    memset(&rep, 0, sizeof rep);
    if (rc == 0) {
        rep.requested = rep.method = o.method;
        rep.problem = &p;
        rep.confidence = o.spec.confidence;
        rep.seconds = m.seconds;
        qmc_sampling_describe(&o.spec, rep.detail, sizeof rep.detail);
        if (qmc_sampling_finish(job, m.sums, m.blocks, &rep.res, &rep.cv) != 0)
            rc = cli_error("merge: the block sums do not form a complete job");
        else if (p.f->audit) /* as qmc_integrate does: merged == whole, flags too */
            rep.res.flags |= p.f->audit(p.f->ctx, &rep.res);
    }
    if (rc == 0) {
        cli_report_print(stdout, &rep, json);
        if (fflush(stdout) != 0)
            rc = cli_error("merge: writing the result failed");
    }
    qmc_sampling_job_free(job);
    if (have_problem)
        cli_problem_free(&p);
    for (int i = 1; i <= m.n_args; i++)
        free(m.args[i]);
    free(m.sums);
    free(m.seen);
    free(m.seen_in);
    return rc;
}
