/*
 * modbus_integrate.c - a register bank's integration session: a device
 * integrates a function it measures through the registers of
 * protocol/MODBUS.md section 9.  The setup registers make a
 * qmc_session_spec; the session (qmc/session.h) hands out batches of
 * points, which the device walks through one point at a time: it reads
 * the point and its request number, measures, and writes the request
 * number and f there in one write.  The values are collected here, and
 * when a batch is complete it is told to the session at once, whose
 * integrator then runs (on its fiber, inside this call) up to its next
 * batch.  So a request's work is bounded by one integrator step, and a
 * bank waiting for its device holds memory only.
 *
 * Why one point at a time: a Modbus device measures one point per cycle,
 * and a request number per point lets it retry a write whose reply was
 * lost (the same number and value are acknowledged again) while a value
 * for any other number is refused (exception 03) instead of being
 * counted at the wrong point.  Why batches are kept small (256 points):
 * the bytes of the result do not depend on the batch size
 * (docs/SESSIONS.md), and the values a bank collects are its memory.
 *
 * Every number a device can see is decided by the registers alone: the
 * spec has a fixed batch size and cubature memory, never the server's
 * caps, so the same registers give the same bits on any server (the
 * caps only refuse a start, with status NO_MEMORY).
 *
 * Must not: do I/O, read a clock, keep global state, or print; answer a
 * request with an exception after changing anything.
 */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "modbus_integrate.h"

static const uint16_t setup_min[QMC_MODBUS_SETUP_COUNT] = {
#define SETUP_MIN(name, addr, lo, hi) [(addr) - QMC_MODBUS_SETUP_BASE] = (lo),
    QMC_MODBUS_SETUP_MAP(SETUP_MIN)
#undef SETUP_MIN
};
static const uint16_t setup_max[QMC_MODBUS_SETUP_COUNT] = {
#define SETUP_MAX(name, addr, lo, hi) [(addr) - QMC_MODBUS_SETUP_BASE] = (hi),
    QMC_MODBUS_SETUP_MAP(SETUP_MAX)
#undef SETUP_MAX
};

/* Register i of the setup block. */
#define SETUP(g, name) ((g)->setup[QMC_MODBUS_SETUP_##name - QMC_MODBUS_SETUP_BASE])

const char *qmc_modbus_integ_status_name(int code)
{
    switch (code) {
#define IST_NAME(name, c, text) \
    case c:                     \
        return text;
        QMC_MODBUS_INTEG_STATUS_MAP(IST_NAME)
#undef IST_NAME
    }
    return "";
}

void qmc__mb_integ_init(qmc__mb_integ *g)
{
    memset(g, 0, sizeof *g);
    SETUP(g, METHOD) = QMC_MODBUS_METHOD_AUTO;
    SETUP(g, DIMS) = 2;
    SETUP(g, SMOOTHNESS) = QMC_SMOOTH_CONTINUOUS;
    SETUP(g, BUDGET_HI) = (uint16_t)(QMC_MODBUS_DEFAULT_BUDGET >> 16);
    SETUP(g, BUDGET_LO) = (uint16_t)QMC_MODBUS_DEFAULT_BUDGET;
    SETUP(g, CONFIDENCE) = QMC_MODBUS_DEFAULT_CONFIDENCE;
    g->next_request = 1;
    g->status = QMC_MODBUS_INTEG_NONE;
}

/* Frees what a session holds; the status and the final result stay. */
static void drop_session(qmc__mb_integ *g)
{
    qmc_session_free(g->sess);
    g->sess = NULL;
    free(g->vals);
    g->vals = NULL;
    g->vals_cap = 0;
    g->sess_bytes = 0;
    memset(&g->batch, 0, sizeof g->batch);
    g->cursor = 0;
    g->request = 0;
}

void qmc__mb_integ_close(qmc__mb_integ *g)
{
    drop_session(g);
}

