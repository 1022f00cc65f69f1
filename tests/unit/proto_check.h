/*
 * proto_check.h - the checks the codec's tests (test_proto.c,
 * test_proto_session.c, test_proto_part.c) make of every message they
 * build: it encodes (and encoded_size agrees), a field the decoder must
 * refuse, mutated in its bytes, is QMC_EPROTO, a field the encoder must
 * refuse is QMC_EINVAL; and the reader of their hex vector files.
 *
 * Must not: build messages (the tests and their builders do).
 */
#ifndef QMC_TEST_PROTO_CHECK_H
#define QMC_TEST_PROTO_CHECK_H

#include <stddef.h>
#include <stdint.h>

#include "qmc/proto.h"

/* Room for the largest frame any test builds. */
#define PROTO_CHECK_FRAME_BYTES (QMC_PROTO_HEADER_BYTES + QMC_PROTO_CHUNK_BYTES + 64)

/* Bytes written over a valid frame's payload that the decoder must refuse. */
typedef struct proto_mutation {
    qmc_msg_type type;
    uint32_t off;     /* in the payload (PROTOCOL.md's offsets) */
    int width;        /* 1, 2, 4 or 8 bytes, little-endian */
    uint64_t value;
    const char *what;
} proto_mutation;

/* Encodes m into buf[0 .. cap): its length; fails the test on an error
 * or an encoded_size that disagrees. */
size_t proto_encode_into(const qmc_msg *m, uint8_t *buf, size_t cap);

/* m (built valid, of mu's type) encodes into buf and decodes; with mu's
 * bytes written over its payload it is QMC_EPROTO, the message cleared. */
void proto_check_mutation(const qmc_msg *m, const proto_mutation *mu, uint8_t *buf,
                          size_t cap);

/* Every mutation of the table: build(type, variant, &m) makes the valid
 * message each is written over. */
typedef void (*proto_builder)(qmc_msg_type type, int variant, qmc_msg *m);
void proto_check_mutations(const proto_mutation *mu, size_t n, proto_builder build,
                           int variant, uint8_t *buf, size_t cap);

/* Asserts that two doubles are the same bit pattern (NaN payloads, -0). */
void proto_same_f64(double a, double b);

/* Encoding m (into buf) is QMC_EINVAL, and encoded_size 0. */
void proto_check_refused(const qmc_msg *m, const char *what, uint8_t *buf, size_t cap);

/* The bytes of a vector file (the .hex files in tests/vectors/proto) into out[0 ..
 * cap): hex digits, white space and '#' comments to end of line ignored;
 * fails the test on a missing file, another character, an odd digit or
 * more than cap bytes. */
size_t proto_read_hex(const char *path, uint8_t *out, size_t cap);

#endif
