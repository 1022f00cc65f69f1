/*
 * test_job.c - jobs as data: the integrands they build, their references,
 * and every refused combination; and the interrupt hook through
 * qmc_job_run for every method: silent, it changes no bit; firing on its
 * first call, the job stops before evaluating anything (QMC_ECANCELED, no
 * estimate); firing later, it stops partway; with a caller's runner it is
 * polled before each batch of blocks.
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "hook.h"
#include "qmc/job.h"

static const char lambert_sphere[] =
    "point 0 0 0\nnormal 0 0 1\nbrdf lambert 0.5\n"
    "light sphere center 0 0 4 radius 1 radiance 2\n";

static void test_testfn_job(void **state)
{
    (void)state;
    qmc_job_spec s;
    qmc_job_spec_init(&s);
    strcpy(s.integrand, "genz-gaussian");
    s.dims = 3;
    s.difficulty = QMC_DIFFICULTY_TESTPACK;
    s.integrate.sampling.seed = 9;
    qmc_job *job = NULL;
    char why[200];
    assert_int_equal(qmc_job_new(&s, &job, why, sizeof why), 0);
    const qmc_integrand *f = qmc_job_integrand(job);
    assert_int_equal(f->dims, 3);
    assert_null(qmc_job_control(job));
    assert_false(qmc_job_is_scene(job));
    double ref;
    int exact;
    assert_int_equal(qmc_job_reference(job, &ref, &exact), 0);
    assert_true(exact && ref == f->exact);
    /* The same spec gives the same integrand (the draw is seeded). */
    qmc_job *again = NULL;
    assert_int_equal(qmc_job_new(&s, &again, why, sizeof why), 0);
    assert_true(qmc_job_integrand(again)->exact == f->exact);
    /* And a job runs through qmc_integrate. */
    qmc_integrate_report rep;
    s.integrate.method = QMC_METHOD_RQMC;
    qmc_sampling_spec_init(&s.integrate.sampling, QMC_SAMPLER_RQMC);
    assert_int_equal(qmc_job_run(job, &s.integrate, NULL, NULL, &rep, why, sizeof why), 0);
    assert_true(fabs(rep.res.estimate - f->exact) < 6 * rep.res.error + 1e-15);
    qmc_job_free(job);
    qmc_job_free(again);
    qmc_job_free(NULL);
}

static void test_scene_job(void **state)
{
    (void)state;
    qmc_job_spec s;
    qmc_job_spec_init(&s);
    s.scene_text = lambert_sphere;
    s.scene_len = sizeof lambert_sphere - 1;
    s.strategy = QMC_SCENE_LIGHT;
    qmc_job *job = NULL;
    char why[200];
    assert_int_equal(qmc_job_new(&s, &job, why, sizeof why), 0);
    assert_true(qmc_job_is_scene(job));
    assert_int_equal(qmc_job_integrand(job)->dims, 2);
    double ref;
    int exact;
    assert_int_equal(qmc_job_reference(job, &ref, &exact), 0);
    /* albedo * L * sin^2(alpha) * cos(theta) = 0.5 * 2 * (1/16) * 1 */
    assert_true(exact && fabs(ref - 0.0625) < 1e-15);
    qmc_job_free(job);
}

static void test_refusals(void **state)
{
    (void)state;
    qmc_job_spec s;
    qmc_job *job = NULL;
    char why[200];
    qmc_job_spec_init(&s);
    assert_int_equal(qmc_job_new(&s, &job, why, sizeof why), QMC_EINVAL);
    assert_non_null(strstr(why, "integrand or give a scene"));
    strcpy(s.integrand, "exp");
    s.dims = 1;
    s.scene_text = lambert_sphere;
    s.scene_len = sizeof lambert_sphere - 1;
    assert_int_equal(qmc_job_new(&s, &job, why, sizeof why), QMC_EINVAL);
    s.scene_text = NULL;
    s.difficulty = QMC_DIFFICULTY_FIXED;
    assert_int_equal(qmc_job_new(&s, &job, why, sizeof why), QMC_EINVAL);
    assert_non_null(strstr(why, "genz"));
    s.difficulty = -1;
    strcpy(s.control, "genz-oscillatory"); /* dims 1 exp with an oscillatory control */
    assert_int_equal(qmc_job_new(&s, &job, why, sizeof why), 0);
    qmc_job_free(job);
    memset(s.control, 'x', sizeof s.control); /* unterminated name */
    assert_int_equal(qmc_job_new(&s, &job, why, sizeof why), QMC_EINVAL);
    assert_null(job);
    qmc_job_spec_init(&s);
    s.scene_text = "point 0 0 0\nnormal 0 0 0\n";
    s.scene_len = (uint32_t)strlen(s.scene_text);
    assert_true(qmc_job_new(&s, &job, why, sizeof why) < 0);
    assert_non_null(strstr(why, "line 2"));
}

