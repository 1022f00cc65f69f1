/*
 * integrate_methods.h - the integrators bench_integrate compares, each run
 * at a fixed evaluation budget on one Genz test function: GSL's plain,
 * MISER and VEGAS Monte Carlo and an average of GSL's unscrambled Sobol
 * points, cubature's hcubature and pcubature, and ours through
 * qmc_integrate (auto, rqmc, cubature).
 *
 * Each run is meant to execute inside a bench_child_run child: it may
 * crash (a peer's bug), and it reports only through its bench_out.
 */
#ifndef BENCH_INTEGRATE_METHODS_H
#define BENCH_INTEGRATE_METHODS_H

#include <stdint.h>

#include "integrate_child.h"
#include "qmc/testfn.h"

/* X(enum suffix, name, 1 for a peer / 0 for ours). */
#define BENCH_METHOD_MAP(X)         \
    X(GSL_PLAIN, "gsl-plain", 1)    \
    X(GSL_MISER, "gsl-miser", 1)    \
    X(GSL_VEGAS, "gsl-vegas", 1)    \
    X(GSL_SOBOL, "gsl-sobol", 1)    \
    X(HCUBATURE, "hcubature", 1)    \
    X(PCUBATURE, "pcubature", 1)    \
    X(AUTO, "auto", 0)              \
    X(RQMC, "rqmc", 0)              \
    X(CUBATURE, "cubature", 0)

typedef enum bench_method {
#define BENCH__METHOD_ENUM(name, text, peer) BENCH_M_##name,
    BENCH_METHOD_MAP(BENCH__METHOD_ENUM)
#undef BENCH__METHOD_ENUM
    BENCH_M_COUNT
} bench_method;

const char *bench_method_name(bench_method m);
int bench_method_is_peer(bench_method m);

/*
 * Scrambles per integrand draw.  auto is randomized: it runs each draw
 * under BENCH_SCRAMBLES seeds, so a cell's error is its expected error on
 * the draws rather than one randomization's.  With one seed a draw, the
 * seeds alone moved auto's geometric mean over the 8 draws by a factor
 * e^0.39 either way (one standard deviation, 40 seed sets, discontinuous
 * family at d = 30 and 1e5; 0.25 at d = 2 and 1e7), which decided
 * comparisons with deterministic peers within that margin by lottery; 16
 * scrambles bring it to about 10%.  Scramble 0 is the draw's own seed
 * (its runs are reported alone too).  Peers run once per draw (GSL's
 * randomized ones included: their noise can only help them, as the best
 * peer is a minimum), and so do our rqmc and cubature, which no target
 * compares with a peer.
 */
enum { BENCH_SCRAMBLES = 16 };
uint32_t bench_method_scrambles(bench_method m);

/* One run: method on a Genz family (qmc_genz_draw FIXED, draw_seed) in d
 * dimensions with a budget of evaluations. */
typedef struct bench_job {
    bench_method method;
    qmc_genz_family family;
    uint32_t dims;
    uint64_t budget;
    uint64_t draw_seed;
    uint32_t scramble; /* 0 .. bench_method_scrambles(method) - 1 */
} bench_job;

/* A bench_fn: runs *(const bench_job *)arg and fills *out. */
void bench_method_run(const void *arg, bench_out *out);

/*
 * Makes the Genz test function of a job (parameters drawn as above).
 * Returns 0 or a QMC_E* code; *out is the caller's to free.
 */
int bench_make_genz(qmc_genz_family family, uint32_t dims, uint64_t draw_seed,
                    qmc_testfn **out);

#endif
