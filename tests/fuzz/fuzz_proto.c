/*
 * fuzz_proto.c - libFuzzer target for the wire codec (protocol/).
 *
 * The input is a byte stream as a peer might send it.  Frames are decoded
 * one after another, once with a small max_payload and once with the
 * largest, until the decoder stops (needs more bytes, or refuses).  Every
 * frame the decoder accepts must be canonical: encoding the decoded
 * message reproduces exactly the bytes consumed, encoded_size agrees, and
 * the re-encoded frame decodes again to the same length; the shared-memory
 * messages keep the bounds a receiver relies on.  Each accepted frame is
 * also decoded as every older protocol version: what an older version
 * accepts is the same message, re-encoded for that version to the same
 * bytes, and it refuses only a JOB_RESULT, SESSION_RESULT or
 * SESSION_REPORT with flags it does not define (PROTOCOL.md section 5) -
 * and every JOB_RESULT and SESSION_RESULT below version 6, which appended
 * the known integral of |f| (section 6.10): encoded for such a version the
 * message is the frame without those 16 bytes, read back as "not told".
 * The session messages keep the bounds their receivers rely on (section
 * 6.21), and a part's (6.22): its blocks are the ones part k/p cuts, its
 * sums records fit a block and read back through qmc_proto_part_sums_at.  Decoding must
 * never touch memory outside the input (ASan) or read uninitialised state.
 *
 * The codec sources are compiled in here (with the fuzzer's coverage
 * flags), so nothing is taken from build/fuzz/libqmcproto.a, which the
 * fuzz rule links for targets such as fuzz_auth.
 */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "../../protocol/codec.c"
#include "../../protocol/fields.c"
#include "../../protocol/known_abs.c"
#include "../../protocol/messages.c"
#include "../../protocol/messages_part.c"
#include "../../protocol/result_flags.c"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* 1 when a decoded PIXELS names a sampler and a format of their tables. */
static int known_pixel_codes(const qmc_msg_pixels *p)
{
    int sampler = 0, format = 0;
#define SAMPLER_IS(name, code, text) sampler |= p->spec.sampler == QMC_PIXEL_##name;
    QMC_PIXEL_SAMPLER_MAP(SAMPLER_IS)
#undef SAMPLER_IS
#define FORMAT_IS(name, code, text, bytes) format |= p->format == QMC_FORMAT_##name;
    QMC_FORMAT_MAP(FORMAT_IS)
#undef FORMAT_IS
    return sampler && format;
}

/* The result flags a frame carries (JOB_RESULT, SESSION_RESULT,
 * SESSION_REPORT: the ones an older version may refuse), or NULL. */
static const uint32_t *result_flags(const qmc_msg *m)
{
    if (m->type == QMC_MSG_JOB_RESULT || m->type == QMC_MSG_SESSION_RESULT)
        return &m->u.result.res.flags;
    if (m->type == QMC_MSG_SESSION_REPORT)
        return &m->u.session_report.report.running.flags;
    return NULL;
}

/* What the daemon and the client rely on in the session messages they
 * accept (PROTOCOL.md section 6.21): 1 when it holds. */
