/*
 * stability_output.c - what `qmc stability` writes: the CSV (one row a
 * cell), REPORT.md (the matrix as a table and the silent cells in words),
 * JSON, the summary on stdout, and the heat map through gnuplot.
 */
#include <math.h>
#include <string.h>

#include "cli.h"
#include "flag_report.h"
#include "gnuplot.h"
#include "outdir.h"
#include "stability.h"

static const char *error_kind_name(qmc_error_kind k)
{
    return k == QMC_ERROR_STDERR ? "stderr" : k == QMC_ERROR_ESTIMATE ? "estimate" : "none";
}

/* Flags as "a|b|c" (or "" for none). */
static void flags_text(uint32_t flags, char *buf, size_t bytes)
{
    size_t used = 0;
    buf[0] = '\0';
    for (int b = 0; b < 32; b++)
        if (flags & (1u << b)) {
            int n = snprintf(buf + used, bytes - used, "%s%s", used ? "|" : "",
                             qmc_flag_key(1u << b)[0] ? qmc_flag_key(1u << b) : "bit");
            if (n < 0 || (size_t)n >= bytes - used)
                return;
            used += (size_t)n;
        }
}

static void csv_text(FILE *f, const char *s)
{
    fputc('"', f);
    for (; *s; s++) {
        if (*s == '"')
            fputc('"', f);
        if ((unsigned char)*s >= 0x20)
            fputc(*s, f);
    }
    fputc('"', f);
}

/* A number for CSV and Markdown: empty for "none", else %.6g. */
static void num(FILE *f, double v)
{
    if (isnan(v))
        fputs("nan", f);
    else
        fprintf(f, "%.6g", v);
}

int cli_stab_write_csv(FILE *f, const cli_stab_matrix *mx)
{
    fputs("case,category,method,class,runs,ok_runs,ok_flagged_runs,flagged_runs,refused_runs,"
          "silent_runs,seed,method_used,estimate,error_kind,reported_error,truth,truth_error,"
          "truth_source,abs_error,ratio,flags,evals,seconds,reason\n", f);
    for (size_t r = 0; r < mx->n_cases; r++)
        for (size_t c = 0; c < mx->n_methods; c++) {
            const cli_stab_cell *cell = &mx->cells[r * mx->n_methods + c];
            const cli_stab_ref *ref = &mx->refs[r];
            const qmc_stab_tally *t = &cell->tally;
            int refused = cell->v.cls == QMC_STAB_REFUSED;
            char flags[256];
            flags_text(refused ? 0 : cell->res.flags, flags, sizeof flags);
            fprintf(f, "%s,", cell->c->name);
            csv_text(f, cell->c->category);
            fprintf(f, ",%s,%s,%u,%u,%u,%u,%u,%u,%llu,%s,", cell->m->name,
                    qmc_stab_class_name(cell->cls), t->runs, t->ok, t->ok_flagged, t->flagged,
                    t->refused, t->silent, (unsigned long long)cell->seed, cell->method_used);
            if (refused) {
                fputs(",,,", f);
            } else {
                num(f, cell->res.estimate);
                fprintf(f, ",%s,", error_kind_name(cell->res.error_kind));
                if (cell->res.error_kind != QMC_ERROR_NONE)
                    num(f, cell->res.error);
                fputc(',', f);
            }
            num(f, ref->truth.value);
            fputc(',', f);
            num(f, ref->truth.abs_error);
            fprintf(f, ",%s,", ref->source);
            if (!refused && !isnan(cell->v.abs_error))
                num(f, cell->v.abs_error);
            fputc(',', f);
            if (!refused && !isnan(cell->v.ratio))
                num(f, cell->v.ratio);
            fprintf(f, ",%s,%llu,%.4f,", flags,
                    refused ? 0ull : (unsigned long long)cell->res.evals, cell->seconds);
            csv_text(f, cell->reason);
            fputc('\n', f);
        }
    return ferror(f) ? -1 : 0;
}

static const char *short_class(qmc_stab_class c)
{
    switch (c) {
    case QMC_STAB_OK: return "ok";
    case QMC_STAB_FLAGGED: return "flag";
    case QMC_STAB_REFUSED: return "ref";
    case QMC_STAB_SILENT: return "**SILENT**";
    }
    return "?";
}

