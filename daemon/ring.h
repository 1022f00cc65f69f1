/*
 * ring.h - a client's shared-memory ring (SHM_ATTACH, PROTOCOL.md section
 * 10): mapped and handed out by ring.c, attached by shm.c, filled by the
 * producers that stream through it (points.c), freed by its connection.
 */
#ifndef QMCD_RING_H
#define QMCD_RING_H

#include <stddef.h>
#include <stdint.h>

typedef struct qmcd_ring qmcd_ring;

/* A client's ring: its memfd mapped shared, cut into equal slots that are
 * filled in order 0, 1, ... slots - 1, 0, ... and handed back oldest first,
 * so the free slots are always the `slots - held` after the held ones. */
struct qmcd_ring {
    uint8_t *base;
    size_t bytes;                /* slots * slot_bytes */
    uint32_t slots, slot_bytes;
    uint32_t next;               /* the slot the next chunk goes to */
    uint32_t held;               /* given to the client, not yet released */
    uint32_t unsent;             /* chunks queued since the last flush hint */
    int64_t full_ms;             /* when the last free slot was taken, or 0 */
    /* Slots ever handed out and taken back: the slot handed out as the
     * h-th (handed_total just after it) is still the client's while
     * released_total < h (a session reads its values from it). */
    uint64_t handed_total, released_total;
};

/* Checks the client's memfd fd (a memfd on shmem, sealed against
 * shrinking but not against writing, at least slots * slot_bytes long,
 * every page populated), maps it shared, seals it against hole punching
 * and returns the ring in *out: 0, or an error code with one line in why
 * (*out NULL).  fd stays the caller's to close; the mapping outlives it. */
int qmcd_ring_map(int fd, uint32_t slots, uint32_t slot_bytes, struct qmcd_ring **out,
                  char *why, size_t why_bytes);

/* 1 when this kernel refuses to punch holes in a memfd sealed with
 * F_SEAL_FUTURE_WRITE (probed on a scratch memfd: call once). */
int qmcd_ring_seal_stops_punching(void);

/* SHM_RELEASE: the client hands back its `slots` oldest slots.  Returns 0,
 * or -1 when it holds fewer. */
int qmcd_ring_take_back(struct qmcd_ring *r, uint32_t slots);

/* Unmaps and frees the ring; NULL is a no-op. */
void qmcd_ring_free(struct qmcd_ring *r);

/* Filling the ring, for any producer that streams through it (POINTS
 * today; PIXELS and sessions alike).  While qmcd_ring_full says 1 the
 * producer waits (QMCD_WAIT_RING, QMCD_PUMP_WAIT); otherwise it writes at
 * most slot_bytes at qmcd_ring_next, queues the frame that names *slot, and
 * then calls qmcd_ring_hand_out. */
int qmcd_ring_full(const struct qmcd_ring *r);
uint8_t *qmcd_ring_next(const struct qmcd_ring *r, uint32_t *slot);
/* The slot qmcd_ring_next named is the client's until SHM_RELEASE.
 * Returns 1 when the frames queued since the last such 1 should be sent
 * now (half the ring is out, or all of it: QMCD_PUMP_FLUSH). */
int qmcd_ring_hand_out(struct qmcd_ring *r);

#endif
