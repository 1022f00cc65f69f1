/*
 * messages.c - the payload layout of every message, each written once as a
 * qmc__io function that both decodes and encodes (see codec.h), and the
 * table, driven by QMC_MSG_MAP, that ties type codes to names, directions,
 * payload bounds and layouts.  protocol/PROTOCOL.md documents the same
 * layouts byte by byte; change both together.
 *
 * Enumerations travel as one byte holding the code of their X-macro table
 * (seq kinds, scrambles, formats, samplers, pixel samplers, methods,
 * scene strategies, job states, ...).  What the codec can check it checks
 * here: codes known, reserved bytes zero, flag bits defined, lengths within
 * limits, request doubles finite.  Semantic checks (dimension limits, which
 * scramble a kind takes, budgets, tiles inside the image) stay with
 * qmc_seq_spec_check, qmc_pixel_spec_check and qmc_job_new in the daemon.  No I/O, no allocation, no global state.
 */
#include <string.h>

#include "codec.h"

/* ---- enumeration codes ---------------------------------------------------- */

#define CASE_CODE(name, code, ...) case code:
#define COUNT_ONE(...) +1

static int seq_kind_ok(uint32_t v)
{
    switch (v) {
    QMC_SEQ_KIND_MAP(CASE_CODE)
        return 1;
    default:
        return 0;
    }
}

/* A sampling spec names a sequence kind, or 0 where none applies (the
 * report of a non-sampling method is all zeros). */
static int seq_kind_or_none_ok(uint32_t v)
{
    return v == 0 || seq_kind_ok(v);
}

static int scramble_ok(uint32_t v)
{
    switch (v) {
    QMC_SCRAMBLE_MAP(CASE_CODE)
        return 1;
    default:
        return 0;
    }
}

static int format_ok(uint32_t v)
{
    switch (v) {
    QMC_FORMAT_MAP(CASE_CODE)
        return 1;
    default:
        return 0;
    }
}

static int strategy_ok(uint32_t v)
{
    switch (v) {
    QMC_SCENE_STRATEGY_MAP(CASE_CODE)
        return 1;
    default:
        return 0;
    }
}

/* Pixel samplers are numbered by their code (qmc/pixel.h). */
static int pixel_sampler_ok(uint32_t v)
{
    switch (v) {
    QMC_PIXEL_SAMPLER_MAP(CASE_CODE)
        return 1;
    default:
        return 0;
    }
}

/* qmc_points_transport: 0 inline, 1 the shared-memory ring. */
static int transport_ok(uint32_t v)
{
    return v == QMC_TRANSPORT_INLINE || v == QMC_TRANSPORT_SHM;
}

static int job_state_ok(uint32_t v)
{
    switch (v) {
    QMC_JOB_STATE_MAP(CASE_CODE)
        return 1;
    default:
        return 0;
    }
}

/* qmc_smoothness: analytic 0 .. singular 3 (qmc/integrand.h). */
static int smoothness_ok(uint32_t v)
{
    return v <= QMC_SMOOTH_SINGULAR;
}

/* qmc_session_end: QMC_SESSION_END_MAP, numbered from 0 (qmc/session.h). */
static int session_end_ok(uint32_t v)
{
    return v < 0 QMC_SESSION_END_MAP(COUNT_ONE);
}

/* Methods and samplers are numbered by their position in the table. */
static int method_ok(uint32_t v)
{
    return v < 0 QMC_METHOD_MAP(COUNT_ONE);
}

static int sampler_ok(uint32_t v)
{
    return v < 0 QMC_SAMPLER_MAP(COUNT_ONE);
}

/* qmc_error_kind and reference_kind: 0, 1 or 2. */
static int kind3_ok(uint32_t v)
{
    return v <= 2;
}

/* difficulty: a QMC_DIFFICULTY_MAP code, or 255 for "none" (-1). */
static int difficulty_ok(uint32_t v)
{
    switch (v) {
    QMC_DIFFICULTY_MAP(CASE_CODE)
    case 255:
        return 1;
    default:
        return 0;
    }
}

/* Defined flag bits; the others are reserved and must be zero.  A new
 * bit is a protocol change: result flags by version are in
 * result_flags.c. */
#define SEQ_FLAGS_KNOWN ((uint32_t)QMC_SEQ_SHUFFLE)

static void io_flags(qmc__io *io, uint32_t *v, uint32_t known)
{
    qmc__io_u32(io, v);
    if (*v & ~known)
        qmc__io_invalid(io);
}

/* Result flags as the connection's version defines them: encoding tells
 * an older peer the newer bits through error_unreliable; decoding refuses
 * a bit the version does not define. */
