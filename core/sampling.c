/*
 * sampling.c - sampling jobs and their blocks (see qmc/sampling.h).
 *
 * Replicate r of a job draws its points from its own sequence instance:
 * random (mc), stratified or lhs sets of n points, or the chosen QMC
 * sequence, scrambled with a seed hashed from (seed, r) for rqmc.  Block b
 * of replicate r covers indices [b B, min(n, (b+1) B)), B =
 * QMC_SAMPLING_BLOCK, and its sums are computed in index order.  A split
 * net (spec.split_net) scrambles every replicate alike and shifts
 * replicate r's indices by r n.
 *
 * Must not: keep state between calls, or allocate in run_block.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "bits.h"
#include "msg.h"
#include "lane_sum.h"
#include "hot_clones.h"
#include "neumaier.h"
#include "sampling_impl.h"
#include "seq_impl.h"

enum {
    TAG_REPLICATE = 0x72657073, /* "reps" */
    CHUNK_MAX = 256             /* points per integrand call, at most */
};

void qmc_sampling_spec_init(qmc_sampling_spec *spec, qmc_sampler sampler)
{
    memset(spec, 0, sizeof *spec);
    spec->sampler = sampler;
    spec->seq = QMC_SEQ_SOBOL;
    spec->scramble = sampler == QMC_SAMPLER_RQMC ? QMC_SCRAMBLE_OWEN : QMC_SCRAMBLE_NONE;
    spec->n = 4096;
    spec->reps = sampler == QMC_SAMPLER_RQMC ? 16 : 1;
    spec->confidence = 0.95;
}

/* The sequence replicate r samples from. */
static qmc_seq_spec replicate_seq(const qmc_sampling_spec *s, uint32_t dims, uint32_t r)
{
    qmc_seq_spec q = {.dims = dims, .scramble = QMC_SCRAMBLE_NONE};
    uint64_t seed_r = qmc__hash3(s->seed, r, TAG_REPLICATE);
    switch (s->sampler) {
    case QMC_SAMPLER_MC:
        q.kind = QMC_SEQ_RANDOM;
        q.seed = seed_r;
        break;
    case QMC_SAMPLER_STRATIFIED:
        q.kind = QMC_SEQ_STRATIFIED;
        q.seed = seed_r;
        q.set_size = s->n;
        break;
    case QMC_SAMPLER_LHS:
        q.kind = QMC_SEQ_LHS;
        q.seed = seed_r;
        q.set_size = s->n;
        break;
    case QMC_SAMPLER_QMC:
    case QMC_SAMPLER_RQMC:
        q.kind = s->seq;
        q.scramble = s->scramble;
        q.flags = s->seq_flags;
        q.seed = s->sampler != QMC_SAMPLER_RQMC ? s->seed
                 : s->split_net                 ? qmc__hash3(s->seed, 0, TAG_REPLICATE)
                                                : seed_r;
        q.set_size = s->seq == QMC_SEQ_HAMMERSLEY ? s->n : 0;
        break;
    }
    return q;
}

