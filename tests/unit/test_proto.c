/*
 * test_proto.c - the wire codec: every message round-trips field by field
 * (representative, minimal and maximal values), every truncation is
 * "incomplete", malformed headers, lengths, codes and reserved bytes are
 * rejected, encoders refuse what decoders would reject, and the worked
 * examples of protocol/PROTOCOL.md (tests/vectors/proto/<type>.hex) are
 * reproduced byte for byte.
 *
 * QMC_PROTO_WRITE_VECTORS=1 build/tests/test_proto rewrites the vectors
 * from the examples below instead (run from the top directory).
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <ctype.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "codec.h"
#include "proto_check.h"
#include "proto_part.h"
#include "proto_session.h"
#include "qmc/proto.h"
/* The handshake's worked example (vector 0): real nonces and MACs. */
#include "../vectors/auth_vectors.h"

#define VECTOR_DIR "tests/vectors/proto"

static const qmc_msg_type all_types[] = {
#define TYPE_ENTRY(name, code, dir) QMC_MSG_##name,
    QMC_MSG_MAP(TYPE_ENTRY)
#undef TYPE_ENTRY
};
#define N_TYPES (sizeof all_types / sizeof all_types[0])

enum { EXAMPLE, MINIMAL, MAXIMAL, N_VARIANTS };

/* ---- message builders ---------------------------------------------------- */

static qmc_str str_of(const char *s)
{
    qmc_str r = {s, (uint32_t)strlen(s)};
    return r;
}

/* Long text fields for the maximal variants: valid UTF-8 of exactly the
 * limit, multi-byte sequences included. */
static char long_text[QMC_SCENE_MAX_BYTES];
static uint8_t chunk_data[QMC_PROTO_CHUNK_BYTES];
static double big_list[QMC_PROTO_MAX_LIST];
static qmc_stat many_stats[QMC_PROTO_MAX_STATS];
static char stat_names[QMC_PROTO_MAX_STATS][QMC_PROTO_MAX_NAME];

static void fill_text(char *dst, size_t n)
{
    /* "é" (2 bytes) and "€" (3 bytes) between ASCII, ASCII to finish. */
    static const char pattern[] = "ab\xc3\xa9" "c\xe2\x82\xac";
    size_t i = 0;
    while (i + sizeof pattern - 1 <= n) {
        memcpy(dst + i, pattern, sizeof pattern - 1);
        i += sizeof pattern - 1;
    }
    while (i < n)
        dst[i++] = 'z';
}

static qmc_str text_of_len(size_t n)
{
    fill_text(long_text, n);
    qmc_str r = {long_text, (uint32_t)n};
    return r;
}

static void setup_static(void)
{
    for (size_t i = 0; i < sizeof chunk_data; i++)
        chunk_data[i] = (uint8_t)(i * 131u + 7u);
    static const double specials[] = {DBL_MAX, -DBL_MAX, DBL_MIN, -0.0, 4.9e-324, 1.0,
                                      -1e-300};
    for (size_t i = 0; i < QMC_PROTO_MAX_LIST; i++)
        big_list[i] = specials[i % 7] * (i % 7 == 0 || i % 7 == 1 ? 1.0 : (double)(i + 1));
    for (size_t i = 0; i < QMC_PROTO_MAX_STATS; i++) {
        memset(stat_names[i], 'a' + (int)(i % 26), QMC_PROTO_MAX_NAME);
        many_stats[i].name.ptr = stat_names[i];
        many_stats[i].name.len = QMC_PROTO_MAX_NAME;
        many_stats[i].value = UINT64_MAX - i;
    }
}

static const qmc_stat example_stats[] = {
    {{"connections", 11}, 1}, {{"jobs_running", 12}, 1}, {{"points_sent", 11}, 2}};
static const double example_a[] = {1.5, 2.0, 2.5};
static const double example_u[] = {0.5, 0.5, 0.5};
static const uint8_t example_points[32] = {
    /* (0, 0) and (0.5, 0.5) as binary64 LE: Sobol points 0 and 1 */
    0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
    0, 0, 0, 0, 0, 0, 0xe0, 0x3f, 0, 0, 0, 0, 0, 0, 0xe0, 0x3f};

static void build_integrate(qmc_msg *m, int variant)
{
    qmc_msg_integrate *g = &m->u.integrate;
    qmc_job_spec_init(&g->spec);
    qmc_job_spec *s = &g->spec;
    if (variant == EXAMPLE) {
        strcpy(s->integrand, "genz-gaussian");
        s->dims = 3;
        g->a.values = example_a;
        g->a.count = 3;
        g->u.values = example_u;
        g->u.count = 3;
        s->integrate.method = QMC_METHOD_RQMC;
        qmc_sampling_spec_init(&s->integrate.sampling, QMC_SAMPLER_RQMC);
        s->integrate.sampling.seed = 7;
        s->integrate.n_given = 1;
        g->progress_ms = 500;
    } else if (variant == MINIMAL) {
        memset(g, 0, sizeof *g);
        s->strategy = QMC_SCENE_UNIFORM;
        s->difficulty = -1;
    } else {
        memset(s->integrand, 'i', QMC_JOB_NAME_BYTES - 1);
        memset(s->control, 'c', QMC_JOB_NAME_BYTES - 1);
        s->dims = UINT32_MAX;
        g->a.values = big_list;
        g->a.count = QMC_PROTO_MAX_LIST;
        g->u.values = big_list;
        g->u.count = QMC_PROTO_MAX_LIST;
        g->scene = text_of_len(QMC_SCENE_MAX_BYTES);
        s->difficulty = QMC_DIFFICULTY_FIXED;
        s->strategy = QMC_SCENE_MIS_MAX;
        s->beta = -DBL_MAX;
        s->samples_brdf = s->samples_light = UINT32_MAX;
        qmc_integrate_spec *in = &s->integrate;
        in->method = QMC_METHOD_CUBATURE;
        in->sampling.sampler = QMC_SAMPLER_RQMC;
        in->sampling.seq = QMC_SEQ_LHS;
        in->sampling.scramble = QMC_SCRAMBLE_FAST_OWEN; /* the largest code */
        in->sampling.seq_flags = QMC_SEQ_SHUFFLE;
        in->sampling.seed = UINT64_MAX;
        in->sampling.n = UINT64_MAX;
        in->sampling.reps = UINT32_MAX;
        in->sampling.split_net = 1;
        in->sampling.confidence = DBL_MIN;
        in->n_given = 1;
        in->n_axis = UINT32_MAX;
        in->tol_abs = DBL_MAX;
        in->tol_rel = 4.9e-324;
        in->max_evals = in->max_memory = UINT64_MAX;
        g->progress_ms = UINT32_MAX;
    }
}

static void build_result(qmc_msg *m, int variant)
{
    qmc_msg_job_result *r = &m->u.result;
    if (variant == MINIMAL)
        return; /* all zeros: a valid, empty result */
    if (variant == EXAMPLE) {
        r->job_id = 17;
        r->res = (qmc_result){.estimate = 0.3126145012,
                              .error = 1.2e-7,
                              .ci_low = 0.31261424,
                              .ci_high = 0.31261476,
                              .error_kind = QMC_ERROR_STDERR,
                              .n = 4096,
                              .evals = 65536,
                              .dims = 3,
                              .flags = 0,
                              .nonfinite = 0,
                              .abs_integral = 0.3126145012};
        r->method_used = QMC_METHOD_RQMC;
        qmc_sampling_spec_init(&r->sampling, QMC_SAMPLER_RQMC);
        r->sampling.seed = 7;
        r->seconds = 0.0125;
        r->reference_kind = 1;
        r->reference = 0.3126145;
        r->detail = str_of("sobol owen, 16 x 4096 points");
        r->auto_reason = str_of("");
        r->has_known_abs = 1; /* version 6: a positive f's, its exact value */
        r->known_abs = 0.3126145;
        return;
    }
    r->job_id = UINT64_MAX;
    r->res.estimate = NAN;
    r->res.error = INFINITY;
    r->res.ci_low = -INFINITY;
    r->res.ci_high = -0.0;
    r->res.error_kind = QMC_ERROR_ESTIMATE;
    r->res.n = r->res.evals = r->res.nonfinite = UINT64_MAX;
    r->res.dims = UINT32_MAX;
    r->res.flags = 0 /* every defined flag */
#define ALL_FLAGS(name, bit, key, text) | QMC_FLAG_##name
        QMC_FLAG_MAP(ALL_FLAGS);
#undef ALL_FLAGS
    r->res.abs_integral = DBL_MAX;
    r->cv.used = 1;
    r->cv.beta = -NAN;
    r->cv.variance_ratio = 4.9e-324;
    r->method_used = QMC_METHOD_CUBATURE;
    r->sampling.sampler = QMC_SAMPLER_RQMC;
    r->sampling.seq = QMC_SEQ_LHS;
    r->sampling.scramble = QMC_SCRAMBLE_FAST_OWEN;
    r->sampling.seq_flags = QMC_SEQ_SHUFFLE;
    r->sampling.seed = r->sampling.n = UINT64_MAX;
    r->sampling.reps = UINT32_MAX;
    r->sampling.split_net = 1;
    r->sampling.confidence = NAN;
    r->seconds = DBL_MAX;
    r->reference_kind = 2;
    r->reference = -DBL_MIN;
    r->detail = text_of_len(QMC_PROTO_MAX_MESSAGE);
    r->auto_reason = text_of_len(QMC_PROTO_MAX_MESSAGE);
    r->has_known_abs = 1;
    r->known_abs = DBL_MAX;
}

