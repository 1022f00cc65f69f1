/*
 * qmc/auth.h - the authenticated handshake of protocol version 3
 * (protocol/PROTOCOL.md section 4.1): a shared key, a fresh nonce from each
 * side, and an HMAC-SHA256 proof in each direction.
 *
 *   client                                     server
 *   HELLO {versions, max_frame, name}   ->
 *                                       <-  AUTH_CHALLENGE {version, Ns}
 *   AUTH_RESPONSE {Nc, Mc}              ->     checks Mc (constant time)
 *                                       <-  AUTH_OK {Ms}, then HELLO_OK
 *   checks Ms, then HELLO_OK
 *
 * Mc = HMAC-SHA256(key, transcript("C>S")), Ms = HMAC-SHA256(key,
 * transcript("S>C")), where the transcript binds the direction, the
 * client's version range, the version chosen and both nonces (see
 * qmc_auth_transcript).  A fresh server nonce makes a recorded response
 * useless on a new connection (no replay); the direction label makes a
 * proof of one side useless as the other's (no reflection); the versions
 * make an altered HELLO fail the proof (no silent downgrade).
 *
 * These are pure functions and small state machines over caller-owned
 * structs: they do no I/O and draw no randomness - the caller passes the
 * nonce it drew (randombytes_buf), so tests can inject their own.  The
 * MAC and the comparison are libsodium's (crypto_auth_hmacsha256_*,
 * sodium_memcmp); nothing here is a home-made primitive.
 */
#ifndef QMC_AUTH_H
#define QMC_AUTH_H

#include <stddef.h>
#include <stdint.h>

#include "qmc/error.h"
#include "qmc/proto.h"

#ifdef __cplusplus
extern "C" {
#endif

/* A key is the whole content of its file, byte for byte (32 random bytes
 * recommended: `head -c 32 /dev/urandom`).  Shorter keys are refused as
 * too weak to be a key; longer ones as not what a key file holds. */
#define QMC_AUTH_KEY_MIN_BYTES 16u
#define QMC_AUTH_KEY_MAX_BYTES 1024u

/* The bytes an HMAC covers: label (16), version_min, version_max,
 * version, zero (u16 each), server nonce (32), client nonce (32). */
#define QMC_AUTH_TRANSCRIPT_BYTES 88u

typedef enum qmc_auth_dir {
    QMC_AUTH_CLIENT_PROOF = 1,   /* label "qmcd-auth-v1 C>S" */
    QMC_AUTH_SERVER_PROOF = 2    /* label "qmcd-auth-v1 S>C" */
} qmc_auth_dir;

/*
 * Writes the transcript for dir into out (QMC_AUTH_TRANSCRIPT_BYTES);
 * returns its length, or 0 for an unknown dir or NULL pointers.
 */
size_t qmc_auth_transcript(qmc_auth_dir dir, uint16_t version_min, uint16_t version_max,
                           uint16_t version, const uint8_t *server_nonce,
                           const uint8_t *client_nonce, uint8_t *out);

/*
 * mac = HMAC-SHA256(key, transcript(dir, ...)).  Returns 0, or QMC_EINVAL
 * for a key outside QMC_AUTH_KEY_MIN_BYTES..QMC_AUTH_KEY_MAX_BYTES, an
 * unknown dir or NULL pointers (mac is then zeroed).
 */
QMC_MUST_CHECK int qmc_auth_mac(const uint8_t *key, size_t key_bytes, qmc_auth_dir dir,
                                uint16_t version_min, uint16_t version_max,
                                uint16_t version, const uint8_t *server_nonce,
                                const uint8_t *client_nonce, uint8_t *mac);

/*
 * The key-file rule, from fstat(2) fields: a regular file, no access for
 * group or others (mode 0600 or stricter), QMC_AUTH_KEY_MIN_BYTES ..
 * QMC_AUTH_KEY_MAX_BYTES long.  Returns 0, or QMC_EAUTH with *why set to
 * a static phrase ("is readable or writable by group or others (chmod
 * 600 it)").
 */
QMC_MUST_CHECK int qmc_auth_key_file_check(uint32_t st_mode, uint64_t st_size,
                                           const char **why);

/* Handshake states. */
enum { QMC_AUTH_IDLE = 0, QMC_AUTH_CHALLENGED = 1, QMC_AUTH_DONE = 2, QMC_AUTH_FAILED = 3 };

/* The server's side of one connection's handshake (caller-allocated;
 * zero it to start). */
typedef struct qmc_auth_server {
    int state;
    uint16_t version_min, version_max, version;
    uint8_t server_nonce[QMC_PROTO_AUTH_NONCE_BYTES];
} qmc_auth_server;

/*
 * After a HELLO that must authenticate: chooses the version (the highest
 * of the client's range up to server_version_max) and fills the
 * AUTH_CHALLENGE payload with it and nonce (the caller's fresh random
 * bytes).  Returns 0; QMC_ENOTSUP when the client's range stops below
 * version 3 (it cannot authenticate: refuse it); QMC_EPROTO when s is not
 * idle.
 */
QMC_MUST_CHECK int qmc_auth_server_challenge(qmc_auth_server *s, const qmc_msg_hello *hello,
                                             uint16_t server_version_max,
                                             const uint8_t *nonce,
                                             qmc_msg_auth_challenge *out);

/*
 * On AUTH_RESPONSE: checks the client's proof in constant time.  Returns
 * 0 with *out the server's proof (send AUTH_OK, then HELLO_OK with
 * s->version); QMC_EAUTH for a wrong proof (the key differs); QMC_EPROTO
 * when no challenge is pending; QMC_EINVAL for a bad key.  Either way the
 * state leaves CHALLENGED: a connection gets one try.
 */
QMC_MUST_CHECK int qmc_auth_server_verify(qmc_auth_server *s, const uint8_t *key,
                                          size_t key_bytes,
                                          const qmc_msg_auth_response *r,
                                          qmc_msg_auth_ok *out);

/* The client's side of one handshake. */
typedef struct qmc_auth_client {
    int state;
    uint16_t version;            /* what AUTH_CHALLENGE announced */
    uint8_t expect[QMC_PROTO_AUTH_MAC_BYTES];  /* the server's proof to come */
} qmc_auth_client;

/*
 * On AUTH_CHALLENGE, for a HELLO that offered version_min..version_max:
 * fills the AUTH_RESPONSE with nonce (fresh random bytes) and the proof,
 * and remembers the server's proof to expect.  Returns 0; QMC_EPROTO for
 * a challenge announcing a version the HELLO did not offer, or when s is
 * not idle; QMC_EINVAL for a bad key.
 */
QMC_MUST_CHECK int qmc_auth_client_respond(qmc_auth_client *s, uint16_t version_min,
                                           uint16_t version_max,
                                           const qmc_msg_auth_challenge *ch,
                                           const uint8_t *nonce, const uint8_t *key,
                                           size_t key_bytes, qmc_msg_auth_response *out);

/* On AUTH_OK: 0 when the server proved it holds the key, QMC_EAUTH when
 * not, QMC_EPROTO when no response was sent. */
QMC_MUST_CHECK int qmc_auth_client_check(qmc_auth_client *s, const qmc_msg_auth_ok *ok);

#ifdef __cplusplus
}
#endif
#endif /* QMC_AUTH_H */
