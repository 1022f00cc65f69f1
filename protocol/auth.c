/*
 * auth.c - the version-3 handshake's computation (qmc/auth.h): the
 * transcript each proof covers, HMAC-SHA256 over it, the constant-time
 * check, the key-file rule, and the two sides' small state machines.
 *
 * It must not do I/O or draw randomness: the daemon and the client read
 * key files and draw nonces (randombytes_buf), and pass both in.  The
 * primitives are libsodium's; this file only decides what they cover.
 */
#include <string.h>
#include <sys/stat.h>

#include <sodium.h>

#include "qmc/auth.h"
#include "wire.h"

/* 16 bytes each, no terminator on the wire: the direction is the first
 * thing the MAC covers, so a proof for one direction never verifies as
 * the other's. */
static const char label_client[16] = {'q', 'm', 'c', 'd', '-', 'a', 'u', 't',
                                      'h', '-', 'v', '1', ' ', 'C', '>', 'S'};
static const char label_server[16] = {'q', 'm', 'c', 'd', '-', 'a', 'u', 't',
                                      'h', '-', 'v', '1', ' ', 'S', '>', 'C'};

size_t qmc_auth_transcript(qmc_auth_dir dir, uint16_t version_min, uint16_t version_max,
                           uint16_t version, const uint8_t *server_nonce,
                           const uint8_t *client_nonce, uint8_t *out)
{
    if (!server_nonce || !client_nonce || !out)
        return 0;
    const char *label = dir == QMC_AUTH_CLIENT_PROOF   ? label_client
                        : dir == QMC_AUTH_SERVER_PROOF ? label_server
                                                       : NULL;
    if (!label)
        return 0;
    memcpy(out, label, 16);
    qmc__store_u16(out + 16, version_min);
    qmc__store_u16(out + 18, version_max);
    qmc__store_u16(out + 20, version);
    qmc__store_u16(out + 22, 0);
    memcpy(out + 24, server_nonce, QMC_PROTO_AUTH_NONCE_BYTES);
    memcpy(out + 24 + QMC_PROTO_AUTH_NONCE_BYTES, client_nonce, QMC_PROTO_AUTH_NONCE_BYTES);
    return QMC_AUTH_TRANSCRIPT_BYTES;
}

int qmc_auth_mac(const uint8_t *key, size_t key_bytes, qmc_auth_dir dir,
                 uint16_t version_min, uint16_t version_max, uint16_t version,
                 const uint8_t *server_nonce, const uint8_t *client_nonce, uint8_t *mac)
{
    if (!mac)
        return QMC_EINVAL;
    memset(mac, 0, QMC_PROTO_AUTH_MAC_BYTES);
    uint8_t t[QMC_AUTH_TRANSCRIPT_BYTES];
    if (!key || key_bytes < QMC_AUTH_KEY_MIN_BYTES || key_bytes > QMC_AUTH_KEY_MAX_BYTES ||
        qmc_auth_transcript(dir, version_min, version_max, version, server_nonce,
                            client_nonce, t) != sizeof t)
        return QMC_EINVAL;
    /* The init that takes a key of any length: HMAC as RFC 2104 defines
     * it (a key longer than the block is hashed first), so any HMAC-SHA256
     * implementation computes the same tag. */
    crypto_auth_hmacsha256_state st;
    if (crypto_auth_hmacsha256_init(&st, key, key_bytes) != 0 ||
        crypto_auth_hmacsha256_update(&st, t, sizeof t) != 0 ||
        crypto_auth_hmacsha256_final(&st, mac) != 0) {
        sodium_memzero(&st, sizeof st);
        memset(mac, 0, QMC_PROTO_AUTH_MAC_BYTES);
        return QMC_EINVAL;
    }
    sodium_memzero(&st, sizeof st);
    return 0;
}

int qmc_auth_key_file_check(uint32_t st_mode, uint64_t st_size, const char **why)
{
    const char *w = NULL;
    if (!S_ISREG(st_mode))
        w = "is not a regular file";
    else if (st_mode & 077)
        w = "is readable or writable by group or others (chmod 600 it)";
    else if (st_size < QMC_AUTH_KEY_MIN_BYTES)
        w = "is shorter than 16 bytes (make one with head -c 32 /dev/urandom)";
    else if (st_size > QMC_AUTH_KEY_MAX_BYTES)
        w = "is longer than 1024 bytes: not a key file";
    if (why)
        *why = w ? w : "";
    return w ? QMC_EAUTH : 0;
}

