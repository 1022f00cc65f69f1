/*
 * testfn_impl.h - what the test-function registry (testfn.c) shares with
 * the files that implement the functions (genz.c, testfn_1d.c) (private).
 *
 * The registry validates parameters and fills defaults; a function's setup
 * hook then derives what eval reads and writes the exact values into the
 * integrand view.  Eval hooks read the testfn through the view's ctx and
 * never write to it.
 */
#ifndef QMC_TESTFN_IMPL_H
#define QMC_TESTFN_IMPL_H

#include <stddef.h>
#include <stdint.h>

#include "qmc/testfn.h"

struct qmc_testfn {
    qmc_integrand view;  /* view.ctx points back at this object */
    size_t index;        /* row of the registry table */
    uint32_t dims;
    size_t n_a, n_u;
    double *a;           /* n_a values (owned) */
    double *u;           /* n_u values (owned) */
    double *w;           /* dims derived values for eval (owned), e.g.
                            a_i^-2 for the product peak */
    double c0;           /* a derived scalar for eval, e.g. 2 pi u1 */
};

typedef void qmc__testfn_setup_fn(qmc_testfn *fn);
typedef void qmc__testfn_eval_fn(const void *ctx, const double *x, size_t n,
                                 uint32_t dims, double *out);

/* Genz families (genz.c).  Setup needs fn->a, fn->u (dims each) and fn->w
 * (dims values of scratch it fills). */
qmc__testfn_setup_fn qmc__genz_osc_setup, qmc__genz_ppeak_setup,
    qmc__genz_corner_setup, qmc__genz_gauss_setup, qmc__genz_cont_setup,
    qmc__genz_disc_setup;
qmc__testfn_eval_fn qmc__genz_osc_eval, qmc__genz_ppeak_eval,
    qmc__genz_corner_eval, qmc__genz_gauss_eval, qmc__genz_cont_eval,
    qmc__genz_disc_eval;

/*
 * The corner peak's exact integral int_[0,1]^dims (1 + a.x)^-(dims+1) dx by
 * the Laplace representation (genz.c).  Returns 0 and the value, or
 * QMC_ERANGE when the a-posteriori check fails or the value is below
 * DBL_MIN (then *value is the unreliable estimate).  *err_est is the
 * estimated relative error (quadrature step halving plus rounding).
 */
int qmc__genz_corner_exact(uint32_t dims, const double *a, double *value,
                           double *err_est);

/* One-dimensional functions (testfn_1d.c). */
qmc__testfn_setup_fn qmc__fn1d_poly_setup, qmc__fn1d_exp_setup,
    qmc__fn1d_cos_setup, qmc__fn1d_invsqrt_setup, qmc__fn1d_log_setup,
    qmc__fn1d_step_setup;
qmc__testfn_eval_fn qmc__fn1d_poly_eval, qmc__fn1d_exp_eval,
    qmc__fn1d_cos_eval, qmc__fn1d_invsqrt_eval, qmc__fn1d_log_eval,
    qmc__fn1d_step_eval;

/* For a 1D function whose only kink or jump is at u1: declares it as the
 * view's break (qmc_integrand.breaks), unless u1 is an end of [0,1]. */
void qmc__testfn_break_at_u1(qmc_testfn *fn);

/* Sets the view's exact and abs values; has_* only when the value is
 * finite. */
void qmc__testfn_set_exact(qmc_testfn *fn, double exact, int has_abs,
                           double abs_integral);

#endif
