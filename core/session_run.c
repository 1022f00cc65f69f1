/*
 * session_run.c - the fiber's side of a session: qmc_integrate, unchanged,
 * with an integrand whose every call becomes a batch for the caller, and a
 * block runner that assembles larger batches for the sampling methods.
 *
 * The integrand (session_eval), in MODE_DIRECT, yields the fiber with the
 * integrator's own points and returns when the caller's values are in its
 * output: the integrator never learns that it was suspended, so every
 * number it computes is what it computes with a callback giving the same
 * values.
 *
 * The sampling engine calls the integrand once per chunk of 256 points,
 * which would make batches of 256.  So the session hands qmc_integrate a
 * block runner (qmc_block_runner, as the daemon's and the CLI's thread
 * pools are) and runs each group of whole blocks twice: first collecting
 * the points into the batch, summing nothing, then, once the caller has
 * answered the whole batch, summing the values in order.  When the job's
 * f is the session's own, the first pass makes each block's points
 * straight into the batch (qmc__sampling_block_fill) and the second sums
 * the caller's values as given (qmc__sampling_sum_block: no point made
 * again, no call); when a wrapper stands between (auto's VEGAS map, which
 * moves the points and weighs the values), both passes call the job's f,
 * the session's integrand copying the points (MODE_COLLECT) and answering
 * from the values (MODE_REPLAY).  A block's points and the order of its
 * integrand calls depend only on the job and the block (never on the
 * values: sampling.c evaluates every point of a block in a fixed order),
 * so the second pass sees exactly the points the first collected, and its
 * sums are those of a plain run: the bytes of every result are unchanged,
 * whatever the batch size.  The next group is collected before the told
 * one is summed, and a tell ahead returns between the two
 * (session_runner).
 *
 * Must not: write the caller's buffers (values are read where tell found
 * them), allocate per batch, or change what an integrator computes.
 */
#include <stdlib.h>
#include <string.h>

#include "integrate_memory.h"
#include "msg.h"
#include "session_impl.h"

/* Hands the caller count points: the batch it waits for from now on
 * (collected: a group of whole blocks, whose values tell leaves at src;
 * else they go to out). */
static void hand_out(qmc_session *s, const double *points, size_t count, double *out,
                     int collected)
{
    s->points = points;
    s->count = count;
    s->out = out;
    s->collected = collected;
    s->pending = 1;
    s->served = 0;
}

/* Hands the caller count points and suspends until tell (or free) resumes
 * the fiber; out holds the values (zeros when the session is closing). */
static void ask_caller(qmc_session *s, const double *points, size_t count, double *out)
{
    if (s->closing) {
        memset(out, 0, count * sizeof *out);
        return;
    }
    hand_out(s, points, count, out, 0);
    qmc__fiber_yield(s->fiber);
    /* tell cleared pending and wrote out; free set closing instead */
    if (s->closing)
        memset(out, 0, count * sizeof *out);
}

static void session_eval(const void *ctx, const double *x, size_t n, uint32_t dims, double *out)
{
    /* The integrand contract forbids writing ctx because integrands may
     * run on several threads at once; this one runs only on its
     * session's fiber, one call at a time. */
    qmc_session *s = (qmc_session *)ctx;
    if (n == 0)
        return;
    switch (s->mode) {
    case MODE_COLLECT:
        if (s->fill + n > s->max_batch) {
            s->overrun = 1;
            memset(out, 0, n * sizeof *out);
            return;
        }
        memcpy(s->collect + s->fill * dims, x, n * dims * sizeof *x);
        memset(out, 0, n * sizeof *out);
        s->fill += n;
        return;
    case MODE_REPLAY:
        if (s->cursor + n > s->fill) {
            s->overrun = 1;
            memset(out, 0, n * sizeof *out);
            return;
        }
        memcpy(out, s->src + s->cursor, n * sizeof *out);
        s->cursor += n;
        return;
    case MODE_DIRECT:
        ask_caller(s, x, n, out);
        return;
    }
}

/* The session's interrupt hook: it fires when the session is being
 * closed, and whenever the caller's own hook (spec.integrate.interrupt)
 * does. */
static int session_interrupt(void *ctx)
{
    const qmc_session *s = ctx;
    const qmc_interrupt *own = &s->spec.integrate.interrupt;
    return s->closing || (own->fn && own->fn(own->ctx));
}

/* Runs blocks [first, first + count) of job into out (NULL: evaluate
 * only, the collect pass), one pass. */
static int run_pass(qmc_session *s, const qmc_sampling_job *job, uint64_t first, uint64_t count,
                    qmc_sampling_sums *out)
{
    for (uint64_t b = 0; b < count; b++) {
        int err = out ? qmc_sampling_run_block(job, first + b, s->ws, s->ws_bytes, &out[b])
                      : qmc__sampling_eval_block(job, first + b, s->ws, s->ws_bytes);
        if (err)
            return err;
    }
    return 0;
}

