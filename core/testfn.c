/*
 * testfn.c - the test-function registry: one X-macro table of names, and
 * the lifetime of a qmc_testfn (validation, defaults, the integrand view).
 *
 * The table row says what parameters a function takes; this file checks
 * them, fills defaults, copies them into the testfn, and hands over to the
 * function's setup hook (genz.c, testfn_1d.c) for derived values and the
 * exact integral.
 *
 * Must not: allocate anywhere but qmc_testfn_new, or keep state.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "msg.h"
#include "testfn_impl.h"

/* How many values a parameter list takes. */
typedef enum param_rule {
    P_NONE,  /* none */
    P_DIMS,  /* exactly dims */
    P_ONE,   /* at most one */
    P_COEFS  /* 1 .. QMC_TESTFN_MAX_COEFS */
} param_rule;

/* What values a's list takes (u's are always in [0,1]). */
typedef enum param_domain {
    D_POSITIVE, /* finite and > 0 */
    D_FINITE
} param_domain;

#define NOT_GENZ (-1)

static const double poly_default[] = {0, 0, 0, 0, 0, 1}; /* x^5 */
/* A default list in a table row: the array and its length, or none. */
#define DEF(arr) arr, sizeof(arr) / sizeof(double)
#define NODEF NULL, 0
static const double one_default[] = {1.0};
static const double step_default[] = {0.3};

/*
 * X(name, genz family or NOT_GENZ, smoothness, max dims, a rule, a domain,
 *   default a (NODEF for Genz: drawn), u rule, default u, hooks prefix
 *   (prefix_setup, prefix_eval), help)
 */
#define QMC__TESTFN_MAP(X)                                                    \
    X("genz-oscillatory", QMC_GENZ_OSCILLATORY, ANALYTIC,                     \
      QMC_TESTFN_MAX_DIMS, P_DIMS, D_POSITIVE, NODEF, P_DIMS, NODEF,          \
      qmc__genz_osc,                                                          \
      "cos(2 pi u1 + sum a_i x_i); a_i > 0, u_i in [0,1], dims each; "        \
      "int |f| not known")                                                    \
    X("genz-product-peak", QMC_GENZ_PRODUCT_PEAK, ANALYTIC,                   \
      QMC_TESTFN_MAX_DIMS, P_DIMS, D_POSITIVE, NODEF, P_DIMS, NODEF,          \
      qmc__genz_ppeak,                                                        \
      "prod 1/(a_i^-2 + (x_i - u_i)^2); a_i > 0, u_i in [0,1], dims each")    \
    X("genz-corner-peak", QMC_GENZ_CORNER_PEAK, ANALYTIC,                     \
      QMC_TESTFN_MAX_DIMS, P_DIMS, D_POSITIVE, NODEF, P_DIMS, NODEF,          \
      qmc__genz_corner,                                                       \
      "(1 + sum a_i x_i)^-(dims+1); a_i > 0, u_i in [0,1] (unused), "         \
      "dims each")                                                            \
    X("genz-gaussian", QMC_GENZ_GAUSSIAN, ANALYTIC, QMC_TESTFN_MAX_DIMS,      \
      P_DIMS, D_POSITIVE, NODEF, P_DIMS, NODEF, qmc__genz_gauss,              \
      "exp(-sum a_i^2 (x_i - u_i)^2); a_i > 0, u_i in [0,1], dims each")      \
    X("genz-continuous", QMC_GENZ_CONTINUOUS, CONTINUOUS,                     \
      QMC_TESTFN_MAX_DIMS, P_DIMS, D_POSITIVE, NODEF, P_DIMS, NODEF,          \
      qmc__genz_cont,                                                         \
      "exp(-sum a_i |x_i - u_i|); a_i > 0, u_i in [0,1], dims each")          \
    X("genz-discontinuous", QMC_GENZ_DISCONTINUOUS, DISCONTINUOUS,            \
      QMC_TESTFN_MAX_DIMS, P_DIMS, D_POSITIVE, NODEF, P_DIMS, NODEF,          \
      qmc__genz_disc,                                                         \
      "0 if x1 > u1 or x2 > u2, else exp(sum a_i x_i); a_i > 0, "             \
      "u_i in [0,1], dims each")                                              \
    X("poly", NOT_GENZ, ANALYTIC, 1, P_COEFS, D_FINITE, DEF(poly_default),    \
      P_NONE, NODEF, qmc__fn1d_poly,                                          \
      "c0 + c1 x + ... on [0,1]; a = c0, c1, ... (up to 32); default x^5, "   \
      "exact 1/6")                                                            \
    X("exp", NOT_GENZ, ANALYTIC, 1, P_ONE, D_POSITIVE, DEF(one_default),      \
      P_NONE, NODEF, qmc__fn1d_exp,                                           \
      "e^(a1 x) on [0,1]; a1 > 0, default 1: exact e - 1")                    \
    X("cos", NOT_GENZ, ANALYTIC, 1, P_ONE, D_POSITIVE, DEF(one_default),      \
      P_NONE, NODEF, qmc__fn1d_cos,                                           \
      "cos(a1 x) on [0,1]; a1 > 0, default 1; exact sin(a1)/a1")              \
    X("inv-sqrt", NOT_GENZ, SINGULAR, 1, P_NONE, D_POSITIVE, NODEF, P_NONE,   \
      NODEF, qmc__fn1d_invsqrt, "x^-1/2 on [0,1]; exact 2; +inf at 0")        \
    X("log", NOT_GENZ, SINGULAR, 1, P_NONE, D_POSITIVE, NODEF, P_NONE, NODEF, \
      qmc__fn1d_log, "log x on [0,1]; exact -1; -inf at 0")                   \
    X("step", NOT_GENZ, DISCONTINUOUS, 1, P_NONE, D_POSITIVE, NODEF, P_ONE,   \
      DEF(step_default), qmc__fn1d_step,                                      \
      "1 for x < u1 else 0 on [0,1]; u1 in [0,1], default 0.3; exact u1")

