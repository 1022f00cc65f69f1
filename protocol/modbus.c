/*
 * modbus.c - the Modbus request handler: (request PDU, session) ->
 * response PDU or exception, over the register map of protocol/MODBUS.md.
 *
 * Every field is read through the bounds-checked big-endian cursor of
 * modbus_pdu.h, and every length the request states is checked against
 * the bytes that came (the class of bug behind libmodbus's reply-path
 * CVEs: CVE-2019-14462/14463, CVE-2022-0367, CVE-2024-10918).  Checks run
 * in the order of the spec's state diagrams (Modbus application protocol
 * v1.1b3, section 6): function code (01), quantity and length (03),
 * address (02), then value and execution (03, 04).  A write that is
 * refused stores nothing.
 *
 * Must not: do I/O, read a clock, keep global state, or print.  Points come
 * from the same core calls as `qmc points` (qmc_seq_new, qmc_seq_fill), so
 * the registers hold exactly the numbers it prints.
 */
#include <stdlib.h>
#include <string.h>

#include "modbus_integrate.h"
#include "modbus_pdu.h"
#include "qmc/modbus.h"
#include "qmc/seq.h"

struct qmc_modbus_session {
    uint16_t hr[QMC_MODBUS_HOLDING_COUNT];     /* holding registers 0..12 */
    uint16_t result[QMC_MODBUS_RESULT_REGS];   /* the result block */
    int has_result;                            /* a request number was served */
    qmc_seq *seq;                              /* built for seq_spec, or NULL */
    qmc_seq_spec seq_spec;
    qmc__mb_integ integ;                       /* 300..323, 400..495 (modbus_integrate.c) */
};

static const uint16_t hr_min[QMC_MODBUS_HOLDING_COUNT] = {
#define HR_MIN(name, addr, lo, hi) [addr] = (lo),
    QMC_MODBUS_HOLDING_MAP(HR_MIN)
#undef HR_MIN
};
static const uint16_t hr_max[QMC_MODBUS_HOLDING_COUNT] = {
#define HR_MAX(name, addr, lo, hi) [addr] = (hi),
    QMC_MODBUS_HOLDING_MAP(HR_MAX)
#undef HR_MAX
};

const char *qmc_modbus_exception_name(int code)
{
    switch (code) {
#define EXC_NAME(name, c, text) \
    case c:                     \
        return text;
        QMC_MODBUS_EXC_MAP(EXC_NAME)
#undef EXC_NAME
    }
    return "";
}

const char *qmc_modbus_status_name(int code)
{
    switch (code) {
#define ST_NAME(name, c, text) \
    case c:                    \
        return text;
        QMC_MODBUS_STATUS_MAP(ST_NAME)
#undef ST_NAME
    }
    return "";
}

static uint64_t get_u64(const uint16_t *r)
{
    uint64_t v = 0;
    for (int i = 0; i < 4; i++)
        v = v << 16 | r[i];
    return v;
}

int qmc_modbus_session_new(qmc_modbus_session **out)
{
    *out = NULL;
    qmc_modbus_session *s = calloc(1, sizeof *s);
    if (!s)
        return QMC_ENOMEM;
    s->hr[QMC_MODBUS_HR_KIND] = QMC_MODBUS_KIND_SOBOL;
    s->hr[QMC_MODBUS_HR_DIMS] = 2;
    s->result[1] = QMC_MODBUS_STATUS_NO_REQUEST;
    qmc__mb_integ_init(&s->integ);
    *out = s;
    return 0;
}

void qmc_modbus_session_free(qmc_modbus_session *s)
{
    if (!s)
        return;
    qmc_seq_free(s->seq);
    qmc__mb_integ_close(&s->integ);
    free(s);
}