static void io_result_flags(qmc__io *io, uint32_t *v)
{
    if (!io->decode)
        *v = qmc_proto_result_flags_for(io->version, *v);
    io_flags(io, v, qmc_proto_result_flags_defined(io->version));
}

/* An enumeration stored in a C enum (or int) field, as one byte. */
#define IO_ENUM(io, field, ok)                 \
    do {                                       \
        uint32_t code_ = (uint32_t)(field);    \
        qmc__io_code8((io), &code_, (ok));     \
        (field) = code_;                       \
    } while (0)

/* ---- layouts ---------------------------------------------------------------
 * The FIXED_* sizes are the bytes before a layout's first variable field;
 * the table's bounds are built from them and the limits in proto.h. */

enum {
    STR16 = 2, /* u16 length prefix */
    LEN32 = 4, /* u32 length or count prefix */
    FIXED_HELLO = 8,
    FIXED_HELLO_OK = 32,
    FIXED_POINTS = 48,
    FIXED_PIXELS = 64,
    FIXED_CHUNK = 16,
    FIXED_END = 16,
    FIXED_INTEGRATE = 104,
    FIXED_JOB_ID = 8,
    FIXED_PROGRESS = 24,
    FIXED_STATE = 32,
    FIXED_RESULT = 160,
    FIXED_STATS = 4,
    STAT_MIN = STR16 + 8,
    FIXED_ERROR = 4,
    FIXED_SHM = 16,
    FIXED_SHM_CHUNK = 24,
    FIXED_SHM_RELEASE = 4,
    FIXED_AUTH_CHALLENGE = 4 + QMC_PROTO_AUTH_NONCE_BYTES,
    FIXED_AUTH_RESPONSE = QMC_PROTO_AUTH_NONCE_BYTES + QMC_PROTO_AUTH_MAC_BYTES,
    FIXED_AUTH_OK = QMC_PROTO_AUTH_MAC_BYTES,
    FIXED_SESSION_OPEN = 112,
    FIXED_SESSION_OPENED = 40 + QMC_PROTO_SESSION_TOKEN_BYTES,
    FIXED_SESSION_BATCH = 44,
    FIXED_SESSION_VALUES = 40,
    FIXED_SESSION_REPORT = 112,
    FIXED_SESSION_RESUME = 16 + QMC_PROTO_SESSION_TOKEN_BYTES,
    FIXED_SESSION_CLOSE = 8 + QMC_PROTO_SESSION_TOKEN_BYTES
};

static void io_hello(qmc__io *io, qmc_msg *m)
{
    qmc_msg_hello *h = &m->u.hello;
    qmc__io_u16(io, &h->version_min);
    qmc__io_u16(io, &h->version_max);
    qmc__io_u32(io, &h->max_frame);
    qmc__io_str(io, &h->client, QMC_PROTO_MAX_NAME, QMC__STR_TEXT);
    if (h->version_min == 0 || h->version_min > h->version_max)
        qmc__io_invalid(io);
}

static void io_hello_ok(qmc__io *io, qmc_msg *m)
{
    qmc_msg_hello_ok *h = &m->u.hello_ok;
    qmc__io_u16(io, &h->version);
    qmc__io_zero(io, 2);
    qmc__io_u32(io, &h->max_frame);
    qmc__io_u32(io, &h->max_inflight);
    qmc__io_zero(io, 4);
    qmc__io_u64(io, &h->max_points);
    qmc__io_u64(io, &h->sobol_table_hash);
    qmc__io_str(io, &h->server, QMC_PROTO_MAX_NAME, QMC__STR_TEXT);
    qmc__io_str(io, &h->engine, QMC_PROTO_MAX_NAME, QMC__STR_TEXT);
    if (h->version == 0)
        qmc__io_invalid(io);
}

/* PING and PONG: opaque bytes, echoed. */
static void io_ping(qmc__io *io, qmc_msg *m)
{
    qmc__io_str(io, &m->u.ping.data, QMC_PROTO_MAX_PING, 0);
}

static void io_points(qmc__io *io, qmc_msg *m)
{
    qmc_msg_points *p = &m->u.points;
    IO_ENUM(io, p->seq.kind, seq_kind_ok);
    IO_ENUM(io, p->seq.scramble, scramble_ok);
    IO_ENUM(io, p->format, format_ok);
    IO_ENUM(io, p->transport, transport_ok);
    qmc__io_u32(io, &p->seq.dims);
    io_flags(io, &p->seq.flags, SEQ_FLAGS_KNOWN);
    qmc__io_zero(io, 4);
    qmc__io_u64(io, &p->seq.seed);
    qmc__io_u64(io, &p->seq.set_size);
    qmc__io_u64(io, &p->start);
    qmc__io_u64(io, &p->count);
}

