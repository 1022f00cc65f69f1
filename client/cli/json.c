/*
 * json.c - JSON members for the CLI's --json output (see json.h).
 *
 * Writes to a FILE and nothing else: whether the writes reached their
 * target is for the caller's fflush to tell.
 */
#include <math.h>

#include "json.h"

static void key_and_value_start(FILE *f, const char *key)
{
    fprintf(f, "\"%s\":", key);
}

static void number(FILE *f, double v)
{
    if (isfinite(v))
        fprintf(f, "%.17g", v);
    else
        fputs("null", f);
}

void cli_json_num(FILE *f, const char *key, double v, int comma)
{
    key_and_value_start(f, key);
    number(f, v);
    if (comma)
        fputc(',', f);
}

void cli_json_u64(FILE *f, const char *key, uint64_t v, int comma)
{
    key_and_value_start(f, key);
    fprintf(f, "%llu", (unsigned long long)v);
    if (comma)
        fputc(',', f);
}

void cli_json_bool(FILE *f, const char *key, int v, int comma)
{
    key_and_value_start(f, key);
    fputs(v ? "true" : "false", f);
    if (comma)
        fputc(',', f);
}

void cli_json_string(FILE *f, const char *v)
{
    fputc('"', f);
    for (const char *p = v ? v : ""; *p; p++) {
        unsigned char c = (unsigned char)*p;
        if (c == '"' || c == '\\')
            fprintf(f, "\\%c", c);
        else if (c < 0x20)
            fprintf(f, "\\u%04x", c);
        else
            fputc(c, f);
    }
    fputc('"', f);
}

void cli_json_str(FILE *f, const char *key, const char *v, int comma)
{
    key_and_value_start(f, key);
    cli_json_string(f, v);
    if (comma)
        fputc(',', f);
}

void cli_json_num_array(FILE *f, const char *key, const double *v, size_t n,
                        int comma)
{
    key_and_value_start(f, key);
    fputc('[', f);
    for (size_t i = 0; i < n; i++) {
        if (i)
            fputc(',', f);
        number(f, v[i]);
    }
    fputc(']', f);
    if (comma)
        fputc(',', f);
}
