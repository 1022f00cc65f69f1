"""pinproxy.py - a frame-level proxy between a client and qmcd, for
comparing `qmc integrate --json --connect` with the Python client byte
for byte: everything in a JOB_RESULT is a deterministic function of the
request except `seconds` (the daemon's compute time), so the proxy pins
that field to one value (and, when asked, rewrites the known integral of
|f|, to show who reads it from the wire); it also records every INTEGRATE payload, so a
test can check that both clients sent the same request.

Frames are relayed whole and parsed with the package's codec; nothing
else is changed.  Must not: relay descriptors (it serves job traffic
only), or outlive its test (threads are daemons; close() stops it).
"""
import os
import socket
import struct
import threading

from qmcd import wire

PINNED_SECONDS = 0.125
_SECONDS_OFFSET = 104  # JOB_RESULT payload: seconds (PROTOCOL.md 6.10)
_TAIL = 16  # version 6's known integral of |f|, the payload's last bytes


def _read_exact(s, n):
    out = bytearray()
    while len(out) < n:
        b = s.recv(n - len(out))
        if not b:
            return None
        out += b
    return bytes(out)


def _frames(s):
    while True:
        h = _read_exact(s, wire.HEADER_BYTES)
        if h is None:
            return
        n = struct.unpack_from("<I", h, 16)[0]
        p = _read_exact(s, n)
        if p is None:
            return
        yield h, p


class PinProxy:
    def __init__(self, upstream_path, directory, known_abs=None):
        """known_abs: a value to put in every JOB_RESULT's known integral
        of |f| (version 6), to show which clients read it from the wire."""
        self.known_abs = known_abs
        self.upstream = upstream_path
        self.path = os.path.join(directory, "pin.sock")
        self.endpoint = "unix:" + self.path
        self.requests = []  # INTEGRATE payloads, in arrival order
        self.lock = threading.Lock()
        self.ls = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.ls.bind(self.path)
        self.ls.listen(8)
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self):
        while True:
            try:
                c, _ = self.ls.accept()
            except OSError:
                return
            u = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            u.connect(self.upstream)
            threading.Thread(target=self._pump, args=(c, u, True), daemon=True).start()
            threading.Thread(target=self._pump, args=(u, c, False), daemon=True).start()

    def _pump(self, src, dst, from_client):
        try:
            for h, p in _frames(src):
                mtype = h[5]
                if from_client and mtype == wire.INTEGRATE:
                    with self.lock:
                        self.requests.append(p)
                if not from_client and mtype == wire.JOB_RESULT:
                    p = (p[:_SECONDS_OFFSET] + struct.pack("<d", PINNED_SECONDS) +
                         p[_SECONDS_OFFSET + 8:])
                    if self.known_abs is not None:
                        p = p[:-_TAIL] + b"\1" + bytes(7) + struct.pack("<d", self.known_abs)
                dst.sendall(h + p)
        except OSError:
            pass
        finally:
            # Each socket is the source of one pump: that pump closes it.
            for s in (src, dst):
                try:
                    s.shutdown(socket.SHUT_RDWR)
                except OSError:
                    pass
            src.close()

    def close(self):
        self.ls.close()


class CutProxy(PinProxy):
    """A PinProxy that breaks its first connection after relaying `after`
    SESSION_BATCH frames (or frames of type `mtype`; both sockets shut
    down, as a network failure would): the client sees the connection drop
    in the middle of a session, the daemon parks the session.  Later
    connections pass."""

    def __init__(self, upstream_path, directory, after, mtype=wire.SESSION_BATCH):
        self.after = after
        self.mtype = mtype
        self.batches = 0
        self.cut = threading.Event()
        self.first = None
        PinProxy.__init__(self, upstream_path, directory)

    def _pump(self, src, dst, from_client):
        if self.first is None and from_client:
            self.first = src
        try:
            for h, p in _frames(src):
                dst.sendall(h + p)
                if not from_client and h[5] == self.mtype and \
                        self.first is dst and not self.cut.is_set():
                    self.batches += 1
                    if self.batches == self.after:
                        self.cut.set()
                        for s in (src, dst):
                            s.shutdown(socket.SHUT_RDWR)
                        break
        except OSError:
            pass
        finally:
            for s in (src, dst):
                try:
                    s.shutdown(socket.SHUT_RDWR)
                except OSError:
                    pass
            src.close()