typedef struct entry {
    const char *name;
    int genz;
    qmc_smoothness smoothness;
    uint32_t max_dims;
    param_rule a_rule;
    param_domain a_domain;
    const double *a_default;
    size_t n_a_default;
    param_rule u_rule;
    const double *u_default;
    size_t n_u_default;
    qmc__testfn_setup_fn *setup;
    qmc__testfn_eval_fn *eval;
    const char *help;
} entry;

static const entry table[] = {
#define QMC__TESTFN_ROW(name, genz, smooth, max_dims, a_rule, a_dom, a_def,   \
                        u_rule, u_def, fn, help)                              \
    {name, genz, QMC_SMOOTH_##smooth, max_dims, a_rule, a_dom, a_def, u_rule, \
     u_def, fn##_setup, fn##_eval, help},
    QMC__TESTFN_MAP(QMC__TESTFN_ROW)
#undef QMC__TESTFN_ROW
};

#define TABLE_LEN (sizeof table / sizeof table[0])

size_t qmc_testfn_count(void)
{
    return TABLE_LEN;
}

const char *qmc_testfn_name(size_t index)
{
    return index < TABLE_LEN ? table[index].name : NULL;
}

const char *qmc_testfn_help(size_t index)
{
    return index < TABLE_LEN ? table[index].help : NULL;
}

int qmc_testfn_lookup(const char *name, size_t *index)
{
    if (!index)
        return QMC_EINVAL;
    *index = TABLE_LEN;
    if (!name)
        return QMC_EINVAL;
    for (size_t i = 0; i < TABLE_LEN; i++)
        if (strcmp(name, table[i].name) == 0) {
            *index = i;
            return 0;
        }
    return QMC_EINVAL;
}

void qmc__testfn_break_at_u1(qmc_testfn *fn)
{
    if (fn->dims == 1 && fn->n_u >= 1 && fn->u[0] > 0.0 && fn->u[0] < 1.0) {
        fn->view.breaks = fn->u;
        fn->view.n_breaks = 1;
    }
}