/* Builds a message of each type: the documented example, the smallest
 * payload, or the largest (every field at its limit). */
static void build(qmc_msg_type type, int variant, qmc_msg *m)
{
    memset(m, 0, sizeof *m);
    m->type = type;
    m->request_id = variant == MAXIMAL ? UINT64_MAX : variant == MINIMAL ? 0 : 1;
    int ex = variant == EXAMPLE, mx = variant == MAXIMAL;
    switch (type) {
    case QMC_MSG_HELLO:
        m->u.hello.version_min = mx ? UINT16_MAX : 1;
        m->u.hello.version_max = mx ? UINT16_MAX : 1;
        m->u.hello.max_frame = mx ? UINT32_MAX : ex ? QMC_PROTO_MAX_PAYLOAD : 0;
        m->u.hello.client = mx ? text_of_len(QMC_PROTO_MAX_NAME)
                               : str_of(ex ? "qmc-client/1" : "");
        break;
    case QMC_MSG_HELLO_OK:
        m->u.hello_ok.version = mx ? UINT16_MAX : 1;
        m->u.hello_ok.max_frame = mx ? UINT32_MAX : ex ? QMC_PROTO_MAX_PAYLOAD : 0;
        m->u.hello_ok.max_inflight = mx ? UINT32_MAX : ex ? 64 : 0;
        m->u.hello_ok.max_points = mx ? UINT64_MAX : ex ? QMC_SEQ_MAX_INDEX : 0;
        m->u.hello_ok.sobol_table_hash = mx ? UINT64_MAX : ex ? qmc_sobol_table_hash() : 0;
        m->u.hello_ok.server = mx ? text_of_len(QMC_PROTO_MAX_NAME) : str_of(ex ? "qmcd" : "");
        m->u.hello_ok.engine = mx ? text_of_len(QMC_PROTO_MAX_NAME)
                                  : str_of(ex ? "qmc 0.1" : "");
        break;
    case QMC_MSG_PING:
    case QMC_MSG_PONG:
        m->request_id = ex ? 2 : m->request_id;
        if (mx) {
            /* opaque bytes: NULs and invalid UTF-8 allowed */
            m->u.ping.data.ptr = (const char *)chunk_data;
            m->u.ping.data.len = QMC_PROTO_MAX_PING;
        } else {
            m->u.ping.data = str_of(ex ? "t=1234" : "");
        }
        break;
    case QMC_MSG_POINTS:
        m->request_id = ex ? 3 : m->request_id;
        m->u.points.seq.kind = mx ? QMC_SEQ_LHS : QMC_SEQ_SOBOL;
        m->u.points.seq.dims = mx ? UINT32_MAX : ex ? 2 : 0;
        m->u.points.seq.scramble = mx ? QMC_SCRAMBLE_FAST_OWEN : QMC_SCRAMBLE_NONE;
        m->u.points.seq.flags = mx ? QMC_SEQ_SHUFFLE : 0;
        m->u.points.seq.seed = mx ? UINT64_MAX : 0;
        m->u.points.seq.set_size = mx ? UINT64_MAX : 0;
        m->u.points.format = mx ? QMC_FORMAT_U32 : QMC_FORMAT_F64;
        m->u.points.transport = mx ? QMC_TRANSPORT_SHM : QMC_TRANSPORT_INLINE;
        m->u.points.start = mx ? UINT64_MAX : 0;
        m->u.points.count = mx ? UINT64_MAX : ex ? 2 : 0;
        break;
    case QMC_MSG_POINTS_CHUNK:
        m->request_id = ex ? 3 : m->request_id;
        m->u.chunk.first = mx ? UINT64_MAX : 0;
        m->u.chunk.points = mx ? 1 : ex ? 2 : 1;
        m->u.chunk.data = ex ? example_points : chunk_data;
        m->u.chunk.data_len = mx ? QMC_PROTO_CHUNK_BYTES : ex ? 32 : 4;
        break;
    case QMC_MSG_END:
        m->request_id = ex ? 3 : m->request_id;
        m->u.end.points = mx ? UINT64_MAX : ex ? 2 : 0;
        m->u.end.bytes = mx ? UINT64_MAX : ex ? 32 : 0;
        break;
    case QMC_MSG_INTEGRATE:
        m->request_id = ex ? 4 : m->request_id;
        build_integrate(m, variant);
        break;
    case QMC_MSG_JOB_ACCEPTED:
    case QMC_MSG_JOB_STATUS:
    case QMC_MSG_JOB_CANCEL:
        m->request_id = ex ? (type == QMC_MSG_JOB_ACCEPTED ? 4 : type == QMC_MSG_JOB_STATUS ? 5 : 6)
                           : m->request_id;
        m->u.job.job_id = mx ? UINT64_MAX : ex ? 17 : 0;
        break;
    case QMC_MSG_JOB_PROGRESS:
        m->request_id = ex ? 4 : m->request_id;
        m->u.progress.job_id = mx ? UINT64_MAX : ex ? 17 : 0;
        m->u.progress.evals = mx ? UINT64_MAX : ex ? 32768 : 0;
        m->u.progress.seconds = mx ? NAN : ex ? 0.25 : 0;
        break;
    case QMC_MSG_JOB_RESULT:
    case QMC_MSG_SESSION_RESULT: /* the same layout: session 5, request 11 */
        m->request_id = ex ? (type == QMC_MSG_JOB_RESULT ? 4 : 11) : m->request_id;
        build_result(m, variant);
        if (ex && type == QMC_MSG_SESSION_RESULT) {
            m->u.result.job_id = 5;
            m->u.result.has_known_abs = 0; /* a session's f: nothing known */
            m->u.result.known_abs = 0;
        }
        break;
    case QMC_MSG_JOB_STATE:
        m->request_id = ex ? 5 : m->request_id;
        m->u.state.job_id = mx ? UINT64_MAX : ex ? 17 : 0;
        m->u.state.state = mx ? QMC_JOB_UNKNOWN : ex ? QMC_JOB_RUNNING : QMC_JOB_QUEUED;
        m->u.state.evals = mx ? UINT64_MAX : ex ? 32768 : 0;
        m->u.state.seconds = mx ? INFINITY : ex ? 0.25 : 0;
        break;
    case QMC_MSG_STATS:
        m->request_id = ex ? 7 : m->request_id;
        break;
    case QMC_MSG_STATS_REPLY:
        m->request_id = ex ? 7 : m->request_id;
        m->u.stats.count = mx ? QMC_PROTO_MAX_STATS : ex ? 3 : 0;
        m->u.stats.entries = mx ? many_stats : ex ? example_stats : NULL;
        break;
    case QMC_MSG_ERROR:
        m->request_id = ex ? 4 : m->request_id;
        m->u.error.code = mx ? INT32_MIN : ex ? -125 /* -ECANCELED, Linux */ : -1;
        m->u.error.message = mx ? text_of_len(QMC_PROTO_MAX_MESSAGE)
                                : str_of(ex ? "job 17 cancelled" : "");
        break;
    case QMC_MSG_SHM_ATTACH:
    case QMC_MSG_SHM_OK:
        m->request_id = ex ? 8 : m->request_id;
        m->u.shm.slots = mx ? QMC_PROTO_SHM_MAX_SLOTS : ex ? 8 : QMC_PROTO_SHM_MIN_SLOTS;
        m->u.shm.slot_bytes = mx   ? QMC_PROTO_SHM_MAX_SLOT_BYTES
                              : ex ? QMC_PROTO_CHUNK_BYTES
                                   : QMC_PROTO_SHM_MIN_SLOT_BYTES;
        break;
    case QMC_MSG_POINTS_SHM_CHUNK:
        m->request_id = ex ? 9 : m->request_id;
        m->u.shm_chunk.first = mx ? UINT64_MAX : ex ? 4096 : 0;
        m->u.shm_chunk.points = mx ? 1 : ex ? 4096 : 1;
        m->u.shm_chunk.data_len = mx   ? QMC_PROTO_SHM_MAX_SLOT_BYTES
                                  : ex ? 4096 * 32 * 8
                                       : 4;
        m->u.shm_chunk.slot = mx ? QMC_PROTO_SHM_MAX_SLOTS - 1 : ex ? 1 : 0;
        break;
    case QMC_MSG_SHM_RELEASE:
        m->request_id = ex ? 0 : m->request_id;
        m->u.release.slots = mx ? QMC_PROTO_SHM_MAX_SLOTS : ex ? 2 : 1;
        break;
    case QMC_MSG_AUTH_CHALLENGE:
        m->request_id = ex ? 1 : m->request_id;
        m->u.challenge.version = mx ? UINT16_MAX : QMC_PROTO_VERSION_AUTH;
        for (unsigned i = 0; i < QMC_PROTO_AUTH_NONCE_BYTES; i++)
            m->u.challenge.nonce[i] = mx ? 0xff : ex ? auth_vectors[0].server_nonce[i] : 0;
        break;
    case QMC_MSG_AUTH_RESPONSE:
        m->request_id = ex ? 1 : m->request_id;
        for (unsigned i = 0; i < QMC_PROTO_AUTH_NONCE_BYTES; i++)
            m->u.response.nonce[i] = mx ? 0xff : ex ? auth_vectors[0].client_nonce[i] : 0;
        for (unsigned i = 0; i < QMC_PROTO_AUTH_MAC_BYTES; i++)
            m->u.response.mac[i] = mx ? 0xff : ex ? auth_vectors[0].client_mac[i] : 0;
        break;
    case QMC_MSG_AUTH_OK:
        m->request_id = ex ? 1 : m->request_id;
        for (unsigned i = 0; i < QMC_PROTO_AUTH_MAC_BYTES; i++)
            m->u.auth_ok.mac[i] = mx ? 0xff : ex ? auth_vectors[0].server_mac[i] : 0;
        break;
    case QMC_MSG_PIXELS: {
        /* The example: a 16 x 8 tile at (64, 32) of a 1920 x 1080 zsobol
         * image at 16 spp, samples 4..11, 5 values each, as f32.  The
         * minimal variant is all zeros but the codes, which the codec
         * takes (zero sizes are the daemon's to refuse). */
        qmc_msg_pixels *p = &m->u.pixels;
        m->request_id = ex ? 10 : m->request_id;
        p->spec.sampler = mx ? QMC_PIXEL_SOBOL : QMC_PIXEL_ZSOBOL;
        p->format = mx ? QMC_FORMAT_U32 : ex ? QMC_FORMAT_F32 : QMC_FORMAT_F64;
        p->transport = mx ? QMC_TRANSPORT_SHM : QMC_TRANSPORT_INLINE;
        p->spec.width = mx ? UINT32_MAX : ex ? 1920 : 0;
        p->spec.height = mx ? UINT32_MAX : ex ? 1080 : 0;
        p->spec.seed = mx ? UINT32_MAX : ex ? 7 : 0;
        p->spec.frame = mx ? UINT32_MAX : ex ? 2 : 0;
        p->spec.dims = mx ? UINT32_MAX : ex ? 5 : 0;
        p->spec.spp = mx ? UINT64_MAX : ex ? 16 : 0;
        p->tile.x = mx ? UINT32_MAX : ex ? 64 : 0;
        p->tile.y = mx ? UINT32_MAX : ex ? 32 : 0;
        p->tile.width = mx ? UINT32_MAX : ex ? 16 : 0;
        p->tile.height = mx ? UINT32_MAX : ex ? 8 : 0;
        p->tile.sample_start = mx ? UINT64_MAX : ex ? 4 : 0;
        p->tile.sample_count = mx ? UINT64_MAX : ex ? 8 : 0;
        break;
    }
    case QMC_MSG_SESSION_OPEN:
    case QMC_MSG_SESSION_OPENED:
    case QMC_MSG_SESSION_BATCH:
    case QMC_MSG_SESSION_VALUES:
    case QMC_MSG_SESSION_REPORT:
    case QMC_MSG_SESSION_RESUME:
    case QMC_MSG_SESSION_CLOSE:
        proto_session_build(type, variant, m); /* proto_session.c */
        break;
    case QMC_MSG_SESSION_PART:
    case QMC_MSG_SESSION_PART_SUMS:
        proto_part_build(type, variant, m); /* proto_part.c */
        break;
    }
}

