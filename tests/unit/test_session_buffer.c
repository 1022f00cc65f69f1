/*
 * test_session_buffer.c - qmc_session_tell_to and qmc_session_own_batch:
 * batches assembled in a caller's buffers (as qmcd assembles them in its
 * client's ring slots) give qmc_integrate's result bit for bit; ask hands
 * out exactly the caller's buffer; what another party writes there after
 * the batch is handed out changes nothing the session computes; own_batch
 * moves a waiting batch home before its buffer goes; and the refusals
 * leave the session as it was.  qmc_session_tell_ahead: the next batch is
 * handed out before the told one is summed, with the same bytes, only
 * the job's batches, and a refusal, own_batch or free while behind.
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "qmc/session.h"
#include "session_drive.h"

enum { DIMS = 3 };

static qmc_integrate_spec rqmc_spec(void)
{
    qmc_integrate_spec is;
    qmc_integrate_spec_init(&is);
    is.method = QMC_METHOD_RQMC;
    qmc_sampling_spec_init(&is.sampling, QMC_SAMPLER_RQMC);
    is.sampling.n = 8192;
    is.sampling.reps = 8;
    is.n_given = 1;
    return is;
}

/* Drives s to its end with its batches assembled in the caller's n
 * buffers in turn (ring slots: batch k in bufs[k % n], checked), counting
 * the batches in o.  Told plainly (tell_to), each batch's points are
 * scribbled over once its values are computed, as a careless or hostile
 * client could.  Told ahead (tell_ahead, as qmcd does: the client holds
 * batch k's slot while k + 1 is collected), each is caught up at once and
 * its values scribbled once summed; the tells that came back behind are
 * counted in o->behind. */
static void drive_ring(qmc_session *s, const qmc_integrand *f, double *const *bufs, size_t n,
                       size_t cap, int ahead, outcome *o)
{
    double *vals = malloc(cap * sizeof *vals);
    assert_non_null(vals);
    memset(o, 0, sizeof *o);
    for (uint64_t k = 0;; k++) {
        qmc_session_batch bt;
        assert_int_equal(qmc_session_ask(s, &bt), 0);
        if (bt.count == 0)
            break;
        if (k > 0) /* batch k was assembled where the tell before said */
            assert_ptr_equal(bt.points, bufs[k % n]);
        f->eval(f->ctx, bt.points, bt.count, bt.dims, vals);
        double *next = bufs[(k + 1) % n];
        if (!ahead) {
            memset((void *)bt.points, 0xff, bt.count * bt.dims * sizeof(double)); /* NaNs */
            assert_int_equal(qmc_session_tell_to(s, bt.seq, vals, bt.count, next, cap, o->why,
                                                 sizeof o->why),
                             0);
        } else {
            assert_int_equal(qmc_session_tell_ahead(s, bt.seq, vals, bt.count, next, cap,
                                                    o->why, sizeof o->why),
                             0);
            if (qmc_session_behind(s)) {
                o->behind++;
                qmc_session_catch_up(s);
                assert_false(qmc_session_behind(s));
            }
            memset(vals, 0xff, cap * sizeof *vals); /* summed: nobody reads them again */
        }
        o->batches++;
    }
    o->err = qmc_session_result(s, &o->rep, o->why, sizeof o->why);
    qmc_session_status(s, &o->status);
    free(vals);
}

static void test_same_bytes(void **state)
{
    (void)state;
    problem p = session_test_make("genz-gaussian", DIMS, NULL, NULL);
    qmc_integrate_spec is = rqmc_spec();
    outcome want = session_test_via_integrate(&is, p.f);
    for (uint64_t max_batch = 4096; max_batch <= 65536; max_batch *= 4) {
        size_t cap = (size_t)max_batch;
        double *a = malloc(cap * DIMS * sizeof *a), *b = malloc(cap * DIMS * sizeof *b);
        assert_non_null(a);
        assert_non_null(b);
        qmc_session_spec ss;
        qmc_session *s = session_test_open(&ss, &is, p.f, max_batch);
        double *const ring[2] = {b, a}; /* batch 1 in a, 2 in b, ... */
        outcome got;
        drive_ring(s, p.f, ring, 2, cap, 0, &got);
        session_test_assert_same(&got, &want, "rqmc through two caller buffers");
        assert_int_equal(got.batches, 65536 / max_batch); /* 8 x 8192 points */
        qmc_session_free(s);
        free(a);
        free(b);
    }
    qmc_testfn_free(p.fn);
}

/* own_batch: the waiting batch moves into the session's own buffer, the
 * same points; scribbling the caller's buffer afterwards changes nothing. */
