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
#include <unistd.h>

#include "config.h"
#include "log.h"
#include "modbus_spec.h"
#include "regular_file.h"
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
          "       qmcd --check-config [--config FILE] [--KEY VALUE]...\n"
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
          "--check-config reads FILE (default " QMCD_DEFAULT_CONFIG ") and the flags,\n"
          "prints what is wrong (file and line) and exits 2, or exits 0 if all is well.\n"
          "\n"
          "Modbus (protocol/MODBUS.md), off by default, repeatable:\n"
          "  --modbus tcp:HOST:PORT          e.g. tcp:127.0.0.1:1502, tcp:[::1]:1502\n"
          "  --modbus rtu:DEVICE:BAUD:PARITY:DATABITS:STOPBITS[:UNIT][:rs485]\n"
          "  --modbus-allow CIDR,...         clients let in; required off loopback\n"
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

static int set_log_level(qmcd_config *c, const char *key, const char *value, char *why,
                         size_t n)
{
    (void)key;
    int l = qmcd_log_level_parse(value);
    if (l < 0) {
        snprintf(why, n, "log-level: '%s' is not one of err, warning, notice, info, debug",
                 value);
        return -1;
    }
    c->log_level = l;
    return 0;
}

static int set_foreground(qmcd_config *c, const char *key, const char *value, char *why,
                          size_t n)
{
    (void)key;
    if (strcmp(value, "yes") == 0 || strcmp(value, "1") == 0 || strcmp(value, "true") == 0)
        c->foreground = 1;
    else if (strcmp(value, "no") == 0 || strcmp(value, "0") == 0 || strcmp(value, "false") == 0)
        c->foreground = 0;
    else {
        snprintf(why, n, "foreground: '%s' is not yes or no", value);
        return -1;
    }
    return 0;
}

/* Copies a non-empty path-like value into dst (QMCD_PATH_BYTES). */
static int set_path(char *dst, const char *key, const char *value, char *why, size_t n)
{
    if (strlen(value) >= QMCD_PATH_BYTES || !value[0]) {
        snprintf(why, n, "%s: value is empty or longer than %d bytes", key,
                 QMCD_PATH_BYTES - 1);
        return -1;
    }
    strcpy(dst, value);
    return 0;
}

static int set_ready_file(qmcd_config *c, const char *key, const char *value, char *why,
                          size_t n)
{
    return set_path(c->ready_file, key, value, why, n);
}

static int set_listen(qmcd_config *c, const char *key, const char *value, char *why, size_t n)
{
    if (c->n_listen == QMCD_MAX_LISTEN) {
        snprintf(why, n, "listen: more than %d listeners", QMCD_MAX_LISTEN);
        return -1;
    }
    if (strncmp(value, "unix:", 5) != 0 && strncmp(value, "tcp:", 4) != 0) {
        snprintf(why, n, "listen: '%s' is neither unix:PATH nor tcp:HOST:PORT", value);
        return -1;
    }
    if (set_path(c->listen[c->n_listen], key, value, why, n) != 0)
        return -1;
    c->n_listen++;
    return 0;
}

static int set_modbus(qmcd_config *c, const char *key, const char *value, char *why, size_t n)
{
    if (c->n_modbus == QMCD_MAX_LISTEN) {
        snprintf(why, n, "modbus: more than %d transports", QMCD_MAX_LISTEN);
        return -1;
    }
    qmcd_modbus_rtu_spec rtu;
    if (qmcd_modbus_spec_parse(value, NULL, &rtu, why, n) < 0)
        return -1;
    if (set_path(c->modbus[c->n_modbus], key, value, why, n) != 0)
        return -1;
    c->n_modbus++;
    return 0;
}

