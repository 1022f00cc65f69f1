/*
 * test_integrate_memory.c - qmc_integrate_memory_bytes is an upper bound
 * on what qmc_integrate allocates (qmcd reserves it against
 * max-jobs-memory-total before a job runs).  The oracle is the allocator
 * itself: the Makefile links this test with -Wl,--wrap for malloc, calloc,
 * realloc, aligned_alloc (core/seq.c) and free, so every allocation libqmc makes passes through the
 * wrappers below, which keep the bytes live and their peak.  Each case
 * runs one call and checks peak - before <= bound + the part the bound
 * leaves out by design (the serial runner's block workspace and the
 * sequence instances: a fixed allowance at these small dimensions), and
 * that the bound is not vacuous (it is within a small factor of the peak
 * where the call fills what it may: 4 for the fixed methods, 2 for auto
 * where it can only run RQMC, whose rounds the bound counts one by one).
 */
#define _GNU_SOURCE
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <malloc.h>
#include <stdio.h>
#include <string.h>

#include "qmc/integrate.h"
#include "qmc/session.h"
#include "qmc/testfn.h"

void *__real_malloc(size_t n);
void *__real_calloc(size_t n, size_t size);
void *__real_realloc(void *p, size_t n);
void __real_free(void *p);
void *__real_aligned_alloc(size_t align, size_t n);
void *__wrap_aligned_alloc(size_t align, size_t n);
void *__wrap_malloc(size_t n);
void *__wrap_calloc(size_t n, size_t size);
void *__wrap_realloc(void *p, size_t n);
void __wrap_free(void *p);

static size_t live_bytes, peak_bytes;

static void note(void *p)
{
    if (!p)
        return;
    live_bytes += malloc_usable_size(p);
    if (live_bytes > peak_bytes)
        peak_bytes = live_bytes;
}

void *__wrap_malloc(size_t n)
{
    void *p = __real_malloc(n);
    note(p);
    return p;
}

void *__wrap_calloc(size_t n, size_t size)
{
    void *p = __real_calloc(n, size);
    note(p);
    return p;
}

void *__wrap_realloc(void *p, size_t n)
{
    size_t old = p ? malloc_usable_size(p) : 0;
    void *q = __real_realloc(p, n);
    if (q || n == 0)
        live_bytes -= old;
    note(q);
    return q;
}

void *__wrap_aligned_alloc(size_t align, size_t n)
{
    void *p = __real_aligned_alloc(align, n);
    note(p);
    return p;
}

void __wrap_free(void *p)
{
    if (p)
        live_bytes -= malloc_usable_size(p);
    __real_free(p);
}

/* What the bound leaves out at these dimensions (<= 8): the serial
 * runner's block workspace (256 points x (dims + 2) doubles), a few
 * sequence instances and messages. */
#define UNBOUNDED_ALLOWANCE (1u << 20)

typedef struct mem_case {
    const char *integrand;
    uint32_t dims;
    const char *method;
    double tol_rel;
    uint64_t max_evals, max_memory;
    uint64_t n;
    uint32_t reps;
    double fill_ratio;           /* > 0: bound <= fill_ratio x peak (not vacuous) */
    double fill_ratio_for;       /* > 0: the same for the integrand's own bound */
} mem_case;

/* genz-discontinuous in 1D with its jump at the end point 1: no jump
 * inside (0,1) to declare, so auto takes RQMC (with the jump inside, at a
 * declared break, it takes Gauss-Kronrod: 42 evaluations, nothing to fill
 * a bound with). */
static const double jump_at_end[] = {1.0};