/* The register values of kind and scramble as core's enums. */
static qmc_seq_spec spec_of(const uint16_t *hr)
{
    static const qmc_seq_kind kinds[] = {
        [QMC_MODBUS_KIND_SOBOL] = QMC_SEQ_SOBOL,
        [QMC_MODBUS_KIND_HALTON] = QMC_SEQ_HALTON,
        [QMC_MODBUS_KIND_RANDOM] = QMC_SEQ_RANDOM,
    };
    static const qmc_scramble scrambles[] = {
        [QMC_MODBUS_SCRAMBLE_NONE] = QMC_SCRAMBLE_NONE,
        [QMC_MODBUS_SCRAMBLE_OWEN] = QMC_SCRAMBLE_OWEN,
        [QMC_MODBUS_SCRAMBLE_SHIFT] = QMC_SCRAMBLE_SHIFT,
        [QMC_MODBUS_SCRAMBLE_FAURE] = QMC_SCRAMBLE_FAURE,
        [QMC_MODBUS_SCRAMBLE_FAST_OWEN] = QMC_SCRAMBLE_FAST_OWEN,
    };
    qmc_seq_spec spec;
    memset(&spec, 0, sizeof spec); /* flags 0, set_size 0: infinite kinds */
    spec.kind = kinds[hr[QMC_MODBUS_HR_KIND]];
    spec.dims = hr[QMC_MODBUS_HR_DIMS];
    spec.scramble = scrambles[hr[QMC_MODBUS_HR_SCRAMBLE]];
    spec.seed = (uint64_t)hr[QMC_MODBUS_HR_SEED_HI] << 16 | hr[QMC_MODBUS_HR_SEED_LO];
    return spec;
}

/*
 * Computes the point the holding registers ask for into the result block.
 * Returns 0, or QMC_ENOMEM (the block is then unchanged).  A spec core
 * refuses or an index past the end is not an error of the request: the
 * block says so in its status register.
 */
static int compute(qmc_modbus_session *s)
{
    qmc_seq_spec spec = spec_of(s->hr);
    uint64_t index = get_u64(&s->hr[QMC_MODBUS_HR_INDEX_3]);
    int status = QMC_MODBUS_STATUS_OK;
    const qmc_seq_spec *had = &s->seq_spec;
    int same = s->seq && had->kind == spec.kind && had->dims == spec.dims &&
               had->scramble == spec.scramble && had->seed == spec.seed;
    if (!same) {
        qmc_seq *fresh = NULL;
        if (qmc_seq_spec_check(&spec, NULL, 0) != 0) {
            status = QMC_MODBUS_STATUS_BAD_SPEC;
        } else if (qmc_seq_new(&spec, &fresh) != 0) {
            return QMC_ENOMEM;
        } else {
            qmc_seq_free(s->seq);
            s->seq = fresh;
            s->seq_spec = spec;
        }
    }
    uint16_t block[QMC_MODBUS_RESULT_REGS] = {0};
    block[0] = s->hr[QMC_MODBUS_HR_REQUEST];
    qmc__mb_regs_u64(&block[2], index);
    if (status == QMC_MODBUS_STATUS_OK && qmc_seq_range_check(s->seq, index, 1, NULL, 0) != 0)
        status = QMC_MODBUS_STATUS_BAD_INDEX;
    if (status == QMC_MODBUS_STATUS_OK) {
        uint32_t words[QMC_MODBUS_MAX_DIMS];
        unsigned fmt = s->hr[QMC_MODBUS_HR_FORMAT];
        /* float32 and u32 are the core's own formats; u16 is the u32 value
         * shifted: floor(x * 2^32) >> 16 == floor(x * 2^16). */
        qmc_format f = fmt == QMC_MODBUS_FORMAT_F32 ? QMC_FORMAT_F32 : QMC_FORMAT_U32;
        if (qmc_seq_fill(s->seq, index, 1, f, words) != 0) {
            status = QMC_MODBUS_STATUS_BAD_INDEX; /* range was checked: unreachable */
        } else {
            int low_first = s->hr[QMC_MODBUS_HR_WORD_ORDER] == 1;
            uint16_t *c = &block[6];
            for (uint32_t j = 0; j < spec.dims; j++) {
                /* f32 arrives as float bits in a uint32_t slot. */
                uint32_t w = words[j];
                if (fmt == QMC_MODBUS_FORMAT_U16) {
                    *c++ = (uint16_t)(w >> 16);
                } else {
                    uint16_t hi = (uint16_t)(w >> 16), lo = (uint16_t)w;
                    *c++ = low_first ? lo : hi;
                    *c++ = low_first ? hi : lo;
                }
            }
        }
    }
    block[1] = (uint16_t)status;
    memcpy(s->result, block, sizeof block);
    s->has_result = 1;
    if (status == QMC_MODBUS_STATUS_OK && s->hr[QMC_MODBUS_HR_AUTO_ADVANCE] == 1)
        qmc__mb_regs_u64(&s->hr[QMC_MODBUS_HR_INDEX_3], index + 1);
    return 0;
}

