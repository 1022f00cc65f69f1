/*
 * gnuplot.h - running gnuplot for the CLI's charts (private to the CLI).
 *
 * Charts are written by gnuplot (gnuplot-nox: pngcairo and svg terminals)
 * from a script the command generates; the script and its data stay in
 * the output directory so a chart can be re-made or restyled by hand.
 */
#ifndef QMC_CLI_GNUPLOT_H
#define QMC_CLI_GNUPLOT_H

#include <stdio.h>

/* Writes the terminal preamble for one output: "png" (pngcairo) or "svg",
 * width x height pixels, into the script. */
void cli_gnuplot_terminal(FILE *script, const char *kind, int width, int height,
                          const char *output_path);

/* Runs `gnuplot SCRIPT`.  Returns 0, or -1 after printing one line (the
 * first line gnuplot wrote, or why it could not run). */
int cli_gnuplot_run(const char *script_path);

/* Writes s as a gnuplot single-quoted string (quotes doubled). */
void cli_gnuplot_quote(FILE *script, const char *s);

#endif
