/*
 * modules.c - puts the modules of modules.h into the server: their rows
 * into the dispatch table (by message type), their server-wide state
 * opened at start and closed at exit.
 *
 * This file must not handle a request itself; main.c calls it once each
 * way.
 */
#include <stdio.h>
#include <string.h>

#include "modules.h"

#define QMCD__MODULE_ADDRESS(m) &m,
static const qmcd_module *const modules[] = {QMCD_MODULES(QMCD__MODULE_ADDRESS)};
#undef QMCD__MODULE_ADDRESS
#define N_MODULES (sizeof modules / sizeof modules[0])

int qmcd_modules_open(qmcd_server *srv, char *why, size_t n)
{
    memset(srv->routes, 0, sizeof srv->routes);
    srv->modules = modules;
    srv->n_modules = 0;
    for (unsigned i = 0; i < N_MODULES; i++) {
        const qmcd_module *mod = modules[i];
        for (const qmcd_route *r = mod->routes; r && r->fn; r++) {
            if ((unsigned)r->type >= QMCD_ROUTE_TYPES || srv->routes[r->type]) {
                snprintf(why, n, "module %s: message type %u %s", mod->name,
                         (unsigned)r->type,
                         (unsigned)r->type >= QMCD_ROUTE_TYPES ? "is past the dispatch table"
                                                               : "has a handler already");
                qmcd_modules_close(srv);
                return -1;
            }
            srv->routes[r->type] = r;
        }
        int err = mod->open ? mod->open(srv) : 0;
        if (err) {
            snprintf(why, n, "module %s: %s", mod->name, strerror(-err));
            qmcd_modules_close(srv);
            return -1;
        }
        srv->n_modules = i + 1; /* opened: closed in turn */
    }
    return 0;
}

void qmcd_modules_close(qmcd_server *srv)
{
    while (srv->n_modules) {
        const qmcd_module *mod = srv->modules[--srv->n_modules];
        if (mod->close)
            mod->close(srv);
    }
    memset(srv->routes, 0, sizeof srv->routes);
}
