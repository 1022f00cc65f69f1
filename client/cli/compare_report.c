/*
 * compare_report.c - what `qmc compare` writes: compare.csv (one row a
 * run), the medians per (method, budget) with the Pareto front of error
 * against time and a fitted convergence slope per method, three charts
 * (gnuplot, PNG and SVG) and REPORT.md in words.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "compare.h"
#include "flag_report.h"
#include "gnuplot.h"
#include "outdir.h"

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static double median(double *v, size_t n)
{
    if (n == 0)
        return NAN;
    qsort(v, n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* Errors below this are drawn (and fitted) at it: an exact hit has no
 * logarithm. */
static double error_floor(const cli_cmp *c)
{
    double s = fmax(fabs(c->truth.value), c->truth.scale);
    return s > 0 ? 1e-16 * s : 1e-300;
}

int cli_cmp_summarize(cli_cmp *c)
{
    c->points = calloc((size_t)c->n_methods * c->n_budgets, sizeof *c->points);
    double *sec = calloc(c->n_runs + 1, sizeof *sec), *err = calloc(c->n_runs + 1, sizeof *err),
           *ev = calloc(c->n_runs + 1, sizeof *ev);
    if (!c->points || !sec || !err || !ev) {
        free(sec), free(err), free(ev);
        return cli_error("out of memory"), -1;
    }
    const double lo = error_floor(c);
    for (uint32_t m = 0; m < c->n_methods; m++)
        for (uint32_t k = 0; k < c->n_budgets; k++) {
            size_t n = 0;
            for (size_t i = 0; i < c->n_runs; i++) {
                const cli_cmp_run *r = &c->runs[i];
                if (r->method != m || r->budget_index != k || r->refused ||
                    !isfinite(r->v.abs_error))
                    continue;
                /* a clock tick at least: log axes have no 0 */
                sec[n] = fmax(r->seconds, 1e-9);
                err[n] = fmax(r->v.abs_error, lo);
                ev[n] = (double)r->res.evals;
                n++;
            }
            if (n == 0)
                continue;
            cli_cmp_point *p = &c->points[c->n_points++];
            p->method = m;
            p->budget = c->budgets[k];
            p->runs = (uint32_t)n;
            p->seconds = median(sec, n);
            p->error = median(err, n);
            p->evals = median(ev, n);
        }
    free(sec), free(err), free(ev);
    for (size_t i = 0; i < c->n_points; i++) {
        cli_cmp_point *p = &c->points[i];
        p->pareto = 1;
        for (size_t j = 0; j < c->n_points && p->pareto; j++) {
            const cli_cmp_point *q = &c->points[j];
            if (j != i && q->seconds <= p->seconds && q->error <= p->error &&
                (q->seconds < p->seconds || q->error < p->error))
                p->pareto = 0;
        }
    }
    /* Least squares of log error on log evaluations, per method, over the
     * points above rounding (1e-14 of the scale): a method that has reached
     * rounding stops converging, and its plateau would bend the slope. */
    const double plateau = 100 * lo;
    for (uint32_t m = 0; m < c->n_methods; m++) {
        double sx = 0, sy = 0, sxx = 0, sxy = 0, xlo = INFINITY, xhi = 0;
        size_t n = 0;
        for (size_t i = 0; i < c->n_points; i++) {
            const cli_cmp_point *p = &c->points[i];
            if (p->method != m || !(p->evals > 0))
                continue;
            if (p->error <= plateau) {
                c->at_rounding[m]++;
                continue;
            }
            double x = log10(p->evals), y = log10(p->error);
            sx += x, sy += y, sxx += x * x, sxy += x * y, n++;
            xlo = fmin(xlo, p->evals), xhi = fmax(xhi, p->evals);
        }
        double den = (double)n * sxx - sx * sx;
        if (n >= 2 && den > 1e-9) {
            c->slope[m] = ((double)n * sxy - sx * sy) / den;
            c->intercept[m] = (sy - c->slope[m] * sx) / (double)n;
            c->fit_lo[m] = xlo, c->fit_hi[m] = xhi;
            c->has_slope[m] = 1;
        }
    }
    return 0;
}

