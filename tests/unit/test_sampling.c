/*
 * test_sampling.c - the sampling engine: estimates inside their intervals,
 * determinism under any block order, control variates, adaptive stopping,
 * every diagnostic flag, and the errors.
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "qmc/sampling.h"
#include "qmc/seq.h"

/* f(x) = sum_j x_j^2, integral dims/3. */
static void sum_squares(const void *ctx, const double *x, size_t n, uint32_t d, double *out)
{
    (void)ctx;
    for (size_t i = 0; i < n; i++) {
        double s = 0;
        for (uint32_t j = 0; j < d; j++)
            s += x[i * d + j] * x[i * d + j];
        out[i] = s;
    }
}

/* g(x) = sum_j x_j, integral dims/2: a control for sum_squares. */
static void sum_linear(const void *ctx, const double *x, size_t n, uint32_t d, double *out)
{
    (void)ctx;
    for (size_t i = 0; i < n; i++) {
        double s = 0;
        for (uint32_t j = 0; j < d; j++)
            s += x[i * d + j];
        out[i] = s;
    }
}

/* x^-1/2 in 1D: integral 2, infinite variance. */
static void inv_sqrt(const void *ctx, const double *x, size_t n, uint32_t d, double *out)
{
    (void)ctx;
    for (size_t i = 0; i < n; i++)
        out[i] = 1.0 / sqrt(x[i * d]);
}

/* NaN on a tenth of the cube. */
static void sometimes_nan(const void *ctx, const double *x, size_t n, uint32_t d, double *out)
{
    (void)ctx;
    for (size_t i = 0; i < n; i++)
        out[i] = x[i * d] < 0.1 ? NAN : 1.0;
}

static qmc_integrand make_f(void (*eval)(const void *, const double *, size_t, uint32_t, double *),
                            uint32_t dims, double exact)
{
    qmc_integrand f = {.eval = eval, .dims = dims, .has_exact = 1, .exact = exact,
                       .name = "test"};
    return f;
}

static void run(const qmc_sampling_spec *s, const qmc_integrand *f, const qmc_integrand *g,
                qmc_result *res, qmc_cv_report *cv)
{
    qmc_sampling_job *job = NULL;
    char why[200];
    int err = qmc_sampling_job_new(s, f, g, &job, why, sizeof why);
    if (err)
        fail_msg("job_new: %s", why);
    assert_int_equal(qmc_sampling_run(job, NULL, NULL, res, cv), 0);
    qmc_sampling_job_free(job);
}

static void test_estimates_inside_intervals(void **state)
{
    (void)state;
    qmc_integrand f = make_f(sum_squares, 3, 1.0);
    const qmc_sampler samplers[] = {QMC_SAMPLER_MC, QMC_SAMPLER_STRATIFIED, QMC_SAMPLER_LHS,
                                    QMC_SAMPLER_RQMC};
    for (size_t k = 0; k < 4; k++) {
        qmc_sampling_spec s;
        qmc_sampling_spec_init(&s, samplers[k]);
        s.n = samplers[k] == QMC_SAMPLER_STRATIFIED ? 8000 : 8192;
        s.seed = 42;
        qmc_result r;
        run(&s, &f, NULL, &r, NULL);
        assert_int_equal(r.error_kind, QMC_ERROR_STDERR);
        assert_true(r.error > 0 && r.error < 0.01);
        assert_true(r.ci_low <= 1.0 && 1.0 <= r.ci_high);
        assert_int_equal(r.flags, 0);
        assert_int_equal(r.dims, 3);
        assert_int_equal(r.evals, s.n * s.reps);
    }
    /* RQMC's error bar is far smaller than MC's at the same n. */
    qmc_sampling_spec s;
    qmc_result mc, rq;
    qmc_sampling_spec_init(&s, QMC_SAMPLER_MC);
    s.n = 16 * 4096;
    run(&s, &f, NULL, &mc, NULL);
    qmc_sampling_spec_init(&s, QMC_SAMPLER_RQMC);
    s.n = 4096;
    run(&s, &f, NULL, &rq, NULL);
    assert_true(rq.error < mc.error / 20);
}

