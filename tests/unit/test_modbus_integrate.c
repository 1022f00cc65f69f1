/*
 * test_modbus_integrate.c - a device integrates a function it measures
 * through the Modbus integration block (protocol/MODBUS.md section 9),
 * driven through the pure handler as a device would drive it: read the
 * point and its request number, evaluate, write value and number.
 *
 * Two oracles.  The closed form: f = exp(x_1 + ... + x_d) has integral
 * (e - 1)^d, which must lie within the reported bar of the estimate when
 * the session converged.  And the same session driven directly through
 * qmc_session_* (qmc/session.h), with its default batch size, evaluating
 * f at the coordinates the registers carry (float32, u32 or u16, rounded
 * as MODBUS.md says, computed here from the doubles) and handing back
 * float32 values: every number the registers show - estimate and bar as
 * float64, flags, evaluations, status, method - must equal its report
 * bit for bit.  The setup registers' meaning is written out here from
 * MODBUS.md, apart from protocol/modbus_integrate.c.
 * Hostile masters: test_modbus_integrate_hostile.c.
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "modbus_device.h"
#include "qmc/modbus.h"
#include "qmc/session.h"

static const qmc_modbus_env env = {.version = "0.1.0", .integration_bytes_max = 64u << 20};

static double exp_sum(const double *x, uint32_t dims)
{
    double s = 0;
    for (uint32_t j = 0; j < dims; j++)
        s += x[j];
    return exp(s);
}

static double exp_sum_exact(uint32_t dims)
{
    return pow(expm1(1.0), dims);
}

/* ---- one case: setup registers, and the same spec written out ---------------- */

typedef struct icase {
    const char *name;
    uint16_t method;        /* register 300 */
    uint32_t dims;
    uint16_t smoothness;
    uint32_t seed, n;
    uint16_t reps;
    float tol_abs, tol_rel;
    uint32_t budget;
    int format, low_first, fc23;
    int expect_status;      /* QMC_MODBUS_INTEG_* */
    int expect_method;      /* qmc_method auto picks (method_used), or -1 */
} icase;

/* The setup registers 300..315 for c, start number start. */
static void setup_regs(const icase *c, uint16_t start, uint16_t out[QMC_MODBUS_SETUP_COUNT])
{
    memset(out, 0, QMC_MODBUS_SETUP_COUNT * sizeof *out);
    out[0] = c->method;
    out[1] = (uint16_t)c->dims;
    out[2] = c->smoothness;
    out[3] = (uint16_t)(c->seed >> 16), out[4] = (uint16_t)c->seed;
    out[5] = (uint16_t)(c->n >> 16), out[6] = (uint16_t)c->n;
    out[7] = c->reps;
    mb_put_f32(&out[8], c->tol_abs, c->low_first);
    mb_put_f32(&out[10], c->tol_rel, c->low_first);
    out[12] = (uint16_t)(c->budget >> 16), out[13] = (uint16_t)c->budget;
    out[14] = 950;
    out[15] = start;
}

/* MODBUS.md section 9's mapping, as `qmc integrate` would take the same
 * options, with the default batch size (the bits do not depend on it). */
static void spec_for(const icase *c, qmc_session_spec *ss)
{
    qmc_session_spec_init(ss);
    ss->dims = c->dims;
    ss->smoothness = (qmc_smoothness)c->smoothness;
    qmc_integrate_spec *is = &ss->integrate;
    switch (c->method) {
    case 1:
        is->method = QMC_METHOD_MC;
        qmc_sampling_spec_init(&is->sampling, QMC_SAMPLER_MC);
        break;
    case 2:
        is->method = QMC_METHOD_QMC;
        qmc_sampling_spec_init(&is->sampling, QMC_SAMPLER_QMC);
        break;
    case 3:
        is->method = QMC_METHOD_RQMC;
        qmc_sampling_spec_init(&is->sampling, QMC_SAMPLER_RQMC);
        break;
    default:
        is->method = QMC_METHOD_AUTO;
        break;
    }
    is->sampling.seed = c->seed;
    if (c->n) {
        is->sampling.n = c->n;
        is->n_given = 1;
        is->n_axis = c->n;
    }
    if (c->reps)
        is->sampling.reps = c->reps;
    is->sampling.confidence = 0.95;
    is->tol_abs = c->tol_abs;
    is->tol_rel = c->tol_rel;
    is->max_evals = c->budget;
    is->max_memory = 1u << 20;
}

