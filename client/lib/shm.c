/*
 * shm.c - the shared-memory ring for POINTS data and session batches
 * (PROTOCOL.md sections 10 and 6.21).
 *
 * The ring is a memfd: sized, sealed against shrinking and growing, mapped
 * (writable: a session writes its values into its batch's slot) with every
 * page faulted in here (so the pages are ours - the
 * server refuses a ring with holes), and passed to the server with SCM_RIGHTS in
 * the sendmsg that carries SHM_ATTACH.  The server then writes each chunk
 * into the next slot and sends a small POINTS_SHM_CHUNK frame naming it
 * (points.c hands the slot's bytes to the caller's callback); slots go
 * back, oldest first and several at a time, in one SHM_RELEASE before each
 * wait for more frames (conn.c).
 *
 * Must not: leave a descriptor open (the memfd is closed once sent: the
 * mapping keeps the memory), keep a mapping once the connection is gone,
 * or print.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#include "client_impl.h"

/* A sealed memfd of `bytes`; returns it or -errno, with the reason in
 * c->message. */
static int make_memfd(qmc_client *c, size_t bytes)
{
    int fd = memfd_create("qmc-client-ring", MFD_CLOEXEC | MFD_ALLOW_SEALING);
    if (fd < 0) {
        int err = -errno;
        return qmc__client_fail(c, err, "shared memory: memfd_create: %s", qmc_strerror(err));
    }
    const char *step = "ftruncate";
    int err = 0;
    if (ftruncate(fd, (off_t)bytes) != 0) {
        err = -errno;
    } else if (fcntl(fd, F_ADD_SEALS, F_SEAL_SHRINK | F_SEAL_GROW) != 0) {
        /* Not F_SEAL_SEAL: the server adds F_SEAL_FUTURE_WRITE once it has
         * mapped the ring, so that no one can punch holes in it. */
        err = -errno;
        step = "sealing";
    }
    if (err) {
        close(fd);
        return qmc__client_fail(c, err, "shared memory: %s a %zu-byte memfd: %s", step,
                                bytes, qmc_strerror(err));
    }
    return fd;
}

/* SHM_ATTACH and its answer.  0, or an error: a local one or the server's
 * ERROR (the connection stays usable), or a broken connection (closed). */
static int attach(qmc_client *c, uint32_t slots, uint32_t slot_bytes)
{
    const size_t bytes = (size_t)slots * slot_bytes;
    int fd = make_memfd(c, bytes);
    if (fd < 0)
        return fd;
    /* MAP_POPULATE faults every page in now: the pages are allocated (and
     * charged) here, as the server insists, not at its first write.  The
     * mapping is made before SHM_ATTACH, when the server's seal against
     * new writable mappings is not there yet: sessions write their values
     * through it. */
    void *base = mmap(NULL, bytes, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_POPULATE, fd, 0);
    if (base == MAP_FAILED) {
        int err = -errno;
        close(fd);
        return qmc__client_fail(c, err, "shared memory: mmap: %s", qmc_strerror(err));
    }
    qmc_msg m;
    memset(&m, 0, sizeof m);
    m.type = QMC_MSG_SHM_ATTACH;
    m.request_id = c->next_request_id++;
    m.u.shm.slots = slots;
    m.u.shm.slot_bytes = slot_bytes;
    const uint64_t id = m.request_id;
    int err = qmc__client_send_frame(c, &m, fd);
    close(fd); /* the server has its own now, and the mapping keeps ours */
    if (!err)
        err = qmc__client_await(c, id, qmc__client_deadline(c), 0, &m);
    if (!err && m.type == QMC_MSG_ERROR)
        err = qmc__client_server_error(c, &m);
    else if (!err && (m.type != QMC_MSG_SHM_OK || m.u.shm.slots != slots ||
                      m.u.shm.slot_bytes != slot_bytes))
        err = qmc__client_break(c, QMC_EPROTO, "protocol error: %s (%u x %u) in answer to "
                                "SHM_ATTACH (%u x %u)", qmc_msg_type_name(m.type),
                                m.u.shm.slots, m.u.shm.slot_bytes, slots, slot_bytes);
    if (err) {
        munmap(base, bytes);
        return err;
    }
    c->ring.base = base;
    c->ring.bytes = bytes;
    c->ring.slots = slots;
    c->ring.slot_bytes = slot_bytes;
    c->ring.next = 0;
    c->ring.held = 0;
    c->ring.pinned = 0;
    return 0;
}