static int check_spec(const qmc_sampling_spec *s, const qmc_integrand *f,
                      const qmc_integrand *g, qmc__msg *why)
{
    if (!f || !f->eval || f->dims == 0) {
        qmc__msg_str(why, "no integrand");
        return QMC_EINVAL;
    }
    if (qmc_sampler_name(s->sampler)[0] == '\0') {
        qmc__msg_str(why, "unknown sampler");
        return QMC_EINVAL;
    }
    if (s->n == 0 || s->n > QMC_SEQ_MAX_INDEX) {
        qmc__msg_set(why, "n = ", s->n, " points is outside 1..2^32");
        return QMC_ECOUNT;
    }
    if (s->reps == 0 || s->reps > QMC_SAMPLING_MAX_REPS) {
        qmc__msg_set(why, "reps = ", s->reps, " is outside 1..");
        qmc__msg_u64(why, QMC_SAMPLING_MAX_REPS);
        return QMC_EINVAL;
    }
    if ((uint64_t)s->reps * f->dims > QMC_SAMPLING_MAX_REP_DIMS) {
        qmc__msg_set(why, "", s->reps, " replicates of ");
        qmc__msg_u64(why, f->dims);
        qmc__msg_str(why, " dimensions need too much sequence memory; keep reps x dims <= ");
        qmc__msg_u64(why, QMC_SAMPLING_MAX_REP_DIMS);
        return QMC_ETOOBIG;
    }
    if ((uint64_t)s->reps * ((s->n + QMC_SAMPLING_BLOCK - 1) / QMC_SAMPLING_BLOCK) >
        QMC_SAMPLING_MAX_BLOCKS) {
        qmc__msg_set(why, "", s->reps, " replicates x ");
        qmc__msg_u64(why, s->n);
        qmc__msg_str(why, " points is more than one job may hold (");
        qmc__msg_u64(why, (uint64_t)QMC_SAMPLING_MAX_BLOCKS * QMC_SAMPLING_BLOCK);
        qmc__msg_str(why, " points)");
        return QMC_ETOOBIG;
    }
    if ((s->sampler == QMC_SAMPLER_RQMC) && s->seq == QMC_SEQ_HAMMERSLEY) {
        /* Its first coordinate i/N is the same in every replicate, so the
         * replicates are neither independent nor unbiased. */
        qmc__msg_str(why, "hammersley's first coordinate is not randomized: use rqmc with "
                          "sobol or halton, or qmc with hammersley");
        return QMC_ESCRAMBLE;
    }
    if (s->split_net != 0 && s->split_net != 1) {
        qmc__msg_str(why, "split_net is 0 or 1");
        return QMC_EINVAL;
    }
    /* A split net's R n indices stay below 2^32 by the block cap above;
     * rqmc refuses hammersley's finite set below. */
    if (s->split_net && s->sampler != QMC_SAMPLER_RQMC) {
        qmc__msg_str(why, "a split net is for rqmc: the other samplers have no net to split");
        return QMC_EINVAL;
    }
    if (s->sampler == QMC_SAMPLER_RQMC && s->reps < 2) {
        qmc__msg_str(why, "rqmc needs reps >= 2 independent randomizations for an error bar");
        return QMC_EINVAL;
    }
    if (s->sampler == QMC_SAMPLER_QMC && s->reps != 1) {
        qmc__msg_str(why, "qmc is deterministic: every replicate would be the same; use rqmc for replicates");
        return QMC_EINVAL;
    }
    if (s->sampler == QMC_SAMPLER_RQMC && s->scramble == QMC_SCRAMBLE_NONE) {
        qmc__msg_str(why, "rqmc needs a random scramble (owen, fast-owen, shift)");
        return QMC_ESCRAMBLE;
    }
    if (s->sampler == QMC_SAMPLER_RQMC && s->scramble == QMC_SCRAMBLE_FAURE) {
        qmc__msg_str(why, "faure is a deterministic scramble: rqmc needs owen (or shift, fast-owen for sobol)");
        return QMC_ESCRAMBLE;
    }
    if (!(s->confidence > 0.0 && s->confidence < 1.0)) {
        qmc__msg_str(why, "confidence must lie strictly between 0 and 1");
        return QMC_EINVAL;
    }
    if (g) {
        if (!g->eval || !g->has_exact) {
            qmc__msg_str(why, "the control variate needs a known integral");
            return QMC_EINVAL;
        }
        if (g->dims != f->dims) {
            qmc__msg_set(why, "the control variate has ", g->dims, " dims; the integrand has ");
            qmc__msg_u64(why, f->dims);
            return QMC_EDIMS;
        }
    }
    qmc_seq_spec q = replicate_seq(s, f->dims, 0);
    return qmc_seq_spec_check(&q, why->buf, why->cap);
}

