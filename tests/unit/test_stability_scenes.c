/*
 * test_stability_scenes.c - classes 4 and 5 of issue 13's audit on scenes
 * and sampling: a MIS technique that never samples its share
 * (mis_undersampled), tiny lights and budgets, zero pdfs, overflowing
 * sums (nonfinite) and stratified past 2 strata a side (refused); and
 * issue 23's two: MIS at beta 0.05 starving the light technique under a
 * large rect light, and uniform sampling missing a narrow lobe in every
 * RQMC replicate (closed forms for both).
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <string.h>

#include "qmc/integrate.h"
#include "qmc/quad.h"
#include "qmc/scene.h"
#include "qmc/testfn.h"

#include "stability_cases.h"

/* ---- scenes ---- */

typedef struct scene_out {
    int err;
    qmc_integrate_report rep;
    char why[256];
    double truth;
} scene_out;

/* The audit's budget unless a case lowers it (seconds, not minutes). */
static uint64_t scene_budget = 20000000;
static uint64_t scene_seed = 12345;

static scene_out run_scene(const char *text, qmc_scene_strategy st, double beta,
                           qmc_method method, uint64_t n)
{
    qmc_scene sc;
    qmc_scene_job job;
    char why[256];
    if (qmc_scene_parse(text, strlen(text), &sc, why, sizeof why) != 0)
        fail_msg("%s", why);
    if (qmc_scene_integrand(&sc, st, beta, 1, 1, &job, why, sizeof why) != 0)
        fail_msg("%s", why);
    scene_out o;
    memset(&o, 0, sizeof o);
    /* No closed form (a Phong lobe under a rect): NAN, which no interval
     * covers, so a case on such a scene must be flagged. */
    if (qmc_scene_exact(&sc, &o.truth) != 0)
        o.truth = NAN;
    qmc_integrate_spec s;
    qmc_integrate_spec_init(&s);
    s.method = method;
    if (method == QMC_METHOD_RQMC)
        qmc_sampling_spec_init(&s.sampling, QMC_SAMPLER_RQMC);
    s.max_evals = scene_budget;
    s.sampling.seed = scene_seed;
    if (n) {
        s.sampling.n = n;
        s.n_given = 1;
    }
    o.err = qmc_integrate(&s, &job.integrand, NULL, NULL, NULL, &o.rep, o.why, sizeof o.why);
    return o;
}

/* Class 5, zero_pdf: reachable, by one floating-point gap in the model's
 * argument (scene_eval.c) that the audit exists to catch.  With kd = 0
 * the BRDF density is the power-cosine lobe alone, (n + 1) / (2 pi)
 * cos^n(alpha); for n < 2.14 that factor is below 1/2, so where cos^n
 * rounds to the smallest subnormal the density rounds to 0, while the
 * shade, ks (n + 2) / (2 pi) > 1/2 times the same power, keeps it and a
 * radiance of 1e300 lifts it to 4e-24.  cos(alpha) must then be about
 * 2e-162 at a light direction: the normal along x and the view (1, 1,
 * -4.4e-162) make r = (0.71, -0.71, 2.2e-162), and the rect's grid row
 * with x = y (exact in binary) makes the first two products of w . r
 * cancel exactly, leaving w_z r_z.  The mass lost is 1e-300 of the
 * integral, but it is mass the brdf estimator can never draw, and the
 * flag says so; uniform sampling, positive there, is not flagged. */
static const char zero_pdf_scene[] =
    "point 0 0 0\nnormal 1 0 0\nview 1 1 -4.4e-162\n"
    "brdf phong kd 0 ks 1 exponent 2\n"
    "light rect corner 0.25 0.7578125 1 edge1 0.5 0.5 0 edge2 1 0 0 radiance 1e300\n";

