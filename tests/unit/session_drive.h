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

typedef struct outcome {
    int err;
    qmc_integrate_report rep;
    char why[512];
    qmc_session_report status;
    uint64_t batches, largest;
    uint64_t behind;       /* tells ahead that returned behind */
} outcome;

/* Answers every batch of s with f until it is done, checking the batch
 * numbers and the end reason, then takes the result and the status. */
void session_test_drive(qmc_session *s, const qmc_integrand *f, outcome *o);

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
