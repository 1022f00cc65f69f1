"""qmcd.conn - one socket to qmcd: endpoint text to a connected socket,
whole sends (with a descriptor beside the first byte when asked), and
frames read under a deadline.

Reading: every wait for bytes is bounded by the client's timeout, and a
frame must arrive whole within it from its first byte; the header is
checked byte by byte as it arrives (garbage is refused at once, not after
a timeout) and its size against our limit before any payload is read, so
a hostile peer can make us neither wait forever nor buffer more than one
frame.  Payloads can be read straight into a caller's buffer (a numpy
array): point data is not copied twice.

Must not: print, raise anything but qmcd.errors' exceptions for trouble
on the wire, or keep the socket after an error that leaves the stream in
an unknown state (close() is then called).
"""
import os
import select
import socket
import time

from . import wire
from .errors import ConnectionLost, ProtocolError, QmcdError, Timeout, QMC_EINVAL

ENDPOINT_HELP = "want unix:PATH or tcp:HOST:PORT"


def parse_endpoint(text):
    """("unix", path) or ("tcp", host, port) for endpoint text, by the rules
    of client/lib/endpoint.c; QmcdError(QMC_EINVAL) names what is wrong."""
    def bad(reason):
        return QmcdError(QMC_EINVAL, "malformed endpoint '%.200s': %s (%s)"
                         % (text, reason, ENDPOINT_HELP))
    if not text:
        raise bad("no endpoint")
    if text.startswith("unix:"):
        path = text[5:]
        if not path:
            raise bad("empty socket path")
        if len(os.fsencode(path)) > 107:
            raise bad("socket path longer than 107 bytes")
        return ("unix", path)
    if not text.startswith("tcp:"):
        raise bad("unknown transport")
    rest = text[4:]
    if rest.startswith("["):
        close = rest.find("]")
        if close < 0:
            raise bad("'[' without ']'")
        if rest[close + 1:close + 2] != ":":
            raise bad("no ':PORT' after ']'")
        host, port = rest[1:close], rest[close + 2:]
    else:
        colon = rest.rfind(":")
        if colon < 0:
            raise bad("no ':PORT'")
        host, port = rest[:colon], rest[colon + 1:]
        if ":" in host:
            raise bad("an IPv6 address goes in brackets, tcp:[::1]:PORT")
    if not host:
        raise bad("empty host")
    if len(host) > 255:
        raise bad("host name too long")
    if not port:
        raise bad("empty port")
    if not port.isdigit() or not port.isascii() or len(port) > 5 or not 1 <= int(port) <= 65535:
        raise bad("the port is not a number 1..65535")
    if any(ord(c) <= 0x20 or c in "/[]" for c in host):
        raise bad("bad character in the host")
    return ("tcp", host, int(port))


def _deadline(timeout):
    return None if timeout is None else time.monotonic() + timeout


def open_socket(endpoint, timeout):
    """A connected socket for parsed endpoint ep, each connect bounded by
    timeout (seconds, None: no limit)."""
    ep = parse_endpoint(endpoint)
    if ep[0] == "unix":
        s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        s.settimeout(timeout)
        try:
            s.connect(ep[1])
        except socket.timeout:
            s.close()
            raise Timeout("cannot connect to %s: timed out" % endpoint) from None
        except OSError as e:
            s.close()
            raise QmcdError(-(e.errno or 5), "cannot connect to %s: %s"
                            % (endpoint, e.strerror or e)) from None
        return s
    _, host, port = ep
    try:
        addrs = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    except socket.gaierror as e:
        raise QmcdError(-5, "cannot resolve %s: %s" % (endpoint, e.strerror)) from None
    last = None
    deadline = _deadline(timeout)
    for family, kind, proto, _, addr in addrs:
        s = socket.socket(family, kind, proto)
        left = None if deadline is None else max(deadline - time.monotonic(), 0.001)
        s.settimeout(left)
        try:
            s.connect(addr)
        except OSError as e:
            s.close()
            last = e
            continue
        # Requests are small and answered at once: no Nagle delay.
        s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        return s
    if isinstance(last, socket.timeout):
        raise Timeout("cannot connect to %s: timed out" % endpoint)
    errno_ = getattr(last, "errno", None) or 5
    raise QmcdError(-errno_, "cannot connect to %s: %s"
                    % (endpoint, getattr(last, "strerror", None) or last))