int qmc__mb_integ_writable(unsigned addr)
{
    return (addr >= QMC_MODBUS_SETUP_BASE &&
            addr < QMC_MODBUS_SETUP_BASE + QMC_MODBUS_SETUP_COUNT) ||
           (addr >= QMC_MODBUS_VALUE_BASE &&
            addr < QMC_MODBUS_VALUE_BASE + QMC_MODBUS_VALUE_COUNT);
}

/* ---- 32- and 64-bit values in registers ------------------------------------ */

static uint32_t u32_of(const uint16_t *r)
{
    return (uint32_t)r[0] << 16 | r[1];
}

static void put_u32(uint16_t *r, uint32_t v)
{
    r[0] = (uint16_t)(v >> 16);
    r[1] = (uint16_t)v;
}

/* A binary32 from two registers in word order low_first (register 12). */
static float f32_of(const uint16_t *r, int low_first)
{
    uint32_t bits = low_first ? (uint32_t)r[1] << 16 | r[0] : (uint32_t)r[0] << 16 | r[1];
    float f;
    memcpy(&f, &bits, sizeof f);
    return f;
}

static void put_f32(uint16_t *r, float f, int low_first)
{
    uint32_t bits;
    memcpy(&bits, &f, sizeof bits);
    r[low_first ? 1 : 0] = (uint16_t)(bits >> 16);
    r[low_first ? 0 : 1] = (uint16_t)bits;
}

/* x as binary32, rounded to nearest; past the float range an infinity of
 * its sign (Annex F's overflow, spelt out: C leaves the conversion of an
 * out-of-range double undefined). */
static float to_f32(double x)
{
    if (x > FLT_MAX || x < -FLT_MAX)
        return x > 0 ? INFINITY : -INFINITY;
    return (float)x;
}

/* A binary64 in four registers: high word first, or (low_first) the
 * words reversed. */
static void put_f64(uint16_t *r, double x, int low_first)
{
    uint64_t bits;
    memcpy(&bits, &x, sizeof bits);
    for (int i = 0; i < 4; i++) {
        uint16_t w = (uint16_t)(bits >> (48 - 16 * i));
        r[low_first ? 3 - i : i] = w;
    }
}

/*
 * One coordinate in the bank's format (register 5): the nearest value the
 * format carries - binary32 rounded to nearest, u32 round(x 2^32), u16
 * round(x 2^16), the fixed point ones capped at their largest value.
 * Returns the registers written (1 or 2).  Not floor(), as the result
 * block's points are: a device measures f where the registers say, and
 * always rounding down would bias every estimate by half a step times
 * the integral of f's gradient (7.6e-6 of it for u16), which no error bar
 * sees; to nearest, the shift averages out to second order.
 */
static unsigned put_coord(uint16_t *r, double x, unsigned fmt, int low_first)
{
    if (!(x > 0))
        x = 0; /* also NaN, which no integrator hands out */
    if (x > 1)
        x = 1;
    if (fmt == QMC_MODBUS_FORMAT_U16) {
        double v = floor(x * 65536.0 + 0.5);
        r[0] = v >= 65535.0 ? 0xFFFF : (uint16_t)v;
        return 1;
    }
    if (fmt == QMC_MODBUS_FORMAT_U32) {
        double v = floor(x * 4294967296.0 + 0.5);
        uint32_t u = v >= 4294967295.0 ? 0xFFFFFFFFu : (uint32_t)v;
        r[low_first ? 1 : 0] = (uint16_t)(u >> 16);
        r[low_first ? 0 : 1] = (uint16_t)u;
        return 2;
    }
    put_f32(r, (float)x, low_first);
    return 2;
}

/*
 * The values come as binary32: each within 2^-24 of the device's number,
 * relative.  A deterministic rule's error estimate compares rule levels on
 * those values and cannot see that rounding, so a rule's bar below 2^-23
 * of the integral's scale (|f|'s integral where the rule has it, else the
 * estimate's size) claims more than the values hold: the block raises
 * roundoff for it.  The sampling methods' bars take the rounding in as
 * part of the spread.
 */