int qmc_sampling_job_new(const qmc_sampling_spec *spec, const qmc_integrand *f,
                         const qmc_integrand *control, qmc_sampling_job **out,
                         char *why, size_t why_bytes)
{
    qmc__msg m;
    qmc__msg_init(&m, why, why_bytes);
    *out = NULL;
    int err = check_spec(spec, f, control, &m);
    if (err)
        return err;
    qmc_sampling_job *job = calloc(1, sizeof *job);
    if (!job)
        goto nomem;
    job->spec = *spec;
    job->f = f;
    job->g = control;
    job->dims = f->dims;
    job->blocks_per_rep = (spec->n + QMC_SAMPLING_BLOCK - 1) / QMC_SAMPLING_BLOCK;
    /* Points per integrand call: 256, fewer for very wide points so the
     * workspace stays near 2 MiB. */
    job->chunk = qmc__sampling_chunk(f->dims);
    job->seqs = calloc(spec->reps, sizeof *job->seqs);
    if (!job->seqs)
        goto nomem;
    for (uint32_t r = 0; r < spec->reps; r++) {
        qmc_seq_spec q = replicate_seq(spec, f->dims, r);
        err = qmc_seq_new(&q, &job->seqs[r]);
        if (err) {
            qmc_sampling_job_free(job);
            qmc__msg_str(&m, qmc_strerror(err));
            return err;
        }
    }
    *out = job;
    return 0;
nomem:
    qmc_sampling_job_free(job);
    qmc__msg_str(&m, "out of memory");
    return QMC_ENOMEM;
}

void qmc_sampling_job_free(qmc_sampling_job *job)
{
    if (!job)
        return;
    if (job->seqs)
        for (uint32_t r = 0; r < job->spec.reps; r++)
            qmc_seq_free(job->seqs[r]);
    free(job->seqs);
    free(job);
}

uint64_t qmc_sampling_blocks(const qmc_sampling_job *job)
{
    return job->blocks_per_rep * job->spec.reps;
}

uint32_t qmc__sampling_chunk(uint32_t dims)
{
    return dims <= 1024 ? CHUNK_MAX : (uint32_t)(262144 / dims) + 1;
}

size_t qmc__sampling_workspace_bytes_for(uint32_t dims)
{
    const size_t chunk = qmc__sampling_chunk(dims);
    /* points, then f values, then g values (room for them with or
     * without a control variate) */
    return (chunk * dims + 2 * chunk) * sizeof(double);
}

uint64_t qmc__sampling_job_bytes(const qmc_sampling_spec *spec, uint32_t dims)
{
    uint64_t bytes = sizeof(qmc_sampling_job) + (uint64_t)spec->reps * sizeof(qmc_seq *);
    for (uint32_t r = 0; r < spec->reps; r++) {
        qmc_seq_spec q = replicate_seq(spec, dims, r);
        bytes += qmc__seq_bytes(&q);
    }
    return bytes;
}

size_t qmc_sampling_workspace_bytes(const qmc_sampling_job *job)
{
    return qmc__sampling_workspace_bytes_for(job->dims);
}

uint64_t qmc__sampling_block_points(const qmc_sampling_job *job, uint64_t block)
{
    const uint64_t first = block % job->blocks_per_rep * QMC_SAMPLING_BLOCK;
    return job->spec.n - first < QMC_SAMPLING_BLOCK ? job->spec.n - first : QMC_SAMPLING_BLOCK;
}

enum { PROBES = 4 };

/* A hash of f's values at PROBES fixed points (0 if memory is short). */
static uint64_t probe_hash(const qmc_integrand *f)
{
    double *x = malloc((size_t)PROBES * f->dims * sizeof *x);
    if (!x)
        return 0;
    for (uint32_t p = 0; p < PROBES; p++)
        for (uint32_t j = 0; j < f->dims; j++)
            x[(size_t)p * f->dims + j] = qmc__u01_from_bits(qmc__hash3(0x70726f6265, p, j));
    double v[PROBES];
    f->eval(f->ctx, x, PROBES, f->dims, v);
    free(x);
    uint64_t h = 0;
    for (uint32_t p = 0; p < PROBES; p++) {
        uint64_t bits;
        memcpy(&bits, &v[p], sizeof bits);
        h = qmc__hash3(h, bits, p);
    }
    return h;
}

