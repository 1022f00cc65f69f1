/*
 * hook.c - the test interrupt hook (see hook.h).
 */
#include <string.h>

#include "hook.h"

static int test_hook_fn(void *ctx)
{
    test_hook *h = ctx;
    h->calls++;
    uint64_t now = h->evals ? *h->evals : 0;
    if (now - h->last > h->max_gap)
        h->max_gap = now - h->last;
    h->last = now;
    if (h->fire_at == 0 || h->calls < h->fire_at)
        return 0;
    if (h->calls == h->fire_at)
        h->evals_at_fire = now;
    return 1;
}

qmc_interrupt test_hook_init(test_hook *h, uint64_t fire_at, const uint64_t *evals)
{
    h->fire_at = fire_at;
    h->evals = evals;
    h->calls = 0;
    h->evals_at_fire = 0;
    h->max_gap = 0;
    h->last = evals ? *evals : 0;
    qmc_interrupt hook = {test_hook_fn, h};
    return hook;
}

#define SAME(field) (memcmp(&a->field, &b->field, sizeof a->field) == 0)

int test_same_result(const qmc_result *a, const qmc_result *b)
{
    return SAME(estimate) && SAME(error) && SAME(ci_low) && SAME(ci_high) &&
           SAME(error_kind) && SAME(n) && SAME(evals) && SAME(dims) && SAME(flags) &&
           SAME(nonfinite) && SAME(abs_integral);
}
