/*
 * interrupt.h - polling the caller's interrupt hook (qmc_interrupt, see
 * qmc/integrand.h) at a bounded granularity (private to core/).
 *
 * The deterministic integrators count their work in evaluations (Gauss-
 * Legendre nodes in steps of the Legendre recurrence) and call the hook
 * once QMC_INTERRUPT_EVALS units have passed since the last call, so a
 * cancel is seen after a few thousand evaluations whatever the method,
 * while the hook costs one call per thousands of evaluations.  Polling
 * only decides whether to go on; it touches no number the methods compute,
 * so a hook that never fires leaves every result bit-identical.  Nothing
 * here reads a clock or keeps state beyond the caller's qmc__poll.
 */
#ifndef QMC_INTERRUPT_H
#define QMC_INTERRUPT_H

#include <stddef.h>
#include <stdint.h>

#include "qmc/error.h"
#include "qmc/integrand.h"
#include "qmc/result.h"
#include "qmc/sampling.h"

typedef struct qmc__poll {
    int (*fn)(void *ctx);   /* NULL: never interrupted */
    void *ctx;
    uint64_t work;          /* units since the last call */
} qmc__poll;

/* hook may be NULL. */
static inline void qmc__poll_init(qmc__poll *p, const qmc_interrupt *hook)
{
    p->fn = hook ? hook->fn : NULL;
    p->ctx = hook ? hook->ctx : NULL;
    p->work = 0;
}

/* The hook fired: *res is reset to hold no estimate, only the dimensions
 * and the evaluations spent (the quadrature methods' common answer).
 * Returns QMC_ECANCELED. */
static inline int qmc__cancelled(qmc_result *res, uint32_t dims, uint64_t evals)
{
    qmc_result_init(res);
    res->error_kind = QMC_ERROR_ESTIMATE;
    res->dims = dims;
    res->evals = evals;
    return QMC_ECANCELED;
}

/* Calls the hook now.  Returns 1 when it asks to stop. */
static inline int qmc__poll_now(qmc__poll *p)
{
    p->work = 0;
    return p->fn != NULL && p->fn(p->ctx) != 0;
}

/* Counts `units` of work and calls the hook once QMC_INTERRUPT_EVALS have
 * passed since the last call.  Returns 1 when it asks to stop. */
static inline int qmc__poll_work(qmc__poll *p, uint64_t units)
{
    p->work += units;
    return p->work >= QMC_INTERRUPT_EVALS && qmc__poll_now(p);
}

/*
 * The sampling engine's side (core/sampling_finish.c): a block runner that
 * honours an interrupt hook.  Without a caller's runner it runs the blocks
 * serially and polls the hook before each one (a block is
 * QMC_SAMPLING_BLOCK points); with one, it polls before handing over each
 * batch and leaves the blocks inside a batch to the runner, which owns
 * the threads and so its own cancellation.  Returns QMC_ECANCELED when
 * the hook fires, else what running the blocks returns.
 */
typedef struct qmc__guard {
    qmc_block_runner runner;   /* the caller's, or NULL: serially */
    void *runner_ctx;
    qmc_interrupt hook;
} qmc__guard;

int qmc__guard_run(void *guard, const qmc_sampling_job *job, uint64_t first,
                   uint64_t count, qmc_sampling_sums *out);

#endif /* QMC_INTERRUPT_H */