/* A job on a test function, sized so that every method polls the hook
 * more than once: 4 blocks (rqmc: 8 x 1), 20^3 + 10^3 tensor points,
 * cubature (and auto's choice, cubature) and Gauss-Kronrod (on cos 5000 x)
 * to tolerances they cannot meet. */
static qmc_job *interrupt_job(qmc_method m, qmc_job_spec *s)
{
    static const double fast[1] = {5000.0};
    qmc_job_spec_init(s);
    strcpy(s->integrand, "genz-oscillatory");
    s->dims = 3;
    if (m == QMC_METHOD_GAUSS_KRONROD) { /* cos(5000 x): all 200 intervals */
        strcpy(s->integrand, "cos");
        s->dims = 1;
        s->a = fast;
        s->n_a = 1;
    }
    qmc_integrate_spec *g = &s->integrate;
    g->method = m;
    g->n_given = 1;
    g->n_axis = m == QMC_METHOD_SIMPSON || m == QMC_METHOD_TRAPEZOID ? 21 : 20;
    g->sampling.n = m == QMC_METHOD_STRATIFIED ? 17576 : 16384; /* 26^3 */
    g->sampling.reps = m == QMC_METHOD_RQMC ? 8 : 1;
    g->sampling.scramble = m == QMC_METHOD_RQMC ? QMC_SCRAMBLE_OWEN : QMC_SCRAMBLE_NONE;
    g->max_evals = 300000;
    if (m == QMC_METHOD_CUBATURE || m == QMC_METHOD_GAUSS_KRONROD || m == QMC_METHOD_AUTO)
        g->tol_rel = 1e-15;
    qmc_job *job = NULL;
    char why[200];
    if (qmc_job_new(s, &job, why, sizeof why) != 0)
        fail_msg("%s: %s", qmc_method_name(m), why);
    return job;
}

static void test_interrupt_every_method(void **state)
{
    (void)state;
    for (int m = QMC_METHOD_AUTO; m <= QMC_METHOD_CUBATURE; m++) {
        const char *name = qmc_method_name((qmc_method)m);
        qmc_job_spec s;
        qmc_job *job = interrupt_job((qmc_method)m, &s);
        qmc_integrate_report plain, rep;
        char why[200];
        if (qmc_job_run(job, &s.integrate, NULL, NULL, &plain, why, sizeof why) != 0)
            fail_msg("%s: %s", name, why);
        test_hook h;
        s.integrate.interrupt = test_hook_init(&h, 0, NULL);
        assert_int_equal(qmc_job_run(job, &s.integrate, NULL, NULL, &rep, why, sizeof why), 0);
        if (!test_same_result(&plain.res, &rep.res))
            fail_msg("%s: a silent hook changed the result", name);
        assert_string_equal(plain.detail, rep.detail);
        const uint64_t calls = h.calls;
        if (calls < 2)
            fail_msg("%s: the hook was polled %llu times", name, (unsigned long long)calls);
        /* First call: before any evaluation.  Then halfway. */
        const uint64_t ks[] = {1, (calls + 1) / 2};
        for (int i = 0; i < 2; i++) {
            s.integrate.interrupt = test_hook_init(&h, ks[i], NULL);
            int rc = qmc_job_run(job, &s.integrate, NULL, NULL, &rep, why, sizeof why);
            if (rc != QMC_ECANCELED)
                fail_msg("%s, hook firing on call %llu: rc %d", name,
                         (unsigned long long)ks[i], rc);
            assert_int_equal(h.calls, ks[i]);
            assert_true(rep.res.estimate == 0.0 && rep.res.error == 0.0);
            assert_true(rep.res.evals < plain.res.evals);
            if (ks[i] == 1 && rep.res.evals != 0)
                fail_msg("%s: %llu evaluations before the first poll", name,
                         (unsigned long long)rep.res.evals);
        }
        qmc_job_free(job);
    }
}