/*
 * The running estimate from blocks [0, done) of job.  Finishing costs a
 * pass over every block done, so it is taken again only once the blocks
 * have grown by an eighth since the last time (or by one, early on):
 * the passes add up to at most 9 times the job's blocks, where one per
 * batch would be quadratic (2^20 blocks in batches of 16: 3e10 block
 * merges), and the estimate is never more than an eighth of the work
 * behind.  Its n says how many points a replicate it rests on.
 */
static void update_running(qmc_session *s, const qmc_sampling_job *job,
                           const qmc_sampling_sums *sums, uint64_t done)
{
    const uint64_t n = job->spec.n; /* an adaptive round's n names it */
    if (job != s->run_job || n != s->run_key || done < s->run_done) {
        s->run_job = job; /* a new job: an adaptive round, auto's rqmc */
        s->run_key = n;
        s->run_done = 0;
    }
    const uint64_t step = s->run_done / 8 ? s->run_done / 8 : 1;
    if (done != qmc_sampling_blocks(job) && done - s->run_done < step)
        return;
    s->run_done = done;
    qmc_result r;
    if (qmc__sampling_running(job, sums, done, &r)) {
        s->running = r;
        s->has_estimate = 1;
    }
}

/* The end of the group of whole blocks from block i on (of count from
 * first): at most max_batch points, *points of them; i itself when block i
 * alone is larger. */
static uint64_t group_end(const qmc_session *s, const qmc_sampling_job *job, uint64_t first,
                          uint64_t i, uint64_t count, uint64_t *points)
{
    uint64_t j = i;
    *points = 0;
    while (j < count && *points + qmc__sampling_block_points(job, first + j) <= s->max_batch)
        *points += qmc__sampling_block_points(job, first + j++);
    return j;
}

/* Whether job evaluates the session's integrand itself (not through a
 * wrapper such as auto's VEGAS map, which changes the points and the
 * values): then the passes need not call it. */
static int own_integrand(const qmc_session *s, const qmc_sampling_job *job)
{
    return job->f->eval == session_eval && job->f->ctx == s && !job->g;
}

/* The collect pass over blocks [first, first + count): their points into
 * s->collect, s->fill of them - made straight there when the job's f is
 * the session's own (the points block_pass would hand it), else by
 * calling f in MODE_COLLECT. */
static int collect(qmc_session *s, const qmc_sampling_job *job, uint64_t first, uint64_t count)
{
    s->fill = 0;
    if (own_integrand(s, job)) {
        for (uint64_t b = 0; b < count; b++) {
            const uint64_t n = qmc__sampling_block_points(job, first + b);
            if (s->fill + n > s->max_batch)
                return QMC_EINVAL; /* group_end keeps within: cannot happen */
            int err = qmc__sampling_block_fill(job, first + b, s->collect + s->fill * job->dims);
            if (err)
                return err;
            s->fill += n;
        }
        return 0;
    }
    s->mode = MODE_COLLECT;
    int err = run_pass(s, job, first, count, NULL);
    s->mode = MODE_DIRECT;
    return err;
}

/* The replay pass: the blocks' sums from the values at src, in order -
 * taken as they are when the job's f is the session's own, else handed to
 * f's calls in MODE_REPLAY. */
static int replay(qmc_session *s, const qmc_sampling_job *job, uint64_t first, uint64_t count,
                  const double *src, size_t n, qmc_sampling_sums *out)
{
    s->src = src;
    s->fill = n;
    s->cursor = 0;
    int err = 0;
    if (own_integrand(s, job)) {
        for (uint64_t b = 0; b < count && !err; b++) {
            const uint64_t m = qmc__sampling_block_points(job, first + b);
            if (s->cursor + m > n)
                return QMC_EINVAL;
            err = qmc__sampling_sum_block(job, first + b, src + s->cursor, s->ws, s->ws_bytes,
                                          &out[b]);
            s->cursor += m;
        }
    } else {
        s->mode = MODE_REPLAY;
        err = run_pass(s, job, first, count, out);
        s->mode = MODE_DIRECT;
    }
    if (!err && s->cursor != n)
        s->overrun = 1;
    return err;
}

/*
 * The block runner: groups of whole blocks of at most max_batch points,
 * each collected, handed to the caller as one batch and replayed.  A block
 * larger than max_batch runs in MODE_DIRECT (the engine's chunks are the
 * batches).  After each group the running estimate is taken from the
 * blocks complete so far: both of the engine's callers (qmc_sampling_run
 * and qmc_sampling_adaptive) pass out = sums + first, where sums is the
 * job's whole array and sums[0 .. first) are complete, so out - first is
 * that array (a private guarantee of core/, written down at
 * qmc__sampling_run_blocks in sampling_impl.h).  A part's out is its own
 * array: no running estimate there.
 *
 * Once a group's values are in, the next group of this call (the blocks
 * are known: a fixed job's whole range, an adaptive round's replicate) is
 * collected and handed out before the told group is replayed; a tell
 * ahead (s->early) returns to its caller between the two, so that the
 * caller can send the next batch out first and replay while its client
 * evaluates (catch_up resumes here).  The order of the two passes changes
 * no sum: a block's points and calls depend on the job and the block only,
 * and each group is replayed from its own values.  Nothing is collected
 * past this call's blocks, so no batch is ever handed out that the
 * integrator might not want.
 */