static void test_zero_pdf_reachable(void **state)
{
    (void)state;
    scene_out o = run_scene(zero_pdf_scene, QMC_SCENE_BRDF, 0, QMC_METHOD_MC, 4096);
    assert_int_equal(o.err, 0);
    ASSERT_FLAGS(o, QMC_FLAG_ZERO_PDF | QMC_FLAG_ERROR_UNRELIABLE);
    ASSERT_COVERS_OR_FLAGGED(o, o.truth);
    assert_true(isnan(o.truth)); /* so the line above demanded the flag */
    o = run_scene(zero_pdf_scene, QMC_SCENE_UNIFORM, 0, QMC_METHOD_MC, 4096);
    assert_int_equal(o.err, 0);
    assert_false(o.rep.res.flags & QMC_FLAG_ZERO_PDF);
}

/* Lambert under a sphere light of radius 0.005 at distance 5.1: 1e-6 of
 * the hemisphere.  Closed form albedo L sin^2(alpha) cos(theta). */
static const char tiny_light[] = "point 0 0 0\nnormal 0 0 1\nbrdf lambert 0.8\n"
                                 "light sphere center 1 0.5 5 radius 0.005 radiance 10\n";

static double tiny_light_truth(void)
{
    double dist = sqrt(1.0 + 0.25 + 25.0), s = 0.005 / dist;
    return 0.8 * 10.0 * s * s * (5.0 / dist);
}

/* Class 2, scenes: uniform and BRDF sampling never reach the tiny light in
 * 4096 points: 0 +- 0. */
static void test_tiny_light_zero_flagged(void **state)
{
    (void)state;
    const qmc_scene_strategy st[] = {QMC_SCENE_UNIFORM, QMC_SCENE_BRDF};
    for (size_t i = 0; i < 2; i++) {
        scene_out o = run_scene(tiny_light, st[i], 0, QMC_METHOD_MC, 0);
        assert_true(fabs(o.truth - tiny_light_truth()) < 1e-12 * o.truth);
        ASSERT_FLAGS(o, QMC_FLAG_FEW_NONZERO | QMC_FLAG_ERROR_UNRELIABLE);
        ASSERT_COVERS_OR_FLAGGED(o, o.truth);
        /* auto keeps going until it finds the light or the budget ends. */
        scene_budget = 4000000;
        o = run_scene(tiny_light, st[i], 0, QMC_METHOD_AUTO, 0);
        scene_budget = 20000000;
        assert_true(o.rep.res.evals > 2000000); /* it did not stop at 0 +- 0 */
        ASSERT_COVERS_OR_FLAGGED(o, o.truth);
    }
}

/* Class 4: the balance heuristic gives the BRDF technique 1e-6 of the tiny
 * light, which its samples (one in 10^6 reaches the light) never see;
 * mis-power at beta 0.05 gives it 35% (33% low).  The default power
 * heuristic (beta 2) leaves it 1e-12 of the integral: not flagged. */
static void test_mis_undersampled(void **state)
{
    (void)state;
    scene_out o = run_scene(tiny_light, QMC_SCENE_MIS_BALANCE, 0, QMC_METHOD_AUTO, 0);
    ASSERT_FLAGS(o, QMC_FLAG_MIS_UNDERSAMPLED | QMC_FLAG_ERROR_UNRELIABLE);
    ASSERT_COVERS_OR_FLAGGED(o, o.truth);
    assert_false(o.rep.res.ci_low <= o.truth && o.truth <= o.rep.res.ci_high);
    o = run_scene(tiny_light, QMC_SCENE_MIS_POWER, 0.05, QMC_METHOD_AUTO, 0);
    ASSERT_FLAGS(o, QMC_FLAG_MIS_UNDERSAMPLED | QMC_FLAG_ERROR_UNRELIABLE);
    assert_true(o.rep.res.ci_high < 0.8 * o.truth);
    o = run_scene(tiny_light, QMC_SCENE_MIS_POWER, 0.05, QMC_METHOD_RQMC, 0);
    ASSERT_FLAGS(o, QMC_FLAG_MIS_UNDERSAMPLED);
    o = run_scene(tiny_light, QMC_SCENE_MIS_POWER, 0, QMC_METHOD_AUTO, 0);
    assert_false(o.rep.res.flags & QMC_FLAG_MIS_UNDERSAMPLED);
    assert_true(o.rep.res.ci_low <= o.truth && o.truth <= o.rep.res.ci_high);
    /* Ours: a large light, where BRDF samples reach it all the time. */
    static const char big[] = "point 0 0 0\nnormal 0 0 1\nbrdf lambert 0.8\n"
                              "light sphere center 1 0.5 5 radius 0.6 radiance 10\n";
    o = run_scene(big, QMC_SCENE_MIS_BALANCE, 0, QMC_METHOD_AUTO, 0);
    assert_int_equal(o.rep.res.flags & (QMC_FLAG_MIS_UNDERSAMPLED | QMC_FLAG_ZERO_PDF), 0);
}

