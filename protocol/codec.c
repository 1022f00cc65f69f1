/*
 * codec.c - frames: the 24-byte header, decoding one frame from a buffer
 * (bytes consumed, QMC_EAGAIN or an error, picohttpparser's habit),
 * encoding one into a caller's buffer, the zero-copy POINTS_CHUNK prefix,
 * and the accessors and names of proto.h.  The payloads themselves are in
 * messages.c, built from the field helpers of fields.c.
 *
 * It must not do I/O, allocate, keep state or print: the daemon and the
 * client own sockets and buffers, and call this on bytes they hold.
 */
#include <string.h>

#include "codec.h"

/* Header offsets (proto.h, PROTOCOL.md section 2). */
enum {
    OFF_MAGIC = 0,
    OFF_VERSION = 4,
    OFF_TYPE = 5,
    OFF_FLAGS = 6,
    OFF_REQUEST_ID = 8,
    OFF_PAYLOAD_LEN = 16,
    OFF_RESERVED = 20
};

/* Checks the header bytes present so far, so that garbage is refused as
 * soon as it arrives rather than after 24 bytes: 1 if they can still
 * begin a valid header. */
static int header_prefix_ok(const uint8_t *b, size_t n)
{
    static const uint8_t magic[4] = {0x51, 0x4d, 0x43, 0x44}; /* "QMCD" */
    for (size_t i = 0; i < n && i < OFF_VERSION; i++)
        if (b[i] != magic[i])
            return 0;
    if (n > OFF_VERSION && b[OFF_VERSION] != QMC_PROTO_VERSION)
        return 0;
    if (n > OFF_TYPE && qmc__proto_layout(b[OFF_TYPE]) == NULL)
        return 0;
    for (size_t i = OFF_FLAGS; i < n && i < OFF_REQUEST_ID; i++)
        if (b[i] != 0)
            return 0;
    for (size_t i = OFF_RESERVED; i < n && i < QMC_PROTO_HEADER_BYTES; i++)
        if (b[i] != 0)
            return 0;
    return 1;
}

int qmc_proto_peek(const uint8_t *buf, size_t len, uint32_t max_payload,
                   qmc_msg_type *type, uint64_t *request_id, uint32_t *payload_len)
{
    qmc_msg_type t = (qmc_msg_type)0;
    uint64_t id = 0;
    uint32_t plen = 0;
    int ret;
    if (buf == NULL && len > 0) {
        ret = QMC_EINVAL;
        goto out;
    }
    if (!header_prefix_ok(buf, len)) {
        ret = QMC_EPROTO;
        goto out;
    }
    if (len < QMC_PROTO_HEADER_BYTES) {
        ret = QMC_EAGAIN;
        goto out;
    }
    plen = qmc__load_u32(buf + OFF_PAYLOAD_LEN);
    /* The size limit before anything about the payload, so a hostile
     * length costs the receiver nothing. */
    if (plen > max_payload || plen > QMC_PROTO_MAX_PAYLOAD) {
        plen = 0;
        ret = QMC_ETOOBIG;
        goto out;
    }
    const qmc__layout *lay = qmc__proto_layout(buf[OFF_TYPE]);
    if (plen < lay->min_payload || plen > lay->max_payload) {
        plen = 0;
        ret = QMC_EPROTO;
        goto out;
    }
    t = (qmc_msg_type)buf[OFF_TYPE];
    id = qmc__load_u64(buf + OFF_REQUEST_ID);
    ret = (int)QMC_PROTO_HEADER_BYTES;
out:
    if (type)
        *type = t;
    if (request_id)
        *request_id = id;
    if (payload_len)
        *payload_len = plen;
    return ret;
}

static int version_ok(unsigned version)
{
    return version >= 1 && version <= QMC_PROTO_VERSION_MAX;
}

int qmc_proto_decode(const uint8_t *buf, size_t len, uint32_t max_payload, qmc_msg *out)
{
    return qmc_proto_decode_version(buf, len, max_payload, QMC_PROTO_VERSION_MAX, out);
}

