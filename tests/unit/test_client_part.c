/*
 * test_client_part.c - libqmcclient's side of a part session's answer
 * (client/lib/session_part.c, PROTOCOL.md section 6.22): frames a hostile
 * or broken server could send in the wrong order, for the wrong session
 * or part, or past the part's blocks are refused with a reason; a good
 * sequence gives back exactly the sums sent; the buffer grows only with
 * sums that came and never past the part's count.
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <string.h>

#include "../../client/lib/client_impl.h"

static qmc_sampling_sums sums[300];

static qmc_msg head(uint64_t session, uint64_t blocks, uint32_t k, uint32_t p)
{
    qmc_msg m;
    memset(&m, 0, sizeof m);
    m.type = QMC_MSG_SESSION_PART;
    m.u.session_part.session_id = session;
    m.u.session_part.blocks = blocks;
    m.u.session_part.part_k = k;
    m.u.session_part.part_p = p;
    m.u.session_part.first = blocks * (k - 1) / p;
    m.u.session_part.count = blocks * k / p - m.u.session_part.first;
    m.u.session_part.fingerprint = 0x1234;
    return m;
}

/* Sums [first, first + n) as a SESSION_PART_SUMS (from this file's). */
static qmc_msg piece(uint64_t session, uint64_t first, uint32_t n)
{
    qmc_msg m;
    memset(&m, 0, sizeof m);
    m.type = QMC_MSG_SESSION_PART_SUMS;
    m.u.part_sums.session_id = session;
    m.u.part_sums.first = first;
    m.u.part_sums.n = n;
    m.u.part_sums.sums = sums + first;
    return m;
}

static void fill_sums(void)
{
    for (uint64_t i = 0; i < sizeof sums / sizeof sums[0]; i++) {
        memset(&sums[i], 0, sizeof sums[i]);
        sums[i].block = i;
        sums[i].count = 4096;
        sums[i].f[0] = (double)i * 0.5;
        sums[i].top[0] = (double)i;
    }
}

static int file(qmc__client_part *p, uint64_t session, qmc_msg m)
{
    char why[128] = "";
    int err = qmc__client_part_file(p, session, &m, why, sizeof why);
    if (err)
        assert_true(why[0] != '\0'); /* a refusal says why */
    return err;
}

/* The sums filled in and a fresh filer opened as part 2 of 3, where the
 * two sequence tests below start. */
static qmc__client_part part_2_of_3(void)
{
    fill_sums();
    qmc__client_part p;
    memset(&p, 0, sizeof p);
    p.part_k = 2;
    p.part_p = 3;
    return p;
}

static void test_good_sequence(void **state)
{
    (void)state;
    qmc__client_part p = part_2_of_3();
    /* 300 blocks, part 2/3: [100, 200). */
    assert_int_equal(file(&p, 7, head(7, 300, 2, 3)), 0);
    char why[128];
    assert_int_equal(qmc__client_part_end(&p, why, sizeof why), QMC_EPROTO); /* none yet */
    assert_int_equal(file(&p, 7, piece(7, 100, 30)), 0);
    assert_true(p.cap <= 100 && p.cap >= 30);
    assert_int_equal(file(&p, 7, piece(7, 130, 70)), 0);
    assert_true(p.cap == 100); /* grown to the part's count, never past it */
    assert_int_equal(qmc__client_part_end(&p, why, sizeof why), 0);
    qmc_session_part_sums out;
    assert_int_equal(qmc__client_part_get(&p, &out), 0);
    assert_true(out.fingerprint == 0x1234 && out.blocks == 300 && out.first == 100 &&
                out.count == 100);
    assert_memory_equal(out.sums, sums + 100, 100 * sizeof sums[0]);
    /* Nothing past the part. */
    assert_int_equal(file(&p, 7, piece(7, 200, 1)), QMC_EPROTO);
    qmc__client_part_free(&p);
}

static void test_refusals(void **state)
{
    (void)state;
    qmc__client_part p = part_2_of_3();
    assert_int_equal(file(&p, 7, piece(7, 100, 1)), QMC_EPROTO);  /* sums before the head */
    assert_int_equal(file(&p, 7, head(8, 300, 2, 3)), QMC_EPROTO); /* another session's */
    assert_int_equal(file(&p, 7, head(7, 300, 1, 3)), QMC_EPROTO); /* another part */
    assert_int_equal(file(&p, 7, head(7, 300, 2, 3)), 0);
    assert_int_equal(file(&p, 7, head(7, 300, 2, 3)), QMC_EPROTO); /* the head again */
    assert_int_equal(file(&p, 7, piece(7, 101, 1)), QMC_EPROTO);  /* a gap */
    assert_int_equal(file(&p, 7, piece(7, 99, 1)), QMC_EPROTO);   /* before the part */
    assert_int_equal(file(&p, 7, piece(8, 100, 1)), QMC_EPROTO);  /* another session's */
    assert_int_equal(file(&p, 7, piece(7, 100, 101)), QMC_EPROTO); /* past its count */
    assert_true(p.got == 0 && p.cap == 0); /* nothing taken, nothing allocated */
    assert_int_equal(file(&p, 7, piece(7, 100, 99)), 0);
    char why[128];
    assert_int_equal(qmc__client_part_end(&p, why, sizeof why), QMC_EPROTO); /* one short */
    qmc__client_part_free(&p);

    /* A session opened as a part whose result comes without its sums. */
    p.part_k = 1;
    p.part_p = 2;
    assert_int_equal(qmc__client_part_end(&p, why, sizeof why), QMC_EPROTO);
    qmc_session_part_sums out;
    assert_int_equal(qmc__client_part_get(&p, &out), QMC_EINVAL);
    /* A whole job's result, or a resumed session's that is no part. */
    memset(&p, 0, sizeof p);
    assert_int_equal(qmc__client_part_end(&p, why, sizeof why), 0);
}

/* A part of no blocks (p above the job's blocks): the head alone. */
static void test_empty_part(void **state)
{
    (void)state;
    qmc__client_part p;
    memset(&p, 0, sizeof p);
    assert_int_equal(file(&p, 3, head(3, 2, 1, 3)), 0);
    assert_true(p.head.count == 0);
    char why[128];
    assert_int_equal(qmc__client_part_end(&p, why, sizeof why), 0);
    assert_int_equal(file(&p, 3, piece(3, 0, 1)), QMC_EPROTO);
    qmc_session_part_sums out;
    assert_int_equal(qmc__client_part_get(&p, &out), 0);
    assert_true(out.count == 0 && out.blocks == 2);
    qmc__client_part_free(&p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_good_sequence),
        cmocka_unit_test(test_refusals),
        cmocka_unit_test(test_empty_part),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