uint64_t qmc_sampling_fingerprint(const qmc_sampling_job *job)
{
    const qmc_sampling_spec *s = &job->spec;
    uint64_t h = qmc__hash3(s->sampler, s->seq, s->scramble);
    h = qmc__hash3(h, s->seq_flags, s->seed);
    h = qmc__hash3(h, s->n, s->reps);
    uint64_t conf;
    memcpy(&conf, &s->confidence, sizeof conf);
    h = qmc__hash3(h, conf, job->dims);
    if (s->split_net) /* 0 hashes as before the option existed */
        h = qmc__hash3(h, s->split_net, 0x73706c6974 /* "split" */);
    for (const char *p = job->f->name ? job->f->name : ""; *p; p++)
        h = qmc__hash3(h, (unsigned char)*p, 1);
    uint64_t ex;
    memcpy(&ex, &job->f->exact, sizeof ex);
    h = qmc__hash3(h, job->f->has_exact ? ex : 0, job->g != NULL);
    /* The integrand's parameters (Genz a and u, a scene's geometry and
     * strategy) are not visible here, so fingerprint the functions
     * themselves: their values at a few fixed pseudo-random points. */
    h = qmc__hash3(h, probe_hash(job->f), 4);
    if (job->g)
        h = qmc__hash3(h, probe_hash(job->g), 5);
    if (job->g) {
        memcpy(&ex, &job->g->exact, sizeof ex);
        for (const char *p = job->g->name ? job->g->name : ""; *p; p++)
            h = qmc__hash3(h, (unsigned char)*p, 2);
        h = qmc__hash3(h, ex, 3);
    }
    return h;
}

/* Inserts v into the descending top list if it belongs there: after the
 * last entry not below it (a binary search, then one move; a heavy-tailed
 * or sorted stream inserts often). */
static void top_insert(double *top, double v)
{
    if (!(v > top[QMC_SAMPLING_TOP - 1]))
        return;
    size_t lo = 0, hi = QMC_SAMPLING_TOP - 1; /* top[hi] < v; find the first such */
    while (lo < hi) {
        size_t mid = (lo + hi) / 2;
        if (top[mid] < v)
            hi = mid;
        else
            lo = mid + 1;
    }
    memmove(top + lo + 1, top + lo, (QMC_SAMPLING_TOP - 1 - lo) * sizeof *top);
    top[lo] = v;
}

/*
 * While a block runs, candidates for its largest |f| collect in a pool:
 * a value is written to the next free slot and kept when it beats the
 * pool's floor (a store and a compare, no branch).  When the pool is full
 * a selection keeps the QMC_SAMPLING_TOP largest and raises the floor to
 * the smallest of them; a block of 4096 values fills it about three times.
 * (A min-heap cost a sixth of a cheap integrand's job, in the mispredicted
 * branches of its sifts.)  The list the block reports is the same either
 * way: its largest values, descending, zeros where there are fewer.
 */
enum { POOL = 4 * QMC_SAMPLING_TOP };

typedef struct {
    double v[POOL]; /* v[n] takes each new value, kept or not */
    size_t n;
    double floor; /* a value at or below it cannot be among the largest */
} top_pool;

static double median3(double a, double b, double c)
{
    return a < b ? (b < c ? b : a < c ? c : a) : (a < c ? a : b < c ? c : b);
}

/* Moves the values of v[lo .. hi) that pass keep (> p, or >= p) to the
 * front and returns where the rest begin: Lomuto's partition without a
 * branch (each step swaps, and the front grows when the value passed),
 * as the comparisons are unpredictable. */
static size_t partition_front(double *v, size_t lo, size_t hi, double p, int or_equal)
{
    size_t a = lo;
    for (size_t i = lo; i < hi; i++) {
        double x = v[i];
        int keep = or_equal ? x >= p : x > p;
        v[i] = v[a];
        v[a] = x;
        a += (size_t)keep;
    }
    return a;
}

/* Rearranges v[0 .. n) so that v[0 .. k) holds k largest values
 * (quickselect).  Everything left of lo is at least everything in
 * [lo, hi), which is at least everything from hi on. */
