/*
 * rule_need_scan.c - whether the error_unreliable flags a deterministic
 * rule carries on correct answers in `qmc stability` were needed.
 *
 * A rule's cell in the matrix is one run, so it cannot be repeated with
 * new seeds as bench/scans/flag_need.py repeats a randomized cell.  What
 * can be repeated is the case: this draws RUNS instances of the cell's
 * integrand that differ from it only where the case is arbitrary - the
 * peak's or the break's position u, uniform in [0.1, 0.9] an axis (MODE
 * pos), for a small support each u_j times 2^U(-1, 1) (MODE scale), for
 * an aliased frequency each a_j times 2^U(-1/2, 1/2) (MODE freq) - and
 * runs the rule with the matrix's own budget and spec (method_spec.c:
 * 2^20 evaluations unless EVALS is given, as the matrix's aliasing cases
 * give theirs; 2e7 for an adaptive rule), its flags stripped.  A
 * miss is what the matrix calls one: more than 3 bars plus 64 ulps from
 * the closed form.  Misses in 6 or more of 100 (the matrix's binomial
 * test, p = 1%, alpha = 1e-3) say that a correct answer of this cell can
 * not be told from a wrong one by its bar: the flag was needed.
 *
 * Prints one line: case, method, runs, misses, and of them the runs the
 * rule flagged error_unreliable (flags are judged, then stripped), and
 * the correct runs it flagged.  A measuring tool: it must not be built
 * into anything.
 *
 * Build and run (from the tree, after make):
 *   cc -O2 -Iinclude -Iclient/cli bench/scans/rule_need_scan.c \
 *      client/cli/method_spec.c build/libqmc.a -lm -lsodium -pthread \
 *      -o /tmp/rule_need_scan
 *   /tmp/rule_need_scan FAMILY D A1,..,AD U1,..,UD METHOD MODE RUNS SEED [EVALS]
 * (U "-" for a family without u, such as cos).
 * e.g. /tmp/rule_need_scan genz-gaussian 3 150,150,150 0.21,0.68,0.43 \
 *      midpoint pos 100 1
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "method_spec.h"
#include "qmc/integrate.h"
#include "qmc/testfn.h"

#include "scan_rng.h"

#define MAX_D 8

static int parse_list(const char *s, double *v, int d)
{
    char *end;
    for (int j = 0; j < d; j++) {
        v[j] = strtod(s, &end);
        if (end == s)
            return -1;
        s = *end == ',' ? end + 1 : end;
    }
    return 0;
}

int main(int argc, char **argv)
{
    if (argc != 9 && argc != 10) {
        fprintf(stderr, "usage: %s FAMILY D A1,.. U1,.. METHOD MODE RUNS SEED [EVALS]\n",
                argv[0]);
        return 2;
    }
    const char *fam = argv[1], *mode = argv[6];
    const int d = atoi(argv[2]), runs = atoi(argv[7]);
    double a[MAX_D], u0[MAX_D];
    const int has_u = strcmp(argv[4], "-") != 0; /* "-": the family takes no u (cos) */
    if (d < 1 || d > MAX_D || parse_list(argv[3], a, d) || (has_u && parse_list(argv[4], u0, d)) ||
        (strcmp(mode, "pos") && strcmp(mode, "scale") && strcmp(mode, "freq")) || runs < 1) {
        fprintf(stderr, "bad arguments\n");
        return 2;
    }
    state = strtoull(argv[8], NULL, 10);
    if (!state)
        state = 1;
    cli_method m;
    char why[256];
    if (cli_method_parse(argv[5], &m, why, sizeof why)) {
        fprintf(stderr, "%s\n", why);
        return 2;
    }
    const uint64_t evals = argc == 10 ? strtoull(argv[9], NULL, 10) : UINT64_C(1) << 20;
    const int adaptive = m.method == QMC_METHOD_CUBATURE ||
                         m.method == QMC_METHOD_CLENSHAW_CURTIS ||
                         m.method == QMC_METHOD_GAUSS_KRONROD;
    int misses = 0, misses_flagged = 0, correct_flagged = 0, failed = 0;
    for (int r = 0; r < runs; r++) {
        double u[MAX_D], ar[MAX_D];
        for (int j = 0; j < d; j++) {
            u[j] = strcmp(mode, "pos") == 0     ? 0.1 + 0.8 * u01()
                   : strcmp(mode, "scale") == 0 ? u0[j] * exp2(2 * u01() - 1)
                                                : u0[j];
            ar[j] = strcmp(mode, "freq") == 0 ? a[j] * exp2(u01() - 0.5) : a[j];
        }
        qmc_testfn *fn;
        if (qmc_testfn_new(fam, (uint32_t)d, ar, (size_t)d, has_u ? u : NULL,
                           has_u ? (size_t)d : 0, &fn, why, sizeof why)) {
            fprintf(stderr, "%s\n", why);
            return 3;
        }
        const qmc_integrand *f = qmc_testfn_integrand(fn);
        cli_budget b = {.evals = evals, .dims = (uint32_t)d,
                        .seed = 12345 + 1000003ull * (uint64_t)r};
        qmc_integrate_spec s;
        cli_method_spec(&m, &b, &s);
        if (adaptive && argc == 9)
            s.max_evals = 20000000;
        qmc_integrate_report rep;
        if (qmc_integrate(&s, f, NULL, NULL, NULL, &rep, why, sizeof why)) {
            failed++;
        } else {
            const qmc_result *res = &rep.res;
            const double truth = f->exact;
            const int ok = fabs(res->estimate - truth) <=
                           3 * res->error + 64 * DBL_EPSILON * fabs(truth);
            const int fl = (res->flags & QMC_FLAG_ERROR_UNRELIABLE) != 0;
            misses += !ok;
            misses_flagged += !ok && fl;
            correct_flagged += ok && fl;
            if (!ok && !fl) {
                printf("  silent:");
                for (int j = 0; j < d; j++)
                    printf(" a%d %.17g u%d %.17g", j + 1, ar[j], j + 1, u[j]);
                printf(": %.17g +- %.3g, truth %.17g\n", res->estimate, res->error, truth);
            }
        }
        qmc_testfn_free(fn);
    }
    printf("%s d %d %s %s: %d runs, %d misses (%d flagged), %d correct flagged, %d refused\n",
           fam, d, m.name, mode, runs, misses, misses_flagged, correct_flagged, failed);
    return 0;
}
