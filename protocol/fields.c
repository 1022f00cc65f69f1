/*
 * fields.c - the field helpers every payload layout is built from (see
 * codec.h) for strings and lists, each read and checked or checked and
 * written in one place.  The fixed-width fields are inline in codec.h.
 *
 * No I/O, no allocation, no global state: decoded strings and lists are
 * views into the caller's buffer.
 */
#include <math.h>
#include <string.h>

#include "codec.h"

/* RFC 3629: no overlong forms, no surrogates, nothing past U+10FFFF. */
int qmc__utf8_ok(const uint8_t *p, size_t n)
{
    size_t i = 0;
    while (i < n) {
        uint8_t c = p[i];
        if (c == 0)
            return 0;
        if (c < 0x80) {
            i++;
            continue;
        }
        size_t more;
        uint8_t lo = 0x80, hi = 0xbf; /* allowed range of the 2nd byte */
        if (c >= 0xc2 && c <= 0xdf) {
            more = 1;
        } else if (c >= 0xe0 && c <= 0xef) {
            more = 2;
            if (c == 0xe0)
                lo = 0xa0;
            else if (c == 0xed)
                hi = 0x9f;
        } else if (c >= 0xf0 && c <= 0xf4) {
            more = 3;
            if (c == 0xf0)
                lo = 0x90;
            else if (c == 0xf4)
                hi = 0x8f;
        } else {
            return 0;
        }
        if (more > n - i - 1)
            return 0;
        if (p[i + 1] < lo || p[i + 1] > hi)
            return 0;
        for (size_t k = 2; k <= more; k++)
            if ((p[i + k] & 0xc0) != 0x80)
                return 0;
        i += more + 1;
    }
    return 1;
}

void qmc__io_str(qmc__io *io, qmc_str *s, uint32_t max, int flags)
{
    int len32 = (flags & QMC__STR_LEN32) != 0;
    if (io->decode) {
        uint32_t len = len32 ? qmc__rd_u32(&io->rd) : qmc__rd_u16(&io->rd);
        /* The limit first, so a hostile length is refused before the
         * cursor is asked for that many bytes. */
        if (qmc__io_rd_ok(io) && len > max)
            qmc__io_invalid(io);
        if (io->err)
            return;
        const uint8_t *p = qmc__rd_take(&io->rd, len);
        if (!qmc__io_rd_ok(io))
            return;
        if ((flags & QMC__STR_TEXT) && !qmc__utf8_ok(p, len)) {
            qmc__io_invalid(io);
            return;
        }
        s->ptr = (const char *)p;
        s->len = len;
        return;
    }
    if (s->len > max || (len32 ? 0 : s->len > UINT16_MAX) || (s->len && !s->ptr) ||
        ((flags & QMC__STR_TEXT) && !qmc__utf8_ok((const uint8_t *)s->ptr, s->len))) {
        qmc__io_invalid(io);
        return;
    }
    if (len32)
        qmc__wr_u32(&io->wr, s->len);
    else
        qmc__wr_u16(&io->wr, (uint16_t)s->len);
    qmc__wr_bytes(&io->wr, s->ptr, s->len);
}

void qmc__io_name(qmc__io *io, char *name)
{
    qmc_str s = {name, 0};
    if (!io->decode) {
        const char *nul = memchr(name, '\0', QMC_JOB_NAME_BYTES);
        if (!nul) {
            qmc__io_invalid(io);
            return;
        }
        s.len = (uint32_t)(nul - name);
    }
    qmc__io_str(io, &s, QMC_JOB_NAME_BYTES - 1, QMC__STR_TEXT);
    if (io->decode) {
        memset(name, 0, QMC_JOB_NAME_BYTES);
        if (io->err == 0 && s.len)
            memcpy(name, s.ptr, s.len);
    }
}

void qmc__io_f64s(qmc__io *io, qmc_f64s *list, uint32_t max, int finite)
{
    if (io->decode) {
        uint32_t count = qmc__rd_u32(&io->rd);
        if (qmc__io_rd_ok(io) && count > max)
            qmc__io_invalid(io);
        if (io->err)
            return;
        const uint8_t *raw = qmc__rd_take(&io->rd, (size_t)count * 8);
        if (!qmc__io_rd_ok(io))
            return;
        for (uint32_t i = 0; finite && i < count; i++)
            if (!isfinite(qmc__load_f64(raw + 8 * (size_t)i))) {
                qmc__io_invalid(io);
                return;
            }
        list->values = NULL;
        list->raw = count ? raw : NULL;
        list->count = count;
        return;
    }
    if (list->count > max || (list->count && !list->values && !list->raw)) {
        qmc__io_invalid(io);
        return;
    }
    for (uint32_t i = 0; finite && i < list->count; i++)
        if (!isfinite(qmc_proto_f64_at(list, i))) {
            qmc__io_invalid(io);
            return;
        }
    qmc__wr_u32(&io->wr, list->count);
    if (list->values == NULL) {
        /* A decoded list: its raw bytes are already the wire form. */
        qmc__wr_bytes(&io->wr, list->raw, (size_t)list->count * 8);
        return;
    }
    for (uint32_t i = 0; i < list->count; i++) {
        uint8_t *p = qmc__wr_take(&io->wr, 8);
        if (p)
            qmc__store_f64(p, list->values[i]);
    }
}

void qmc__io_blob(qmc__io *io, const uint8_t **data, uint32_t len)
{
    if (io->decode) {
        const uint8_t *p = qmc__rd_take(&io->rd, len);
        if (qmc__io_rd_ok(io))
            *data = len ? p : NULL;
        return;
    }
    if (len && !*data) {
        qmc__io_invalid(io);
        return;
    }
    qmc__wr_bytes(&io->wr, *data, len);
}