static void select_largest(double *v, size_t n, size_t k)
{
    size_t lo = 0, hi = n;
    while (hi - lo > 1) {
        const double p = median3(v[lo], v[lo + (hi - lo) / 2], v[hi - 1]);
        size_t a = partition_front(v, lo, hi, p, 0); /* [lo, a) > p */
        if (a == lo) { /* p is the largest here: take its copies instead */
            a = partition_front(v, lo, hi, p, 1);
            if (k <= a)
                return;
            lo = a;
        } else if (k < a) {
            hi = a;
        } else if (k == a) {
            return;
        } else {
            lo = a;
        }
    }
}

/* Keeps the QMC_SAMPLING_TOP largest; the floor becomes their smallest. */
static void pool_compact(top_pool *p)
{
    select_largest(p->v, p->n, QMC_SAMPLING_TOP);
    p->n = QMC_SAMPLING_TOP;
    double lo = p->v[0];
    for (size_t k = 1; k < QMC_SAMPLING_TOP; k++)
        lo = p->v[k] < lo ? p->v[k] : lo;
    p->floor = lo;
}

static void pool_offer(top_pool *p, const double *fv, size_t m)
{
    for (size_t k = 0; k < m; k++) {
        double a = fabs(fv[k]);
        p->v[p->n] = a;
        p->n += a > p->floor;
        if (p->n == POOL)
            pool_compact(p);
    }
}

/* The block's list: the largest values, descending (an insertion sort of
 * at most QMC_SAMPLING_TOP), zero-padded. */
static void pool_to_top(top_pool *p, double *top)
{
    if (p->n > QMC_SAMPLING_TOP)
        pool_compact(p);
    memset(top, 0, QMC_SAMPLING_TOP * sizeof *top);
    for (size_t k = 0; k < p->n; k++) {
        double x = p->v[k];
        size_t j = k;
        for (; j > 0 && top[j - 1] < x; j--)
            top[j] = top[j - 1];
        top[j] = x;
    }
}

void qmc__top_merge(double *a, const double *b)
{
    for (int i = 0; i < QMC_SAMPLING_TOP && b[i] > 0.0; i++)
        top_insert(a, b[i]);
}

void qmc__moments_merge(qmc_sampling_sums *a, const qmc_sampling_sums *b)
{
    uint64_t na = a->count - a->nonfinite, nb = b->count - b->nonfinite;
    if (nb == 0)
        return;
    if (na == 0) {
        a->mean_f = b->mean_f;
        a->mean_g = b->mean_g;
        a->m2_f = b->m2_f;
        a->m2_g = b->m2_g;
        a->c_fg = b->c_fg;
        return;
    }
    double n = (double)(na + nb), w = (double)na * (double)nb / n;
    double df = b->mean_f - a->mean_f, dg = b->mean_g - a->mean_g;
    a->mean_f += df * ((double)nb / n);
    a->mean_g += dg * ((double)nb / n);
    a->m2_f += b->m2_f + df * df * w;
    a->m2_g += b->m2_g + dg * dg * w;
    a->c_fg += b->c_fg + df * dg * w;
}

/* A block's running sums: f, |f| and g in four lanes each (lane_sum.h),
 * folded into the block's Neumaier pairs when it ends. */
typedef struct {
    qmc__lane_sum f, absf, g;
    top_pool top;
} block_acc;

/* Sum of the lanes of v, in a fixed order. */
static double lanes_total(qmc__f64x4 v)
{
    return (v[0] + v[1]) + (v[2] + v[3]);
}

static int lanes_finite(qmc__f64x4 v)
{
    return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]) && isfinite(v[3]);
}

/* Adds a chunk of m values f (and the control's values less its integral,
 * g, when not NULL): value k of the chunk goes to lane k % 4 of each sum,
 * and the moments are the chunk's own, two-pass (the first pass is the
 * lanes' own), merged by Chan's update.  (Welford's per-point division and
 * then the one chain of each Neumaier sum were the block loop's critical
 * path.)  Unless checked is set, a chunk with a value that is not finite
 * - its |f| or g lanes stop being finite - is left out and 0 returned:
 * the caller drops those points and adds the rest with checked set.
 * Built for AVX2 too (hot_clones.h): 12% of auto's time at d = 2. */