static void flags_text(FILE *f, uint32_t flags)
{
    int first = 1;
    for (int b = 0; b < 32; b++)
        if (flags & (1u << b)) {
            fprintf(f, "%s%s", first ? "" : "|", qmc_flag_key(1u << b));
            first = 0;
        }
}

static int write_csv(FILE *f, const cli_cmp *c)
{
    fputs("method,budget,rep,estimate,reported_error,actual_error,seconds,evals,flags,"
          "error_kind,class,reason\n", f);
    for (size_t i = 0; i < c->n_runs; i++) {
        const cli_cmp_run *r = &c->runs[i];
        fprintf(f, "%s,%llu,%u,", c->methods[r->method].name, (unsigned long long)r->budget,
                r->rep);
        if (r->refused) {
            fprintf(f, ",,,%.6g,0,,,%s,\"", r->seconds, qmc_stab_class_name(r->v.cls));
            for (const char *p = r->reason; *p; p++)
                if (*p != '"')
                    fputc(*p, f);
            fputs("\"\n", f);
            continue;
        }
        fprintf(f, "%.17g,", r->res.estimate);
        if (r->res.error_kind != QMC_ERROR_NONE)
            fprintf(f, "%.6g", r->res.error);
        fputc(',', f);
        if (isfinite(r->v.abs_error))
            fprintf(f, "%.6g", r->v.abs_error);
        fprintf(f, ",%.6g,%llu,", r->seconds, (unsigned long long)r->res.evals);
        flags_text(f, r->res.flags);
        fprintf(f, ",%s,%s,\n",
                r->res.error_kind == QMC_ERROR_STDERR     ? "stderr"
                : r->res.error_kind == QMC_ERROR_ESTIMATE ? "estimate"
                                                          : "none",
                qmc_stab_class_name(r->v.cls));
    }
    return ferror(f) ? -1 : 0;
}

/* Per-method honesty counts. */
typedef struct honesty {
    uint32_t runs, covered, flagged, silent, refused, no_bar, ok_flagged;
    double median_ratio;
} honesty;

static honesty method_honesty(const cli_cmp *c, uint32_t m)
{
    honesty h = {0};
    double *ratio = calloc(c->n_runs + 1, sizeof *ratio);
    size_t n = 0;
    for (size_t i = 0; i < c->n_runs; i++) {
        const cli_cmp_run *r = &c->runs[i];
        if (r->method != m)
            continue;
        h.runs++;
        if (r->refused) {
            h.refused++;
            continue;
        }
        if (r->res.error_kind == QMC_ERROR_NONE)
            h.no_bar++;
        if (r->v.cls == QMC_STAB_OK) {
            h.covered++;
            /* compare sets adaptive methods a tolerance they cannot reach,
             * so "budget" and "not converged" are its doing, not alarms */
            h.ok_flagged += (r->res.flags & ~(uint32_t)(QMC_FLAG_BUDGET |
                                                        QMC_FLAG_NOT_CONVERGED)) != 0;
        }
        h.flagged += r->v.cls == QMC_STAB_FLAGGED && r->res.error_kind != QMC_ERROR_NONE;
        h.silent += r->v.cls == QMC_STAB_SILENT;
        if (ratio && r->v.bar_usable && r->res.error > 0 && isfinite(r->v.ratio))
            ratio[n++] = r->v.ratio;
    }
    h.median_ratio = ratio ? median(ratio, n) : NAN;
    free(ratio);
    return h;
}

static void fmt_seconds(char *buf, size_t bytes, double s)
{
    if (s < 1e-3)
        snprintf(buf, bytes, "%.3g us", s * 1e6);
    else if (s < 1)
        snprintf(buf, bytes, "%.3g ms", s * 1e3);
    else
        snprintf(buf, bytes, "%.3g s", s);
}

