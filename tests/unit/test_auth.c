/*
 * test_auth.c - the version-3 handshake (protocol/auth.c, qmc/auth.h):
 * transcripts and HMAC-SHA256 proofs against known answers computed by
 * Python's hmac/hashlib (tests/vectors/gen_auth_vectors.py, an oracle
 * written apart from the C code), the two state machines end to end with
 * injected nonces, and every way a proof must fail: another key, a flipped
 * bit, a replayed response, a reflected proof, an altered version range,
 * a second try.  The codec side (round trip, truncation, bad lengths of
 * AUTH_*) is test_proto's, which covers every message type.
 */
#define _GNU_SOURCE /* S_IFREG, S_IFDIR */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <string.h>
#include <sys/stat.h>

#include "qmc/auth.h"
#include "../vectors/auth_vectors.h"

static void test_transcript_and_mac_vectors(void **state)
{
    (void)state;
    for (size_t i = 0; i < N_AUTH_VECTORS; i++) {
        const auth_vector *v = &auth_vectors[i];
        uint8_t t[QMC_AUTH_TRANSCRIPT_BYTES];
        assert_int_equal(qmc_auth_transcript(QMC_AUTH_CLIENT_PROOF, v->version_min,
                                             v->version_max, v->version, v->server_nonce,
                                             v->client_nonce, t),
                         sizeof t);
        assert_memory_equal(t, v->transcript_c, sizeof t);
        uint8_t mac[QMC_PROTO_AUTH_MAC_BYTES];
        assert_int_equal(qmc_auth_mac(v->key, v->key_bytes, QMC_AUTH_CLIENT_PROOF,
                                      v->version_min, v->version_max, v->version,
                                      v->server_nonce, v->client_nonce, mac),
                         0);
        assert_memory_equal(mac, v->client_mac, sizeof mac);
        assert_int_equal(qmc_auth_mac(v->key, v->key_bytes, QMC_AUTH_SERVER_PROOF,
                                      v->version_min, v->version_max, v->version,
                                      v->server_nonce, v->client_nonce, mac),
                         0);
        assert_memory_equal(mac, v->server_mac, sizeof mac);
    }
}

static void test_mac_refuses_bad_input(void **state)
{
    (void)state;
    const auth_vector *v = &auth_vectors[0];
    uint8_t mac[QMC_PROTO_AUTH_MAC_BYTES];
    memset(mac, 0xaa, sizeof mac);
    assert_int_equal(qmc_auth_mac(v->key, QMC_AUTH_KEY_MIN_BYTES - 1, QMC_AUTH_CLIENT_PROOF,
                                  1, 3, 3, v->server_nonce, v->client_nonce, mac),
                     QMC_EINVAL);
    for (size_t i = 0; i < sizeof mac; i++)
        assert_int_equal(mac[i], 0); /* zeroed, never a stale tag */
    assert_int_equal(qmc_auth_mac(v->key, QMC_AUTH_KEY_MAX_BYTES + 1, QMC_AUTH_CLIENT_PROOF,
                                  1, 3, 3, v->server_nonce, v->client_nonce, mac),
                     QMC_EINVAL);
    assert_int_equal(qmc_auth_mac(v->key, 32, (qmc_auth_dir)3, 1, 3, 3, v->server_nonce,
                                  v->client_nonce, mac),
                     QMC_EINVAL);
    assert_int_equal(qmc_auth_mac(NULL, 32, QMC_AUTH_CLIENT_PROOF, 1, 3, 3, v->server_nonce,
                                  v->client_nonce, mac),
                     QMC_EINVAL);
    uint8_t t[QMC_AUTH_TRANSCRIPT_BYTES];
    assert_int_equal(qmc_auth_transcript((qmc_auth_dir)0, 1, 3, 3, v->server_nonce,
                                         v->client_nonce, t),
                     0);
}

static void test_key_file_rule(void **state)
{
    (void)state;
    const char *why = NULL;
    assert_int_equal(qmc_auth_key_file_check(S_IFREG | 0600, 32, &why), 0);
    assert_string_equal(why, "");
    assert_int_equal(qmc_auth_key_file_check(S_IFREG | 0400, 16, &why), 0);
    assert_int_equal(qmc_auth_key_file_check(S_IFREG | 0644, 32, &why), QMC_EAUTH);
    assert_non_null(strstr(why, "group or others"));
    assert_int_equal(qmc_auth_key_file_check(S_IFREG | 0604, 32, &why), QMC_EAUTH);
    assert_int_equal(qmc_auth_key_file_check(S_IFREG | 0620, 32, &why), QMC_EAUTH);
    assert_int_equal(qmc_auth_key_file_check(S_IFDIR | 0700, 32, &why), QMC_EAUTH);
    assert_non_null(strstr(why, "regular file"));
    assert_int_equal(qmc_auth_key_file_check(S_IFREG | 0600, 15, &why), QMC_EAUTH);
    assert_int_equal(qmc_auth_key_file_check(S_IFREG | 0600, 1025, &why), QMC_EAUTH);
    assert_int_equal(qmc_auth_key_file_check(S_IFREG | 0600, 1024, NULL), 0);
}