/* ---- field-by-field comparison ------------------------------------------- */


static void same_str(qmc_str a, qmc_str b)
{
    assert_int_equal(a.len, b.len);
    if (a.len)
        assert_memory_equal(a.ptr, b.ptr, a.len);
}

static void same_list(const qmc_f64s *a, const qmc_f64s *b)
{
    assert_int_equal(a->count, b->count);
    for (uint32_t i = 0; i < a->count; i++)
        proto_same_f64(qmc_proto_f64_at(a, i), qmc_proto_f64_at(b, i));
}

static void same_sampling(const qmc_sampling_spec *a, const qmc_sampling_spec *b)
{
    assert_int_equal(a->sampler, b->sampler);
    assert_int_equal(a->seq, b->seq);
    assert_int_equal(a->scramble, b->scramble);
    assert_int_equal(a->seq_flags, b->seq_flags);
    assert_true(a->seed == b->seed);
    assert_true(a->n == b->n);
    assert_int_equal(a->reps, b->reps);
    proto_same_f64(a->confidence, b->confidence);
}

static void same_integrate(const qmc_msg_integrate *a, const qmc_msg_integrate *b)
{
    const qmc_job_spec *s = &a->spec, *t = &b->spec;
    assert_string_equal(s->integrand, t->integrand);
    assert_string_equal(s->control, t->control);
    assert_int_equal(s->dims, t->dims);
    assert_int_equal(s->difficulty, t->difficulty);
    assert_int_equal(s->strategy, t->strategy);
    proto_same_f64(s->beta, t->beta);
    assert_int_equal(s->samples_brdf, t->samples_brdf);
    assert_int_equal(s->samples_light, t->samples_light);
    assert_int_equal(s->integrate.method, t->integrate.method);
    same_sampling(&s->integrate.sampling, &t->integrate.sampling);
    assert_int_equal(s->integrate.n_given != 0, t->integrate.n_given != 0);
    assert_int_equal(s->integrate.n_axis, t->integrate.n_axis);
    proto_same_f64(s->integrate.tol_abs, t->integrate.tol_abs);
    proto_same_f64(s->integrate.tol_rel, t->integrate.tol_rel);
    assert_true(s->integrate.max_evals == t->integrate.max_evals);
    assert_true(s->integrate.max_memory == t->integrate.max_memory);
    same_list(&a->a, &b->a);
    same_list(&a->u, &b->u);
    same_str(a->scene, b->scene);
    assert_int_equal(a->progress_ms, b->progress_ms);
    /* The decoded spec's own views are left for the daemon to set. */
    assert_null(t->a);
    assert_null(t->u);
    assert_null(t->scene_text);
}

static void same_result(const qmc_msg_job_result *a, const qmc_msg_job_result *b)
{
    assert_true(a->job_id == b->job_id);
    proto_same_f64(a->res.estimate, b->res.estimate);
    proto_same_f64(a->res.error, b->res.error);
    proto_same_f64(a->res.ci_low, b->res.ci_low);
    proto_same_f64(a->res.ci_high, b->res.ci_high);
    assert_int_equal(a->res.error_kind, b->res.error_kind);
    assert_true(a->res.n == b->res.n);
    assert_true(a->res.evals == b->res.evals);
    assert_int_equal(a->res.dims, b->res.dims);
    assert_int_equal(a->res.flags, b->res.flags);
    assert_true(a->res.nonfinite == b->res.nonfinite);
    proto_same_f64(a->res.abs_integral, b->res.abs_integral);
    assert_int_equal(a->cv.used != 0, b->cv.used != 0);
    proto_same_f64(a->cv.beta, b->cv.beta);
    proto_same_f64(a->cv.variance_ratio, b->cv.variance_ratio);
    assert_int_equal(a->method_used, b->method_used);
    same_sampling(&a->sampling, &b->sampling);
    proto_same_f64(a->seconds, b->seconds);
    assert_int_equal(a->reference_kind, b->reference_kind);
    proto_same_f64(a->reference, b->reference);
    same_str(a->detail, b->detail);
    same_str(a->auto_reason, b->auto_reason);
    assert_int_equal(a->has_known_abs, b->has_known_abs);
    proto_same_f64(a->known_abs, b->known_abs);
}