/* PIXELS: the spec, then the tile.  Zero sizes, tiles outside the image
 * and samples past spp are the daemon's to refuse with the core's reason
 * (qmc_pixel_spec_check, qmc_pixels_tile_check), as POINTS leaves dims to
 * qmc_seq_spec_check. */
static void io_pixels(qmc__io *io, qmc_msg *m)
{
    qmc_msg_pixels *p = &m->u.pixels;
    IO_ENUM(io, p->spec.sampler, pixel_sampler_ok);
    IO_ENUM(io, p->format, format_ok);
    IO_ENUM(io, p->transport, transport_ok);
    qmc__io_zero(io, 1);
    qmc__io_u32(io, &p->spec.width);
    qmc__io_u32(io, &p->spec.height);
    qmc__io_u32(io, &p->spec.seed);
    qmc__io_u32(io, &p->spec.frame);
    qmc__io_u32(io, &p->spec.dims);
    qmc__io_u64(io, &p->spec.spp);
    qmc__io_u32(io, &p->tile.x);
    qmc__io_u32(io, &p->tile.y);
    qmc__io_u32(io, &p->tile.width);
    qmc__io_u32(io, &p->tile.height);
    qmc__io_u64(io, &p->tile.sample_start);
    qmc__io_u64(io, &p->tile.sample_count);
}

/* Whole points of whole 4- or 8-byte coordinates: at least one point,
 * the data a multiple of the point count and of 4 bytes, at most max. */
static int whole_points(uint32_t points, uint32_t data_len, uint32_t max)
{
    return data_len <= max && points != 0 && data_len % 4 == 0 && data_len % points == 0 &&
           data_len / points >= 4;
}

static void io_chunk(qmc__io *io, qmc_msg *m)
{
    qmc_msg_points_chunk *c = &m->u.chunk;
    qmc__io_u64(io, &c->first);
    qmc__io_u32(io, &c->points);
    qmc__io_u32(io, &c->data_len);
    if (!whole_points(c->points, c->data_len, QMC_PROTO_CHUNK_BYTES)) {
        qmc__io_invalid(io);
        return;
    }
    qmc__io_blob(io, &c->data, c->data_len);
}

static void io_end(qmc__io *io, qmc_msg *m)
{
    qmc__io_u64(io, &m->u.end.points);
    qmc__io_u64(io, &m->u.end.bytes);
}

/* qmc_sampling_spec, shared by INTEGRATE and JOB_RESULT: 4 code bytes,
 * seq_flags, seed, n, confidence, reps, split_net, 3 reserved (40 bytes in
 * all; split_net was a reserved zero before it existed). */
void qmc__io_sampling(qmc__io *io, qmc_sampling_spec *s, int finite)
{
    IO_ENUM(io, s->sampler, sampler_ok);
    IO_ENUM(io, s->seq, seq_kind_or_none_ok);
    IO_ENUM(io, s->scramble, scramble_ok);
    qmc__io_zero(io, 1);
    io_flags(io, &s->seq_flags, SEQ_FLAGS_KNOWN);
    qmc__io_u64(io, &s->seed);
    qmc__io_u64(io, &s->n);
    if (finite)
        qmc__io_f64_finite(io, &s->confidence);
    else
        qmc__io_f64(io, &s->confidence);
    qmc__io_u32(io, &s->reps);
    qmc__io_bool(io, &s->split_net);
    qmc__io_zero(io, 3);
}

static void io_integrate(qmc__io *io, qmc_msg *m)
{
    qmc_msg_integrate *g = &m->u.integrate;
    qmc_job_spec *s = &g->spec;
    qmc_integrate_spec *in = &s->integrate;
    IO_ENUM(io, in->method, method_ok);
    IO_ENUM(io, s->strategy, strategy_ok);
    uint32_t difficulty = s->difficulty < 0 ? 255u : (uint32_t)s->difficulty;
    if (!io->decode && s->difficulty < -1)
        qmc__io_invalid(io);
    qmc__io_code8(io, &difficulty, difficulty_ok);
    s->difficulty = difficulty == 255 ? -1 : (int)difficulty;
    qmc__io_bool(io, &in->n_given);
    qmc__io_u32(io, &s->dims);
    qmc__io_u32(io, &s->samples_brdf);
    qmc__io_u32(io, &s->samples_light);
    qmc__io_u32(io, &in->n_axis);
    qmc__io_u32(io, &g->progress_ms);
    qmc__io_u64(io, &in->max_evals);
    qmc__io_u64(io, &in->max_memory);
    qmc__io_f64_finite(io, &s->beta);
    qmc__io_f64_finite(io, &in->tol_abs);
    qmc__io_f64_finite(io, &in->tol_rel);
    qmc__io_sampling(io, &in->sampling, 1);
    qmc__io_name(io, s->integrand);
    qmc__io_name(io, s->control);
    qmc__io_f64s(io, &g->a, QMC_PROTO_MAX_LIST, 1);
    qmc__io_f64s(io, &g->u, QMC_PROTO_MAX_LIST, 1);
    qmc__io_str(io, &g->scene, QMC_SCENE_MAX_BYTES, QMC__STR_TEXT | QMC__STR_LEN32);
    /* The wire carries a, u and scene; the spec's own pointers are the
     * daemon's to set once it has copied them. */
    if (io->decode) {
        s->a = s->u = NULL;
        s->n_a = s->n_u = 0;
        s->scene_text = NULL;
        s->scene_len = 0;
    }
}

