/*
 * rule_confirm_scan.c - deterministic rules on declared kinks and jumps:
 * what the Gauss-Kronrod confirmation leaves flagged (docs/FLAGS.md,
 * "Flags cut by better evidence").
 *
 *   MODE 1d: step, genz-discontinuous and genz-continuous in 1D (they
 *     declare their breaks), a log-uniform in 0.5..300, u uniform or within
 *     1e-9 of either end; midpoint, trapezoid, Simpson, Gauss-Legendre at
 *     16, 64, 1024 or 4096 nodes (odd for trapezoid and Simpson), cubature
 *     and Clenshaw-Curtis at their defaults.  Per cell: correct runs, of
 *     them flagged error_unreliable, wrong runs, and silent ones (wrong,
 *     unflagged), each printed.
 *   MODE kinks: genz-continuous in 2D and 3D (no breaks: they are 1D only),
 *     a log-uniform in 1..300, u uniform, the four tensor rules at 16, 33
 *     or 65 nodes an axis.  Counts the wrong runs that nothing but the
 *     declared kink flags (no unresolved, no roundoff): what confirming a
 *     kink by the rule's own sibling check would have left silent, the
 *     correct runs still flagged error_unreliable, and the silent runs
 *     (wrong with no flag: what the RQMC pilot, rule_pilot.h, confirmed).
 *   MODE jumps: the same with genz-discontinuous (axis-aligned jumps,
 *     where the pilot is plain MC).
 * A run is judged as `qmc stability` judges (3 bars plus 64 ulps).  A
 * measuring tool: it must not be built into anything.
 *
 * Build and run (from the tree, after make):
 *   cc -O2 -Iinclude bench/scans/rule_confirm_scan.c build/libqmc.a \
 *      -lm -lsodium -pthread -o /tmp/rule_confirm_scan
 *   /tmp/rule_confirm_scan MODE RUNS SEED
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "qmc/integrate.h"
#include "qmc/testfn.h"

#include "scan_rng.h"

static int judge(const char *fam, uint32_t d, const double *a, const double *u, qmc_method m,
                 uint32_t n, qmc_result *out, double *truth)
{
    qmc_testfn *fn;
    const int has_a = strcmp(fam, "step") != 0;
    if (qmc_testfn_new(fam, d, has_a ? a : NULL, has_a ? d : 0, u, d, &fn, NULL, 0))
        return -1;
    const qmc_integrand *f = qmc_testfn_integrand(fn);
    qmc_integrate_spec s;
    qmc_integrate_spec_init(&s);
    s.method = m;
    s.n_axis = n;
    s.n_given = n != 0;
    qmc_integrate_report rep;
    char why[256];
    int err = qmc_integrate(&s, f, NULL, NULL, NULL, &rep, why, sizeof why);
    *out = rep.res;
    *truth = f->exact;
    qmc_testfn_free(fn);
    if (err)
        return -1;
    return fabs(out->estimate - *truth) <= 3 * out->error + 64 * DBL_EPSILON * fabs(*truth);
}

static int scan_1d(int runs)
{
    const qmc_method ms[] = {QMC_METHOD_MIDPOINT, QMC_METHOD_TRAPEZOID, QMC_METHOD_SIMPSON,
                             QMC_METHOD_GAUSS_LEGENDRE, QMC_METHOD_CUBATURE,
                             QMC_METHOD_CLENSHAW_CURTIS};
    const char *fams[] = {"step", "genz-discontinuous", "genz-continuous"};
    for (int fi = 0; fi < 3; fi++)
        for (int mi = 0; mi < 6; mi++) {
            int correct = 0, flagged = 0, wrong = 0, silent = 0;
            for (int r = 0; r < runs; r++) {
                double a = exp(log(0.5) + (log(300) - log(0.5)) * u01()), u;
                const double e = u01();
                u = e < 0.2 ? pow(10, -9 * u01()) : e < 0.4 ? 1 - pow(10, -9 * u01()) : u01();
                if (!(u > 0 && u < 1))
                    u = 0.5;
                const uint32_t ns[] = {16, 64, 1024, 4096};
                uint32_t n = ns[(int)(u01() * 4)];
                if ((mi == 1 || mi == 2) && n % 2 == 0)
                    n++;
                qmc_result res;
                double truth;
                int ok = judge(fams[fi], 1, &a, &u, ms[mi], mi < 4 ? n : 0, &res, &truth);
                if (ok < 0)
                    return 3;
                const int fl = (res.flags & QMC_FLAG_ERROR_UNRELIABLE) != 0;
                if (ok) {
                    correct++;
                    flagged += fl;
                } else {
                    wrong++;
                    silent += !fl;
                    if (!fl)
                        printf("  silent %s %s n %u a %.17g u %.17g: %.17g +- %.3g, truth "
                               "%.17g\n", fams[fi], qmc_method_name(ms[mi]), n, a, u,
                               res.estimate, res.error, truth);
                }
            }
            printf("%s %s: %d runs, %d correct (%d flagged), %d wrong, %d silent\n", fams[fi],
                   qmc_method_name(ms[mi]), runs, correct, flagged, wrong, silent);
        }
    return 0;
}

static int scan_kinks(int runs, const char *fam)
{
    const qmc_method ms[] = {QMC_METHOD_MIDPOINT, QMC_METHOD_TRAPEZOID, QMC_METHOD_SIMPSON,
                             QMC_METHOD_GAUSS_LEGENDRE};
    const uint32_t others = QMC_FLAG_UNRESOLVED | QMC_FLAG_ROUNDOFF | QMC_FLAG_NONFINITE;
    for (int mi = 0; mi < 4; mi++) {
        int wrong = 0, only = 0, silent = 0, correct = 0, alarmed = 0;
        for (int r = 0; r < runs; r++) {
            const uint32_t d = 2 + (uint32_t)(u01() * 2);
            double a[3], u[3];
            for (uint32_t j = 0; j < d; j++) {
                a[j] = exp(log(300) * u01());
                u[j] = u01();
            }
            const uint32_t ns[] = {16, 33, 65};
            uint32_t n = ns[(int)(u01() * 3)];
            if (mi == 2 && n % 2 == 0)
                n++;
            qmc_result res;
            double truth;
            int ok = judge(fam, d, a, u, ms[mi], n, &res, &truth);
            if (ok < 0)
                return 3;
            if (ok) {
                correct++;
                alarmed += (res.flags & QMC_FLAG_ERROR_UNRELIABLE) != 0;
                continue;
            }
            wrong++;
            if (res.flags == 0) {
                silent++;
                printf("  silent: %s d %u n %u a1 %.17g u1 %.17g, %.2f bars off\n",
                       qmc_method_name(ms[mi]), d, n, a[0], u[0],
                       fabs(res.estimate - truth) / res.error);
            } else if (!(res.flags & others)) {
                only++;
                printf("  only the declaration: %s d %u n %u a1 %.17g u1 %.17g, %.2f bars off\n",
                       qmc_method_name(ms[mi]), d, n, a[0], u[0],
                       fabs(res.estimate - truth) / res.error);
            }
        }
        printf("%s: %d runs, %d correct (%d flagged error_unreliable), %d wrong, %d flagged by "
               "nothing but the declared kink, %d silent\n",
               qmc_method_name(ms[mi]), runs, correct, alarmed, wrong, only, silent);
    }
    return 0;
}

int main(int argc, char **argv)
{
    if (argc != 4 || (strcmp(argv[1], "1d") && strcmp(argv[1], "kinks") &&
                      strcmp(argv[1], "jumps"))) {
        fprintf(stderr, "usage: %s 1d|kinks|jumps RUNS SEED\n", argv[0]);
        return 2;
    }
    state = strtoull(argv[3], NULL, 10);
    if (strcmp(argv[1], "1d") == 0)
        return scan_1d(atoi(argv[2]));
    return scan_kinks(atoi(argv[2]), strcmp(argv[1], "kinks") == 0 ? "genz-continuous"
                                                                   : "genz-discontinuous");
}
