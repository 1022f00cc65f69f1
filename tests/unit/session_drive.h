/*
 * session_drive.h - running integration sessions in the unit tests
 * (test_session*.c): built-in integrands, a caller that answers every
 * batch, and the field-by-field comparison with qmc_integrate.
 */
#ifndef QMC_TEST_SESSION_DRIVE_H
#define QMC_TEST_SESSION_DRIVE_H

#include <stdint.h>

#include "qmc/integrate.h"
#include "qmc/session.h"
#include "qmc/testfn.h"

typedef struct problem {
    qmc_testfn *fn;
    const qmc_integrand *f;
} problem;

/* The test function name on dims dims (a, u: NULL or dims values each);
 * fails the test when it cannot be made. */
problem session_test_make(const char *name, uint32_t dims, const double *a, const double *u);

/* A session spec running is on f's declarations (dims, smoothness, exact
 * value, name). */
void session_test_spec(qmc_session_spec *ss, const qmc_integrate_spec *is,
                       const qmc_integrand *f);

/* is set up for method (a name qmc_method_parse knows; the test fails on
 * any other), with its sampler's defaults where the method samples. */
void session_test_method(qmc_integrate_spec *is, const char *method);

/* Opens a session on is and f (session_test_spec, then max_batch, 0 for
 * the default) and leaves its spec in ss; fails the test, with the
 * session's reason, when it will not open. */
qmc_session *session_test_open(qmc_session_spec *ss, const qmc_integrate_spec *is,
                               const qmc_integrand *f, uint64_t max_batch);

/* A caller's buffer for a batch's values, grown to the largest batch it
 * answers (vals NULL and cap 0 to start; the caller frees vals). */
typedef struct answer_buf {
    double *vals;
    size_t cap;
} answer_buf;

/* Evaluates f on b's points into buf and tells s; fails the test, with the
 * session's reason, when the tell is refused. */
void session_test_tell(qmc_session *s, const qmc_integrand *f, const qmc_session_batch *b,
                       answer_buf *buf);

/* Asks s for its batch (into b) and, unless it is empty, answers it with
 * f; returns the batch's count, 0 once the session is done. */
size_t session_test_answer(qmc_session *s, const qmc_integrand *f, qmc_session_batch *b,
                           answer_buf *buf);

typedef struct outcome {
    int err;
    qmc_integrate_report rep;
    char why[512];
    qmc_session_report status;
    uint64_t batches, largest;
    uint64_t behind;       /* tells ahead that returned behind */
} outcome;

/* The session's result and status as they stand (batches and largest 0). */
outcome session_test_outcome(qmc_session *s);

/* Answers every batch of s with f until it is done, checking the batch
 * numbers and the end reason, then takes the result and the status. */
outcome session_test_drive(qmc_session *s, const qmc_integrand *f);

/* The same, each batch told ahead (qmc_session_tell_ahead): half the
 * catch-ups explicit, half left to the next tell; counts o->behind. */
void session_test_drive_ahead(qmc_session *s, const qmc_integrand *f, outcome *o);

/* Opens a session on ss, drives it with f and frees it. */
outcome session_test_via_session(const qmc_session_spec *ss, const qmc_integrand *f);
outcome session_test_via_session_ahead(const qmc_session_spec *ss, const qmc_integrand *f);
outcome session_test_via_integrate(const qmc_integrate_spec *is, const qmc_integrand *f);

/* Fails unless the two outcomes have the same return value and the same
 * report in every field (doubles compared as bits). */
void session_test_assert_same(const outcome *a, const outcome *b, const char *what);

#endif