static uint32_t resolution_flags(const qmc_result *res, double bar)
{
    const double scale = fmax(fabs(res->estimate), res->abs_integral);
    if (res->error_kind == QMC_ERROR_ESTIMATE && bar < scale * 0x1p-23)
        return QMC_FLAG_ROUNDOFF;
    return 0;
}

/* ---- the session ------------------------------------------------------------ */

/* The session the setup registers ask for (low_first: their floats' word
 * order).  MODBUS.md section 9 gives the mapping; it follows `qmc
 * integrate`'s options (cli_integrate_spec). */
static void session_spec_of(const qmc__mb_integ *g, int low_first, qmc_session_spec *ss)
{
    qmc_session_spec_init(ss);
    ss->dims = SETUP(g, DIMS);
    ss->smoothness = (qmc_smoothness)SETUP(g, SMOOTHNESS);
    ss->max_batch = QMC_MODBUS_SESSION_BATCH;
    qmc_integrate_spec *is = &ss->integrate;
    static const struct {
        qmc_method method;
        int sampler; /* qmc_sampler, or -1 for auto */
    } methods[] = {
        [QMC_MODBUS_METHOD_MC] = {QMC_METHOD_MC, QMC_SAMPLER_MC},
        [QMC_MODBUS_METHOD_QMC] = {QMC_METHOD_QMC, QMC_SAMPLER_QMC},
        [QMC_MODBUS_METHOD_RQMC] = {QMC_METHOD_RQMC, QMC_SAMPLER_RQMC},
        [QMC_MODBUS_METHOD_AUTO] = {QMC_METHOD_AUTO, -1},
    };
    unsigned m = SETUP(g, METHOD);
    is->method = methods[m].method;
    if (methods[m].sampler >= 0)
        qmc_sampling_spec_init(&is->sampling, (qmc_sampler)methods[m].sampler);
    is->sampling.seed = u32_of(&SETUP(g, SEED_HI));
    uint32_t n = u32_of(&SETUP(g, N_HI));
    if (n) {
        is->sampling.n = n;
        is->n_given = 1;
        is->n_axis = n;
    }
    if (SETUP(g, REPS))
        is->sampling.reps = SETUP(g, REPS);
    is->sampling.confidence = SETUP(g, CONFIDENCE) / 1000.0;
    is->tol_abs = f32_of(&SETUP(g, TOL_ABS_0), low_first);
    is->tol_rel = f32_of(&SETUP(g, TOL_REL_0), low_first);
    is->max_evals = u32_of(&SETUP(g, BUDGET_HI));
    is->max_memory = QMC_MODBUS_SESSION_REGION_BYTES;
}

static uint64_t sat_add(uint64_t a, uint64_t b)
{
    return a > UINT64_MAX - b ? UINT64_MAX : a + b;
}

/* The next request number: 1, 2, ..., 2^32 - 1, 1, ... */
static uint32_t take_number(qmc__mb_integ *g)
{
    uint32_t n = g->next_request++;
    if (g->next_request == 0)
        g->next_request = 1;
    return n;
}

/* The session ended with code err (FAILED) or is over: keeps what the
 * status block shows and frees the rest. */
static void fail(qmc__mb_integ *g, int err)
{
    drop_session(g);
    g->status = QMC_MODBUS_INTEG_FAILED;
    g->err = err;
}

