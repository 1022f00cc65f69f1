"""qmcd.ring - the shared-memory ring of PROTOCOL.md section 10, client
side: a memfd sized slots x slot_bytes, sealed against shrinking and
growing, mapped read-only with every page faulted in here (the server
refuses a ring with holes), and handed to the server beside SHM_ATTACH.

The server then writes each chunk into the next slot and names it in a
POINTS_SHM_CHUNK frame; the client copies the chunk out (once, straight
into the caller's array) and gives slots back, oldest first, in one
SHM_RELEASE before it next waits for the socket.

Must not: keep the memfd open once sent (the mapping keeps the memory),
write into the ring but a session's values into its batch's slot, or
outlive the connection (close() unmaps).
"""
import fcntl
import mmap
import os

from .errors import QmcdError


class Ring:
    """A mapped ring; .fd is valid until sent() is called."""

    def __init__(self, slots, slot_bytes):
        self.slots, self.slot_bytes = slots, slot_bytes
        self.bytes = slots * slot_bytes
        self.next = 0    # the slot the next chunk must name
        self.held = 0    # slots named by chunks and not yet released
        self.pinned = 0  # of those, a session batch's, waiting for its values
        self.map = None
        self.view = None
        self.fd = -1
        try:
            self.fd = os.memfd_create("qmcd-py-ring", os.MFD_CLOEXEC | os.MFD_ALLOW_SEALING)
            os.ftruncate(self.fd, self.bytes)
            # Not F_SEAL_SEAL: the server adds F_SEAL_FUTURE_WRITE itself
            # once it has mapped the ring.
            fcntl.fcntl(self.fd, fcntl.F_ADD_SEALS, fcntl.F_SEAL_SHRINK | fcntl.F_SEAL_GROW)
            # MAP_POPULATE: the pages are allocated (and charged) here, as
            # the server insists (it checks with mincore).  Writable, and
            # mapped before the server seals new writable mappings away: a
            # session writes its values into its batch's slot.
            self.map = mmap.mmap(self.fd, self.bytes, flags=mmap.MAP_SHARED | mmap.MAP_POPULATE,
                                 prot=mmap.PROT_READ | mmap.PROT_WRITE)
            self.view = memoryview(self.map)
            self.ro = self.view.toreadonly()
        except OSError as e:
            self.close()
            raise QmcdError(-(e.errno or 5), "shared memory: %s" % (e.strerror or e)) from None

    def sent(self):
        """The server holds its own descriptor now: close ours."""
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1

    def slot(self, index, nbytes):
        """A read-only view of the first nbytes of slot index."""
        off = index * self.slot_bytes
        return self.ro[off:off + nbytes]

    def close(self):
        self.sent()
        if self.view is not None:
            self.ro.release()
            self.view.release()
            self.view = self.ro = None
        if self.map is not None:
            try:
                self.map.close()
            except BufferError:
                # An array still views the ring: the mapping goes with it.
                pass
            self.map = None
