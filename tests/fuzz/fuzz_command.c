/*
 * fuzz_command.c - libFuzzer target for the bytes `qmc integrate
 * --command` reads from a user's program (client/cli/command_codec.c),
 * driven as the pump drives it.
 *
 * Input: byte 0 picks the format (bit 0: text or f64) and the size of
 * the pieces (bits 1-4: 1..16 bytes), bytes 1-2 the count of values
 * expected (0..65535); the rest is the program's output.  Checked:
 *   - fed whole or in pieces, the decoder ends with the same status, the
 *     same values (bit for bit) and the same reason;
 *   - never more values than the count; DONE exactly when count arrived
 *     and nothing past them; a refusal has a NUL-terminated reason;
 *   - the rest, taken as doubles and written as a text batch of one
 *     dimension (the encoder), reads back as the same doubles (NaN as
 *     NaN), and the batch ends with its empty line.
 */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "command_codec.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

typedef struct run {
    int status;
    size_t got;
    char why[160];
} run;

static run decode(cli_cmd_format fmt, const uint8_t *p, size_t n, size_t count, size_t step,
                  double *vals)
{
    cli_cmd_dec d;
    run r;
    memset(&r, 0, sizeof r);
    if (cli_cmd_dec_init(&d, fmt) != 0)
        __builtin_trap();
    cli_cmd_dec_start(&d, vals, count);
    int st = CLI_CMD_MORE;
    for (size_t i = 0; i < n && st >= 0; i += step)
        st = cli_cmd_dec_feed(&d, (const char *)p + i, n - i < step ? n - i : step);
    if (st >= 0)
        st = cli_cmd_dec_end(&d);
    if (d.got > count || (st == CLI_CMD_DONE) != (d.got == count && st >= 0))
        __builtin_trap();
    if (st < 0 && (d.why[0] == '\0' || !memchr(d.why, '\0', sizeof d.why)))
        __builtin_trap();
    r.status = st;
    r.got = d.got;
    memcpy(r.why, d.why, sizeof r.why);
    cli_cmd_dec_close(&d);
    return r;
}

static void roundtrip(const uint8_t *p, size_t n)
{
    size_t count = n / 8;
    if (count == 0)
        return;
    double *x = malloc(count * sizeof *x), *back = malloc(count * sizeof *back);
    size_t cap = cli_cmd_enc_min_bytes(CLI_CMD_TEXT, 1);
    char *text = malloc(count * cap + 1), *buf = malloc(cap);
    if (!x || !back || !text || !buf)
        __builtin_trap();
    memcpy(x, p, count * sizeof *x);
    cli_cmd_enc e;
    cli_cmd_enc_start(&e, CLI_CMD_TEXT, x, count, 1);
    size_t len = 0, k;
    while ((k = cli_cmd_enc_fill(&e, buf, cap)) > 0) {
        memcpy(text + len, buf, k);
        len += k;
    }
    if (!cli_cmd_enc_done(&e) || len < 2 || text[len - 1] != '\n' || text[len - 2] != '\n')
        __builtin_trap();
    /* Without the batch's empty line, the points are the values. */
    run r = decode(CLI_CMD_TEXT, (const uint8_t *)text, len - 1, count, len, back);
    if (r.status != CLI_CMD_DONE)
        __builtin_trap();
    for (size_t i = 0; i < count; i++)
        if (isnan(x[i]) ? !isnan(back[i]) : memcmp(&x[i], &back[i], sizeof x[i]) != 0)
            __builtin_trap();
    free(x), free(back), free(text), free(buf);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 3)
        return 0;
    cli_cmd_format fmt = (data[0] & 1) ? CLI_CMD_F64 : CLI_CMD_TEXT;
    size_t step = 1 + ((data[0] >> 1) & 15);
    size_t count = (size_t)data[1] | (size_t)data[2] << 8;
    const uint8_t *p = data + 3;
    size_t n = size - 3;
    double *a = calloc(count + 1, sizeof *a), *b = calloc(count + 1, sizeof *b);
    if (!a || !b)
        __builtin_trap();
    run whole = decode(fmt, p, n, count, n ? n : 1, a);
    run cut = decode(fmt, p, n, count, step, b);
    if (whole.status != cut.status || whole.got != cut.got ||
        strcmp(whole.why, cut.why) != 0 || memcmp(a, b, whole.got * sizeof *a) != 0)
        __builtin_trap();
    free(a), free(b);
    roundtrip(p, n);
    return 0;
}
