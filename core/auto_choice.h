/*
 * auto_choice.h - which method `auto` runs for an integrand, a control
 * variate and a budget (private to core/).  integrate.c runs the choice;
 * integrate_memory.c bounds the memory of exactly the rules it can reach.
 */
#ifndef QMC_AUTO_CHOICE_H
#define QMC_AUTO_CHOICE_H

#include <stddef.h>
#include <stdint.h>

#include "qmc/integrand.h"
#include "qmc/integrate.h"

/* The method auto runs for f (and control variate g, or NULL) under spec:
 * gauss-kronrod, clenshaw-curtis, cubature or rqmc; reason says why in
 * one line (truncated to bytes). */
qmc_method qmc__auto_choice(const qmc_integrate_spec *spec, const qmc_integrand *f,
                            const qmc_integrand *g, char *reason, size_t bytes);

/* The same without the reason. */
qmc_method qmc__auto_pick(const qmc_integrate_spec *spec, const qmc_integrand *f,
                          const qmc_integrand *g);

/* auto's choices as far as dims and the budget decide them, with the
 * conditions qmc__auto_choice uses: 1 when auto may run method m
 * (gauss-kronrod, clenshaw-curtis, cubature, rqmc) for some integrand of
 * these dims with this budget. */
int qmc__auto_may_use(qmc_method m, uint32_t dims, uint64_t budget);

#endif
