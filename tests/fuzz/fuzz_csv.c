/*
 * fuzz_csv.c - libFuzzer target for the CSV points reader of `qmc
 * discrepancy` (client/cli/csv_read.c), driven as the CLI drives it.
 *
 * The first input byte picks the size of the pieces the rest is fed in, so
 * lines split across pieces are covered.  Checked for every input:
 *   - the result (accepted or not, the points, the reason) is the same fed
 *     whole as fed in pieces;
 *   - an accepted input gives 1 .. max_points points of 1 .. max_dims
 *     coordinates, each finite and in [0, 1];
 *   - a refusal has a NUL-terminated one-line reason.
 * Run twice: with the CLI's caps and with small ones, so that the limit
 * paths are reached by inputs of a few hundred bytes.
 */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "csv_read.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static int run(const char *text, size_t n, size_t piece, size_t max_points,
               uint32_t max_dims, size_t max_line, cli_csv_reader *r)
{
    if (cli_csv_init(r, "fuzz", max_points, max_dims, max_line) != 0)
        __builtin_trap(); /* small sizes: allocation does not fail here */
    int rc = 0;
    for (size_t off = 0; off < n && rc == 0; off += piece)
        rc = cli_csv_feed(r, text + off, n - off < piece ? n - off : piece);
    if (rc == 0)
        rc = cli_csv_finish(r);
    return rc;
}

static void check(const char *text, size_t n, size_t piece, size_t max_points,
                  uint32_t max_dims, size_t max_line)
{
    cli_csv_reader whole, parts;
    int a = run(text, n, n ? n : 1, max_points, max_dims, max_line, &whole);
    int b = run(text, n, piece, max_points, max_dims, max_line, &parts);
    if (a != b)
        __builtin_trap();
    if (a != 0) {
        if (!memchr(whole.why, '\0', sizeof whole.why) || strchr(whole.why, '\n') ||
            !whole.why[0] || strcmp(whole.why, parts.why) != 0)
            __builtin_trap();
    } else {
        if (whole.n == 0 || whole.n > max_points || whole.dims == 0 ||
            whole.dims > max_dims || whole.n != parts.n || whole.dims != parts.dims)
            __builtin_trap();
        for (size_t i = 0; i < whole.n * whole.dims; i++)
            if (!(whole.v[i] >= 0.0 && whole.v[i] <= 1.0) ||
                memcmp(&whole.v[i], &parts.v[i], sizeof whole.v[i]) != 0)
                __builtin_trap();
    }
    cli_csv_close(&whole);
    cli_csv_close(&parts);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size == 0)
        return 0;
    size_t piece = (size_t)data[0] % 64 + 1;
    const char *text = (const char *)data + 1;
    check(text, size - 1, piece, 10000, 64, 4096); /* qmc discrepancy's caps */
    check(text, size - 1, piece, 4, 3, 40);
    return 0;
}