QMC__AVX2_CLONE
static int add_chunk(qmc_sampling_sums *out, block_acc *acc, const double *fv,
                     const double *gv, size_t m, int checked)
{
    qmc__lane_sum sf = acc->f, sa = acc->absf, sg = acc->g; /* in registers */
    qmc__f64x4 plain_f = {0, 0, 0, 0}, plain_g = plain_f;
    for (size_t k = 0; k < m; k += 4) {
        qmc__f64x4 x = qmc__lane_load(fv, k, m);
        qmc__lane_add(&sf, x);
        qmc__lane_add(&sa, qmc__lane_abs(x));
        plain_f += x;
    }
    if (!checked && !lanes_finite(sa.s))
        return 0;
    if (gv) {
        for (size_t k = 0; k < m; k += 4) {
            qmc__f64x4 x = qmc__lane_load(gv, k, m);
            qmc__lane_add(&sg, x);
            plain_g += x;
        }
        if (!checked && !lanes_finite(sg.s))
            return 0;
    }
    acc->f = sf;
    acc->absf = sa;
    acc->g = sg;
    pool_offer(&acc->top, fv, m);
    qmc_sampling_sums c = {.count = m};
    c.mean_f = lanes_total(plain_f) / (double)m;
    double m2[4] = {0, 0, 0, 0};
    size_t k = 0;
    for (; k + 4 <= m; k += 4)
        for (int l = 0; l < 4; l++) {
            double e = fv[k + (size_t)l] - c.mean_f;
            m2[l] += e * e;
        }
    for (; k < m; k++)
        m2[0] += (fv[k] - c.mean_f) * (fv[k] - c.mean_f);
    c.m2_f = (m2[0] + m2[1]) + (m2[2] + m2[3]);
    if (gv) {
        c.mean_g = lanes_total(plain_g) / (double)m;
        for (k = 0; k < m; k++) {
            double eg = gv[k] - c.mean_g;
            c.m2_g += eg * eg;
            c.c_fg += (fv[k] - c.mean_f) * eg;
        }
    }
    qmc__moments_merge(out, &c);
    out->count += m;
    return 1;
}

/* Drops the points whose f or g value is not finite, keeping the order,
 * and returns how many remain. */
static size_t drop_nonfinite(double *fv, double *gv, size_t m)
{
    size_t kept = 0;
    for (size_t k = 0; k < m; k++) {
        if (!isfinite(fv[k]) || (gv && !isfinite(gv[k])))
            continue;
        fv[kept] = fv[k];
        if (gv)
            gv[kept] = gv[k];
        kept++;
    }
    return kept;
}

/* Block `block`: its points in index order, chunk by chunk, evaluated and
 * (out not NULL) summed into *out; with out NULL only evaluated, which
 * calls the integrands exactly as the summing pass does.  With given not
 * NULL (a job without a control), f's values are taken from there in
 * order instead of made: no point is made and f is not called, and the
 * sums are those of a run whose f returned them. */
