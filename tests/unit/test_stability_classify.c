/*
 * test_stability_classify.c - the classification `qmc stability` and
 * `qmc compare` use (qmc/stability.h), on hand-made results whose class
 * is known by construction:
 *
 *   covered, flagged or not                           OK
 *   outside 3 x the bar, a flag raised                FLAGGED
 *   no bar declared (plain QMC), wrong                FLAGGED
 *   outside 3 x the bar, no flag                      SILENT
 *   a zero bar on a wrong answer (issue 13, class 2)  SILENT
 *   a NaN or infinite bar printed bare                SILENT
 *   a finite answer to an integral that overflows     SILENT
 *   an exact rule rounding its bar to 0               OK (rounding slack)
 *   the method returned an error                      REFUSED
 * and the binomial threshold that keeps an honest randomized cell from
 * being called SILENT by chance (checked against binomial tails computed
 * here by direct summation), the same test for qmc compare's methods, and
 * the per-flag counts of correct and wrong answers.
 */
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include "qmc/stability.h"

static qmc_result result(double est, double err, qmc_error_kind kind, uint32_t flags)
{
    qmc_result r;
    qmc_result_init(&r);
    r.estimate = est;
    r.error = err;
    r.error_kind = kind;
    r.flags = flags;
    r.ci_low = est - 2 * err;
    r.ci_high = est + 2 * err;
    return r;
}

static const qmc_stab_truth one = {.value = 1.0, .abs_error = 0, .scale = 1.0, .defined = 1};

static void test_covered(void **state)
{
    (void)state;
    qmc_result r = result(1.02, 0.01, QMC_ERROR_STDERR, 0);
    qmc_stab_verdict v = qmc_stab_classify(0, &r, &one);
    assert_int_equal(v.cls, QMC_STAB_OK);
    assert_true(v.covered);
    assert_true(fabs(v.ratio - 2.0) < 1e-12);
    /* a flag on a covered result does not make it wrong */
    r.flags = QMC_FLAG_HEAVY_TAIL;
    assert_int_equal(qmc_stab_classify(0, &r, &one).cls, QMC_STAB_OK);
}

static void test_wrong_flagged_and_silent(void **state)
{
    (void)state;
    qmc_result r = result(1.05, 0.01, QMC_ERROR_ESTIMATE, 0);
    assert_int_equal(qmc_stab_classify(0, &r, &one).cls, QMC_STAB_SILENT);
    r.flags = QMC_FLAG_ERROR_UNRELIABLE;
    assert_int_equal(qmc_stab_classify(0, &r, &one).cls, QMC_STAB_FLAGGED);
    /* just inside and just outside 3 errors */
    r = result(1.0299, 0.01, QMC_ERROR_STDERR, 0);
    assert_int_equal(qmc_stab_classify(0, &r, &one).cls, QMC_STAB_OK);
    r = result(1.0301, 0.01, QMC_ERROR_STDERR, 0);
    assert_int_equal(qmc_stab_classify(0, &r, &one).cls, QMC_STAB_SILENT);
    /* the reference's own error widens what counts as covered */
    qmc_stab_truth loose = one;
    loose.abs_error = 0.001;
    assert_int_equal(qmc_stab_classify(0, &r, &loose).cls, QMC_STAB_OK);
}

static void test_zero_bar(void **state)
{
    (void)state;
    /* issue 13: a tiny support seen by no sample, 0 +- 0 */
    qmc_stab_truth t = {.value = 6.0e-6, .scale = 6.0e-6, .defined = 1};
    qmc_result r = result(0, 0, QMC_ERROR_STDERR, 0);
    qmc_stab_verdict v = qmc_stab_classify(0, &r, &t);
    assert_int_equal(v.cls, QMC_STAB_SILENT);
    assert_true(isinf(v.ratio));
}

static void test_bare_bars(void **state)
{
    (void)state;
    qmc_result r = result(0.9, NAN, QMC_ERROR_STDERR, 0);
    assert_int_equal(qmc_stab_classify(0, &r, &one).cls, QMC_STAB_SILENT);
    r = result(0.9, INFINITY, QMC_ERROR_STDERR, 0);
    assert_int_equal(qmc_stab_classify(0, &r, &one).cls, QMC_STAB_SILENT);
    /* even an accurate estimate with an unusable bar is not "covered" */
    r = result(1.0, INFINITY, QMC_ERROR_STDERR, 0);
    assert_int_equal(qmc_stab_classify(0, &r, &one).cls, QMC_STAB_SILENT);
    r.flags = QMC_FLAG_ERROR_UNRELIABLE;
    assert_int_equal(qmc_stab_classify(0, &r, &one).cls, QMC_STAB_FLAGGED);
    /* a NaN estimate (overflow during summation) with no flag */
    r = result(NAN, NAN, QMC_ERROR_STDERR, 0);
    assert_int_equal(qmc_stab_classify(0, &r, &one).cls, QMC_STAB_SILENT);
    r.flags = QMC_FLAG_NONFINITE;
    assert_int_equal(qmc_stab_classify(0, &r, &one).cls, QMC_STAB_FLAGGED);
}

