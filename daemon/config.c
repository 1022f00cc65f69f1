/*
 * config.c - qmcd's settings from defaults, an optional config file, and
 * flags, in that order (later wins).
 *
 * File format (systemd/qmcd.conf is the documented example): one
 * `key = value` per line, `#` starts a comment, blank lines are ignored,
 * keys are the long flag names without "--", `listen` may repeat.  Numbers
 * are decimal integers with an optional K, M or G suffix (binary multiples).
 * Any problem is one line naming the file, the line and the problem.
 *
 * This file must not act on settings (no sockets, no threads, no logging
 * level changes): it only turns text into a qmcd_config.
 */
#define _GNU_SOURCE
#include <ctype.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "config.h"
#include "log.h"
#include "qmc/seq.h"

typedef struct num_key {
    const char *key;
    size_t offset;
    uint64_t def, min, max;
    int reloadable;
} num_key;

static const num_key num_keys[] = {
#define QMCD__CFG_ROW(k, field, d, lo, hi, reload) \
    {k, offsetof(qmcd_config, field), (uint64_t)(d), (uint64_t)(lo), (uint64_t)(hi), reload},
    QMCD_CONFIG_NUM_MAP(QMCD__CFG_ROW)
#undef QMCD__CFG_ROW
};
#define N_NUM_KEYS (sizeof num_keys / sizeof num_keys[0])

static uint64_t *num_field(qmcd_config *c, const num_key *k)
{
    return (uint64_t *)(void *)((char *)c + k->offset);
}

void qmcd_config_defaults(qmcd_config *c)
{
    memset(c, 0, sizeof *c);
    for (size_t i = 0; i < N_NUM_KEYS; i++)
        *num_field(c, &num_keys[i]) = num_keys[i].def;
    c->log_level = QMCD_LOG_INFO;
}

void qmcd_usage(void)
{
    fputs("usage: qmcd [--config FILE] [--listen unix:PATH | tcp:HOST:PORT]... [--threads N]\n"
          "            [--foreground] [--log-level err|warning|notice|info|debug]\n"
          "            [--ready-file PATH] [--auth-key FILE] [--KEY VALUE]...\n"
          "\n"
          "Serves quasi-Monte Carlo points and integration jobs (see protocol/PROTOCOL.md).\n"
          "Default listener: unix:$RUNTIME_DIRECTORY/qmcd.sock or unix:/run/qmcd/qmcd.sock.\n"
          "tcp:[::1]:0 listens on IPv6; port 0 picks a free port (the bound address is\n"
          "logged and written to --ready-file).  Without --foreground qmcd forks and the\n"
          "parent exits once the child is ready.  SIGHUP re-reads the config (limits and\n"
          "log level); SIGTERM drains jobs for shutdown-timeout-ms and exits 0.\n"
          "tcp::PORT listens on loopback only.  A TCP listener on any other address\n"
          "needs --auth-key FILE (mode 0600, 16-1024 bytes; re-read on SIGHUP): clients\n"
          "then prove they hold the same key (docs/SECURITY.md).\n"
          "\n"
          "KEY (also usable as `key = value` in the config file), default:\n",
          stdout);
    for (size_t i = 0; i < N_NUM_KEYS; i++)
        printf("  --%-22s %llu%s\n", num_keys[i].key, (unsigned long long)num_keys[i].def,
               strcmp(num_keys[i].key, "threads") == 0 ? " (0: one per online CPU)" : "");
}

/* A decimal integer with an optional K/M/G suffix, within [min, max]. */
static int parse_num(const char *text, const num_key *k, uint64_t *out, char *why, size_t n)
{
    errno = 0;
    char *end;
    if (!isdigit((unsigned char)text[0]))
        goto bad;
    unsigned long long v = strtoull(text, &end, 10);
    if (errno)
        goto bad;
    unsigned shift = 0;
    if (*end == 'K' || *end == 'k')
        shift = 10, end++;
    else if (*end == 'M')
        shift = 20, end++;
    else if (*end == 'G')
        shift = 30, end++;
    if (*end != '\0' || (shift && v > (UINT64_MAX >> shift)))
        goto bad;
    v <<= shift;
    if (v < k->min || v > k->max) {
        snprintf(why, n, "%s: %llu is outside %llu..%llu", k->key, v,
                 (unsigned long long)k->min, (unsigned long long)k->max);
        return -1;
    }
    *out = v;
    return 0;
bad:
    snprintf(why, n, "%s: '%s' is not a number", k->key, text);
    return -1;
}

