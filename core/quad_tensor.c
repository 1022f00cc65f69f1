/*
 * quad_tensor.c - tensor products of one-dimensional rules over [0,1]^d
 * (see qmc/quad.h).
 *
 * A product rule with n points per axis costs n^d evaluations, which
 * passes any budget quickly as d grows; so the cost (fine rule plus the
 * coarser rule that gives the error estimate) is computed first, with
 * overflow checks, and a request over budget is refused before a single
 * evaluation, with a reason that names the cost.
 *
 * Points are walked in lexicographic order by an odometer over the axis
 * indices and handed to the integrand in chunks of TENSOR_CHUNK; the
 * weighted sum is compensated (Neumaier), so that millions of small terms
 * do not lose digits.  Nothing here allocates: nodes, weights, the chunk
 * and the odometer sit in the caller's workspace.
 *
 * The caller's interrupt hook is polled before anything is computed, while
 * Gauss-Legendre nodes are (their O(n^2) work can pass any evaluation
 * count here), and after every chunk, counting evaluations: a cancel
 * takes effect within about QMC_INTERRUPT_EVALS evaluations.
 *
 * The bar |fine - coarse| is checked by evidence that shares none of the
 * levels' nodes (tensor_check, below): the same rule at the next sizes
 * above the coarse level, and a probe of the values' rounding.
 */
#include <float.h>
#include <math.h>
#include <stdint.h>

#include "bits.h"
#include "msg.h"
#include "qmc/quad.h"
#include "quad_impl.h"

#define TENSOR_CHUNK 256u
#define TENSOR_ONE_MINUS 0x1.fffffffffffffp-1

/* n^d, or UINT64_MAX (with *overflow set) when it does not fit. */
static uint64_t pow_u64(uint64_t n, uint32_t d, int *overflow)
{
    uint64_t r = 1;
    for (uint32_t i = 0; i < d; i++) {
        if (n != 0 && r > UINT64_MAX / n) {
            *overflow = 1;
            return UINT64_MAX;
        }
        r *= n;
    }
    return r;
}

/* The coarser rule's n for the error estimate, 0 when there is none. */
static uint32_t coarse_n(qmc_rule1d rule, uint32_t n)
{
    uint32_t c;
    switch (rule) {
    case QMC_RULE1D_MIDPOINT:
    case QMC_RULE1D_GAUSS_LEGENDRE:
        c = n / 2;
        return c >= 1 ? c : 0;
    case QMC_RULE1D_TRAPEZOID:
        c = n / 2 + n % 2; /* (n+1)/2 without overflow */
        return c >= 2 && c < n ? c : 0;
    case QMC_RULE1D_SIMPSON:
        c = n / 2 + n % 2;
        if (c % 2 == 0)
            c--;
        return c >= 3 && c < n ? c : 0;
    default:
        return 0;
    }
}

/* Whether the run keeps each axis's marginal for the Legendre-decay test
 * (gl_marginal_unresolved, below): Gauss-Legendre with enough nodes. */
static int watches_marginals(qmc_rule1d rule, uint32_t n);

size_t qmc_quad_tensor_rule_workspace_bytes(qmc_rule1d rule, uint32_t n, uint32_t dims)
{
    /* fine and coarse nodes and weights (coarse n <= n), the chunk's points,
     * values and weights, the odometer and the chunk's node indices; and
     * for Gauss-Legendre the marginals (n per axis) and their Legendre
     * coefficients (n), which the other rules do not keep (a midpoint rule
     * at 1.3M nodes an axis would hold 31 MB more for nothing) */
    const size_t marg = watches_marginals(rule, n) ? (size_t)dims + 1 : 0;
    if (dims == 0 || n > (SIZE_MAX / sizeof(double) - 4) / ((size_t)dims + 5))
        return 0;
    size_t doubles = (4 + marg) * (size_t)n;
    if (dims > (SIZE_MAX / sizeof(double) - doubles) / (2 * TENSOR_CHUNK) - 2)
        return 0;
    doubles += (size_t)TENSOR_CHUNK * ((size_t)dims + 2);
    size_t words = (size_t)dims * (TENSOR_CHUNK + 1);
    if (doubles > (SIZE_MAX - words * sizeof(uint32_t)) / sizeof(double))
        return 0;
    return doubles * sizeof(double) + words * sizeof(uint32_t);
}

