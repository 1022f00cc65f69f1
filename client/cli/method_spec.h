/*
 * method_spec.h - a method as `qmc stability` and `qmc compare` name it
 * ("rqmc/sobol/owen", "qmc/halton", "gauss-legendre", ...), and the
 * integrate spec that spends a given evaluation budget with it (private
 * to the CLI).
 */
#ifndef QMC_CLI_METHOD_SPEC_H
#define QMC_CLI_METHOD_SPEC_H

#include <stdint.h>

#include "qmc/integrate.h"
#include "qmc/seq.h"

enum { CLI_METHOD_NAME_BYTES = 40 };

typedef struct cli_method {
    char name[CLI_METHOD_NAME_BYTES]; /* as given, canonical */
    qmc_method method;
    qmc_seq_kind seq;         /* qmc, rqmc */
    qmc_scramble scramble;    /* qmc (none by default), rqmc (owen) */
    int randomized;           /* seeds change the answer */
} cli_method;

/* Parses METHOD[/SEQ[/SCRAMBLE]]: SEQ and SCRAMBLE only for qmc and rqmc
 * (default sobol; scramble none for qmc, owen for rqmc).  Prints nothing;
 * returns 0 or -1 with a one-line reason in why. */
int cli_method_parse(const char *token, cli_method *m, char *why, size_t why_bytes);

/* How the budget is spent. */
typedef struct cli_budget {
    uint64_t evals;           /* the evaluation budget */
    uint32_t dims;            /* the integrand's dimensions */
    uint32_t reps;            /* rqmc replicates (0: 16) */
    uint64_t seed;
    int exhaust;              /* adaptive methods: aim at a tolerance they
                                 cannot reach, so they spend the whole
                                 budget (compare); 0: their default
                                 tolerance, with the budget as the cap
                                 (stability: what a user gets) */
    int pow2;                 /* qmc, rqmc: round n down to a power of two,
                                 the sizes at which nets keep their
                                 property (compare; stability tests the
                                 other sizes on purpose) */
} cli_budget;

/*
 * Fills s for method m and budget b: sampling methods take n = evals
 * (rqmc n = evals / reps, stratified the largest k^d <= evals); tensor
 * rules the largest n per axis with n^d <= evals (at least 2; the rule
 * refuses when even that is over budget); gauss-kronrod, cubature,
 * clenshaw-curtis and auto take max_evals = evals.
 */
void cli_method_spec(const cli_method *m, const cli_budget *b, qmc_integrate_spec *s);

#endif