/* The case with the integrand's u given (NULL: its defaults). */
static void run_case_u(const mem_case *c, const double *u)
{
    char why[512];
    qmc_testfn *fn = NULL;
    assert_int_equal(qmc_testfn_new(c->integrand, c->dims, NULL, 0, u, u ? c->dims : 0, &fn,
                                    why, sizeof why), 0);
    qmc_integrate_spec spec;
    qmc_integrate_spec_init(&spec);
    assert_int_equal(qmc_method_parse(c->method, &spec.method), 0);
    spec.tol_rel = c->tol_rel;
    spec.max_evals = c->max_evals;
    spec.max_memory = c->max_memory;
    if (c->n) {
        spec.sampling.n = c->n;
        spec.n_given = 1;
    }
    if (c->reps)
        spec.sampling.reps = c->reps;
    if (spec.method == QMC_METHOD_RQMC)
        spec.sampling.scramble = QMC_SCRAMBLE_OWEN;
    uint64_t bound = qmc_integrate_memory_bytes(&spec, c->dims);
    uint64_t bound_for = qmc_integrate_memory_bytes_for(&spec, qmc_testfn_integrand(fn), NULL);
    qmc_integrate_report rep;
    size_t before = live_bytes;
    peak_bytes = live_bytes;
    int err = qmc_integrate(&spec, qmc_testfn_integrand(fn), NULL, NULL, NULL, &rep, why,
                            sizeof why);
    size_t used = peak_bytes - before;
    print_message("%s %ud %s tol %g budget %llu: %llu evals, peak %zu bytes, bound %llu, "
                  "for this integrand %llu (%s)\n",
                  c->integrand, c->dims, c->method, c->tol_rel,
                  (unsigned long long)c->max_evals, (unsigned long long)rep.res.evals, used,
                  (unsigned long long)bound, (unsigned long long)bound_for,
                  err ? why : qmc_method_name(rep.method_used));
    assert_int_equal(err, 0);
    assert_true(used <= bound + UNBOUNDED_ALLOWANCE);
    if (c->fill_ratio > 0)
        assert_true((double)bound <= c->fill_ratio * (double)used);
    /* Knowing the integrand only narrows what auto may pick. */
    assert_true(used <= bound_for + UNBOUNDED_ALLOWANCE);
    assert_true(bound_for <= bound);
    if (c->fill_ratio_for > 0)
        assert_true((double)bound_for <= c->fill_ratio_for * (double)used);
    qmc_testfn_free(fn);
}

static void run_case(const mem_case *c)
{
    run_case_u(c, NULL);
}

