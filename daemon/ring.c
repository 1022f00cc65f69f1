/*
 * ring.c - the shared-memory ring a client on a Unix socket lends for bulk
 * data (SHM_ATTACH, PROTOCOL.md section 10): checking and mapping its
 * memfd, handing its slots out in order and taking them back.  The
 * requests that attach and release it are shm.c's.
 *
 * The ring is the client's memory, and must stay so: the daemon only
 * writes into pages the client allocated.  So the memfd must be a memfd
 * (shmem, not hugetlbfs, whose faults can fail), sealed against shrinking
 * (a truncated mapping would SIGBUS us), and every page populated before
 * it is attached.  And once we have mapped it, we add F_SEAL_FUTURE_WRITE
 * (and F_SEAL_SEAL): our mapping stays writable, but no one can punch
 * holes in the file any more (fallocate PUNCH_HOLE, or MADV_REMOVE through
 * a mapping the client made before) - without it a client could free its
 * pages after SHM_OK and let our writes allocate them again, charged to
 * the daemon (64 MiB a connection at the default max-shm-bytes).  Whether
 * the kernel really refuses a punch under that seal is probed once, on a
 * scratch memfd, before the first ring is accepted
 * (qmcd_ring_seal_stops_punching); if it does not, the transport is refused
 * (clients fall back to inline chunks).
 *
 * This file must not generate data (the producers do), answer requests
 * (shm.c) or read sockets (conn.c): it calls nothing of the daemon but the
 * clock.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <linux/falloc.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/vfs.h>
#include <unistd.h>

#include "qmc/proto.h"
#include "ring.h"
#include "server.h"

/* statfs f_type of shmem (memfd_create, tmpfs): linux/magic.h. */
#define SHMEM_MAGIC 0x01021994
#ifndef F_SEAL_FUTURE_WRITE
#define F_SEAL_FUTURE_WRITE 0x0010 /* Linux 5.1, linux/fcntl.h */
#endif

void qmcd_ring_free(qmcd_ring *r)
{
    if (!r)
        return;
    munmap(r->base, r->bytes);
    free(r);
}

int qmcd_ring_full(const qmcd_ring *r)
{
    return r->held == r->slots;
}

uint8_t *qmcd_ring_next(const qmcd_ring *r, uint32_t *slot)
{
    *slot = r->next;
    return r->base + (size_t)r->next * r->slot_bytes;
}

/* Ring chunks go out in batches of half the ring (and whenever the ring
 * is full, or the producer or the kick's turn ends): each send wakes a
 * client that waits, and on a VM a wakeup costs as much as generating a
 * few hundred KiB, so a send per chunk cost about a fifth of the rate
 * (measured, 8 x 1 MiB); while the client handles one half, we fill the
 * other. */
int qmcd_ring_hand_out(qmcd_ring *r)
{
    r->next = r->next + 1 == r->slots ? 0 : r->next + 1;
    r->handed_total++;
    if (++r->held == r->slots)
        r->full_ms = qmcd_now_ms();
    if (r->held == r->slots || ++r->unsent >= r->slots / 2) {
        r->unsent = 0;
        return 1;
    }
    return 0;
}

/* The descriptor must be a memfd (a regular file on shmem: not hugetlbfs,
 * whose faults can fail with SIGBUS, nor a disk file), sealed so that it
 * cannot shrink under our mapping, writable, and as long as the ring.
 * Returns 0 or an error code with the reason in why. */
static int check_memfd(int fd, uint64_t bytes, char *why, size_t n)
{
    struct stat st;
    struct statfs sf;
    if (fstat(fd, &st) != 0 || fstatfs(fd, &sf) != 0) {
        int e = -errno;
        snprintf(why, n, "SHM_ATTACH: cannot inspect the descriptor: %s", qmc_strerror(e));
        return e;
    }
    if (!S_ISREG(st.st_mode) || sf.f_type != SHMEM_MAGIC) {
        snprintf(why, n, "SHM_ATTACH: the descriptor is not a memfd (memfd_create without "
                         "MFD_HUGETLB)");
        return QMC_EINVAL;
    }
    int seals = fcntl(fd, F_GET_SEALS);
    if (seals < 0) {
        snprintf(why, n, "SHM_ATTACH: the memfd has no seals (create it with "
                         "MFD_ALLOW_SEALING and seal it with F_SEAL_SHRINK)");
        return QMC_EINVAL;
    }
    if (!(seals & F_SEAL_SHRINK)) {
        snprintf(why, n, "SHM_ATTACH: the memfd is not sealed with F_SEAL_SHRINK (the server "
                         "maps it, and a file that may shrink under a mapping would crash it)");
        return QMC_EINVAL;
    }
    if (seals & (F_SEAL_WRITE | F_SEAL_FUTURE_WRITE)) {
        snprintf(why, n, "SHM_ATTACH: the memfd is sealed against writing");
        return QMC_EINVAL;
    }
    if (seals & F_SEAL_SEAL) {
        snprintf(why, n, "SHM_ATTACH: the memfd is sealed with F_SEAL_SEAL, so the server "
                         "cannot add F_SEAL_FUTURE_WRITE (which stops hole punching); seal "
                         "only F_SEAL_SHRINK and F_SEAL_GROW");
        return QMC_EINVAL;
    }
    if (st.st_size < 0 || (uint64_t)st.st_size < bytes) {
        snprintf(why, n, "SHM_ATTACH: the memfd holds %lld bytes, less than the ring's %llu",
                 (long long)st.st_size, (unsigned long long)bytes);
        return QMC_EINVAL;
    }
    return 0;
}

