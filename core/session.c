/*
 * session.c - integration sessions, the caller's side (see qmc/session.h
 * and docs/SESSIONS.md): open, ask, tell, status, result, close, and the
 * memory bound.  The integrator runs on the session's fiber
 * (session_run.c); every call here that moves it on resumes the fiber and
 * returns once it waits for its next batch or has finished.
 *
 * Must not: evaluate anything itself, keep a thread, or read the caller's
 * values after tell returns.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "integrate_memory.h"
#include "msg.h"
#include "session_impl.h"

void qmc_session_spec_init(qmc_session_spec *spec)
{
    memset(spec, 0, sizeof *spec);
    spec->smoothness = QMC_SMOOTH_CONTINUOUS;
    qmc_integrate_spec_init(&spec->integrate);
}

const char *qmc_session_end_key(qmc_session_end e)
{
    switch (e) {
#define QMC__SESSION_END_KEY(name, key, text) \
    case QMC_SESSION_##name:                  \
        return key;
        QMC_SESSION_END_MAP(QMC__SESSION_END_KEY)
#undef QMC__SESSION_END_KEY
    }
    return "";
}

const char *qmc_session_end_text(qmc_session_end e)
{
    switch (e) {
#define QMC__SESSION_END_TEXT(name, key, text) \
    case QMC_SESSION_##name:                   \
        return text;
        QMC_SESSION_END_MAP(QMC__SESSION_END_TEXT)
#undef QMC__SESSION_END_TEXT
    }
    return "";
}

static int is_sampling(qmc_method m)
{
    return m == QMC_METHOD_MC || m == QMC_METHOD_STRATIFIED || m == QMC_METHOD_LHS ||
           m == QMC_METHOD_QMC || m == QMC_METHOD_RQMC;
}

/* Whether the integrator may run the sampling engine (and so the block
 * runner, which needs the batch buffer and a block workspace). */
static int may_sample(const qmc_session_spec *spec)
{
    return is_sampling(spec->integrate.method) || spec->integrate.method == QMC_METHOD_AUTO;
}

/* The points of the largest batch the session assembles. */
static uint64_t batch_points(const qmc_session_spec *spec)
{
    if (spec->max_batch)
        return spec->max_batch;
    uint64_t fit = QMC_SESSION_BATCH_BYTES / (((uint64_t)spec->dims + 1) * sizeof(double));
    return fit < QMC_SESSION_MAX_BATCH ? (fit ? fit : 1) : QMC_SESSION_MAX_BATCH;
}

static uint64_t sat_add(uint64_t a, uint64_t b)
{
    return a > UINT64_MAX - b ? UINT64_MAX : a + b;
}

static uint64_t sat_mul(uint64_t a, uint64_t b)
{
    return b && a > UINT64_MAX / b ? UINT64_MAX : a * b;
}

/* The caller's declarations as an integrand (eval filled in by open). */
static qmc_integrand declared(const qmc_session_spec *spec)
{
    qmc_integrand f;
    memset(&f, 0, sizeof f);
    f.dims = spec->dims;
    f.smoothness = spec->smoothness;
    f.has_exact = spec->has_exact;
    f.exact = spec->exact;
    return f;
}

/* A part's block count (whole job's blocks cut as --part does), or 0 -
 * also for a part that is not k/p, which qmc_session_new refuses (a
 * server sizes a request before it opens it: k = 0 must not wrap). */
static uint64_t part_blocks(const qmc_session_spec *spec)
{
    if (!spec->part_p || spec->part_k == 0 || spec->part_k > spec->part_p)
        return 0;
    qmc_sampling_spec q;
    if (qmc__fixed_sampling_spec(&spec->integrate, spec->dims, &q, NULL, 0) != 0)
        return 0;
    const uint64_t nb = q.reps * ((q.n + QMC_SAMPLING_BLOCK - 1) / QMC_SAMPLING_BLOCK);
    return nb * spec->part_k / spec->part_p - nb * (spec->part_k - 1) / spec->part_p + 1;
}