/* Blocks computed in any order, in any groups, give the same bits. */
/* Values on a coarse grid (many ties), zero on a fifth of the cube, NaN
 * on a twentieth, negative below 0.3: what a block's top list and sums
 * must get right. */
static double coarse_value(const double *x)
{
    if (x[1] < 0.05)
        return NAN;
    if (x[1] > 0.8)
        return 0.0;
    return floor(x[0] * 500.0) / 500.0 - 0.3;
}

static void coarse(const void *ctx, const double *x, size_t n, uint32_t d, double *out)
{
    (void)ctx;
    for (size_t i = 0; i < n; i++)
        out[i] = coarse_value(x + i * d);
}

static int by_descending(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x < y) - (x > y);
}

/* Each block's count, sums, moments and top list against a direct
 * computation over the same points (plain Sobol: the qmc sampler). */
static void test_block_sums_match_reference(void **state)
{
    (void)state;
    qmc_integrand f = make_f(coarse, 2, 0.0);
    qmc_sampling_spec s;
    qmc_sampling_spec_init(&s, QMC_SAMPLER_QMC);
    s.n = QMC_SAMPLING_BLOCK + 1001; /* a partial block, a partial chunk, an odd tail */
    qmc_sampling_job *job = NULL;
    assert_int_equal(qmc_sampling_job_new(&s, &f, NULL, &job, NULL, 0), 0);
    size_t bytes = qmc_sampling_workspace_bytes(job);
    void *ws = malloc(bytes);
    qmc_seq_spec q = {.kind = QMC_SEQ_SOBOL, .dims = 2, .scramble = QMC_SCRAMBLE_NONE};
    qmc_seq *seq = NULL;
    assert_int_equal(qmc_seq_new(&q, &seq), 0);
    double *x = malloc(s.n * 2 * sizeof *x), *all = malloc(s.n * sizeof *all);
    assert_int_equal(qmc_seq_fill(seq, 0, s.n, QMC_FORMAT_F64, x), 0);
    for (uint64_t b = 0; b < 2; b++) {
        qmc_sampling_sums got;
        assert_int_equal(qmc_sampling_run_block(job, b, ws, bytes, &got), 0);
        uint64_t first = b * QMC_SAMPLING_BLOCK, end = b ? s.n : QMC_SAMPLING_BLOCK;
        long double sum = 0, sum_abs = 0;
        size_t finite = 0, nan = 0;
        for (uint64_t i = first; i < end; i++) {
            double v = coarse_value(x + 2 * i);
            if (isnan(v)) {
                nan++;
                continue;
            }
            sum += v;
            sum_abs += fabs(v);
            all[finite++] = v;
        }
        long double mean = sum / finite, m2 = 0;
        for (size_t k = 0; k < finite; k++)
            m2 += (all[k] - mean) * (all[k] - mean);
        assert_int_equal(got.count, end - first);
        assert_int_equal(got.nonfinite, nan);
        assert_true(nan > 0 && finite > QMC_SAMPLING_TOP);
        assert_true(fabsl(got.f[0] + got.f[1] - sum) <= 1e-15L * sum_abs);
        assert_true(fabsl(got.absf[0] + got.absf[1] - sum_abs) <= 1e-15L * sum_abs);
        assert_true(fabsl(got.mean_f - mean) <= 1e-14L);
        assert_true(fabsl(got.m2_f - m2) <= 1e-12L * m2);
        /* The top list: the largest |f|, descending, ties kept, zeros out. */
        for (size_t k = 0; k < finite; k++)
            all[k] = fabs(all[k]);
        qsort(all, finite, sizeof *all, by_descending);
        double want[QMC_SAMPLING_TOP] = {0};
        for (size_t k = 0; k < QMC_SAMPLING_TOP && all[k] > 0.0; k++)
            want[k] = all[k];
        assert_memory_equal(got.top, want, sizeof want);
        int ties = 0;
        for (size_t k = 1; k < QMC_SAMPLING_TOP; k++)
            ties += want[k] == want[k - 1];
        assert_true(ties > 0);
    }
    qmc_seq_free(seq);
    free(x), free(all), free(ws);
    qmc_sampling_job_free(job);
}

