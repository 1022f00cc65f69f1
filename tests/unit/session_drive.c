/*
 * session_drive.c - running integration sessions in the unit tests (see
 * session_drive.h): a built-in integrand answers every batch, and the
 * session's report is compared with qmc_integrate's field by field.
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hook.h"
#include "session_drive.h"

#define SAME(x, y) (memcmp(&(x), &(y), sizeof(x)) == 0)

problem session_test_make(const char *name, uint32_t dims, const double *a, const double *u)
{
    problem p;
    char why[256];
    int err = qmc_testfn_new(name, dims, a, a ? dims : 0, u, u ? dims : 0, &p.fn, why,
                             sizeof why);
    if (err)
        fail_msg("%s: %s", name, why);
    p.f = qmc_testfn_integrand(p.fn);
    return p;
}

/* ---- running a session ----------------------------------------------------- */

void session_test_spec(qmc_session_spec *ss, const qmc_integrate_spec *is, const qmc_integrand *f)
{
    qmc_session_spec_init(ss);
    ss->integrate = *is;
    ss->dims = f->dims;
    ss->smoothness = f->smoothness;
    ss->has_exact = f->has_exact;
    ss->exact = f->exact;
    if (f->name)
        snprintf(ss->name, sizeof ss->name, "%s", f->name);
}


void session_test_method(qmc_integrate_spec *is, const char *method)
{
    qmc_integrate_spec_init(is);
    assert_int_equal(qmc_method_parse(method, &is->method), 0);
    qmc_sampler sm;
    if (qmc_sampler_parse(method, &sm) == 0)
        qmc_sampling_spec_init(&is->sampling, sm);
}

qmc_session *session_test_open(qmc_session_spec *ss, const qmc_integrate_spec *is,
                               const qmc_integrand *f, uint64_t max_batch)
{
    session_test_spec(ss, is, f);
    ss->max_batch = max_batch;
    qmc_session *s = NULL;
    char why[256];
    int err = qmc_session_new(ss, &s, why, sizeof why);
    if (err)
        print_error("open: %s\n", why);
    assert_int_equal(err, 0);
    assert_non_null(s);
    return s;
}

void session_test_tell(qmc_session *s, const qmc_integrand *f, const qmc_session_batch *b,
                       answer_buf *buf)
{
    if (b->count > buf->cap) {
        buf->cap = b->count;
        buf->vals = realloc(buf->vals, buf->cap * sizeof *buf->vals);
        assert_non_null(buf->vals);
    }
    f->eval(f->ctx, b->points, b->count, b->dims, buf->vals);
    char why[256];
    int err = qmc_session_tell(s, b->seq, buf->vals, b->count, why, sizeof why);
    if (err)
        print_error("tell: %s\n", why);
    assert_int_equal(err, 0);
}

size_t session_test_answer(qmc_session *s, const qmc_integrand *f, qmc_session_batch *b,
                           answer_buf *buf)
{
    assert_int_equal(qmc_session_ask(s, b), 0);
    if (b->count)
        session_test_tell(s, f, b, buf);
    return b->count;
}

outcome session_test_outcome(qmc_session *s)
{
    outcome o;
    memset(&o, 0, sizeof o);
    o.err = qmc_session_result(s, &o.rep, o.why, sizeof o.why);
    qmc_session_status(s, &o.status);
    return o;
}

/* Asks s for its batch into b, the n-th the driver has had (the first's
 * number kept in seq0): 0 once the session is done (its end reason
 * set), else 1 with b running, numbered in order and of f's dims. */
static int ask_in_order(qmc_session *s, const qmc_integrand *f, qmc_session_batch *b,
                        uint64_t n, uint64_t *seq0)
{
    assert_int_equal(qmc_session_ask(s, b), 0);
    if (b->count == 0) {
        assert_int_not_equal(b->end, QMC_SESSION_RUNNING);
        return 0;
    }
    assert_int_equal(b->end, QMC_SESSION_RUNNING);
    if (n == 0)
        *seq0 = b->seq;
    assert_int_equal(b->seq, *seq0 + n); /* numbered in order */
    assert_int_equal(b->dims, f->dims);
    return 1;
}

/* Answers every batch with f until the session is done. */
outcome session_test_drive(qmc_session *s, const qmc_integrand *f)
{
    answer_buf buf = {NULL, 0};
    uint64_t batches = 0, largest = 0, seq0 = 0;
    for (;;) {
        qmc_session_batch b;
        if (!ask_in_order(s, f, &b, batches, &seq0))
            break;
        session_test_tell(s, f, &b, &buf);
        batches++;
        largest = b.count > largest ? b.count : largest;
    }
    free(buf.vals);
    outcome o = session_test_outcome(s);
    o.batches = batches;
    o.largest = largest;
    qmc_session_batch done;
    assert_int_equal(qmc_session_ask(s, &done), 0);
    assert_int_equal(done.end, o.status.end);
    return o;
}