static void test_rules(void **state)
{
    (void)state;
    static const mem_case cases[] = {
        /* Cubature refining until its region memory is full. */
        {"genz-gaussian", 2, "cubature", 1e-300, 4000000, 8u << 20, 0, 0, 4, 0},
        /* ... or until the budget, below the memory cap. */
        {"genz-gaussian", 3, "cubature", 1e-300, 200000, 64u << 20, 0, 0, 0, 0},
        {"genz-gaussian", 3, "clenshaw-curtis", 1e-300, 2000000, 16u << 20, 0, 0, 0, 0},
        {"genz-gaussian", 4, "gauss-legendre", 0, 100000000, 64u << 20, 16, 0, 0, 0},
        {"exp", 1, "gauss-kronrod", 1e-12, 100000, 64u << 20, 0, 0, 0, 0},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        run_case(&cases[i]);
}

static void test_sampling(void **state)
{
    (void)state;
    static const mem_case cases[] = {
        /* Fixed n: one array of exactly its blocks. */
        {"genz-oscillatory", 4, "rqmc", 0, 100000000, 64u << 20, 1u << 16, 16, 0, 0},
        /* Adaptive until the budget: rounds double, two arrays live. */
        {"genz-discontinuous", 3, "rqmc", 1e-300, 1u << 24, 64u << 20, 4096, 16, 4, 0},
        {"genz-discontinuous", 3, "mc", 1e-300, 1u << 23, 64u << 20, 4096, 0, 0, 0},
        /* auto: whatever it picks, within what it reserves.  At 4 dims
         * the bound must cover cubature's regions (an analytic integrand
         * would get them), so RQMC stays far below it. */
        {"genz-discontinuous", 4, "auto", 1e-300, 1u << 22, 64u << 20, 0, 0, 0, 0},
        {"genz-gaussian", 3, "auto", 1e-300, 1u << 22, 8u << 20, 0, 0, 0, 0},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        run_case(&cases[i]);
}

/* auto where no rule is within reach (above cubature's 10 dims, a budget
 * short of 17^d for Clenshaw-Curtis): its bound is its RQMC's rounds
 * and VEGAS map alone, and a run to the budget fills it. */
/* auto knowing the integrand (qmc_integrate_memory_bytes_for, what qmcd
 * reserves): jumps, kinks past 4 dims and a smooth 1-D integrand rule out
 * the regions and the grid that the dims alone cannot. */
static void test_auto_for_integrand(void **state)
{
    (void)state;
    static const mem_case cases[] = {
        {"genz-discontinuous", 4, "auto", 1e-300, 1u << 24, 256u << 20, 0, 0, 0, 2},
        {"genz-discontinuous", 2, "auto", 1e-300, 1u << 24, 256u << 20, 0, 0, 0, 2},
        {"genz-continuous", 6, "auto", 1e-300, 1u << 24, 256u << 20, 0, 0, 0, 2},
        /* A smooth one still gets its rule's workspace. */
        {"genz-gaussian", 3, "auto", 1e-300, 1u << 22, 8u << 20, 0, 0, 0, 2},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        run_case(&cases[i]);
    /* 1 dimension, jumps: RQMC when none is declared inside (0,1), which
     * fills the bound; Gauss-Kronrod from a declared one, within it */
    static const mem_case one = {"genz-discontinuous", 1, "auto", 1e-300, 1u << 22,
                                 256u << 20, 0, 0, 0, 2};
    run_case_u(&one, jump_at_end);
    static const mem_case declared = {"genz-discontinuous", 1, "auto", 1e-300, 1u << 22,
                                      256u << 20, 0, 0, 0, 0};
    run_case(&declared);
}

static void test_auto_rqmc(void **state)
{
    (void)state;
    static const mem_case cases[] = {
        /* Jumps: no map, 8 replicates of one split net. */
        {"genz-discontinuous", 16, "auto", 1e-300, 1u << 24, 256u << 20, 0, 0, 2, 0},
        /* Smooth: a VEGAS pilot first (its map kept through the run). */
        {"genz-oscillatory", 12, "auto", 1e-300, 1u << 24, 256u << 20, 0, 0, 2, 0},
        {"genz-gaussian", 11, "auto", 1e-300, 3000000, 256u << 20, 0, 0, 2, 0},
        /* The caller's own n (not a power of two) doubles from there. */
        {"genz-discontinuous", 16, "auto", 1e-300, 1u << 24, 256u << 20, 5000, 0, 2, 0},
        {"exp", 1, "auto", 1e-12, 1u << 22, 256u << 20, 0, 0, 0, 0},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        run_case(&cases[i]);
    /* 1 dimension: Gauss-Kronrod or RQMC, never the regions; the bound
     * holds a VEGAS pilot's buffers, which jumps never train. */
    static const mem_case one = {"genz-discontinuous", 1, "auto", 1e-300, 1u << 22,
                                 256u << 20, 0, 0, 3, 0};
    run_case_u(&one, jump_at_end);
}

/* The bound saturates instead of wrapping at an unbounded budget. */
static void test_saturates(void **state)
{
    (void)state;
    qmc_integrate_spec spec;
    qmc_integrate_spec_init(&spec);
    spec.max_evals = UINT64_MAX;
    spec.tol_rel = 1e-3;
    spec.method = QMC_METHOD_RQMC;
    assert_true(qmc_integrate_memory_bytes(&spec, 8) >= UINT64_MAX / 4096);
    spec.method = QMC_METHOD_CUBATURE;
    spec.max_memory = UINT64_MAX;
    assert_true(qmc_integrate_memory_bytes(&spec, 8) > 0);
}

/* Sessions (qmc_session_memory_bytes, what a server reserves before
 * opening one): from open to the last tell, the session, its fiber stack,
 * its batch buffer and the integrator's own stay within the bound.  The
 * caller's values live in a static buffer, outside the count. */
static double session_vals[1u << 17];

typedef struct session_case {
    const char *integrand;
    uint32_t dims;
    const char *method;
    double tol_rel;
    uint64_t max_evals, max_batch;
    uint32_t part_k, part_p;
    double fill_ratio;           /* > 0: bound <= fill_ratio x peak */
} session_case;

static void run_session_case(const session_case *c)
{
    char why[512];
    qmc_testfn *fn = NULL;
    assert_int_equal(qmc_testfn_new(c->integrand, c->dims, NULL, 0, NULL, 0, &fn, why,
                                    sizeof why), 0);
    const qmc_integrand *f = qmc_testfn_integrand(fn);
    qmc_session_spec ss;
    qmc_session_spec_init(&ss);
    ss.dims = c->dims;
    ss.smoothness = f->smoothness;
    assert_int_equal(qmc_method_parse(c->method, &ss.integrate.method), 0);
    qmc_sampler sm;
    if (qmc_sampler_parse(c->method, &sm) == 0)
        qmc_sampling_spec_init(&ss.integrate.sampling, sm);
    ss.integrate.tol_rel = c->tol_rel;
    ss.integrate.max_evals = c->max_evals;
    ss.max_batch = c->max_batch;
    ss.part_k = c->part_k;
    ss.part_p = c->part_p;
    const uint64_t bound = qmc_session_memory_bytes(&ss);
    size_t before = live_bytes;
    peak_bytes = live_bytes;
    qmc_session *s = NULL;
    assert_int_equal(qmc_session_new(&ss, &s, why, sizeof why), 0);
    uint64_t evals = 0;
    for (;;) {
        qmc_session_batch b;
        assert_int_equal(qmc_session_ask(s, &b), 0);
        if (b.count == 0)
            break;
        assert_true(b.count <= sizeof session_vals / sizeof session_vals[0]);
        f->eval(f->ctx, b.points, b.count, b.dims, session_vals);
        assert_int_equal(qmc_session_tell(s, b.seq, session_vals, b.count, why, sizeof why), 0);
        evals += b.count;
    }
    qmc_session_free(s);
    size_t used = peak_bytes - before;
    print_message("session %s %ud %s: %llu evals, peak %zu bytes, bound %llu\n", c->integrand,
                  c->dims, c->method, (unsigned long long)evals, used,
                  (unsigned long long)bound);
    assert_int_equal(live_bytes, before); /* and everything freed */
    assert_true(used <= bound + UNBOUNDED_ALLOWANCE);
    if (c->fill_ratio > 0)
        assert_true((double)bound <= c->fill_ratio * (double)used);
    qmc_testfn_free(fn);
}

static void test_sessions(void **state)
{
    (void)state;
    static const session_case cases[] = {
        /* a fixed rqmc job: its 16 blocks make one full batch */
        {"genz-oscillatory", 4, "rqmc", 0, 100000000, 0, 0, 0, 2},
        {"genz-oscillatory", 4, "rqmc", 0, 100000000, 10000, 0, 0, 2},
        /* adaptive, to the budget */
        {"genz-discontinuous", 3, "rqmc", 1e-300, 1u << 22, 0, 0, 0, 0},
        /* auto: a VEGAS pilot then rqmc; cubature's regions */
        {"genz-oscillatory", 12, "auto", 1e-300, 3000000, 0, 0, 0, 0},
        {"genz-gaussian", 3, "cubature", 1e-300, 200000, 0, 0, 0, 0},
        {"exp", 1, "gauss-kronrod", 1e-12, 100000, 0, 0, 0, 0},
        /* a part's sums */
        {"genz-gaussian", 3, "rqmc", 0, 100000000, 0, 2, 3, 2},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        run_session_case(&cases[i]);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rules),
        cmocka_unit_test(test_sampling),
        cmocka_unit_test(test_auto_rqmc),
        cmocka_unit_test(test_auto_for_integrand),
        cmocka_unit_test(test_saturates),
        cmocka_unit_test(test_sessions),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