static void test_block_order_does_not_matter(void **state)
{
    (void)state;
    qmc_integrand f = make_f(sum_squares, 4, 4.0 / 3);
    qmc_sampling_spec s;
    qmc_sampling_spec_init(&s, QMC_SAMPLER_RQMC);
    s.n = 3 * 4096 + 100; /* a partial last block */
    s.reps = 5;
    qmc_sampling_job *job = NULL;
    assert_int_equal(qmc_sampling_job_new(&s, &f, NULL, &job, NULL, 0), 0);
    uint64_t nb = qmc_sampling_blocks(job);
    assert_int_equal(nb, 20);
    qmc_sampling_sums *a = calloc(nb, sizeof *a), *b = calloc(nb, sizeof *b);
    size_t bytes = qmc_sampling_workspace_bytes(job);
    void *ws = malloc(bytes);
    for (uint64_t i = 0; i < nb; i++)
        assert_int_equal(qmc_sampling_run_block(job, i, ws, bytes, &a[i]), 0);
    for (uint64_t i = nb; i-- > 0;) /* reverse order, as another thread might */
        assert_int_equal(qmc_sampling_run_block(job, i, ws, bytes, &b[i]), 0);
    assert_memory_equal(a, b, nb * sizeof *a);
    qmc_result ra, rb;
    assert_int_equal(qmc_sampling_finish(job, a, nb, &ra, NULL), 0);
    qmc_result serial;
    assert_int_equal(qmc_sampling_run(job, NULL, NULL, &serial, NULL), 0);
    assert_int_equal(qmc_sampling_finish(job, b, nb, &rb, NULL), 0);
    assert_memory_equal(&ra, &rb, sizeof ra);
    assert_memory_equal(&ra, &serial, sizeof ra);
    /* A missing or misplaced block is refused. */
    b[3].block = 7;
    assert_int_equal(qmc_sampling_finish(job, b, nb, &rb, NULL), QMC_EINVAL);
    assert_int_equal(qmc_sampling_finish(job, a, nb - 1, &rb, NULL), QMC_EINVAL);
    assert_int_equal(qmc_sampling_run_block(job, nb, ws, bytes, &b[0]), QMC_ERANGE);
    assert_int_equal(qmc_sampling_run_block(job, 0, ws, bytes - 1, &b[0]), QMC_EINVAL);
    free(ws), free(a), free(b);
    qmc_sampling_job_free(job);
}

static void test_control_variate(void **state)
{
    (void)state;
    qmc_integrand f = make_f(sum_squares, 2, 2.0 / 3), g = make_f(sum_linear, 2, 1.0);
    qmc_sampling_spec s;
    qmc_sampling_spec_init(&s, QMC_SAMPLER_MC);
    s.n = 1 << 15;
    qmc_result plain, cvr;
    qmc_cv_report cv;
    run(&s, &f, NULL, &plain, NULL);
    run(&s, &f, &g, &cvr, &cv);
    assert_true(cv.used);
    /* Cov(x^2, x) / Var(x) = (1/4 - 1/6) / (1/12) = 1 per coordinate. */
    assert_true(fabs(cv.beta - 1.0) < 0.02);
    /* Var(x^2 - x) / Var(x^2) = (1/180) / (4/45) = 1/16 in each coordinate. */
    assert_true(fabs(cv.variance_ratio - 0.0625) < 0.005);
    assert_true(cvr.error < plain.error / 3.5);
    assert_true(cvr.ci_low <= 2.0 / 3 && 2.0 / 3 <= cvr.ci_high);
    assert_int_equal(cvr.evals, 2 * s.n);
}