/* One handshake with vector v's nonces and versions; the server holds
 * server_key, the client client_key.  Returns the server's verdict. */
typedef struct run {
    qmc_auth_server srv;
    qmc_auth_client cli;
    qmc_msg_auth_challenge ch;
    qmc_msg_auth_response resp;
    qmc_msg_auth_ok ok;
} run;

static qmc_msg_hello hello_of(uint16_t vmin, uint16_t vmax)
{
    qmc_msg_hello h;
    memset(&h, 0, sizeof h);
    h.version_min = vmin;
    h.version_max = vmax;
    h.max_frame = 1u << 20;
    return h;
}

static int handshake(run *r, const auth_vector *v, const uint8_t *server_key,
                     size_t server_key_bytes, const uint8_t *client_key,
                     size_t client_key_bytes)
{
    memset(r, 0, sizeof *r);
    qmc_msg_hello h = hello_of(v->version_min, v->version_max);
    assert_int_equal(qmc_auth_server_challenge(&r->srv, &h, v->version, v->server_nonce,
                                               &r->ch),
                     0);
    assert_int_equal(r->ch.version, v->version);
    assert_int_equal(qmc_auth_client_respond(&r->cli, v->version_min, v->version_max, &r->ch,
                                             v->client_nonce, client_key, client_key_bytes,
                                             &r->resp),
                     0);
    return qmc_auth_server_verify(&r->srv, server_key, server_key_bytes, &r->resp, &r->ok);
}

static void test_handshake_vectors(void **state)
{
    (void)state;
    for (size_t i = 0; i < N_AUTH_VECTORS; i++) {
        const auth_vector *v = &auth_vectors[i];
        run r;
        assert_int_equal(handshake(&r, v, v->key, v->key_bytes, v->key, v->key_bytes), 0);
        /* The wire carries what the oracle computed. */
        assert_memory_equal(r.resp.mac, v->client_mac, sizeof r.resp.mac);
        assert_memory_equal(r.resp.nonce, v->client_nonce, sizeof r.resp.nonce);
        assert_memory_equal(r.ok.mac, v->server_mac, sizeof r.ok.mac);
        assert_int_equal(r.srv.state, QMC_AUTH_DONE);
        assert_int_equal(qmc_auth_client_check(&r.cli, &r.ok), 0);
        assert_int_equal(r.cli.state, QMC_AUTH_DONE);
        /* Each side proves once. */
        assert_int_equal(qmc_auth_server_verify(&r.srv, v->key, v->key_bytes, &r.resp, &r.ok),
                         QMC_EPROTO);
        assert_int_equal(qmc_auth_client_check(&r.cli, &r.ok), QMC_EPROTO);
    }
}

static void test_wrong_key(void **state)
{
    (void)state;
    const auth_vector *v = &auth_vectors[0];
    uint8_t other[32];
    memcpy(other, v->key, sizeof other);
    other[31] ^= 1;
    run r;
    assert_int_equal(handshake(&r, v, v->key, v->key_bytes, other, sizeof other), QMC_EAUTH);
    assert_int_equal(r.srv.state, QMC_AUTH_FAILED);
    /* No proof of the server's leaks out on failure. */
    for (size_t i = 0; i < sizeof r.ok.mac; i++)
        assert_int_equal(r.ok.mac[i], 0);
    /* One try per connection: the right answer now is refused too. */
    qmc_msg_auth_response good;
    memcpy(good.nonce, v->client_nonce, sizeof good.nonce);
    memcpy(good.mac, v->client_mac, sizeof good.mac);
    assert_int_equal(qmc_auth_server_verify(&r.srv, v->key, v->key_bytes, &good, &r.ok),
                     QMC_EPROTO);
}

static void test_every_flipped_bit_fails(void **state)
{
    (void)state;
    const auth_vector *v = &auth_vectors[0];
    for (unsigned bit = 0; bit < 8 * QMC_PROTO_AUTH_MAC_BYTES; bit++) {
        run r;
        memset(&r, 0, sizeof r);
        qmc_msg_hello h = hello_of(v->version_min, v->version_max);
        assert_int_equal(qmc_auth_server_challenge(&r.srv, &h, 3, v->server_nonce, &r.ch), 0);
        memcpy(r.resp.nonce, v->client_nonce, sizeof r.resp.nonce);
        memcpy(r.resp.mac, v->client_mac, sizeof r.resp.mac);
        r.resp.mac[bit / 8] ^= (uint8_t)(1u << (bit % 8));
        assert_int_equal(qmc_auth_server_verify(&r.srv, v->key, v->key_bytes, &r.resp, &r.ok),
                         QMC_EAUTH);
    }
    /* And the client refuses a server proof with any bit flipped. */
    for (unsigned bit = 0; bit < 8 * QMC_PROTO_AUTH_MAC_BYTES; bit += 7) {
        run r;
        assert_int_equal(handshake(&r, v, v->key, v->key_bytes, v->key, v->key_bytes), 0);
        r.ok.mac[bit / 8] ^= (uint8_t)(1u << (bit % 8));
        assert_int_equal(qmc_auth_client_check(&r.cli, &r.ok), QMC_EAUTH);
    }
}

