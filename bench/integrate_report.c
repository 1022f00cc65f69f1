/*
 * integrate_report.c - part 3 of bench_integrate (see integrate_report.h).
 *
 * Cells.  Each (method, family, d, budget) ran on the same draws of the
 * integrand, auto under BENCH_SCRAMBLES seeds a draw (integrate_methods.h);
 * a cell sums its runs up as the geometric mean of the error relative to
 * int |f| (floored at BENCH_COMPARE_FLOOR: rounding compares equal), and
 * the median of the wall times.  The geometric mean is the mean number of
 * correct digits, Genz's own yardstick; unlike a single draw it does not
 * crown a method for one lucky u.  A cell counts only if every run
 * succeeded.  The verdicts are also given over each draw's first scramble
 * alone (run_scope).
 *
 * Equal wall time.  For each auto cell (time t, error e) of a family and
 * dimension, the best peer is the smallest error among that family's and
 * dimension's complete peer cells (any peer, any budget) that took at
 * most t seconds: a step envelope, not an interpolation, so peers get no
 * credit for budgets they did not run.  The ratio is e / best; "n/a" when
 * no peer cell finished within t and auto's error is above the target
 * times the fastest peer cell's.  When auto finished before every peer and
 * is within the target of the fastest one, that peer is the comparison
 * (printed with '*'): auto is both faster and as accurate, which the step
 * envelope alone could not show (a 2D analytic integrand at rounding in
 * 40 us left every cell n/a).  The target per (family, d) is that every
 * comparable auto cell has ratio <= 1, and <= 1/3 at d >= 20; an auto cell
 * with a refused draw counts as MISSED for its budget (peers answered); the
 * count that ignores refusals is printed too.
 *
 * Honesty.  For each method, over its successful runs that report an error
 * estimate: ratio = reported estimate / actual error (floored, see
 * bench_floored_error, BENCH_HONESTY_FLOOR).  Ratios below 1 are
 * overconfident bars.  Target for ours: a median between 1 and 10.
 */
#include "integrate_report.h"

#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

#include "qmc/integrate.h"