/*
 * Stores count values (big-endian in v) from holding register addr on, as
 * one write.  Returns 0 or an exception code; on an exception nothing is
 * stored.  Writing register 10 with a new request number computes after
 * every value is stored; with the number already served the whole write is
 * acknowledged and changes nothing, so a retried request never skips a
 * point.  The integration block's registers (300..315, 320..323) are
 * modbus_integrate.c's.
 */
static int write_holding(qmc_modbus_session *s, const qmc_modbus_env *env, unsigned addr,
                         unsigned count, qmc__mb_rd *v)
{
    if (addr >= QMC_MODBUS_HOLDING_COUNT && qmc__mb_integ_writable(addr))
        return qmc__mb_integ_write(&s->integ, s->hr, env, addr, count, v);
    if (addr >= QMC_MODBUS_HOLDING_COUNT || count > QMC_MODBUS_HOLDING_COUNT - addr)
        return QMC_MODBUS_EX_ILLEGAL_ADDRESS;
    uint16_t fresh[QMC_MODBUS_HOLDING_COUNT];
    memcpy(fresh, s->hr, sizeof fresh);
    for (unsigned i = 0; i < count; i++) {
        uint16_t x = qmc__mb_u16(v);
        if (x < hr_min[addr + i] || x > hr_max[addr + i])
            return QMC_MODBUS_EX_ILLEGAL_VALUE;
        fresh[addr + i] = x;
    }
    int triggers = addr <= QMC_MODBUS_HR_REQUEST && addr + count > QMC_MODBUS_HR_REQUEST;
    if (triggers && s->has_result && fresh[QMC_MODBUS_HR_REQUEST] == s->result[0])
        return 0;
    uint16_t old[QMC_MODBUS_HOLDING_COUNT];
    memcpy(old, s->hr, sizeof old);
    memcpy(s->hr, fresh, sizeof fresh);
    if (triggers && compute(s) != 0) {
        memcpy(s->hr, old, sizeof old);
        return QMC_MODBUS_EX_SERVER_FAILURE;
    }
    return 0;
}

/* One readable block: registers [base, base + count) from src. */
typedef struct block {
    unsigned base, count;
    const uint16_t *src;
} block;

/*
 * Writes count registers from addr into w, from whichever block holds
 * addr.  A read that starts outside every block is exception 02; one that
 * starts inside a block and runs past its end is 03 (MODBUS.md).
 */
static int read_blocks(const block *b, size_t n_blocks, unsigned addr, unsigned count,
                       qmc__mb_wr *w)
{
    for (size_t i = 0; i < n_blocks; i++) {
        if (addr < b[i].base || addr >= b[i].base + b[i].count)
            continue;
        if (count > b[i].base + b[i].count - addr)
            return QMC_MODBUS_EX_ILLEGAL_VALUE;
        for (unsigned k = 0; k < count; k++)
            qmc__mb_put_u16(w, b[i].src[addr - b[i].base + k]);
        return 0;
    }
    return QMC_MODBUS_EX_ILLEGAL_ADDRESS;
}