static void test_replay_and_reflection(void **state)
{
    (void)state;
    const auth_vector *v = &auth_vectors[0];
    /* Replay: the recorded response of one connection, against a fresh
     * challenge on the next. */
    qmc_auth_server s;
    memset(&s, 0, sizeof s);
    qmc_msg_hello h = hello_of(v->version_min, v->version_max);
    uint8_t fresh[QMC_PROTO_AUTH_NONCE_BYTES];
    memcpy(fresh, v->server_nonce, sizeof fresh);
    fresh[0] ^= 0x80;
    qmc_msg_auth_challenge ch;
    assert_int_equal(qmc_auth_server_challenge(&s, &h, 3, fresh, &ch), 0);
    qmc_msg_auth_response recorded;
    memcpy(recorded.nonce, v->client_nonce, sizeof recorded.nonce);
    memcpy(recorded.mac, v->client_mac, sizeof recorded.mac);
    qmc_msg_auth_ok ok;
    assert_int_equal(qmc_auth_server_verify(&s, v->key, v->key_bytes, &recorded, &ok),
                     QMC_EAUTH);
    /* Reflection: the server's own proof handed back as a client's. */
    memset(&s, 0, sizeof s);
    assert_int_equal(qmc_auth_server_challenge(&s, &h, 3, v->server_nonce, &ch), 0);
    qmc_msg_auth_response reflected;
    memcpy(reflected.nonce, v->client_nonce, sizeof reflected.nonce);
    memcpy(reflected.mac, v->server_mac, sizeof reflected.mac);
    assert_int_equal(qmc_auth_server_verify(&s, v->key, v->key_bytes, &reflected, &ok),
                     QMC_EAUTH);
}

static void test_versions_are_bound(void **state)
{
    (void)state;
    const auth_vector *v = &auth_vectors[0]; /* HELLO 1..3, version 3 */
    /* A HELLO altered on the way (1..3 became 3..3): the client's proof
     * covers what it sent, the server checks what it received. */
    qmc_auth_server s;
    memset(&s, 0, sizeof s);
    qmc_msg_hello altered = hello_of(3, 3);
    qmc_msg_auth_challenge ch;
    assert_int_equal(qmc_auth_server_challenge(&s, &altered, 3, v->server_nonce, &ch), 0);
    qmc_msg_auth_response resp;
    memcpy(resp.nonce, v->client_nonce, sizeof resp.nonce);
    memcpy(resp.mac, v->client_mac, sizeof resp.mac);
    qmc_msg_auth_ok ok;
    assert_int_equal(qmc_auth_server_verify(&s, v->key, v->key_bytes, &resp, &ok), QMC_EAUTH);

    /* A client that cannot speak version 3 cannot be challenged. */
    memset(&s, 0, sizeof s);
    qmc_msg_hello old = hello_of(1, 2);
    assert_int_equal(qmc_auth_server_challenge(&s, &old, 3, v->server_nonce, &ch),
                     QMC_ENOTSUP);
    memset(&s, 0, sizeof s);
    qmc_msg_hello future = hello_of(5, 9);
    assert_int_equal(qmc_auth_server_challenge(&s, &future, 3, v->server_nonce, &ch),
                     QMC_ENOTSUP);
    /* The highest common version is chosen. */
    memset(&s, 0, sizeof s);
    qmc_msg_hello wide = hello_of(1, 9);
    assert_int_equal(qmc_auth_server_challenge(&s, &wide, 3, v->server_nonce, &ch), 0);
    assert_int_equal(ch.version, 3);
    assert_int_equal(qmc_auth_server_challenge(&s, &wide, 3, v->server_nonce, &ch),
                     QMC_EPROTO); /* not idle any more */

    /* The client refuses a challenge for a version it did not offer. */
    qmc_auth_client c;
    memset(&c, 0, sizeof c);
    qmc_msg_auth_challenge odd = {.version = 4};
    memcpy(odd.nonce, v->server_nonce, sizeof odd.nonce);
    assert_int_equal(qmc_auth_client_respond(&c, 1, 3, &odd, v->client_nonce, v->key,
                                             v->key_bytes, &resp),
                     QMC_EPROTO);
    memset(&c, 0, sizeof c);
    assert_int_equal(qmc_auth_client_check(&c, &ok), QMC_EPROTO); /* nothing sent */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_transcript_and_mac_vectors),
        cmocka_unit_test(test_mac_refuses_bad_input),
        cmocka_unit_test(test_key_file_rule),
        cmocka_unit_test(test_handshake_vectors),
        cmocka_unit_test(test_wrong_key),
        cmocka_unit_test(test_every_flipped_bit_fails),
        cmocka_unit_test(test_replay_and_reflection),
        cmocka_unit_test(test_versions_are_bound),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