static void same_msg(const qmc_msg *a, const qmc_msg *b)
{
    assert_int_equal(a->type, b->type);
    assert_true(a->request_id == b->request_id);
    switch (a->type) {
    case QMC_MSG_HELLO:
        assert_int_equal(a->u.hello.version_min, b->u.hello.version_min);
        assert_int_equal(a->u.hello.version_max, b->u.hello.version_max);
        assert_int_equal(a->u.hello.max_frame, b->u.hello.max_frame);
        same_str(a->u.hello.client, b->u.hello.client);
        break;
    case QMC_MSG_HELLO_OK:
        assert_int_equal(a->u.hello_ok.version, b->u.hello_ok.version);
        assert_int_equal(a->u.hello_ok.max_frame, b->u.hello_ok.max_frame);
        assert_int_equal(a->u.hello_ok.max_inflight, b->u.hello_ok.max_inflight);
        assert_true(a->u.hello_ok.max_points == b->u.hello_ok.max_points);
        assert_true(a->u.hello_ok.sobol_table_hash == b->u.hello_ok.sobol_table_hash);
        same_str(a->u.hello_ok.server, b->u.hello_ok.server);
        same_str(a->u.hello_ok.engine, b->u.hello_ok.engine);
        break;
    case QMC_MSG_PING:
    case QMC_MSG_PONG:
        same_str(a->u.ping.data, b->u.ping.data);
        break;
    case QMC_MSG_POINTS:
        assert_int_equal(a->u.points.seq.kind, b->u.points.seq.kind);
        assert_int_equal(a->u.points.seq.dims, b->u.points.seq.dims);
        assert_int_equal(a->u.points.seq.scramble, b->u.points.seq.scramble);
        assert_int_equal(a->u.points.seq.flags, b->u.points.seq.flags);
        assert_true(a->u.points.seq.seed == b->u.points.seq.seed);
        assert_true(a->u.points.seq.set_size == b->u.points.seq.set_size);
        assert_int_equal(a->u.points.format, b->u.points.format);
        assert_int_equal(a->u.points.transport, b->u.points.transport);
        assert_true(a->u.points.start == b->u.points.start);
        assert_true(a->u.points.count == b->u.points.count);
        break;
    case QMC_MSG_POINTS_CHUNK:
        assert_true(a->u.chunk.first == b->u.chunk.first);
        assert_int_equal(a->u.chunk.points, b->u.chunk.points);
        assert_int_equal(a->u.chunk.data_len, b->u.chunk.data_len);
        assert_memory_equal(a->u.chunk.data, b->u.chunk.data, a->u.chunk.data_len);
        break;
    case QMC_MSG_END:
        assert_true(a->u.end.points == b->u.end.points);
        assert_true(a->u.end.bytes == b->u.end.bytes);
        break;
    case QMC_MSG_INTEGRATE:
        same_integrate(&a->u.integrate, &b->u.integrate);
        break;
    case QMC_MSG_JOB_ACCEPTED:
    case QMC_MSG_JOB_STATUS:
    case QMC_MSG_JOB_CANCEL:
        assert_true(a->u.job.job_id == b->u.job.job_id);
        break;
    case QMC_MSG_JOB_PROGRESS:
        assert_true(a->u.progress.job_id == b->u.progress.job_id);
        assert_true(a->u.progress.evals == b->u.progress.evals);
        proto_same_f64(a->u.progress.seconds, b->u.progress.seconds);
        break;
    case QMC_MSG_JOB_RESULT:
    case QMC_MSG_SESSION_RESULT:
        same_result(&a->u.result, &b->u.result);
        break;
    case QMC_MSG_JOB_STATE:
        assert_true(a->u.state.job_id == b->u.state.job_id);
        assert_int_equal(a->u.state.state, b->u.state.state);
        assert_true(a->u.state.evals == b->u.state.evals);
        proto_same_f64(a->u.state.seconds, b->u.state.seconds);
        break;
    case QMC_MSG_STATS:
        break;
    case QMC_MSG_STATS_REPLY:
        assert_int_equal(a->u.stats.count, b->u.stats.count);
        for (uint32_t i = 0; i < a->u.stats.count; i++) {
            qmc_stat x = qmc_proto_stat_at(&a->u.stats, i);
            qmc_stat y = qmc_proto_stat_at(&b->u.stats, i);
            same_str(x.name, y.name);
            assert_true(x.value == y.value);
        }
        break;
    case QMC_MSG_ERROR:
        assert_int_equal(a->u.error.code, b->u.error.code);
        same_str(a->u.error.message, b->u.error.message);
        break;
    case QMC_MSG_SHM_ATTACH:
    case QMC_MSG_SHM_OK:
        assert_int_equal(a->u.shm.slots, b->u.shm.slots);
        assert_int_equal(a->u.shm.slot_bytes, b->u.shm.slot_bytes);
        break;
    case QMC_MSG_POINTS_SHM_CHUNK:
        assert_true(a->u.shm_chunk.first == b->u.shm_chunk.first);
        assert_int_equal(a->u.shm_chunk.points, b->u.shm_chunk.points);
        assert_int_equal(a->u.shm_chunk.data_len, b->u.shm_chunk.data_len);
        assert_int_equal(a->u.shm_chunk.slot, b->u.shm_chunk.slot);
        break;
    case QMC_MSG_SHM_RELEASE:
        assert_int_equal(a->u.release.slots, b->u.release.slots);
        break;
    case QMC_MSG_AUTH_CHALLENGE:
        assert_int_equal(a->u.challenge.version, b->u.challenge.version);
        assert_memory_equal(a->u.challenge.nonce, b->u.challenge.nonce,
                            QMC_PROTO_AUTH_NONCE_BYTES);
        break;
    case QMC_MSG_AUTH_RESPONSE:
        assert_memory_equal(a->u.response.nonce, b->u.response.nonce,
                            QMC_PROTO_AUTH_NONCE_BYTES);
        assert_memory_equal(a->u.response.mac, b->u.response.mac, QMC_PROTO_AUTH_MAC_BYTES);
        break;
    case QMC_MSG_AUTH_OK:
        assert_memory_equal(a->u.auth_ok.mac, b->u.auth_ok.mac, QMC_PROTO_AUTH_MAC_BYTES);
        break;
    case QMC_MSG_PIXELS: {
        const qmc_msg_pixels *p = &a->u.pixels, *q = &b->u.pixels;
        assert_int_equal(p->spec.sampler, q->spec.sampler);
        assert_int_equal(p->format, q->format);
        assert_int_equal(p->transport, q->transport);
        assert_int_equal(p->spec.width, q->spec.width);
        assert_int_equal(p->spec.height, q->spec.height);
        assert_int_equal(p->spec.seed, q->spec.seed);
        assert_int_equal(p->spec.frame, q->spec.frame);
        assert_int_equal(p->spec.dims, q->spec.dims);
        assert_true(p->spec.spp == q->spec.spp);
        assert_int_equal(p->tile.x, q->tile.x);
        assert_int_equal(p->tile.y, q->tile.y);
        assert_int_equal(p->tile.width, q->tile.width);
        assert_int_equal(p->tile.height, q->tile.height);
        assert_true(p->tile.sample_start == q->tile.sample_start);
        assert_true(p->tile.sample_count == q->tile.sample_count);
        break;
    }
    case QMC_MSG_SESSION_OPEN:
    case QMC_MSG_SESSION_OPENED:
    case QMC_MSG_SESSION_BATCH:
    case QMC_MSG_SESSION_VALUES:
    case QMC_MSG_SESSION_REPORT:
    case QMC_MSG_SESSION_RESUME:
    case QMC_MSG_SESSION_CLOSE:
        proto_session_same(a, b);
        break;
    case QMC_MSG_SESSION_PART:
    case QMC_MSG_SESSION_PART_SUMS:
        proto_part_same(a, b);
        break;
    }
}

/* ---- helpers --------------------------------------------------------------- */

#define BIG PROTO_CHECK_FRAME_BYTES
static uint8_t frame[BIG];
static uint8_t frame2[BIG];

/* Encodes m into frame; returns the length (asserting encoded_size agrees). */
static size_t encode_ok(const qmc_msg *m)
{
    return proto_encode_into(m, frame, sizeof frame);
}

static int decode(const uint8_t *buf, size_t len, qmc_msg *out)
{
    return qmc_proto_decode(buf, len, QMC_PROTO_MAX_PAYLOAD, out);
}

static void set_payload_len(uint8_t *f, uint32_t len)
{
    qmc__store_u32(f + 16, len);
}

/* ---- round trips, truncation, layout bounds --------------------------------- */

static void test_roundtrip(void **state)
{
    (void)state;
    for (size_t t = 0; t < N_TYPES; t++)
        for (int v = 0; v < N_VARIANTS; v++) {
            qmc_msg m, d;
            build(all_types[t], v, &m);
            size_t n = encode_ok(&m);
            assert_int_equal(decode(frame, n, &d), (int)n);
            same_msg(&m, &d);
            /* The decoded message encodes to the same bytes. */
            assert_int_equal(qmc_proto_encode(&d, frame2, sizeof frame2), (int)n);
            assert_memory_equal(frame, frame2, n);
            /* The minimal and maximal variants sit exactly on the table's
             * payload bounds - which span every version: a result's
             * smallest frame is version 5's, without version 6's tail. */
            const qmc__layout *lay = qmc__proto_layout(all_types[t]);
            const int result = all_types[t] == QMC_MSG_JOB_RESULT ||
                               all_types[t] == QMC_MSG_SESSION_RESULT;
            if (v == MINIMAL)
                assert_int_equal(n - QMC_PROTO_HEADER_BYTES,
                                 lay->min_payload + (result ? QMC__KNOWN_ABS_BYTES : 0));
            if (v == MAXIMAL)
                assert_int_equal(n - QMC_PROTO_HEADER_BYTES, lay->max_payload);
        }
}

static void test_truncation(void **state)
{
    (void)state;
    for (size_t t = 0; t < N_TYPES; t++)
        for (int v = 0; v < N_VARIANTS; v++) {
            qmc_msg m, d;
            build(all_types[t], v, &m);
            size_t n = encode_ok(&m);
            /* Every prefix of the big frames is slow under sanitizers; the
             * header and a window at each end cover every field. */
            for (size_t k = 0; k < n; k++) {
                if (n > 4096 && k > 2048 && k < n - 2048)
                    k = n - 2048;
                d.type = QMC_MSG_ERROR;
                assert_int_equal(decode(frame, k, &d), QMC_EAGAIN);
                assert_int_equal(d.type, 0);
            }
        }
}

