/*
 * proto_check.c - the codec's per-message checks shared by its tests
 * (proto_check.h).
 *
 * Must not: build messages, or decide what is valid (the codec does).
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <ctype.h>
#include <stdio.h>
#include <string.h>

#include "proto_check.h"

size_t proto_encode_into(const qmc_msg *m, uint8_t *buf, size_t cap)
{
    int n = qmc_proto_encode(m, buf, cap);
    if (n < 0)
        fail_msg("encoding %s failed: %d", qmc_msg_type_name(m->type), n);
    assert_int_equal((size_t)n, qmc_proto_encoded_size(m));
    return (size_t)n;
}

void proto_check_mutation(const qmc_msg *m, const proto_mutation *mu, uint8_t *buf,
                          size_t cap)
{
    qmc_msg d;
    assert_int_equal(m->type, mu->type);
    size_t n = proto_encode_into(m, buf, cap);
    /* Unmutated, it decodes: the mutation is what breaks it. */
    assert_int_equal(qmc_proto_decode(buf, n, QMC_PROTO_MAX_PAYLOAD, &d), (int)n);
    assert_true(QMC_PROTO_HEADER_BYTES + mu->off + (size_t)mu->width <= n);
    uint8_t *p = buf + QMC_PROTO_HEADER_BYTES + mu->off;
    for (int k = 0; k < mu->width; k++)
        p[k] = (uint8_t)(mu->value >> (8 * k));
    int got = qmc_proto_decode(buf, n, QMC_PROTO_MAX_PAYLOAD, &d);
    if (got != QMC_EPROTO)
        fail_msg("%s: %s decoded to %d", qmc_msg_type_name(mu->type), mu->what, got);
    assert_int_equal(d.type, 0); /* the message is cleared on error */
}

void proto_check_mutations(const proto_mutation *mu, size_t n, proto_builder build,
                           int variant, uint8_t *buf, size_t cap)
{
    for (size_t i = 0; i < n; i++) {
        qmc_msg m;
        build(mu[i].type, variant, &m);
        proto_check_mutation(&m, &mu[i], buf, cap);
    }
}

void proto_same_f64(double a, double b)
{
    uint64_t x, y;
    memcpy(&x, &a, 8);
    memcpy(&y, &b, 8);
    assert_true(x == y);
}

void proto_check_refused(const qmc_msg *m, const char *what, uint8_t *buf, size_t cap)
{
    int got = qmc_proto_encode(m, buf, cap);
    if (got != QMC_EINVAL)
        fail_msg("encoding %s with %s gave %d", qmc_msg_type_name(m->type), what, got);
    assert_int_equal(qmc_proto_encoded_size(m), 0);
}

size_t proto_read_hex(const char *path, uint8_t *out, size_t cap)
{
    FILE *f = fopen(path, "r");
    if (f == NULL)
        fail_msg("cannot open %s (run the test from the top directory)", path);
    size_t n = 0;
    int c, hi = -1;
    while ((c = fgetc(f)) != EOF) {
        if (c == '#') {
            while ((c = fgetc(f)) != EOF && c != '\n')
                ;
            continue;
        }
        if (isspace(c))
            continue;
        if (!isxdigit(c))
            fail_msg("%s: unexpected character %c", path, c);
        int v = isdigit(c) ? c - '0' : tolower(c) - 'a' + 10;
        if (hi < 0) {
            hi = v;
        } else {
            assert_true(n < cap);
            out[n++] = (uint8_t)(hi << 4 | v);
            hi = -1;
        }
    }
    fclose(f);
    assert_int_equal(hi, -1);
    return n;
}