/* Class 4, tiny budgets: a Phong lobe of exponent 5000 at n = 16. */
static void test_tiny_budget_flagged(void **state)
{
    (void)state;
    static const char phong[] = "point 0 0 0\nnormal 0 0 1\nview 0.6 0 0.8\n"
                                "brdf phong kd 0 ks 0.6 exponent 5000\n"
                                "light sphere center -2 0 2.6667 radius 0.8 radiance 8\n";
    qmc_scene sc;
    char why[256];
    assert_int_equal(qmc_scene_parse(phong, strlen(phong), &sc, why, sizeof why), 0);
    double ref = 0, ref_err = 0;
    int exact = 0;
    assert_int_equal(qmc_scene_reference(&sc, &ref, &ref_err, &exact), 0);
    const qmc_method m[] = {QMC_METHOD_MC, QMC_METHOD_LHS};
    const qmc_scene_strategy st[] = {QMC_SCENE_BRDF, QMC_SCENE_LIGHT, QMC_SCENE_MIS_POWER};
    for (size_t i = 0; i < 2; i++)
        for (size_t j = 0; j < 3; j++) {
            qmc_scene_job job;
            assert_int_equal(qmc_scene_integrand(&sc, st[j], 0, 1, 1, &job, why, sizeof why),
                             0);
            qmc_integrate_spec s;
            qmc_integrate_spec_init(&s);
            s.method = m[i];
            s.sampling.seed = 12345;
            s.sampling.n = 16;
            s.n_given = 1;
            qmc_integrate_report rep;
            assert_int_equal(qmc_integrate(&s, &job.integrand, NULL, NULL, NULL, &rep, why,
                                           sizeof why), 0);
            assert_true(rep.res.flags & QMC_FLAG_TAIL_UNTESTED);
        }
}

/* Light sampling of a light 3e-4 rad wide: the cone's 1 - cos is 4.5e-8,
 * and taken from cos it kept 2.5e-9 relative error, a bias 1000x the
 * RQMC bar (the stability matrix's tiny-light/light cell).  Now the
 * interval covers the closed form albedo L (r / D)^2 cos(theta). */
static void test_tiny_cone_no_roundoff_bias(void **state)
{
    (void)state;
    static const char tiny[] = "point 0 0 0\nnormal 0 0 1\nbrdf lambert albedo 0.8\n"
                               "light sphere center 0.3 0.2 10 radius 0.003 radiance 1e6\n";
    scene_out o = run_scene(tiny, QMC_SCENE_LIGHT, 0, QMC_METHOD_RQMC, 4096);
    double dist = sqrt(0.09 + 0.04 + 100.0), s = 0.003 / dist;
    double truth = 0.8 * 1e6 * s * s * (10.0 / dist);
    assert_true(fabs(o.truth - truth) <= 1e-14 * truth);
    assert_int_equal(o.err, 0);
    assert_int_equal(o.rep.res.flags, 0);
    assert_true(o.rep.res.ci_low <= truth && truth <= o.rep.res.ci_high);
}