/* Sets one key.  Returns 0, or -1 with the problem in why. */
static int set_key(qmcd_config *c, const char *key, const char *value, char *why, size_t n)
{
    for (size_t i = 0; i < N_NUM_KEYS; i++)
        if (strcmp(key, num_keys[i].key) == 0)
            return parse_num(value, &num_keys[i], num_field(c, &num_keys[i]), why, n);
    if (strcmp(key, "log-level") == 0) {
        int l = qmcd_log_level_parse(value);
        if (l < 0) {
            snprintf(why, n, "log-level: '%s' is not one of err, warning, notice, info, debug",
                     value);
            return -1;
        }
        c->log_level = l;
        return 0;
    }
    if (strcmp(key, "foreground") == 0) {
        if (strcmp(value, "yes") == 0 || strcmp(value, "1") == 0 || strcmp(value, "true") == 0)
            c->foreground = 1;
        else if (strcmp(value, "no") == 0 || strcmp(value, "0") == 0 ||
                 strcmp(value, "false") == 0)
            c->foreground = 0;
        else {
            snprintf(why, n, "foreground: '%s' is not yes or no", value);
            return -1;
        }
        return 0;
    }
    if (strcmp(key, "auth-key") == 0) {
        if (strlen(value) >= QMCD_PATH_BYTES) {
            snprintf(why, n, "auth-key: path longer than %d bytes", QMCD_PATH_BYTES - 1);
            return -1;
        }
        strcpy(c->auth_key, value); /* "" (auth-key =) means no key */
        return 0;
    }
    if (strcmp(key, "ready-file") == 0 || strcmp(key, "listen") == 0) {
        if (strlen(value) >= QMCD_PATH_BYTES || !value[0]) {
            snprintf(why, n, "%s: value is empty or longer than %d bytes", key,
                     QMCD_PATH_BYTES - 1);
            return -1;
        }
        if (key[0] == 'r') {
            strcpy(c->ready_file, value);
            return 0;
        }
        if (c->n_listen == QMCD_MAX_LISTEN) {
            snprintf(why, n, "listen: more than %d listeners", QMCD_MAX_LISTEN);
            return -1;
        }
        if (strncmp(value, "unix:", 5) != 0 && strncmp(value, "tcp:", 4) != 0) {
            snprintf(why, n, "listen: '%s' is neither unix:PATH nor tcp:HOST:PORT", value);
            return -1;
        }
        strcpy(c->listen[c->n_listen++], value);
        return 0;
    }
    snprintf(why, n, "unknown key '%s' (see qmcd --help)", key);
    return -1;
}

static char *trim(char *s)
{
    while (isspace((unsigned char)*s))
        s++;
    size_t len = strlen(s);
    while (len > 0 && isspace((unsigned char)s[len - 1]))
        s[--len] = '\0';
    return s;
}

static int load_file(const char *path, qmcd_config *c, char *why, size_t n)
{
    FILE *f = fopen(path, "r");
    if (!f) {
        snprintf(why, n, "%s: cannot open: %s", path, strerror(errno));
        return -1;
    }
    char line[1024], problem[400];
    unsigned lineno = 0;
    int rc = 0;
    while (fgets(line, sizeof line, f)) {
        lineno++;
        if (!strchr(line, '\n') && !feof(f)) {
            snprintf(why, n, "%s:%u: line longer than %zu bytes", path, lineno, sizeof line - 2);
            rc = -1;
            break;
        }
        char *hash = strchr(line, '#');
        if (hash)
            *hash = '\0';
        char *s = trim(line);
        if (!*s)
            continue;
        char *eq = strchr(s, '=');
        if (!eq) {
            snprintf(why, n, "%s:%u: expected 'key = value', got '%.60s'", path, lineno, s);
            rc = -1;
            break;
        }
        *eq = '\0';
        char *key = trim(s), *value = trim(eq + 1);
        if (set_key(c, key, value, problem, sizeof problem) != 0) {
            snprintf(why, n, "%s:%u: %s", path, lineno, problem);
            rc = -1;
            break;
        }
    }
    if (rc == 0 && ferror(f)) {
        snprintf(why, n, "%s: read error", path);
        rc = -1;
    }
    fclose(f);
    return rc;
}

