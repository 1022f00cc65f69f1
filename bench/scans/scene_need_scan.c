/*
 * scene_need_scan.c - rule_need_scan.c's question for the stability
 * matrix's scene cells: were the error_unreliable flags that deterministic
 * rules carry on correct answers needed?
 *
 * The case is redrawn where it is arbitrary: the light's place beside the
 * shading point.  mis-rect (Phong kd 0.5 ks 0.5 exponent 50 under a 200 x
 * 200 rect light 0.01 above the point, power heuristic beta 0.05): the
 * rect's corner moved by U(-50, 50) on each axis, so that it still covers
 * the point.  lobe3000 (a Phong lobe of exponent 3000 about the normal
 * under a sphere light of radius 1 at height 2, uniform directions): the
 * light's centre moved by U(-0.3, 0.3) on each horizontal axis, so that
 * its cone still holds the lobe.  tiny-light/uniform and /light (a
 * Lambert point under a sphere light of radius 0.003 at height 10): the
 * centre moved by U(-2, 2) on each horizontal axis.  phong5000/light (a
 * near-mirror lobe of exponent 5000, light sampling): the sphere's centre
 * moved by U(-0.5, 0.5) horizontally.  overflow-light/light (radiance
 * 1e308): the centre moved by U(-1, 1) horizontally.  Each drawn scene is run by the rule with
 * the matrix's budget and spec (method_spec.c; EVALS as the case gives
 * it, 2e7 for an adaptive rule) and judged against the scene module's
 * own reference (qmc_scene_reference, as `qmc stability` judges: 3 bars
 * plus 64 ulps), flags stripped.  Prints the misses of RUNS and, of them,
 * the runs the rule flagged error_unreliable; and every unflagged miss.
 * A measuring tool: it must not be built into anything.
 *
 * Build and run (from the tree, after make):
 *   cc -O2 -Iinclude -Iclient/cli bench/scans/scene_need_scan.c \
 *      client/cli/method_spec.c build/libqmc.a -lm -lsodium -pthread \
 *      -o /tmp/scene_need_scan
 *   /tmp/scene_need_scan SCENE METHOD RUNS SEED EVALS
 * SCENE: mis-rect, lobe3000, tiny-light/uniform, tiny-light/light,
 * phong5000/light, overflow-light/light.
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "method_spec.h"
#include "qmc/job.h"
#include "qmc/scene.h"

#include "scan_rng.h"

/* The matrix's scenes (client/cli/stability_cases.c) with the light's
 * horizontal place (x0, y0) as a parameter: a sphere's centre, or a
 * rect's corner (edges 200 along y and x, radiance 1). */
typedef struct drawn_scene {
    const char *name, *head; /* head: the lines before the light's */
    int rect;
    double x0, y0, half;     /* moved by U(-half, half) on each axis */
    double z, radius, radiance;
    qmc_scene_strategy st;
    double beta;
} drawn_scene;

static const drawn_scene scenes[] = {
    {"mis-rect", "point 0 0 0\nnormal 0 0 1\nbrdf phong kd 0.5 ks 0.5 exponent 50\n", 1, -100,
     -100, 50, 0.01, 0, 1, QMC_SCENE_MIS_POWER, 0.05},
    {"lobe3000", "point 0 0 0\nnormal 0 0 1\nbrdf phong kd 0.02 ks 0.98 exponent 3000\n", 0, 0,
     0, 0.3, 2, 1, 2.6, QMC_SCENE_UNIFORM, 2},
    {"tiny-light/uniform", "point 0 0 0\nnormal 0 0 1\nbrdf lambert albedo 0.8\n", 0, 0.3, 0.2,
     2, 10, 0.003, 1e6, QMC_SCENE_UNIFORM, 2},
    {"tiny-light/light", "point 0 0 0\nnormal 0 0 1\nbrdf lambert albedo 0.8\n", 0, 0.3, 0.2, 2,
     10, 0.003, 1e6, QMC_SCENE_LIGHT, 2},
    {"phong5000/light",
     "point 0 0 0\nnormal 0 0 1\nview 0.6 0 0.8\nbrdf phong kd 0.05 ks 0.95 exponent 5000\n", 0,
     -2, 0.3, 0.5, 3.5, 0.8, 8, QMC_SCENE_LIGHT, 2},
    {"overflow-light/light", "point 0 0 0\nnormal 0 0 1\nbrdf lambert albedo 1\n", 0, 0, 0, 1, 3,
     1, 1e308, QMC_SCENE_LIGHT, 2},
};