static void test_back_to_back(void **state)
{
    (void)state;
    qmc_msg a, b, d;
    build(QMC_MSG_INTEGRATE, EXAMPLE, &a);
    build(QMC_MSG_PING, MAXIMAL, &b);
    static uint8_t two[4096];
    int na = qmc_proto_encode(&a, two, sizeof two);
    assert_true(na > 0);
    int nb = qmc_proto_encode(&b, two + na, sizeof two - (size_t)na);
    assert_true(nb > 0);
    size_t total = (size_t)na + (size_t)nb;
    assert_int_equal(decode(two, total, &d), na);
    same_msg(&a, &d);
    assert_int_equal(decode(two + na, total - (size_t)na, &d), nb);
    same_msg(&b, &d);
    /* The second frame's partial header behind a whole first frame. */
    assert_int_equal(decode(two, (size_t)na + 3, &d), na);
    assert_int_equal(decode(two + na, 3, &d), QMC_EAGAIN);
}

/* ---- header checks -------------------------------------------------------------- */

static void test_bad_header(void **state)
{
    (void)state;
    qmc_msg m, d;
    build(QMC_MSG_PING, EXAMPLE, &m);
    size_t n = encode_ok(&m);
    static const struct {
        size_t off;
        uint8_t value;
    } bad[] = {{0, 'q'}, {3, 'X'}, {4, 0}, {4, 2}, {5, 0}, {5, 38}, {5, 255},
               {6, 1}, {7, 0x80}, {20, 1}, {23, 0x80}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        memcpy(frame2, frame, n);
        frame2[bad[i].off] = bad[i].value;
        assert_int_equal(decode(frame2, n, &d), QMC_EPROTO);
        /* Garbage is refused as soon as the offending byte arrives. */
        assert_int_equal(decode(frame2, bad[i].off + 1, &d), QMC_EPROTO);
        qmc_msg_type type = QMC_MSG_PING;
        uint64_t id = 9;
        uint32_t plen = 9;
        assert_int_equal(qmc_proto_peek(frame2, n, QMC_PROTO_MAX_PAYLOAD, &type, &id, &plen),
                         QMC_EPROTO);
        assert_int_equal(type, 0);
        assert_true(id == 0 && plen == 0);
    }
    /* A good header peeks. */
    qmc_msg_type type;
    uint64_t id;
    uint32_t plen;
    assert_int_equal(qmc_proto_peek(frame, n, 64, &type, &id, &plen), QMC_PROTO_HEADER_BYTES);
    assert_int_equal(type, QMC_MSG_PING);
    assert_true(id == 2 && plen == n - QMC_PROTO_HEADER_BYTES);
    assert_int_equal(qmc_proto_peek(frame, 23, 64, &type, &id, &plen), QMC_EAGAIN);
    assert_int_equal(qmc_proto_decode(frame, n, 64, NULL), QMC_EINVAL);
    assert_int_equal(decode(NULL, 0, &d), QMC_EAGAIN);
}

static void test_too_big(void **state)
{
    (void)state;
    qmc_msg m, d;
    build(QMC_MSG_INTEGRATE, EXAMPLE, &m);
    size_t n = encode_ok(&m);
    uint32_t plen = (uint32_t)(n - QMC_PROTO_HEADER_BYTES);
    /* payload_len above the caller's max: refused from the header alone. */
    assert_int_equal(qmc_proto_decode(frame, n, plen, &d), (int)n);
    assert_int_equal(qmc_proto_decode(frame, n, plen - 1, &d), QMC_ETOOBIG);
    assert_int_equal(qmc_proto_decode(frame, QMC_PROTO_HEADER_BYTES, plen - 1, &d),
                     QMC_ETOOBIG);
    /* ... and above QMC_PROTO_MAX_PAYLOAD whatever the caller allows. */
    set_payload_len(frame, QMC_PROTO_MAX_PAYLOAD + 1);
    assert_int_equal(qmc_proto_decode(frame, n, UINT32_MAX, &d), QMC_ETOOBIG);
    set_payload_len(frame, UINT32_MAX);
    assert_int_equal(qmc_proto_decode(frame, n, UINT32_MAX, &d), QMC_ETOOBIG);
    /* Within max but past the type's own bound: malformed. */
    build(QMC_MSG_PING, EXAMPLE, &m);
    n = encode_ok(&m);
    set_payload_len(frame, 2 + QMC_PROTO_MAX_PING + 1);
    assert_int_equal(decode(frame, QMC_PROTO_HEADER_BYTES, &d), QMC_EPROTO);
}

/* Payload one byte longer or shorter than its fields: always malformed. */
static void test_bad_lengths(void **state)
{
    (void)state;
    for (size_t t = 0; t < N_TYPES; t++)
        for (int v = 0; v < N_VARIANTS; v++) {
            qmc_msg m, d;
            build(all_types[t], v, &m);
            size_t n = encode_ok(&m);
            uint32_t plen = (uint32_t)(n - QMC_PROTO_HEADER_BYTES);
            frame[n] = 0;
            set_payload_len(frame, plen + 1);
            assert_int_equal(decode(frame, n + 1, &d), QMC_EPROTO);
            if (plen > 0) {
                set_payload_len(frame, plen - 1);
                assert_int_equal(decode(frame, n - 1, &d), QMC_EPROTO);
            }
        }
}

/* ---- payload mutations ------------------------------------------------------------ */

/* Offsets of the variable fields of the INTEGRATE example (integrand
 * "genz-gaussian", control "", a and u of 3 values each, no scene). */
enum {
    I_NAME = 104,
    I_CONTROL = I_NAME + 2 + 13,
    I_A = I_CONTROL + 2,
    I_U = I_A + 4 + 24,
    I_SCENE = I_U + 4 + 24
};

/* Where the JOB_RESULT example's version-6 tail starts. */
enum { R_TAIL = 160 + 2 + 28 + 2 };

typedef proto_mutation mutation; /* proto_check.h */

