/*
 * messages_part.c - the answer of a part session (protocol version 6,
 * PROTOCOL.md section 6.22): SESSION_PART, the part's place in its job,
 * and SESSION_PART_SUMS, its block sums, each layout written once as a
 * qmc__io function that both decodes and encodes (codec.h), and the
 * accessor for a record of block sums.  messages.c's table points here.
 *
 * What the bytes can show is checked here, both ways: the part's blocks
 * are the ones `--part k/p` computes of a job of that many blocks (blocks
 * [nb (k-1) / p, nb k / p)), a record's counts fit a block, its largest
 * values are non-negative and descending, as `qmc merge` demands of a
 * part file (docs/FILES.md).  The sums themselves are any binary64 (a
 * finite 1e308 may overflow one to infinity), carried bit for bit.
 *
 * Must not: do I/O, allocate, keep state.
 */
#include <string.h>

#include "codec.h"

/* Part k of p of a job of nb blocks: its first block and its count. */
static void part_range(uint64_t nb, uint32_t k, uint32_t p, uint64_t *first, uint64_t *count)
{
    *first = nb * (k - 1) / p;
    *count = nb * k / p - *first;
}

void qmc__io_session_part(qmc__io *io, qmc_msg *m)
{
    qmc_msg_session_part *p = &m->u.session_part;
    qmc__io_u64(io, &p->session_id);
    qmc__io_u64(io, &p->fingerprint);
    qmc__io_u64(io, &p->blocks);
    qmc__io_u64(io, &p->first);
    qmc__io_u64(io, &p->count);
    qmc__io_u32(io, &p->part_k);
    qmc__io_u32(io, &p->part_p);
    qmc__io_sampling(io, &p->sampling, 1);
    if (io->err || io->rd.bad)
        return;
    /* blocks <= 2^20 and part_k < 2^32: the products stay below 2^52. */
    if (p->blocks == 0 || p->blocks > QMC_SAMPLING_MAX_BLOCKS || p->part_k == 0 ||
        p->part_k > p->part_p) {
        qmc__io_invalid(io);
        return;
    }
    uint64_t first, count;
    part_range(p->blocks, p->part_k, p->part_p, &first, &count);
    if (p->first != first || p->count != count)
        qmc__io_invalid(io);
}

/* One block's record: count and nonfinite as u32, the 11 sums and
 * moments, the QMC_SAMPLING_TOP largest |f|; s->block is not on the wire
 * (the frame's first + i).  Decoding fills *s only to check it. */
static void io_sums_record(qmc__io *io, qmc_sampling_sums *s)
{
    uint32_t count = (uint32_t)s->count, nonfinite = (uint32_t)s->nonfinite;
    if (!io->decode && (s->count > QMC_SAMPLING_BLOCK || s->nonfinite > s->count)) {
        qmc__io_invalid(io);
        return;
    }
    qmc__io_u32(io, &count);
    qmc__io_u32(io, &nonfinite);
    s->count = count;
    s->nonfinite = nonfinite;
    double *v[11] = {&s->f[0], &s->f[1], &s->absf[0], &s->absf[1], &s->g[0], &s->g[1],
                     &s->mean_f, &s->mean_g, &s->m2_f, &s->m2_g, &s->c_fg};
    for (int k = 0; k < 11; k++)
        qmc__io_f64(io, v[k]);
    for (int k = 0; k < QMC_SAMPLING_TOP; k++) {
        qmc__io_f64(io, &s->top[k]);
        /* Non-negative and descending: NaN fails both. */
        if (!(s->top[k] >= 0.0) || (k > 0 && !(s->top[k] <= s->top[k - 1])))
            qmc__io_invalid(io);
    }
    if (count > QMC_SAMPLING_BLOCK || nonfinite > count)
        qmc__io_invalid(io);
}

void qmc__io_session_part_sums(qmc__io *io, qmc_msg *m)
{
    qmc_msg_session_part_sums *p = &m->u.part_sums;
    qmc__io_u64(io, &p->session_id);
    qmc__io_u64(io, &p->first);
    qmc__io_u32(io, &p->n);
    qmc__io_zero(io, 4);
    if (io->err || io->rd.bad)
        return;
    if (p->n == 0 || p->n > QMC_PROTO_PART_MAX_SUMS || p->first >= QMC_SAMPLING_MAX_BLOCKS ||
        p->n > QMC_SAMPLING_MAX_BLOCKS - p->first || (!io->decode && !p->sums && !p->raw)) {
        qmc__io_invalid(io);
        return;
    }
    if (io->decode) {
        /* The records are read where they are (qmc_proto_part_sums_at);
         * here each is only checked.  A count the payload cannot hold is
         * refused before walking it. */
        if ((uint64_t)p->n * QMC_PROTO_PART_SUMS_BYTES != io->rd.left) {
            qmc__io_invalid(io);
            return;
        }
        p->sums = NULL;
        p->raw = io->rd.p;
        for (uint32_t i = 0; i < p->n && io->err == 0; i++) {
            qmc_sampling_sums s;
            io_sums_record(io, &s);
        }
        return;
    }
    /* From the caller's sums, or from a decoded frame's records. */
    for (uint32_t i = 0; i < p->n && io->err == 0; i++) {
        qmc_sampling_sums s;
        qmc_proto_part_sums_at(p, i, &s);
        if (s.block != p->first + i) {
            qmc__io_invalid(io);
            return;
        }
        io_sums_record(io, &s);
    }
}

void qmc_proto_part_sums_at(const qmc_msg_session_part_sums *p, uint32_t i,
                            qmc_sampling_sums *out)
{
    memset(out, 0, sizeof *out);
    if (p == NULL || i >= p->n)
        return;
    if (p->sums) {
        *out = p->sums[i];
        return;
    }
    if (p->raw == NULL)
        return;
    /* The decoder checked every record: read record i as it was read. */
    qmc__io io = {.decode = 1,
                  .rd = qmc__rd_make(p->raw + (size_t)i * QMC_PROTO_PART_SUMS_BYTES,
                                     QMC_PROTO_PART_SUMS_BYTES),
                  .version = QMC_PROTO_VERSION_MAX};
    io_sums_record(&io, out);
    out->block = p->first + i;
}