uint64_t qmc_session_memory_bytes(const qmc_session_spec *spec)
{
    qmc_integrand f = declared(spec);
    uint64_t bytes = qmc_integrate_memory_bytes_for(&spec->integrate, &f, NULL);
    bytes = sat_add(bytes, sizeof(qmc_session) + qmc__fiber_bytes(QMC__FIBER_STACK_BYTES));
    if (may_sample(spec) || spec->part_p) {
        uint64_t batch = sat_mul(batch_points(spec), ((uint64_t)spec->dims + 1) * sizeof(double));
        bytes = sat_add(bytes, batch);
        bytes = sat_add(bytes, qmc__sampling_workspace_bytes_for(spec->dims));
    }
    if (spec->part_p) {
        bytes = sat_add(bytes, sat_mul(part_blocks(spec), sizeof(qmc_sampling_sums)));
        bytes = sat_add(bytes, 4 * ((uint64_t)spec->dims + 1) * sizeof(double)); /* probes */
    }
    return bytes;
}

static int check_spec(const qmc_session_spec *spec, qmc__msg *why)
{
    if (spec->dims == 0 || spec->dims > QMC_SESSION_MAX_DIMS) {
        qmc__msg_set(why, "a session needs dims in 1..", QMC_SESSION_MAX_DIMS, ", not ");
        qmc__msg_u64(why, spec->dims);
        return spec->dims == 0 ? QMC_EINVAL : QMC_EDIMS;
    }
    if ((unsigned)spec->smoothness > QMC_SMOOTH_SINGULAR) {
        qmc__msg_str(why, "smoothness is analytic, continuous, discontinuous or singular");
        return QMC_EINVAL;
    }
    if (!memchr(spec->name, '\0', sizeof spec->name)) {
        qmc__msg_set(why, "the name takes at most ", QMC_SESSION_NAME_BYTES - 1, " bytes");
        return QMC_EINVAL;
    }
    if (spec->has_exact != 0 && spec->has_exact != 1) {
        qmc__msg_str(why, "has_exact is 0 or 1");
        return QMC_EINVAL;
    }
    if ((spec->part_p == 0) != (spec->part_k == 0) || spec->part_k > spec->part_p) {
        qmc__msg_set(why, "part ", spec->part_k, "/");
        qmc__msg_u64(why, spec->part_p);
        qmc__msg_str(why, " is not k/p with 1 <= k <= p (0/0: the whole job)");
        return QMC_EINVAL;
    }
    if (spec->part_p) {
        qmc_sampling_spec q;
        return qmc__fixed_sampling_spec(&spec->integrate, spec->dims, &q, why->buf, why->cap);
    }
    return 0;
}

/* After the fiber stopped: the answer, once it has finished. */
static void settle(qmc_session *s)
{
    if (!s->finished)
        return;
    s->pending = 0;
    s->has_estimate = s->err == 0 && !s->spec.part_p;
    if (s->has_estimate)
        s->running = s->rep.res;
}