/* One drawn scene of d as text. */
static void draw_scene(const drawn_scene *d, char *text, size_t bytes)
{
    const double x = d->x0 + d->half * (2 * u01() - 1), y = d->y0 + d->half * (2 * u01() - 1);
    if (d->rect)
        snprintf(text, bytes,
                 "%slight rect corner %.17g %.17g %.17g edge1 0 200 0 edge2 200 0 0 radiance 1\n",
                 d->head, x, y, d->z);
    else
        snprintf(text, bytes, "%slight sphere center %.17g %.17g %.17g radius %.17g radiance %.17g\n",
                 d->head, x, y, d->z, d->radius, d->radiance);
}

int main(int argc, char **argv)
{
    if (argc != 6) {
        fprintf(stderr, "usage: %s SCENE METHOD RUNS SEED EVALS\n", argv[0]);
        return 2;
    }
    const int runs = atoi(argv[3]);
    const uint64_t evals = strtoull(argv[5], NULL, 10);
    state = strtoull(argv[4], NULL, 10);
    if (!state)
        state = 1;
    cli_method m;
    char why[256];
    if (runs < 1 || evals == 0 || cli_method_parse(argv[2], &m, why, sizeof why)) {
        fprintf(stderr, "bad arguments\n");
        return 2;
    }
    const drawn_scene *d = NULL;
    for (size_t i = 0; i < sizeof scenes / sizeof scenes[0]; i++)
        if (strcmp(argv[1], scenes[i].name) == 0)
            d = &scenes[i];
    if (!d) {
        fprintf(stderr, "unknown scene %s\n", argv[1]);
        return 2;
    }
    int misses = 0, flagged_misses = 0, flagged_correct = 0;
    for (int r = 0; r < runs; r++) {
        char text[512];
        qmc_job_spec js;
        qmc_job_spec_init(&js);
        draw_scene(d, text, sizeof text);
        js.strategy = d->st;
        js.beta = d->beta;
        js.scene_text = text;
        js.scene_len = (uint32_t)strlen(text);
        qmc_scene sc;
        double truth, truth_err;
        int exact = 0;
        qmc_job *job;
        if (qmc_scene_parse(text, strlen(text), &sc, why, sizeof why) ||
            qmc_scene_reference(&sc, &truth, &truth_err, &exact) ||
            qmc_job_new(&js, &job, why, sizeof why)) {
            fprintf(stderr, "scene: %s\n", why);
            return 3;
        }
        cli_budget b = {.evals = evals, .dims = qmc_job_integrand(job)->dims,
                        .seed = 12345 + 1000003ull * (uint64_t)r};
        qmc_integrate_spec s;
        cli_method_spec(&m, &b, &s);
        if (m.method == QMC_METHOD_CUBATURE || m.method == QMC_METHOD_CLENSHAW_CURTIS ||
            m.method == QMC_METHOD_GAUSS_KRONROD)
            s.max_evals = 20000000;
        qmc_integrate_report rep;
        if (qmc_job_run(job, &s, NULL, NULL, &rep, why, sizeof why)) {
            fprintf(stderr, "run: %s\n", why);
            return 4;
        }
        const double miss = fabs(rep.res.estimate - truth);
        const int wrong = !(miss <= 3 * rep.res.error + 64 * DBL_EPSILON * truth);
        const int flag = (rep.res.flags & QMC_FLAG_ERROR_UNRELIABLE) != 0;
        misses += wrong;
        flagged_misses += wrong && flag;
        flagged_correct += !wrong && flag;
        if (wrong && !flag)
            printf("  unflagged miss: %.17g +- %.3g against %.17g in\n%s", rep.res.estimate,
                   rep.res.error, truth, text);
        qmc_job_free(job);
    }
    printf("%s %s: %d scenes, %d misses (%d flagged), %d correct flagged\n", argv[1], m.name,
           runs, misses, flagged_misses, flagged_correct);
    return 0;
}
