/*
 * auth.h - the daemon's side of key authentication (PROTOCOL.md section
 * 4.1, docs/SECURITY.md): the key file, which connections must prove they
 * hold it, the HELLO / AUTH_RESPONSE hooks, and the per-network slowing
 * after repeated failures.
 */
#ifndef QMCD_AUTH_H
#define QMCD_AUTH_H

#include <stddef.h>
#include <stdint.h>
#include <sys/socket.h>

#include "qmc/proto.h"
#include "server.h"

typedef struct qmcd_auth qmcd_auth;
/* One connection's handshake in progress (auth.c). */
typedef struct qmcd_auth_conn qmcd_auth_conn;

/* Creates the server's authentication state (no key yet).  Returns 0 or
 * -ENOMEM / the libsodium initialisation failure as -EIO. */
int qmcd_auth_new(qmcd_auth **out);
/* Wipes the key and frees; NULL is a no-op. */
void qmcd_auth_free(qmcd_auth *a);

/*
 * Reads cfg's auth-key file (none configured: no key) and checks it: a
 * regular file, mode 0600 or stricter, 16 to 1024 bytes.  On success the
 * key replaces the one a holds (a SIGHUP rotates keys this way) and 0 is
 * returned; on error a keeps its key and one line goes into why (-1).
 */
int qmcd_auth_load_key(qmcd_auth *a, const qmcd_config *cfg, char *why, size_t why_bytes);

/* 1 when a key is loaded. */
int qmcd_auth_has_key(const qmcd_auth *a);

/* 1 for an address only this host can reach: 127.0.0.0/8, ::1, or an
 * IPv4-mapped 127.x.  0.0.0.0 and :: (every interface) are not. */
int qmcd_auth_is_loopback(const struct sockaddr *sa);

/* HELLO and AUTH_RESPONSE are qmcd_auth_module's rows (modules.h): HELLO
 * is answered HELLO_OK, or AUTH_CHALLENGE when this connection must prove
 * it holds the key; a good AUTH_RESPONSE gets AUTH_OK and HELLO_OK, a bad
 * one fails the connection (QMC_EAUTH or QMC_EPROTO) - at once, or when
 * its network's wait is over (auth_guard.h).  With no room left in
 * max-connections (admit.h), ERROR instead of HELLO_OK.  While a
 * challenge awaits its answer, the connection's auth field is set. */

#endif