int qmcd_args_parse(int argc, char **argv, qmcd_args *args)
{
    memset(args, 0, sizeof *args);
    args->argc = argc;
    args->argv = argv;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            qmcd_usage();
            return 1;
        }
        if (strcmp(a, "--version") == 0) {
            printf("qmcd 0.1.0\nSobol table fingerprint: %016llx\n",
                   (unsigned long long)qmc_sobol_table_hash());
            return 1;
        }
        if (strcmp(a, "--config") == 0) {
            if (i + 1 >= argc) {
                fprintf(stderr, "qmcd: --config needs a FILE\n");
                return -1;
            }
            args->config_path = argv[++i];
        } else if (strncmp(a, "--config=", 9) == 0) {
            args->config_path = a + 9;
        }
    }
    return 0;
}

/* Applies the flags (everything but --config) over *c. */
static int apply_flags(const qmcd_args *args, qmcd_config *c, char *why, size_t n)
{
    char problem[400];
    int listen_seen = 0;
    for (int i = 1; i < args->argc; i++) {
        const char *a = args->argv[i];
        if (strncmp(a, "--", 2) != 0) {
            snprintf(why, n, "unexpected argument '%s' (see qmcd --help)", a);
            return -1;
        }
        char key[64];
        const char *value;
        const char *eq = strchr(a, '=');
        size_t klen = eq ? (size_t)(eq - a - 2) : strlen(a + 2);
        if (klen >= sizeof key) {
            snprintf(why, n, "unknown option '%.60s'", a);
            return -1;
        }
        memcpy(key, a + 2, klen);
        key[klen] = '\0';
        if (strcmp(key, "foreground") == 0 && !eq) {
            c->foreground = 1;
            continue;
        }
        if (eq) {
            value = eq + 1;
        } else if (i + 1 < args->argc) {
            value = args->argv[++i];
        } else {
            snprintf(why, n, "--%s needs a value", key);
            return -1;
        }
        if (strcmp(key, "config") == 0)
            continue;
        /* --listen on the command line replaces the file's listeners. */
        if (strcmp(key, "listen") == 0 && !listen_seen) {
            c->n_listen = 0;
            listen_seen = 1;
        }
        if (set_key(c, key, value, problem, sizeof problem) != 0) {
            snprintf(why, n, "--%s", problem);
            return -1;
        }
    }
    return 0;
}

int qmcd_config_load(const qmcd_args *args, qmcd_config *c, char *why, size_t why_bytes)
{
    qmcd_config_defaults(c);
    if (args->config_path && load_file(args->config_path, c, why, why_bytes) != 0)
        return -1;
    if (apply_flags(args, c, why, why_bytes) != 0)
        return -1;
    if (c->auth_key[0] && c->auth_key[0] != '/' && args->base_dir) {
        char abs[QMCD_PATH_BYTES];
        int len = snprintf(abs, sizeof abs, "%s/%s", args->base_dir, c->auth_key);
        if (len < 0 || (size_t)len >= sizeof abs) {
            snprintf(why, why_bytes, "auth-key: %s/%s is longer than %d bytes", args->base_dir,
                     c->auth_key, QMCD_PATH_BYTES - 1);
            return -1;
        }
        memcpy(c->auth_key, abs, (size_t)len + 1);
    }
    return 0;
}

void qmcd_config_keep_fixed(const qmcd_config *old, qmcd_config *fresh)
{
    for (size_t i = 0; i < N_NUM_KEYS; i++) {
        const num_key *k = &num_keys[i];
        if (k->reloadable)
            continue;
        uint64_t *f = num_field(fresh, k);
        const uint64_t *o = (const uint64_t *)(const void *)((const char *)old + k->offset);
        if (*f != *o)
            qmcd_warn("reload: %s changes only on restart; keeping %llu", k->key,
                      (unsigned long long)*o);
        *f = *o;
    }
    int listen_changed = old->n_listen != fresh->n_listen;
    for (unsigned i = 0; !listen_changed && i < old->n_listen; i++)
        listen_changed = strcmp(old->listen[i], fresh->listen[i]) != 0;
    if (listen_changed)
        qmcd_warn("reload: listen changes only on restart; keeping the current listeners");
    if (strcmp(old->ready_file, fresh->ready_file) != 0)
        qmcd_warn("reload: ready-file changes only on restart");
    memcpy(fresh->listen, old->listen, sizeof fresh->listen);
    fresh->n_listen = old->n_listen;
    memcpy(fresh->ready_file, old->ready_file, sizeof fresh->ready_file);
    fresh->foreground = old->foreground;
}