static void test_flags(void **state)
{
    (void)state;
    qmc_sampling_spec s;
    qmc_result r;
    /* Infinite variance: x^-1/2 by plain MC. */
    qmc_integrand heavy = make_f(inv_sqrt, 1, 2.0);
    qmc_sampling_spec_init(&s, QMC_SAMPLER_MC);
    s.n = 1 << 16;
    run(&s, &heavy, NULL, &r, NULL);
    assert_true(r.flags & QMC_FLAG_HEAVY_TAIL);
    assert_true(r.flags & QMC_FLAG_ERROR_UNRELIABLE);
    /* ...and no false alarm on a bounded integrand. */
    qmc_integrand smooth = make_f(sum_squares, 1, 1.0 / 3);
    run(&s, &smooth, NULL, &r, NULL);
    assert_false(r.flags & QMC_FLAG_HEAVY_TAIL);
    /* Non-finite values are counted, left out, and flagged. */
    qmc_integrand nan = make_f(sometimes_nan, 2, 0.9);
    run(&s, &nan, NULL, &r, NULL);
    assert_true(r.flags & QMC_FLAG_NONFINITE);
    assert_true(r.nonfinite > s.n / 20 && r.nonfinite < s.n / 5);
    /* Nets want powers of two. */
    qmc_sampling_spec_init(&s, QMC_SAMPLER_QMC);
    s.n = 1000;
    run(&s, &smooth, NULL, &r, NULL);
    assert_true(r.flags & QMC_FLAG_NOT_POW2);
    assert_int_equal(r.error_kind, QMC_ERROR_NONE);
    assert_true(r.ci_low == r.estimate && r.ci_high == r.estimate);
    /* Plain Halton past 10 dims. */
    qmc_integrand wide = make_f(sum_squares, 12, 4.0);
    s.seq = QMC_SEQ_HALTON;
    s.n = 1024;
    run(&s, &wide, NULL, &r, NULL);
    assert_true(r.flags & QMC_FLAG_DIMS_PAST_GOOD);
    s.scramble = QMC_SCRAMBLE_OWEN;
    run(&s, &wide, NULL, &r, NULL);
    assert_false(r.flags & QMC_FLAG_DIMS_PAST_GOOD);
    /* Few randomizations. */
    qmc_sampling_spec_init(&s, QMC_SAMPLER_RQMC);
    s.reps = 4;
    run(&s, &smooth, NULL, &r, NULL);
    assert_true(r.flags & QMC_FLAG_FEW_REPS);
}

static qmc_sampling_spec rqmc_spec(uint64_t n, uint32_t reps)
{
    qmc_sampling_spec s;
    qmc_sampling_spec_init(&s, QMC_SAMPLER_RQMC);
    s.n = n;
    s.reps = reps;
    return s;
}

static void test_adaptive(void **state)
{
    (void)state;
    qmc_integrand f = make_f(sum_squares, 3, 1.0);
    qmc_sampling_spec s = rqmc_spec(256, 8);
    qmc_result r, fixed;
    uint64_t n = 0;
    char why[200];
    assert_int_equal(qmc_sampling_adaptive(&s, &f, NULL, 0, 1e-6, 1u << 26, NULL, NULL, &r,
                                           NULL, &n, why, sizeof why), 0);
    assert_true(r.ci_high - r.estimate <= 1e-6 * fabs(r.estimate));
    assert_false(r.flags & QMC_FLAG_NOT_CONVERGED);
    assert_true(n > 256 && (n & (n - 1)) == 0);
    /* Same numbers as a fixed run at the final n (blocks were reused). */
    s.n = n;
    run(&s, &f, NULL, &fixed, NULL);
    assert_true(fixed.estimate == r.estimate && fixed.error == r.error);
    /* A budget that cannot reach the tolerance. */
    s.n = 256;
    assert_int_equal(qmc_sampling_adaptive(&s, &f, NULL, 0, 1e-12, 1u << 16, NULL, NULL, &r,
                                           NULL, &n, why, sizeof why), 0);
    assert_true(r.flags & QMC_FLAG_BUDGET);
    assert_true(r.flags & QMC_FLAG_NOT_CONVERGED);
    assert_true(r.evals <= 1u << 16);
    /* Plain qmc has no error bar to adapt on. */
    s.sampler = QMC_SAMPLER_QMC;
    s.reps = 1;
    s.scramble = QMC_SCRAMBLE_NONE;
    assert_int_equal(qmc_sampling_adaptive(&s, &f, NULL, 0, 1e-3, 1u << 20, NULL, NULL, &r,
                                           NULL, &n, why, sizeof why), QMC_EINVAL);
    assert_non_null(strstr(why, "rqmc"));
}