static int read_regs(const qmc_modbus_session *s, const qmc_modbus_env *env, int input,
                     unsigned addr, unsigned count, qmc__mb_wr *w)
{
    /* The status block is rendered only for a read that starts in it. */
    uint16_t ib[QMC_MODBUS_INTEG_COUNT] = {0};
    if (addr >= QMC_MODBUS_INTEG_BASE && addr < QMC_MODBUS_INTEG_BASE + QMC_MODBUS_INTEG_COUNT)
        qmc__mb_integ_render(&s->integ, s->hr, ib);
    const block integ = {QMC_MODBUS_INTEG_BASE, QMC_MODBUS_INTEG_COUNT, ib};
    if (input) {
        uint16_t ctr[4 * 6];
        uint16_t *p = ctr;
#define PUT_CTR(name, field)                    \
    qmc__mb_regs_u64(p, env ? env->field : 0); \
    p += 4;
        QMC_MODBUS_COUNTER_MAP(PUT_CTR)
#undef PUT_CTR
        const block b[] = {{0, QMC_MODBUS_RESULT_REGS, s->result},
                           {QMC_MODBUS_COUNTERS_INPUT, (unsigned)(p - ctr), ctr},
                           integ};
        return read_blocks(b, 3, addr, count, w);
    }
    const block b[] = {{0, QMC_MODBUS_HOLDING_COUNT, s->hr},
                       {QMC_MODBUS_RESULT_HOLDING, QMC_MODBUS_RESULT_REGS, s->result},
                       {QMC_MODBUS_SETUP_BASE, QMC_MODBUS_SETUP_COUNT, s->integ.setup},
                       {QMC_MODBUS_VALUE_BASE, QMC_MODBUS_VALUE_COUNT, s->integ.value},
                       integ};
    return read_blocks(b, 5, addr, count, w);
}

/* FC03, FC04 (spec 6.3, 6.4): address, quantity 1..125. */
static int on_read(qmc_modbus_session *s, const qmc_modbus_env *env, uint8_t fc,
                   qmc__mb_rd *r, qmc__mb_wr *w)
{
    unsigned addr = qmc__mb_u16(r), count = qmc__mb_u16(r);
    if (!qmc__mb_rd_done(r) || count < 1 || count > 125)
        return QMC_MODBUS_EX_ILLEGAL_VALUE;
    qmc__mb_put_u8(w, fc);
    qmc__mb_put_u8(w, (uint8_t)(2 * count));
    return read_regs(s, env, fc == QMC_MODBUS_FC_READ_INPUT, addr, count, w);
}

/* FC06 (spec 6.6): the response echoes the request. */
static int on_write_single(qmc_modbus_session *s, const qmc_modbus_env *env,
                           const uint8_t *req, size_t n, qmc__mb_rd *r, qmc__mb_wr *w)
{
    unsigned addr = qmc__mb_u16(r);
    qmc__mb_rd value = *r;
    (void)qmc__mb_u16(r);
    if (!qmc__mb_rd_done(r))
        return QMC_MODBUS_EX_ILLEGAL_VALUE;
    /* Outside the writable registers (the result and status blocks are
     * read-only): 02. */
    int ex = write_holding(s, env, addr, 1, &value);
    if (ex)
        return ex;
    qmc__mb_put_bytes(w, req, n);
    return 0;
}

/* FC16 (spec 6.12): address, quantity 1..123, byte count = 2 * quantity. */
static int on_write_multiple(qmc_modbus_session *s, const qmc_modbus_env *env, qmc__mb_rd *r,
                             qmc__mb_wr *w)
{
    unsigned addr = qmc__mb_u16(r), count = qmc__mb_u16(r), bytes = qmc__mb_u8(r);
    if (r->bad || count < 1 || count > 123 || bytes != 2 * count || r->len - r->off != bytes)
        return QMC_MODBUS_EX_ILLEGAL_VALUE;
    int ex = write_holding(s, env, addr, count, r);
    if (ex)
        return ex;
    qmc__mb_put_u8(w, QMC_MODBUS_FC_WRITE_MULTIPLE);
    qmc__mb_put_u16(w, (uint16_t)addr);
    qmc__mb_put_u16(w, (uint16_t)count);
    return 0;
}