static void test_declared_no_bar(void **state)
{
    (void)state;
    qmc_result r = result(0.5, 0, QMC_ERROR_NONE, 0);
    qmc_stab_verdict v = qmc_stab_classify(0, &r, &one);
    assert_int_equal(v.cls, QMC_STAB_FLAGGED);
    assert_false(v.bar_usable);
}

static void test_undefined_integral(void **state)
{
    (void)state;
    qmc_stab_truth inf = {.value = INFINITY, .defined = 0};
    qmc_result r = result(1e300, 1e299, QMC_ERROR_STDERR, 0);
    assert_int_equal(qmc_stab_classify(0, &r, &inf).cls, QMC_STAB_SILENT);
    r.flags = QMC_FLAG_NONFINITE;
    assert_int_equal(qmc_stab_classify(0, &r, &inf).cls, QMC_STAB_FLAGGED);
}

static void test_rounding_slack(void **state)
{
    (void)state;
    /* an exact rule: error 3 ulps, its estimate rounded to 0 */
    qmc_result r = result(1.0 + 3 * 2.220446049250313e-16, 0, QMC_ERROR_ESTIMATE, 0);
    assert_int_equal(qmc_stab_classify(0, &r, &one).cls, QMC_STAB_OK);
    /* but 1e-12 off with a zero bar is wrong */
    r.estimate = 1.0 + 1e-12;
    assert_int_equal(qmc_stab_classify(0, &r, &one).cls, QMC_STAB_SILENT);
}

static void test_refused(void **state)
{
    (void)state;
    qmc_stab_verdict v = qmc_stab_classify(1, NULL, &one);
    assert_int_equal(v.cls, QMC_STAB_REFUSED);
    assert_string_equal(qmc_stab_class_name(QMC_STAB_REFUSED), "REFUSED");
    assert_string_equal(qmc_stab_class_name(QMC_STAB_SILENT), "SILENT");
}

/* P(Binomial(n, p) >= s), by direct summation of the terms. */
static double binom_tail(unsigned n, double p, unsigned s)
{
    double total = 0;
    for (unsigned k = s; k <= n; k++) {
        double c = 1;
        for (unsigned j = 0; j < k; j++)
            c = c * (double)(n - j) / (double)(j + 1);
        total += c * pow(p, k) * pow(1 - p, n - k);
    }
    return total;
}

static void test_threshold(void **state)
{
    (void)state;
    assert_int_equal(qmc_stab_silent_threshold(1, 0.01, 1e-3), 1);
    const unsigned ns[] = {2, 3, 5, 16, 64, 200};
    for (size_t i = 0; i < sizeof ns / sizeof ns[0]; i++) {
        unsigned n = ns[i];
        uint32_t s = qmc_stab_silent_threshold(n, 0.01, 1e-3);
        assert_true(s >= 1 && s <= n);
        /* the smallest s whose tail is below alpha */
        assert_true(binom_tail(n, 0.01, s) < 1e-3);
        if (s > 1)
            assert_true(binom_tail(n, 0.01, s - 1) >= 1e-3);
    }
    assert_int_equal(qmc_stab_silent_threshold(3, 0.01, 1e-3), 2);
}

static void test_tally(void **state)
{
    (void)state;
    qmc_stab_tally t = {0};
    qmc_result ok = result(1.0, 0.1, QMC_ERROR_STDERR, 0);
    qmc_result bad = result(2.0, 0.1, QMC_ERROR_STDERR, 0);
    qmc_stab_verdict vo = qmc_stab_classify(0, &ok, &one), vb = qmc_stab_classify(0, &bad, &one);
    qmc_stab_tally_add(&t, &vo, &ok);
    qmc_stab_tally_add(&t, &vo, &ok);
    qmc_stab_tally_add(&t, &vb, &bad);
    /* one silent run in three: below the threshold of 2, and most runs OK */
    assert_int_equal(qmc_stab_tally_class(&t, 2), QMC_STAB_OK);
    qmc_stab_tally_add(&t, &vb, &bad);
    assert_int_equal(qmc_stab_tally_class(&t, 2), QMC_STAB_SILENT);
    qmc_stab_tally r = {0};
    qmc_stab_verdict vr = qmc_stab_classify(1, NULL, &one);
    qmc_stab_tally_add(&r, &vr, NULL);
    assert_int_equal(qmc_stab_tally_class(&r, 1), QMC_STAB_REFUSED);
}

/* The one test stability and compare share: one 3-sigma miss in nine
 * randomized runs (a 1% event each, P(>= 1) = 8.6%) is chance, as are two
 * (P = 0.34%); three (P = 8e-5) are not.  A deterministic rule's one miss
 * is no chance: it repeats on every run. */