double bench_floored_error(const bench_rec *r, double rel_floor)
{
    return fmax(r->abs_err, rel_floor * fmax(fabs(r->absint), fabs(r->exact)));
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Quantile q of sorted v[0 .. n) by linear interpolation. */
static double quantile(const double *v, size_t n, double q)
{
    if (n == 0)
        return NAN;
    double pos = q * (double)(n - 1);
    size_t i = (size_t)pos;
    if (i + 1 >= n)
        return v[n - 1];
    return v[i] + (pos - (double)i) * (v[i + 1] - v[i]);
}

/* Which runs a cell takes: all of them, or each draw's first scramble
 * only (one randomization per draw, as the benchmark ran before ours got
 * BENCH_SCRAMBLES; peers have only that one). */
typedef enum { RUNS_ALL, RUNS_FIRST_SCRAMBLE } run_scope;

/* What the draws of one (method, family, d, budget) add up to. */
typedef struct bench_cell {
    int runs, ok, refused;   /* runs found; succeeded; refused (budget) */
    double err;              /* geometric mean of floored |error| / int |f| */
    double seconds;          /* median wall time */
    int method_used;         /* ours: the qmc_method of every draw, -2 if mixed */
    const bench_rec *first;  /* the first draw (for notes), or NULL */
} bench_cell;

enum { CELL_TIMES_MAX = 256 }; /* runs whose time the median sees */

static bench_cell cell_of(const bench_rec *recs, size_t n, bench_method m, qmc_genz_family fam,
                          uint32_t d, uint64_t budget, run_scope scope)
{
    bench_cell c = {0, 0, 0, NAN, NAN, -1, NULL};
    double secs[CELL_TIMES_MAX], log_sum = 0;
    for (size_t i = 0; i < n; i++) {
        const bench_rec *r = &recs[i];
        if (r->job.method != m || r->job.family != fam || r->job.dims != d ||
            r->job.budget != budget || (scope == RUNS_FIRST_SCRAMBLE && r->job.scramble != 0))
            continue;
        if (!c.first) {
            c.first = r;
            c.method_used = r->out.method_used;
        }
        c.runs++;
        c.refused += r->out.outcome == BENCH_REFUSED;
        if (r->out.outcome != BENCH_OK)
            continue;
        if (r->out.method_used != c.method_used)
            c.method_used = -2;
        log_sum += log(bench_floored_error(r, BENCH_COMPARE_FLOOR) / fabs(r->absint));
        if (c.ok < CELL_TIMES_MAX)
            secs[c.ok] = r->out.seconds;
        c.ok++;
    }
    if (c.ok && c.ok == c.runs) {
        int k = c.ok < CELL_TIMES_MAX ? c.ok : CELL_TIMES_MAX;
        qsort(secs, (size_t)k, sizeof *secs, cmp_double);
        c.err = exp(log_sum / c.ok);
        c.seconds = k % 2 ? secs[k / 2] : 0.5 * (secs[k / 2 - 1] + secs[k / 2]);
    }
    return c;
}

static int cell_complete(const bench_cell *c)
{
    return c->runs > 0 && c->ok == c->runs;
}

static const char *short_family(qmc_genz_family f)
{
    return qmc_genz_family_name(f) + 5; /* drop "genz-" */
}

/* ---- auto against the best peer ----------------------------------------- */

/* A complete peer cell of a family and d (any peer, any budget), or one
 * with first == NULL: the most accurate of those that took at most
 * `within` seconds, or, when within is NAN, the fastest (the more accurate
 * on a tie). */
static bench_cell peer_cell(const bench_rec *recs, size_t n, const bench_grid *g,
                            qmc_genz_family fam, uint32_t d, double within, run_scope scope)
{
    bench_cell best = {0, 0, 0, NAN, NAN, -1, NULL};
    for (int m = 0; m < BENCH_M_COUNT; m++) {
        if (!bench_method_is_peer((bench_method)m))
            continue;
        for (size_t pb = 0; pb < g->n_budgets; pb++) {
            bench_cell p = cell_of(recs, n, (bench_method)m, fam, d, g->budgets[pb], scope);
            if (!cell_complete(&p))
                continue;
            int better = isnan(within) ? !best.first || p.seconds < best.seconds ||
                                             (p.seconds == best.seconds && p.err < best.err)
                                       : p.seconds <= within && (!best.first || p.err < best.err);
            if (better)
                best = p;
        }
    }
    return best;
}

/* Prints to out unless it is NULL. */
__attribute__((format(printf, 2, 3))) static void say(FILE *out, const char *fmt, ...)
{
    if (!out)
        return;
    va_list ap;
    va_start(ap, fmt);
    vfprintf(out, fmt, ap);
    va_end(ap);
}

/* The table of auto against the best peer over the runs of scope, to out
 * (NULL: none) and csv (NULL: none); pair_met[p] is set for each (family, d)
 * pair p = d index * families + family index, and the counts returned. */
static void auto_vs_peers(const bench_rec *recs, size_t n, const bench_grid *g, run_scope scope,
                          FILE *out, FILE *csv, int *pair_met, int *met, int *missed)
{
    if (csv)
        fprintf(csv, "family,dims,budget,runs,auto_outcome,auto_method,auto_seconds,"
                     "auto_error_rel,best_peer,best_peer_budget,best_peer_seconds,"
                     "best_peer_error_rel,ratio,target\n");
    say(out,
        "\nAuto vs the best peer at equal wall time, over %zu integrand draws per family and "
        "d, auto's under %u scrambles each: ratio = auto's error / the smallest peer error "
        "among peer cells that took no longer (step envelope); errors are geometric means "
        "over the runs of |error| / int |f|, times are medians.  '*': auto finished before "
        "every peer and was within the target of the fastest one (the ratio is to that "
        "peer); n/a: it finished first but less accurately, so no peer ran in its time.\n",
        g->draws, scope == RUNS_ALL ? bench_method_scrambles(BENCH_M_AUTO) : 1u);
    say(out, "Target: ratio <= 1 for every family and d, <= 1/3 at d >= 20.  Columns: auto's "
             "budget.\n\n");
    say(out, "%-15s %3s", "family", "d");
    for (size_t b = 0; b < g->n_budgets; b++)
        say(out, " %9.0e", (double)g->budgets[b]);
    say(out, " %9s %7s  %-24s %s\n", "worst", "target", "best peer @ top budget", "verdict");
    int n_met = 0, n_missed = 0, n_acc_met = 0;
    for (size_t di = 0; di < g->n_dims; di++) {
        uint32_t d = g->dims[di];
        double target = d >= 20 ? 1.0 / 3.0 : 1.0;
        for (size_t fi = 0; fi < g->n_families; fi++) {
            qmc_genz_family fam = g->families[fi];
            say(out, "%-15s %3u", short_family(fam), d);
            double worst = 0;
            int any = 0, refused = 0;
            char best_top[64] = "-";
            for (size_t b = 0; b < g->n_budgets; b++) {
                bench_cell a = cell_of(recs, n, BENCH_M_AUTO, fam, d, g->budgets[b], scope);
                if (!cell_complete(&a)) {
                    int skipped = a.first && a.first->out.outcome == BENCH_SKIPPED;
                    say(out, " %9s", !a.runs ? "-" : a.refused ? "refused" : "FAIL");
                    if (a.runs && !skipped)
                        refused++;
                    if (csv && a.runs)
                        fprintf(csv, "%s,%u,%llu,%d,%s,,,,,,,,,%.4f\n",
                                qmc_genz_family_name(fam), d,
                                (unsigned long long)g->budgets[b], a.runs,
                                a.refused ? "refused" : "failed", target);
                    continue;
                }
                bench_cell best = peer_cell(recs, n, g, fam, d, a.seconds, scope);
                int dominates = 0;
                if (!best.first) { /* faster than every peer: the fastest one */
                    bench_cell fastest = peer_cell(recs, n, g, fam, d, NAN, scope);
                    if (fastest.first && a.err <= target * fastest.err) {
                        best = fastest;
                        dominates = 1;
                    }
                }
                double ratio = best.first ? a.err / best.err : NAN;
                if (best.first) {
                    any = 1;
                    worst = fmax(worst, ratio);
                    say(out, dominates ? " %8.3g*" : " %9.3g", ratio);
                    snprintf(best_top, sizeof best_top, "%s@%.0e %.2gs",
                             bench_method_name(best.first->job.method),
                             (double)best.first->job.budget, best.seconds);
                } else {
                    say(out, " %9s", "n/a");
                    snprintf(best_top, sizeof best_top, "none within %.2gs", a.seconds);
                }
                if (csv) {
                    fprintf(csv, "%s,%u,%llu,%d,ok,%s,%.6g,%.6e,", qmc_genz_family_name(fam), d,
                            (unsigned long long)g->budgets[b], a.runs,
                            a.method_used >= 0 ? qmc_method_name((qmc_method)a.method_used)
                                               : "mixed",
                            a.seconds, a.err);
                    if (best.first)
                        fprintf(csv, "%s,%llu,%.6g,%.6e,%.6g,%.4f\n",
                                bench_method_name(best.first->job.method),
                                (unsigned long long)best.first->job.budget, best.seconds,
                                best.err, ratio, target);
                    else
                        fprintf(csv, ",,,,,%.4f\n", target);
                }
            }
            int acc_ok = any && worst <= target;
            int ok = acc_ok && !refused;
            say(out, " %9.3g %7.3f  %-24s %s%s\n", any ? worst : NAN, target, best_top,
                   ok ? "met" : "MISSED",
                   refused ? (acc_ok ? " (refused a budget; ratios met)" : " (+ refused a budget)")
                           : "");
            pair_met[di * g->n_families + fi] = ok;
            n_met += ok;
            n_missed += !ok;
            n_acc_met += acc_ok;
        }
    }
    say(out, "Auto vs best peer: %d met, %d MISSED of %d (family, d) pairs; ignoring auto's "
           "refusals, the ratios meet the target in %d\n", n_met, n_missed, n_met + n_missed,
           n_acc_met);
    *met += n_met;
    *missed += n_missed;
}

/* ---- honesty of error estimates -------------------------------------------- */

typedef struct honesty {
    double med, p10, p90, lo, hi, under;
    size_t count;
} honesty;

/* Ratios for method m (and, when used >= 0, auto's choice used); family
 * -1 for all; clear_only: only runs whose error is clear of rounding. */
static honesty honesty_of_runs(const bench_rec *recs, size_t n, bench_method m, int used,
                               int family, int clear_only)
{
    honesty h = {NAN, NAN, NAN, NAN, NAN, NAN, 0};
    double *v = malloc((n ? n : 1) * sizeof *v);
    if (!v)
        return h;
    size_t k = 0, under = 0;
    for (size_t i = 0; i < n; i++) {
        const bench_rec *r = &recs[i];
        if (r->job.method != m || r->out.outcome != BENCH_OK || !isfinite(r->out.err_est))
            continue;
        if (used >= 0 && r->out.method_used != used)
            continue;
        if (family >= 0 && (int)r->job.family != family)
            continue;
        if (clear_only &&
            r->abs_err < BENCH_HONESTY_CLEAR * fmax(fabs(r->absint), fabs(r->exact)))
            continue;
        v[k] = r->out.err_est / bench_floored_error(r, BENCH_HONESTY_FLOOR);
        under += v[k] < 1.0;
        k++;
    }
    qsort(v, k, sizeof *v, cmp_double);
    if (k) {
        h.med = quantile(v, k, 0.5);
        h.p10 = quantile(v, k, 0.1);
        h.p90 = quantile(v, k, 0.9);
        h.lo = v[0];
        h.hi = v[k - 1];
        h.under = (double)under / (double)k;
    }
    h.count = k;
    free(v);
    return h;
}

static honesty honesty_of(const bench_rec *recs, size_t n, bench_method m, int used, int family)
{
    return honesty_of_runs(recs, n, m, used, family, 0);
}

static void print_honesty_row(const char *name, honesty h, honesty clear, const char *verdict)
{
    if (h.count == 0) {
        printf("  %-23s %5s  (no error estimate)\n", name, "0");
        return;
    }
    printf("  %-23s %5zu %9.3g %9.3g %9.3g %9.3g %9.3g %6.0f%% | %5zu %9.3g %6.0f%%  %s\n", name,
           h.count, h.med, h.p10, h.p90, h.lo, h.hi, 100 * h.under, clear.count, clear.med,
           100 * clear.under, verdict);
}

static void honesty_table(const bench_rec *recs, size_t n, const bench_grid *g, FILE *csv,
                          int *met, int *missed)
{
    printf("\nHonesty of reported error estimates: ratio = reported error / actual |error| "
           "(all families, d and budgets)\n");
    printf("Target for ours: median in [1, 10].  'under' = runs whose bar is smaller than the "
           "actual error.\nRight of '|': only the runs whose actual error is above %.0e of "
           "int |f| (clear of rounding).\n\n", BENCH_HONESTY_CLEAR);
    printf("  %-23s %5s %9s %9s %9s %9s %9s %7s | %5s %9s %7s\n", "method", "runs", "median",
           "p10", "p90", "min", "max", "under", "runs", "median", "under");
    if (csv)
        fprintf(csv, "method,family,runs,median,p10,p90,min,max,under_fraction\n");
    for (int m = 0; m < BENCH_M_COUNT; m++) {
        honesty h = honesty_of(recs, n, (bench_method)m, -1, -1);
        const char *verdict = "";
        if (!bench_method_is_peer((bench_method)m) && m != BENCH_M_AUTO) {
            int ok = h.count && h.med >= 1 && h.med <= 10;
            verdict = ok ? "met" : "MISSED";
            *met += ok;
            *missed += !ok;
        }
        print_honesty_row(bench_method_name((bench_method)m), h,
                          honesty_of_runs(recs, n, (bench_method)m, -1, -1, 1),
                          m == BENCH_M_AUTO ? "(mixed: see its choices)" : verdict);
        if (m == BENCH_M_AUTO) {
            /* auto's verdict is per choice: a good median over a mixture
             * would hide a bad one. */
            static const qmc_method used[] = {QMC_METHOD_CLENSHAW_CURTIS, QMC_METHOD_CUBATURE,
                                              QMC_METHOD_RQMC};
            for (size_t u = 0; u < sizeof used / sizeof used[0]; u++) {
                char name[40];
                snprintf(name, sizeof name, "  auto->%s", qmc_method_name(used[u]));
                honesty hu = honesty_of(recs, n, BENCH_M_AUTO, (int)used[u], -1);
                if (hu.count == 0) /* auto never chose it here */
                    continue;
                int ok = hu.count && hu.med >= 1 && hu.med <= 10;
                *met += ok;
                *missed += !ok;
                print_honesty_row(name, hu,
                                  honesty_of_runs(recs, n, BENCH_M_AUTO, (int)used[u], -1, 1),
                                  ok ? "met" : "MISSED");
            }
        }
        for (size_t fi = 0; csv && fi < g->n_families; fi++) {
            honesty hf = honesty_of(recs, n, (bench_method)m, -1, (int)g->families[fi]);
            fprintf(csv, "%s,%s,%zu,%.4g,%.4g,%.4g,%.4g,%.4g,%.3f\n",
                    bench_method_name((bench_method)m), qmc_genz_family_name(g->families[fi]),
                    hf.count, hf.med, hf.p10, hf.p90, hf.lo, hf.hi, hf.under);
        }
    }
    printf("\n  Ours by family (median ratio):\n  %-10s", "method");
    for (size_t fi = 0; fi < g->n_families; fi++)
        printf(" %14s", short_family(g->families[fi]));
    printf("\n");
    static const bench_method ours[] = {BENCH_M_AUTO, BENCH_M_RQMC, BENCH_M_CUBATURE};
    for (size_t k = 0; k < 3; k++) {
        printf("  %-10s", bench_method_name(ours[k]));
        for (size_t fi = 0; fi < g->n_families; fi++) {
            honesty hf = honesty_of(recs, n, ours[k], -1, (int)g->families[fi]);
            printf(" %14.3g", hf.med);
        }
        printf("\n");
    }
}

/* ---- outcomes and memory ----------------------------------------------------- */

static void outcomes_table(const bench_rec *recs, size_t n, const bench_grid *g, int *met,
                           int *missed)
{
    printf("\nOutcomes: successful runs / runs, per method and d (peers in a child with "
           "RLIMIT_AS and alarm; see the header)\n\n");
    printf("  %-10s", "method");
    for (size_t di = 0; di < g->n_dims; di++)
        printf("   d=%-4u", g->dims[di]);
    printf(" %12s\n", "max RSS MiB");
    for (int m = 0; m < BENCH_M_COUNT; m++) {
        printf("  %-10s", bench_method_name((bench_method)m));
        long rss = 0;
        for (size_t di = 0; di < g->n_dims; di++) {
            int ok = 0, all = 0;
            for (size_t i = 0; i < n; i++) {
                const bench_rec *r = &recs[i];
                if ((int)r->job.method != m || r->job.dims != g->dims[di])
                    continue;
                all++;
                ok += r->out.outcome == BENCH_OK;
                if (r->out.outcome != BENCH_SKIPPED && r->proc.maxrss_kb > rss)
                    rss = r->proc.maxrss_kb;
            }
            printf("   %3d/%-3d", ok, all);
        }
        printf(" %12.1f\n", (double)rss / 1024.0);
    }
    printf("\n  Runs that did not succeed (first of each method, d and outcome):\n");
    for (size_t i = 0; i < n; i++) {
        const bench_rec *r = &recs[i];
        if (r->out.outcome == BENCH_OK)
            continue;
        int seen = 0;
        for (size_t j = 0; j < i && !seen; j++)
            seen = recs[j].job.method == r->job.method && recs[j].job.dims == r->job.dims &&
                   recs[j].out.outcome == r->out.outcome;
        if (seen)
            continue;
        int count = 0;
        for (size_t j = i; j < n; j++)
            count += recs[j].job.method == r->job.method && recs[j].job.dims == r->job.dims &&
                     recs[j].out.outcome == r->out.outcome;
        printf("  %-10s d=%-3u %-14s x%-3d e.g. %s @%.0e: %s (peak RSS %.0f MiB)\n",
               bench_method_name(r->job.method), r->job.dims, bench_outcome_name(r->out.outcome),
               count, short_family(r->job.family), (double)r->job.budget, r->out.note,
               (double)r->proc.maxrss_kb / 1024.0);
    }

    /* Ours: no crash, no out-of-memory, no timeout, RSS under the bound. */
    long ours_rss = 0;
    int bad = 0, refused = 0;
    for (size_t i = 0; i < n; i++) {
        const bench_rec *r = &recs[i];
        if (bench_method_is_peer(r->job.method))
            continue;
        if (r->proc.maxrss_kb > ours_rss)
            ours_rss = r->proc.maxrss_kb;
        bad += r->out.outcome != BENCH_OK && r->out.outcome != BENCH_REFUSED;
        refused += r->out.outcome == BENCH_REFUSED;
    }
    int ok = bad == 0 && ours_rss <= BENCH_OURS_RSS_BOUND_KB;
    printf("\n  Ours: %d runs crashed, ran out of memory, timed out or failed; %d refused "
           "before evaluating (budget); max RSS %.1f MiB (bound %ld MiB): %s\n",
           bad, refused, (double)ours_rss / 1024.0, BENCH_OURS_RSS_BOUND_KB / 1024,
           ok ? "met" : "MISSED");
    *met += ok;
    *missed += !ok;
}

/* At the largest budget: auto's error beside our other two methods and the
 * best peer at the same budget (cells: geometric mean of |error| / int |f|
 * over the draws, median seconds), so a poor choice by auto stands out. */
static void top_budget_table(const bench_rec *recs, size_t n, const bench_grid *g)
{
    const uint64_t top = g->budgets[g->n_budgets - 1];
    printf("\nAt the budget of %.0e evaluations: |error| / int |f| (geometric mean over the "
           "draws) and median seconds of ours and of the most accurate peer at that budget\n\n",
           (double)top);
    printf("%-15s %3s %-9s %18s %18s %18s %18s  %s\n", "family", "d", "auto ran", "auto",
           "rqmc", "cubature", "best peer", "peer");
    for (size_t di = 0; di < g->n_dims; di++) {
        for (size_t fi = 0; fi < g->n_families; fi++) {
            qmc_genz_family fam = g->families[fi];
            uint32_t d = g->dims[di];
            bench_cell a = cell_of(recs, n, BENCH_M_AUTO, fam, d, top, RUNS_ALL);
            printf("%-15s %3u %-9s", short_family(fam), d,
                   a.method_used >= 0 && cell_complete(&a)
                       ? qmc_method_name((qmc_method)a.method_used)
                       : a.method_used == -2 ? "mixed" : "-");
            static const bench_method ours[] = {BENCH_M_AUTO, BENCH_M_RQMC, BENCH_M_CUBATURE};
            for (size_t k = 0; k < 3; k++) {
                bench_cell c = cell_of(recs, n, ours[k], fam, d, top, RUNS_ALL);
                if (cell_complete(&c))
                    printf("  %9.2e (%5.3fs)", c.err, c.seconds);
                else
                    printf(" %18s", c.first ? bench_outcome_name(c.first->out.outcome) : "-");
            }
            bench_cell best = {0, 0, 0, NAN, NAN, -1, NULL};
            for (int m = 0; m < BENCH_M_COUNT; m++) {
                if (!bench_method_is_peer((bench_method)m))
                    continue;
                bench_cell c = cell_of(recs, n, (bench_method)m, fam, d, top, RUNS_ALL);
                if (cell_complete(&c) && (!best.first || c.err < best.err))
                    best = c;
            }
            if (best.first)
                printf("  %9.2e (%5.3fs)  %s\n", best.err, best.seconds,
                       bench_method_name(best.first->job.method));
            else
                printf(" %18s\n", "none");
        }
    }
}

void bench_report(const bench_rec *recs, size_t n, const bench_grid *g, FILE *pair_csv,
                  FILE *honesty_csv, int *met, int *missed)
{
    outcomes_table(recs, n, g, met, missed);
    const size_t pairs = g->n_dims * g->n_families;
    int *all_met = calloc(2 * pairs, sizeof *all_met);
    if (!all_met) {
        fprintf(stderr, "bench_integrate: out of memory\n");
        exit(1);
    }
    int *first_met = all_met + pairs, m1 = 0, x1 = 0;
    auto_vs_peers(recs, n, g, RUNS_ALL, stdout, pair_csv, all_met, met, missed);
    auto_vs_peers(recs, n, g, RUNS_FIRST_SCRAMBLE, NULL, NULL, first_met, &m1, &x1);
    printf("With each draw's first scramble only (one randomization per draw): %d met, %d "
           "MISSED", m1, x1);
    for (size_t di = 0; di < g->n_dims; di++)
        for (size_t fi = 0; fi < g->n_families; fi++) {
            size_t p = di * g->n_families + fi;
            if (all_met[p] != first_met[p])
                printf("; %s at d = %u: %s", short_family(g->families[fi]), g->dims[di],
                       first_met[p] ? "met" : "MISSED");
        }
    printf("\n");
    free(all_met);
    top_budget_table(recs, n, g);
    honesty_table(recs, n, g, honesty_csv, met, missed);
}