int qmc_proto_decode_version(const uint8_t *buf, size_t len, uint32_t max_payload,
                             unsigned version, qmc_msg *out)
{
    if (out == NULL)
        return QMC_EINVAL;
    memset(out, 0, sizeof *out);
    if (!version_ok(version))
        return QMC_EINVAL;
    qmc_msg_type type;
    uint64_t id;
    uint32_t plen;
    int ret = qmc_proto_peek(buf, len, max_payload, &type, &id, &plen);
    if (ret < 0)
        return ret;
    if (len - QMC_PROTO_HEADER_BYTES < plen)
        return QMC_EAGAIN;
    qmc__io io = {.decode = 1,
                  .rd = qmc__rd_make(buf + QMC_PROTO_HEADER_BYTES, plen),
                  .version = version};
    out->type = type;
    out->request_id = id;
    qmc__proto_layout(type)->io(&io, out);
    /* Every byte of the payload belongs to a field: a short read or bytes
     * left over both mean the lengths disagree. */
    if (io.err == 0 && (io.rd.bad || io.rd.left != 0))
        io.err = QMC_EPROTO;
    if (io.err) {
        memset(out, 0, sizeof *out);
        return io.err;
    }
    return (int)(QMC_PROTO_HEADER_BYTES + plen);
}

static void put_header(uint8_t *p, uint32_t type, uint64_t request_id, uint32_t payload_len)
{
    qmc__store_u32(p + OFF_MAGIC, QMC_PROTO_MAGIC);
    p[OFF_VERSION] = QMC_PROTO_VERSION;
    p[OFF_TYPE] = (uint8_t)type;
    qmc__store_u16(p + OFF_FLAGS, 0);
    qmc__store_u64(p + OFF_REQUEST_ID, request_id);
    qmc__store_u32(p + OFF_PAYLOAD_LEN, payload_len);
    qmc__store_u32(p + OFF_RESERVED, 0);
}

/* Runs the layout over a copy of msg (the layouts take a mutable message,
 * as decoding needs; encoding only normalises the copy).  buf NULL:
 * validate and measure only.  Returns the payload length or an error. */
static int encode_payload(const qmc_msg *msg, unsigned version, uint8_t *buf, size_t cap,
                          size_t *payload_len)
{
    *payload_len = 0;
    if (msg == NULL || !version_ok(version))
        return QMC_EINVAL;
    const qmc__layout *lay = qmc__proto_layout((uint32_t)msg->type);
    if (lay == NULL)
        return QMC_EINVAL;
    qmc_msg tmp = *msg;
    qmc__io io = {.decode = 0, .wr = qmc__wr_make(buf, cap), .version = version};
    lay->io(&io, &tmp);
    if (io.err)
        return io.err;
    if (io.wr.bad)
        return QMC_ETOOBIG;
    /* The field limits imply the bounds; this only guards the table. */
    if (io.wr.len < lay->min_payload || io.wr.len > lay->max_payload)
        return QMC_EINVAL;
    *payload_len = io.wr.len;
    return 0;
}

size_t qmc_proto_encoded_size(const qmc_msg *msg)
{
    return qmc_proto_encoded_size_version(msg, QMC_PROTO_VERSION_MAX);
}

size_t qmc_proto_encoded_size_version(const qmc_msg *msg, unsigned version)
{
    size_t plen;
    if (encode_payload(msg, version, NULL, 0, &plen) != 0)
        return 0;
    return QMC_PROTO_HEADER_BYTES + plen;
}

int qmc_proto_encode(const qmc_msg *msg, uint8_t *buf, size_t cap)
{
    return qmc_proto_encode_version(msg, QMC_PROTO_VERSION_MAX, buf, cap);
}

int qmc_proto_encode_version(const qmc_msg *msg, unsigned version, uint8_t *buf, size_t cap)
{
    size_t plen;
    if (buf == NULL || cap < QMC_PROTO_HEADER_BYTES) {
        /* Report a bad message as such before a small buffer. */
        int err = encode_payload(msg, version, NULL, 0, &plen);
        return err ? err : QMC_ETOOBIG;
    }
    /* One pass: the write cursor is sticky and bounded by cap, and field
     * errors are reported before "did not fit" - so there is no need to
     * measure first (the daemon encodes a frame per small answer). */
    int err = encode_payload(msg, version, buf + QMC_PROTO_HEADER_BYTES,
                             cap - QMC_PROTO_HEADER_BYTES, &plen);
    if (err)
        return err;
    put_header(buf, (uint32_t)msg->type, msg->request_id, (uint32_t)plen);
    return (int)(QMC_PROTO_HEADER_BYTES + plen);
}