/* A coordinate as the registers carry it, from the double: the nearest
 * binary32, or round(x 2^32)/2^32, round(x 2^16)/2^16 capped below 1. */
static double as_carried(double x, int format)
{
    if (format == QMC_MODBUS_FORMAT_F32)
        return (float)x;
    double scale = format == QMC_MODBUS_FORMAT_U16 ? 65536.0 : 4294967296.0;
    double v = nearbyint(x * scale);
    return (v > scale - 1 ? scale - 1 : v) / scale;
}

typedef struct direct {
    int err;
    qmc_integrate_report rep;
    qmc_session_end end;
} direct;

/* The same session through qmc_session_*: the device's view of f. */
static direct run_direct(const icase *c)
{
    qmc_session_spec ss;
    spec_for(c, &ss);
    qmc_session *s = NULL;
    char why[256];
    assert_int_equal(qmc_session_new(&ss, &s, why, sizeof why), 0);
    double *vals = NULL;
    size_t cap = 0;
    direct d;
    for (;;) {
        qmc_session_batch b;
        assert_int_equal(qmc_session_ask(s, &b), 0);
        if (b.count == 0) {
            d.end = b.end;
            break;
        }
        if (b.count > cap) {
            vals = realloc(vals, b.count * sizeof *vals);
            assert_non_null(vals);
            cap = b.count;
        }
        for (size_t i = 0; i < b.count; i++) {
            double x[QMC_MODBUS_MAX_DIMS];
            for (uint32_t j = 0; j < b.dims; j++)
                x[j] = as_carried(b.points[i * b.dims + j], c->format);
            vals[i] = (float)exp_sum(x, b.dims);
        }
        assert_int_equal(qmc_session_tell(s, b.seq, vals, b.count, why, sizeof why), 0);
    }
    d.err = qmc_session_result(s, &d.rep, why, sizeof why);
    qmc_session_free(s);
    free(vals);
    return d;
}

static int status_of(qmc_session_end e)
{
    switch (e) {
    case QMC_SESSION_CONVERGED:
        return QMC_MODBUS_INTEG_CONVERGED;
    case QMC_SESSION_COMPLETE:
        return QMC_MODBUS_INTEG_COMPLETE;
    case QMC_SESSION_BUDGET:
        return QMC_MODBUS_INTEG_BUDGET;
    case QMC_SESSION_CANNOT_TELL:
        return QMC_MODBUS_INTEG_CANNOT_TELL;
    default:
        return QMC_MODBUS_INTEG_FAILED;
    }
}

static int same_bits(double a, double b)
{
    return memcmp(&a, &b, sizeof a) == 0;
}

/* Runs c as a device against a fresh bank and as a direct session, and
 * compares; then the closed form. */
