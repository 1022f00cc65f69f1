/*
 * flag_report.h - the table of what each flag is worth, which `qmc
 * stability` and `qmc compare` both write into their REPORT.md (private to
 * the CLI).  The counting is the library's (qmc_stab_flag_tally_add).
 */
#ifndef QMC_CLI_FLAG_REPORT_H
#define QMC_CLI_FLAG_REPORT_H

#include <stdint.h>
#include <stdio.h>

#include "qmc/stability.h"

/* Writes a Markdown table: for every flag that fired (and for "any flag"),
 * its runs on correct and on wrong answers, each as a share of all correct
 * or wrong runs, and its precision (wrong / fired).  Returns ferror(f). */
int cli_flag_report(FILE *f, const qmc_stab_flag_tally *t);

#endif