/* 1 below x_0 = 0.3: a jump, integral 0.3. */
static void step(const void *ctx, const double *x, size_t n, uint32_t d, double *out)
{
    (void)ctx;
    for (size_t i = 0; i < n; i++)
        out[i] = x[i * d] < 0.3 ? 1.0 : 0.0;
}

static void test_split_net(void **state)
{
    (void)state;
    qmc_integrand f = make_f(step, 3, 0.3);
    qmc_sampling_spec s = rqmc_spec(4096, 8);
    s.split_net = 1;
    /* The replicates cut one point set: 8 x 4096 and 4 x 8192 points give
     * the same estimate (up to the order of the sums), and a different
     * one from independent replicates. */
    qmc_result r8, r4, indep, fixed;
    run(&s, &f, NULL, &r8, NULL);
    s.reps = 4;
    s.n = 8192;
    run(&s, &f, NULL, &r4, NULL);
    assert_true(fabs(r8.estimate - r4.estimate) <= 1e-15);
    assert_true(r8.error != r4.error);
    s.split_net = 0;
    run(&s, &f, NULL, &indep, NULL);
    assert_true(indep.estimate != r4.estimate);
    /* Adaptive rounds reuse the old net as the first half of the new
     * replicates: the answer is a fixed run's at the final n, bit for bit. */
    s.split_net = 1;
    s.reps = 8;
    s.n = 4096;
    uint64_t n = 0;
    char why[200];
    assert_int_equal(qmc_sampling_adaptive(&s, &f, NULL, 0, 1e-5, 1u << 26, NULL, NULL, &r8,
                                           NULL, &n, why, sizeof why), 0);
    assert_true(n >= 4 * 4096);
    assert_true(r8.evals == 8 * n);
    s.n = n;
    run(&s, &f, NULL, &fixed, NULL);
    assert_true(fixed.estimate == r8.estimate && fixed.error == r8.error);
    /* Only rqmc, and only 2^32 indices in all
     * (the job's block cap keeps reps x n below). */
    qmc_sampling_job *job = NULL;
    s.n = 1u << 30;
    assert_int_equal(qmc_sampling_job_new(&s, &f, NULL, &job, why, sizeof why), QMC_ETOOBIG);
    qmc_sampling_spec_init(&s, QMC_SAMPLER_MC);
    s.split_net = 1;
    assert_int_equal(qmc_sampling_job_new(&s, &f, NULL, &job, why, sizeof why), QMC_EINVAL);
    assert_non_null(strstr(why, "split net"));
    s.split_net = 2;
    assert_int_equal(qmc_sampling_job_new(&s, &f, NULL, &job, why, sizeof why), QMC_EINVAL);
    assert_null(job);
}

/* |q - want| <= tol |want| */
static void assert_quantile(double level, double df, double want, double tol)
{
    double q = qmc_student_t_quantile(level, df);
    if (!(fabs(q - want) <= tol * fabs(want)))
        fail_msg("t quantile(%g, df %g) = %.17g, want %.17g", level, df, q, want);
}