class Conn:
    """Frames over one connected socket.  timeout: seconds for each frame
    (and each send), None for no limit.

    The socket is non-blocking and every wait is our own poll() bounded by
    the deadline: a send that fits goes out in one system call, a read is
    one poll and one recv."""

    BUF_BYTES = 256 << 10

    def __init__(self, sock, timeout, max_payload):
        sock.setblocking(False)
        self.sock = sock
        self.timeout = timeout
        self.max_payload = max_payload
        self.buf = bytearray(self.BUF_BYTES)
        self.view = memoryview(self.buf)
        self.start = self.end = 0  # unread bytes are buf[start:end]
        self.poller = select.poll()
        self.poller.register(sock, select.POLLIN)
        self.polling = select.POLLIN

    @property
    def closed(self):
        return self.sock is None

    def close(self):
        if self.sock is not None:
            try:
                self.sock.close()
            finally:
                self.sock = None

    def _wait(self, events, deadline):
        """Waits until the socket is ready for events (POLLIN or POLLOUT) or
        the deadline passes (raises Timeout, closing the connection)."""
        if events != self.polling:
            self.poller.modify(self.sock, events)
            self.polling = events
        while True:
            if deadline is None:
                ms = -1
            else:
                left = deadline - time.monotonic()
                if left <= 0:
                    self.close()
                    if events == select.POLLOUT:
                        raise Timeout("the daemon took none of our request for %g s"
                                      % self.timeout)
                    raise Timeout("no answer from the daemon within %g s" % self.timeout)
                ms = max(1, int(left * 1000 + 0.999))
            if self.poller.poll(ms):
                return

    def _failed(self, e):
        self.close()
        return ConnectionLost("the connection broke: %s" % (e.strerror or e),
                              -(e.errno or 104))

    # -- sending --
    def send(self, data, fd=None):
        """All of data, the descriptor fd (if any) riding with its first byte
        (SCM_RIGHTS, PROTOCOL.md section 10)."""
        if self.sock is None:
            raise ConnectionLost("the connection is closed")
        deadline = None
        view = memoryview(data)
        try:
            while len(view):
                try:
                    if fd is not None:
                        n = socket.send_fds(self.sock, [view], [fd])
                        fd = None
                    else:
                        n = self.sock.send(view)
                    view = view[n:]
                except BlockingIOError:
                    if deadline is None and self.timeout is not None:
                        deadline = time.monotonic() + self.timeout
                    self._wait(select.POLLOUT, deadline)
        except QmcdError:
            raise  # our Timeout is an OSError too (TimeoutError)
        except OSError as e:
            raise self._failed(e) from None

    # -- receiving --
    def buffered(self):
        """Bytes already read and not yet handed out."""
        return self.end - self.start

    def whole_frame_buffered(self):
        """Whether a whole frame waits in the buffer (so reading it will not
        block): the ring's slots go back before we would block."""
        n = self.end - self.start
        if n < wire.HEADER_BYTES:
            return False
        plen = int.from_bytes(self.buf[self.start + 16:self.start + 20], "little")
        return n >= wire.HEADER_BYTES + plen

    def readable(self, seconds):
        """Whether bytes wait (buffered, or on the socket) within seconds
        (None: as long as it takes).  Waiting here is not a failure: the
        connection stays as it was."""
        if self.end > self.start:
            return True
        if self.sock is None:
            raise ConnectionLost("the connection is closed")
        if self.polling != select.POLLIN:
            self.poller.modify(self.sock, select.POLLIN)
            self.polling = select.POLLIN
        ms = -1 if seconds is None else max(0, int(seconds * 1000))
        return bool(self.poller.poll(ms))

    def _recv(self, deadline, into=None):
        """One recv into the buffer's free tail (or into `into`), after
        waiting for it; returns the byte count.  EOF, errors and the
        deadline raise."""
        if self.sock is None:
            raise ConnectionLost("the connection is closed")
        if into is None:
            if self.start == self.end:
                self.start = self.end = 0
            elif self.end == len(self.buf):
                n = self.end - self.start
                self.buf[:n] = self.buf[self.start:self.end]
                self.start, self.end = 0, n
            into = self.view[self.end:]
            own = True
        else:
            own = False
        try:
            while True:
                try:
                    got = self.sock.recv_into(into)
                    break
                except BlockingIOError:
                    self._wait(select.POLLIN, deadline)
        except QmcdError:
            raise  # our Timeout is an OSError too (TimeoutError)
        except OSError as e:
            raise self._failed(e) from None
        if got == 0:
            self.close()
            raise ConnectionLost("the daemon closed the connection")
        if own:
            self.end += got
        return got

    def read_header(self):
        """The next frame's (type, request_id, payload_len), checked (section
        2); returns a deadline by which its payload must arrive too."""
        deadline = None if self.timeout is None else time.monotonic() + self.timeout
        need = wire.HEADER_BYTES
        while self.end - self.start < need:
            have = self.end - self.start
            if have:
                why = wire.check_header_prefix(self.buf[self.start:self.end], have)
                if why:
                    self.close()
                    raise ProtocolError("protocol error: " + why)
            self._recv(deadline)
        h = self.view[self.start:self.start + need]
        self.start += need
        try:
            mtype, rid, plen = wire.parse_header(h, self.max_payload)
        except ProtocolError:
            self.close()
            raise
        return mtype, rid, plen, deadline

    def read_into(self, dest, deadline):
        """Fills memoryview dest (byte-cast) with the next payload bytes:
        from the buffer first, then straight from the socket."""
        n = len(dest)
        have = min(self.end - self.start, n)
        if have:
            dest[:have] = self.view[self.start:self.start + have]
            self.start += have
        off = have
        while off < n:
            if n - off < 4096:
                # A short tail: read ahead into the buffer, so the next
                # frame's header comes with it.
                self._recv(deadline)
                take = min(self.end - self.start, n - off)
                dest[off:off + take] = self.view[self.start:self.start + take]
                self.start += take
                off += take
            else:
                off += self._recv(deadline, dest[off:])

    def read_payload(self, plen, deadline):
        """The payload as bytes (a copy: it outlives the buffer)."""
        if self.end - self.start >= plen:
            p = bytes(self.view[self.start:self.start + plen])
            self.start += plen
            return p
        out = bytearray(plen)
        self.read_into(memoryview(out), deadline)
        return bytes(out)