int qmc_auth_server_challenge(qmc_auth_server *s, const qmc_msg_hello *hello,
                              uint16_t server_version_max, const uint8_t *nonce,
                              qmc_msg_auth_challenge *out)
{
    if (!s || !hello || !nonce || !out)
        return QMC_EINVAL;
    if (s->state != QMC_AUTH_IDLE)
        return QMC_EPROTO;
    memset(out, 0, sizeof *out);
    uint16_t top = hello->version_max < server_version_max ? hello->version_max
                                                           : server_version_max;
    if (top < QMC_PROTO_VERSION_AUTH || hello->version_min > top) {
        s->state = QMC_AUTH_FAILED;
        return QMC_ENOTSUP;
    }
    s->version_min = hello->version_min;
    s->version_max = hello->version_max;
    s->version = top;
    memcpy(s->server_nonce, nonce, QMC_PROTO_AUTH_NONCE_BYTES);
    out->version = top;
    memcpy(out->nonce, nonce, QMC_PROTO_AUTH_NONCE_BYTES);
    s->state = QMC_AUTH_CHALLENGED;
    return 0;
}

int qmc_auth_server_verify(qmc_auth_server *s, const uint8_t *key, size_t key_bytes,
                           const qmc_msg_auth_response *r, qmc_msg_auth_ok *out)
{
    if (!s || !r || !out)
        return QMC_EINVAL;
    memset(out, 0, sizeof *out);
    if (s->state != QMC_AUTH_CHALLENGED)
        return QMC_EPROTO;
    s->state = QMC_AUTH_FAILED; /* until proven otherwise: one try */
    uint8_t want[QMC_PROTO_AUTH_MAC_BYTES];
    int err = qmc_auth_mac(key, key_bytes, QMC_AUTH_CLIENT_PROOF, s->version_min,
                           s->version_max, s->version, s->server_nonce, r->nonce, want);
    if (err)
        return err;
    int same = sodium_memcmp(want, r->mac, sizeof want) == 0;
    sodium_memzero(want, sizeof want);
    if (!same)
        return QMC_EAUTH;
    err = qmc_auth_mac(key, key_bytes, QMC_AUTH_SERVER_PROOF, s->version_min, s->version_max,
                       s->version, s->server_nonce, r->nonce, out->mac);
    if (err)
        return err;
    s->state = QMC_AUTH_DONE;
    return 0;
}

int qmc_auth_client_respond(qmc_auth_client *s, uint16_t version_min, uint16_t version_max,
                            const qmc_msg_auth_challenge *ch, const uint8_t *nonce,
                            const uint8_t *key, size_t key_bytes, qmc_msg_auth_response *out)
{
    if (!s || !ch || !nonce || !out)
        return QMC_EINVAL;
    memset(out, 0, sizeof *out);
    if (s->state != QMC_AUTH_IDLE)
        return QMC_EPROTO;
    s->state = QMC_AUTH_FAILED;
    if (ch->version < version_min || ch->version > version_max ||
        ch->version < QMC_PROTO_VERSION_AUTH)
        return QMC_EPROTO;
    memcpy(out->nonce, nonce, QMC_PROTO_AUTH_NONCE_BYTES);
    int err = qmc_auth_mac(key, key_bytes, QMC_AUTH_CLIENT_PROOF, version_min, version_max,
                           ch->version, ch->nonce, nonce, out->mac);
    if (!err)
        err = qmc_auth_mac(key, key_bytes, QMC_AUTH_SERVER_PROOF, version_min, version_max,
                           ch->version, ch->nonce, nonce, s->expect);
    if (err) {
        memset(out, 0, sizeof *out);
        return err;
    }
    s->version = ch->version;
    s->state = QMC_AUTH_CHALLENGED;
    return 0;
}

int qmc_auth_client_check(qmc_auth_client *s, const qmc_msg_auth_ok *ok)
{
    if (!s || !ok)
        return QMC_EINVAL;
    if (s->state != QMC_AUTH_CHALLENGED)
        return QMC_EPROTO;
    int same = sodium_memcmp(s->expect, ok->mac, sizeof s->expect) == 0;
    sodium_memzero(s->expect, sizeof s->expect);
    s->state = same ? QMC_AUTH_DONE : QMC_AUTH_FAILED;
    return same ? 0 : QMC_EAUTH;
}
