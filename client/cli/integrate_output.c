/*
 * integrate_output.c - prints an integration report as text or JSON.
 *
 * Honesty rules: a method without an error estimate prints none (not 0);
 * an error flagged unreliable is printed with that word next to it; the
 * error relative to the integral of |f| is shown too, so near-zero
 * integrals keep a meaningful relative error.
 */
#include <math.h>
#include <string.h>

#include "integrate.h"
#include "json.h"

/* The integral of |f| to judge errors against: known (as the daemon said,
 * else as the integrand built here says), else estimated. */
static double abs_integral(const cli_report *rep)
{
    const qmc_integrand *f = rep->problem->f;
    if (rep->known_abs_told ? rep->has_known_abs : f->has_abs_integral)
        return rep->known_abs_told ? rep->known_abs : f->abs_integral;
    return rep->res.abs_integral > 0 ? rep->res.abs_integral : NAN;
}

static void print_json(FILE *f, const cli_report *rep)
{
    const qmc_result *r = &rep->res;
    const cli_problem *p = rep->problem;
    double ref = p->has_reference ? p->reference : NAN;
    double err = r->estimate - ref, absint = abs_integral(rep);
    fputc('{', f);
    cli_json_str(f, "integrand", p->label, 1);
    cli_json_str(f, "method", rep->requested, 1);
    cli_json_str(f, "method_used", rep->method, 1);
    cli_json_str(f, "detail", rep->detail, 1);
    if (rep->auto_reason[0])
        cli_json_str(f, "auto_reason", rep->auto_reason, 1);
    cli_json_num(f, "estimate", r->estimate, 1);
    cli_json_num(f, "stderr", r->error_kind == QMC_ERROR_STDERR ? r->error : NAN, 1);
    cli_json_num(f, "error_estimate", r->error_kind == QMC_ERROR_ESTIMATE ? r->error : NAN, 1);
    cli_json_num(f, "ci_low", r->error_kind == QMC_ERROR_NONE ? NAN : r->ci_low, 1);
    cli_json_num(f, "ci_high", r->error_kind == QMC_ERROR_NONE ? NAN : r->ci_high, 1);
    cli_json_num(f, "confidence", r->error_kind == QMC_ERROR_STDERR ? rep->confidence : NAN, 1);
    cli_json_num(f, "exact", p->reference_exact ? ref : NAN, 1);
    if (p->has_reference && !p->reference_exact)
        cli_json_num(f, "reference", ref, 1);
    cli_json_num(f, "abs_error", fabs(err), 1);
    cli_json_num(f, "rel_error", fabs(err) / fabs(ref), 1);
    cli_json_num(f, "abs_integral", absint, 1);
    cli_json_num(f, "error_vs_abs_integral", fabs(err) / absint, 1);
    cli_json_u64(f, "n", r->n, 1);
    cli_json_u64(f, "evals", r->evals, 1);
    cli_json_u64(f, "dims", r->dims, 1);
    cli_json_u64(f, "nonfinite", r->nonfinite, 1);
    if (rep->cv.used) {
        cli_json_num(f, "cv_beta", rep->cv.beta, 1);
        cli_json_num(f, "cv_variance_ratio", rep->cv.variance_ratio, 1);
    }
    cli_json_num(f, "seconds", rep->seconds, 1);
    fputs("\"flags\":[", f);
    int first = 1;
    for (int b = 0; b < 32; b++)
        if (r->flags & (1u << b)) {
            fprintf(f, "%s\"%s\"", first ? "" : ",", qmc_flag_key(1u << b));
            first = 0;
        }
    fputs("]}\n", f);
}

static void print_text(FILE *f, const cli_report *rep)
{
    const qmc_result *r = &rep->res;
    const cli_problem *p = rep->problem;
    const int unreliable = (r->flags & QMC_FLAG_ERROR_UNRELIABLE) != 0;
    if (p->is_scene)
        fprintf(f, "scene      %s (%u sample dimensions per point)\n", p->label, r->dims);
    else
        fprintf(f, "integrand  %s (%u dims)\n", p->label, r->dims);
    fprintf(f, "method     %s: %s\n", rep->method, rep->detail);
    if (rep->auto_reason[0])
        fprintf(f, "auto       chose %s\n", rep->auto_reason);
    fprintf(f, "estimate   %.17g%s\n", r->estimate,
            r->flags & QMC_FLAG_NONFINITE ? "  (INVALID: non-finite values, see flags)" : "");
    switch (r->error_kind) {
    case QMC_ERROR_STDERR:
        fprintf(f, "stderr     %.3g%s  (%g%% interval [%.17g, %.17g])\n", r->error,
                unreliable ? " UNRELIABLE" : "", 100 * rep->confidence, r->ci_low, r->ci_high);
        break;
    case QMC_ERROR_ESTIMATE:
        fprintf(f, "error est  %.3g%s  (the rule's own estimate)\n", r->error,
                unreliable ? " UNRELIABLE" : "");
        break;
    case QMC_ERROR_NONE:
        fputs("stderr     none: one deterministic point set carries no error estimate "
              "(use rqmc)\n", f);
        break;
    }
    if (p->has_reference) {
        double e = r->estimate - p->reference;
        fprintf(f, "%s  %.17g\n", p->reference_exact ? "exact    " : "reference", p->reference);
        fprintf(f, "abs error  %.3g", fabs(e));
        if (r->error_kind != QMC_ERROR_NONE && r->error > 0)
            fprintf(f, " = %.2f x the reported error", fabs(e) / r->error);
        double absint = abs_integral(rep);
        if (isfinite(absint) && absint > 0)
            fprintf(f, "; %.3g of the integral of |f|", fabs(e) / absint);
        fputc('\n', f);
    }
    if (rep->cv.used)
        fprintf(f, "control    beta %.6g, variance ratio %.4g\n", rep->cv.beta,
                rep->cv.variance_ratio);
    fprintf(f, "work       n %llu, evals %llu, %.3f s\n", (unsigned long long)r->n,
            (unsigned long long)r->evals, rep->seconds);
    if (!r->flags) {
        fputs("flags      none\n", f);
        return;
    }
    for (int b = 0; b < 32; b++)
        if (r->flags & (1u << b))
            fprintf(f, "flag       %s: %s\n", qmc_flag_key(1u << b), qmc_flag_text(1u << b));
    if (r->nonfinite)
        fprintf(f, "nonfinite  %llu values left out\n", (unsigned long long)r->nonfinite);
}

void cli_report_print(FILE *f, const cli_report *rep, int json)
{
    if (json)
        print_json(f, rep);
    else
        print_text(f, rep);
}