static const mutation mutations[] = {
    {QMC_MSG_HELLO, 0, 2, 0, "version_min 0"},
    {QMC_MSG_HELLO, 0, 2, 2, "version_min > version_max"},
    {QMC_MSG_HELLO, 8, 2, QMC_PROTO_MAX_NAME + 1, "client name over its limit"},
    {QMC_MSG_HELLO, 8, 2, 13, "client name past the payload"},
    {QMC_MSG_HELLO, 8, 2, 11, "client name leaves a byte over"},
    {QMC_MSG_HELLO, 10, 1, 0, "NUL in a text string"},
    {QMC_MSG_HELLO, 10, 1, 0xff, "invalid UTF-8"},
    {QMC_MSG_HELLO, 10, 1, 0xc3, "truncated UTF-8 sequence"},
    {QMC_MSG_HELLO_OK, 0, 2, 0, "version 0"},
    {QMC_MSG_HELLO_OK, 2, 1, 1, "reserved"},
    {QMC_MSG_HELLO_OK, 3, 1, 0x80, "reserved"},
    {QMC_MSG_HELLO_OK, 12, 4, 1, "reserved"},
    {QMC_MSG_HELLO_OK, 32, 2, 5, "server name past its bytes"},
    {QMC_MSG_PING, 0, 2, 7, "data past the payload"},
    {QMC_MSG_POINTS, 0, 1, 0, "seq kind 0"},
    {QMC_MSG_POINTS, 0, 1, 7, "seq kind 7"},
    {QMC_MSG_POINTS, 1, 1, 5, "scramble 5"},
    {QMC_MSG_POINTS, 2, 1, 0, "format 0"},
    {QMC_MSG_POINTS, 2, 1, 4, "format 4"},
    {QMC_MSG_POINTS, 3, 1, 2, "transport 2"},
    {QMC_MSG_POINTS, 3, 1, 0xff, "transport 255"},
    {QMC_MSG_POINTS, 8, 4, 2, "undefined seq flag"},
    {QMC_MSG_POINTS, 8, 4, 0x80000000u, "undefined seq flag"},
    {QMC_MSG_POINTS, 12, 4, 1, "reserved"},
    {QMC_MSG_POINTS_CHUNK, 8, 4, 0, "no points"},
    {QMC_MSG_POINTS_CHUNK, 8, 4, 3, "data not whole points"},
    {QMC_MSG_POINTS_CHUNK, 8, 4, 16, "points of 2 bytes"},
    {QMC_MSG_POINTS_CHUNK, 12, 4, 31, "data_len disagrees"},
    {QMC_MSG_POINTS_CHUNK, 12, 4, 36, "data_len past the payload"},
    {QMC_MSG_POINTS_CHUNK, 12, 4, QMC_PROTO_CHUNK_BYTES + 4, "data_len over the chunk cap"},
    {QMC_MSG_INTEGRATE, 0, 1, 13, "method 13"},
    {QMC_MSG_INTEGRATE, 1, 1, 0, "strategy 0"},
    {QMC_MSG_INTEGRATE, 1, 1, 7, "strategy 7"},
    {QMC_MSG_INTEGRATE, 2, 1, 2, "difficulty 2"},
    {QMC_MSG_INTEGRATE, 2, 1, 254, "difficulty 254"},
    {QMC_MSG_INTEGRATE, 3, 1, 2, "n_given 2"},
    {QMC_MSG_INTEGRATE, 40, 8, 0x7ff0000000000000u, "beta infinite"},
    {QMC_MSG_INTEGRATE, 48, 8, 0x7ff8000000000000u, "tol_abs NaN"},
    {QMC_MSG_INTEGRATE, 56, 8, 0xfff0000000000000u, "tol_rel -inf"},
    {QMC_MSG_INTEGRATE, 64, 1, 5, "sampler 5"},
    {QMC_MSG_INTEGRATE, 65, 1, 7, "seq kind 7"},
    {QMC_MSG_INTEGRATE, 66, 1, 5, "scramble 5"},
    {QMC_MSG_INTEGRATE, 67, 1, 1, "reserved"},
    {QMC_MSG_INTEGRATE, 68, 4, 2, "undefined seq flag"},
    {QMC_MSG_INTEGRATE, 88, 8, 0x7ff8000000000001u, "confidence NaN"},
    {QMC_MSG_INTEGRATE, 100, 1, 2, "split_net 2"},
    {QMC_MSG_INTEGRATE, 101, 3, 1, "reserved"},
    {QMC_MSG_INTEGRATE, I_NAME, 2, QMC_JOB_NAME_BYTES, "integrand name over its limit"},
    {QMC_MSG_INTEGRATE, I_A, 4, 4, "a count past the payload"},
    {QMC_MSG_INTEGRATE, I_A, 4, QMC_PROTO_MAX_LIST, "a count past the payload"},
    {QMC_MSG_INTEGRATE, I_A, 4, QMC_PROTO_MAX_LIST + 1, "a count over its limit"},
    {QMC_MSG_INTEGRATE, I_A, 4, UINT32_MAX, "a count over its limit"},
    {QMC_MSG_INTEGRATE, I_A + 4, 8, 0x7ff8000000000000u, "a[0] NaN"},
    {QMC_MSG_INTEGRATE, I_U + 4 + 16, 8, 0x7ff0000000000000u, "u[2] inf"},
    {QMC_MSG_INTEGRATE, I_U, 4, 2, "u count leaves bytes over"},
    {QMC_MSG_INTEGRATE, I_SCENE, 4, 1, "scene past the payload"},
    {QMC_MSG_INTEGRATE, I_SCENE, 4, QMC_SCENE_MAX_BYTES + 1, "scene over its limit"},
    {QMC_MSG_JOB_STATE, 8, 1, 0, "state 0"},
    {QMC_MSG_JOB_STATE, 8, 1, 7, "state 7"},
    {QMC_MSG_JOB_STATE, 9, 1, 1, "reserved"},
    {QMC_MSG_JOB_STATE, 15, 1, 1, "reserved"},
    {QMC_MSG_JOB_RESULT, 8, 1, 13, "method 13"},
    {QMC_MSG_JOB_RESULT, 9, 1, 3, "error kind 3"},
    {QMC_MSG_JOB_RESULT, 10, 1, 3, "reference kind 3"},
    {QMC_MSG_JOB_RESULT, 11, 1, 2, "cv.used 2"},
    {QMC_MSG_JOB_RESULT, 16, 4, 1u << 17, "undefined result flag"},
    {QMC_MSG_JOB_RESULT, 20, 4, 1, "reserved"},
    {QMC_MSG_JOB_RESULT, 120, 1, 5, "sampler 5"},
    {QMC_MSG_JOB_RESULT, 121, 1, 7, "seq kind 7"},
    {QMC_MSG_JOB_RESULT, 123, 1, 1, "reserved"},
    {QMC_MSG_JOB_RESULT, 156, 1, 2, "split_net 2"},
    {QMC_MSG_JOB_RESULT, 157, 3, 1, "reserved"},
    {QMC_MSG_JOB_RESULT, 160, 2, QMC_PROTO_MAX_MESSAGE + 1, "detail over its limit"},
    {QMC_MSG_JOB_RESULT, 160, 2, 40, "detail past the payload"},
    /* Version 6's tail, after the 28-byte detail and the empty auto_reason. */
    {QMC_MSG_JOB_RESULT, R_TAIL, 1, 2, "has_known_abs 2"},
    {QMC_MSG_JOB_RESULT, R_TAIL, 1, 0, "an unknown integral of |f| with a value"},
    {QMC_MSG_JOB_RESULT, R_TAIL + 1, 1, 1, "reserved"},
    {QMC_MSG_JOB_RESULT, R_TAIL + 7, 1, 1, "reserved"},
    {QMC_MSG_JOB_RESULT, R_TAIL + 8, 8, 0x7ff8000000000000u, "known_abs NaN"},
    {QMC_MSG_JOB_RESULT, R_TAIL + 8, 8, 0x7ff0000000000000u, "known_abs inf"},
    {QMC_MSG_JOB_RESULT, R_TAIL + 8, 8, 0xbff0000000000000u, "known_abs -1"},
    {QMC_MSG_STATS_REPLY, 0, 4, 4, "count past the payload"},
    {QMC_MSG_STATS_REPLY, 0, 4, 2, "count leaves bytes over"},
    {QMC_MSG_STATS_REPLY, 0, 4, QMC_PROTO_MAX_STATS, "count past the payload"},
    {QMC_MSG_STATS_REPLY, 0, 4, QMC_PROTO_MAX_STATS + 1, "count over its limit"},
    {QMC_MSG_STATS_REPLY, 4, 2, QMC_PROTO_MAX_NAME + 1, "name over its limit"},
    {QMC_MSG_STATS_REPLY, 4, 2, 200, "name past the payload"},
    {QMC_MSG_ERROR, 0, 4, 0, "code 0"},
    {QMC_MSG_ERROR, 0, 4, 1, "positive code"},
    {QMC_MSG_ERROR, 4, 2, QMC_PROTO_MAX_MESSAGE + 1, "message over its limit"},
    {QMC_MSG_ERROR, 4, 2, 17, "message past the payload"},
    {QMC_MSG_SHM_ATTACH, 0, 4, 0, "no slots"},
    {QMC_MSG_SHM_ATTACH, 0, 4, QMC_PROTO_SHM_MIN_SLOTS - 1, "too few slots"},
    {QMC_MSG_SHM_ATTACH, 0, 4, QMC_PROTO_SHM_MAX_SLOTS + 1, "too many slots"},
    {QMC_MSG_SHM_ATTACH, 4, 4, QMC_PROTO_SHM_MIN_SLOT_BYTES - 4096, "slots too small"},
    {QMC_MSG_SHM_ATTACH, 4, 4, QMC_PROTO_SHM_MAX_SLOT_BYTES + 4096, "slots too large"},
    {QMC_MSG_SHM_ATTACH, 4, 4, QMC_PROTO_CHUNK_BYTES + 8, "slots not whole pages"},
    {QMC_MSG_SHM_ATTACH, 8, 1, 1, "reserved"},
    {QMC_MSG_SHM_ATTACH, 15, 1, 0x80, "reserved"},
    {QMC_MSG_SHM_OK, 0, 4, 1, "too few slots"},
    {QMC_MSG_SHM_OK, 12, 4, 1, "reserved"},
    {QMC_MSG_POINTS_SHM_CHUNK, 8, 4, 0, "no points"},
    {QMC_MSG_POINTS_SHM_CHUNK, 8, 4, 4097, "data not whole points"},
    {QMC_MSG_POINTS_SHM_CHUNK, 12, 4, 4096 * 32 * 8 + 2, "data not whole points"},
    {QMC_MSG_POINTS_SHM_CHUNK, 12, 4, QMC_PROTO_SHM_MAX_SLOT_BYTES + 4096,
     "data_len over the largest slot"},
    {QMC_MSG_POINTS_SHM_CHUNK, 16, 4, QMC_PROTO_SHM_MAX_SLOTS, "slot past the largest ring"},
    {QMC_MSG_POINTS_SHM_CHUNK, 20, 4, 1, "reserved"},
    {QMC_MSG_SHM_RELEASE, 0, 4, 0, "no slots"},
    {QMC_MSG_SHM_RELEASE, 0, 4, QMC_PROTO_SHM_MAX_SLOTS + 1, "more slots than a ring has"},
    {QMC_MSG_AUTH_CHALLENGE, 0, 2, 2, "a version without the handshake"},
    {QMC_MSG_AUTH_CHALLENGE, 0, 2, 0, "version 0"},
    {QMC_MSG_AUTH_CHALLENGE, 2, 2, 1, "reserved"},
    {QMC_MSG_PIXELS, 0, 1, 0, "pixel sampler 0"},
    {QMC_MSG_PIXELS, 0, 1, 4, "pixel sampler 4"},
    {QMC_MSG_PIXELS, 1, 1, 0, "format 0"},
    {QMC_MSG_PIXELS, 1, 1, 4, "format 4"},
    {QMC_MSG_PIXELS, 2, 1, 2, "transport 2"},
    {QMC_MSG_PIXELS, 3, 1, 1, "reserved"},
};

static void test_mutations(void **state)
{
    (void)state;
    proto_check_mutations(mutations, sizeof mutations / sizeof mutations[0], build, EXAMPLE,
                          frame, sizeof frame);
}

/* ---- the encoder's refusals ---------------------------------------------------------- */

static void refuse(const qmc_msg *m, const char *what)
{
    proto_check_refused(m, what, frame, sizeof frame);
}