static void test_own_batch(void **state)
{
    (void)state;
    problem p = session_test_make("genz-oscillatory", DIMS, NULL, NULL);
    qmc_integrate_spec is = rqmc_spec();
    outcome want = session_test_via_integrate(&is, p.f);
    const size_t cap = 16384;
    double *slot = malloc(cap * DIMS * sizeof *slot), *copy = malloc(cap * DIMS * sizeof *copy);
    double *vals = malloc(cap * sizeof *vals);
    assert_true(slot && copy && vals);
    qmc_session_spec ss;
    qmc_session *s = session_test_open(&ss, &is, p.f, cap);
    char why[256];
    qmc_session_batch b;
    assert_int_equal(qmc_session_ask(s, &b), 0);
    p.f->eval(p.f->ctx, b.points, b.count, b.dims, vals);
    assert_int_equal(qmc_session_tell_to(s, b.seq, vals, b.count, slot, cap, why, sizeof why), 0);
    assert_int_equal(qmc_session_ask(s, &b), 0);
    assert_ptr_equal(b.points, slot);
    memcpy(copy, b.points, b.count * DIMS * sizeof *copy);
    qmc_session_own_batch(s);
    memset(slot, 0xff, cap * DIMS * sizeof *slot);
    qmc_session_batch again;
    assert_int_equal(qmc_session_ask(s, &again), 0);
    assert_true(again.points != slot && again.seq == b.seq && again.count == b.count);
    assert_memory_equal(again.points, copy, b.count * DIMS * sizeof *copy);
    outcome got = session_test_drive(s, p.f);
    session_test_assert_same(&got, &want, "rqmc after own_batch");
    qmc_session_own_batch(s); /* done: a no-op */
    qmc_session_own_batch(NULL);
    qmc_session_free(s);
    free(slot);
    free(copy);
    free(vals);
    qmc_testfn_free(p.fn);
}

/* Refusals take nothing: the same batch still waits. */
static void test_refusals(void **state)
{
    (void)state;
    problem p = session_test_make("genz-gaussian", DIMS, NULL, NULL);
    qmc_integrate_spec is = rqmc_spec();
    double *buf = malloc(8192 * DIMS * sizeof *buf), *vals = calloc(8192, sizeof *vals);
    assert_true(buf && vals);
    qmc_session_spec ss;
    qmc_session *s = session_test_open(&ss, &is, p.f, 8192);
    char why[256];
    qmc_session_batch b;
    assert_int_equal(qmc_session_ask(s, &b), 0);
    assert_int_equal(qmc_session_tell_to(s, b.seq, vals, b.count, buf, 8191, why, sizeof why),
                     QMC_EINVAL);
    assert_non_null(strstr(why, "8191"));
    assert_int_equal(qmc_session_tell_to(s, b.seq + 1, vals, b.count, buf, 8192, why,
                                         sizeof why),
                     QMC_EINVAL);
    qmc_session_batch same;
    assert_int_equal(qmc_session_ask(s, &same), 0);
    assert_true(same.seq == b.seq && same.points == b.points && same.count == b.count);
    qmc_session_free(s);
    /* A rule assembles no batches: no buffer of its own to stand in for. */
    problem q = session_test_make("exp", 1, NULL, NULL);
    qmc_integrate_spec gk;
    session_test_method(&gk, "gauss-kronrod");
    s = session_test_open(&ss, &gk, q.f, 0);
    assert_int_equal(qmc_session_ask(s, &b), 0);
    assert_int_equal(qmc_session_tell_to(s, b.seq, vals, b.count, buf, 8192, why, sizeof why),
                     QMC_EINVAL);
    assert_non_null(strstr(why, "none"));
    /* NULL: the session's own buffer, as plain tell. */
    q.f->eval(q.f->ctx, b.points, b.count, b.dims, vals);
    assert_int_equal(qmc_session_tell_to(s, b.seq, vals, b.count, NULL, 0, why, sizeof why), 0);
    qmc_session_free(s);
    free(buf);
    free(vals);
    qmc_testfn_free(p.fn);
    qmc_testfn_free(q.fn);
}

/* ---- telling ahead ---------------------------------------------------------- */

/* A fixed job's groups are all known: every tell but the last comes back
 * behind, the result is the same bytes, and only the job's batches are
 * ever handed out (the status counts exactly the job's evaluations). */
static void test_ahead_same_bytes(void **state)
{
    (void)state;
    problem p = session_test_make("genz-gaussian", DIMS, NULL, NULL);
    qmc_integrate_spec is = rqmc_spec();
    outcome want = session_test_via_integrate(&is, p.f);
    const size_t cap = 8192;
    double *bufs[3];
    for (int i = 0; i < 3; i++)
        assert_non_null(bufs[i] = malloc(cap * DIMS * sizeof *bufs[i]));
    qmc_session_spec ss;
    qmc_session *s = session_test_open(&ss, &is, p.f, cap);
    outcome got;
    drive_ring(s, p.f, bufs, 3, cap, 1, &got);
    session_test_assert_same(&got, &want, "rqmc told ahead into three buffers");
    assert_int_equal(got.batches, 8);   /* 8 x 8192 points, one replicate a batch */
    assert_int_equal(got.behind, 7);    /* the last has no next group */
    assert_int_equal(got.status.evals, want.rep.res.evals);
    assert_int_equal(got.status.batches, 8);
    qmc_session_free(s);
    for (int i = 0; i < 3; i++)
        free(bufs[i]);
    qmc_testfn_free(p.fn);
}