/* Every page of the mapping must already be allocated (the client wrote
 * it or called fallocate): we only write into pages the client paid for,
 * and a ring with holes would be filled at the server's expense. */
static int check_populated(uint8_t *base, size_t bytes, char *why, size_t n)
{
    long page = sysconf(_SC_PAGESIZE);
    if (page <= 0)
        page = 4096;
    unsigned char vec[256];
    const size_t window = sizeof vec * (size_t)page;
    for (size_t off = 0; off < bytes; off += window) {
        size_t len = bytes - off < window ? bytes - off : window;
        if (mincore(base + off, len, vec) != 0) {
            int e = -errno;
            snprintf(why, n, "SHM_ATTACH: mincore: %s", qmc_strerror(e));
            return e;
        }
        size_t pages = (len + (size_t)page - 1) / (size_t)page;
        for (size_t i = 0; i < pages; i++)
            if (!(vec[i] & 1)) {
                snprintf(why, n, "SHM_ATTACH: the memfd is not populated (page at byte %zu "
                                 "is not allocated): write it or fallocate it before "
                                 "attaching", off + i * (size_t)page);
                return QMC_EINVAL;
            }
    }
    return 0;
}

/* 1 when this kernel refuses to punch a hole in a memfd sealed with
 * F_SEAL_FUTURE_WRITE while a writable shared mapping of it exists (our
 * situation after SHM_ATTACH), tried on a one-page scratch memfd; 0 when it
 * lets the punch through or lacks the seal (before Linux 5.1). */
int qmcd_ring_seal_stops_punching(void)
{
    int fd = memfd_create("qmcd-seal-probe", MFD_CLOEXEC | MFD_ALLOW_SEALING);
    if (fd < 0)
        return 0;
    int refused = 0;
    long page = sysconf(_SC_PAGESIZE);
    size_t bytes = page > 0 ? (size_t)page : 4096;
    void *map = MAP_FAILED;
    if (ftruncate(fd, (off_t)bytes) == 0)
        map = mmap(NULL, bytes, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
    if (map != MAP_FAILED) {
        ((volatile char *)map)[0] = 1; /* one allocated page to punch */
        if (fcntl(fd, F_ADD_SEALS, F_SEAL_SHRINK | F_SEAL_FUTURE_WRITE) == 0)
            refused = fallocate(fd, FALLOC_FL_PUNCH_HOLE | FALLOC_FL_KEEP_SIZE, 0,
                                (off_t)bytes) != 0 && errno == EPERM;
        munmap(map, bytes);
    }
    close(fd);
    return refused;
}

int qmcd_ring_map(int fd, uint32_t slots, uint32_t slot_bytes, qmcd_ring **out, char *why,
                  size_t n)
{
    const uint64_t bytes = (uint64_t)slots * slot_bytes;
    void *base = MAP_FAILED;
    qmcd_ring *r = NULL;
    *out = NULL;
    int err = check_memfd(fd, bytes, why, n);
    if (!err) {
        base = mmap(NULL, (size_t)bytes, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
        if (base == MAP_FAILED) {
            err = -errno;
            snprintf(why, n, "SHM_ATTACH: cannot map the memfd: %s", qmc_strerror(err));
        }
    }
    /* Sealed before the populated check, so that what it finds stays true:
     * from here on no one can punch a hole (PROTOCOL.md section 10). */
    if (!err && fcntl(fd, F_ADD_SEALS, F_SEAL_FUTURE_WRITE | F_SEAL_SEAL) != 0) {
        err = -errno;
        snprintf(why, n, "SHM_ATTACH: cannot seal the memfd with F_SEAL_FUTURE_WRITE: %s",
                 qmc_strerror(err));
    }
    if (!err)
        err = check_populated(base, (size_t)bytes, why, n);
    if (!err && !(r = calloc(1, sizeof *r))) {
        err = QMC_ENOMEM;
        snprintf(why, n, "out of memory");
    }
    if (err) {
        if (base != MAP_FAILED)
            munmap(base, (size_t)bytes);
        return err;
    }
#ifdef MADV_POPULATE_WRITE
    /* Map every page now (they exist: checked above), so the first lap of
     * the ring takes no page faults.  Only a speed-up: errors are fine. */
    (void)madvise(base, (size_t)bytes, MADV_POPULATE_WRITE);
#endif
    r->base = base;
    r->bytes = (size_t)bytes;
    r->slots = slots;
    r->slot_bytes = slot_bytes;
    *out = r;
    return 0;
}

int qmcd_ring_take_back(qmcd_ring *r, uint32_t slots)
{
    if (slots > r->held)
        return -1;
    r->held -= slots;
    r->released_total += slots;
    r->full_ms = 0;
    return 0;
}