/* FC23 (spec 6.17): read 1..125, write 1..121; the write happens first, so
 * one transaction can set the index, trigger, and read the point. */
static int on_read_write(qmc_modbus_session *s, const qmc_modbus_env *env, qmc__mb_rd *r,
                         qmc__mb_wr *w)
{
    unsigned raddr = qmc__mb_u16(r), rcount = qmc__mb_u16(r);
    unsigned waddr = qmc__mb_u16(r), wcount = qmc__mb_u16(r), bytes = qmc__mb_u8(r);
    if (r->bad || rcount < 1 || rcount > 125 || wcount < 1 || wcount > 121 ||
        bytes != 2 * wcount || r->len - r->off != bytes)
        return QMC_MODBUS_EX_ILLEGAL_VALUE;
    /* Check the read's address before writing: a refused transaction must
     * not have stored its write. */
    qmc__mb_wr probe = *w;
    int ex = read_regs(s, env, 0, raddr, rcount, &probe);
    if (ex)
        return ex;
    if ((ex = write_holding(s, env, waddr, wcount, r)) != 0)
        return ex;
    qmc__mb_put_u8(w, QMC_MODBUS_FC_READ_WRITE_MULTIPLE);
    qmc__mb_put_u8(w, (uint8_t)(2 * rcount));
    return read_regs(s, env, 0, raddr, rcount, w);
}

int qmc_modbus_handle(qmc_modbus_session *s, const qmc_modbus_env *env, const uint8_t *req,
                      size_t req_bytes, uint8_t *resp, size_t resp_bytes)
{
    if (req_bytes == 0 || req_bytes > QMC_MODBUS_MAX_PDU || resp_bytes < QMC_MODBUS_MAX_PDU)
        return QMC_EINVAL;
    uint8_t fc = req[0];
    qmc__mb_rd r = {req, req_bytes, 1, 0};
    qmc__mb_wr w = {resp, QMC_MODBUS_MAX_PDU, 0, 0};
    int ex;
    switch (fc) {
    case QMC_MODBUS_FC_READ_HOLDING:
    case QMC_MODBUS_FC_READ_INPUT:
        ex = on_read(s, env, fc, &r, &w);
        break;
    case QMC_MODBUS_FC_WRITE_SINGLE:
        ex = on_write_single(s, env, req, req_bytes, &r, &w);
        break;
    case QMC_MODBUS_FC_WRITE_MULTIPLE:
        ex = on_write_multiple(s, env, &r, &w);
        break;
    case QMC_MODBUS_FC_READ_WRITE_MULTIPLE:
        ex = on_read_write(s, env, &r, &w);
        break;
    case QMC_MODBUS_FC_REPORT_SERVER_ID:
        ex = qmc__modbus_report_id(env, &r, &w);
        break;
    case QMC_MODBUS_FC_ENCAPSULATED:
        ex = qmc__modbus_device_id(env, &r, &w);
        break;
    default:
        ex = QMC_MODBUS_EX_ILLEGAL_FUNCTION;
        break;
    }
    if (ex == 0 && w.bad)
        ex = QMC_MODBUS_EX_SERVER_FAILURE; /* a response past 253 bytes: a bug */
    if (ex) {
        resp[0] = (uint8_t)(fc | 0x80);
        resp[1] = (uint8_t)ex;
        return 2;
    }
    return (int)w.off;
}

int qmc_modbus_request_writes(const uint8_t *req, size_t req_bytes)
{
    if (req_bytes == 0)
        return 0;
    return req[0] == QMC_MODBUS_FC_WRITE_SINGLE || req[0] == QMC_MODBUS_FC_WRITE_MULTIPLE ||
           req[0] == QMC_MODBUS_FC_READ_WRITE_MULTIPLE;
}

void qmc_modbus_session_usage(const qmc_modbus_session *s, qmc_modbus_usage *out)
{
    if (!s) {
        memset(out, 0, sizeof *out);
        return;
    }
    qmc__mb_integ_usage(&s->integ, out);
}
