/*
 * fuzz_auth.c - libFuzzer target for the HELLO / authentication exchange
 * (protocol version 3, protocol/auth.c and the AUTH_* layouts of
 * protocol/messages.c), linked against build/fuzz/libqmcproto.a.
 *
 * The input is: one byte choosing the key length (16..79 bytes), the key,
 * 32 bytes of server nonce, 32 of client nonce, then a byte stream that
 * plays a hostile peer to both sides at once.  Its frames are decoded one
 * after another and fed to
 *
 *   - the server's machine (qmc_auth_server_*): a HELLO is challenged, an
 *     AUTH_RESPONSE verified; and
 *   - the client's machine (qmc_auth_client_*), as if it had sent HELLO
 *     1..3: an AUTH_CHALLENGE is answered, an AUTH_OK checked.
 *
 * What must hold whatever the bytes: a proof is accepted exactly when it
 * equals the HMAC the oracle path (qmc_auth_mac over the same fields)
 * gives, never otherwise; each side accepts at most once and never after
 * a failure; every answer the machines produce encodes and decodes back to
 * itself.  Then an honest exchange from the same key and nonces, through
 * the codec, must succeed on both sides, and fail on the server when any
 * one bit of the client's proof is flipped.
 */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "qmc/auth.h"
#include "qmc/proto.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#define NONCE QMC_PROTO_AUTH_NONCE_BYTES
#define MAC QMC_PROTO_AUTH_MAC_BYTES

static uint8_t frame[QMC_PROTO_HEADER_BYTES + 256];

/* Encodes m and decodes it again: the same type, id and bytes back. */
static void round_trip(const qmc_msg *m)
{
    int n = qmc_proto_encode(m, frame, sizeof frame);
    if (n <= 0)
        __builtin_trap();
    qmc_msg d;
    if (qmc_proto_decode(frame, (size_t)n, QMC_PROTO_MAX_PAYLOAD, &d) != n ||
        d.type != m->type || d.request_id != m->request_id)
        __builtin_trap();
    if (m->type == QMC_MSG_AUTH_RESPONSE &&
        (memcmp(d.u.response.mac, m->u.response.mac, MAC) != 0 ||
         memcmp(d.u.response.nonce, m->u.response.nonce, NONCE) != 0))
        __builtin_trap();
    if (m->type == QMC_MSG_AUTH_OK && memcmp(d.u.auth_ok.mac, m->u.auth_ok.mac, MAC) != 0)
        __builtin_trap();
    if (m->type == QMC_MSG_AUTH_CHALLENGE &&
        (d.u.challenge.version != m->u.challenge.version ||
         memcmp(d.u.challenge.nonce, m->u.challenge.nonce, NONCE) != 0))
        __builtin_trap();
}

typedef struct sides {
    const uint8_t *key;
    size_t key_bytes;
    const uint8_t *sn, *cn;
    qmc_auth_server srv;
    qmc_msg_hello hello;         /* what the server was told */
    int srv_accepts;
    qmc_auth_client cli;
    int cli_accepts;
} sides;

static void to_server(sides *s, const qmc_msg *m)
{
    if (m->type == QMC_MSG_HELLO) {
        qmc_msg ch = {.type = QMC_MSG_AUTH_CHALLENGE, .request_id = m->request_id};
        int before = s->srv.state;
        int err = qmc_auth_server_challenge(&s->srv, &m->u.hello, QMC_PROTO_VERSION_MAX, s->sn,
                                            &ch.u.challenge);
        if (err == 0) {
            if (before != QMC_AUTH_IDLE || ch.u.challenge.version < QMC_PROTO_VERSION_AUTH ||
                ch.u.challenge.version > m->u.hello.version_max ||
                ch.u.challenge.version < m->u.hello.version_min)
                __builtin_trap();
            s->hello = m->u.hello;
            round_trip(&ch);
        } else if (err != QMC_ENOTSUP && err != QMC_EPROTO) {
            __builtin_trap();
        }
        return;
    }
    if (m->type != QMC_MSG_AUTH_RESPONSE)
        return;
    int challenged = s->srv.state == QMC_AUTH_CHALLENGED;
    qmc_msg ok = {.type = QMC_MSG_AUTH_OK, .request_id = m->request_id};
    int err = qmc_auth_server_verify(&s->srv, s->key, s->key_bytes, &m->u.response,
                                     &ok.u.auth_ok);
    /* The oracle path: the MAC over the fields the server holds. */
    uint8_t want[MAC];
    int right = challenged &&
                qmc_auth_mac(s->key, s->key_bytes, QMC_AUTH_CLIENT_PROOF,
                             s->hello.version_min, s->hello.version_max, s->srv.version,
                             s->sn, m->u.response.nonce, want) == 0 &&
                memcmp(want, m->u.response.mac, MAC) == 0;
    if ((err == 0) != right)
        __builtin_trap();
    if (err == 0) {
        if (++s->srv_accepts > 1 || s->srv.state != QMC_AUTH_DONE)
            __builtin_trap();
        round_trip(&ok);
    } else if (s->srv.state == QMC_AUTH_DONE && !s->srv_accepts) {
        __builtin_trap();
    }
}