/* Repeated keys add to the list, kept as validated text. */
static int set_modbus_allow(qmcd_config *c, const char *key, const char *value, char *why,
                            size_t n)
{
    (void)key;
    qmcd_cidr nets[QMCD_MODBUS_MAX_ALLOW];
    unsigned n_nets = 0;
    if (qmcd_modbus_allow_parse(c->modbus_allow, nets, &n_nets, why, n) != 0 ||
        qmcd_modbus_allow_parse(value, nets, &n_nets, why, n) != 0)
        return -1;
    if (n_nets == 0) {
        snprintf(why, n, "modbus-allow: no address given");
        return -1;
    }
    size_t have = strlen(c->modbus_allow);
    if (have + 1 + strlen(value) >= sizeof c->modbus_allow) {
        snprintf(why, n, "modbus-allow: the list is longer than %zu bytes",
                 sizeof c->modbus_allow - 1);
        return -1;
    }
    if (have)
        c->modbus_allow[have++] = ',';
    strcpy(c->modbus_allow + have, value);
    return 0;
}

/* Keys that are not plain numbers: one row each, with the function that
 * checks and stores the value.  A new key is one row here and its setter
 * (plus a line in systemd/qmcd.conf and man/qmcd.conf.5). */
typedef struct text_key {
    const char *key;
    int (*set)(qmcd_config *c, const char *key, const char *value, char *why, size_t n);
} text_key;

/* The key file (auth.c reads and checks it); "" (auth-key =) means none. */
static int set_auth_key(qmcd_config *c, const char *key, const char *value, char *why,
                        size_t n)
{
    if (!value[0]) {
        c->auth_key[0] = '\0';
        return 0;
    }
    return set_path(c->auth_key, key, value, why, n);
}

static const text_key text_keys[] = {
    {"log-level", set_log_level},
    {"foreground", set_foreground},
    {"ready-file", set_ready_file},
    {"listen", set_listen},
    {"auth-key", set_auth_key},
    {"modbus", set_modbus},
    {"modbus-allow", set_modbus_allow},
};
#define N_TEXT_KEYS (sizeof text_keys / sizeof text_keys[0])

/* Sets one key.  Returns 0, or -1 with the problem in why (-2 when the key
 * is unknown, so that a flag can say "unknown option"). */