static int session_bounds_hold(const qmc_msg *m)
{
    switch (m->type) {
    case QMC_MSG_SESSION_BATCH: {
        const qmc_msg_session_batch *b = &m->u.session_batch;
        const uint64_t bytes = (uint64_t)b->points * b->dims * 8;
        if (b->points == 0 || b->dims == 0 || b->first > b->count ||
            b->points > b->count - b->first || bytes != b->data_len)
            return 0;
        if (b->transport == QMC_TRANSPORT_SHM)
            return b->slot < QMC_PROTO_SHM_MAX_SLOTS && b->data == NULL &&
                   bytes + 8ull * b->points <= QMC_PROTO_SHM_MAX_SLOT_BYTES;
        return b->transport == QMC_TRANSPORT_INLINE && b->slot == 0 &&
               bytes <= QMC_PROTO_CHUNK_BYTES && b->data != NULL;
    }
    case QMC_MSG_SESSION_VALUES: {
        const qmc_msg_session_values *v = &m->u.session_values;
        if (v->count == 0)
            return 0;
        if (v->transport == QMC_TRANSPORT_SHM)
            return v->slot < QMC_PROTO_SHM_MAX_SLOTS && v->data_len == 0 && v->data == NULL &&
                   v->count <= QMC_PROTO_SHM_MAX_SLOT_BYTES / 8;
        return v->transport == QMC_TRANSPORT_INLINE && v->slot == 0 &&
               v->count <= QMC_PROTO_SESSION_MAX_VALUES && v->data_len == 8 * v->count &&
               v->data != NULL;
    }
    case QMC_MSG_SESSION_REPORT: {
        const qmc_session_report *r = &m->u.session_report.report;
        return (unsigned)r->end <= QMC_SESSION_FAILED && r->err <= 0 &&
               (r->end == QMC_SESSION_FAILED) == (r->err != 0);
    }
    case QMC_MSG_SESSION_OPEN:
        return (unsigned)m->u.session_open.spec.smoothness <= QMC_SMOOTH_SINGULAR &&
               memchr(m->u.session_open.spec.name, '\0', QMC_SESSION_NAME_BYTES) != NULL &&
               isfinite(m->u.session_open.spec.exact);
    case QMC_MSG_SESSION_RESUME:
        return m->u.session_ref.transport == QMC_TRANSPORT_INLINE ||
               m->u.session_ref.transport == QMC_TRANSPORT_SHM;
    case QMC_MSG_SESSION_PART: {
        const qmc_msg_session_part *p = &m->u.session_part;
        return p->blocks >= 1 && p->blocks <= QMC_SAMPLING_MAX_BLOCKS && p->part_k >= 1 &&
               p->part_k <= p->part_p && p->first == p->blocks * (p->part_k - 1) / p->part_p &&
               p->first + p->count == p->blocks * p->part_k / p->part_p;
    }
    case QMC_MSG_SESSION_PART_SUMS: {
        const qmc_msg_session_part_sums *p = &m->u.part_sums;
        if (p->n == 0 || p->n > QMC_PROTO_PART_MAX_SUMS || p->raw == NULL ||
            p->first + p->n > QMC_SAMPLING_MAX_BLOCKS)
            return 0;
        for (uint32_t i = 0; i < p->n; i++) {
            qmc_sampling_sums s;
            qmc_proto_part_sums_at(p, i, &s);
            if (s.block != p->first + i || s.count > QMC_SAMPLING_BLOCK ||
                s.nonfinite > s.count || !(s.top[QMC_SAMPLING_TOP - 1] >= 0.0))
                return 0;
            for (int k = 1; k < QMC_SAMPLING_TOP; k++)
                if (!(s.top[k] <= s.top[k - 1]))
                    return 0;
        }
        return 1;
    }
    default:
        return 1;
    }
}

static uint8_t *again; /* room for one re-encoded frame of any size */