/* One silent (or any) cell in words. */
static void cell_words(FILE *f, const cli_stab_cell *cell, const cli_stab_ref *ref)
{
    fprintf(f, "- **%s** x `%s`", cell->c->name, cell->m->name);
    if (cell->method_used[0] && strcmp(cell->method_used, cell->m->name) != 0 &&
        strncmp(cell->m->name, cell->method_used, strlen(cell->method_used)) != 0)
        fprintf(f, " (ran %s)", cell->method_used);
    fprintf(f, ": %u of %u runs silent; ", cell->tally.silent, cell->tally.runs);
    if (cell->m->randomized)
        fprintf(f, "e.g. seed %llu ", (unsigned long long)cell->seed);
    fprintf(f, "gave %.10g", cell->res.estimate);
    if (cell->res.error_kind == QMC_ERROR_NONE)
        fputs(" with no bar", f);
    else
        fprintf(f, " +- %.3g", cell->res.error);
    fprintf(f, " against %.10g (%s): |error| %.3g", ref->truth.value, ref->source,
            cell->v.abs_error);
    if (isfinite(cell->v.ratio))
        fprintf(f, ", %.3g x the bar", cell->v.ratio);
    fprintf(f, ", %llu evaluations, no flag. %s.\n", (unsigned long long)cell->res.evals,
            cell->c->why);
}

static uint32_t bit_count(const uint32_t *per_bit, uint32_t flag)
{
    for (int b = 0; b < 32; b++)
        if ((1u << b) == flag)
            return per_bit[b];
    return 0;
}

/* Where the false alarms at normal budgets come from: per method, its
 * correct runs and how many of them carry error_unreliable or any flag. */
static void false_alarms_by_method(FILE *f, const cli_stab_matrix *mx)
{
    fputs("Correct answers flagged anyway, by method (normal budgets):\n\n| method | correct "
          "runs | with error_unreliable | with any flag |\n|---|---|---|---|\n", f);
    for (size_t c = 0; c < mx->n_methods; c++) {
        qmc_stab_flag_tally t = {0};
        for (size_t r = 0; r < mx->n_cases; r++)
            if (!mx->cases[r]->tiny)
                qmc_stab_flag_tally_merge(&t, &mx->cells[r * mx->n_methods + c].flags);
        fprintf(f, "| %s | %u | %u | %u |\n", mx->methods[c].name, t.correct,
                bit_count(t.on_correct, QMC_FLAG_ERROR_UNRELIABLE), t.correct_flagged);
    }
    fputc('\n', f);
}

