/*
 * remote.c - what every subcommand shares in remote mode: finding the
 * endpoint (--connect, else QMC_ENDPOINT) and the key (--auth-key, else
 * QMC_AUTH_KEY_FILE, read by the library), connecting, and turning the
 * client library's errors into the CLI's one line on stderr.
 *
 * The CLI links libqmcclient exactly as any other user would; nothing
 * here reaches past include/qmc/client.h.
 */
#include <stdlib.h>
#include <string.h>

#include "cli.h"

const char cli_remote_help[] =
    "\nremote mode:\n"
    "  --connect ENDPOINT  run on the qmcd daemon at ENDPOINT: unix:PATH,\n"
    "                    tcp:HOST:PORT or tcp:[IPv6]:PORT; the output is the same\n"
    "                    bytes as in-process (default: $QMC_ENDPOINT; '' forces\n"
    "                    in-process)\n"
    "  --auth-key FILE     prove to the daemon that we hold the key in FILE (mode\n"
    "                    0600; default: $QMC_AUTH_KEY_FILE), and insist that a tcp:\n"
    "                    daemon proves it too (docs/SECURITY.md)\n";

/* --auth-key as given (NULL: the library reads $QMC_AUTH_KEY_FILE).  One
 * per process, like the endpoint: the CLI runs one command. */
static const char *auth_key_file;

int cli_remote_take(int *argc, char **argv, const char **endpoint)
{
    const char *env = getenv("QMC_ENDPOINT");
    *endpoint = env;
    int out = 1;
    for (int i = 1; i < *argc; i++) {
        if (strcmp(argv[i], "--connect") == 0) {
            if (i + 1 >= *argc) {
                cli_error("%s: --connect needs an ENDPOINT (unix:PATH or tcp:HOST:PORT)",
                          argv[0]);
                return -1;
            }
            *endpoint = argv[++i];
        } else if (strncmp(argv[i], "--connect=", 10) == 0) {
            *endpoint = argv[i] + 10;
        } else if (strcmp(argv[i], "--auth-key") == 0) {
            if (i + 1 >= *argc) {
                cli_error("%s: --auth-key needs a FILE", argv[0]);
                return -1;
            }
            auth_key_file = argv[++i];
        } else if (strncmp(argv[i], "--auth-key=", 11) == 0) {
            auth_key_file = argv[i] + 11;
        } else {
            argv[out++] = argv[i];
        }
    }
    argv[out] = NULL;
    *argc = out;
    if (*endpoint && (*endpoint)[0] == '\0')
        *endpoint = NULL;
    return 0;
}

int cli_remote_in_process_only(const char *option, const char *what)
{
    return cli_error("%s is an in-process option: the daemon runs %s on its own pool (drop "
                     "it, or --connect '' to run here)", option, what);
}

int cli_remote_connect(const char *endpoint, qmc_client **out)
{
    int err = qmc_client_connect_auth(endpoint, CLI_REMOTE_TIMEOUT_MS, auth_key_file, out);
    if (err == 0)
        return 0;
    int rc = cli_remote_fail(*out, err, "");
    qmc_client_close(*out);
    *out = NULL;
    return rc;
}

int cli_remote_fail(const qmc_client *c, int err, const char *prefix)
{
    const char *msg = qmc_client_last_error(c);
    return cli_error("%s%s", prefix, msg[0] ? msg : qmc_strerror(err));
}