static void write_fastest(FILE *f, const cli_cmp *c)
{
    double tmin = INFINITY, tmax = 0, emin = INFINITY, emax = 0;
    for (size_t i = 0; i < c->n_points; i++) {
        tmin = fmin(tmin, c->points[i].seconds), tmax = fmax(tmax, c->points[i].seconds);
        emin = fmin(emin, c->points[i].error), emax = fmax(emax, c->points[i].error);
    }
    fputs("## Which method is most accurate within each time budget\n\n", f);
    if (c->n_points == 0) {
        fputs("No method produced an estimate.\n\n", f);
        return;
    }
    fputs("Medians over the seeds at each (method, budget); a method's best point that\n"
          "finished within the time.\n\n", f);
    for (double t = pow(10, ceil(log10(fmax(tmin, 1e-7)))); t <= 10 * tmax; t *= 10) {
        const cli_cmp_point *best[2] = {NULL, NULL};
        uint32_t best_m[2] = {UINT32_MAX, UINT32_MAX};
        for (uint32_t m = 0; m < c->n_methods; m++) {
            const cli_cmp_point *mine = NULL;
            for (size_t i = 0; i < c->n_points; i++) {
                const cli_cmp_point *p = &c->points[i];
                if (p->method == m && p->seconds <= t && (!mine || p->error < mine->error))
                    mine = p;
            }
            if (!mine)
                continue;
            if (!best[0] || mine->error < best[0]->error) {
                best[1] = best[0], best_m[1] = best_m[0];
                best[0] = mine, best_m[0] = m;
            } else if (!best[1] || mine->error < best[1]->error) {
                best[1] = mine, best_m[1] = m;
            }
        }
        char tb[32];
        fmt_seconds(tb, sizeof tb, t);
        if (!best[0]) {
            fprintf(f, "- **Within %s**: no method finished.\n", tb);
            continue;
        }
        fprintf(f, "- **Within %s**: `%s` is the most accurate, error %.2e (budget %.3g, "
                "%.3g s)", tb, c->methods[best_m[0]].name, best[0]->error,
                (double)best[0]->budget, best[0]->seconds);
        if (best[1])
            fprintf(f, "; next `%s`, %.2e (%.2gx larger)", c->methods[best_m[1]].name,
                    best[1]->error, best[1]->error / best[0]->error);
        fputs(".\n", f);
        if (t > tmax)
            break;
    }
    fputs("\n## Which method reaches a given error fastest\n\n| error at most | fastest "
          "method | its time | budget |\n|---|---|---|---|\n", f);
    for (double e = pow(10, floor(log10(emax))); e >= emin * 0.999; e /= 10) {
        const cli_cmp_point *best = NULL;
        for (size_t i = 0; i < c->n_points; i++) {
            const cli_cmp_point *p = &c->points[i];
            if (p->error <= e && (!best || p->seconds < best->seconds))
                best = p;
        }
        if (!best)
            continue;
        char tb[32];
        fmt_seconds(tb, sizeof tb, best->seconds);
        fprintf(f, "| %.0e | `%s` | %s | %.3g |\n", e, c->methods[best->method].name, tb,
                (double)best->budget);
    }
    fputc('\n', f);
}

static void write_honesty(FILE *f, const cli_cmp *c)
{
    fputs("## How honest each method's error bars were\n\n"
          "Each run judged as `qmc stability` judges a cell: covered when |estimate -\n"
          "reference| <= 3 x the reported error; wrong runs are flagged or silent.\n\n"
          "| method | runs | covered | wrong, flagged | wrong, SILENT | refused | median "
          "actual / reported | in words |\n|---|---|---|---|---|---|---|---|\n", f);
    for (uint32_t m = 0; m < c->n_methods; m++) {
        honesty h = method_honesty(c, m);
        fprintf(f, "| `%s` | %u | %u | %u | %u | %u | ", c->methods[m].name, h.runs, h.covered,
                h.flagged, h.silent, h.refused);
        if (isfinite(h.median_ratio))
            fprintf(f, "%.2g", h.median_ratio);
        else
            fputs("-", f);
        fputs(" | ", f);
        if (h.refused == h.runs)
            fputs("refused every budget", f);
        else if (h.no_bar == h.runs - h.refused)
            fputs("reports no error bar (plain QMC): accuracy only", f);
        else if (h.silent >= qmc_stab_silent_needed(h.runs - h.refused, c->methods[m].randomized))
            fprintf(f, "**not honest**: %u of %u runs were wrong by more than 3x their bar "
                    "with no flag", h.silent, h.runs - h.refused);
        else if (h.silent > 0)
            fprintf(f, "honest within chance: %u of %u runs missed by more than 3x their bar "
                    "with no flag, no more than an honest 3-sigma bar misses by chance "
                    "(binomial test, as qmc stability judges a cell)", h.silent,
                    h.runs - h.refused);
        else if (h.flagged > 0)
            fprintf(f, "honest where it counts: its %u wrong runs were flagged", h.flagged);
        else
            fputs("honest: every bar covered the actual error", f);
        if (h.ok_flagged)
            fprintf(f, " (%u correct runs flagged anyway)", h.ok_flagged);
        fputs(" |\n", f);
    }
    fputc('\n', f);
}

