/*
 * method_spec.c - method tokens and budgets for `qmc stability` and
 * `qmc compare` (see method_spec.h).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "method_spec.h"
#include "qmc/quad.h"

enum { CLI_GL_MAX_AXIS = 2048 };

int cli_method_parse(const char *token, cli_method *m, char *why, size_t why_bytes)
{
    memset(m, 0, sizeof *m);
    char buf[CLI_METHOD_NAME_BYTES];
    if (strlen(token) >= sizeof buf) {
        snprintf(why, why_bytes, "method '%.40s...' is too long", token);
        return -1;
    }
    strcpy(buf, token);
    char *parts[4] = {buf, NULL, NULL, NULL};
    int n = 1;
    for (char *p = buf; *p; p++)
        if (*p == '/') {
            if (n == 3) {
                snprintf(why, why_bytes, "method '%s': want METHOD[/SEQ[/SCRAMBLE]]", token);
                return -1;
            }
            *p = '\0';
            parts[n++] = p + 1;
        }
    if (qmc_method_parse(parts[0], &m->method) != 0) {
        snprintf(why, why_bytes, "unknown method '%s' (auto, mc, stratified, lhs, qmc, rqmc, "
                 "midpoint, trapezoid, simpson, gauss-legendre, gauss-kronrod, cubature, "
                 "clenshaw-curtis)", parts[0]);
        return -1;
    }
    int seq_method = m->method == QMC_METHOD_QMC || m->method == QMC_METHOD_RQMC;
    if (n > 1 && !seq_method) {
        snprintf(why, why_bytes, "method '%s': only qmc and rqmc take /SEQ/SCRAMBLE", token);
        return -1;
    }
    m->seq = QMC_SEQ_SOBOL;
    m->scramble = m->method == QMC_METHOD_RQMC ? QMC_SCRAMBLE_OWEN : QMC_SCRAMBLE_NONE;
    if (n > 1 && qmc_seq_kind_parse(parts[1], &m->seq) != 0) {
        snprintf(why, why_bytes, "method '%s': unknown sequence '%s'", token, parts[1]);
        return -1;
    }
    if (n > 2 && qmc_scramble_parse(parts[2], &m->scramble) != 0) {
        snprintf(why, why_bytes, "method '%s': unknown scramble '%s' (none, shift, owen, faure, fast-owen)",
                 token, parts[2]);
        return -1;
    }
    switch (m->method) {
    case QMC_METHOD_MC: case QMC_METHOD_STRATIFIED: case QMC_METHOD_LHS:
    case QMC_METHOD_RQMC: case QMC_METHOD_AUTO:
        m->randomized = 1;
        break;
    case QMC_METHOD_QMC:
        m->randomized = m->scramble != QMC_SCRAMBLE_NONE;
        break;
    default:
        m->randomized = 0;
    }
    if (seq_method && (n > 1 || m->method == QMC_METHOD_QMC || m->method == QMC_METHOD_RQMC))
        snprintf(m->name, sizeof m->name, "%s/%s/%s", qmc_method_name(m->method),
                 qmc_seq_kind_name(m->seq), qmc_scramble_name(m->scramble));
    else
        snprintf(m->name, sizeof m->name, "%s", qmc_method_name(m->method));
    return 0;
}

/* k^d, or n + 1 once it passes n. */
static uint64_t power_upto(uint64_t k, uint32_t d, uint64_t n)
{
    uint64_t p = 1;
    for (uint32_t j = 0; j < d && p <= n; j++)
        p = p > n / k ? n + 1 : p * k;
    return p;
}

/* The largest k >= k_min with k^d <= n, else k_min: a floating-point
 * guess, then corrected by exact integer powers. */
static uint64_t largest_root(uint64_t n, uint32_t d, uint64_t k_min)
{
    uint64_t k = (uint64_t)pow((double)(n ? n : 1), 1.0 / (double)(d ? d : 1));
    if (k < 1)
        k = 1;
    while (k > 1 && power_upto(k, d, n) > n)
        k--;
    while (power_upto(k + 1, d, n) <= n)
        k++;
    return k < k_min ? k_min : k;
}

static qmc_rule1d tensor_rule(qmc_method m)
{
    switch (m) {
    case QMC_METHOD_MIDPOINT: return QMC_RULE1D_MIDPOINT;
    case QMC_METHOD_TRAPEZOID: return QMC_RULE1D_TRAPEZOID;
    case QMC_METHOD_SIMPSON: return QMC_RULE1D_SIMPSON;
    default: return QMC_RULE1D_GAUSS_LEGENDRE;
    }
}