/* As session_test_drive, each batch told ahead (qmc_session_tell_ahead):
 * the values of even batches caught up at once (then their buffer is
 * scribbled over: nothing may read it later), those of odd batches left
 * for the next tell to sum.  Two value buffers in turn, as a client
 * evaluating batch k + 1 while k's values wait. */
void session_test_drive_ahead(qmc_session *s, const qmc_integrand *f, outcome *o)
{
    double *vals[2] = {NULL, NULL};
    size_t cap[2] = {0, 0};
    o->batches = o->largest = o->behind = 0;
    uint64_t seq0 = 0;
    for (;;) {
        qmc_session_batch b;
        if (!ask_in_order(s, f, &b, o->batches, &seq0))
            break;
        /* Only this batch's buffer grows: the other may hold values told
         * ahead, still to be summed. */
        const int w = (int)(o->batches % 2);
        if (b.count > cap[w]) {
            free(vals[w]);
            cap[w] = b.count;
            vals[w] = malloc(cap[w] * sizeof *vals[w]);
            assert_non_null(vals[w]);
        }
        double *v = vals[w];
        f->eval(f->ctx, b.points, b.count, b.dims, v);
        char why[256];
        int err = qmc_session_tell_ahead(s, b.seq, v, b.count, NULL, 0, why, sizeof why);
        if (err)
            fail_msg("tell ahead: %s", why);
        qmc_session_report st;
        qmc_session_status(s, &st);
        assert_int_equal(st.batches, o->batches + 1); /* told, summed or not */
        if (qmc_session_behind(s)) {
            o->behind++;
            qmc_session_batch next;
            assert_int_equal(qmc_session_ask(s, &next), 0);
            assert_int_equal(next.seq, b.seq + 1); /* handed out before the sums */
            assert_true(next.count > 0);
            if (o->batches % 2 == 0) {
                qmc_session_catch_up(s);
                assert_false(qmc_session_behind(s));
                memset(v, 0xff, b.count * sizeof *v); /* NaNs, read by no one */
            }
        }
        o->batches++;
        o->largest = b.count > o->largest ? b.count : o->largest;
    }
    assert_false(qmc_session_behind(s));
    free(vals[0]);
    free(vals[1]);
    o->err = qmc_session_result(s, &o->rep, o->why, sizeof o->why);
    qmc_session_status(s, &o->status);
}

/* Opens a session on ss, drives it (each batch told ahead or not) and
 * frees it: the one opening both drivers below share. */
static outcome via_session(const qmc_session_spec *ss, const qmc_integrand *f, int ahead)
{
    outcome o;
    memset(&o, 0, sizeof o);
    qmc_session *s = NULL;
    o.err = qmc_session_new(ss, &s, o.why, sizeof o.why);
    if (o.err)
        return o;
    if (ahead)
        session_test_drive_ahead(s, f, &o);
    else
        o = session_test_drive(s, f);
    qmc_session_free(s);
    return o;
}

outcome session_test_via_session_ahead(const qmc_session_spec *ss, const qmc_integrand *f)
{
    return via_session(ss, f, 1);
}

outcome session_test_via_session(const qmc_session_spec *ss, const qmc_integrand *f)
{
    return via_session(ss, f, 0);
}

outcome session_test_via_integrate(const qmc_integrate_spec *is, const qmc_integrand *f)
{
    outcome o;
    memset(&o, 0, sizeof o);
    o.err = qmc_integrate(is, f, NULL, NULL, NULL, &o.rep, o.why, sizeof o.why);
    return o;
}


/* Every field of the two reports, and the return value. */
void session_test_assert_same(const outcome *a, const outcome *b, const char *what)
{
    if (a->err != b->err)
        fail_msg("%s: err %d vs %d (%s / %s)", what, a->err, b->err, a->why, b->why);
    if (!test_same_result(&a->rep.res, &b->rep.res))
        fail_msg("%s: results differ: %.17g +- %.17g (%llu evals, flags %x) vs %.17g +- %.17g "
                 "(%llu evals, flags %x)", what, a->rep.res.estimate, a->rep.res.error,
                 (unsigned long long)a->rep.res.evals, a->rep.res.flags, b->rep.res.estimate,
                 b->rep.res.error, (unsigned long long)b->rep.res.evals, b->rep.res.flags);
    assert_true(SAME(a->rep.cv, b->rep.cv));
    assert_int_equal(a->rep.method_used, b->rep.method_used);
    const qmc_sampling_spec *x = &a->rep.sampling, *y = &b->rep.sampling;
    assert_true(x->sampler == y->sampler && x->seq == y->seq && x->scramble == y->scramble &&
                x->seq_flags == y->seq_flags && x->seed == y->seed && x->n == y->n &&
                x->reps == y->reps && SAME(x->confidence, y->confidence) &&
                x->split_net == y->split_net);
    assert_string_equal(a->rep.detail, b->rep.detail);
    assert_string_equal(a->rep.auto_reason, b->rep.auto_reason);
    if (a->err)
        assert_string_equal(a->why, b->why);
}