/* JOB_ACCEPTED, JOB_STATUS, JOB_CANCEL. */
static void io_job_id(qmc__io *io, qmc_msg *m)
{
    qmc__io_u64(io, &m->u.job.job_id);
}

static void io_progress(qmc__io *io, qmc_msg *m)
{
    qmc__io_u64(io, &m->u.progress.job_id);
    qmc__io_u64(io, &m->u.progress.evals);
    qmc__io_f64(io, &m->u.progress.seconds);
}

static void io_state(qmc__io *io, qmc_msg *m)
{
    qmc_msg_job_state *st = &m->u.state;
    qmc__io_u64(io, &st->job_id);
    IO_ENUM(io, st->state, job_state_ok);
    qmc__io_zero(io, 7);
    qmc__io_u64(io, &st->evals);
    qmc__io_f64(io, &st->seconds);
}

static void io_result(qmc__io *io, qmc_msg *m)
{
    qmc_msg_job_result *r = &m->u.result;
    qmc_result *res = &r->res;
    qmc__io_u64(io, &r->job_id);
    IO_ENUM(io, r->method_used, method_ok);
    IO_ENUM(io, res->error_kind, kind3_ok);
    IO_ENUM(io, r->reference_kind, kind3_ok);
    qmc__io_bool(io, &r->cv.used);
    qmc__io_u32(io, &res->dims);
    io_result_flags(io, &res->flags);
    qmc__io_zero(io, 4);
    qmc__io_u64(io, &res->n);
    qmc__io_u64(io, &res->evals);
    qmc__io_u64(io, &res->nonfinite);
    qmc__io_f64(io, &res->estimate);
    qmc__io_f64(io, &res->error);
    qmc__io_f64(io, &res->ci_low);
    qmc__io_f64(io, &res->ci_high);
    qmc__io_f64(io, &res->abs_integral);
    qmc__io_f64(io, &r->cv.beta);
    qmc__io_f64(io, &r->cv.variance_ratio);
    qmc__io_f64(io, &r->seconds);
    qmc__io_f64(io, &r->reference);
    qmc__io_sampling(io, &r->sampling, 0);
    qmc__io_str(io, &r->detail, QMC_PROTO_MAX_MESSAGE, QMC__STR_TEXT);
    qmc__io_str(io, &r->auto_reason, QMC_PROTO_MAX_MESSAGE, QMC__STR_TEXT);
    qmc__io_known_abs(io, r); /* version 6 on */
}

static void io_empty(qmc__io *io, qmc_msg *m)
{
    (void)io;
    (void)m;
}

static void io_stats_reply(qmc__io *io, qmc_msg *m)
{
    qmc_msg_stats_reply *r = &m->u.stats;
    qmc__io_u32(io, &r->count);
    if (r->count > QMC_PROTO_MAX_STATS) {
        qmc__io_invalid(io);
        return;
    }
    if (io->decode) {
        /* Every entry takes at least STAT_MIN bytes: a count the payload
         * cannot hold is refused before walking it. */
        if (io->err || (uint64_t)r->count * STAT_MIN > io->rd.left) {
            qmc__io_invalid(io);
            return;
        }
        r->entries = NULL;
        r->raw = io->rd.left ? io->rd.p : NULL;
        r->raw_len = 0;
        size_t before = io->rd.left;
        for (uint32_t i = 0; i < r->count && io->err == 0; i++) {
            qmc_stat st;
            qmc__io_str(io, &st.name, QMC_PROTO_MAX_NAME, QMC__STR_TEXT);
            qmc__io_u64(io, &st.value);
        }
        r->raw_len = (uint32_t)(before - io->rd.left);
        if (r->raw_len == 0)
            r->raw = NULL;
        return;
    }
    if (r->count && !r->entries && !r->raw) {
        qmc__io_invalid(io);
        return;
    }
    for (uint32_t i = 0; i < r->count && io->err == 0; i++) {
        qmc_stat st = qmc_proto_stat_at(r, i);
        qmc__io_str(io, &st.name, QMC_PROTO_MAX_NAME, QMC__STR_TEXT);
        qmc__io_u64(io, &st.value);
    }
}