static void finish(qmc__mb_integ *g, qmc_session_end end)
{
    static const int status_of[] = {
        [QMC_SESSION_RUNNING] = QMC_MODBUS_INTEG_FAILED, /* never: count 0 means done */
        [QMC_SESSION_CONVERGED] = QMC_MODBUS_INTEG_CONVERGED,
        [QMC_SESSION_COMPLETE] = QMC_MODBUS_INTEG_COMPLETE,
        [QMC_SESSION_BUDGET] = QMC_MODBUS_INTEG_BUDGET,
        [QMC_SESSION_CANNOT_TELL] = QMC_MODBUS_INTEG_CANNOT_TELL,
        [QMC_SESSION_FAILED] = QMC_MODBUS_INTEG_FAILED,
    };
    qmc_integrate_report rep;
    int err = qmc_session_result(g->sess, &rep, NULL, 0);
    g->method_used = (int)rep.method_used + 1;
    if (err == 0 && end != QMC_SESSION_FAILED && end != QMC_SESSION_RUNNING) {
        g->has_final = 1;
        g->final = rep.res;
    }
    drop_session(g);
    g->status = status_of[end];
    g->err = err ? err : (end == QMC_SESSION_FAILED ? QMC_EINVAL : 0);
}

/* Takes the batch the session waits for, or its end.  A batch larger
 * than the values collected so far grows them within the bank's
 * allowance; past it the session fails (QMC_ETOOBIG, bytes needed). */
static void fetch_batch(qmc__mb_integ *g, const qmc_modbus_env *env)
{
    qmc_session_batch b;
    if (qmc_session_ask(g->sess, &b) != 0) {
        fail(g, QMC_EINVAL);
        return;
    }
    if (b.count == 0) {
        finish(g, b.end);
        return;
    }
    if (b.count > g->vals_cap) {
        uint64_t need = sat_add(g->sess_bytes, (uint64_t)b.count * sizeof *g->vals);
        if (need > (env ? env->integration_bytes_max : 0)) {
            fail(g, QMC_ETOOBIG);
            g->bytes_needed = need;
            return;
        }
        double *more = realloc(g->vals, b.count * sizeof *more);
        if (!more) {
            fail(g, QMC_ENOMEM);
            return;
        }
        g->vals = more;
        g->vals_cap = b.count;
    }
    g->batch = b;
    g->cursor = 0;
    g->request = take_number(g);
}

/* Opens the session the setup registers ask for, closing any other.  The
 * answer is the status register's, never an exception: the registers are
 * stored whatever it is. */
static void start(qmc__mb_integ *g, const uint16_t *hr, const qmc_modbus_env *env)
{
    drop_session(g);
    g->has_value = 0;
    g->err = 0;
    g->bytes_needed = 0;
    g->evals = g->nonfinite = 0;
    g->has_final = 0;
    g->method_used = 0;
    qmc_session_spec ss;
    session_spec_of(g, hr[QMC_MODBUS_HR_WORD_ORDER] == 1, &ss);
    /* The bound first: a start the bank cannot hold allocates nothing. */
    uint64_t bound = qmc_session_memory_bytes(&ss);
    uint64_t need = sat_add(bound, QMC_MODBUS_SESSION_BATCH * sizeof *g->vals);
    if (need > (env ? env->integration_bytes_max : 0)) {
        g->status = QMC_MODBUS_INTEG_NO_MEMORY;
        g->bytes_needed = need;
        g->refused++;
        return;
    }
    int err = qmc_session_new(&ss, &g->sess, NULL, 0);
    if (err) {
        g->status = err == QMC_ENOMEM ? QMC_MODBUS_INTEG_FAILED : QMC_MODBUS_INTEG_BAD_SETUP;
        g->err = err;
        return;
    }
    g->sess_bytes = bound;
    g->vals = malloc(QMC_MODBUS_SESSION_BATCH * sizeof *g->vals);
    if (!g->vals) {
        fail(g, QMC_ENOMEM);
        return;
    }
    g->vals_cap = QMC_MODBUS_SESSION_BATCH;
    if (ss.integrate.method != QMC_METHOD_AUTO)
        g->method_used = (int)ss.integrate.method + 1;
    g->status = QMC_MODBUS_INTEG_WAITING;
    fetch_batch(g, env);
}

/* The setup registers [addr, addr + count): range-checked, stored, and
 * a new start number acted on once all are stored. */