/* A caller's runner: serial, counting its batches. */
typedef struct batches {
    uint64_t calls;
} batches;

static int counting_runner(void *ctx, const qmc_sampling_job *job, uint64_t first,
                           uint64_t count, qmc_sampling_sums *out)
{
    ((batches *)ctx)->calls++;
    size_t bytes = qmc_sampling_workspace_bytes(job);
    void *ws = malloc(bytes);
    if (!ws)
        return QMC_ENOMEM;
    int err = 0;
    for (uint64_t i = 0; i < count && !err; i++)
        err = qmc_sampling_run_block(job, first + i, ws, bytes, &out[i]);
    free(ws);
    return err;
}

static void test_interrupt_with_runner(void **state)
{
    (void)state;
    qmc_job_spec s;
    qmc_job *job = interrupt_job(QMC_METHOD_RQMC, &s);
    s.integrate.tol_rel = 1e-9; /* adaptive: one batch per replicate and round */
    s.integrate.sampling.n = 4096;
    qmc_integrate_report plain, rep;
    char why[200];
    batches b = {0};
    assert_int_equal(qmc_job_run(job, &s.integrate, counting_runner, &b, &plain, why,
                                 sizeof why), 0);
    const uint64_t batch_calls = b.calls;
    assert_true(batch_calls >= 16);
    test_hook h;
    s.integrate.interrupt = test_hook_init(&h, 0, NULL);
    b.calls = 0;
    assert_int_equal(qmc_job_run(job, &s.integrate, counting_runner, &b, &rep, why,
                                 sizeof why), 0);
    assert_true(test_same_result(&plain.res, &rep.res));
    assert_int_equal(h.calls, batch_calls); /* once before each batch */
    assert_int_equal(b.calls, batch_calls);
    /* Firing on call 10: the runner got 9 batches, and the job no estimate. */
    s.integrate.interrupt = test_hook_init(&h, 10, NULL);
    b.calls = 0;
    assert_int_equal(qmc_job_run(job, &s.integrate, counting_runner, &b, &rep, why,
                                 sizeof why), QMC_ECANCELED);
    assert_int_equal(b.calls, 9);
    assert_true(rep.res.estimate == 0.0 && rep.res.error == 0.0);
    assert_true(rep.res.evals > 0 && rep.res.evals < plain.res.evals);
    qmc_job_free(job);

    /* A scene is just another integrand: cubature on it stops too. */
    qmc_job_spec_init(&s);
    s.scene_text = lambert_sphere;
    s.scene_len = sizeof lambert_sphere - 1;
    s.integrate.method = QMC_METHOD_CUBATURE;
    s.integrate.tol_rel = 1e-15;
    s.integrate.max_evals = 100000;
    assert_int_equal(qmc_job_new(&s, &job, why, sizeof why), 0);
    s.integrate.interrupt = test_hook_init(&h, 0, NULL);
    assert_int_equal(qmc_job_run(job, &s.integrate, NULL, NULL, &plain, why, sizeof why), 0);
    assert_true(h.calls >= 3);
    s.integrate.interrupt = test_hook_init(&h, 3, NULL);
    assert_int_equal(qmc_job_run(job, &s.integrate, NULL, NULL, &rep, why, sizeof why),
                     QMC_ECANCELED);
    assert_true(rep.res.evals < plain.res.evals);
    qmc_job_free(job);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_testfn_job),
        cmocka_unit_test(test_scene_job),
        cmocka_unit_test(test_refusals),
        cmocka_unit_test(test_interrupt_every_method),
        cmocka_unit_test(test_interrupt_with_runner),
    };
    return cmocka_run_group_tests_name("job", tests, NULL, NULL);
}