/* Behind, then: a refused tell (the values are summed first, the same
 * batch still waits), own_batch (sums first, then moves the batch home),
 * and free (no leak: the sanitized build checks). */
static void test_ahead_behind_then(void **state)
{
    (void)state;
    problem p = session_test_make("genz-oscillatory", DIMS, NULL, NULL);
    qmc_integrate_spec is = rqmc_spec();
    outcome want = session_test_via_integrate(&is, p.f);
    const size_t cap = 8192;
    double *slot = malloc(cap * DIMS * sizeof *slot), *copy = malloc(cap * DIMS * sizeof *copy);
    double *vals = malloc(cap * sizeof *vals);
    assert_true(slot && copy && vals);
    char why[256];
    for (int how = 0; how < 3; how++) {
        qmc_session_spec ss;
        qmc_session *s = session_test_open(&ss, &is, p.f, cap);
        qmc_session_batch b;
        assert_int_equal(qmc_session_ask(s, &b), 0);
        p.f->eval(p.f->ctx, b.points, b.count, b.dims, vals);
        assert_int_equal(qmc_session_tell_ahead(s, b.seq, vals, b.count, slot, cap, why,
                                                sizeof why),
                         0);
        assert_true(qmc_session_behind(s));
        qmc_session_batch next;
        assert_int_equal(qmc_session_ask(s, &next), 0);
        assert_true(next.seq == 1 && next.points == slot && next.count == cap);
        memcpy(copy, next.points, next.count * DIMS * sizeof *copy);
        if (how == 0) {
            /* a stale seq: refused after the catch-up, batch 1 still waits */
            assert_int_equal(qmc_session_tell(s, 0, vals, b.count, why, sizeof why),
                             QMC_EINVAL);
            assert_non_null(strstr(why, "answered already"));
            assert_false(qmc_session_behind(s));
        } else if (how == 1) {
            qmc_session_own_batch(s);
            assert_false(qmc_session_behind(s));
            memset(slot, 0xff, cap * DIMS * sizeof *slot);
            memset(vals, 0xff, cap * sizeof *vals);
        } else {
            qmc_session_free(s); /* behind: unwound, nothing leaks */
            continue;
        }
        qmc_session_batch again;
        assert_int_equal(qmc_session_ask(s, &again), 0);
        assert_true(again.seq == 1 && again.count == next.count);
        assert_memory_equal(again.points, copy, next.count * DIMS * sizeof *copy);
        outcome got = session_test_drive(s, p.f);
        session_test_assert_same(&got, &want, how ? "after own_batch behind" : "after refusal");
        qmc_session_free(s);
    }
    free(slot);
    free(copy);
    free(vals);
    qmc_testfn_free(p.fn);
}

/* Values handed back inside the buffer the next batch is assembled in
 * (the caller wrote them over its points): copied first, same bytes. */
static void test_ahead_values_in_next(void **state)
{
    (void)state;
    problem p = session_test_make("genz-gaussian", DIMS, NULL, NULL);
    qmc_integrate_spec is = rqmc_spec();
    outcome want = session_test_via_integrate(&is, p.f);
    const size_t cap = 8192;
    double *buf = malloc(cap * DIMS * sizeof *buf), *tmp = malloc(cap * sizeof *tmp);
    assert_true(buf && tmp);
    qmc_session_spec ss;
    qmc_session *s = session_test_open(&ss, &is, p.f, cap);
    char why[256];
    outcome got;
    memset(&got, 0, sizeof got);
    for (;;) {
        qmc_session_batch b;
        assert_int_equal(qmc_session_ask(s, &b), 0);
        if (b.count == 0)
            break;
        p.f->eval(p.f->ctx, b.points, b.count, b.dims, tmp);
        memcpy(buf + 5, tmp, b.count * sizeof *tmp); /* into the next batch's buffer */
        assert_int_equal(qmc_session_tell_ahead(s, b.seq, buf + 5, b.count, buf, cap, why,
                                                sizeof why),
                         0);
        qmc_session_catch_up(s);
    }
    got.err = qmc_session_result(s, &got.rep, got.why, sizeof got.why);
    session_test_assert_same(&got, &want, "values inside the next buffer");
    qmc_session_free(s);
    free(buf);
    free(tmp);
    qmc_testfn_free(p.fn);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_same_bytes),
        cmocka_unit_test(test_own_batch),
        cmocka_unit_test(test_refusals),
        cmocka_unit_test(test_ahead_same_bytes),
        cmocka_unit_test(test_ahead_behind_then),
        cmocka_unit_test(test_ahead_values_in_next),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