int cli_stab_write_report(FILE *f, const cli_stab_matrix *mx)
{
    size_t total = mx->n_cases * mx->n_methods;
    fprintf(f, "# qmc stability%s\n\n", mx->quick ? " --quick" : "");
    fprintf(f, "%zu methods x %zu failure cases = %zu cells, %u runs, %.1f s.\n"
            "Sampling methods and tensor rules get %llu evaluations a run (less where a\n"
            "case says so), adaptive ones (gauss-kronrod, cubature, clenshaw-curtis,\n"
            "auto) a cap of %llu; randomized methods run on %u seeds (64 on the\n"
            "tiny-budget cases).\n\n",
            mx->n_methods, mx->n_cases, total, mx->runs, mx->seconds,
            (unsigned long long)mx->default_evals, (unsigned long long)mx->adaptive_evals,
            mx->default_seeds);
    fprintf(f, "| class | cells |\n|---|---|\n| OK | %u |\n| FLAGGED | %u |\n"
            "| REFUSED | %u |\n| SILENT | %u |\n\n",
            mx->count[QMC_STAB_OK], mx->count[QMC_STAB_FLAGGED], mx->count[QMC_STAB_REFUSED],
            mx->count[QMC_STAB_SILENT]);
    fprintf(f, "**Silent cells: %u.**  Correct answers that carry a flag anyway (false\n"
            "alarms): %u of %u runs on the cases with a normal budget; %u of %u runs in\n"
            "all, the tiny-budget cases included (where a flag such as tail_untested is\n"
            "what the evidence calls for).\n\n", mx->count[QMC_STAB_SILENT],
            mx->ok_flagged_runs_normal, mx->runs_normal, mx->ok_flagged_runs, mx->runs);
    fputs("A cell is OK when |estimate - truth| <= 3 x the reported error (plus the\n"
          "reference's own error and 64 ulps of rounding), FLAGGED when it is not but a\n"
          "flag says so (or the method says it has no bar), REFUSED when the method\n"
          "declined with an error, and SILENT when it is wrong with no flag.  The truth\n"
          "is never computed by a method in the matrix.  See docs/STABILITY.md.\n\n", f);
    fputs("## What each flag is worth\n\n"
          "Every run of every cell, judged as above: a flag on a correct answer is a\n"
          "false alarm, on a wrong one it did its job.  Precision is the share of a\n"
          "flag's runs whose answer was wrong.  Runs of plain QMC (no bar) and refusals\n"
          "are left out.  A \"cannot tell\" flag (few_nonzero, tail_untested,\n"
          "zero_spread, unresolved) may fire on an answer that happened to be right;\n"
          "its precision says how often that happens.\n\n"
          "### At normal budgets\n\n", f);
    const qmc_stab_flag_tally *fn = &mx->flags_normal;
    uint32_t eu = bit_count(fn->on_correct, QMC_FLAG_ERROR_UNRELIABLE);
    cli_flag_report(f, fn);
    fprintf(f, "error_unreliable on correct answers: %u of %u (%.1f%%).\n\n", eu, fn->correct,
            fn->correct ? 100.0 * eu / fn->correct : 0.0);
    false_alarms_by_method(f, mx);
    fputs("### On the tiny-budget cases (16 evaluations a run)\n\n", f);
    cli_flag_report(f, &mx->flags_tiny);
    fprintf(f, "## Silent cells (%u)\n\n", mx->count[QMC_STAB_SILENT]);
    if (mx->count[QMC_STAB_SILENT] == 0)
        fputs("None.\n", f);
    for (size_t r = 0; r < mx->n_cases; r++)
        for (size_t c = 0; c < mx->n_methods; c++) {
            const cli_stab_cell *cell = &mx->cells[r * mx->n_methods + c];
            if (cell->cls == QMC_STAB_SILENT)
                cell_words(f, cell, &mx->refs[r]);
        }
    fputs("\n## The matrix\n\nRows are cases, columns methods (ok, flag = FLAGGED, "
          "ref = REFUSED).\n\n| case |", f);
    for (size_t c = 0; c < mx->n_methods; c++)
        fprintf(f, " %s |", mx->methods[c].name);
    fputs("\n|---|", f);
    for (size_t c = 0; c < mx->n_methods; c++)
        fputs("---|", f);
    fputc('\n', f);
    for (size_t r = 0; r < mx->n_cases; r++) {
        fprintf(f, "| %s |", mx->cases[r]->name);
        for (size_t c = 0; c < mx->n_methods; c++)
            fprintf(f, " %s |", short_class(mx->cells[r * mx->n_methods + c].cls));
        fputc('\n', f);
    }
    fputs("\n## The cases\n\n| case | class of failure | what it probes | reference |\n"
          "|---|---|---|---|\n", f);
    for (size_t r = 0; r < mx->n_cases; r++) {
        const cli_stab_ref *ref = &mx->refs[r];
        fprintf(f, "| %s | %s | %s | ", mx->cases[r]->name, mx->cases[r]->category,
                mx->cases[r]->why);
        num(f, ref->truth.value);
        if (ref->truth.abs_error > 0) {
            fputs(" +- ", f);
            num(f, ref->truth.abs_error);
        }
        fprintf(f, " (%s) |\n", ref->source);
    }
    fputs("\nThe heat map: stability.png and stability.svg; every cell's numbers:\n"
          "stability.csv.\n", f);
    return ferror(f) ? -1 : 0;
}

static void json_num(FILE *f, double v)
{
    if (isfinite(v))
        fprintf(f, "%.17g", v);
    else
        fputs("null", f);
}

