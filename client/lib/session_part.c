/*
 * session_part.c - a part session's answer on the client side (protocol
 * version 6, PROTOCOL.md section 6.22): SESSION_PART, then the part's
 * block sums in SESSION_PART_SUMS frames, in block order, gathered here
 * until SESSION_RESULT ends the request; qmc_client_session_part then
 * hands them out as qmc_session_part does in-process, so the caller
 * writes the same part file from either.
 *
 * Must not: trust the server's counts for an allocation (the buffer grows
 * with the sums that actually came, never past the part's own count),
 * accept sums out of order, or print.  session.c routes the frames here.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "client_impl.h"

static int refuse(char *why, size_t n, const char *what)
{
    snprintf(why, n, "%s", what);
    return QMC_EPROTO;
}

/* Room for at least want sums: doubling, capped by the part's count. */
static int grow(qmc__client_part *p, uint64_t want)
{
    if (want <= p->cap)
        return 0;
    uint64_t cap = p->cap ? p->cap : 64;
    while (cap < want)
        cap *= 2;
    if (cap > p->head.count)
        cap = p->head.count;
    qmc_sampling_sums *s = realloc(p->sums, (size_t)cap * sizeof *s);
    if (!s)
        return QMC_ENOMEM;
    p->sums = s;
    p->cap = cap;
    return 0;
}

int qmc__client_part_file(qmc__client_part *p, uint64_t session_id, const qmc_msg *m,
                          char *why, size_t why_bytes)
{
    if (m->type == QMC_MSG_SESSION_PART) {
        const qmc_msg_session_part *h = &m->u.session_part;
        if (p->have_head || h->session_id != session_id)
            return refuse(why, why_bytes, "SESSION_PART again, or for another session");
        /* The decoder checked that first and count are part k/p's. */
        if (p->part_p && (h->part_k != p->part_k || h->part_p != p->part_p))
            return refuse(why, why_bytes, "SESSION_PART for another part than the one opened");
        p->head = *h;
        p->have_head = 1;
        return 0;
    }
    const qmc_msg_session_part_sums *q = &m->u.part_sums;
    if (!p->have_head || q->session_id != session_id)
        return refuse(why, why_bytes, "block sums before SESSION_PART, or for another session");
    if (q->first != p->head.first + p->got || q->n > p->head.count - p->got)
        return refuse(why, why_bytes, "block sums out of order, or past the part's blocks");
    if (grow(p, p->got + q->n) != 0) {
        snprintf(why, why_bytes, "out of memory for %llu block sums",
                 (unsigned long long)(p->got + q->n));
        return QMC_ENOMEM;
    }
    for (uint32_t i = 0; i < q->n; i++)
        qmc_proto_part_sums_at(q, i, &p->sums[p->got + i]);
    p->got += q->n;
    return 0;
}

int qmc__client_part_end(const qmc__client_part *p, char *why, size_t why_bytes)
{
    if (p->part_p && !p->have_head)
        return refuse(why, why_bytes, "the result of a part session without its block sums");
    if (p->have_head && p->got != p->head.count) {
        snprintf(why, why_bytes, "the result after %llu of the part's %llu block sums",
                 (unsigned long long)p->got, (unsigned long long)p->head.count);
        return QMC_EPROTO;
    }
    return 0;
}

int qmc__client_part_get(const qmc__client_part *p, qmc_session_part_sums *out)
{
    memset(out, 0, sizeof *out);
    if (!p->have_head)
        return QMC_EINVAL;
    out->fingerprint = p->head.fingerprint;
    out->blocks = p->head.blocks;
    out->first = p->head.first;
    out->count = p->head.count;
    out->sums = p->sums;
    out->sampling = p->head.sampling;
    return 0;
}

void qmc__client_part_free(qmc__client_part *p)
{
    free(p->sums);
    memset(p, 0, sizeof *p);
}