static void to_client(sides *s, const qmc_msg *m)
{
    if (m->type == QMC_MSG_AUTH_CHALLENGE) {
        qmc_msg r = {.type = QMC_MSG_AUTH_RESPONSE, .request_id = m->request_id};
        int before = s->cli.state;
        int err = qmc_auth_client_respond(&s->cli, 1, QMC_PROTO_VERSION_MAX, &m->u.challenge,
                                          s->cn, s->key, s->key_bytes, &r.u.response);
        if (err == 0) {
            if (before != QMC_AUTH_IDLE || m->u.challenge.version > QMC_PROTO_VERSION_MAX)
                __builtin_trap();
            round_trip(&r);
        }
        return;
    }
    if (m->type != QMC_MSG_AUTH_OK)
        return;
    int waiting = s->cli.state == QMC_AUTH_CHALLENGED;
    int right = waiting && memcmp(s->cli.expect, m->u.auth_ok.mac, MAC) == 0;
    int err = qmc_auth_client_check(&s->cli, &m->u.auth_ok);
    if ((err == 0) != right)
        __builtin_trap();
    if (err == 0 && ++s->cli_accepts > 1)
        __builtin_trap();
}

/* The honest exchange, through the codec. */
static void honest(const uint8_t *key, size_t key_bytes, const uint8_t *sn, const uint8_t *cn,
                   unsigned flip)
{
    qmc_auth_server srv;
    qmc_auth_client cli;
    memset(&srv, 0, sizeof srv);
    memset(&cli, 0, sizeof cli);
    qmc_msg hello = {.type = QMC_MSG_HELLO, .request_id = 1};
    hello.u.hello.version_min = 1;
    hello.u.hello.version_max = QMC_PROTO_VERSION_MAX;
    hello.u.hello.max_frame = 1u << 20;
    round_trip(&hello);
    qmc_msg ch = {.type = QMC_MSG_AUTH_CHALLENGE, .request_id = 1};
    if (qmc_auth_server_challenge(&srv, &hello.u.hello, QMC_PROTO_VERSION_MAX, sn,
                                  &ch.u.challenge) != 0)
        __builtin_trap();
    round_trip(&ch);
    qmc_msg r = {.type = QMC_MSG_AUTH_RESPONSE, .request_id = 1};
    if (qmc_auth_client_respond(&cli, 1, QMC_PROTO_VERSION_MAX, &ch.u.challenge, cn, key,
                                key_bytes, &r.u.response) != 0)
        __builtin_trap();
    round_trip(&r);
    qmc_msg_auth_response bent = r.u.response;
    bent.mac[(flip / 8) % MAC] ^= (uint8_t)(1u << (flip % 8));
    qmc_auth_server twin = srv;
    qmc_msg_auth_ok ok2;
    if (qmc_auth_server_verify(&twin, key, key_bytes, &bent, &ok2) != QMC_EAUTH)
        __builtin_trap();
    qmc_msg ok = {.type = QMC_MSG_AUTH_OK, .request_id = 1};
    if (qmc_auth_server_verify(&srv, key, key_bytes, &r.u.response, &ok.u.auth_ok) != 0)
        __builtin_trap();
    round_trip(&ok);
    if (qmc_auth_client_check(&cli, &ok.u.auth_ok) != 0)
        __builtin_trap();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1)
        return 0;
    size_t key_bytes = QMC_AUTH_KEY_MIN_BYTES + (data[0] & 63u);
    if (size < 1 + key_bytes + 2 * NONCE)
        return 0;
    sides s;
    memset(&s, 0, sizeof s);
    s.key = data + 1;
    s.key_bytes = key_bytes;
    s.sn = s.key + key_bytes;
    s.cn = s.sn + NONCE;
    const uint8_t *p = s.cn + NONCE;
    size_t left = size - (size_t)(p - data);
    while (left > 0) {
        qmc_msg m;
        int n = qmc_proto_decode(p, left, 4096, &m);
        if (n < 0)
            break;
        to_server(&s, &m);
        to_client(&s, &m);
        p += n;
        left -= (size_t)n;
    }
    honest(s.key, s.key_bytes, s.sn, s.cn, data[0]);
    /* The key-file rule is total: any mode and size gives 0 or EAUTH. */
    const char *why = NULL;
    uint32_t mode = (uint32_t)data[0] << 8 | s.key[0];
    int k = qmc_auth_key_file_check(mode | 0100000u, s.key[1], &why);
    if ((k != 0 && k != QMC_EAUTH) || why == NULL)
        __builtin_trap();
    return 0;
}