/* {"correct":C,"wrong":W,"flags":{"key":[on correct, on wrong],...}} */
static void json_flags(FILE *f, const qmc_stab_flag_tally *t)
{
    fprintf(f, "{\"correct\":%u,\"wrong\":%u,\"flags\":{", t->correct, t->wrong);
    int first = 1;
    for (int b = 0; b < 32; b++)
        if (t->on_correct[b] + t->on_wrong[b] && qmc_flag_key(1u << b)[0]) {
            fprintf(f, "%s\"%s\":[%u,%u]", first ? "" : ",", qmc_flag_key(1u << b),
                    t->on_correct[b], t->on_wrong[b]);
            first = 0;
        }
    fputs("}}", f);
}

void cli_stab_print_json(FILE *f, const cli_stab_matrix *mx)
{
    fputs("{\"flag_precision\":{\"normal_budget\":", f);
    json_flags(f, &mx->flags_normal);
    fputs(",\"tiny_budget\":", f);
    json_flags(f, &mx->flags_tiny);
    fputs("},", f);
    fprintf(f, "\"quick\":%s,\"seconds\":%.3f,\"runs\":%u,\"ok_flagged_runs\":%u,"
            "\"ok_flagged_runs_normal_budget\":%u,\"counts\":{\"OK\":%u,\"FLAGGED\":%u,\"REFUSED\":%u,\"SILENT\":%u},\"cells\":[",
            mx->quick ? "true" : "false", mx->seconds, mx->runs, mx->ok_flagged_runs,
            mx->ok_flagged_runs_normal, mx->count[0], mx->count[1], mx->count[2], mx->count[3]);
    for (size_t i = 0; i < mx->n_cases * mx->n_methods; i++) {
        const cli_stab_cell *cell = &mx->cells[i];
        const cli_stab_ref *ref = &mx->refs[i / mx->n_methods];
        int refused = cell->v.cls == QMC_STAB_REFUSED;
        fprintf(f, "%s{\"case\":\"%s\",\"method\":\"%s\",\"class\":\"%s\",\"runs\":%u,"
                "\"silent_runs\":%u,\"estimate\":", i ? "," : "", cell->c->name, cell->m->name,
                qmc_stab_class_name(cell->cls), cell->tally.runs, cell->tally.silent);
        json_num(f, refused ? NAN : cell->res.estimate);
        fputs(",\"reported_error\":", f);
        json_num(f, refused || cell->res.error_kind == QMC_ERROR_NONE ? NAN : cell->res.error);
        fputs(",\"truth\":", f);
        json_num(f, ref->truth.value);
        fputs(",\"flags\":[", f);
        int first = 1;
        for (int b = 0; b < 32 && !refused; b++)
            if (cell->res.flags & (1u << b)) {
                fprintf(f, "%s\"%s\"", first ? "" : ",", qmc_flag_key(1u << b));
                first = 0;
            }
        fprintf(f, "],\"tiny\":%s,\"flag_runs\":", cell->c->tiny ? "true" : "false");
        json_flags(f, &cell->flags);
        fputs("}", f);
    }
    fputs("]}\n", f);
}

void cli_stab_print_summary(FILE *f, const cli_stab_matrix *mx)
{
    fprintf(f, "stability%s: %zu cells (%zu cases x %zu methods), %u runs in %.1f s\n",
            mx->quick ? " --quick" : "", mx->n_cases * mx->n_methods, mx->n_cases,
            mx->n_methods, mx->runs, mx->seconds);
    fprintf(f, "  OK %u  FLAGGED %u  REFUSED %u  SILENT %u\n", mx->count[0], mx->count[1],
            mx->count[2], mx->count[3]);
    fprintf(f, "  correct runs flagged anyway: %u of %u at normal budgets, %u of %u in all\n",
            mx->ok_flagged_runs_normal, mx->runs_normal, mx->ok_flagged_runs, mx->runs);
    const qmc_stab_flag_tally *fn = &mx->flags_normal;
    for (int b = 0; b < 32; b++)
        if ((1u << b) == QMC_FLAG_ERROR_UNRELIABLE)
            fprintf(f, "  error_unreliable: on %u of %u correct and %u of %u wrong runs with a "
                    "bar at normal budgets\n", fn->on_correct[b], fn->correct, fn->on_wrong[b],
                    fn->wrong);
    for (size_t i = 0; i < mx->n_cases * mx->n_methods; i++) {
        const cli_stab_cell *cell = &mx->cells[i];
        if (cell->cls != QMC_STAB_SILENT)
            continue;
        fprintf(f, "  SILENT %-28s %-20s %u/%u runs, est %.10g", cell->c->name, cell->m->name,
                cell->tally.silent, cell->tally.runs, cell->res.estimate);
        if (cell->res.error_kind != QMC_ERROR_NONE)
            fprintf(f, " +- %.3g", cell->res.error);
        fprintf(f, ", truth %.10g\n", mx->refs[i / mx->n_methods].truth.value);
    }
}