static void test_student_t(void **state)
{
    (void)state;
    /* References: mpmath 1.2 at 40 digits, findroot on 1 - betainc(df/2,
     * 1/2, 0, df/(df+t^2)) at the double nearest each level (scipy 1.10's
     * t.ppf is off by up to 1e-9 here, and so, before, were we: 3e-8). */
    assert_quantile(0.95, 1, 12.706204736174693, 1e-14);
    assert_quantile(0.95, 2, 4.3026527297494618, 1e-14);
    assert_quantile(0.95, 7, 2.3646242515927847, 1e-14);
    assert_quantile(0.95, 15, 2.1314495455597752, 1e-14);
    assert_quantile(0.95, 30, 2.0422724563012379, 1e-14);
    assert_quantile(0.99, 15, 2.9467128834752385, 1e-14);
    assert_quantile(0.5, 3, 0.76489232840434528, 1e-14);
    assert_quantile(0.1, 12, 0.12834738079561133, 1e-14);
    assert_quantile(0.999999, 7, 15.767009437416195, 1e-14); /* solved in the tail */
    assert_quantile(0.95, 0.5, 164.55767348048824, 1e-11);
    assert_quantile(0.95, 1e5, 1.9599877075346093, 1e-12);
    /* Past 1e7 degrees of freedom: the normal quantile, 1.959963984540054. */
    assert_quantile(0.95, 1e9, 1.959963984540054, 1e-7);
    assert_quantile(0.95, 1e15, 1.959963984540054, 1e-15);
    assert_true(isnan(qmc_student_t_quantile(1.5, 3)));
    assert_true(isnan(qmc_student_t_quantile(0.95, 0)));
}

static void test_errors(void **state)
{
    (void)state;
    qmc_integrand f = make_f(sum_squares, 2, 2.0 / 3), g3 = make_f(sum_linear, 3, 1.5);
    qmc_sampling_spec s;
    qmc_sampling_job *job = (qmc_sampling_job *)&f;
    char why[200];
    qmc_sampling_spec_init(&s, QMC_SAMPLER_RQMC);
    s.reps = 1;
    assert_int_equal(qmc_sampling_job_new(&s, &f, NULL, &job, why, sizeof why), QMC_EINVAL);
    assert_null(job);
    assert_non_null(strstr(why, "reps >= 2"));
    qmc_sampling_spec_init(&s, QMC_SAMPLER_QMC);
    s.reps = 3;
    assert_int_equal(qmc_sampling_job_new(&s, &f, NULL, &job, why, sizeof why), QMC_EINVAL);
    qmc_sampling_spec_init(&s, QMC_SAMPLER_STRATIFIED);
    s.n = 10;
    assert_int_equal(qmc_sampling_job_new(&s, &f, NULL, &job, why, sizeof why), QMC_ECOUNT);
    assert_non_null(strstr(why, "9 and 16"));
    qmc_sampling_spec_init(&s, QMC_SAMPLER_MC);
    assert_int_equal(qmc_sampling_job_new(&s, &f, &g3, &job, why, sizeof why), QMC_EDIMS);
    s.n = 0;
    assert_int_equal(qmc_sampling_job_new(&s, &f, NULL, &job, why, sizeof why), QMC_ECOUNT);
    qmc_sampling_spec_init(&s, QMC_SAMPLER_RQMC);
    s.scramble = QMC_SCRAMBLE_NONE;
    assert_int_equal(qmc_sampling_job_new(&s, &f, NULL, &job, why, sizeof why), QMC_ESCRAMBLE);
    qmc_sampling_job_free(NULL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_estimates_inside_intervals),
        cmocka_unit_test(test_block_sums_match_reference),
        cmocka_unit_test(test_block_order_does_not_matter),
        cmocka_unit_test(test_control_variate),
        cmocka_unit_test(test_flags),
        cmocka_unit_test(test_adaptive),
        cmocka_unit_test(test_split_net),
        cmocka_unit_test(test_student_t),
        cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests_name("sampling", tests, NULL, NULL);
}