static void io_error(qmc__io *io, qmc_msg *m)
{
    qmc__io_i32(io, &m->u.error.code);
    if (m->u.error.code >= 0)
        qmc__io_invalid(io);
    qmc__io_str(io, &m->u.error.message, QMC_PROTO_MAX_MESSAGE, QMC__STR_TEXT);
}

/* SHM_ATTACH and SHM_OK: the ring's geometry, then 8 reserved bytes. */
static void io_shm(qmc__io *io, qmc_msg *m)
{
    qmc_msg_shm *r = &m->u.shm;
    qmc__io_u32(io, &r->slots);
    qmc__io_u32(io, &r->slot_bytes);
    qmc__io_zero(io, 8);
    if (r->slots < QMC_PROTO_SHM_MIN_SLOTS || r->slots > QMC_PROTO_SHM_MAX_SLOTS ||
        r->slot_bytes < QMC_PROTO_SHM_MIN_SLOT_BYTES ||
        r->slot_bytes > QMC_PROTO_SHM_MAX_SLOT_BYTES ||
        r->slot_bytes % QMC_PROTO_SHM_SLOT_ALIGN != 0)
        qmc__io_invalid(io);
}

/* POINTS_SHM_CHUNK: where the points are; the data stays in the ring. */
static void io_shm_chunk(qmc__io *io, qmc_msg *m)
{
    qmc_msg_shm_chunk *c = &m->u.shm_chunk;
    qmc__io_u64(io, &c->first);
    qmc__io_u32(io, &c->points);
    qmc__io_u32(io, &c->data_len);
    qmc__io_u32(io, &c->slot);
    qmc__io_zero(io, 4);
    if (!whole_points(c->points, c->data_len, QMC_PROTO_SHM_MAX_SLOT_BYTES) ||
        c->slot >= QMC_PROTO_SHM_MAX_SLOTS)
        qmc__io_invalid(io);
}

static void io_shm_release(qmc__io *io, qmc_msg *m)
{
    qmc__io_u32(io, &m->u.release.slots);
    if (m->u.release.slots == 0 || m->u.release.slots > QMC_PROTO_SHM_MAX_SLOTS)
        qmc__io_invalid(io);
}

/* n opaque bytes held in the message itself (nonces, MACs): copied, not
 * viewed, so a decoded handshake message outlives the receive buffer. */
static void io_fixed_bytes(qmc__io *io, uint8_t *bytes, size_t n)
{
    if (io->decode) {
        const uint8_t *p = qmc__rd_take(&io->rd, n);
        if (qmc__io_rd_ok(io))
            memcpy(bytes, p, n);
        return;
    }
    qmc__wr_bytes(&io->wr, bytes, n);
}

/* A session's token: 32 opaque bytes held in the message. */
static void io_token(qmc__io *io, uint8_t *token)
{
    io_fixed_bytes(io, token, QMC_PROTO_SESSION_TOKEN_BYTES);
}

static void io_auth_challenge(qmc__io *io, qmc_msg *m)
{
    qmc_msg_auth_challenge *a = &m->u.challenge;
    qmc__io_u16(io, &a->version);
    qmc__io_zero(io, 2);
    io_fixed_bytes(io, a->nonce, sizeof a->nonce);
    /* Only a version that has the handshake can be announced by it. */
    if (a->version < QMC_PROTO_VERSION_AUTH)
        qmc__io_invalid(io);
}

static void io_auth_response(qmc__io *io, qmc_msg *m)
{
    io_fixed_bytes(io, m->u.response.nonce, sizeof m->u.response.nonce);
    io_fixed_bytes(io, m->u.response.mac, sizeof m->u.response.mac);
}

static void io_auth_ok(qmc__io *io, qmc_msg *m)
{
    io_fixed_bytes(io, m->u.auth_ok.mac, sizeof m->u.auth_ok.mac);
}

/* ---- integration sessions (version 5) ------------------------------------------- */

/* A session's name: text of at most QMC_SESSION_NAME_BYTES - 1 bytes held
 * NUL-terminated in a char[QMC_SESSION_NAME_BYTES]. */