static int block_pass(const qmc_sampling_job *job, uint64_t block, void *workspace,
                      size_t workspace_bytes, const double *given, qmc_sampling_sums *out)
{
    if (out) {
        memset(out, 0, sizeof *out);
        out->block = block;
    }
    if (block >= qmc_sampling_blocks(job))
        return QMC_ERANGE;
    if (workspace_bytes < qmc_sampling_workspace_bytes(job))
        return QMC_EINVAL;
    const uint32_t r = (uint32_t)(block / job->blocks_per_rep);
    const uint64_t b = block % job->blocks_per_rep;
    const uint64_t first = b * QMC_SAMPLING_BLOCK;
    const uint64_t offset = job->spec.split_net ? (uint64_t)r * job->spec.n : 0;
    const uint64_t end = first + qmc__sampling_block_points(job, block);
    const uint32_t d = job->dims;
    double *x = workspace;
    double *fv = x + (size_t)job->chunk * d;
    double *gv = job->g ? fv + job->chunk : NULL;
    block_acc acc;
    memset(&acc, 0, sizeof acc);
    for (uint64_t i0 = first; i0 < end; i0 += job->chunk) {
        size_t m = end - i0 < job->chunk ? (size_t)(end - i0) : job->chunk;
        if (given) {
            /* copied: dropping a non-finite value rewrites fv in place */
            memcpy(fv, given + (i0 - first), m * sizeof *fv);
        } else {
            int err = qmc_seq_fill(job->seqs[r], offset + i0, m, QMC_FORMAT_F64, x);
            if (err)
                return err;
            job->f->eval(job->f->ctx, x, m, d, fv);
        }
        if (gv) {
            job->g->eval(job->g->ctx, x, m, d, gv);
            for (size_t k = 0; k < m; k++)
                gv[k] -= job->g->exact;
        }
        if (!out || add_chunk(out, &acc, fv, gv, m, 0))
            continue;
        size_t kept = drop_nonfinite(fv, gv, m);
        out->count += m - kept;
        out->nonfinite += m - kept;
        if (kept > 0)
            add_chunk(out, &acc, fv, gv, kept, 1);
    }
    if (!out)
        return 0;
    qmc__lane_fold(&acc.f, out->f);
    qmc__lane_fold(&acc.absf, out->absf);
    qmc__lane_fold(&acc.g, out->g);
    pool_to_top(&acc.top, out->top);
    return 0;
}

int qmc_sampling_run_block(const qmc_sampling_job *job, uint64_t block, void *workspace,
                           size_t workspace_bytes, qmc_sampling_sums *out)
{
    return block_pass(job, block, workspace, workspace_bytes, NULL, out);
}

int qmc__sampling_eval_block(const qmc_sampling_job *job, uint64_t block, void *workspace,
                             size_t workspace_bytes)
{
    return block_pass(job, block, workspace, workspace_bytes, NULL, NULL);
}

int qmc__sampling_block_fill(const qmc_sampling_job *job, uint64_t block, double *dst)
{
    if (block >= qmc_sampling_blocks(job))
        return QMC_ERANGE;
    const uint32_t r = (uint32_t)(block / job->blocks_per_rep);
    const uint64_t first = block % job->blocks_per_rep * QMC_SAMPLING_BLOCK;
    const uint64_t offset = job->spec.split_net ? (uint64_t)r * job->spec.n : 0;
    /* One fill for the whole block: a sequence's batch agrees bit for bit
     * with any split of it (qmc_seq_fill's contract), so these are the
     * points block_pass makes chunk by chunk. */
    return qmc_seq_fill(job->seqs[r], offset + first, qmc__sampling_block_points(job, block),
                        QMC_FORMAT_F64, dst);
}

int qmc__sampling_sum_block(const qmc_sampling_job *job, uint64_t block, const double *values,
                            void *workspace, size_t workspace_bytes, qmc_sampling_sums *out)
{
    if (job->g || !values)
        return QMC_EINVAL;
    return block_pass(job, block, workspace, workspace_bytes, values, out);
}

const char *qmc_sampler_name(qmc_sampler s)
{
    switch (s) {
#define QMC__SAMPLER_TEXT(name, text) \
    case QMC_SAMPLER_##name:          \
        return text;
        QMC_SAMPLER_MAP(QMC__SAMPLER_TEXT)
#undef QMC__SAMPLER_TEXT
    }
    return "";
}

int qmc_sampler_parse(const char *name, qmc_sampler *out)
{
#define QMC__SAMPLER_PARSE(n, text)    \
    if (strcmp(name, text) == 0) {     \
        *out = QMC_SAMPLER_##n;        \
        return 0;                      \
    }
    QMC_SAMPLER_MAP(QMC__SAMPLER_PARSE)
#undef QMC__SAMPLER_PARSE
    return QMC_EINVAL;
}