static void test_encoder_refuses(void **state)
{
    (void)state;
    qmc_msg m;
    static char over[QMC_PROTO_MAX_MESSAGE + 2];
    memset(over, 'x', sizeof over - 1);

    build(QMC_MSG_HELLO, EXAMPLE, &m);
    m.u.hello.client.len = QMC_PROTO_MAX_NAME + 1;
    m.u.hello.client.ptr = over;
    refuse(&m, "a long client name");
    build(QMC_MSG_HELLO, EXAMPLE, &m);
    m.u.hello.client.ptr = NULL;
    refuse(&m, "a NULL name");
    build(QMC_MSG_HELLO, EXAMPLE, &m);
    m.u.hello.client = str_of("bad\xff");
    refuse(&m, "invalid UTF-8");
    build(QMC_MSG_HELLO, EXAMPLE, &m);
    m.u.hello.version_max = 0;
    refuse(&m, "an empty version range");

    build(QMC_MSG_PING, EXAMPLE, &m);
    m.u.ping.data.ptr = over;
    m.u.ping.data.len = QMC_PROTO_MAX_PING + 1;
    refuse(&m, "long ping data");

    build(QMC_MSG_POINTS, EXAMPLE, &m);
    m.u.points.seq.kind = (qmc_seq_kind)0;
    refuse(&m, "seq kind 0");
    build(QMC_MSG_POINTS, EXAMPLE, &m);
    m.u.points.format = (qmc_format)300;
    refuse(&m, "format 300");
    build(QMC_MSG_POINTS, EXAMPLE, &m);
    m.u.points.seq.flags = 2;
    refuse(&m, "an undefined flag");

    build(QMC_MSG_POINTS_CHUNK, EXAMPLE, &m);
    m.u.chunk.points = 3;
    refuse(&m, "data not whole points");
    build(QMC_MSG_POINTS_CHUNK, EXAMPLE, &m);
    m.u.chunk.data = NULL;
    refuse(&m, "NULL data");
    build(QMC_MSG_POINTS_CHUNK, MAXIMAL, &m);
    m.u.chunk.data_len += 4;
    m.u.chunk.points = m.u.chunk.data_len / 4;
    refuse(&m, "a chunk over QMC_PROTO_CHUNK_BYTES");

    build(QMC_MSG_INTEGRATE, EXAMPLE, &m);
    memset(m.u.integrate.spec.integrand, 'x', QMC_JOB_NAME_BYTES);
    refuse(&m, "an unterminated integrand name");
    build(QMC_MSG_INTEGRATE, EXAMPLE, &m);
    m.u.integrate.a.count = QMC_PROTO_MAX_LIST + 1;
    m.u.integrate.a.values = big_list;
    refuse(&m, "a list over its limit");
    build(QMC_MSG_INTEGRATE, EXAMPLE, &m);
    m.u.integrate.a.values = NULL;
    refuse(&m, "a list without values");
    build(QMC_MSG_INTEGRATE, EXAMPLE, &m);
    m.u.integrate.u.values = (const double[]){0.5, NAN, 0.5};
    refuse(&m, "a NaN parameter");
    build(QMC_MSG_INTEGRATE, EXAMPLE, &m);
    m.u.integrate.spec.integrate.tol_rel = INFINITY;
    refuse(&m, "an infinite tolerance");
    build(QMC_MSG_INTEGRATE, EXAMPLE, &m);
    m.u.integrate.spec.difficulty = 2;
    refuse(&m, "difficulty 2");
    build(QMC_MSG_INTEGRATE, EXAMPLE, &m);
    m.u.integrate.spec.difficulty = -2;
    refuse(&m, "difficulty -2");
    build(QMC_MSG_INTEGRATE, EXAMPLE, &m);
    m.u.integrate.spec.strategy = (qmc_scene_strategy)0;
    refuse(&m, "strategy 0");
    build(QMC_MSG_INTEGRATE, EXAMPLE, &m);
    m.u.integrate.spec.integrate.method = (qmc_method)13;
    refuse(&m, "method 13");
    build(QMC_MSG_INTEGRATE, EXAMPLE, &m);
    m.u.integrate.scene = text_of_len(QMC_SCENE_MAX_BYTES);
    m.u.integrate.scene.len++;
    refuse(&m, "scene text over QMC_SCENE_MAX_BYTES");

    build(QMC_MSG_JOB_STATE, EXAMPLE, &m);
    m.u.state.state = (qmc_job_state)7;
    refuse(&m, "state 7");

    build(QMC_MSG_JOB_RESULT, EXAMPLE, &m);
    m.u.result.res.flags = 1u << 31;
    refuse(&m, "an undefined result flag");
    build(QMC_MSG_JOB_RESULT, EXAMPLE, &m);
    m.u.result.reference_kind = 3;
    refuse(&m, "reference kind 3");
    build(QMC_MSG_JOB_RESULT, EXAMPLE, &m);
    m.u.result.detail.ptr = over;
    m.u.result.detail.len = QMC_PROTO_MAX_MESSAGE + 1;
    refuse(&m, "a long detail");
    build(QMC_MSG_JOB_RESULT, EXAMPLE, &m);
    m.u.result.has_known_abs = -1;
    refuse(&m, "a known integral of |f| never told (a version-5 frame's)");
    build(QMC_MSG_JOB_RESULT, EXAMPLE, &m);
    m.u.result.known_abs = -0.5;
    refuse(&m, "a negative integral of |f|");
    build(QMC_MSG_JOB_RESULT, EXAMPLE, &m);
    m.u.result.has_known_abs = 0;
    refuse(&m, "an unknown integral of |f| with a value");

    build(QMC_MSG_STATS_REPLY, EXAMPLE, &m);
    m.u.stats.count = QMC_PROTO_MAX_STATS + 1;
    m.u.stats.entries = many_stats;
    refuse(&m, "too many stats");
    build(QMC_MSG_STATS_REPLY, EXAMPLE, &m);
    m.u.stats.entries = NULL;
    refuse(&m, "stats without entries");

    build(QMC_MSG_ERROR, EXAMPLE, &m);
    m.u.error.code = 0;
    refuse(&m, "code 0");

    build(QMC_MSG_POINTS, EXAMPLE, &m);
    m.u.points.transport = (qmc_points_transport)2;
    refuse(&m, "transport 2");
    build(QMC_MSG_SHM_ATTACH, EXAMPLE, &m);
    m.u.shm.slots = QMC_PROTO_SHM_MAX_SLOTS + 1;
    refuse(&m, "too many slots");
    build(QMC_MSG_SHM_OK, EXAMPLE, &m);
    m.u.shm.slot_bytes = QMC_PROTO_SHM_MIN_SLOT_BYTES + 1;
    refuse(&m, "a slot of no whole pages");
    build(QMC_MSG_POINTS_SHM_CHUNK, EXAMPLE, &m);
    m.u.shm_chunk.points = 0;
    refuse(&m, "a chunk without points");
    build(QMC_MSG_POINTS_SHM_CHUNK, EXAMPLE, &m);
    m.u.shm_chunk.slot = QMC_PROTO_SHM_MAX_SLOTS;
    refuse(&m, "slot 64");
    build(QMC_MSG_SHM_RELEASE, EXAMPLE, &m);
    m.u.release.slots = 0;
    refuse(&m, "a release of nothing");

    build(QMC_MSG_PING, EXAMPLE, &m);
    m.type = (qmc_msg_type)0;
    refuse(&m, "type 0");
    m.type = (qmc_msg_type)34;
    refuse(&m, "type 34");
    build(QMC_MSG_PIXELS, EXAMPLE, &m);
    m.u.pixels.spec.sampler = (qmc_pixel_sampler)0;
    refuse(&m, "pixel sampler 0");
    build(QMC_MSG_PIXELS, EXAMPLE, &m);
    m.u.pixels.format = (qmc_format)0;
    refuse(&m, "format 0");
    build(QMC_MSG_PIXELS, EXAMPLE, &m);
    m.u.pixels.transport = (qmc_points_transport)2;
    refuse(&m, "transport 2");
    build(QMC_MSG_AUTH_CHALLENGE, EXAMPLE, &m);
    m.u.challenge.version = QMC_PROTO_VERSION_AUTH - 1;
    refuse(&m, "a challenge for a version without the handshake");
    assert_int_equal(qmc_proto_encode(NULL, frame, sizeof frame), QMC_EINVAL);
    assert_int_equal(qmc_proto_encoded_size(NULL), 0);

    /* Normalised, not refused: n_given and cv.used are booleans. */
    build(QMC_MSG_INTEGRATE, EXAMPLE, &m);
    m.u.integrate.spec.integrate.n_given = 42;
    qmc_msg d;
    size_t n = encode_ok(&m);
    assert_int_equal(decode(frame, n, &d), (int)n);
    assert_int_equal(d.u.integrate.spec.integrate.n_given, 1);
}

static void test_small_buffers(void **state)
{
    (void)state;
    for (size_t t = 0; t < N_TYPES; t++) {
        qmc_msg m;
        build(all_types[t], EXAMPLE, &m);
        size_t n = encode_ok(&m);
        memcpy(frame2, frame, n);
        for (size_t cap = 0; cap < n; cap++) {
            memset(frame, 0xaa, n);
            assert_int_equal(qmc_proto_encode(&m, frame, cap), QMC_ETOOBIG);
            for (size_t k = cap; k < n; k++) /* nothing past cap */
                assert_int_equal(frame[k], 0xaa);
        }
        assert_int_equal(qmc_proto_encode(&m, NULL, 0), QMC_ETOOBIG);
        assert_int_equal(qmc_proto_encode(&m, frame, n), (int)n);
        assert_memory_equal(frame, frame2, n);
    }
}

