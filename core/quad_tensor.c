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
 */
#include <math.h>
#include <stdint.h>

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

size_t qmc_quad_tensor_workspace_bytes(uint32_t n, uint32_t dims)
{
    /* fine and coarse nodes and weights (coarse n <= n), the chunk's points,
     * values and weights, and the odometer */
    size_t doubles = 4 * (size_t)n;
    if (dims > (SIZE_MAX / sizeof(double) - doubles) / TENSOR_CHUNK - 2)
        return 0;
    doubles += (size_t)TENSOR_CHUNK * ((size_t)dims + 2);
    if (doubles > (SIZE_MAX - (size_t)dims * sizeof(uint32_t)) / sizeof(double))
        return 0;
    return doubles * sizeof(double) + (size_t)dims * sizeof(uint32_t);
}

typedef struct tensor_scratch {
    double *px;     /* TENSOR_CHUNK x dims points */
    double *pw;     /* TENSOR_CHUNK product weights */
    double *pf;     /* TENSOR_CHUNK values */
    uint32_t *idx;  /* the odometer, dims digits */
} tensor_scratch;

/* The product rule with m nodes x[], w[] per axis; total = m^dims points,
 * into *out.  Adds the evaluations to *evals and the non-finite values to
 * *nonfinite.  Returns QMC_ECANCELED when the poll fires, else 0. */
static int tensor_sum(const qmc_integrand *f, const double *x,
                      const double *w, uint32_t m, uint64_t total,
                      const tensor_scratch *t, qmc__poll *poll, double *out,
                      uint64_t *evals, uint64_t *nonfinite)
{
    uint32_t d = f->dims;
    double sum = 0.0, comp = 0.0;
    for (uint32_t j = 0; j < d; j++)
        t->idx[j] = 0;
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
        }
        *evals += c;
        left -= c;
        if (qmc__poll_work(poll, c))
            return QMC_ECANCELED;
    }
    *out = sum + comp;
    return 0;
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
    size_t need = qmc_quad_tensor_workspace_bytes(n, d);
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
    t.idx = (uint32_t *)(t.pf + TENSOR_CHUNK);
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
    if (tensor_sum(f, xf, wf, n, fine, &t, &poll, &est, &evals, &nonfinite))
        return cancelled(&m, res, evals);
    uint32_t flags = 0;
    if (nc) {
        double low;
        if (tensor_sum(f, xc, wc, nc, coarse, &t, &poll, &low, &evals, &nonfinite))
            return cancelled(&m, res, evals);
        err = fabs(est - low);
    } else {
        err = fabs(est);
        flags |= QMC_FLAG_ERROR_UNRELIABLE;
    }
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
    return 0;
}
