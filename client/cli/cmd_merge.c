/*
 * cmd_merge.c - `qmc merge [--json] FILE...`: combines --part files into
 * the result a single run would print (the same numbers, bit for bit;
 * seconds are the parts' sum).
 *
 * Every part must describe the same job (same arguments and fingerprint),
 * and together the parts must hold every block exactly once; anything else
 * is an error naming the file and the block.
 */
#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "integrate.h"

enum { LINE_MAX_BYTES = 1 << 16 };

typedef struct merge_state {
    char *args[CLI_MAX_ARGS + 1];
    int n_args;
    unsigned long long fingerprint, blocks;
    int have_header;
    double seconds;
    qmc_sampling_sums *sums;
    unsigned char *seen;
    const char **seen_in;
} merge_state;

static char *decode_word(const char *w)
{
    size_t n = strlen(w);
    char *out = malloc(n + 1), *o = out;
    if (!out)
        return NULL;
    for (; *w; w++) {
        unsigned v;
        if (*w == '%' && sscanf(w + 1, "%2X", &v) == 1) {
            *o++ = (char)v;
            w += 2;
        } else {
            *o++ = *w;
        }
    }
    *o = '\0';
    return out;
}

static int parse_sums(const char *line, qmc_sampling_sums *s)
{
    char *p = (char *)line;
    memset(s, 0, sizeof *s);
    unsigned long long v[3];
    for (int i = 0; i < 3; i++) {
        v[i] = strtoull(p, &p, 10);
        if (*p != ' ')
            return -1;
    }
    s->block = v[0], s->count = v[1], s->nonfinite = v[2];
    double *d[11] = {&s->f[0], &s->f[1], &s->absf[0], &s->absf[1], &s->g[0], &s->g[1],
                     &s->mean_f, &s->mean_g, &s->m2_f, &s->m2_g, &s->c_fg};
    for (int i = 0; i < 11; i++) {
        char *end;
        *d[i] = strtod(p, &end);
        if (end == p)
            return -1;
        p = end;
    }
    long top = strtol(p, &p, 10);
    if (top < 0 || top > QMC_SAMPLING_TOP)
        return -1;
    for (long k = 0; k < top; k++) {
        char *end;
        s->top[k] = strtod(p, &end);
        if (end == p)
            return -1;
        p = end;
    }
    while (*p == ' ' || *p == '\n')
        p++;
    return *p == '\0' ? 0 : -1;
}

/* Reads one part file; first call takes the job's arguments. */
static int read_part(const char *path, merge_state *m, int first_file)
{
    FILE *f = fopen(path, "r");
    if (!f)
        return cli_error("merge: cannot open '%s': %s", path, strerror(errno));
    char *line = malloc(LINE_MAX_BYTES);
    int rc = line ? 0 : cli_error("out of memory");
    unsigned long lineno = 0;
    int n_args = 0, ended = 0, version_ok = 0;
    unsigned long long fp = 0, blocks = 0;
    while (rc == 0 && fgets(line, LINE_MAX_BYTES, f)) {
        lineno++;
        size_t len = strlen(line);
        if (len && line[len - 1] == '\n')
            line[--len] = '\0';
        else if (!feof(f))
            rc = cli_error("merge: %s:%lu: line too long", path, lineno);
        else /* every record ends with a newline: the file was cut short */
            rc = cli_error("merge: %s is truncated (line %lu is incomplete)", path, lineno);
        if (rc)
            break;
        if (lineno == 1) {
            version_ok = strcmp(line, "qmc-partial 1") == 0;
            if (!version_ok)
                rc = cli_error("merge: %s is not a qmc partial result (first line '%.40s')",
                               path, line);
        } else if (strncmp(line, "fingerprint ", 12) == 0) {
            fp = strtoull(line + 12, NULL, 16);
        } else if (strncmp(line, "blocks ", 7) == 0) {
            blocks = strtoull(line + 7, NULL, 10);
        } else if (strncmp(line, "seconds ", 8) == 0) {
            m->seconds += strtod(line + 8, NULL);
        } else if (strncmp(line, "arg ", 4) == 0) {
            char *w = decode_word(line + 4);
            if (!w)
                rc = cli_error("out of memory");
            else if (first_file && n_args < CLI_MAX_ARGS)
                m->args[1 + n_args++] = w;
            else if (!first_file && (n_args >= m->n_args || strcmp(w, m->args[1 + n_args++]) != 0))
                rc = cli_error("merge: %s:%lu: argument '%s' differs from the first part's: "
                               "not the same job", path, lineno, w);
            if (!first_file || rc)
                free(w);
        } else if (strncmp(line, "sums ", 5) == 0) {
            if (!m->sums) {
                rc = cli_error("merge: %s:%lu: block sums before the job's arguments", path,
                               lineno);
                break;
            }
            qmc_sampling_sums s;
            if (parse_sums(line + 5, &s) != 0)
                rc = cli_error("merge: %s:%lu: malformed block sums", path, lineno);
            else if (s.block >= m->blocks)
                rc = cli_error("merge: %s:%lu: block %llu past the job's %llu blocks", path,
                               lineno, (unsigned long long)s.block, m->blocks);
            else if (m->seen[s.block])
                rc = cli_error("merge: block %llu is in both %s and %s",
                               (unsigned long long)s.block, m->seen_in[s.block], path);
            else {
                m->sums[s.block] = s;
                m->seen[s.block] = 1;
                m->seen_in[s.block] = path;
            }
        } else if (strcmp(line, "end") == 0) {
            ended = 1;
        } else {
            rc = cli_error("merge: %s:%lu: unknown record '%.40s'", path, lineno, line);
        }
        /* The header ends with "seconds": set up the block table once. */
        if (rc == 0 && first_file && !m->sums && blocks && strncmp(line, "seconds ", 8) == 0) {
            m->blocks = blocks;
            m->fingerprint = fp;
            m->sums = calloc(blocks, sizeof *m->sums);
            m->seen = calloc(blocks, 1);
            m->seen_in = calloc(blocks, sizeof *m->seen_in);
            if (!m->sums || !m->seen || !m->seen_in)
                rc = cli_error("out of memory for %llu blocks", blocks);
        }
        if (rc == 0 && !first_file && strncmp(line, "seconds ", 8) == 0 &&
            (fp != m->fingerprint || blocks != m->blocks))
            rc = cli_error("merge: %s is a part of a different job (fingerprint %016llx, "
                           "expected %016llx)", path, fp, m->fingerprint);
    }
    if (rc == 0 && ferror(f))
        rc = cli_error("merge: reading %s: %s", path, strerror(errno));
    if (rc == 0 && !ended)
        rc = cli_error("merge: %s is truncated (no end record)", path);
    if (rc == 0 && first_file)
        m->n_args = n_args;
    if (rc == 0 && !first_file && n_args != m->n_args)
        rc = cli_error("merge: %s has different arguments: not the same job", path);
    free(line);
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
                  "same job, and together they must hold every block exactly once.\n",
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
    if (rc == 0 && (qmc_sampling_fingerprint(job) != m.fingerprint ||
                    qmc_sampling_blocks(job) != m.blocks))
        rc = cli_error("merge: the parts were made by a different qmc (job fingerprint "
                       "%016llx, this build makes %016llx)", m.fingerprint,
                       (unsigned long long)qmc_sampling_fingerprint(job));
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