size_t qmc_quad_tensor_workspace_bytes(uint32_t n, uint32_t dims)
{
    return qmc_quad_tensor_rule_workspace_bytes(QMC_RULE1D_GAUSS_LEGENDRE, n, dims);
}

typedef struct tensor_scratch {
    double *px;     /* TENSOR_CHUNK x dims points */
    double *pw;     /* TENSOR_CHUNK product weights */
    double *pf;     /* TENSOR_CHUNK values */
    double *marg;   /* dims x n: sum of w f over the nodes with index k on axis j */
    double *coef;   /* n: one marginal's Legendre coefficients */
    double abs_sum; /* sum of |w f| over the last sum's nodes */
    uint32_t *idx;  /* the odometer, dims digits */
    uint32_t *ridx; /* TENSOR_CHUNK x dims: each row's node indices */
} tensor_scratch;

/* The product rule with m nodes x[], w[] per axis; total = m^dims points,
 * into *out.  Adds the evaluations to *evals and the non-finite values to
 * *nonfinite; with marg, sums each axis's marginal into t->marg (m a
 * axis).  Returns QMC_ECANCELED when the poll fires, else 0. */
static int tensor_sum(const qmc_integrand *f, const double *x,
                      const double *w, uint32_t m, uint64_t total,
                      tensor_scratch *t, int marg, qmc__poll *poll, double *out,
                      uint64_t *evals, uint64_t *nonfinite)
{
    uint32_t d = f->dims;
    double sum = 0.0, comp = 0.0;
    for (uint32_t j = 0; j < d; j++)
        t->idx[j] = 0;
    double abs_sum = 0.0;
    if (marg)
        for (size_t k = 0; k < (size_t)d * m; k++)
            t->marg[k] = 0.0;
    uint64_t left = total;
    while (left > 0) {
        size_t c = left < TENSOR_CHUNK ? (size_t)left : TENSOR_CHUNK;
        for (size_t i = 0; i < c; i++) {
            double wp = 1.0;
            double *row = t->px + i * d;
            for (uint32_t j = 0; j < d; j++) {
                double xj = x[t->idx[j]];
                row[j] = xj >= 1.0 ? TENSOR_ONE_MINUS : xj;
                wp *= w[t->idx[j]];
                t->ridx[i * d + j] = t->idx[j];
            }
            t->pw[i] = wp;
            /* advance the odometer, last axis fastest */
            for (uint32_t j = d; j-- > 0;) {
                if (++t->idx[j] < m)
                    break;
                t->idx[j] = 0;
            }
        }
        f->eval(f->ctx, t->px, c, d, t->pf);
        for (size_t i = 0; i < c; i++) {
            if (!isfinite(t->pf[i]))
                (*nonfinite)++;
            double v = t->pw[i] * t->pf[i], s = sum + v;
            comp += fabs(sum) >= fabs(v) ? (sum - s) + v : (v - s) + sum;
            sum = s;
            abs_sum += fabs(v);
            for (uint32_t j = 0; marg && j < d; j++)
                t->marg[(size_t)j * m + t->ridx[i * d + j]] += v;
        }
        *evals += c;
        left -= c;
        if (qmc__poll_work(poll, c))
            return QMC_ECANCELED;
    }
    *out = sum + comp;
    t->abs_sum = abs_sum;
    return 0;
}

/*
 * Whether Gauss-Legendre's nodes resolve the integrand, seen in its
 * marginals.  The bar |fine - coarse| with n and n/2 nodes an axis holds
 * while the coarse rule is converging: its error then dominates, and the
 * fine one is far smaller.  When neither resolves a feature the two
 * errors are alike, and can agree by chance: a Gaussian of width 1/150 in
 * 3D, 97 and 48 nodes an axis, gave 9.97e-7 +- 3.9e-8 against 1.65e-6
 * (the stability run's peak-gauss-3d).  The fine rule's own values say
 * which: along each axis j, the marginal g(x) (f integrated over the
 * other axes by the rule) has Legendre coefficients
 *     c_l = (2l + 1) sum_k m_k P_l(2 x_k - 1),   m_k = sum of w f over the
 * nodes with index k on axis j, exact for l < n while g is a polynomial
 * of degree < n.  A resolved g's coefficients have decayed well before
 * l = n, and the coarse rule, exact to degree n - 1, is converging; when
 * the top quarter [3n/4, n) still holds GL_TAIL_SHARE of the largest
 * coefficient, the coefficients have not begun to decay (the peak above:
 * 1.0), and the bar is flagged unresolved.  The top quarter, not the upper
 * half: a resolved cosine of frequency near n/2 has its largest
 * coefficients there (oscillatory d = 2 at 16 nodes, error 1e-12: 0.55 in
 * the upper half).  0.9, not 0.5: on the testpack Genz families at 16
 * nodes (bench/scans/smooth_flags.sh) 0.5 flagged 30 correct answers more
 * and 0.9 7, each of them an answer whose error was as large as its bar
 * (oscillatory d = 1: 0.2 against 0.16).  Coefficients below
 * GL_TAIL_FLOOR n sum |w f| are rounding, whatever their ratio.  Not below
 * GL_TAIL_MIN_N nodes an axis.  O(n^2 d) work beside n^d evaluations.
 */