static int write_setup(qmc__mb_integ *g, const uint16_t *hr, const qmc_modbus_env *env,
                       unsigned addr, unsigned count, qmc__mb_rd *v)
{
    const unsigned first = addr - QMC_MODBUS_SETUP_BASE;
    if (count > QMC_MODBUS_SETUP_COUNT - first)
        return QMC_MODBUS_EX_ILLEGAL_ADDRESS; /* runs into 316.. */
    uint16_t fresh[QMC_MODBUS_SETUP_COUNT];
    memcpy(fresh, g->setup, sizeof fresh);
    for (unsigned i = 0; i < count; i++) {
        uint16_t x = qmc__mb_u16(v);
        if (x < setup_min[first + i] || x > setup_max[first + i])
            return QMC_MODBUS_EX_ILLEGAL_VALUE;
        fresh[first + i] = x;
    }
    const unsigned start_at = QMC_MODBUS_SETUP_START - QMC_MODBUS_SETUP_BASE;
    const int triggers = first <= start_at && first + count > start_at;
    /* The start number in force again: a retried start, acknowledged
     * with nothing changed (the other registers of the write included),
     * as register 10 is for points. */
    if (triggers && fresh[start_at] == g->setup[start_at])
        return 0;
    memcpy(g->setup, fresh, sizeof fresh);
    if (!triggers)
        return 0;
    if (fresh[start_at] == 0) {
        drop_session(g);
        g->status = QMC_MODBUS_INTEG_NONE;
        g->err = 0;
        g->has_final = 0;
        g->has_value = 0;
        g->method_used = 0;
        g->bytes_needed = 0;
        g->evals = g->nonfinite = 0;
        return 0;
    }
    start(g, hr, env);
    return 0;
}

/* The value write: request number and f at its point, exactly 320..323. */
static int write_value(qmc__mb_integ *g, const uint16_t *hr, const qmc_modbus_env *env,
                       unsigned addr, unsigned count, qmc__mb_rd *v)
{
    if (addr != QMC_MODBUS_VALUE_BASE || count != QMC_MODBUS_VALUE_COUNT)
        return QMC_MODBUS_EX_ILLEGAL_VALUE; /* a value comes whole, with its number */
    uint16_t w[QMC_MODBUS_VALUE_COUNT];
    for (unsigned i = 0; i < count; i++)
        w[i] = qmc__mb_u16(v);
    /* The write taken last, again: its reply was lost and the device
     * retries.  Acknowledged; nothing changes. */
    if (g->has_value && memcmp(w, g->value, sizeof w) == 0)
        return 0;
    if (g->status != QMC_MODBUS_INTEG_WAITING || u32_of(w) != g->request)
        return QMC_MODBUS_EX_ILLEGAL_VALUE; /* stale, future, or nothing waits */
    const double f = f32_of(&w[2], hr[QMC_MODBUS_HR_WORD_ORDER] == 1);
    memcpy(g->value, w, sizeof w);
    g->has_value = 1;
    g->vals[g->cursor++] = f;
    g->evals++;
    g->nonfinite += !isfinite(f);
    if (g->cursor < g->batch.count) {
        g->request = take_number(g);
        return 0;
    }
    /* The batch is complete: the integrator runs to its next one. */
    int err = qmc_session_tell(g->sess, g->batch.seq, g->vals, g->batch.count, NULL, 0);
    if (err) {
        fail(g, err); /* cannot happen: seq and count are the batch's */
        return 0;
    }
    fetch_batch(g, env);
    return 0;
}

int qmc__mb_integ_write(qmc__mb_integ *g, const uint16_t *hr, const qmc_modbus_env *env,
                        unsigned addr, unsigned count, qmc__mb_rd *v)
{
    if (addr >= QMC_MODBUS_SETUP_BASE && addr < QMC_MODBUS_SETUP_BASE + QMC_MODBUS_SETUP_COUNT)
        return write_setup(g, hr, env, addr, count, v);
    if (addr >= QMC_MODBUS_VALUE_BASE && addr < QMC_MODBUS_VALUE_BASE + QMC_MODBUS_VALUE_COUNT)
        return write_value(g, hr, env, addr, count, v);
    return QMC_MODBUS_EX_ILLEGAL_ADDRESS;
}