static void io_session_name(qmc__io *io, char *name)
{
    qmc_str s = {name, 0};
    if (!io->decode) {
        const char *nul = memchr(name, '\0', QMC_SESSION_NAME_BYTES);
        if (!nul) {
            qmc__io_invalid(io);
            return;
        }
        s.len = (uint32_t)(nul - name);
    }
    qmc__io_str(io, &s, QMC_SESSION_NAME_BYTES - 1, QMC__STR_TEXT);
    if (io->decode) {
        memset(name, 0, QMC_SESSION_NAME_BYTES);
        if (io->err == 0 && s.len)
            memcpy(name, s.ptr, s.len);
    }
}

/* SESSION_OPEN: the session spec (qmc_session_spec without the in-process
 * interrupt hook) and the transport batches should take.  Dims, parts and
 * budgets are the daemon's to check (qmc_session_new), as INTEGRATE leaves
 * them to qmc_job_new. */
static void io_session_open(qmc__io *io, qmc_msg *m)
{
    qmc_msg_session_open *o = &m->u.session_open;
    qmc_session_spec *s = &o->spec;
    qmc_integrate_spec *in = &s->integrate;
    IO_ENUM(io, in->method, method_ok);
    IO_ENUM(io, s->smoothness, smoothness_ok);
    IO_ENUM(io, o->transport, transport_ok);
    qmc__io_bool(io, &in->n_given);
    qmc__io_u32(io, &s->dims);
    qmc__io_u32(io, &in->n_axis);
    qmc__io_bool(io, &s->has_exact);
    qmc__io_zero(io, 3);
    qmc__io_u32(io, &s->part_k);
    qmc__io_u32(io, &s->part_p);
    qmc__io_u64(io, &in->max_evals);
    qmc__io_u64(io, &in->max_memory);
    qmc__io_u64(io, &s->max_batch);
    qmc__io_f64_finite(io, &in->tol_abs);
    qmc__io_f64_finite(io, &in->tol_rel);
    qmc__io_f64_finite(io, &s->exact);
    qmc__io_sampling(io, &in->sampling, 1);
    io_session_name(io, s->name);
    if (io->decode)
        memset(&in->interrupt, 0, sizeof in->interrupt); /* in-process only */
}

static void io_session_opened(qmc__io *io, qmc_msg *m)
{
    qmc_msg_session_opened *o = &m->u.session_opened;
    qmc__io_u64(io, &o->session_id);
    io_token(io, o->token);
    qmc__io_u32(io, &o->dims);
    qmc__io_zero(io, 4);
    qmc__io_u64(io, &o->max_batch);
    qmc__io_u64(io, &o->memory_bytes);
    qmc__io_u64(io, &o->park_ms);
}

/* SESSION_BATCH's or SESSION_VALUES' data: inline, len bytes follow;
 * through the ring it is in a slot (a decoded message has no pointer). */
static void io_ring_or_inline(qmc__io *io, int ring, const uint8_t **data, uint32_t len)
{
    if (!ring)
        qmc__io_blob(io, data, len);
    else if (io->decode)
        *data = NULL;
}

/* SESSION_BATCH: a piece of whole points inside its batch; inline the
 * coordinates follow (at most a chunk's bytes), through the ring they are
 * in the slot named and the piece's values must fit after them in a slot
 * of the largest size. */
static void io_session_batch(qmc__io *io, qmc_msg *m)
{
    qmc_msg_session_batch *b = &m->u.session_batch;
    qmc__io_u64(io, &b->seq);
    qmc__io_u64(io, &b->count);
    qmc__io_u64(io, &b->first);
    qmc__io_u32(io, &b->points);
    qmc__io_u32(io, &b->dims);
    IO_ENUM(io, b->transport, transport_ok);
    qmc__io_zero(io, 3);
    qmc__io_u32(io, &b->slot);
    qmc__io_u32(io, &b->data_len);
    if (io->err || io->rd.bad)
        return;
    const uint64_t bytes = (uint64_t)b->points * b->dims * 8;
    const int ring = b->transport == QMC_TRANSPORT_SHM;
    if (b->points == 0 || b->dims == 0 || b->first > b->count ||
        b->points > b->count - b->first || bytes != b->data_len ||
        (ring ? b->slot >= QMC_PROTO_SHM_MAX_SLOTS ||
                    bytes + 8ull * b->points > QMC_PROTO_SHM_MAX_SLOT_BYTES
              : b->slot != 0 || bytes > QMC_PROTO_CHUNK_BYTES)) {
        qmc__io_invalid(io);
        return;
    }
    io_ring_or_inline(io, ring, &b->data, b->data_len);
}

/* SESSION_VALUES: values of whole points; inline they follow, through the
 * ring they sit after the piece's points in its slot. */