#define GL_TAIL_SHARE 0.9
#define GL_TAIL_FLOOR 1e-12
enum { GL_TAIL_MIN_N = 8 };

static int watches_marginals(qmc_rule1d rule, uint32_t n)
{
    return rule == QMC_RULE1D_GAUSS_LEGENDRE && n >= GL_TAIL_MIN_N;
}

static int gl_marginal_unresolved(const double *x, uint32_t n, uint32_t d, const double *marg,
                                  double *coef, double abs_sum)
{
    /* |c_l| <= (2l + 1) sum |w f|: rounding sits near 1e-16 n abs_sum */
    const double floor_c = GL_TAIL_FLOOR * (double)n * abs_sum;
    for (uint32_t j = 0; j < d; j++) {
        const double *mj = marg + (size_t)j * n;
        for (uint32_t l = 0; l < n; l++)
            coef[l] = 0.0;
        for (uint32_t k = 0; k < n; k++) {
            /* P_0 .. P_(n-1) at the node by the three-term recurrence */
            const double xi = 2.0 * x[k] - 1.0, mk = mj[k];
            double p0 = 1.0, p1 = xi;
            coef[0] += mk;
            coef[1] += mk * xi; /* n >= GL_TAIL_MIN_N > 1 */
            for (uint32_t l = 1; l + 1 < n; l++) {
                double p2 = ((2.0 * l + 1.0) * xi * p1 - (double)l * p0) / (l + 1.0);
                coef[l + 1] += mk * p2;
                p0 = p1;
                p1 = p2;
            }
        }
        double head = 0.0, tail = 0.0;
        for (uint32_t l = 0; l < n; l++) {
            double c = fabs(coef[l]) * (2.0 * l + 1.0);
            head = fmax(head, c);
            if (4 * l >= 3 * n)
                tail = fmax(tail, c);
        }
        if (tail > GL_TAIL_SHARE * head && tail > floor_c)
            return 1;
    }
    return 0;
}

/*
 * The check.  Nested levels share their nodes: when both sample a
 * frequency at the same phase, or both miss a peak, they agree and the bar
 * says "exact" (Simpson at 17 and 9 nodes on cos(100 x): 0.954 +- 1e-7
 * against -0.005; midpoint at 16 and 8 on cos(2 pi 16 (x + y)): 1 +- 0
 * against 0).  So the rule is run again at the TENSOR_SIBLINGS sizes just
 * above the coarse level (n_c + 1, n_c + 2; Simpson n_c + 2, n_c + 4),
 * whose nodes fall between the levels' (a midpoint node (i + 1/2)/m is
 * never one of (j + 1/2)/n when m is odd and n even; trapezoid and
 * Simpson share their end points and a few others; Gauss-Legendre at most
 * the centre).  A resolved integrand converges monotonically: a sibling is
 * nearer the truth than the coarse level, so |sibling - fine| <= |coarse -
 * fine| and the bar stands.  An aliased or missed feature lands at another
 * phase at every size, and the siblings scatter by its amplitude; the bar
 * becomes the largest |sibling - fine|, and where that is a tenth of the
 * estimate the node watch (rule_evidence.h) flags it unresolved.  The
 * siblings cost about two coarse levels: 2 / (2^d + 1) of the rule in d
 * dimensions (67% at d = 1, 12% at d = 4).
 *
 * And a rounding probe: f at TENSOR_PROBES hashed points and one ulp away
 * on every axis (toward 1 or 0 by a hashed bit).  Levels share their
 * rounded values at common nodes, so their difference cannot see rounding;
 * the rms of the probe's differences is what rounding the nodes (and f's
 * own arguments) does to one value, and a sum of values with weights w
 * carries about sqrt(sum w^2) of it when the errors are independent
 * (trapezoid at 334 nodes on cos(27759 x), aliased to a periodic sum of 0:
 * 9e-14 of the integral of |f| off under a bar 21 times smaller).  On four
 * such cosines the error was 0.15-0.57 of rms sqrt(sum w^2), so the floor
 * is TENSOR_ROUND_FACTOR = 2 times that (3.2e-13 on the case above).  Where the
 * floor is above the levels' bar and above TENSOR_ROUND_ULPS ulps of the
 * integral of |f| (below that, last-bit noise any reader allows), the bar
 * is raised to it and `roundoff` set.
 *
 * Both run only within the budget the levels left: siblings in increasing
 * size while they fit, then the probes.  No seed: the same request gives
 * the same bytes.
 */
