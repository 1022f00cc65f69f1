/*
 * flag_report.c - the per-flag precision table of `qmc stability` and `qmc
 * compare` (flag_report.h).  Writes Markdown only; counts nothing itself.
 */
#include "flag_report.h"

#include "qmc/result.h"

/* "n (p%)" with p the share of `of`; "0" for none. */
static void count_share(FILE *f, uint32_t n, uint32_t of)
{
    if (n == 0 || of == 0)
        fprintf(f, "%u", n);
    else
        fprintf(f, "%u (%.1f%%)", n, 100.0 * n / of);
}

static void row(FILE *f, const char *key, uint32_t on_ok, uint32_t on_bad,
                const qmc_stab_flag_tally *t)
{
    fprintf(f, "| %s | ", key);
    count_share(f, on_ok, t->correct);
    fputs(" | ", f);
    count_share(f, on_bad, t->wrong);
    fputs(" | ", f);
    if (on_ok + on_bad)
        fprintf(f, "%.0f%%", 100.0 * on_bad / (on_ok + on_bad));
    else
        fputs("-", f);
    fputs(" |\n", f);
}

int cli_flag_report(FILE *f, const qmc_stab_flag_tally *t)
{
    fprintf(f, "%u runs with a bar: %u correct (covered), %u wrong.\n\n", t->correct + t->wrong,
            t->correct, t->wrong);
    fputs("| flag | on correct answers (share of them) | on wrong answers (share of them) "
          "| precision: wrong / fired |\n|---|---|---|---|\n", f);
    for (int b = 0; b < 32; b++) {
        uint32_t bit = 1u << b;
        if (t->on_correct[b] + t->on_wrong[b] == 0)
            continue;
        const char *key = qmc_flag_key(bit);
        row(f, key[0] ? key : "(unnamed bit)", t->on_correct[b], t->on_wrong[b], t);
    }
    row(f, "any flag", t->correct_flagged, t->wrong_flagged, t);
    fputc('\n', f);
    return ferror(f);
}