int qmc_proto_encode_chunk_prefix(uint64_t request_id, uint64_t first, uint32_t points,
                                  uint32_t data_len, uint8_t *buf, size_t cap)
{
    /* The same frame qmc_proto_encode makes for this chunk, less the data:
     * the layout checks points against data_len. */
    qmc_msg m = {.type = QMC_MSG_POINTS_CHUNK, .request_id = request_id};
    m.u.chunk.first = first;
    m.u.chunk.points = points;
    m.u.chunk.data_len = data_len;
    if (data_len > QMC_PROTO_CHUNK_BYTES)
        return QMC_ETOOBIG;
    static const uint8_t no_data[1];
    m.u.chunk.data = no_data; /* only measured: the caller writes the data */
    size_t plen;
    int err = encode_payload(&m, QMC_PROTO_VERSION_MAX, NULL, 0, &plen);
    if (err)
        return err;
    size_t prefix = QMC_PROTO_HEADER_BYTES + plen - data_len;
    if (buf == NULL || cap < prefix)
        return QMC_ETOOBIG;
    qmc__wr w = qmc__wr_make(buf + QMC_PROTO_HEADER_BYTES, prefix - QMC_PROTO_HEADER_BYTES);
    qmc__wr_u64(&w, first);
    qmc__wr_u32(&w, points);
    qmc__wr_u32(&w, data_len);
    if (w.bad || w.len != prefix - QMC_PROTO_HEADER_BYTES)
        return QMC_EINVAL; /* the prefix above and io_chunk disagree */
    put_header(buf, QMC_MSG_POINTS_CHUNK, request_id, (uint32_t)plen);
    return (int)prefix;
}

int qmc_proto_encode_session_values_prefix(uint64_t request_id,
                                           const qmc_msg_session_values *v, uint8_t *buf,
                                           size_t cap)
{
    if (v == NULL || v->transport != QMC_TRANSPORT_INLINE)
        return QMC_EINVAL;
    qmc_msg m = {.type = QMC_MSG_SESSION_VALUES, .request_id = request_id};
    m.u.session_values = *v;
    static const uint8_t no_data[1];
    m.u.session_values.data = no_data; /* only measured: the caller writes the data */
    size_t plen;
    int err = encode_payload(&m, QMC_PROTO_VERSION_MAX, NULL, 0, &plen);
    if (err)
        return err;
    const size_t prefix = QMC_PROTO_HEADER_BYTES + plen - v->data_len;
    if (buf == NULL || cap < prefix)
        return QMC_ETOOBIG;
    /* The layout itself writes the fields: its data put finds no room
     * (the cursor ends at the prefix) and is dropped, everything before it
     * is written - one layout, not a copy of it here. */
    qmc__io io = {.decode = 0,
                  .wr = qmc__wr_make(buf + QMC_PROTO_HEADER_BYTES,
                                     prefix - QMC_PROTO_HEADER_BYTES),
                  .version = QMC_PROTO_VERSION_MAX};
    qmc__proto_layout(QMC_MSG_SESSION_VALUES)->io(&io, &m);
    if (io.err)
        return io.err;
    put_header(buf, QMC_MSG_SESSION_VALUES, request_id, (uint32_t)plen);
    return (int)prefix;
}

double qmc_proto_f64_at(const qmc_f64s *list, uint32_t i)
{
    if (list == NULL || i >= list->count)
        return 0.0;
    if (list->values)
        return list->values[i];
    if (list->raw)
        return qmc__load_f64(list->raw + 8 * (size_t)i);
    return 0.0;
}

qmc_stat qmc_proto_stat_at(const qmc_msg_stats_reply *r, uint32_t i)
{
    qmc_stat st = {{NULL, 0}, 0};
    if (r == NULL || i >= r->count)
        return st;
    if (r->entries)
        return r->entries[i];
    if (r->raw == NULL)
        return st;
    /* Entries vary in length: walk to entry i (count <= QMC_PROTO_MAX_STATS,
     * and the decoder has already checked every one). */
    qmc__rd rd = qmc__rd_make(r->raw, r->raw_len);
    for (uint32_t k = 0;; k++) {
        uint16_t len = qmc__rd_u16(&rd);
        const uint8_t *name = qmc__rd_take(&rd, len);
        uint64_t value = qmc__rd_u64(&rd);
        if (rd.bad)
            return st;
        if (k == i) {
            st.name.ptr = (const char *)name;
            st.name.len = len;
            st.value = value;
            return st;
        }
    }
}

const char *qmc_msg_type_name(qmc_msg_type type)
{
    const qmc__layout *lay = qmc__proto_layout((uint32_t)type);
    return lay ? lay->name : "";
}

const char *qmc_job_state_name(qmc_job_state state)
{
    switch (state) {
#define QMC__STATE_NAME(name, code, text) \
    case QMC_JOB_##name:                  \
        return text;
        QMC_JOB_STATE_MAP(QMC__STATE_NAME)
#undef QMC__STATE_NAME
    }
    return "";
}