enum { TENSOR_SIBLINGS = 2, TENSOR_PROBES = 16 };
#define TENSOR_ROUND_FACTOR 2.0
#define TENSOR_ROUND_ULPS 64.0
static const uint64_t TENSOR_PROBE_SEED = 0x74656e736f72ull; /* "tensor" */

/* The sibling sizes (increasing) into m[]; returns how many. */
static uint32_t sibling_sizes(qmc_rule1d rule, uint32_t n, uint32_t nc, uint32_t *m)
{
    const uint32_t step = rule == QMC_RULE1D_SIMPSON ? 2 : 1;
    uint32_t k = 0;
    for (uint32_t c = nc + step; nc && c < n && k < TENSOR_SIBLINGS; c += step)
        m[k++] = c;
    return k;
}

typedef struct tensor_checked {
    double spread;      /* max |sibling - fine|, 0 without siblings */
    double round_floor; /* the probe's floor, 0 without probes */
} tensor_checked;

/* The probes: f at hashed points and one ulp away, into the chunk. */
static void rounding_probe(const qmc_integrand *f, const double *w, uint32_t n,
                           tensor_scratch *t, tensor_checked *out, uint64_t *evals,
                           uint64_t *nonfinite)
{
    const uint32_t d = f->dims, k = TENSOR_PROBES;
    double *x = t->px, *xp = t->px + (size_t)k * d;
    for (uint32_t i = 0; i < k; i++)
        for (uint32_t j = 0; j < d; j++) {
            uint64_t h = qmc__hash3(TENSOR_PROBE_SEED, i, j);
            double v = qmc__u01_from_bits(h);
            double u = nextafter(v, (h & 1) || v == 0.0 ? 1.0 : 0.0);
            x[(size_t)i * d + j] = v;
            xp[(size_t)i * d + j] = u < 1.0 ? u : nextafter(v, 0.0);
        }
    f->eval(f->ctx, x, 2 * k, d, t->pf);
    *evals += 2 * k;
    /* The differences' root mean square, squared at the scale of the
     * largest: a power of two, so the sum is the unscaled one's exactly,
     * but neither squares of 2^1000 nor of 2^-1000 leave the doubles (an
     * integrand times 2^1000 gave a floor of inf: bar inf, roundoff). */
    double big = 0.0;
    for (uint32_t i = 0; i < 2 * k; i++)
        if (!isfinite(t->pf[i]))
            (*nonfinite)++;
    for (uint32_t i = 0; i < k; i++) {
        double diff = fabs(t->pf[k + i] - t->pf[i]);
        if (isfinite(diff) && diff > big)
            big = diff;
    }
    const int e = big > 0.0 ? ilogb(big) : 0;
    double ms = 0.0;
    for (uint32_t i = 0; i < k; i++) {
        double diff = ldexp(t->pf[k + i] - t->pf[i], -e);
        ms += isfinite(diff) ? diff * diff : 0.0;
    }
    /* sqrt(sum of w^2) of the product rule: the 1D one to the d-th */
    double wsq = 0.0;
    for (uint32_t i = 0; i < n; i++)
        wsq += w[i] * w[i];
    out->round_floor =
        TENSOR_ROUND_FACTOR * ldexp(sqrt(ms / k), e) * pow(sqrt(wsq), (double)d);
}

/* Siblings and probes within `left` evaluations, nodes in xs, ws (room for
 * n each).  Returns QMC_ECANCELED when the poll fires, else 0. */