int qmc_client_attach_shm(qmc_client *c, uint32_t slots, uint32_t slot_bytes)
{
    int err = qmc__client_ready(c);
    if (err)
        return err;
    if (c->ring.base)
        return qmc__client_fail(c, QMC_EINVAL, "shared memory: a ring is already attached "
                                "to this connection");
    if (slots == 0) {
        c->shm_off = 1;
        return 0;
    }
    if (slots < QMC_PROTO_SHM_MIN_SLOTS || slots > QMC_PROTO_SHM_MAX_SLOTS ||
        slot_bytes < QMC_PROTO_SHM_MIN_SLOT_BYTES || slot_bytes > QMC_PROTO_SHM_MAX_SLOT_BYTES ||
        slot_bytes % QMC_PROTO_SHM_SLOT_ALIGN != 0)
        return qmc__client_fail(c, QMC_EINVAL, "shared memory: %u slots of %u bytes: want "
                                "%u..%u slots of a multiple of %u bytes in %u..%u", slots,
                                slot_bytes, QMC_PROTO_SHM_MIN_SLOTS, QMC_PROTO_SHM_MAX_SLOTS,
                                QMC_PROTO_SHM_SLOT_ALIGN, QMC_PROTO_SHM_MIN_SLOT_BYTES,
                                QMC_PROTO_SHM_MAX_SLOT_BYTES);
    if (!c->unix_socket)
        return qmc__client_fail(c, QMC_ENOTSUP, "shared memory needs a unix: endpoint");
    if (c->version < QMC_PROTO_VERSION_SHM)
        return qmc__client_fail(c, QMC_ENOTSUP, "shared memory: the server speaks protocol "
                                "version %u; the ring needs %u", c->version,
                                QMC_PROTO_VERSION_SHM);
    return attach(c, slots, slot_bytes);
}

uint32_t qmc_client_shm_slots(const qmc_client *c)
{
    return c->ring.slots;
}

uint32_t qmc_client_shm_slot_bytes(const qmc_client *c)
{
    return c->ring.slot_bytes;
}

int qmc__client_shm_auto(qmc_client *c)
{
    return qmc__client_shm_attach_sized(c, QMC__CLIENT_AUTO_SLOTS, QMC__CLIENT_AUTO_SLOT_BYTES);
}

int qmc__client_shm_attach_sized(qmc_client *c, uint32_t slots, uint32_t slot_bytes)
{
    if (c->ring.base || c->shm_off || !c->unix_socket || c->version < QMC_PROTO_VERSION_SHM)
        return 0;
    int err = attach(c, slots, slot_bytes);
    if (err == 0)
        return 0;
    c->shm_off = 1; /* refused or impossible here: inline from now on */
    if (c->fd < 0)
        return err;
    c->message[0] = '\0';
    return 0;
}

int qmc__client_shm_release(qmc_client *c)
{
    /* Release is oldest first: a slot a session's batch still needs holds
     * back every later one too, until its values are sent. */
    if (c->ring.held == 0 || c->ring.pinned || c->fd < 0)
        return 0;
    qmc_msg m;
    memset(&m, 0, sizeof m);
    m.type = QMC_MSG_SHM_RELEASE;
    m.request_id = 0; /* about the connection's ring, not one request */
    m.u.release.slots = c->ring.held;
    int err = qmc__client_send_frame(c, &m, -1);
    if (err)
        return err;
    c->ring.held = 0;
    return 0;
}

void qmc__client_shm_unmap(qmc_client *c)
{
    if (c->ring.base)
        munmap(c->ring.base, c->ring.bytes);
    memset(&c->ring, 0, sizeof c->ring);
}