void qmc__testfn_set_exact(qmc_testfn *fn, double exact, int has_abs,
                           double abs_integral)
{
    fn->view.exact = exact;
    fn->view.has_exact = isfinite(exact) ? 1 : 0;
    fn->view.abs_integral = has_abs ? abs_integral : 0.0;
    fn->view.has_abs_integral = has_abs && isfinite(abs_integral) ? 1 : 0;
}

/* ---- validation ---------------------------------------------------------- */

/* Checks a list's length against its rule; a NULL list means defaults. */
static int check_count(const entry *e, const char *list, param_rule rule,
                       const double *v, size_t n, uint32_t dims, qmc__msg *m)
{
    if (!v)
        return 0;
    int ok = 0;
    switch (rule) {
    case P_NONE:
        ok = n == 0;
        break;
    case P_DIMS:
        ok = n == dims;
        break;
    case P_ONE:
        ok = n <= 1;
        break;
    case P_COEFS:
        ok = n >= 1 && n <= QMC_TESTFN_MAX_COEFS;
        break;
    }
    if (ok)
        return 0;
    qmc__msg_str(m, e->name);
    switch (rule) {
    case P_NONE:
        qmc__msg_str(m, " takes no ");
        qmc__msg_str(m, list);
        qmc__msg_str(m, " values");
        break;
    case P_DIMS:
        qmc__msg_str(m, " takes exactly ");
        qmc__msg_u64(m, dims);
        qmc__msg_str(m, " ");
        qmc__msg_str(m, list);
        qmc__msg_str(m, " values (one per dimension)");
        break;
    case P_ONE:
        qmc__msg_str(m, " takes at most one ");
        qmc__msg_str(m, list);
        qmc__msg_str(m, " value");
        break;
    case P_COEFS:
        qmc__msg_str(m, " takes 1..");
        qmc__msg_u64(m, QMC_TESTFN_MAX_COEFS);
        qmc__msg_str(m, " coefficients as a");
        break;
    }
    qmc__msg_str(m, ", got ");
    qmc__msg_u64(m, n);
    return QMC_EINVAL;
}

static int check_values(const entry *e, const char *list, int is_u,
                        param_domain dom, const double *v, size_t n,
                        qmc__msg *m)
{
    for (size_t i = 0; v && i < n; i++) {
        double x = v[i];
        int ok = is_u ? (x >= 0.0 && x <= 1.0)
                      : dom == D_POSITIVE ? (isfinite(x) && x > 0.0)
                                          : isfinite(x);
        if (ok)
            continue;
        qmc__msg_str(m, list);
        qmc__msg_str(m, "[");
        qmc__msg_u64(m, i);
        qmc__msg_str(m, "] of ");
        qmc__msg_str(m, e->name);
        qmc__msg_str(m, is_u ? " must lie in [0, 1]"
                        : dom == D_POSITIVE ? " must be finite and > 0"
                                            : " must be finite");
        return QMC_EDOMAIN;
    }
    return 0;
}

static void unknown_name(const char *name, qmc__msg *m)
{
    qmc__msg_str(m, "unknown test function '");
    qmc__msg_str(m, name);
    qmc__msg_str(m, "'; valid:");
    for (size_t i = 0; i < TABLE_LEN; i++) {
        qmc__msg_str(m, " ");
        qmc__msg_str(m, table[i].name);
    }
}

/* Copies a list, or its default, into a new array; n_out gets the count. */
static int take_list(const double *v, size_t n, const double *def,
                     size_t n_def, double **out, size_t *n_out)
{
    if (!v || n == 0) {
        v = def;
        n = def ? n_def : 0;
    }
    *n_out = n;
    *out = NULL;
    if (n == 0)
        return 0;
    *out = malloc(n * sizeof(double));
    if (!*out)
        return QMC_ENOMEM;
    memcpy(*out, v, n * sizeof(double));
    return 0;
}