static void run_case(const icase *c)
{
    qmc_modbus_session *s = NULL;
    assert_int_equal(qmc_modbus_session_new(&s), 0);
    /* The bank's word order and format first (registers 5 and 12), then
     * setup and start in one FC16. */
    mb_reply r = mb_write1(s, &env, QMC_MODBUS_HR_FORMAT, (unsigned)c->format);
    assert_int_equal(r.n, 5);
    r = mb_write1(s, &env, QMC_MODBUS_HR_WORD_ORDER, (unsigned)c->low_first);
    assert_int_equal(r.n, 5);
    uint16_t setup[QMC_MODBUS_SETUP_COUNT];
    setup_regs(c, 1, setup);
    r = mb_write(s, &env, QMC_MODBUS_SETUP_BASE, setup, QMC_MODBUS_SETUP_COUNT);
    mb_assert_written(&r);
    qmc_modbus_usage u;
    qmc_modbus_session_usage(s, &u);
    assert_int_equal(u.integrating, 1);
    assert_true(u.integration_bytes > 0 && u.integration_bytes <= env.integration_bytes_max);

    mb_device dev = {c->dims, c->format, c->low_first, c->fc23, exp_sum};
    uint64_t written = mb_device_run(s, &env, &dev, 50000000);
    mb_snapshot snap;
    mb_snapshot_take(s, &env, &snap);
    const uint16_t *ib = snap.ib;
    direct d = run_direct(c);
    print_message("  %-28s %8llu values, status %u (%s), est %.15g, bar %.3g\n", c->name,
                  (unsigned long long)written, ib[QMC_MODBUS_IB_STATUS],
                  qmc_modbus_integ_status_name(ib[QMC_MODBUS_IB_STATUS]),
                  mb_f64(&ib[QMC_MODBUS_IB_ESTIMATE_F64], c->low_first),
                  mb_f64(&ib[QMC_MODBUS_IB_BAR_F64], c->low_first));

    /* The direct session's report, bit for bit. */
    assert_int_equal(d.err, 0);
    assert_int_equal(ib[QMC_MODBUS_IB_STATUS], status_of(d.end));
    assert_int_equal(ib[QMC_MODBUS_IB_STATUS], c->expect_status);
    assert_int_equal(ib[QMC_MODBUS_IB_START], 1);
    assert_int_equal(mb_u32(&ib[QMC_MODBUS_IB_REQUEST]), 0);
    assert_int_equal(mb_u64(&ib[QMC_MODBUS_IB_EVALS]), d.rep.res.evals);
    assert_int_equal(written, d.rep.res.evals);
    const double est = mb_f64(&ib[QMC_MODBUS_IB_ESTIMATE_F64], c->low_first);
    const double bar = mb_f64(&ib[QMC_MODBUS_IB_BAR_F64], c->low_first);
    /* The block's own flag: a rule's bar below what float32 values resolve. */
    const double scale = fmax(fabs(d.rep.res.estimate), d.rep.res.abs_integral);
    const int below = d.rep.res.error_kind == QMC_ERROR_ESTIMATE && bar < scale / 8388608.0;
    assert_int_equal(mb_u32(&ib[QMC_MODBUS_IB_FLAGS]),
                     d.rep.res.flags | (below ? QMC_FLAG_ROUNDOFF : 0));
    assert_int_equal(mb_u64(&ib[QMC_MODBUS_IB_NONFINITE]), d.rep.res.nonfinite);
    assert_int_equal(ib[QMC_MODBUS_IB_ERROR], 0);
    assert_int_equal(ib[QMC_MODBUS_IB_METHOD_USED], (int)d.rep.method_used + 1);
    if (c->expect_method >= 0)
        assert_int_equal(d.rep.method_used, c->expect_method);
    assert_true(same_bits(est, d.rep.res.estimate));
    if (d.rep.res.error_kind == QMC_ERROR_NONE)
        assert_true(isnan(bar));
    else
        assert_true(same_bits(bar, (d.rep.res.ci_high - d.rep.res.ci_low) / 2));
    const float est32 = mb_f32(&ib[QMC_MODBUS_IB_ESTIMATE_F32], c->low_first);
    assert_true(memcmp(&est32, &(float){(float)est}, sizeof est32) == 0);
    /* Over: the session is freed, the bank holds nothing. */
    qmc_modbus_session_usage(s, &u);
    assert_int_equal(u.integrating, 0);
    assert_int_equal(u.integration_bytes, 0);
    assert_int_equal(mb_u64(&ib[QMC_MODBUS_IB_BYTES]), 0);

    /* The closed form. */
    const double exact = exp_sum_exact(c->dims);
    if (c->expect_status == QMC_MODBUS_INTEG_CONVERGED) {
        /* Within the bar, or - flagged roundoff - within what float32
         * values resolve. */
        assert_true(fabs(est - exact) <= (below ? fmax(bar, exact / 4194304.0) : bar));
        double tol = fmax(c->tol_abs, c->tol_rel * fabs(est));
        if (c->method == QMC_MODBUS_METHOD_RQMC)
            assert_true(bar <= tol * (1 + 1e-12));
    } else {
        /* Not converged: still a sane estimate, the bar says how sane. */
        assert_true(fabs(est - exact) <= (isnan(bar) ? 1e-2 * exact : 4 * bar));
    }
    qmc_modbus_session_free(s);
}