static int session_runner(void *ctx, const qmc_sampling_job *job, uint64_t first,
                          uint64_t count, qmc_sampling_sums *out)
{
    qmc_session *s = ctx;
    if (qmc_sampling_workspace_bytes(job) > s->ws_bytes)
        return QMC_EINVAL; /* sized from the dims at open: cannot happen */
    uint64_t i = 0, j = 0, points = 0;
    int handed = 0; /* group [i, j) is handed out, its values awaited */
    while (i < count) {
        if (s->closing)
            return QMC_ECANCELED;
        int err = 0;
        if (!handed) {
            j = group_end(s, job, first, i, count, &points);
            if (j == i) { /* one block over max_batch: the engine's own chunks */
                err = run_pass(s, job, first + i, 1, out + i);
                if (err)
                    return err;
                i++;
                if (!s->spec.part_p)
                    update_running(s, job, out - first, first + i);
                continue;
            }
            err = collect(s, job, first + i, j - i);
            if (err)
                return err;
            if (s->overrun || s->fill != points)
                return QMC_EINVAL; /* the pass did not match the blocks: never seen */
            hand_out(s, s->collect, s->fill, s->vals, 1);
        }
        /* Wait for the values of [i, j) (tell clears pending; free sets
         * closing). */
        if (s->pending)
            qmc__fiber_yield(s->fiber);
        if (s->closing)
            return QMC_ECANCELED;
        const double *src = s->src;
        const size_t n = s->count;
        /* The next group, collected and handed out now. */
        uint64_t k = j;
        handed = 0;
        if (j < count && (k = group_end(s, job, first, j, count, &points)) > j) {
            err = collect(s, job, first + j, k - j);
            if (err)
                return err;
            if (s->overrun || s->fill != points)
                return QMC_EINVAL;
            hand_out(s, s->collect, s->fill, s->vals, 1);
            handed = 1;
            if (s->early) { /* the tell returns now; catch_up resumes */
                s->behind = 1;
                qmc__fiber_yield(s->fiber);
                s->behind = 0;
                if (s->closing)
                    return QMC_ECANCELED;
            }
        }
        err = replay(s, job, first + i, j - i, src, n, out + i);
        if (!err && s->overrun)
            err = QMC_EINVAL; /* the two passes disagreed: never seen; refuse to guess */
        if (err)
            return err;
        i = j;
        j = k;
        if (!s->spec.part_p)
            update_running(s, job, out - first, first + i);
    }
    return 0;
}

/* A part: the whole job's fingerprint (its probe points are the first
 * batch), then the part's blocks through the runner. */
static int run_part(qmc_session *s)
{
    qmc__msg m;
    qmc__msg_init(&m, s->why, sizeof s->why);
    qmc_sampling_spec q;
    int err = qmc__fixed_sampling_spec(&s->ispec, s->spec.dims, &q, s->why, sizeof s->why);
    if (err)
        return err;
    qmc_sampling_job *job = NULL;
    err = qmc_sampling_job_new(&q, &s->f, NULL, &job, s->why, sizeof s->why);
    if (err)
        return err;
    const uint64_t nb = qmc_sampling_blocks(job);
    const uint64_t first = nb * (s->spec.part_k - 1) / s->spec.part_p;
    const uint64_t end = nb * s->spec.part_k / s->spec.part_p;
    s->part_sums = calloc(end - first + 1, sizeof *s->part_sums);
    if (!s->part_sums) {
        qmc_sampling_job_free(job);
        qmc__msg_str(&m, "out of memory for the part's block sums");
        return QMC_ENOMEM;
    }
    s->part.fingerprint = qmc_sampling_fingerprint(job);
    s->part.blocks = nb;
    s->part.first = first;
    s->part.count = end - first;
    s->part.sums = s->part_sums;
    s->part.sampling = q;
    /* Through the interrupt-aware path, as qmc_integrate runs blocks. */
    err = s->closing ? QMC_ECANCELED : session_runner(s, job, first, end - first, s->part_sums);
    qmc_sampling_job_free(job);
    if (err)
        qmc__msg_str(&m, qmc_strerror(err));
    return err;
}

void qmc__session_main(void *arg)
{
    qmc_session *s = arg;
    s->f.eval = session_eval;
    s->ispec = s->spec.integrate;
    s->ispec.interrupt.fn = session_interrupt;
    s->ispec.interrupt.ctx = s;
    if (s->spec.part_p) {
        memset(&s->rep, 0, sizeof s->rep);
        qmc_result_init(&s->rep.res);
        s->rep.method_used = s->spec.integrate.method;
        s->err = run_part(s);
    } else {
        s->err = qmc_integrate(&s->ispec, &s->f, NULL, session_runner, s, &s->rep, s->why,
                               sizeof s->why);
    }
    s->finished = 1;
}
