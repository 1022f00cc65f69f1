/*
 * fuzz_part.c - libFuzzer target for the --part file reader of `qmc
 * merge` (client/cli/part_read.c), driven as the CLI drives it.
 *
 * The first input byte picks the size of the pieces the rest is fed in.
 * Checked for every input:
 *   - fed whole or in pieces, the reader accepts or refuses alike, with
 *     the same reason and the same records;
 *   - records come in the format's order (one HEADER, then ARGs, then
 *     consecutive SUMS inside the header's block count, then DONE), with
 *     fields inside their documented ranges;
 *   - an accepted input ended with DONE; a refusal has a NUL-terminated
 *     one-line reason.
 * The seeds are real parts (their digests match), so mutations reach
 * every record and the digest check itself.  When the first byte's top
 * bit is set, the harness appends a correct digest line and "end" to the
 * rest, so mutated bodies also get past the digest to the end of a part.
 */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "part_read.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

typedef struct seen {
    cli_part_reader *r;
    int last;                 /* the previous event, 0 before any */
    uint64_t records, hash;   /* count and an order-sensitive hash */
} seen;

static void mix(seen *s, const void *p, size_t n)
{
    const uint8_t *b = p;
    for (size_t i = 0; i < n; i++)
        s->hash = (s->hash ^ b[i]) * 0x100000001b3ull;
}

static int on_item(void *ctx, const cli_part_item *it)
{
    seen *s = ctx;
    const cli_part_reader *r = s->r;
    switch (it->event) {
    case CLI_PART_HEADER:
        if (s->last != 0 || r->blocks == 0 || r->blocks > QMC_SAMPLING_MAX_BLOCKS ||
            !(r->seconds >= 0.0 && r->seconds <= CLI_PART_MAX_SECONDS))
            __builtin_trap();
        mix(s, &r->fingerprint, sizeof r->fingerprint);
        break;
    case CLI_PART_ARG:
        if (s->last != CLI_PART_HEADER && s->last != CLI_PART_ARG)
            __builtin_trap();
        mix(s, it->word, strlen(it->word));
        break;
    case CLI_PART_SUMS:
        if (s->last == 0 || s->last == CLI_PART_DONE || it->sums.block >= r->blocks ||
            it->sums.nonfinite > it->sums.count || it->sums.count > QMC_SAMPLING_BLOCK)
            __builtin_trap();
        mix(s, &it->sums, sizeof it->sums);
        break;
    case CLI_PART_DONE:
        if (s->last != CLI_PART_SUMS)
            __builtin_trap();
        break;
    default:
        __builtin_trap();
    }
    s->last = (int)it->event;
    s->records++;
    return 0;
}

static int run(const char *text, size_t n, size_t piece, cli_part_reader *r, seen *s)
{
    memset(s, 0, sizeof *s);
    s->r = r;
    if (cli_part_init(r, on_item, s) != 0)
        __builtin_trap();
    int rc = 0;
    for (size_t off = 0; off < n && rc == 0; off += piece)
        rc = cli_part_feed(r, text + off, n - off < piece ? n - off : piece);
    if (rc == 0)
        rc = cli_part_finish(r);
    if (rc == 0 && s->last != CLI_PART_DONE)
        __builtin_trap();
    if (rc != 0 && (!memchr(r->why, '\0', sizeof r->why) || strchr(r->why, '\n') ||
                    !r->why[0]))
        __builtin_trap();
    return rc;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size == 0)
        return 0;
    /* The reader holds a 64 KiB item and line: on the heap. */
    static cli_part_reader *a, *b;
    if (!a && (!(a = malloc(sizeof *a)) || !(b = malloc(sizeof *b))))
        __builtin_trap();
    size_t piece = (size_t)data[0] % 64 + 1;
    const char *text = (const char *)data + 1;
    size_t n = size - 1;
    char *sealed = NULL;
    if (data[0] & 0x80) {
        unsigned char d[crypto_hash_sha256_BYTES];
        char hex[65];
        if (sodium_init() < 0 || !(sealed = malloc(n + 100)))
            __builtin_trap();
        crypto_hash_sha256(d, data + 1, n);
        cli_part_hex(d, hex);
        memcpy(sealed, text, n);
        memcpy(sealed + n, "digest sha256 ", 14);
        memcpy(sealed + n + 14, hex, 64);
        memcpy(sealed + n + 78, "\nend\n", 5);
        text = sealed;
        n += 83;
    }
    seen sa, sb;
    int ra = run(text, n, n ? n : 1, a, &sa);
    int rb = run(text, n, piece, b, &sb);
    if (ra != rb || sa.records != sb.records || sa.hash != sb.hash ||
        (ra != 0 && strcmp(a->why, b->why) != 0))
        __builtin_trap();
    cli_part_close(a);
    cli_part_close(b);
    free(sealed);
    return 0;
}