/* ---- the status block -------------------------------------------------------- */

void qmc__mb_integ_render(const qmc__mb_integ *g, const uint16_t *hr,
                          uint16_t out[QMC_MODBUS_INTEG_COUNT])
{
    const int low_first = hr[QMC_MODBUS_HR_WORD_ORDER] == 1;
    memset(out, 0, QMC_MODBUS_INTEG_COUNT * sizeof *out);
    out[QMC_MODBUS_IB_STATUS] = (uint16_t)g->status;
    out[QMC_MODBUS_IB_START] = SETUP(g, START);
    out[QMC_MODBUS_IB_ERROR] = (uint16_t)(g->err < 0 ? -g->err : 0);
    out[QMC_MODBUS_IB_METHOD_USED] = (uint16_t)g->method_used;
    uint64_t evals = g->evals, nonfinite = g->nonfinite;
    uint32_t flags = 0;
    int has_estimate = 0;
    qmc_result res;
    qmc_result_init(&res);
    if (g->status == QMC_MODBUS_INTEG_WAITING) {
        put_u32(&out[QMC_MODBUS_IB_REQUEST], g->request);
        const double *x = g->batch.points + g->cursor * g->batch.dims;
        uint16_t *r = &out[QMC_MODBUS_IB_POINT];
        for (uint32_t j = 0; j < g->batch.dims; j++)
            r += put_coord(r, x[j], hr[QMC_MODBUS_HR_FORMAT], low_first);
        qmc_session_report rep;
        qmc_session_status(g->sess, &rep);
        has_estimate = rep.has_estimate;
        res = rep.running;
        flags = rep.running.flags;
        if (g->nonfinite) /* as the session raises them, but before the batch is told */
            flags |= QMC_FLAG_NONFINITE | QMC_FLAG_ERROR_UNRELIABLE;
    } else if (g->has_final) {
        has_estimate = 1;
        res = g->final;
        flags = res.flags;
        evals = res.evals;
        nonfinite = res.nonfinite;
    }
    /* No estimate, or one without a bar (a single QMC run): NaN. */
    double est = has_estimate ? res.estimate : NAN;
    double bar = has_estimate && res.error_kind != QMC_ERROR_NONE
                     ? (res.ci_high - res.ci_low) / 2
                     : NAN;
    if (g->has_final)
        flags |= resolution_flags(&res, bar);
    qmc__mb_regs_u64(&out[QMC_MODBUS_IB_EVALS], evals);
    put_u32(&out[QMC_MODBUS_IB_FLAGS], flags);
    qmc__mb_regs_u64(&out[QMC_MODBUS_IB_NONFINITE], nonfinite);
    put_f32(&out[QMC_MODBUS_IB_ESTIMATE_F32], to_f32(est), low_first);
    put_f32(&out[QMC_MODBUS_IB_BAR_F32], to_f32(bar), low_first);
    put_f64(&out[QMC_MODBUS_IB_ESTIMATE_F64], est, low_first);
    put_f64(&out[QMC_MODBUS_IB_BAR_F64], bar, low_first);
    uint64_t bytes = g->status == QMC_MODBUS_INTEG_WAITING
                         ? sat_add(g->sess_bytes, (uint64_t)g->vals_cap * sizeof *g->vals)
                         : g->bytes_needed;
    qmc__mb_regs_u64(&out[QMC_MODBUS_IB_BYTES], bytes);
}

void qmc__mb_integ_usage(const qmc__mb_integ *g, qmc_modbus_usage *out)
{
    memset(out, 0, sizeof *out);
    out->integrations_refused = g->refused;
    if (g->sess) {
        out->integrating = 1;
        out->integration_bytes = sat_add(g->sess_bytes, (uint64_t)g->vals_cap * sizeof *g->vals);
    }
}