static int set_key(qmcd_config *c, const char *key, const char *value, char *why, size_t n)
{
    for (size_t i = 0; i < N_NUM_KEYS; i++)
        if (strcmp(key, num_keys[i].key) == 0)
            return parse_num(value, &num_keys[i], num_field(c, &num_keys[i]), why, n);
    for (size_t i = 0; i < N_TEXT_KEYS; i++)
        if (strcmp(key, text_keys[i].key) == 0)
            return text_keys[i].set(c, key, value, why, n);
    snprintf(why, n, "unknown key '%s' (see qmcd --help)", key);
    return -2;
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

/* The longest line a config file may have, newline excluded. */
#define QMCD_CONFIG_LINE_BYTES 1022

int qmcd_config_parse(const char *name, const char *text, size_t len, qmcd_config *c,
                      char *why, size_t n)
{
    char line[QMCD_CONFIG_LINE_BYTES + 2], problem[400];
    unsigned lineno = 0;
    size_t pos = 0;
    while (pos < len) {
        lineno++;
        const char *nl = memchr(text + pos, '\n', len - pos);
        size_t line_len = nl ? (size_t)(nl - (text + pos)) : len - pos;
        if (line_len > QMCD_CONFIG_LINE_BYTES) {
            snprintf(why, n, "%s:%u: line longer than %d bytes", name, lineno,
                     QMCD_CONFIG_LINE_BYTES);
            return -1;
        }
        memcpy(line, text + pos, line_len);
        line[line_len] = '\0';
        pos += line_len + (nl ? 1 : 0);
        if (memchr(line, '\0', line_len)) {
            snprintf(why, n, "%s:%u: a NUL byte in the line", name, lineno);
            return -1;
        }
        char *hash = strchr(line, '#');
        if (hash)
            *hash = '\0';
        char *s = trim(line);
        if (!*s)
            continue;
        char *eq = strchr(s, '=');
        if (!eq) {
            snprintf(why, n, "%s:%u: expected 'key = value', got '%.60s'", name, lineno, s);
            return -1;
        }
        *eq = '\0';
        char *key = trim(s), *value = trim(eq + 1);
        if (set_key(c, key, value, problem, sizeof problem) != 0) {
            snprintf(why, n, "%s:%u: %s", name, lineno, problem);
            return -1;
        }
    }
    return 0;
}

/* Reads the whole file (at most QMCD_CONFIG_MAX_BYTES) and parses it.
 * Only a regular file is read: a FIFO would hang start-up or, on SIGHUP,
 * the event loop (regular_file.h). */
static int load_file(const char *path, qmcd_config *c, char *why, size_t n)
{
    int fd = qmcd_open_regular("", path, why, n);
    if (fd < 0)
        return -1;
    FILE *f = fdopen(fd, "r");
    if (!f) {
        snprintf(why, n, "%s: cannot open: %s", path, strerror(errno));
        close(fd);
        return -1;
    }
    char *text = malloc(QMCD_CONFIG_MAX_BYTES + 1);
    int rc = -1;
    if (!text) {
        snprintf(why, n, "%s: out of memory", path);
        goto out;
    }
    size_t len = fread(text, 1, QMCD_CONFIG_MAX_BYTES + 1, f);
    if (ferror(f)) {
        snprintf(why, n, "%s: read error: %s", path, strerror(errno));
        goto out;
    }
    if (len > QMCD_CONFIG_MAX_BYTES) {
        snprintf(why, n, "%s: larger than %d bytes", path, QMCD_CONFIG_MAX_BYTES);
        goto out;
    }
    rc = qmcd_config_parse(path, text, len, c, why, n);
out:
    free(text);
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
        if (strcmp(a, "--check-config") == 0) {
            args->check_only = 1;
        } else if (strcmp(a, "--config") == 0) {
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
    int listen_seen = 0, modbus_seen = 0, modbus_allow_seen = 0;
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
        if (strcmp(key, "check-config") == 0 && !eq)
            continue;
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
        /* So do --modbus and --modbus-allow the file's. */
        if (strcmp(key, "modbus") == 0 && !modbus_seen) {
            c->n_modbus = 0;
            modbus_seen = 1;
        }
        if (strcmp(key, "modbus-allow") == 0 && !modbus_allow_seen) {
            c->modbus_allow[0] = '\0';
            modbus_allow_seen = 1;
        }
        int rc = set_key(c, key, value, problem, sizeof problem);
        if (rc == -2) {
            snprintf(why, n, "unknown option '--%s' (see qmcd --help)", key);
            return -1;
        }
        if (rc != 0) {
            snprintf(why, n, "--%s", problem);
            return -1;
        }
    }
    return 0;
}

int qmcd_config_load(const qmcd_args *args, qmcd_config *c, char *why, size_t why_bytes)
{
    qmcd_config_defaults(c);
    const char *path = args->config_path;
    if (!path && args->check_only)
        path = QMCD_DEFAULT_CONFIG;
    if (path && load_file(path, c, why, why_bytes) != 0)
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
    /* A rule across keys: a Modbus listener off loopback needs an allow
     * list.  Numeric hosts are judged here, so --check-config sees it. */
    if (qmcd_modbus_check_exposure(c, why, why_bytes) != 0)
        return -1;
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
    /* The Modbus transports and their allow list are fixed at start. */
    int modbus_changed = old->n_modbus != fresh->n_modbus ||
                         strcmp(old->modbus_allow, fresh->modbus_allow) != 0;
    for (unsigned i = 0; !modbus_changed && i < old->n_modbus; i++)
        modbus_changed = strcmp(old->modbus[i], fresh->modbus[i]) != 0;
    if (modbus_changed)
        qmcd_warn("reload: modbus and modbus-allow change only on restart; keeping them");
    memcpy(fresh->modbus, old->modbus, sizeof fresh->modbus);
    fresh->n_modbus = old->n_modbus;
    memcpy(fresh->modbus_allow, old->modbus_allow, sizeof fresh->modbus_allow);
}