/* ---- zero-copy chunks --------------------------------------------------------------- */

static void test_chunk_prefix(void **state)
{
    (void)state;
    qmc_msg m, d;
    build(QMC_MSG_POINTS_CHUNK, EXAMPLE, &m);
    size_t n = encode_ok(&m);
    int pre = qmc_proto_encode_chunk_prefix(3, 0, 2, 32, frame2, sizeof frame2);
    assert_int_equal(pre, QMC_PROTO_HEADER_BYTES + 16);
    memcpy(frame2 + pre, example_points, 32);
    assert_int_equal((size_t)pre + 32, n);
    assert_memory_equal(frame, frame2, n);
    assert_int_equal(decode(frame2, n, &d), (int)n);
    same_msg(&m, &d);
    /* The largest chunk. */
    pre = qmc_proto_encode_chunk_prefix(1, 99, QMC_PROTO_CHUNK_BYTES / 8, QMC_PROTO_CHUNK_BYTES,
                                        frame2, 40);
    assert_int_equal(pre, 40);
    memcpy(frame2 + pre, chunk_data, QMC_PROTO_CHUNK_BYTES);
    assert_int_equal(decode(frame2, 40 + QMC_PROTO_CHUNK_BYTES, &d), 40 + QMC_PROTO_CHUNK_BYTES);
    assert_true(d.u.chunk.first == 99 && d.u.chunk.points == QMC_PROTO_CHUNK_BYTES / 8);
    assert_ptr_equal(d.u.chunk.data, frame2 + 40); /* a view, not a copy */
    /* Refusals. */
    assert_int_equal(qmc_proto_encode_chunk_prefix(1, 0, 2, 32, frame2, 39), QMC_ETOOBIG);
    assert_int_equal(qmc_proto_encode_chunk_prefix(1, 0, 1, QMC_PROTO_CHUNK_BYTES + 4, frame2,
                                                   sizeof frame2),
                     QMC_ETOOBIG);
    assert_int_equal(qmc_proto_encode_chunk_prefix(1, 0, 0, 0, frame2, sizeof frame2),
                     QMC_EINVAL);
    assert_int_equal(qmc_proto_encode_chunk_prefix(1, 0, 3, 32, frame2, sizeof frame2),
                     QMC_EINVAL);
    assert_int_equal(qmc_proto_encode_chunk_prefix(1, 0, 2, 30, frame2, sizeof frame2),
                     QMC_EINVAL);
}

/* ---- accessors, names, UTF-8 ----------------------------------------------------------- */

static void test_accessors(void **state)
{
    (void)state;
    static const uint8_t raw[16] = {0, 0, 0, 0, 0, 0, 0xf0, 0x3f, 1, 0, 0, 0, 0, 0, 0xf8, 0x7f};
    qmc_f64s l = {NULL, raw, 2};
    assert_true(qmc_proto_f64_at(&l, 0) == 1.0);
    assert_true(isnan(qmc_proto_f64_at(&l, 1)));
    assert_true(qmc_proto_f64_at(&l, 2) == 0.0);
    assert_true(qmc_proto_f64_at(NULL, 0) == 0.0);
    qmc_msg_stats_reply r = {3, example_stats, NULL, 0};
    assert_true(qmc_proto_stat_at(&r, 1).value == 1);
    assert_int_equal(qmc_proto_stat_at(&r, 3).name.len, 0);

    for (size_t t = 0; t < N_TYPES; t++)
        assert_true(strlen(qmc_msg_type_name(all_types[t])) > 0);
    assert_string_equal(qmc_msg_type_name(QMC_MSG_JOB_RESULT), "JOB_RESULT");
    assert_string_equal(qmc_msg_type_name((qmc_msg_type)0), "");
    assert_string_equal(qmc_msg_type_name((qmc_msg_type)99), "");
    assert_string_equal(qmc_job_state_name(QMC_JOB_CANCELLED), "cancelled");
    assert_string_equal(qmc_job_state_name((qmc_job_state)0), "");
}

static void test_utf8(void **state)
{
    (void)state;
    static const struct {
        const char *s;
        int ok;
    } cases[] = {
        {"", 1},
        {"plain", 1},
        {"\xc3\xa9", 1},
        {"\xe2\x82\xac", 1},
        {"\xf0\x9f\x98\x80", 1},
        {"\xf4\x8f\xbf\xbf", 1},  /* U+10FFFF */
        {"\xc0\xaf", 0},          /* overlong */
        {"\xe0\x80\xaf", 0},      /* overlong */
        {"\xed\xa0\x80", 0},      /* surrogate */
        {"\xf4\x90\x80\x80", 0},  /* past U+10FFFF */
        {"\xf5\x80\x80\x80", 0},
        {"\x80", 0},
        {"\xe2\x82", 0},          /* truncated */
        {"a\xe2\x28\xa1", 0},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        assert_int_equal(qmc__utf8_ok((const uint8_t *)cases[i].s, strlen(cases[i].s)),
                         cases[i].ok);
    assert_int_equal(qmc__utf8_ok((const uint8_t *)"a\0b", 3), 0);
}

/* ---- the worked examples (tests/vectors/proto) ----------------------------------------- */

/* A message of version 6 or later (by qmc_proto_msg_min_version of its
 * example) has its vector in VECTOR_DIR/v<N>/, so that a client of an
 * older version that reads every vector of VECTOR_DIR (client/python's
 * tests do) meets only messages it knows. */
static void vector_path(const qmc_msg *m, char *path, size_t bytes)
{
    char name[32], sub[16] = "";
    const char *s = qmc_msg_type_name(m->type);
    size_t i = 0;
    for (; s[i] && i + 1 < sizeof name; i++)
        name[i] = (char)tolower((unsigned char)s[i]);
    name[i] = '\0';
    const unsigned v = qmc_proto_msg_min_version(m);
    if (v > QMC_PROTO_VERSION_SESSIONS)
        snprintf(sub, sizeof sub, "v%u/", v);
    snprintf(path, bytes, "%s/%s%s.hex", VECTOR_DIR, sub, name);
}

/* Header on the first line, then the payload 16 bytes a line. */
static void write_vector(const char *path, const uint8_t *b, size_t n)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    for (size_t i = 0; i < n; i++) {
        int eol = i + 1 == n || i + 1 == QMC_PROTO_HEADER_BYTES ||
                  (i >= QMC_PROTO_HEADER_BYTES && (i + 1 - QMC_PROTO_HEADER_BYTES) % 16 == 0);
        fprintf(f, "%02x%s", b[i], eol ? "\n" : " ");
    }
    assert_int_equal(fclose(f), 0);
}

/* The whole of a text file, NUL-terminated (freed by the caller). */
static char *slurp(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (f == NULL)
        fail_msg("cannot open %s (run the test from the top directory)", path);
    size_t cap = 1 << 20, n = 0;
    char *s = malloc(cap + 1);
    assert_non_null(s);
    n = fread(s, 1, cap, f);
    assert_true(n < cap && !ferror(f));
    fclose(f);
    s[n] = '\0';
    return s;
}

static void test_vectors(void **state)
{
    (void)state;
    int write = getenv("QMC_PROTO_WRITE_VECTORS") != NULL;
    char *doc = write ? NULL : slurp("protocol/PROTOCOL.md");
    for (size_t t = 0; t < N_TYPES; t++) {
        qmc_msg m, d;
        char path[128];
        build(all_types[t], EXAMPLE, &m);
        size_t n = encode_ok(&m);
        vector_path(&m, path, sizeof path);
        if (write) {
            write_vector(path, frame, n);
            continue;
        }
        size_t vn = proto_read_hex(path, frame2, sizeof frame2);
        if (vn != n || memcmp(frame, frame2, n) != 0)
            fail_msg("%s: the encoder no longer reproduces the vector", path);
        assert_int_equal(decode(frame2, vn, &d), (int)vn);
        same_msg(&m, &d);
        /* PROTOCOL.md shows the same frame, in a code block of its own. */
        char *hex = slurp(path), *block = malloc(strlen(hex) + 16);
        assert_non_null(block);
        sprintf(block, "```\n%s```\n", hex);
        if (strstr(doc, block) == NULL)
            fail_msg("protocol/PROTOCOL.md does not show %s verbatim", path);
        free(block);
        free(hex);
    }
    free(doc);
}

int main(void)
{
    setup_static();
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_roundtrip),
        cmocka_unit_test(test_truncation),
        cmocka_unit_test(test_back_to_back),
        cmocka_unit_test(test_bad_header),
        cmocka_unit_test(test_too_big),
        cmocka_unit_test(test_bad_lengths),
        cmocka_unit_test(test_mutations),
        cmocka_unit_test(test_encoder_refuses),
        cmocka_unit_test(test_small_buffers),
        cmocka_unit_test(test_chunk_prefix),
        cmocka_unit_test(test_accessors),
        cmocka_unit_test(test_utf8),
        cmocka_unit_test(test_vectors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