int qmc__session_new(const qmc_session_spec *spec, int paint, qmc_session **out, char *why,
                     size_t why_bytes)
{
    qmc__msg m;
    qmc__msg_init(&m, why, why_bytes);
    *out = NULL;
    if (!spec) {
        qmc__msg_str(&m, "no spec");
        return QMC_EINVAL;
    }
    int err = check_spec(spec, &m);
    if (err)
        return err;
    qmc_session *s = calloc(1, sizeof *s);
    if (!s)
        goto nomem;
    s->spec = *spec;
    s->f = declared(spec);
    s->f.eval = NULL;
    s->f.name = s->spec.name;
    s->f.ctx = s;
    qmc_result_init(&s->running);
    s->running.dims = spec->dims;
    s->mode = MODE_DIRECT;
    s->max_batch = batch_points(spec);
    if (may_sample(spec) || spec->part_p) {
        const uint64_t pts = s->max_batch;
        if (pts <= SIZE_MAX / sizeof(double) / (spec->dims + 1)) {
            s->buf = malloc(pts * spec->dims * sizeof *s->buf);
            s->vals = malloc(pts * sizeof *s->vals);
        }
        s->ws_bytes = qmc__sampling_workspace_bytes_for(spec->dims);
        s->ws = malloc(s->ws_bytes);
        if (!s->buf || !s->vals || !s->ws)
            goto nomem;
    }
    s->collect = s->buf;
    s->fiber = qmc__fiber_new(QMC__FIBER_STACK_BYTES, qmc__session_main, s, paint);
    if (!s->fiber)
        goto nomem;
    qmc__fiber_resume(s->fiber);
    settle(s);
    if (s->finished && s->err) {
        /* Refused before the first point, as qmc_integrate refuses it. */
        qmc__msg_str(&m, s->why);
        err = s->err;
        qmc_session_free(s);
        return err;
    }
    *out = s;
    return 0;
nomem:
    qmc_session_free(s);
    qmc__msg_init(&m, why, why_bytes);
    qmc__msg_str(&m, "out of memory for the session");
    return QMC_ENOMEM;
}

int qmc_session_new(const qmc_session_spec *spec, qmc_session **out, char *why,
                    size_t why_bytes)
{
    return qmc__session_new(spec, 0, out, why, why_bytes);
}

size_t qmc__session_stack_used(const qmc_session *s)
{
    return qmc__fiber_stack_used(s->fiber);
}

void qmc_session_free(qmc_session *s)
{
    if (!s)
        return;
    if (s->fiber && !s->finished) {
        /* Unwind the integrator: every batch it asks for now is answered
         * with zeros at once, its interrupt hook fires at its next poll
         * (at most QMC_INTERRUPT_EVALS evaluations on), and it returns
         * QMC_ECANCELED, freeing what it holds on the way. */
        s->closing = 1;
        while (qmc__fiber_resume(s->fiber))
            ;
    }
    qmc__fiber_free(s->fiber);
    free(s->buf);
    free(s->vals);
    free(s->ws);
    free(s->part_sums);
    free(s);
}

static qmc_session_end end_of(const qmc_session *s);

int qmc_session_ask(qmc_session *s, qmc_session_batch *batch)
{
    if (!batch)
        return QMC_EINVAL;
    memset(batch, 0, sizeof *batch);
    if (!s)
        return QMC_EINVAL;
    batch->dims = s->spec.dims;
    if (!s->pending) {
        batch->end = end_of(s); /* done */
        return 0;
    }
    s->served = 1;
    batch->seq = s->seq;
    batch->points = s->points;
    batch->count = s->count;
    return 0;
}

/* The checks of tell, leaving the session as it was on a refusal. */
static int tell_check(qmc_session *s, uint64_t seq, const double *values, size_t count,
                      qmc__msg *m)
{
    if (!s) {
        qmc__msg_str(m, "no session");
        return QMC_EINVAL;
    }
    if (!s->pending) {
        qmc__msg_str(m, "the session is done: no batch is waiting for values");
        return QMC_EINVAL;
    }
    if (seq < s->seq) { /* a late answer, or a retry of one that got through */
        qmc__msg_set(m, "batch ", seq, " was answered already; batch ");
        qmc__msg_u64(m, s->seq);
        qmc__msg_str(m, " is waiting");
        return QMC_EINVAL;
    }
    if (!s->served) {
        qmc__msg_set(m, "batch ", s->seq, " has not been handed out: ask for it first");
        return QMC_EINVAL;
    }
    if (seq != s->seq) {
        qmc__msg_set(m, "batch ", seq, " has not been handed out yet; batch ");
        qmc__msg_u64(m, s->seq);
        qmc__msg_str(m, " is waiting");
        return QMC_EINVAL;
    }
    if (count != s->count) {
        qmc__msg_set(m, "batch ", s->seq, " has ");
        qmc__msg_u64(m, s->count);
        qmc__msg_str(m, " points; got ");
        qmc__msg_u64(m, count);
        qmc__msg_str(m, " values");
        return QMC_EINVAL;
    }
    if (!values) {
        qmc__msg_str(m, "no values");
        return QMC_EINVAL;
    }
    return 0;
}