static void io_session_values(qmc__io *io, qmc_msg *m)
{
    qmc_msg_session_values *v = &m->u.session_values;
    qmc__io_u64(io, &v->session_id);
    qmc__io_u64(io, &v->seq);
    qmc__io_u64(io, &v->first);
    qmc__io_u32(io, &v->count);
    IO_ENUM(io, v->transport, transport_ok);
    qmc__io_zero(io, 3);
    qmc__io_u32(io, &v->slot);
    qmc__io_u32(io, &v->data_len);
    if (io->err || io->rd.bad)
        return;
    const int ring = v->transport == QMC_TRANSPORT_SHM;
    if (v->count == 0 ||
        (ring ? v->slot >= QMC_PROTO_SHM_MAX_SLOTS || v->data_len != 0 ||
                    v->count > QMC_PROTO_SHM_MAX_SLOT_BYTES / 8
              : v->slot != 0 || v->count > QMC_PROTO_SESSION_MAX_VALUES ||
                    v->data_len != 8 * v->count)) {
        qmc__io_invalid(io);
        return;
    }
    io_ring_or_inline(io, ring, &v->data, v->data_len);
}

/* SESSION_REPORT: qmc_session_status's report.  The flags are the running
 * result's, told as the version defines them; err is a failed session's
 * error and only its. */
static void io_session_report(qmc__io *io, qmc_msg *m)
{
    qmc_msg_session_report *r = &m->u.session_report;
    qmc_session_report *p = &r->report;
    qmc_result *res = &p->running;
    qmc__io_u64(io, &r->session_id);
    qmc__io_u64(io, &p->batches);
    qmc__io_u64(io, &p->evals);
    qmc__io_u64(io, &p->nonfinite);
    IO_ENUM(io, p->end, session_end_ok);
    qmc__io_bool(io, &p->has_estimate);
    IO_ENUM(io, res->error_kind, kind3_ok);
    qmc__io_zero(io, 1);
    io_result_flags(io, &res->flags);
    int32_t err = p->err;
    qmc__io_i32(io, &err);
    p->err = err;
    qmc__io_u32(io, &res->dims);
    qmc__io_u64(io, &res->n);
    qmc__io_u64(io, &res->evals);
    qmc__io_u64(io, &res->nonfinite);
    qmc__io_f64(io, &res->estimate);
    qmc__io_f64(io, &res->error);
    qmc__io_f64(io, &res->ci_low);
    qmc__io_f64(io, &res->ci_high);
    qmc__io_f64(io, &res->abs_integral);
    if (io->err == 0 && !io->rd.bad &&
        (p->err > 0 || (p->end == QMC_SESSION_FAILED) != (p->err != 0)))
        qmc__io_invalid(io);
}

static void io_session_resume(qmc__io *io, qmc_msg *m)
{
    qmc_msg_session_ref *r = &m->u.session_ref;
    qmc__io_u64(io, &r->session_id);
    io_token(io, r->token);
    IO_ENUM(io, r->transport, transport_ok);
    qmc__io_zero(io, 7);
}

static void io_session_close(qmc__io *io, qmc_msg *m)
{
    qmc_msg_session_ref *r = &m->u.session_ref;
    qmc__io_u64(io, &r->session_id);
    io_token(io, r->token);
    if (io->decode)
        r->transport = QMC_TRANSPORT_INLINE; /* not on the wire */
}

/* ---- the table ---------------------------------------------------------------
 * Which layout each message uses, and its payload bounds.  Every name in
 * QMC_MSG_MAP needs a LAYOUT_ line: a missing one fails to compile. */

#define LAYOUT_HELLO io_hello, FIXED_HELLO + STR16, FIXED_HELLO + STR16 + QMC_PROTO_MAX_NAME
#define LAYOUT_HELLO_OK \
    io_hello_ok, FIXED_HELLO_OK + 2 * STR16, FIXED_HELLO_OK + 2 * (STR16 + QMC_PROTO_MAX_NAME)
#define LAYOUT_PING io_ping, STR16, STR16 + QMC_PROTO_MAX_PING
#define LAYOUT_PONG LAYOUT_PING
#define LAYOUT_POINTS io_points, FIXED_POINTS, FIXED_POINTS
#define LAYOUT_POINTS_CHUNK io_chunk, FIXED_CHUNK + 4, FIXED_CHUNK + QMC_PROTO_CHUNK_BYTES
#define LAYOUT_END io_end, FIXED_END, FIXED_END
#define LAYOUT_INTEGRATE                                                          \
    io_integrate, FIXED_INTEGRATE + 2 * STR16 + 3 * LEN32,                       \
        FIXED_INTEGRATE + 2 * (STR16 + QMC_JOB_NAME_BYTES - 1) +                 \
            2 * (LEN32 + 8 * QMC_PROTO_MAX_LIST) + LEN32 + QMC_SCENE_MAX_BYTES