static int write_report(FILE *f, const cli_cmp *c)
{
    fprintf(f, "# qmc compare: %s (%u dims)\n\n", c->label, c->dims);
    fprintf(f, "- reference: %.17g", c->truth.value);
    if (c->truth.abs_error > 0)
        fprintf(f, " +- %.3g", c->truth.abs_error);
    fprintf(f, " (%s)\n", c->ref_source);
    if (c->endpoint)
        fprintf(f, "- jobs ran on the daemon at `%s`; seconds are each job's round trip "
                "(transport and queueing included)\n", c->endpoint);
    else
        fputs("- jobs ran in-process; seconds are wall time\n", f);
    fprintf(f, "- %u methods, %u budgets from %.3g to %.3g evaluations, %u seeds for the "
            "randomized methods, %zu runs\n\n", c->n_methods, c->n_budgets,
            (double)c->budgets[0], (double)c->budgets[c->n_budgets - 1], c->reps, c->n_runs);
    write_fastest(f, c);
    write_honesty(f, c);
    /* compare's own doing (a tolerance the adaptive methods cannot reach)
     * is no alarm: budget and not_converged are left out */
    qmc_stab_flag_tally t = {0};
    for (size_t i = 0; i < c->n_runs; i++) {
        qmc_result r = c->runs[i].res;
        r.flags &= ~(uint32_t)(QMC_FLAG_BUDGET | QMC_FLAG_NOT_CONVERGED);
        qmc_stab_flag_tally_add(&t, c->runs[i].refused, &c->runs[i].v, &r);
    }
    fputs("## What each flag was worth here\n\nEvery run with a bar, judged as above "
          "(budget and not_converged, which compare causes, left out).\n\n", f);
    cli_flag_report(f, &t);
    fputs("## Convergence (fitted on the medians above rounding, 1e-14 of the scale)\n\n", f);
    for (uint32_t m = 0; m < c->n_methods; m++) {
        if (c->has_slope[m])
            fprintf(f, "- `%s`: error ~ evaluations^%.2f (from %.3g to %.3g evaluations)%s\n",
                    c->methods[m].name, c->slope[m], c->fit_lo[m], c->fit_hi[m],
                    c->at_rounding[m] ? "; beyond, it is at rounding" : "");
        else if (c->at_rounding[m])
            fprintf(f, "- `%s`: at rounding at %u of its budgets, too few left above it to "
                    "fit a slope\n", c->methods[m].name, c->at_rounding[m]);
        else
            fprintf(f, "- `%s`: too few budgets with an estimate to fit a slope\n",
                    c->methods[m].name);
    }
    fputs("\n## The Pareto front of error against time\n\n", f);
    for (size_t i = 0; i < c->n_points; i++) {
        const cli_cmp_point *p = &c->points[i];
        if (p->pareto)
            fprintf(f, "- `%s` at budget %.3g: error %.2e in %.3g s\n",
                    c->methods[p->method].name, (double)p->budget, p->error, p->seconds);
    }
    fputs("\nCharts: error-time.svg (.png), error-evals.svg (.png), honesty.svg (.png); "
          "every run: compare.csv.\n", f);
    return ferror(f) ? -1 : 0;
}

/* ---- charts ------------------------------------------------------------ */

