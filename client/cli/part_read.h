/*
 * part_read.h - the reader of --part files for `qmc merge` (private to the
 * CLI).  Pure (no I/O; bytes fed in pieces of any size), so
 * tests/fuzz/fuzz_part.c drives it exactly as the CLI does.  partial.c
 * writes the format; the two share the constants here.
 *
 * Format (text, one record per line, each ending in '\n', in this order):
 *   qmc-partial 2
 *   fingerprint <16 lowercase hex digits>   the job's qmc_sampling_fingerprint
 *   blocks <1 .. QMC_SAMPLING_MAX_BLOCKS>   the job's block count
 *   seconds <finite, 0 .. 1e12>             this part's wall time
 *   arg <word>                              0 .. CLI_PART_MAX_ARGS of them: the
 *                                           job's integrate arguments in order,
 *                                           with %, blanks and newlines as %XX
 *   sums <block> <count> <nonfinite> <11 hex floats> <top> <top hex floats>
 *                                           consecutive blocks, at least one
 *   digest sha256 <64 lowercase hex digits>
 *   end
 * The digest is SHA-256 (libsodium's crypto_hash_sha256) over every byte
 * of the file before the digest line.  It catches an edited, truncated or
 * corrupted part; it is not a signature: anyone can edit a part and write
 * a new digest, so it proves nothing against forgery.
 * Numbers are whole decimal tokens (no sign, no blanks); count is at most
 * QMC_SAMPLING_BLOCK, nonfinite at most count, top at most
 * QMC_SAMPLING_TOP, the top values non-negative and descending.
 */
#ifndef QMC_CLI_PART_READ_H
#define QMC_CLI_PART_READ_H

#include <stddef.h>
#include <stdint.h>

#include <sodium.h>

#include "linebuf.h"
#include "qmc/sampling.h"

#define CLI_PART_MAGIC "qmc-partial 2"
#define CLI_PART_MAX_ARGS 128
#define CLI_PART_MAX_SECONDS 1e12
/* A line: the longest sums record is about 2 KB; args may be long paths. */
#define CLI_PART_MAX_LINE_BYTES (1u << 16)

/* What one fed line turned out to be. */
typedef enum cli_part_event {
    CLI_PART_HEADER = 1,      /* fingerprint, blocks and seconds are set */
    CLI_PART_ARG,             /* item->word holds the next argument */
    CLI_PART_SUMS,            /* item->sums holds the next block */
    CLI_PART_DONE             /* the end record: digest checked */
} cli_part_event;

typedef struct cli_part_item {
    cli_part_event event;
    char word[CLI_PART_MAX_LINE_BYTES + 1]; /* CLI_PART_ARG, decoded */
    qmc_sampling_sums sums;                 /* CLI_PART_SUMS */
} cli_part_item;

/* Called for each record the reader accepts; return 0 to go on, anything
 * else to stop (the reader then fails with the handler's why). */
typedef int (*cli_part_fn)(void *ctx, const cli_part_item *item);

typedef struct cli_part_reader {
    cli_linebuf lines;
    crypto_hash_sha256_state sha;
    int state;                /* the record expected next (part_read.c) */
    unsigned long lineno;
    uint64_t fingerprint, blocks, next_block;
    double seconds;
    int n_args;
    uint64_t n_sums;
    cli_part_fn on_item;
    void *ctx;
    cli_part_item item;
    char why[256];            /* the reason, after an error */
} cli_part_reader;

/* Returns 0, or -1 (out of memory, why set).  r is large: allocate it. */
int cli_part_init(cli_part_reader *r, cli_part_fn on_item, void *ctx);
void cli_part_close(cli_part_reader *r);
/* Feeds n more bytes.  Returns 0, or -1 with why ("line 5: ..."); a
 * handler's refusal also returns -1, with why as the handler set it
 * (cli_part_refuse). */
int cli_part_feed(cli_part_reader *r, const char *data, size_t n);
/* The end of the input: the file must have ended right after "end". */
int cli_part_finish(cli_part_reader *r);
/* For handlers: sets why (printf-style) and returns a stop value. */
int cli_part_refuse(cli_part_reader *r, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));

/* Lowercase hex of a SHA-256 digest: out holds 65 bytes. */
void cli_part_hex(const unsigned char digest[crypto_hash_sha256_BYTES], char out[65]);

#endif