static void check_stream(const uint8_t *data, size_t size, uint32_t max_payload)
{
    size_t off = 0;
    while (off < size) {
        qmc_msg m;
        int n = qmc_proto_decode(data + off, size - off, max_payload, &m);
        if (n == QMC_EAGAIN)
            return;
        if (n < 0) {
            if (n != QMC_EPROTO && n != QMC_ETOOBIG)
                __builtin_trap(); /* only the documented errors */
            if (m.type != 0)
                __builtin_trap(); /* the message is cleared on error */
            return;
        }
        if ((size_t)n < QMC_PROTO_HEADER_BYTES || (size_t)n > size - off)
            __builtin_trap();
        /* The header alone agrees with the full decode. */
        qmc_msg_type type;
        uint64_t id;
        uint32_t plen;
        if (qmc_proto_peek(data + off, size - off, max_payload, &type, &id, &plen) !=
                (int)QMC_PROTO_HEADER_BYTES ||
            type != m.type || id != m.request_id || plen + QMC_PROTO_HEADER_BYTES != (size_t)n)
            __builtin_trap();
        /* encode(decode(x)) == x, byte for byte. */
        size_t want = qmc_proto_encoded_size(&m);
        int e = qmc_proto_encode(&m, again, QMC_PROTO_HEADER_BYTES + QMC_PROTO_MAX_PAYLOAD);
        if (e != n || want != (size_t)n || memcmp(again, data + off, (size_t)n) != 0)
            __builtin_trap();
        /* A buffer one byte short is refused. */
        if (qmc_proto_encode(&m, again, (size_t)n - 1) != QMC_ETOOBIG)
            __builtin_trap();
        qmc_msg m2;
        if (qmc_proto_decode(again, (size_t)n, max_payload, &m2) != n || m2.type != m.type)
            __builtin_trap();
        /* Older versions: the same frame, or a refusal of flags only. */
        for (unsigned v = 1; v < QMC_PROTO_VERSION_MAX; v++) {
            qmc_msg mv;
            int nv = qmc_proto_decode_version(data + off, size - off, max_payload, v, &mv);
            if ((m.type == QMC_MSG_JOB_RESULT || m.type == QMC_MSG_SESSION_RESULT) &&
                v < QMC_PROTO_VERSION_KNOWN_ABS) {
                if (nv != QMC_EPROTO)
                    __builtin_trap();
                if (*result_flags(&m) & ~qmc_proto_result_flags_defined(v))
                    continue; /* projected flags: test_proto_flags.c's matter */
                const int short_n = n - (int)QMC__KNOWN_ABS_BYTES;
                if (qmc_proto_encode_version(&m, v, again, QMC_PROTO_HEADER_BYTES +
                                                               QMC_PROTO_MAX_PAYLOAD) != short_n ||
                    memcmp(again + QMC_PROTO_HEADER_BYTES, data + off + QMC_PROTO_HEADER_BYTES,
                           (size_t)short_n - QMC_PROTO_HEADER_BYTES) != 0 ||
                    qmc_proto_decode_version(again, (size_t)short_n, max_payload, v, &mv) !=
                        short_n ||
                    mv.u.result.has_known_abs != -1)
                    __builtin_trap();
                continue;
            }
            if (nv == QMC_EPROTO) {
                if (result_flags(&m) == NULL ||
                    (*result_flags(&m) & ~qmc_proto_result_flags_defined(v)) == 0)
                    __builtin_trap();
                continue;
            }
            if (nv != n || mv.type != m.type ||
                qmc_proto_encode_version(&mv, v, again,
                                         QMC_PROTO_HEADER_BYTES + QMC_PROTO_MAX_PAYLOAD) != n ||
                memcmp(again, data + off, (size_t)n) != 0)
                __builtin_trap();
        }
        /* Every list element and stats entry is readable. */
        if (m.type == QMC_MSG_INTEGRATE) {
            volatile double sink = 0;
            for (uint32_t i = 0; i < m.u.integrate.a.count; i++)
                sink += qmc_proto_f64_at(&m.u.integrate.a, i);
            (void)sink;
        }
        if (m.type == QMC_MSG_STATS_REPLY)
            for (uint32_t i = 0; i < m.u.stats.count; i++)
                if (qmc_proto_stat_at(&m.u.stats, i).name.len > QMC_PROTO_MAX_NAME)
                    __builtin_trap();
        /* The shared-memory messages: what a receiver relies on before it
         * touches a ring (PROTOCOL.md section 10) holds for every frame the
         * decoder accepts. */
        if ((m.type == QMC_MSG_SHM_ATTACH || m.type == QMC_MSG_SHM_OK) &&
            (m.u.shm.slots < QMC_PROTO_SHM_MIN_SLOTS || m.u.shm.slots > QMC_PROTO_SHM_MAX_SLOTS ||
             m.u.shm.slot_bytes < QMC_PROTO_SHM_MIN_SLOT_BYTES ||
             m.u.shm.slot_bytes > QMC_PROTO_SHM_MAX_SLOT_BYTES ||
             m.u.shm.slot_bytes % QMC_PROTO_SHM_SLOT_ALIGN != 0))
            __builtin_trap();
        if (m.type == QMC_MSG_POINTS_SHM_CHUNK &&
            (m.u.shm_chunk.slot >= QMC_PROTO_SHM_MAX_SLOTS || m.u.shm_chunk.points == 0 ||
             m.u.shm_chunk.data_len > QMC_PROTO_SHM_MAX_SLOT_BYTES ||
             m.u.shm_chunk.data_len % m.u.shm_chunk.points != 0))
            __builtin_trap();
        if (m.type == QMC_MSG_SHM_RELEASE &&
            (m.u.release.slots == 0 || m.u.release.slots > QMC_PROTO_SHM_MAX_SLOTS))
            __builtin_trap();
        if (m.type == QMC_MSG_POINTS && m.u.points.transport != QMC_TRANSPORT_INLINE &&
            m.u.points.transport != QMC_TRANSPORT_SHM)
            __builtin_trap();
        /* PIXELS: the codes a daemon switches on are ones the tables have. */
        if (m.type == QMC_MSG_PIXELS &&
            ((m.u.pixels.transport != QMC_TRANSPORT_INLINE &&
              m.u.pixels.transport != QMC_TRANSPORT_SHM) ||
             !known_pixel_codes(&m.u.pixels)))
            __builtin_trap();
        if (!session_bounds_hold(&m))
            __builtin_trap();
        off += (size_t)n;
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (again == NULL) {
        again = malloc(QMC_PROTO_HEADER_BYTES + QMC_PROTO_MAX_PAYLOAD);
        if (again == NULL)
            return 0;
    }
    check_stream(data, size, 64);
    check_stream(data, size, QMC_PROTO_MAX_PAYLOAD);
    return 0;
}