/* How many of n values are NaN or infinite: an all-ones exponent, tested
 * on the bits so that the loop vectorizes (isfinite's does not here). */
static uint64_t count_nonfinite(const double *v, size_t n)
{
    uint64_t bad = 0;
    for (size_t i = 0; i < n; i++) {
        uint64_t bits;
        memcpy(&bits, &v[i], sizeof bits);
        bad += (bits & 0x7ff0000000000000ull) == 0x7ff0000000000000ull;
    }
    return bad;
}

/* 1 when [p, p + n doubles) and [q, q + m doubles) share a byte.  Compared
 * as integers: the buffers may be unrelated objects. */
static int overlaps(const double *p, size_t n, const double *q, size_t m)
{
    const uintptr_t a = (uintptr_t)p, b = (uintptr_t)q;
    return a < b + m * sizeof *q && b < a + n * sizeof *p;
}

/* Takes the values and runs the integrator on to its next batch (or, told
 * early, until the next batch is handed out). */
static void tell_run(qmc_session *s, const double *values, size_t count, int early)
{
    if (s->collected) {
        /* A group of whole blocks is replayed from the caller's values
         * where they are (read only, before tell returns, or before
         * catch_up after a tell ahead) - unless they sit where the next
         * group is collected, which would overwrite them first. */
        s->src = values;
        if (s->collect && overlaps(values, count, s->collect, s->max_batch * s->spec.dims)) {
            memcpy(s->vals, values, count * sizeof *values);
            s->src = s->vals;
        }
    } else {
        /* memmove: a caller may hand back a buffer of its own that
         * overlaps nothing of ours, but nothing stops it from passing ours. */
        memmove(s->out, values, count * sizeof *values);
    }
    s->nonfinite += count_nonfinite(values, count);
    s->evals += count;
    s->batches++;
    s->seq++;
    s->pending = 0;
    s->served = 0;
    s->early = early;
    qmc__fiber_resume(s->fiber);
    s->early = 0;
    settle(s);
}

void qmc_session_catch_up(qmc_session *s)
{
    if (!s || !s->behind)
        return;
    qmc__fiber_resume(s->fiber); /* the replay, up to the wait for the next values */
    settle(s);
}

int qmc_session_behind(const qmc_session *s)
{
    return s && s->behind;
}

/* tell, tell_to and tell_ahead: next NULL is the session's own buffer. */
static int tell_common(qmc_session *s, uint64_t seq, const double *values, size_t count,
                       double *next, size_t next_points, int with_next, int early, char *why,
                       size_t why_bytes)
{
    qmc__msg m;
    qmc__msg_init(&m, why, why_bytes);
    /* A tell ahead's values are summed first: the fiber waits there. */
    qmc_session_catch_up(s);
    int err = tell_check(s, seq, values, count, &m);
    if (err)
        return err;
    if (with_next && next && (!s->buf || next_points < s->max_batch)) {
        qmc__msg_set(&m, "a batch buffer of ", next_points, " points; the session assembles ");
        qmc__msg_u64(&m, s->buf ? s->max_batch : 0);
        qmc__msg_str(&m, s->buf ? " at once" : " none");
        return QMC_EINVAL;
    }
    s->collect = next ? next : s->buf;
    tell_run(s, values, count, early);
    return 0;
}

int qmc_session_tell(qmc_session *s, uint64_t seq, const double *values, size_t count,
                     char *why, size_t why_bytes)
{
    return tell_common(s, seq, values, count, NULL, 0, 0, 0, why, why_bytes);
}

int qmc_session_tell_to(qmc_session *s, uint64_t seq, const double *values, size_t count,
                        double *next, size_t next_points, char *why, size_t why_bytes)
{
    return tell_common(s, seq, values, count, next, next_points, 1, 0, why, why_bytes);
}

