/*
 * fuzz_config.c - libFuzzer target for qmcd's config-file parser
 * (daemon/config.c, qmcd_config_parse: text in, no I/O).
 *
 * Any input must either be refused with one NUL-terminated line that names
 * the file and the line ("fuzz.conf:N: ..."), or give a configuration in
 * which every number lies within its key's range, every string is
 * terminated, each listener is unix: or tcp:, and the log level is one of
 * the five.  Parsing the same text twice must give the same configuration
 * (the parser keeps no state between calls).
 */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "config.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check_config(const qmcd_config *c)
{
#define QMCD__FUZZ_RANGE(key, field, def, min, max, reload)                     \
    if (c->field < (uint64_t)(min) || c->field > (uint64_t)(max))               \
        __builtin_trap();
    QMCD_CONFIG_NUM_MAP(QMCD__FUZZ_RANGE)
#undef QMCD__FUZZ_RANGE
    if (c->log_level < 3 || c->log_level > 7 || (c->foreground != 0 && c->foreground != 1))
        __builtin_trap();
    if (!memchr(c->ready_file, '\0', sizeof c->ready_file) || c->n_listen > QMCD_MAX_LISTEN)
        __builtin_trap();
    for (unsigned i = 0; i < c->n_listen; i++) {
        const char *l = c->listen[i];
        if (!memchr(l, '\0', QMCD_PATH_BYTES) ||
            (strncmp(l, "unix:", 5) != 0 && strncmp(l, "tcp:", 4) != 0))
            __builtin_trap();
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static qmcd_config a, b;
    char why[512];
    memset(why, 'x', sizeof why);
    qmcd_config_defaults(&a);
    int rc = qmcd_config_parse("fuzz.conf", (const char *)data, size, &a, why, sizeof why);
    if (rc != 0) {
        if (rc != -1 || !memchr(why, '\0', sizeof why) || strchr(why, '\n') ||
            strncmp(why, "fuzz.conf:", 10) != 0)
            __builtin_trap(); /* one terminated line naming the file */
        return 0;
    }
    check_config(&a);
    qmcd_config_defaults(&b);
    if (qmcd_config_parse("fuzz.conf", (const char *)data, size, &b, why, sizeof why) != 0 ||
        memcmp(&a, &b, sizeof a) != 0)
        __builtin_trap();
    return 0;
}
