/*
 * quad_rules.c - one-dimensional rules on [0,1] as nodes and weights, and
 * the table of rule names (see qmc/quad.h).
 *
 * The composite Newton-Cotes rules are written here; Gauss-Legendre lives
 * in gauss_legendre.c.  Nothing here evaluates an integrand or allocates.
 */
#include <string.h>

#include "msg.h"
#include "qmc/quad.h"
#include "quad_impl.h"

static const struct {
    const char *key;
    uint32_t min_n;
} rule_table[QMC_RULE1D_COUNT] = {
#define QMC__RULE1D_ROW(name, value, key, min_n, text) [value] = {key, min_n},
    QMC_RULE1D_MAP(QMC__RULE1D_ROW)
#undef QMC__RULE1D_ROW
};

const char *qmc_rule1d_name(qmc_rule1d rule)
{
    if ((unsigned)rule >= QMC_RULE1D_COUNT)
        return "";
    return rule_table[rule].key;
}

int qmc_rule1d_parse(const char *name, qmc_rule1d *rule)
{
    if (!name || !rule)
        return QMC_EINVAL;
    for (unsigned i = 0; i < QMC_RULE1D_COUNT; i++) {
        if (strcmp(name, rule_table[i].key) == 0) {
            *rule = (qmc_rule1d)i;
            return 0;
        }
    }
    return QMC_EKIND;
}

int qmc_rule1d_check(qmc_rule1d rule, uint32_t n, char *why, size_t why_bytes)
{
    qmc__msg m;
    qmc__msg_init(&m, why, why_bytes);
    if ((unsigned)rule >= QMC_RULE1D_COUNT) {
        qmc__msg_set(&m, "unknown one-dimensional rule ", (uint64_t)rule, "");
        return QMC_EKIND;
    }
    const char *key = rule_table[rule].key;
    if (rule == QMC_RULE1D_SIMPSON && (n < 3 || n % 2 == 0)) {
        qmc__msg_str(&m, key);
        qmc__msg_str(&m, " needs an odd n >= 3, got ");
        qmc__msg_u64(&m, n);
        return QMC_ECOUNT;
    }
    if (n < rule_table[rule].min_n) {
        qmc__msg_str(&m, key);
        qmc__msg_str(&m, " needs n >= ");
        qmc__msg_u64(&m, rule_table[rule].min_n);
        qmc__msg_str(&m, ", got ");
        qmc__msg_u64(&m, n);
        return QMC_ECOUNT;
    }
    if (rule == QMC_RULE1D_GAUSS_LEGENDRE && n > QMC_GAUSS_LEGENDRE_MAX_N) {
        qmc__msg_str(&m, key);
        qmc__msg_str(&m, " needs n <= ");
        qmc__msg_u64(&m, QMC_GAUSS_LEGENDRE_MAX_N);
        qmc__msg_str(&m, ", got ");
        qmc__msg_u64(&m, n);
        return QMC_ECOUNT;
    }
    return 0;
}

/* Nodes i/(n-1) are computed by one division each, so they are correctly
 * rounded and exactly symmetric; weights are multiples of h = 1/(n-1). */
static void newton_cotes(uint32_t n, int simpson, double *x, double *w)
{
    double h = 1.0 / (double)(n - 1);
    for (uint32_t i = 0; i < n; i++) {
        x[i] = (double)i / (double)(n - 1);
        if (simpson)
            w[i] = (i == 0 || i == n - 1) ? h / 3.0
                   : (i % 2 ? 4.0 * h / 3.0 : 2.0 * h / 3.0);
        else
            w[i] = (i == 0 || i == n - 1) ? h / 2.0 : h;
    }
}

int qmc_rule1d_nodes(qmc_rule1d rule, uint32_t n, double *x, double *w)
{
    return qmc__rule1d_nodes(rule, n, x, w, NULL);
}

int qmc__rule1d_nodes(qmc_rule1d rule, uint32_t n, double *x, double *w, qmc__poll *poll)
{
    if (!x || !w)
        return QMC_EINVAL;
    int rc = qmc_rule1d_check(rule, n, NULL, 0);
    if (rc < 0)
        return rc;
    switch (rule) {
    case QMC_RULE1D_MIDPOINT:
        for (uint32_t i = 0; i < n; i++) {
            x[i] = ((double)i + 0.5) / (double)n;
            w[i] = 1.0 / (double)n;
        }
        return 0;
    case QMC_RULE1D_TRAPEZOID:
        newton_cotes(n, 0, x, w);
        return 0;
    case QMC_RULE1D_SIMPSON:
        newton_cotes(n, 1, x, w);
        return 0;
    case QMC_RULE1D_GAUSS_LEGENDRE:
        return qmc__gauss_legendre(n, x, w, poll);
    default:
        return QMC_EKIND;
    }
}