#define LAYOUT_JOB_ACCEPTED io_job_id, FIXED_JOB_ID, FIXED_JOB_ID
#define LAYOUT_JOB_PROGRESS io_progress, FIXED_PROGRESS, FIXED_PROGRESS
#define LAYOUT_JOB_RESULT                            \
    io_result, FIXED_RESULT + 2 * STR16,             \
        FIXED_RESULT + 2 * (STR16 + QMC_PROTO_MAX_MESSAGE) + QMC__KNOWN_ABS_BYTES
#define LAYOUT_JOB_STATUS LAYOUT_JOB_ACCEPTED
#define LAYOUT_JOB_STATE io_state, FIXED_STATE, FIXED_STATE
#define LAYOUT_JOB_CANCEL LAYOUT_JOB_ACCEPTED
#define LAYOUT_STATS io_empty, 0, 0
#define LAYOUT_STATS_REPLY \
    io_stats_reply, FIXED_STATS, FIXED_STATS + QMC_PROTO_MAX_STATS * (STAT_MIN + QMC_PROTO_MAX_NAME)
#define LAYOUT_ERROR io_error, FIXED_ERROR + STR16, FIXED_ERROR + STR16 + QMC_PROTO_MAX_MESSAGE
#define LAYOUT_SHM_ATTACH io_shm, FIXED_SHM, FIXED_SHM
#define LAYOUT_SHM_OK LAYOUT_SHM_ATTACH
#define LAYOUT_POINTS_SHM_CHUNK io_shm_chunk, FIXED_SHM_CHUNK, FIXED_SHM_CHUNK
#define LAYOUT_SHM_RELEASE io_shm_release, FIXED_SHM_RELEASE, FIXED_SHM_RELEASE
#define LAYOUT_AUTH_CHALLENGE io_auth_challenge, FIXED_AUTH_CHALLENGE, FIXED_AUTH_CHALLENGE
#define LAYOUT_AUTH_RESPONSE io_auth_response, FIXED_AUTH_RESPONSE, FIXED_AUTH_RESPONSE
#define LAYOUT_AUTH_OK io_auth_ok, FIXED_AUTH_OK, FIXED_AUTH_OK
#define LAYOUT_PIXELS io_pixels, FIXED_PIXELS, FIXED_PIXELS
#define LAYOUT_SESSION_OPEN                                                     \
    io_session_open, FIXED_SESSION_OPEN + STR16,                                \
        FIXED_SESSION_OPEN + STR16 + QMC_SESSION_NAME_BYTES - 1
#define LAYOUT_SESSION_OPENED io_session_opened, FIXED_SESSION_OPENED, FIXED_SESSION_OPENED
#define LAYOUT_SESSION_BATCH \
    io_session_batch, FIXED_SESSION_BATCH, FIXED_SESSION_BATCH + QMC_PROTO_CHUNK_BYTES
#define LAYOUT_SESSION_VALUES \
    io_session_values, FIXED_SESSION_VALUES, FIXED_SESSION_VALUES + QMC_PROTO_CHUNK_BYTES
#define LAYOUT_SESSION_REPORT io_session_report, FIXED_SESSION_REPORT, FIXED_SESSION_REPORT
#define LAYOUT_SESSION_RESULT LAYOUT_JOB_RESULT
#define LAYOUT_SESSION_RESUME io_session_resume, FIXED_SESSION_RESUME, FIXED_SESSION_RESUME
#define LAYOUT_SESSION_CLOSE io_session_close, FIXED_SESSION_CLOSE, FIXED_SESSION_CLOSE
/* Version 6: messages_part.c. */
#define LAYOUT_SESSION_PART \
    qmc__io_session_part, QMC__FIXED_SESSION_PART, QMC__FIXED_SESSION_PART
#define LAYOUT_SESSION_PART_SUMS                                                \
    qmc__io_session_part_sums, QMC__FIXED_PART_SUMS + QMC_PROTO_PART_SUMS_BYTES, \
        QMC__FIXED_PART_SUMS + QMC_PROTO_PART_MAX_SUMS * QMC_PROTO_PART_SUMS_BYTES

#define ROW_FIELDS(fn, lo, hi) (lo), (hi), fn
#define ROW_EXPAND(...) ROW_FIELDS(__VA_ARGS__)
#define ROW(name, code, dir) [code] = {#name, dir, ROW_EXPAND(LAYOUT_##name)},

static const qmc__layout layouts[] = {QMC_MSG_MAP(ROW)};

const qmc__layout *qmc__proto_layout(uint32_t type)
{
    if (type >= sizeof layouts / sizeof layouts[0] || layouts[type].name == NULL)
        return NULL;
    return &layouts[type];
}