static int tensor_check(const qmc_integrand *f, qmc_rule1d rule, uint32_t n, uint32_t nc,
                        double est, const double *wf, uint64_t left, double *xs, double *ws,
                        tensor_scratch *t, qmc__poll *poll, tensor_checked *out,
                        uint64_t *evals, uint64_t *nonfinite)
{
    uint32_t m[TENSOR_SIBLINGS];
    uint32_t k = sibling_sizes(rule, n, nc, m);
    for (uint32_t i = 0; i < k; i++) {
        int overflow = 0;
        uint64_t cost = pow_u64(m[i], f->dims, &overflow);
        if (overflow || cost > left)
            break;
        int rc = qmc__rule1d_nodes(rule, m[i], xs, ws, poll);
        double q;
        if (rc == 0)
            rc = tensor_sum(f, xs, ws, m[i], cost, t, 0, poll, &q, evals, nonfinite);
        if (rc)
            return rc == QMC_ECANCELED ? rc : 0; /* m is valid: only a cancel */
        out->spread = fmax(out->spread, fabs(q - est));
        left -= cost;
    }
    if (left >= 2 * TENSOR_PROBES)
        rounding_probe(f, wf, n, t, out, evals, nonfinite);
    return 0;
}

uint64_t qmc_quad_tensor_check_evals(qmc_rule1d rule, uint32_t n, uint32_t dims)
{
    uint32_t m[TENSOR_SIBLINGS];
    uint32_t nc = (unsigned)rule < QMC_RULE1D_COUNT ? coarse_n(rule, n) : 0;
    if (nc == 0)
        return 0;
    uint32_t k = sibling_sizes(rule, n, nc, m);
    uint64_t total = 2 * TENSOR_PROBES;
    for (uint32_t i = 0; i < k; i++) {
        int overflow = 0;
        uint64_t c = pow_u64(m[i], dims, &overflow);
        if (overflow || c > UINT64_MAX - total)
            return UINT64_MAX;
        total += c;
    }
    return total;
}

/* "tensor gauss-legendre: 64^6 + 32^6 = 69793218560 evaluations exceed the
 * budget of 10000000" */
static void budget_reason(qmc__msg *m, qmc_rule1d rule, uint32_t n,
                          uint32_t nc, uint32_t d, uint64_t cost, int overflow,
                          uint64_t max_evals)
{
    qmc__msg_str(m, "tensor ");
    qmc__msg_str(m, qmc_rule1d_name(rule));
    qmc__msg_str(m, ": ");
    qmc__msg_u64(m, n);
    qmc__msg_str(m, "^");
    qmc__msg_u64(m, d);
    if (nc) {
        qmc__msg_str(m, " + ");
        qmc__msg_u64(m, nc);
        qmc__msg_str(m, "^");
        qmc__msg_u64(m, d);
    }
    if (overflow) {
        qmc__msg_str(m, " > ");
        qmc__msg_u64(m, UINT64_MAX);
    } else {
        qmc__msg_str(m, " = ");
        qmc__msg_u64(m, cost);
    }
    qmc__msg_str(m, " evaluations exceed the budget of ");
    qmc__msg_u64(m, max_evals);
}

/* The interrupt hook fired: no estimate, only the evaluations spent. */
static int cancelled(qmc__msg *m, qmc_result *res, uint64_t evals)
{
    qmc__msg_set(m, "tensor: stopped by the interrupt hook after ", evals,
                 " evaluations");
    return qmc__cancelled(res, res->dims, evals);
}

