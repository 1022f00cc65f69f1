/*
 * proto_part.h - the part-session messages (protocol version 6,
 * SESSION_PART and SESSION_PART_SUMS) for the codec's tests: test_proto.c
 * builds and compares every message type and hands these two to here;
 * test_proto_part.c adds their mutations, refusals and the accessor.
 *
 * Must not: decide what a valid message is (the codec does); only build
 * the documented example, the smallest and the largest of each.
 */
#ifndef QMC_TEST_PROTO_PART_H
#define QMC_TEST_PROTO_PART_H

#include "qmc/proto.h"

/* The variants, numbered as test_proto.c numbers them. */
enum { PROTO_PART_EXAMPLE, PROTO_PART_MINIMAL, PROTO_PART_MAXIMAL };

/* 1 for SESSION_PART and SESSION_PART_SUMS. */
int proto_part_is(qmc_msg_type type);

/* Builds the variant into *m (zeroed first; type and request id set too);
 * the sums a SESSION_PART_SUMS points at are this file's. */
void proto_part_build(qmc_msg_type type, int variant, qmc_msg *m);

/* Asserts that two part messages carry the same fields, doubles bit for
 * bit (the sums read through qmc_proto_part_sums_at). */
void proto_part_same(const qmc_msg *a, const qmc_msg *b);

#endif