static int write_data(cli_outdir *od, const cli_cmp *c)
{
    FILE *f = cli_outdir_fopen(od, "compare-points.dat");
    if (!f)
        return -1;
    fputs("# one block a method (gnuplot index = method order): budget seconds error evals\n",
          f);
    for (uint32_t m = 0; m < c->n_methods; m++) {
        fprintf(f, "# %s\n", c->methods[m].name);
        for (size_t i = 0; i < c->n_points; i++)
            if (c->points[i].method == m)
                fprintf(f, "%llu %.6g %.6g %.6g\n", (unsigned long long)c->points[i].budget,
                        c->points[i].seconds, c->points[i].error, c->points[i].evals);
        fputs("\n\n", f);
    }
    if (cli_outdir_fclose(f, "compare-points.dat"))
        return -1;
    f = cli_outdir_fopen(od, "compare-front.dat");
    if (!f)
        return -1;
    fputs("# the Pareto front: seconds error\n", f);
    /* sorted by time: the front's errors then fall */
    double (*front)[2] = calloc(c->n_points + 1, sizeof *front);
    size_t nf = 0;
    if (!front) {
        fclose(f);
        return cli_error("out of memory"), -1;
    }
    for (size_t i = 0; i < c->n_points; i++)
        if (c->points[i].pareto) {
            front[nf][0] = c->points[i].seconds;
            front[nf][1] = c->points[i].error;
            nf++;
        }
    qsort(front, nf, sizeof *front, cmp_double); /* by the first member */
    for (size_t i = 0; i < nf; i++)
        fprintf(f, "%.6g %.6g\n", front[i][0], front[i][1]);
    free(front);
    if (cli_outdir_fclose(f, "compare-front.dat"))
        return -1;
    f = cli_outdir_fopen(od, "compare-runs.dat");
    if (!f)
        return -1;
    fputs("# one block a method: reported_error actual_error (runs with a bar)\n", f);
    const double lo = error_floor(c);
    for (uint32_t m = 0; m < c->n_methods; m++) {
        fprintf(f, "# %s\n", c->methods[m].name);
        for (size_t i = 0; i < c->n_runs; i++) {
            const cli_cmp_run *r = &c->runs[i];
            if (r->method == m && !r->refused && r->v.bar_usable && isfinite(r->v.abs_error))
                fprintf(f, "%.6g %.6g\n", fmax(r->res.error, lo), fmax(r->v.abs_error, lo));
        }
        fputs("\n\n", f);
    }
    return cli_outdir_fclose(f, "compare-runs.dat");
}

/* Has method m a point (or, runs != 0, a run with a bar) to draw? */
static int drawable(const cli_cmp *c, uint32_t m, int runs)
{
    if (runs) {
        for (size_t i = 0; i < c->n_runs; i++)
            if (c->runs[i].method == m && !c->runs[i].refused && c->runs[i].v.bar_usable &&
                isfinite(c->runs[i].v.abs_error))
                return 1;
        return 0;
    }
    for (size_t i = 0; i < c->n_points; i++)
        if (c->points[i].method == m)
            return 1;
    return 0;
}