/* Class 5: a radiance of 1e308 overflows the sums of finite values. */
static void test_overflow_nonfinite(void **state)
{
    (void)state;
    static const char hot[] = "point 0 0 0\nnormal 0 0 1\nbrdf lambert 0.8\n"
                              "light sphere center 1 0.5 5 radius 0.6 radiance 1e308\n";
    const qmc_method m[] = {QMC_METHOD_AUTO, QMC_METHOD_MC, QMC_METHOD_RQMC};
    for (size_t i = 0; i < 3; i++) {
        scene_out o = run_scene(hot, QMC_SCENE_MIS_POWER, 0, m[i], 0);
        assert_true(isfinite(o.truth));
        ASSERT_FLAGS(o, QMC_FLAG_NONFINITE | QMC_FLAG_ERROR_UNRELIABLE);
        if (m[i] == QMC_METHOD_AUTO) /* stops: more points will not help */
            assert_true(o.rep.res.evals <= 100000);
    }
}

/* Class 5: stratified at d >= 13 had one stratum of one point. */
static void test_stratified_refused_past_2_per_axis(void **state)
{
    (void)state;
    run_out o = run("genz-gaussian", 13, QMC_METHOD_STRATIFIED, NULL);
    assert_int_equal(o.err, QMC_ECOUNT);
    assert_non_null(strstr(o.why, "8192"));
    assert_int_equal(o.rep.res.evals, 0);
    o = run("genz-gaussian", 12, QMC_METHOD_STRATIFIED, NULL); /* 2^12 = 4096 fits */
    assert_int_equal(o.err, 0);
    assert_true(isfinite(o.rep.res.error));
}

/* Issue 23: a Phong lobe (kd 0.5, ks 0.5, exponent 50) about the normal
 * under a 200 x 200 light 0.01 above the point.  Closed form: the diffuse
 * part is kd times the form factor of a parallel square centred over the
 * point, F = (4 / pi) X atan X with X = A / sqrt(1 + A^2), A = 100 / 0.01
 * (four corner rectangles, Howell's catalogue C-11); the lobe's, ks (n + 2)
 * / (2 pi) int cos^(n+1), is ks up to ks cos^(n+2) of the angle to the
 * nearest edge, (1e-4)^52.  So 0.5 F + 0.5 = 0.99999999591. */
static const char mis_rect[] =
    "point 0 0 0\nnormal 0 0 1\nbrdf phong kd 0.5 ks 0.5 exponent 50\n"
    "light rect corner -100 -100 0.01 edge1 0 200 0 edge2 200 0 0 radiance 1\n";

static double mis_rect_truth(void)
{
    double a = 100.0 / 0.01, x = a / sqrt(1.0 + a * a);
    return 0.5 * (4.0 / 3.14159265358979323846 * x * atan(x)) + 0.5;
}

/* At beta 0.05 the light technique keeps about a quarter of the weight
 * right above the point, where uniform area samples land once in 10^8:
 * 0.71 +- 0.0005 against 1, every seed, and mis_undersampled was silent
 * (the audit assumed the light technique, covering every direction, could
 * not be the one missing).  The default beta 2 and the balance heuristic
 * are right and stay unflagged. */
static void test_mis_starves_the_light_technique(void **state)
{
    (void)state;
    const double truth = mis_rect_truth();
    assert_true(fabs(truth - 0.99999999591) < 1e-11);
    const qmc_method m[] = {QMC_METHOD_MC, QMC_METHOD_RQMC};
    for (size_t i = 0; i < 2; i++) {
        scene_out o = run_scene(mis_rect, QMC_SCENE_MIS_POWER, 0.05, m[i], 4096);
        assert_int_equal(o.err, 0);
        assert_true(o.rep.res.estimate < 0.8); /* the failure is still there ... */
        ASSERT_FLAGS(o, QMC_FLAG_MIS_UNDERSAMPLED | QMC_FLAG_ERROR_UNRELIABLE); /* ... seen */
        ASSERT_COVERS_OR_FLAGGED(o, truth);
        o = run_scene(mis_rect, QMC_SCENE_MIS_POWER, 2.0, m[i], 4096);
        assert_int_equal(o.err, 0);
        assert_int_equal(o.rep.res.flags, 0);
        assert_true(fabs(o.rep.res.estimate - truth) <= 3 * o.rep.res.error);
        o = run_scene(mis_rect, QMC_SCENE_MIS_BALANCE, 0, m[i], 4096);
        assert_int_equal(o.err, 0);
        assert_int_equal(o.rep.res.flags, 0);
        assert_true(fabs(o.rep.res.estimate - truth) <= 3 * o.rep.res.error);
    }
}