/* A tensor rule's evaluations at k points an axis, checked (n + 1 once
 * past n).  A budget of 16 times QMC_INTEGRATE_CONFIRM_EVALS or more also
 * keeps a sixteenth for the evidence that confirms a doubtful bar (the
 * Gauss-Kronrod check from declared 1D breaks, then an RQMC pilot:
 * rule_confirm.h, rule_pilot.h), so that such a run is checked too;
 * smaller budgets keep their grids (a sixteenth would move them). */
static uint64_t tensor_cost(qmc_rule1d rule, uint64_t k, uint32_t d, uint64_t n)
{
    uint64_t levels = power_upto(k, d, n) + power_upto((k + 1) / 2, d, n);
    uint64_t check = qmc_quad_tensor_check_evals(rule, k > UINT32_MAX ? UINT32_MAX : (uint32_t)k, d);
    if (check != UINT64_MAX && n / 16 >= QMC_INTEGRATE_CONFIRM_EVALS)
        check = check > UINT64_MAX - n / 16 ? UINT64_MAX : check + n / 16;
    return levels > n || check > n - levels ? n + 1 : levels + check;
}

static uint64_t floor_pow2(uint64_t n)
{
    uint64_t p = 1;
    while (p <= n / 2)
        p *= 2;
    return p;
}

void cli_method_spec(const cli_method *m, const cli_budget *b, qmc_integrate_spec *s)
{
    qmc_integrate_spec_init(s);
    s->method = m->method;
    s->max_evals = b->evals;
    qmc_sampler smp = QMC_SAMPLER_MC;
    switch (m->method) {
    case QMC_METHOD_STRATIFIED: smp = QMC_SAMPLER_STRATIFIED; break;
    case QMC_METHOD_LHS: smp = QMC_SAMPLER_LHS; break;
    case QMC_METHOD_QMC: smp = QMC_SAMPLER_QMC; break;
    case QMC_METHOD_RQMC: smp = QMC_SAMPLER_RQMC; break;
    default: break;
    }
    qmc_sampling_spec_init(&s->sampling, smp);
    s->sampling.seed = b->seed;
    switch (m->method) {
    case QMC_METHOD_MC: case QMC_METHOD_LHS: case QMC_METHOD_QMC:
        s->sampling.n = b->evals ? b->evals : 1;
        if (m->method == QMC_METHOD_QMC && b->pow2)
            s->sampling.n = floor_pow2(s->sampling.n);
        s->sampling.reps = 1;
        s->sampling.seq = m->seq;
        s->sampling.scramble = m->scramble;
        s->n_given = 1;
        break;
    case QMC_METHOD_STRATIFIED: {
        uint64_t k = largest_root(b->evals, b->dims, 1), n = 1;
        for (uint32_t j = 0; j < b->dims; j++)
            n *= k;
        s->sampling.n = n;
        s->sampling.reps = 1;
        s->n_given = 1;
        break;
    }
    case QMC_METHOD_RQMC: {
        uint32_t reps = b->reps ? b->reps : 16;
        s->sampling.reps = reps;
        s->sampling.n = b->evals / reps ? b->evals / reps : 1;
        if (b->pow2)
            s->sampling.n = floor_pow2(s->sampling.n);
        s->sampling.seq = m->seq;
        s->sampling.scramble = m->scramble;
        s->n_given = 1;
        break;
    }
    case QMC_METHOD_MIDPOINT: case QMC_METHOD_TRAPEZOID: case QMC_METHOD_SIMPSON:
    case QMC_METHOD_GAUSS_LEGENDRE: {
        /* A tensor rule also evaluates its half-size rule for the error
         * estimate, n^d + ceil(n/2)^d evaluations, and then checks its bar
         * (qmc_quad_tensor_check_evals) with what the budget leaves: room
         * is left for the check, so that every run is checked. */
        const qmc_rule1d rule = tensor_rule(m->method);
        uint64_t k = largest_root(b->evals, b->dims, 2);
        /* Gauss-Legendre nodes cost O(n^2) to compute (0.35 s at 4096):
         * past 2048 an axis the budget buys time, not accuracy worth it. */
        if (m->method == QMC_METHOD_GAUSS_LEGENDRE && k > CLI_GL_MAX_AXIS)
            k = CLI_GL_MAX_AXIS;
        int odd = m->method == QMC_METHOD_SIMPSON; /* Simpson wants an odd count */
        if (odd && k % 2 == 0)
            k--;
        uint64_t floor_k = odd ? 3 : 2;
        while (k > floor_k && tensor_cost(rule, k, b->dims, b->evals) > b->evals)
            k -= odd ? 2 : 1;
        if (k < floor_k)
            k = floor_k;
        s->n_axis = k > UINT32_MAX ? UINT32_MAX : (uint32_t)k;
        s->n_given = 1;
        break;
    }
    default:
        /* gauss-kronrod, cubature, clenshaw-curtis, auto: adaptive under
         * the budget */
        if (b->exhaust)
            s->tol_rel = 1e-15;
        break;
    }
}
