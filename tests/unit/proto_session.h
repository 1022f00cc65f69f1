/*
 * proto_session.h - the integration-session messages (protocol version 5)
 * for the codec's tests: test_proto.c builds and compares every message
 * type, and hands the SESSION_* ones to these; test_proto_session.c adds
 * their mutations, refusals and the zero-copy values prefix.
 *
 * Must not: decide what a valid message is (the codec does); only build
 * the documented example, the smallest and the largest of each.
 */
#ifndef QMC_TEST_PROTO_SESSION_H
#define QMC_TEST_PROTO_SESSION_H

#include "qmc/proto.h"

/* The variants, numbered as test_proto.c numbers them. */
enum { PROTO_SESSION_EXAMPLE, PROTO_SESSION_MINIMAL, PROTO_SESSION_MAXIMAL };

/* 1 for a SESSION_* type. */
int proto_session_is(qmc_msg_type type);

/* Builds the variant of a SESSION_* message into *m (zeroed first; the
 * type and request id set too).  Fails the test for another type. */
void proto_session_build(qmc_msg_type type, int variant, qmc_msg *m);

/* Asserts that two SESSION_* messages carry the same fields, doubles bit
 * for bit. */
void proto_session_same(const qmc_msg *a, const qmc_msg *b);

#endif