/* Issue 23: a lobe of exponent 3000 about the normal under a sphere light
 * on the axis (half-angle 30 degrees).  With view = normal the lobe's
 * mirror direction is the normal, and int over the cone of
 * cos^(n+1) theta dw = 2 pi (1 - cos^(n+2) theta_max) / (n + 2), so the
 * radiance is L (kd sin^2 theta_max + ks (1 - cos^(n+2) theta_max)) =
 * 2.6 (0.02 / 4 + 0.98 (1 - 0.75^1501)) = 2.561.  Uniform directions at 16
 * points a replicate miss the lobe (3e-4 of the hemisphere) in every
 * replicate and report the diffuse 0.013 with a normal-looking spread. */
static const char narrow_lobe[] = "point 0 0 0\nnormal 0 0 1\n"
                                  "brdf phong kd 0.02 ks 0.98 exponent 3000\n"
                                  "light sphere center 0 0 2 radius 1 radiance 2.6\n";

static void test_uniform_misses_a_narrow_lobe(void **state)
{
    (void)state;
    const double c = sqrt(0.75), truth = 2.6 * (0.02 * 0.25 + 0.98 * (1.0 - pow(c, 3002)));
    /* Each seed's 256 points expect 0.7 samples in the lobe.  Those that
     * missed it are tight around 0.013 and must carry mis_undersampled;
     * those that hit it have a bar as wide as the integral, and heavy_tail
     * or the wide bar says so. */
    int missed = 0;
    scene_out o;
    for (scene_seed = 1; scene_seed <= 8; scene_seed++) {
        o = run_scene(narrow_lobe, QMC_SCENE_UNIFORM, 0, QMC_METHOD_RQMC, 16);
        assert_int_equal(o.err, 0);
        ASSERT_COVERS_OR_FLAGGED(o, truth);
        if (o.rep.res.estimate < 0.1) {
            missed++;
            ASSERT_FLAGS(o, QMC_FLAG_MIS_UNDERSAMPLED | QMC_FLAG_ERROR_UNRELIABLE);
        }
    }
    scene_seed = 12345;
    assert_true(missed >= 1);
    /* enough points see the lobe, and then no flag */
    o = run_scene(narrow_lobe, QMC_SCENE_UNIFORM, 0, QMC_METHOD_RQMC, 1u << 16);
    assert_int_equal(o.err, 0);
    assert_false(o.rep.res.flags & QMC_FLAG_MIS_UNDERSAMPLED);
    assert_true(fabs(o.rep.res.estimate - truth) <= 3 * o.rep.res.error);
    /* BRDF sampling draws the lobe itself: right at 16 points a replicate */
    o = run_scene(narrow_lobe, QMC_SCENE_BRDF, 0, QMC_METHOD_RQMC, 16);
    assert_int_equal(o.err, 0);
    assert_int_equal(o.rep.res.flags, 0);
    assert_true(fabs(o.rep.res.estimate - truth) <= 3 * o.rep.res.error);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_zero_pdf_reachable),
        cmocka_unit_test(test_tiny_light_zero_flagged),
        cmocka_unit_test(test_mis_undersampled),
        cmocka_unit_test(test_tiny_budget_flagged),
        cmocka_unit_test(test_overflow_nonfinite),
        cmocka_unit_test(test_tiny_cone_no_roundoff_bias),
        cmocka_unit_test(test_stratified_refused_past_2_per_axis),
        cmocka_unit_test(test_mis_starves_the_light_technique),
        cmocka_unit_test(test_uniform_misses_a_narrow_lobe),
    };
    return cmocka_run_group_tests_name("stability-scenes", tests, NULL, NULL);
}
