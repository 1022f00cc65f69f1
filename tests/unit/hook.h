/*
 * hook.h - a test interrupt hook (qmc_interrupt) shared by the unit tests
 * of the integrators: it counts its calls, fires from call fire_at on, and
 * watches the integrand's own evaluation counter to measure how much work
 * runs between two calls and after it fired.
 */
#ifndef QMC_TEST_HOOK_H
#define QMC_TEST_HOOK_H

#include <stdint.h>

#include "qmc/integrand.h"
#include "qmc/result.h"

typedef struct test_hook {
    uint64_t fire_at;          /* the call that first returns 1; 0: never */
    const uint64_t *evals;     /* the integrand's evaluation counter, or NULL */
    uint64_t calls;
    uint64_t evals_at_fire;    /* *evals when it fired */
    uint64_t max_gap;          /* most evaluations between two calls */
    uint64_t last;             /* *evals at the previous call */
} test_hook;

/* Resets h and returns the hook to put in a spec or options. */
qmc_interrupt test_hook_init(test_hook *h, uint64_t fire_at, const uint64_t *evals);

/* 1 when two results hold the same bits in every field. */
int test_same_result(const qmc_result *a, const qmc_result *b);

#endif