static void chart(FILE *gp, cli_outdir *od, const cli_cmp *c, const char *name, int which)
{
    char png[64], svg[64];
    snprintf(png, sizeof png, "%s.png", name);
    snprintf(svg, sizeof svg, "%s.svg", name);
    const char *paths[2] = {cli_outdir_path(od, png), cli_outdir_path(od, svg)};
    const char *pts = cli_outdir_path(od, "compare-points.dat");
    const char *front = cli_outdir_path(od, "compare-front.dat");
    const char *runs = cli_outdir_path(od, "compare-runs.dat");
    for (int pass = 0; pass < 2; pass++) {
        if (!paths[pass])
            continue;
        fputs("reset\n", gp);
        cli_gnuplot_terminal(gp, pass ? "svg" : "png", 1000, 700, paths[pass]);
        fputs("set logscale xy\nset grid\nset format y '%.0e'\nset key outside right top\n",
              gp);
        int any = 0;
        if (which == 0) {
            fprintf(gp, "set title '%s, %u dims: median |error| against median seconds "
                    "(black: Pareto front)'\nset xlabel 'seconds'\nset ylabel '|error|'\n",
                    c->label, c->dims);
            fputs("plot ", gp);
            for (uint32_t m = 0; m < c->n_methods; m++) {
                if (!drawable(c, m, 0))
                    continue;
                fprintf(gp, "%s", any++ ? ", " : "");
                cli_gnuplot_quote(gp, pts);
                fprintf(gp, " index %u using 2:3 with linespoints lw 2 title '%s'", m,
                        c->methods[m].name);
            }
            if (any) {
                fputs(", ", gp);
                cli_gnuplot_quote(gp, front);
                fputs(" using 1:2 with steps lc 'black' lw 1 dt 2 notitle, ", gp);
                cli_gnuplot_quote(gp, front);
                fputs(" using 1:2 with points pt 6 ps 2.2 lc 'black' title 'Pareto front'", gp);
            }
        } else if (which == 1) {
            fprintf(gp, "set title '%s, %u dims: median |error| against evaluations (fitted "
                    "slopes)'\nset xlabel 'evaluations'\nset ylabel '|error|'\n", c->label,
                    c->dims);
            for (uint32_t m = 0; m < c->n_methods; m++)
                if (c->has_slope[m])
                    fprintf(gp, "f%u(x) = 10**(%.6g) * x**(%.6g)\n", m, c->intercept[m],
                            c->slope[m]);
            fputs("plot ", gp);
            for (uint32_t m = 0; m < c->n_methods; m++) {
                if (!drawable(c, m, 0))
                    continue;
                fprintf(gp, "%s", any++ ? ", " : "");
                cli_gnuplot_quote(gp, pts);
                if (c->has_slope[m])
                    fprintf(gp, " index %u using 4:3 with points pt 7 lc %u title '%s (slope "
                            "%.2f)', [%.6g:%.6g] f%u(x) lc %u dt 2 notitle", m, m + 1,
                            c->methods[m].name, c->slope[m], c->fit_lo[m], c->fit_hi[m], m,
                            m + 1);
                else
                    fprintf(gp, " index %u using 4:3 with points pt 7 lc %u title '%s%s'", m,
                            m + 1, c->methods[m].name,
                            c->at_rounding[m] ? " (at rounding)" : "");
            }
        } else {
            fprintf(gp, "set title '%s: reported error against actual error, every run "
                    "(above the 3x line: the bar lied)'\nset xlabel 'reported error'\n"
                    "set ylabel 'actual |error|'\n", c->label);
            fputs("plot ", gp);
            for (uint32_t m = 0; m < c->n_methods; m++) {
                if (!drawable(c, m, 1))
                    continue;
                fprintf(gp, "%s", any++ ? ", " : "");
                cli_gnuplot_quote(gp, runs);
                fprintf(gp, " index %u using 1:2 with points pt 7 title '%s'", m,
                        c->methods[m].name);
            }
            if (any)
                fputs(", x lc 'gray40' dt 2 title 'actual = reported', 3*x lc 'red' dt 3 "
                      "title 'actual = 3 x reported'", gp);
        }
        if (!any)
            fputs("NaN notitle\n", gp);
        fputc('\n', gp);
    }
    fputs("unset output\n", gp);
}

int cli_cmp_write(cli_outdir *od, const cli_cmp *c)
{
    FILE *f = cli_outdir_fopen(od, "compare.csv");
    if (!f || write_csv(f, c) || cli_outdir_fclose(f, "compare.csv"))
        return -1;
    f = cli_outdir_fopen(od, "REPORT.md");
    if (!f || write_report(f, c) || cli_outdir_fclose(f, "REPORT.md"))
        return -1;
    if (write_data(od, c))
        return -1;
    const char *gp_path = cli_outdir_path(od, "compare.gp");
    FILE *gp = gp_path ? cli_outdir_fopen(od, "compare.gp") : NULL;
    if (!gp)
        return -1;
    fputs("# qmc compare's charts; rerun with: gnuplot compare.gp (after renaming the\n"
          "# output and data paths, which point at the temporary names)\n", gp);
    chart(gp, od, c, "error-time", 0);
    chart(gp, od, c, "error-evals", 1);
    chart(gp, od, c, "honesty", 2);
    if (cli_outdir_fclose(gp, "compare.gp"))
        return -1;
    return cli_gnuplot_run(gp_path);
}