/* The heat map: a data file of (column, row, class) and a script that
 * draws it as an image with one colour a class, to PNG and SVG. */
int cli_stab_write_heatmap(cli_outdir *od, const cli_stab_matrix *mx)
{
    const char *dat = cli_outdir_path(od, "stability-matrix.dat");
    const char *png = cli_outdir_path(od, "stability.png");
    const char *svg = cli_outdir_path(od, "stability.svg");
    FILE *f = cli_outdir_fopen(od, "stability-matrix.dat");
    if (!dat || !png || !svg || !f)
        return f ? (fclose(f), -1) : -1;
    fputs("# column row class (0 OK, 1 FLAGGED, 2 REFUSED, 3 SILENT)\n", f);
    for (size_t r = 0; r < mx->n_cases; r++)
        for (size_t c = 0; c < mx->n_methods; c++) {
            qmc_stab_class k = mx->cells[r * mx->n_methods + c].cls;
            fprintf(f, "%zu %zu %d\n", c, r, (int)k);
        }
    if (cli_outdir_fclose(f, "stability-matrix.dat"))
        return -1;
    const char *gp_path = cli_outdir_path(od, "stability.gp");
    FILE *gp = gp_path ? cli_outdir_fopen(od, "stability.gp") : NULL;
    if (!gp)
        return -1;
    int width = 260 + 56 * (int)mx->n_methods, height = 220 + 22 * (int)mx->n_cases;
    for (int pass = 0; pass < 2; pass++) {
        cli_gnuplot_terminal(gp, pass ? "svg" : "png", width, height, pass ? svg : png);
        if (pass)
            continue;
        fprintf(gp, "set title 'qmc stability%s: %u silent of %zu cells (green OK, yellow "
                "FLAGGED, grey REFUSED, red SILENT)'\n", mx->quick ? " --quick" : "",
                mx->count[QMC_STAB_SILENT], mx->n_cases * mx->n_methods);
        fputs("unset key\nunset colorbox\nset palette defined (0 '#4daf4a', 1 '#ffd92f', "
              "2 '#bdbdbd', 3 '#e41a1c')\nset cbrange [-0.5:3.5]\n", gp);
        fprintf(gp, "set xrange [-0.5:%zu.5]\nset yrange [%zu.5:-0.5]\n", mx->n_methods - 1,
                mx->n_cases - 1);
        fputs("set xtics rotate by 45 right nomirror scale 0\nset ytics nomirror scale 0\n"
              "set x2tics scale 0\nunset x2tics\nset tmargin 4\nset xtics (", gp);
        for (size_t c = 0; c < mx->n_methods; c++) {
            fprintf(gp, "%s", c ? ", " : "");
            cli_gnuplot_quote(gp, mx->methods[c].name);
            fprintf(gp, " %zu", c);
        }
        fputs(")\nset ytics (", gp);
        for (size_t r = 0; r < mx->n_cases; r++) {
            fprintf(gp, "%s", r ? ", " : "");
            cli_gnuplot_quote(gp, mx->cases[r]->name);
            fprintf(gp, " %zu", r);
        }
        fputs(")\n", gp);
        fputs("set macros\n", gp);
        fputs("data = ", gp);
        cli_gnuplot_quote(gp, dat);
        fputs("\nplotcmd = \"plot data using 1:2:3 with image, data using 1:2:($3 == 3 ? 'S' : '') "
              "with labels tc 'white'\"\n@plotcmd\n", gp);
    }
    fputs("@plotcmd\nunset output\n", gp);
    if (cli_outdir_fclose(gp, "stability.gp"))
        return -1;
    return cli_gnuplot_run(gp_path);
}