int qmc_testfn_new(const char *name, uint32_t dims, const double *a,
                   size_t n_a, const double *u, size_t n_u, qmc_testfn **out,
                   char *why, size_t why_bytes)
{
    qmc__msg m;
    qmc__msg_init(&m, why, why_bytes);
    qmc_testfn *fn = NULL;
    int rc;
    if (out)
        *out = NULL;
    if (!name || !out) {
        qmc__msg_str(&m, !name ? "no test function name" : "no output pointer");
        return QMC_EINVAL;
    }
    size_t index;
    if (qmc_testfn_lookup(name, &index) != 0) {
        unknown_name(name, &m);
        return QMC_EINVAL;
    }
    const entry *e = &table[index];
    if (dims < 1 || dims > e->max_dims) {
        qmc__msg_set(&m, "dims ", dims, " is outside ");
        qmc__msg_str(&m, e->name);
        qmc__msg_str(&m, "'s range 1..");
        qmc__msg_u64(&m, e->max_dims);
        return QMC_EDIMS;
    }
    if ((rc = check_count(e, "a", e->a_rule, a, n_a, dims, &m)) != 0 ||
        (rc = check_count(e, "u", e->u_rule, u, n_u, dims, &m)) != 0 ||
        (rc = check_values(e, "a", 0, e->a_domain, a, n_a, &m)) != 0 ||
        (rc = check_values(e, "u", 1, e->a_domain, u, n_u, &m)) != 0)
        return rc;

    fn = calloc(1, sizeof *fn);
    if (!fn)
        goto nomem;
    fn->index = index;
    fn->dims = dims;
    rc = 0;
    if (e->genz != NOT_GENZ) {
        /* Genz defaults: the `fixed` difficulty with seed 0; a list given
         * replaces its half of the draw. */
        fn->a = malloc(dims * sizeof(double));
        fn->u = malloc(dims * sizeof(double));
        fn->w = malloc(dims * sizeof(double));
        if (!fn->a || !fn->u || !fn->w)
            goto nomem;
        fn->n_a = fn->n_u = dims;
        if (!a || !u)
            rc = qmc_genz_draw((qmc_genz_family)e->genz, dims,
                               QMC_DIFFICULTY_FIXED, 0, fn->a, fn->u);
        if (rc != 0)
            goto fail;
        if (a)
            memcpy(fn->a, a, dims * sizeof(double));
        if (u)
            memcpy(fn->u, u, dims * sizeof(double));
    } else {
        if ((rc = take_list(a, n_a, e->a_default, e->n_a_default, &fn->a,
                            &fn->n_a)) != 0 ||
            (rc = take_list(u, n_u, e->u_default, e->n_u_default, &fn->u,
                            &fn->n_u)) != 0)
            goto fail;
    }
    fn->view.eval = e->eval;
    fn->view.ctx = fn;
    fn->view.dims = dims;
    fn->view.smoothness = e->smoothness;
    fn->view.name = e->name;
    e->setup(fn);
    *out = fn;
    return 0;

nomem:
    rc = QMC_ENOMEM;
fail:
    qmc__msg_str(&m, rc == QMC_ENOMEM ? "out of memory" : "internal error");
    qmc_testfn_free(fn);
    return rc;
}

void qmc_testfn_free(qmc_testfn *fn)
{
    if (!fn)
        return;
    free(fn->a);
    free(fn->u);
    free(fn->w);
    free(fn);
}

const qmc_integrand *qmc_testfn_integrand(const qmc_testfn *fn)
{
    return fn ? &fn->view : NULL;
}

void qmc_testfn_params(const qmc_testfn *fn, const double **a, size_t *n_a,
                       const double **u, size_t *n_u)
{
    if (a)
        *a = fn ? fn->a : NULL;
    if (n_a)
        *n_a = fn ? fn->n_a : 0;
    if (u)
        *u = fn ? fn->u : NULL;
    if (n_u)
        *n_u = fn ? fn->n_u : 0;
}
