/*
 * partial.c - writes --part files: everything `qmc merge` needs to finish
 * a job bit for bit as a single run would.  The format, and its reader,
 * are in part_read.h; sums are written as C99 hex floats, which read back
 * exactly, and the file ends with a SHA-256 digest of what came before.
 */
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "integrate.h"
#include "part_read.h"

/* Writes to f and feeds the digest the same bytes. */
typedef struct hashed_out {
    FILE *f;
    crypto_hash_sha256_state sha;
} hashed_out;

static void put(hashed_out *h, const char *s, size_t n)
{
    fwrite(s, 1, n, h->f);
    crypto_hash_sha256_update(&h->sha, (const unsigned char *)s, n);
}

static void putf(hashed_out *h, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void putf(hashed_out *h, const char *fmt, ...)
{
    char buf[512];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    /* Every format here is one number or a short word: never cut. */
    put(h, buf, n < 0 ? 0 : (size_t)n < sizeof buf ? (size_t)n : sizeof buf - 1);
}

static void put_word(hashed_out *h, const char *w)
{
    for (; *w; w++) {
        if (*w == '%' || *w == ' ' || *w == '\n' || *w == '\r' || *w == '\t')
            putf(h, "%%%02X", (unsigned char)*w);
        else
            put(h, w, 1);
    }
}

int cli_partial_write(FILE *f, const cli_integrate *o, const qmc_sampling_job *job,
                      const qmc_sampling_sums *sums, uint64_t first, uint64_t count,
                      double seconds)
{
    return cli_partial_write_sums(f, o, qmc_sampling_fingerprint(job), qmc_sampling_blocks(job),
                                  sums, first, count, seconds);
}

int cli_partial_write_sums(FILE *f, const cli_integrate *o, uint64_t fingerprint,
                           uint64_t blocks, const qmc_sampling_sums *sums, uint64_t first,
                           uint64_t count, double seconds)
{
    if (sodium_init() < 0)
        return cli_error("integrate: libsodium cannot start"), -1;
    hashed_out h;
    h.f = f;
    crypto_hash_sha256_init(&h.sha);
    putf(&h, CLI_PART_MAGIC "\nfingerprint %016llx\nblocks %llu\nseconds %.6f\n",
         (unsigned long long)fingerprint, (unsigned long long)blocks, seconds);
    for (int i = 0; i < o->n_job_args; i++) {
        put(&h, "arg ", 4);
        put_word(&h, o->job_args[i]);
        put(&h, "\n", 1);
    }
    for (uint64_t i = 0; i < count; i++) {
        const qmc_sampling_sums *s = &sums[i];
        if (s->block != first + i)
            return cli_error("integrate: internal error: block %llu out of place",
                             (unsigned long long)(first + i)), -1;
        putf(&h, "sums %llu %llu %llu", (unsigned long long)s->block,
             (unsigned long long)s->count, (unsigned long long)s->nonfinite);
        const double v[11] = {s->f[0], s->f[1], s->absf[0], s->absf[1], s->g[0], s->g[1],
                              s->mean_f, s->mean_g, s->m2_f, s->m2_g, s->c_fg};
        for (int k = 0; k < 11; k++)
            putf(&h, " %a", v[k]);
        int top = QMC_SAMPLING_TOP;
        while (top > 0 && s->top[top - 1] == 0.0)
            top--;
        putf(&h, " %d", top);
        for (int k = 0; k < top; k++)
            putf(&h, " %a", s->top[k]);
        put(&h, "\n", 1);
    }
    unsigned char digest[crypto_hash_sha256_BYTES];
    char hex[65];
    crypto_hash_sha256_final(&h.sha, digest);
    cli_part_hex(digest, hex);
    fprintf(f, "digest sha256 %s\nend\n", hex);
    return 0;
}