int qmc_quad_tensor(const qmc_integrand *f, qmc_rule1d rule, uint32_t n,
                    uint64_t max_evals, const qmc_interrupt *interrupt,
                    void *workspace, size_t workspace_bytes, qmc_result *res,
                    char *why, size_t why_bytes)
{
    qmc__msg m;
    qmc__msg_init(&m, why, why_bytes);
    if (!res) {
        qmc__msg_str(&m, "tensor: no result");
        return QMC_EINVAL;
    }
    qmc_result_init(res);
    res->error_kind = QMC_ERROR_ESTIMATE;
    if (!f || !f->eval || !workspace) {
        qmc__msg_str(&m, "tensor: no integrand or workspace");
        return QMC_EINVAL;
    }
    uint32_t d = f->dims;
    res->dims = d;
    if (d == 0) {
        qmc__msg_str(&m, "tensor: the integrand has 0 dimensions");
        return QMC_EDIMS;
    }
    int rc = qmc_rule1d_check(rule, n, why, why_bytes);
    if (rc < 0)
        return rc;
    size_t need = qmc_quad_tensor_rule_workspace_bytes(rule, n, d);
    if (need == 0 || workspace_bytes < need
        || (uintptr_t)workspace % _Alignof(double) != 0) {
        qmc__msg_set(&m, "tensor: the workspace must be aligned and hold ",
                     need, " bytes");
        return QMC_EINVAL;
    }

    uint32_t nc = coarse_n(rule, n);
    int overflow = 0;
    uint64_t fine = pow_u64(n, d, &overflow);
    uint64_t coarse = nc ? pow_u64(nc, d, &overflow) : 0;
    uint64_t cost = overflow || fine > UINT64_MAX - coarse ? UINT64_MAX
                                                           : fine + coarse;
    if (cost == UINT64_MAX)
        overflow = 1;
    if (overflow || cost > max_evals) {
        budget_reason(&m, rule, n, nc, d, cost, overflow, max_evals);
        return QMC_EBUDGET;
    }

    double *xf = workspace, *wf = xf + n, *xc = wf + n, *wc = xc + n;
    tensor_scratch t;
    t.px = wc + n;
    t.pw = t.px + (size_t)TENSOR_CHUNK * d;
    t.pf = t.pw + TENSOR_CHUNK;
    const int watch = watches_marginals(rule, n);
    t.marg = t.pf + TENSOR_CHUNK;
    t.coef = t.marg + (watch ? (size_t)d * n : 0);
    t.idx = (uint32_t *)(t.coef + (watch ? n : 0));
    t.ridx = t.idx + d;
    qmc__poll poll;
    qmc__poll_init(&poll, interrupt);
    if (qmc__poll_now(&poll))
        return cancelled(&m, res, 0);
    rc = qmc__rule1d_nodes(rule, n, xf, wf, &poll);
    if (rc == 0 && nc)
        rc = qmc__rule1d_nodes(rule, nc, xc, wc, &poll);
    if (rc == QMC_ECANCELED)
        return cancelled(&m, res, 0);
    if (rc < 0) {
        qmc__msg_str(&m, "tensor: the rule's nodes failed");
        return rc;
    }

    uint64_t evals = 0, nonfinite = 0;
    double est, err;
    if (tensor_sum(f, xf, wf, n, fine, &t, watch, &poll, &est, &evals, &nonfinite))
        return cancelled(&m, res, evals);
    uint32_t flags = 0;
    /* The fine rule's integral of |f|: the scale the bar is judged against
     * (rule_evidence.h) and the reader's "relative to the integral of
     * |f|" for integrals near 0. */
    const double abs_fine = t.abs_sum;
    if (watch && !nonfinite && gl_marginal_unresolved(xf, n, d, t.marg, t.coef, t.abs_sum))
        flags |= QMC_FLAG_UNRESOLVED | QMC_FLAG_ERROR_UNRELIABLE;
    if (nc) {
        double low;
        if (tensor_sum(f, xc, wc, nc, coarse, &t, 0, &poll, &low, &evals, &nonfinite))
            return cancelled(&m, res, evals);
        err = fabs(est - low);
    } else {
        err = fabs(est);
        flags |= QMC_FLAG_ERROR_UNRELIABLE;
    }
    /* the siblings and the probe, in the coarse level's node arrays; a
     * bar flagged already (no coarse level) has nothing to check */
    tensor_checked chk = {0.0, 0.0};
    if (nc && tensor_check(f, rule, n, nc, est, wf, max_evals - cost, xc, wc, &t, &poll, &chk,
                           &evals, &nonfinite))
        return cancelled(&m, res, evals);
    const double scale = fmax(fabs(est), isfinite(abs_fine) ? abs_fine : 0.0);
    if (chk.round_floor > err && chk.round_floor > TENSOR_ROUND_ULPS * DBL_EPSILON * scale)
        flags |= QMC_FLAG_ROUNDOFF;
    else
        chk.round_floor = 0.0;
    err = fmax(err, fmax(chk.spread, chk.round_floor));
    if (nonfinite)
        flags |= QMC_FLAG_NONFINITE | QMC_FLAG_ERROR_UNRELIABLE;
    res->estimate = est;
    res->error = err;
    res->ci_low = est - err;
    res->ci_high = est + err;
    res->n = fine;
    res->evals = evals;
    res->nonfinite = nonfinite;
    res->flags = flags;
    res->abs_integral = isfinite(abs_fine) ? abs_fine : 0.0;
    return 0;
}