static void test_silent_needed(void **state)
{
    (void)state;
    assert_true(binom_tail(9, QMC_STAB_CHANCE_MISS, 2) >= QMC_STAB_SILENT_ALPHA);
    assert_true(binom_tail(9, QMC_STAB_CHANCE_MISS, 3) < QMC_STAB_SILENT_ALPHA);
    assert_int_equal(qmc_stab_silent_needed(9, 1), 3);
    assert_int_equal(qmc_stab_silent_needed(9, 0), 1);
    assert_int_equal(qmc_stab_silent_needed(1, 1), 1);
    for (unsigned n = 1; n <= 200; n++)
        assert_int_equal(qmc_stab_silent_needed(n, 1),
                         qmc_stab_silent_threshold(n, QMC_STAB_CHANCE_MISS, QMC_STAB_SILENT_ALPHA));
    /* nine randomized runs with one silent: the class stays OK */
    qmc_stab_tally t = {0};
    qmc_result ok = result(1.0, 0.1, QMC_ERROR_STDERR, 0);
    qmc_result bad = result(2.0, 0.1, QMC_ERROR_STDERR, 0);
    qmc_stab_verdict vo = qmc_stab_classify(0, &ok, &one), vb = qmc_stab_classify(0, &bad, &one);
    for (int i = 0; i < 8; i++)
        qmc_stab_tally_add(&t, &vo, &ok);
    qmc_stab_tally_add(&t, &vb, &bad);
    assert_int_equal(qmc_stab_tally_class(&t, qmc_stab_silent_needed(t.runs, 1)), QMC_STAB_OK);
    assert_int_equal(qmc_stab_tally_class(&t, qmc_stab_silent_needed(t.runs, 0)), QMC_STAB_SILENT);
}

/* Per-flag counts: a flag on a covered run counts on correct answers, on
 * an uncovered one on wrong answers; refusals and bar-less runs not at all. */
static void test_flag_tally(void **state)
{
    (void)state;
    qmc_stab_flag_tally t = {0}, sum = {0};
    qmc_result ok = result(1.0, 0.1, QMC_ERROR_STDERR, QMC_FLAG_ERROR_UNRELIABLE);
    qmc_result okq = result(1.0, 0.1, QMC_ERROR_STDERR, 0);
    qmc_result bad = result(2.0, 0.1, QMC_ERROR_STDERR,
                            QMC_FLAG_ERROR_UNRELIABLE | QMC_FLAG_FEW_NONZERO);
    qmc_result nobar = result(2.0, 0.0, QMC_ERROR_NONE, QMC_FLAG_NOT_POW2);
    qmc_stab_verdict v;
    v = qmc_stab_classify(0, &ok, &one), qmc_stab_flag_tally_add(&t, 0, &v, &ok);
    v = qmc_stab_classify(0, &okq, &one), qmc_stab_flag_tally_add(&t, 0, &v, &okq);
    v = qmc_stab_classify(0, &bad, &one), qmc_stab_flag_tally_add(&t, 0, &v, &bad);
    v = qmc_stab_classify(0, &nobar, &one), qmc_stab_flag_tally_add(&t, 0, &v, &nobar);
    v = qmc_stab_classify(1, NULL, &one), qmc_stab_flag_tally_add(&t, 1, &v, &bad);
    assert_int_equal(t.correct, 2);
    assert_int_equal(t.wrong, 1);
    assert_int_equal(t.correct_flagged, 1);
    assert_int_equal(t.wrong_flagged, 1);
    assert_int_equal(t.on_correct[10], 1); /* error_unreliable is bit 10 */
    assert_int_equal(t.on_wrong[10], 1);
    assert_int_equal(t.on_wrong[12], 1);  /* few_nonzero */
    assert_int_equal(t.on_correct[2] + t.on_wrong[2], 0); /* not_pow2: no bar, not counted */
    qmc_stab_flag_tally_merge(&sum, &t);
    qmc_stab_flag_tally_merge(&sum, &t);
    assert_int_equal(sum.correct, 4);
    assert_int_equal(sum.on_wrong[12], 2);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_covered),
        cmocka_unit_test(test_wrong_flagged_and_silent),
        cmocka_unit_test(test_zero_bar),
        cmocka_unit_test(test_bare_bars),
        cmocka_unit_test(test_declared_no_bar),
        cmocka_unit_test(test_undefined_integral),
        cmocka_unit_test(test_rounding_slack),
        cmocka_unit_test(test_refused),
        cmocka_unit_test(test_threshold),
        cmocka_unit_test(test_tally),
        cmocka_unit_test(test_silent_needed),
        cmocka_unit_test(test_flag_tally),
    };
    return cmocka_run_group_tests_name("stability_classify", tests, NULL, NULL);
}
