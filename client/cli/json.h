/*
 * json.h - the CLI's JSON output: one object's members written to a FILE,
 * shared by every subcommand that takes --json (private to the CLI).
 *
 * Each helper writes `"key":value` and, when comma is set, the ',' that
 * separates it from the next member; the caller writes the braces.  Numbers
 * keep every bit ("%.17g"); NaN and infinities, which JSON lacks, become
 * null, so a script sees "no value" rather than a parse error.
 */
#ifndef QMC_CLI_JSON_H
#define QMC_CLI_JSON_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

/* A number, or null when v is not finite. */
void cli_json_num(FILE *f, const char *key, double v, int comma);
/* A whole number, written exactly (no rounding through a double). */
void cli_json_u64(FILE *f, const char *key, uint64_t v, int comma);
/* true or false. */
void cli_json_bool(FILE *f, const char *key, int v, int comma);
/* A string; '"' and '\' are escaped, control characters written as
 * \u00XX, other bytes as they are.  NULL is written as "". */
void cli_json_str(FILE *f, const char *key, const char *v, int comma);
/* The quoted, escaped string alone (as cli_json_str writes its value), for
 * callers whose keys are data, such as the daemon's STATS names. */
void cli_json_string(FILE *f, const char *v);
/* An array of n numbers, each as cli_json_num writes it. */
void cli_json_num_array(FILE *f, const char *key, const double *v, size_t n,
                        int comma);

#endif