int qmc_session_tell_ahead(qmc_session *s, uint64_t seq, const double *values, size_t count,
                           double *next, size_t next_points, char *why, size_t why_bytes)
{
    return tell_common(s, seq, values, count, next, next_points, 1, 1, why, why_bytes);
}

void qmc_session_own_batch(qmc_session *s)
{
    /* Values told ahead may sit in the buffer that goes: summed first. */
    qmc_session_catch_up(s);
    if (!s || s->collect == s->buf)
        return;
    if (s->pending && s->points == s->collect) {
        memcpy(s->buf, s->points, s->count * s->spec.dims * sizeof *s->buf);
        s->points = s->buf;
    }
    s->collect = s->buf;
}

static qmc_session_end end_of(const qmc_session *s)
{
    if (!s->finished)
        return QMC_SESSION_RUNNING;
    if (s->err)
        return QMC_SESSION_FAILED;
    if (s->spec.part_p)
        return QMC_SESSION_COMPLETE;
    const uint32_t flags = s->rep.res.flags;
    if (flags & (QMC_FLAG_ERROR_UNRELIABLE | QMC_FLAG_NONFINITE))
        return QMC_SESSION_CANNOT_TELL;
    if (flags & (QMC_FLAG_NOT_CONVERGED | QMC_FLAG_BUDGET | QMC_FLAG_MAX_SUBDIV |
                 QMC_FLAG_MEMORY_BOUND))
        return QMC_SESSION_BUDGET;
    /* Stopped by a tolerance: auto always, the adaptive rules with their
     * default one, sampling methods when given one. */
    const qmc_integrate_spec *is = &s->spec.integrate;
    const int adaptive = is->method == QMC_METHOD_AUTO ||
                         is->method == QMC_METHOD_GAUSS_KRONROD ||
                         is->method == QMC_METHOD_CUBATURE ||
                         is->method == QMC_METHOD_CLENSHAW_CURTIS ||
                         (is_sampling(is->method) && (is->tol_abs > 0 || is->tol_rel > 0));
    return adaptive ? QMC_SESSION_CONVERGED : QMC_SESSION_COMPLETE;
}

void qmc_session_status(const qmc_session *s, qmc_session_report *out)
{
    memset(out, 0, sizeof *out);
    qmc_result_init(&out->running);
    if (!s)
        return;
    out->end = end_of(s);
    out->err = s->finished ? s->err : 0;
    out->batches = s->batches;
    out->evals = s->evals;
    out->nonfinite = s->nonfinite;
    out->has_estimate = s->has_estimate;
    if (s->has_estimate) {
        out->running = s->running;
        if (s->finished)
            return; /* the final result, as it is */
    }
    out->running.dims = s->spec.dims;
    out->running.evals = s->evals;
    if (s->nonfinite)
        out->running.flags |= QMC_FLAG_NONFINITE | QMC_FLAG_ERROR_UNRELIABLE;
}

int qmc_session_result(const qmc_session *s, qmc_integrate_report *rep, char *why,
                       size_t why_bytes)
{
    qmc__msg m;
    qmc__msg_init(&m, why, why_bytes);
    memset(rep, 0, sizeof *rep);
    qmc_result_init(&rep->res);
    if (!s) {
        qmc__msg_str(&m, "no session");
        return QMC_EINVAL;
    }
    if (!s->finished) {
        qmc__msg_str(&m, "the session is still running: ask for its next batch");
        return QMC_EAGAIN;
    }
    *rep = s->rep;
    qmc__msg_str(&m, s->why);
    return s->err;
}

int qmc_session_part(const qmc_session *s, qmc_session_part_sums *out)
{
    memset(out, 0, sizeof *out);
    if (!s || !s->spec.part_p)
        return QMC_EINVAL;
    if (!s->finished)
        return QMC_EAGAIN;
    if (s->err)
        return s->err;
    *out = s->part;
    return 0;
}