static void test_device_loops(void **state)
{
    (void)state;
    static const icase cases[] = {
        {"rqmc tol 1e-3, f32 ABCD", 3, 2, 0, 3, 1024, 8, 0, 1e-3f, 1000000, 0, 0, 0,
         QMC_MODBUS_INTEG_CONVERGED, QMC_METHOD_RQMC},
        {"rqmc tol 1e-4 d=4, FC23", 3, 4, 0, 11, 0, 0, 0, 1e-4f, 2000000, 0, 0, 1,
         QMC_MODBUS_INTEG_CONVERGED, QMC_METHOD_RQMC},
        {"auto d=2 (clenshaw-curtis), CDAB", 4, 2, 0, 0, 0, 0, 0, 0, 1000000, 0, 1, 1,
         QMC_MODBUS_INTEG_CONVERGED, QMC_METHOD_CLENSHAW_CURTIS},
        /* Declared continuous (kinks possible): no pilot can confirm
         * cubature's bar at this tolerance, so auto spends the rest of
         * the budget on RQMC, which vouches for it: cubature's answer,
         * converged (before issue 23's seventh round: cannot tell). */
        {"auto d=4 kinks (cubature, rqmc)", 4, 4, 1, 0, 0, 0, 0, 1e-5f, 1000000, 0, 0, 0,
         QMC_MODBUS_INTEG_CONVERGED, QMC_METHOD_CUBATURE},
        {"auto d=1 (gauss-kronrod)", 4, 1, 0, 0, 0, 0, 0, 1e-6f, 1000000, 0, 0, 0,
         QMC_MODBUS_INTEG_CONVERGED, QMC_METHOD_GAUSS_KRONROD},
        {"auto d=3 jumps (rqmc)", 4, 3, 2, 5, 0, 0, 0, 1e-3f, 1000000, 2, 1, 1,
         QMC_MODBUS_INTEG_CONVERGED, QMC_METHOD_RQMC},
        {"mc n=2000, u32", 1, 3, 1, 3, 2000, 0, 0, 0, 1000000, 2, 0, 0,
         QMC_MODBUS_INTEG_COMPLETE, QMC_METHOD_MC},
        {"qmc n=1024, u16", 2, 2, 0, 0, 1024, 0, 0, 0, 1000000, 1, 0, 0,
         QMC_MODBUS_INTEG_COMPLETE, QMC_METHOD_QMC},
        {"rqmc budget runs out", 3, 2, 0, 9, 512, 4, 0, 1e-9f, 16384, 0, 0, 1,
         QMC_MODBUS_INTEG_BUDGET, QMC_METHOD_RQMC},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        run_case(&cases[i]);
}

/* While running: the evaluations count each value at once, the estimate is
 * NaN until the method has one (here: two replicates of RQMC done), then
 * finite and flagged few_reps; the bank holds the session's memory. */
static void test_running_estimate(void **state)
{
    (void)state;
    const icase c = {"rqmc 4 x 4096", 3, 2, 0, 1, 4096, 4, 0, 0, 1000000, 0, 0, 0,
                     QMC_MODBUS_INTEG_COMPLETE, QMC_METHOD_RQMC};
    qmc_modbus_session *s = NULL;
    assert_int_equal(qmc_modbus_session_new(&s), 0);
    uint16_t setup[QMC_MODBUS_SETUP_COUNT];
    setup_regs(&c, 5, setup);
    mb_reply r = mb_write(s, &env, QMC_MODBUS_SETUP_BASE, setup, QMC_MODBUS_SETUP_COUNT);
    mb_assert_written(&r);
    mb_device dev = {2, 0, 0, 0, exp_sum};
    mb_snapshot snap;
    assert_int_equal(mb_device_run(s, &env, &dev, 8191), 8191);
    mb_snapshot_take(s, &env, &snap);
    assert_int_equal(snap.ib[QMC_MODBUS_IB_STATUS], QMC_MODBUS_INTEG_WAITING);
    assert_int_equal(snap.ib[QMC_MODBUS_IB_START], 5);
    assert_int_equal(mb_u64(&snap.ib[QMC_MODBUS_IB_EVALS]), 8191);
    assert_true(isnan(mb_f64(&snap.ib[QMC_MODBUS_IB_ESTIMATE_F64], 0)));
    assert_true(isnan(mb_f32(&snap.ib[QMC_MODBUS_IB_ESTIMATE_F32], 0)));
    assert_true(mb_u64(&snap.ib[QMC_MODBUS_IB_BYTES]) > 0);
    assert_int_equal(snap.ib[QMC_MODBUS_IB_METHOD_USED], QMC_METHOD_RQMC + 1);
    assert_int_equal(mb_device_run(s, &env, &dev, 1), 1);
    mb_snapshot_take(s, &env, &snap);
    const double est = mb_f64(&snap.ib[QMC_MODBUS_IB_ESTIMATE_F64], 0);
    assert_true(isfinite(est));
    assert_true(fabs(est - exp_sum_exact(2)) < 1e-3);
    assert_true(mb_u32(&snap.ib[QMC_MODBUS_IB_FLAGS]) & QMC_FLAG_FEW_REPS);
    assert_int_equal(mb_device_run(s, &env, &dev, 100000), 4 * 4096 - 8192);
    mb_snapshot_take(s, &env, &snap);
    assert_int_equal(snap.ib[QMC_MODBUS_IB_STATUS], QMC_MODBUS_INTEG_COMPLETE);
    qmc_modbus_session_free(s);
}

/* Defaults: what a new bank shows; names of the status codes. */
static void test_defaults(void **state)
{
    (void)state;
    qmc_modbus_session *s = NULL;
    assert_int_equal(qmc_modbus_session_new(&s), 0);
    mb_snapshot snap;
    mb_snapshot_take(s, NULL, &snap);
    const uint16_t want[QMC_MODBUS_SETUP_COUNT] = {4, 2, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0,
                                                   0x000F, 0x4240, 950, 0};
    assert_memory_equal(snap.setup, want, sizeof want);
    for (unsigned i = 0; i < QMC_MODBUS_VALUE_COUNT; i++)
        assert_int_equal(snap.value[i], 0);
    assert_int_equal(snap.ib[QMC_MODBUS_IB_STATUS], QMC_MODBUS_INTEG_NONE);
    assert_int_equal(mb_u32(&snap.ib[QMC_MODBUS_IB_REQUEST]), 0);
    assert_true(isnan(mb_f64(&snap.ib[QMC_MODBUS_IB_ESTIMATE_F64], 0)));
    assert_true(isnan(mb_f64(&snap.ib[QMC_MODBUS_IB_BAR_F64], 0)));
    for (unsigned i = QMC_MODBUS_IB_POINT; i < QMC_MODBUS_IB_EVALS; i++)
        assert_int_equal(snap.ib[i], 0);
    qmc_modbus_usage u;
    qmc_modbus_session_usage(s, &u);
    assert_int_equal(u.integration_bytes, 0);
    qmc_modbus_session_usage(NULL, &u);
    assert_int_equal(u.integrating, 0);
    assert_string_equal(qmc_modbus_integ_status_name(QMC_MODBUS_INTEG_CONVERGED),
                        "done: the tolerance was met");
    assert_string_equal(qmc_modbus_integ_status_name(99), "");
    qmc_modbus_session_free(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_defaults),
        cmocka_unit_test(test_device_loops),
        cmocka_unit_test(test_running_estimate),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
