/*
 * gauss_legendre.c - Gauss-Legendre nodes and weights on [0,1] to full
 * double precision (see qmc/quad.h).
 *
 * Method: Newton's iteration on the three-term recurrence for P_n, started
 * from Tricomi's asymptotic guesses x_k ~ (1 - 1/(8n^2) + 1/(8n^3))
 * cos(pi (4k - 1)/(4n + 2)) (F. G. Tricomi 1950; see N. Hale and A.
 * Townsend, "Fast and accurate computation of Gauss-Legendre and
 * Gauss-Jacobi quadrature nodes and weights", SIAM J. Sci. Comput. 35
 * (2013), section 2).  Each root costs O(n) per iteration, O(n^2) in all.
 *
 * Precision near the endpoints.  Working in x loses the small nodes: a root
 * near x = 1 is known only to an ulp of 1, so its mirror image near t = 0
 * on [0,1] would carry an absolute, not relative, error.  So the unknown is
 * u = 1 - x (u in (0,1] for the roots with x >= 0), and for u < 1/2 the
 * recurrence is rewritten in u with D_k = P_k - P_{k-1} (C. Reinsch's
 * modification, as in the stable evaluation of Chebyshev sums near +-1):
 *
 *     D_{k+1} = (k D_k - (2k+1) u P_k) / (k+1),   P_{k+1} = P_k + D_{k+1},
 *
 * which never forms 1 - u.  The nodes on [0,1] are then t = u/2 (exact
 * scaling, full relative precision) and 1 - u/2.  For u >= 1/2 the plain
 * recurrence in x = 1 - u (exact there, by Sterbenz's lemma) is used.
 *
 * Weights on [0,1]: w = 1 / ((1 - x^2) P_n'(x)^2) with 1 - x^2 = u (2 - u)
 * and P_n'(x) = n (x P_n - P_{n-1}) / (x^2 - 1) evaluated at the final
 * root.  Nothing here allocates or keeps state.
 *
 * At the largest n the O(n^2) work takes tens of seconds, so a tensor
 * rule's caller may pass an interrupt poll: each evaluation of the
 * recurrence counts n units of work, and a poll that fires stops the
 * computation between Newton steps (the arithmetic is the same either way).
 */
#include <float.h>
#include <math.h>

#include "qmc/quad.h"
#include "quad_impl.h"

#define GL_PI 3.14159265358979323846
#define GL_MAX_NEWTON 100

/* P_n(1 - u) in *p and P_n'(1 - u) in *dp. */
static void legendre_at(uint32_t n, double u, double *p, double *dp)
{
    double pk, pkm1;
    if (u < 0.5) {
        double d = 0.0; /* D_k = P_k - P_{k-1} */
        pk = 1.0;
        for (uint32_t k = 0; k < n; k++) {
            double kk = (double)k;
            d = (kk * d - (2.0 * kk + 1.0) * u * pk) / (kk + 1.0);
            pk += d;
        }
        pkm1 = pk - d;
        /* x P_n - P_{n-1} = D_n - u P_n */
        *dp = (double)n * (u * pk - d) / (u * (2.0 - u));
    } else {
        double x = 1.0 - u;
        pkm1 = 0.0;
        pk = 1.0;
        for (uint32_t k = 0; k < n; k++) {
            double kk = (double)k;
            double next = ((2.0 * kk + 1.0) * x * pk - kk * pkm1) / (kk + 1.0);
            pkm1 = pk;
            pk = next;
        }
        *dp = (double)n * (pkm1 - x * pk) / (u * (2.0 - u));
    }
    *p = pk;
}

/* The k-th root (k = 1 largest x) as u = 1 - x, by Newton from Tricomi's
 * guess; *w gets its weight on [0,1].  Sets *stop (and returns early) when
 * the poll (NULL: none) fires. */
static double root_u(uint32_t n, uint32_t k, double *w, qmc__poll *poll, int *stop)
{
    double nn = (double)n;
    double theta = GL_PI * (4.0 * (double)k - 1.0) / (4.0 * nn + 2.0);
    double one_minus_c = 1.0 / (8.0 * nn * nn) - 1.0 / (8.0 * nn * nn * nn);
    double s = sin(0.5 * theta);
    /* 1 - c cos(theta) = (1 - c) + c 2 sin^2(theta/2), without cancellation */
    double u = one_minus_c + (1.0 - one_minus_c) * 2.0 * s * s;
    double p, dp;
    for (int it = 0; it < GL_MAX_NEWTON; it++) {
        legendre_at(n, u, &p, &dp);
        if (poll && qmc__poll_work(poll, n)) {
            *stop = 1;
            return u;
        }
        /* dP/du = -P'(x), so Newton's step in u is +p/dp. */
        double du = p / dp;
        u += du;
        if (fabs(du) <= 2.0 * DBL_EPSILON * u)
            break;
    }
    legendre_at(n, u, &p, &dp);
    *w = 1.0 / (u * (2.0 - u) * dp * dp);
    return u;
}

int qmc_gauss_legendre(uint32_t n, double *x, double *w)
{
    return qmc__gauss_legendre(n, x, w, NULL);
}

int qmc__gauss_legendre(uint32_t n, double *x, double *w, qmc__poll *poll)
{
    if (!x || !w)
        return QMC_EINVAL;
    if (n == 0 || n > QMC_GAUSS_LEGENDRE_MAX_N)
        return QMC_ECOUNT;
    uint32_t half = n / 2;
    for (uint32_t k = 1; k <= half; k++) {
        double wk;
        int stop = 0;
        double u = root_u(n, k, &wk, poll, &stop);
        if (stop)
            return QMC_ECANCELED;
        x[k - 1] = 0.5 * u;
        x[n - k] = 1.0 - 0.5 * u;
        w[k - 1] = wk;
        w[n - k] = wk;
    }
    if (n % 2) {
        /* The middle root is x = 0 exactly: u = 1, t = 1/2. */
        double p, dp;
        legendre_at(n, 1.0, &p, &dp);
        x[half] = 0.5;
        w[half] = 1.0 / (dp * dp);
    }
    return 0;
}
