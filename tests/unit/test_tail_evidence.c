/*
 * test_tail_evidence.c - the evidence that clears Hill's heavy_tail flag
 * on a bounded integrand (core/sampling_finish.c): the relative standard
 * error of the pooled variance from the blocks' own variances
 * (qmc__variance_rse), and the "bound seen" test on the largest values.
 *
 * Oracles: closed forms written here - hand-made blocks whose variances
 * are chosen (the statistic's value follows by arithmetic), and iid
 * samples of laws with known kurtosis: Bernoulli(p), kurt - 1 =
 * (1 - 2p)^2 / (p (1 - p)); uniform, kurt = 9/5; the pooled variance of N
 * points then has relative standard error sqrt((kurt - 1) / N).  Pareto
 * quantiles for the top values of x^-1/2, and a geometric run of values
 * (a bounded peak's profile) for the bound test.  Through the sampling
 * engine: a narrow Gaussian peak that the sample hits ~50 times is no
 * longer flagged, the same peak declared singular still is (Hill alone),
 * and x^-1/2 declared smooth keeps Hill's flag on every seed though its
 * blocks' variances agree.  The pooled statistic for stratified samples
 * (qmc__pooled_variance_rse) against the sample's exact fourth moment,
 * computed here: never below it, near it for a spike, exact under
 * scaling by powers of two; and a stratified narrow peak cleared in 2D
 * (where its slab-shaped blocks would have kept the flag) but not in 5D.
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <string.h>

#include "sampling_impl.h"
#include "qmc/sampling.h"
#include "qmc/testfn.h"

/* splitmix64: the test's own generator, not the library's */
static uint64_t mix(uint64_t *s)
{
    uint64_t z = (*s += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

static double u01(uint64_t *s)
{
    return (double)(mix(s) >> 11) * 0x1p-53;
}

static void set_block(qmc_sampling_sums *b, uint64_t count, double m2)
{
    memset(b, 0, sizeof *b);
    b->count = count;
    b->m2_f = m2;
}

static void test_rse_closed_form(void **state)
{
    (void)state;
    /* 16 blocks of m points, half with variance 1, half 3: v = 2,
     * sum m (v_b - v)^2 = 16 m, so sqrt(16 m / 16 / (16 m)) / 2 = 1/8. */
    enum { B = 16, M = 4096 };
    qmc_sampling_sums s[B];
    for (int i = 0; i < B; i++)
        set_block(&s[i], M, (i % 2 ? 3.0 : 1.0) * M);
    assert_true(fabs(qmc__variance_rse(s, B) - 0.125) <= 1e-15);
    /* blocks that agree: 0 */
    for (int i = 0; i < B; i++)
        set_block(&s[i], M, 2.0 * M);
    assert_true(qmc__variance_rse(s, B) == 0.0);
    /* non-finite points are not points: a block of 4096 with 4095
     * non-finite holds 1, which is no variance, and is skipped; 15 blocks
     * are too few */
    s[3].nonfinite = M - 1;
    assert_true(isnan(qmc__variance_rse(s, B)));
    /* zero variance everywhere: nothing to say */
    for (int i = 0; i < B; i++)
        set_block(&s[i], M, 0.0);
    assert_true(isnan(qmc__variance_rse(s, B)));
}

/* B blocks of M iid values from draw, m2 by two passes in the test. */
static double rse_of(double (*draw)(uint64_t *), uint64_t seed, qmc_sampling_sums *s, int B,
                     int M, double *buf)
{
    for (int b = 0; b < B; b++) {
        double mean = 0.0, m2 = 0.0;
        for (int i = 0; i < M; i++)
            mean += buf[i] = draw(&seed);
        mean /= M;
        for (int i = 0; i < M; i++)
            m2 += (buf[i] - mean) * (buf[i] - mean);
        set_block(&s[b], (uint64_t)M, m2);
    }
    return qmc__variance_rse(s, (uint64_t)B);
}

static double bernoulli_001(uint64_t *s)
{
    return u01(s) < 0.01 ? 1.0 : 0.0;
}

static double uniform(uint64_t *s)
{
    return u01(s);
}

static void test_rse_known_kurtosis(void **state)
{
    (void)state;
    enum { B = 256, M = 4096 };
    static qmc_sampling_sums s[B];
    static double buf[M];
    const double n = (double)B * M, p = 0.01;
    const double bern = sqrt((1 - 2 * p) * (1 - 2 * p) / (p * (1 - p)) / n);
    const double unif = sqrt((9.0 / 5.0 - 1.0) / n);
    /* The estimate's own spread over 256 blocks is about 10%: 25% holds on
     * every seed tried; a statistic off by a factor (a missing m_b, a
     * variance in place of a standard error) is not near. */
    for (uint64_t seed = 1; seed <= 3; seed++) {
        double rb = rse_of(bernoulli_001, seed, s, B, M, buf);
        double ru = rse_of(uniform, seed + 100, s, B, M, buf);
        if (!(fabs(rb / bern - 1.0) < 0.25) || !(fabs(ru / unif - 1.0) < 0.25))
            fail_msg("seed %llu: Bernoulli %.4g vs %.4g, uniform %.4g vs %.4g",
                     (unsigned long long)seed, rb, bern, ru, unif);
    }
}

/* Hill's bounded test flags both top arrays below; which one the block
 * evidence may clear depends on their shape. */
static uint32_t evidence(const double *top, double rse, int singular)
{
    qmc_result r;
    qmc_result_init(&r);
    r.estimate = 1.0;
    r.error = 0.01;
    qmc__sampling_evidence(&r, top, 1u << 16, 1, singular, rse);
    return r.flags;
}

static void test_bound_seen(void **state)
{
    (void)state;
    double pareto[QMC_SAMPLING_TOP], peak[QMC_SAMPLING_TOP];
    /* the expected order statistics of x^-1/2 on N points, (N / i)^(1/2),
     * and a Gaussian peak's profile seen from ~15 hits: values that fall
     * by e every 4 ranks */
    for (int i = 0; i < QMC_SAMPLING_TOP; i++) {
        pareto[i] = sqrt(65536.0 / (i + 1));
        peak[i] = exp(-i / 4.0);
    }
    const uint32_t heavy = QMC_FLAG_HEAVY_TAIL | QMC_FLAG_ERROR_UNRELIABLE;
    /* a power law keeps its flag whatever the blocks say */
    assert_int_equal(evidence(pareto, 0.05, 0) & heavy, heavy);
    /* a peak's values with a well-estimated variance: cleared */
    assert_int_equal(evidence(peak, 0.1, 0) & heavy, 0);
    /* ... not with a variance on too few values, nor without block
     * evidence, nor when a singularity is declared */
    assert_int_equal(evidence(peak, 0.3, 0) & heavy, heavy);
    assert_int_equal(evidence(peak, NAN, 0) & heavy, heavy);
    assert_int_equal(evidence(peak, 0.1, 1) & heavy, heavy);
}

static qmc_result sample(qmc_integrand f, uint64_t n, uint64_t seed)
{
    qmc_sampling_spec s;
    qmc_sampling_spec_init(&s, QMC_SAMPLER_MC);
    s.n = n;
    s.seed = seed;
    qmc_sampling_job *job = NULL;
    qmc_result r;
    assert_int_equal(qmc_sampling_job_new(&s, &f, NULL, &job, NULL, 0), 0);
    assert_int_equal(qmc_sampling_run(job, NULL, NULL, &r, NULL), 0);
    qmc_sampling_job_free(job);
    return r;
}

static void test_peak_cleared_singular_kept(void **state)
{
    (void)state;
    /* genz-gaussian, a = 60 in 2D: pi / a^2 of the square carries the
     * variance, ~57 of 2^16 points.  Hill alone flags it (the declared-
     * singular copy shows it); the block evidence clears it. */
    const double a[] = {60, 60}, u[] = {0.21, 0.68};
    qmc_testfn *fn = NULL;
    assert_int_equal(qmc_testfn_new("genz-gaussian", 2, a, 2, u, 2, &fn, NULL, 0), 0);
    qmc_integrand f = *qmc_testfn_integrand(fn), sing = f;
    sing.smoothness = QMC_SMOOTH_SINGULAR;
    for (uint64_t seed = 1; seed <= 3; seed++) {
        qmc_result r = sample(f, 1u << 16, seed);
        assert_false(r.flags & QMC_FLAG_HEAVY_TAIL);
        assert_true(fabs(r.estimate - f.exact) <= 3 * r.error);
        r = sample(sing, 1u << 16, seed);
        assert_true(r.flags & QMC_FLAG_HEAVY_TAIL);
    }
    qmc_testfn_free(fn);
}

static void inv_sqrt(const void *ctx, const double *x, size_t n, uint32_t dims, double *out)
{
    (void)ctx, (void)dims;
    for (size_t i = 0; i < n; i++)
        out[i] = 1.0 / sqrt(x[i]);
}

/* One job of `sampler` run block by block: its result, its pooled top
 * values and its block statistic (qmc__variance_rse). */
static qmc_result run_job(const qmc_integrand *f, qmc_sampler sampler, uint64_t n,
                          uint64_t seed, double *top, double *block_rse)
{
    qmc_sampling_spec s;
    qmc_sampling_spec_init(&s, sampler);
    s.n = n;
    s.seed = seed;
    qmc_sampling_job *job = NULL;
    assert_int_equal(qmc_sampling_job_new(&s, f, NULL, &job, NULL, 0), 0);
    const uint64_t nb = qmc_sampling_blocks(job);
    qmc_sampling_sums *sums = test_calloc(nb, sizeof *sums);
    size_t bytes = qmc_sampling_workspace_bytes(job);
    void *ws = test_malloc(bytes);
    for (int i = 0; i < QMC_SAMPLING_TOP; i++)
        top[i] = 0.0;
    for (uint64_t b = 0; b < nb; b++) {
        assert_int_equal(qmc_sampling_run_block(job, b, ws, bytes, &sums[b]), 0);
        qmc__top_merge(top, sums[b].top);
    }
    qmc_result r;
    assert_int_equal(qmc_sampling_finish(job, sums, nb, &r, NULL), 0);
    *block_rse = qmc__variance_rse(sums, nb);
    test_free(ws);
    test_free(sums);
    qmc_sampling_job_free(job);
    return r;
}

/* Hill's verdict on a run (rse NAN: no block evidence) and the verdict
 * with the run's own block evidence, from the job's block sums. */
static void verdicts(const qmc_integrand *f, uint64_t n, uint64_t seed, uint32_t *hill,
                     uint32_t *both)
{
    double top[QMC_SAMPLING_TOP], rse;
    qmc_result r = run_job(f, QMC_SAMPLER_MC, n, seed, top, &rse);
    *both = r.flags & QMC_FLAG_HEAVY_TAIL;
    qmc_result_init(&r);
    r.estimate = 1.0;
    r.error = 0.01;
    qmc__sampling_evidence(&r, top, n, 1, 0, NAN);
    *hill = r.flags & QMC_FLAG_HEAVY_TAIL;
}

static void test_undeclared_infinite_variance_kept(void **state)
{
    (void)state;
    /* x^-1/2 that says it is smooth: at 2^20 points its blocks' variances
     * agree within 0.1-0.2 on every seed tried (measured), which alone
     * would clear it; its largest values follow a power law, so the flag
     * stays wherever Hill's test raised it (Hill's own 95% test passes
     * about one run in 20 of x^-1/2, seed 3 at 2^20 among them: FLAGS.md). */
    qmc_integrand f = {.eval = inv_sqrt, .dims = 1, .smoothness = QMC_SMOOTH_ANALYTIC,
                       .has_exact = 1, .exact = 2.0, .name = "inv-sqrt-undeclared"};
    int raised = 0;
    for (uint64_t seed = 1; seed <= 6; seed++)
        for (uint64_t n = 1u << 16; n <= 1u << 20; n <<= 4) {
            uint32_t hill, both;
            verdicts(&f, n, seed, &hill, &both);
            if (hill != both)
                fail_msg("seed %llu, n %llu: Hill 0x%x, with the block evidence 0x%x",
                         (unsigned long long)seed, (unsigned long long)n, hill, both);
            raised += hill != 0;
        }
    assert_true(raised >= 10); /* the comparison was not empty */
}

/* The pooled statistic's inputs from a sample: its top |f| (descending,
 * 0-padded), mean and central sum of squares; returns the plug-in value
 * sqrt((kurt - 1) / n) from the sample's exact fourth moment. */
static double pooled_inputs(const double *f, int n, double *top, double *mean, double *m2)
{
    for (int i = 0; i < QMC_SAMPLING_TOP; i++)
        top[i] = 0.0;
    double s = 0.0;
    for (int i = 0; i < n; i++) {
        s += f[i];
        double v = fabs(f[i]);
        for (int j = 0; j < QMC_SAMPLING_TOP; j++)
            if (v > top[j]) { /* insert, shifting the rest down */
                memmove(&top[j + 1], &top[j], (QMC_SAMPLING_TOP - 1 - j) * sizeof *top);
                top[j] = v;
                break;
            }
    }
    *mean = s / n;
    double s2 = 0.0, s4 = 0.0;
    for (int i = 0; i < n; i++) {
        double c = f[i] - *mean;
        s2 += c * c;
        s4 += c * c * c * c;
    }
    *m2 = s2;
    return sqrt(((double)n * s4 / (s2 * s2) - 1.0) / n);
}

static void test_pooled_rse_bounds_the_sample(void **state)
{
    (void)state;
    enum { N = 1 << 14 };
    static double f[N];
    double top[QMC_SAMPLING_TOP], mean, m2;
    for (uint64_t seed = 1; seed <= 4; seed++) {
        uint64_t st = seed;
        for (int law = 0; law < 5; law++) {
            for (int i = 0; i < N; i++) {
                double x = u01(&st);
                f[i] = law == 0   ? 1.0 + x                             /* smooth, offset */
                       : law == 1 ? (x < 0.002 ? exp(-8 * u01(&st)) : 0) /* a spike, ~33 hits */
                       : law == 2 ? 2 * x - 1                           /* signed */
                       : law == 3 ? exp(-400 * (x - 0.3) * (x - 0.3)) /* a peak's profile */
                                  : (x < 0.002 ? 5.0 : 0.0) - 3.0; /* spikes above a negative mean */
            }
            const double exact = pooled_inputs(f, N, top, &mean, &m2);
            const double bound = qmc__pooled_variance_rse(top, N, mean, m2);
            /* an upper bound on the sample's own value, always */
            if (!(bound >= exact * (1 - 1e-12)))
                fail_msg("seed %llu law %d: bound %.6g below the sample's %.6g",
                         (unsigned long long)seed, law, bound, exact);
            /* where every nonzero value is kept, the bound is near: the
             * spike's mean is 1/1000 of its values */
            if (law == 1 && !(bound <= 1.01 * exact))
                fail_msg("seed %llu: spike bound %.6g, sample %.6g", (unsigned long long)seed,
                         bound, exact);
            /* exact under scaling by a power of two */
            double big[QMC_SAMPLING_TOP];
            for (int i = 0; i < QMC_SAMPLING_TOP; i++)
                big[i] = ldexp(top[i], 400);
            assert_true(qmc__pooled_variance_rse(big, N, ldexp(mean, 400), ldexp(m2, 800)) ==
                        bound);
        }
    }
    /* no variance, nothing to judge */
    for (int i = 0; i < QMC_SAMPLING_TOP; i++)
        top[i] = 1.0;
    assert_true(isnan(qmc__pooled_variance_rse(top, N, 1.0, 0.0)));
    assert_true(isnan(qmc__pooled_variance_rse(top, 1, 1.0, 1.0)));
}

/* A stratified sample's blocks are slabs of the cube (strata in order),
 * so a narrow peak sits in one or two: their variances disagree however
 * well the sample resolves it, and the pooled statistic judges instead.
 * The 2D Gaussian of width 1/400 on 1024^2 strata: its error is 1-20% of a
 * bar that is the MC formula's (measured), and it is no longer flagged.
 * On 256^2 strata its top values still bunch toward the peak (the bound
 * is seen), but the pooled statistic is 0.6-0.9 (measured): too few values
 * carry the variance, and the flag stays.  The 5D one of width 1/40 on
 * 16^5 strata, hit about once, is flagged too. */
static qmc_result stratified(const char *fam, uint32_t d, const double *a, const double *u,
                             uint64_t n, uint64_t seed, double *block_rse, double *exact)
{
    qmc_testfn *fn = NULL;
    assert_int_equal(qmc_testfn_new(fam, d, a, d, u, d, &fn, NULL, 0), 0);
    double top[QMC_SAMPLING_TOP];
    qmc_result r =
        run_job(qmc_testfn_integrand(fn), QMC_SAMPLER_STRATIFIED, n, seed, top, block_rse);
    *exact = qmc_testfn_integrand(fn)->exact;
    qmc_testfn_free(fn);
    return r;
}

static void test_stratified_peak_by_pooled_evidence(void **state)
{
    (void)state;
    const double a2[] = {400, 400}, u2[] = {0.123, 0.777};
    const double a5[] = {40, 40, 40, 40, 40}, u5[] = {0.33, 0.58, 0.27, 0.81, 0.46};
    for (uint64_t seed = 1; seed <= 2; seed++) {
        double rse, exact;
        qmc_result r = stratified("genz-gaussian", 2, a2, u2, 1024 * 1024, seed, &rse, &exact);
        assert_false(r.flags & QMC_FLAG_ERROR_UNRELIABLE);
        assert_true(fabs(r.estimate - exact) <= r.error);
        assert_true(!(rse <= QMC__RSE_BOUNDED)); /* the slabs would have kept the flag */
        r = stratified("genz-gaussian", 2, a2, u2, 256 * 256, seed, &rse, &exact);
        assert_true(r.flags & QMC_FLAG_HEAVY_TAIL);
        r = stratified("genz-gaussian", 5, a5, u5, 1u << 20, seed, &rse, &exact);
        assert_true(r.flags & QMC_FLAG_HEAVY_TAIL);
        assert_true(r.flags & QMC_FLAG_ERROR_UNRELIABLE);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rse_closed_form),
        cmocka_unit_test(test_rse_known_kurtosis),
        cmocka_unit_test(test_bound_seen),
        cmocka_unit_test(test_peak_cleared_singular_kept),
        cmocka_unit_test(test_undeclared_infinite_variance_kept),
        cmocka_unit_test(test_pooled_rse_bounds_the_sample),
        cmocka_unit_test(test_stratified_peak_by_pooled_evidence),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
