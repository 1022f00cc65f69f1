"""qmcd.client - one connection to qmcd: the handshake (with the HMAC
proofs when the daemon asks), PING and STATS, points and pixel tiles as
numpy arrays, and the frame loop every request shares.

Answers are matched by request id (PROTOCOL.md section 3).  A frame for
another request in flight - a job's result arriving while points stream -
is filed with that request; anything else is a protocol error that closes
the connection.  Over a Unix socket a request of more than one chunk
first attaches a shared-memory ring (ring.py), and the server then writes
points into it: each chunk is copied once, from the ring straight into
the result array; inline chunks are read from the socket straight into
it.  A request for more points than the server's max_points is sent as
several, so the caller sees one array whatever the daemon's limit.

Must not: print, block past the timeout on any read, send a message the
negotiated version lacks, or keep a connection whose stream went wrong.
"""
import os
import struct
import threading
import time

import numpy as np

from . import auth as _auth
from . import wire
from .conn import Conn, open_socket, parse_endpoint
from .errors import (AuthError, FrameTooBig, ProtocolError, QmcdError, ServerError, QMC_EINVAL,
                     QMC_ENOTSUP)
from .ring import Ring

CLIENT_NAME = "qmcd-python/0.1.0"
# The largest payload we accept: a 1 MiB chunk and its prefix, with room.
MAX_FRAME = wire.CHUNK_BYTES + 4096
DEFAULT_TIMEOUT = 30.0
AUTO_SLOTS = 8
AUTO_SLOT_BYTES = wire.CHUNK_BYTES
# Joe & Kuo's new-joe-kuo-6.21201, as qmc_sobol_table_hash() fingerprints
# it (FNV-1a over degree, coefficients and initial numbers; see
# core/seq_sobol.c).  Sobol points equal scipy's only from this table; the
# unit tests recompute the fingerprint from data/new-joe-kuo-6.21201.
JOE_KUO_TABLE_HASH = 0xD2213C5F4111BE68

DTYPES = {"f64": np.dtype("<f8"), "f32": np.dtype("<f4"), "u32": np.dtype("<u4")}
FINITE_KINDS = ("hammersley", "stratified", "lhs")
_CHUNK_PREFIX = struct.Struct("<QII")


def format_of(dtype):
    """The wire format for a dtype given as "f64"/"f32"/"u32" or a numpy
    dtype (float64, float32, uint32)."""
    if isinstance(dtype, str) and dtype in DTYPES:
        return dtype
    try:
        dt = np.dtype(dtype)
    except TypeError:
        dt = None
    for name, d in DTYPES.items():
        if dt is not None and dt.kind == d.kind and dt.itemsize == d.itemsize:
            return name
    raise ValueError("dtype %r: want f64, f32 or u32 (numpy float64, float32, uint32)"
                     % (dtype,))


def _result_dtype(fmt):
    # The wire is little-endian; numpy's native order on the machines qmcd
    # runs on.  A big-endian host would get a byte-swapped view's copy.
    return DTYPES[fmt].newbyteorder("=") if DTYPES[fmt].isnative else DTYPES[fmt]


class Client:
    """A connection to qmcd.  Use qmcd.connect() to make one.

    Attributes after the handshake: endpoint, version (the protocol version
    HELLO_OK chose), server, engine, sobol_table (hex), sobol_table_matches,
    max_frame, max_inflight, max_points, authenticated, unix.
    """

    def __init__(self, endpoint=None, auth_key=None, timeout=DEFAULT_TIMEOUT, shm=True,
                 name=CLIENT_NAME):
        if endpoint is None:
            endpoint = os.environ.get("QMC_ENDPOINT") or None
        if not endpoint:
            raise QmcdError(QMC_EINVAL, "no daemon to connect to: give an endpoint "
                            "(unix:PATH or tcp:HOST:PORT) or set QMC_ENDPOINT")
        if timeout is not None and not timeout > 0:
            raise ValueError("timeout %r: want seconds > 0, or None for none" % (timeout,))
        self.endpoint = endpoint
        self.timeout = timeout
        self.unix = parse_endpoint(endpoint)[0] == "unix"
        self._key = self._load_key(auth_key)
        self.version = wire.VERSION_MAX  # until HELLO_OK says
        self.authenticated = False
        self._next_id = 1
        self._jobs = {}          # request id -> Job, unfinished
        self._sessions = {}      # request id -> session state (sessions.py)
        self._ring = None
        self._shm = shm
        self._shm_off = not shm
        self._streaming = False  # a points_chunks() iteration is open
        self._name = name
        self._lock = threading.RLock()
        self._conn = Conn(open_socket(endpoint, timeout), timeout, MAX_FRAME)
        try:
            self._hello(name)
        except BaseException:
            self._conn.close()
            raise

    @staticmethod
    def _load_key(auth_key):
        if auth_key is None:
            path = os.environ.get("QMC_AUTH_KEY_FILE")
            return _auth.load_key(path) if path else None
        if isinstance(auth_key, (bytes, bytearray, memoryview)):
            return _auth.check_key(bytes(auth_key), "auth key")
        if auth_key == "" or auth_key is False:
            return None
        return _auth.load_key(auth_key)

    # -- lifetime --
    def close(self):
        """Closes the connection (its jobs are cancelled by the daemon; its
        sessions are parked, resumable for their park_ms)."""
        with self._lock:
            self._drop()
            self._key = None

    def _drop(self):
        self._conn.close()
        if self._ring is not None:
            self._ring.close()
            self._ring = None

    def reconnect(self):
        """A new connection to the same endpoint, with the same key: the
        handshake again, the ring attached again when needed.  Jobs of the
        old connection are lost (wait() raises ConnectionLost); sessions
        are parked on the daemon and resumable (resume(ticket))."""
        from .errors import ConnectionLost
        with self._lock:
            self._drop()
            lost = ConnectionLost("the connection was replaced; the daemon cancelled this job")
            for job in self._jobs.values():
                job._error, job.finished = lost, True
            self._jobs.clear()
            for sess in self._sessions.values():
                sess._unpin()
            self._sessions.clear()
            self._shm_off = not self._shm
            self._streaming = False
            self._next_id = 1
            self.authenticated = False
            self.version = wire.VERSION_MAX
            self._conn = Conn(open_socket(self.endpoint, self.timeout), self.timeout, MAX_FRAME)
            try:
                self._hello(self._name)
            except BaseException:
                self._conn.close()
                raise

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        conn = getattr(self, "_conn", None)
        if conn is not None:
            conn.close()

    @property
    def closed(self):
        return self._conn.closed

    def __repr__(self):
        return "<qmcd.Client %s %s, protocol %d%s>" % (
            self.endpoint, "closed" if self.closed else "open", self.version,
            ", shared memory" if self._ring else "")

    # -- frames --
    def _id(self):
        rid = self._next_id
        self._next_id += 1
        return rid

    def _send(self, mtype, fields, rid=None, fd=None):
        if self._streaming and mtype not in (wire.SHM_RELEASE, wire.POINTS):
            raise QmcdError(QMC_EINVAL, "a points_chunks() stream is open on this client: "
                            "read it to its end first")
        if rid is None:
            rid = self._id()
        self._conn.send(wire.encode(mtype, rid, fields, self.version), fd)
        return rid

    def _break(self, exc):
        """Closes the connection and returns exc, for `raise`."""
        self.close()
        return exc

    def _release(self):
        """Gives back every ring slot handled, before we might block.
        Release is oldest first: while a session's batch holds slots
        (pinned until its values are sent) nothing goes back."""
        ring = self._ring
        if ring is not None and ring.held and not ring.pinned and \
                not self._conn.whole_frame_buffered():
            held, ring.held = ring.held, 0
            self._send(wire.SHM_RELEASE, {"slots": held}, rid=0)

    def _frame(self):
        """The next frame: (type, request_id, payload dict)."""
        self._release()
        mtype, rid, plen, deadline = self._conn.read_header()
        payload = self._conn.read_payload(plen, deadline)
        try:
            return mtype, rid, wire.decode_payload(mtype, payload, self.version)
        except ProtocolError as e:
            raise self._break(e)

    def _await(self, rid):
        """The next frame answering request rid; frames for other requests
        in flight are filed with them."""
        while True:
            mtype, frid, msg = self._frame()
            if frid == rid:
                return mtype, msg
            self._other(mtype, frid, msg)

    def _pump(self):
        """Reads one frame and files it with the request it answers."""
        mtype, rid, msg = self._frame()
        self._other(mtype, rid, msg)

    def _other(self, mtype, rid, msg):
        if rid == 0 and mtype == wire.ERROR:
            raise self._break(ServerError(msg["code"], "the daemon closed the connection: %s"
                                          % msg["message"], 0))
        job = self._jobs.get(rid)
        if job is not None and job._file(mtype, msg):
            if job.finished:
                del self._jobs[rid]
            return
        s = self._sessions.get(rid)
        if s is not None:
            s._file(mtype, msg)
            if s.done:
                del self._sessions[rid]
            return
        if mtype == wire.ERROR:
            for s in self._sessions.values():
                if s._refused(rid, msg):
                    return
        raise self._break(ProtocolError("protocol error: %s for request %d, which is not in "
                                        "flight" % (wire.type_name(mtype), rid)))

    def _answer(self, rid, want):
        """The frame of type `want` answering rid, or the daemon's ERROR
        raised as ServerError."""
        mtype, msg = self._await(rid)
        if mtype == wire.ERROR:
            raise ServerError(msg["code"], msg["message"], rid)
        if mtype != want:
            raise self._break(ProtocolError("protocol error: %s instead of %s"
                                            % (wire.type_name(mtype), wire.type_name(want))))
        return msg

    def _need(self, version, what):
        if self.version < version:
            raise QmcdError(QMC_ENOTSUP, "%s: the server speaks protocol version %d; this "
                            "needs %d (a newer qmcd)" % (what, self.version, version))

    # -- handshake --
    def _hello(self, name):
        vmin, vmax = wire.VERSION_MIN, wire.VERSION_MAX
        rid = self._send(wire.HELLO, {"version_min": vmin, "version_max": vmax,
                                      "max_frame": MAX_FRAME, "client": name})
        try:
            mtype, msg = self._await(rid)
            if mtype == wire.AUTH_CHALLENGE:
                mtype, msg = self._authenticate(rid, vmin, vmax, msg)
        except ProtocolError as e:
            why = "handshake failed: the peer does not speak the qmcd protocol (%s)" % e.message
            raise self._break(FrameTooBig(why) if isinstance(e, FrameTooBig)
                              else ProtocolError(why, e.code))
        if mtype == wire.ERROR:
            raise self._break(ServerError(msg["code"], "the server refused the handshake: %s"
                                          % msg["message"], rid))
        if mtype != wire.HELLO_OK:
            raise self._break(ProtocolError("handshake failed: %s instead of HELLO_OK"
                                            % wire.type_name(mtype)))
        if self._key is not None and not self.authenticated and not self.unix:
            raise self._break(AuthError(
                "the server did not ask for authentication, so it cannot prove it holds our "
                "key; refusing it (connect without a key to a server that has none)"))
        if not wire.VERSION_MIN <= msg["version"] <= wire.VERSION_MAX:
            raise self._break(ProtocolError("handshake failed: the server chose protocol "
                                            "version %d; we speak %d..%d"
                                            % (msg["version"], vmin, vmax)))
        self.version = msg["version"]
        self.max_frame = msg["max_frame"]
        self.max_inflight = msg["max_inflight"]
        self.max_points = msg["max_points"]
        self.sobol_table_hash = msg["sobol_table_hash"]
        self.server = msg["server"]
        self.engine = msg["engine"]
        if self.max_frame < 64:
            raise self._break(ProtocolError("handshake failed: the server accepts frames of "
                                            "only %d bytes" % self.max_frame))

    def _authenticate(self, rid, vmin, vmax, challenge):
        if self._key is None:
            raise self._break(AuthError("the server requires authentication: give its key "
                                        "(auth_key=PATH, or QMC_AUTH_KEY_FILE)"))
        version = challenge["version"]
        if not vmin <= version <= vmax:
            raise self._break(ProtocolError("handshake failed: the server's challenge names "
                                            "protocol version %d; we offered %d..%d"
                                            % (version, vmin, vmax)))
        nonce = os.urandom(wire.AUTH_NONCE_BYTES)
        ns = challenge["nonce"]
        mac = _auth.proof(self._key, _auth.LABEL_CLIENT, vmin, vmax, version, ns, nonce)
        expect = _auth.proof(self._key, _auth.LABEL_SERVER, vmin, vmax, version, ns, nonce)
        self._send(wire.AUTH_RESPONSE, {"nonce": nonce, "mac": mac}, rid=rid)
        mtype, msg = self._await(rid)
        if mtype == wire.ERROR:
            raise self._break(ServerError(msg["code"], "the server refused the handshake: %s"
                                          % msg["message"], rid))
        if mtype != wire.AUTH_OK:
            raise self._break(ProtocolError("handshake failed: %s instead of AUTH_OK"
                                            % wire.type_name(mtype)))
        if not _auth.same(msg["mac"], expect):
            raise self._break(AuthError("authentication failed: the server could not prove "
                                        "it holds our key (a different key, or not the "
                                        "server we meant)"))
        mtype, msg = self._await(rid)
        if mtype == wire.HELLO_OK and msg["version"] != version:
            raise self._break(ProtocolError("handshake failed: HELLO_OK chose version %d "
                                            "after a challenge for %d"
                                            % (msg["version"], version)))
        self.authenticated = True
        return mtype, msg

    # -- identity, PING, STATS --
    @property
    def sobol_table(self):
        return "%016x" % self.sobol_table_hash

    @property
    def sobol_table_matches(self):
        """Whether the daemon's Sobol table is Joe & Kuo's 21201-dimension
        one, the table this package (and scipy) assume."""
        return self.sobol_table_hash == JOE_KUO_TABLE_HASH

    def ping(self, data=None):
        """One round trip; returns its time in seconds.  The PONG must echo
        data (default: 8 bytes naming this request)."""
        with self._lock:
            rid = self._id()
            if data is None:
                data = (rid * 0x9E3779B97F4A7C15 & (2**64 - 1)).to_bytes(8, "little")
            t0 = time.perf_counter()
            self._send(wire.PING, {"data": data}, rid=rid)
            msg = self._answer(rid, wire.PONG)
            t1 = time.perf_counter()
            if msg["data"] != bytes(data):
                raise self._break(ProtocolError("protocol error: PONG does not echo the "
                                                "PING's data"))
            return t1 - t0

    def info(self, pings=1):
        """What `qmc ping --json` prints, as a dict: server, engine,
        sobol_table, sobol_table_matches, max_frame_bytes, max_inflight,
        max_points, rtt_ms (one per PING)."""
        rtt = [1e3 * self.ping() for _ in range(pings)]
        return {"server": self.server, "engine": self.engine, "sobol_table": self.sobol_table,
                "sobol_table_matches": self.sobol_table_matches,
                "max_frame_bytes": self.max_frame, "max_inflight": self.max_inflight,
                "max_points": self.max_points, "rtt_ms": rtt}

    def stats(self):
        """The daemon's counters (STATS_REPLY) as a dict name -> value."""
        with self._lock:
            rid = self._send(wire.STATS, {})
            return self._answer(rid, wire.STATS_REPLY)["stats"]

    # -- the shared-memory ring --
    def attach_shm(self, slots=AUTO_SLOTS, slot_bytes=AUTO_SLOT_BYTES):
        """Attaches a ring of slots x slot_bytes (PROTOCOL.md section 10);
        a Unix socket and protocol version 2 are needed.  Done by itself
        before the first large request unless connect(shm=False)."""
        with self._lock:
            if self._ring is not None:
                raise QmcdError(QMC_EINVAL, "shared memory: a ring is already attached to "
                                "this connection")
            if not (wire.SHM_MIN_SLOTS <= slots <= wire.SHM_MAX_SLOTS and
                    wire.SHM_MIN_SLOT_BYTES <= slot_bytes <= wire.SHM_MAX_SLOT_BYTES and
                    slot_bytes % wire.SHM_SLOT_ALIGN == 0):
                raise QmcdError(QMC_EINVAL, "shared memory: %d slots of %d bytes: want %d..%d "
                                "slots of a multiple of %d bytes in %d..%d"
                                % (slots, slot_bytes, wire.SHM_MIN_SLOTS, wire.SHM_MAX_SLOTS,
                                   wire.SHM_SLOT_ALIGN, wire.SHM_MIN_SLOT_BYTES,
                                   wire.SHM_MAX_SLOT_BYTES))
            if not self.unix:
                raise QmcdError(QMC_ENOTSUP, "shared memory needs a unix: endpoint")
            self._need(wire.VERSION_SHM, "shared memory")
            ring = Ring(slots, slot_bytes)
            try:
                rid = self._id()
                frame = wire.encode(wire.SHM_ATTACH, rid, {"slots": slots,
                                                           "slot_bytes": slot_bytes})
                self._conn.send(frame, ring.fd)
                ring.sent()
                msg = self._answer(rid, wire.SHM_OK)
                if msg["slots"] != slots or msg["slot_bytes"] != slot_bytes:
                    raise self._break(ProtocolError(
                        "protocol error: SHM_OK (%d x %d) in answer to SHM_ATTACH (%d x %d)"
                        % (msg["slots"], msg["slot_bytes"], slots, slot_bytes)))
            except BaseException:
                ring.close()
                raise
            self._ring = ring

    def _shm_auto(self):
        if self._ring is not None or self._shm_off or not self.unix or \
                self.version < wire.VERSION_SHM:
            return
        try:
            self.attach_shm()
        except ServerError:
            self._shm_off = True  # refused here (turned off, too big): inline from now on
        except QmcdError:
            if self.closed:
                raise
            self._shm_off = True

    # -- streams of points (POINTS and PIXELS answers) --
    def _stream(self, mtype, fields, count, row_bytes, first0, dest=None):
        """A generator: sends one POINTS or PIXELS request for `count` points
        of row_bytes bytes, the first at index first0, and yields (done,
        points, view) for each chunk as it arrives, done being the points
        before it.  With dest (a byte memoryview of count * row_bytes) the
        chunk is already in place there and view is None; else view holds
        its bytes (a ring slot, or a buffer reused for the next chunk),
        valid until the generator is resumed.  Returns after END; raises
        the daemon's ERROR as ServerError."""
        if count * row_bytes > AUTO_SLOT_BYTES:
            self._shm_auto()
        ring = self._ring
        # While a session's batch pins ring slots, streams go inline (as
        # libqmcclient's do): releases are oldest first.
        shm = ring is not None and not ring.pinned and row_bytes <= ring.slot_bytes
        fields["transport"] = "shm" if shm else "inline"
        rid = self._send(mtype, fields)
        got = 0
        conn = self._conn
        scratch = None
        while True:
            if ring is not None and ring.held and not ring.pinned:
                self._release()
            ftype, frid, plen, deadline = conn.read_header()
            if frid != rid:
                payload = conn.read_payload(plen, deadline)
                try:
                    msg = wire.decode_payload(ftype, payload, self.version)
                except ProtocolError as e:
                    raise self._break(e)
                self._other(ftype, frid, msg)
                continue
            if ftype == wire.POINTS_CHUNK and not shm:
                first, points, data_len = _CHUNK_PREFIX.unpack(conn.read_payload(16, deadline))
                if data_len != plen - 16 or data_len > wire.CHUNK_BYTES or points == 0 or \
                        data_len % 4 or data_len % points or data_len // points < 4:
                    raise self._break(ProtocolError(
                        "malformed POINTS_CHUNK: %d points, data_len %d, payload %d"
                        % (points, data_len, plen)))
                self._check_chunk(first, points, data_len, first0 + got, count - got,
                                  row_bytes)
                if dest is not None:
                    conn.read_into(dest[got * row_bytes:got * row_bytes + data_len], deadline)
                    view = None
                else:
                    if scratch is None:
                        scratch = memoryview(bytearray(wire.CHUNK_BYTES))
                    view = scratch[:data_len]
                    conn.read_into(view, deadline)
                yield got, points, view
                got += points
                continue
            payload = conn.read_payload(plen, deadline)
            try:
                msg = wire.decode_payload(ftype, payload, self.version)
            except ProtocolError as e:
                raise self._break(e)
            if ftype == wire.POINTS_SHM_CHUNK and shm:
                if msg["slot"] != ring.next or msg["data_len"] > ring.slot_bytes or \
                        ring.held >= ring.slots:
                    raise self._break(ProtocolError(
                        "protocol error: a chunk of %d bytes in ring slot %d; expected slot "
                        "%d, at most %d bytes, with %d of %d slots held"
                        % (msg["data_len"], msg["slot"], ring.next, ring.slot_bytes,
                           ring.held, ring.slots)))
                ring.next = (ring.next + 1) % ring.slots
                ring.held += 1  # given back before we next wait (_release)
                n, points = msg["data_len"], msg["points"]
                self._check_chunk(msg["first"], points, n, first0 + got, count - got,
                                  row_bytes)
                view = ring.slot(msg["slot"], n)
                if dest is not None:
                    dest[got * row_bytes:got * row_bytes + n] = view
                    view = None
                    # Copied out: the slot can go back at once, so the
                    # daemon refills it while we copy the next one.
                    if not ring.pinned:
                        held, ring.held = ring.held, 0
                        self._send(wire.SHM_RELEASE, {"slots": held}, rid=0)
                yield got, points, view
                got += points
            elif ftype == wire.END:
                if msg["points"] != got or got != count or msg["bytes"] != got * row_bytes:
                    raise self._break(ProtocolError(
                        "protocol error: END says %d points in %d bytes; %d of %d points in "
                        "%d bytes arrived" % (msg["points"], msg["bytes"], got, count,
                                              got * row_bytes)))
                if ring is not None and ring.held:
                    self._release()
                return
            elif ftype == wire.ERROR:
                if ring is not None and ring.held:
                    self._release()
                raise ServerError(msg["code"], msg["message"], rid)
            else:
                raise self._break(ProtocolError(
                    "protocol error: %s in a points stream (%s transport)"
                    % (wire.type_name(ftype), "shm" if shm else "inline")))

    def _fill(self, mtype, fields, count, row_bytes, first0, dest):
        for _ in self._stream(mtype, fields, count, row_bytes, first0, dest):
            pass

    def _check_chunk(self, first, points, data_len, want_first, left, row_bytes):
        if first != want_first or points > left or data_len != points * row_bytes:
            raise self._break(ProtocolError(
                "protocol error: chunk of %d points (%d bytes) at index %d; expected index "
                "%d, %d bytes a point, at most %d points"
                % (points, data_len, first, want_first, row_bytes, left)))

    # -- points --
    def _points_request(self, kind, dims, count, start, scramble, seed, dtype, shuffle,
                        set_size):
        fmt = format_of(dtype)
        if kind not in wire.KINDS:
            raise ValueError("kind %r: want one of %s" % (kind, ", ".join(wire.KINDS)))
        if scramble not in wire.SCRAMBLES:
            raise ValueError("scramble %r: want one of %s"
                             % (scramble, ", ".join(wire.SCRAMBLES)))
        dims, count, start = int(dims), int(count), int(start)
        if dims < 1 or count < 0 or start < 0:
            raise ValueError("points: dims >= 1, count >= 0 and start >= 0, not %d, %d, %d"
                             % (dims, count, start))
        if kind in FINITE_KINDS:
            set_size = start + count if set_size is None else int(set_size)
        elif set_size is not None:
            raise ValueError("set_size: %s is an infinite sequence and takes no set size" % kind)
        else:
            set_size = 0
        if scramble == "fast-owen":
            self._need(wire.VERSION_PIXELS, "scramble fast-owen")
        fields = {"kind": kind, "scramble": scramble, "format": fmt, "dims": dims,
                  "flags": wire.SEQ_SHUFFLE if shuffle else 0, "seed": int(seed) % 2**64,
                  "set_size": set_size}
        return fmt, fields, dims, count, start, dims * wire.FORMAT_BYTES[fmt]

    def points(self, kind, dims, count, start=0, scramble="none", seed=0, dtype="f64",
               shuffle=False, set_size=None, out=None):
        """Points [start, start + count) of a sequence as a (count, dims)
        numpy array: what `qmc points` gives for the same options, value
        for value.

        kind: sobol, halton, hammersley, random, stratified, lhs.
        scramble: none, shift, owen, faure, fast-owen (which the kind takes).
        dtype: "f64" (float64), "f32" (float32: floor(x 2^24) / 2^24) or
        "u32" (uint32: floor(x 2^32)).  set_size: the finite kinds'
        (hammersley, stratified, lhs) set, default start + count, as the
        CLI has it.  out: an array of that shape and dtype, C-contiguous,
        to fill instead of a new one.  Each value is written once: from
        the socket, or from the shared-memory ring, straight into the array.
        """
        fmt, fields, dims, count, start, row = self._points_request(
            kind, dims, count, start, scramble, seed, dtype, shuffle, set_size)
        arr = self._out(out, (count, dims), fmt)
        if count == 0:
            return arr
        flat = memoryview(arr).cast("B")
        with self._lock:
            per = self.max_points or count
            done = 0
            while done < count:
                n = min(per, count - done)
                fields["start"], fields["count"] = start + done, n
                self._fill(wire.POINTS, fields, n, row, start + done,
                           flat[done * row:(done + n) * row])
                done += n
        return arr

    def points_chunks(self, kind, dims, count, start=0, scramble="none", seed=0, dtype="f64",
                      shuffle=False, set_size=None):
        """The points of points(...), chunk by chunk as they arrive, without
        copying them: yields (index, array) with array a read-only (n, dims)
        view of the chunk's n points from index on - in the shared-memory
        ring over a Unix socket.  Each view is valid only until the next
        step (its slot then goes back to the daemon): copy what you keep.
        Until the iteration ends the client takes no other request; leaving
        it early closes the connection (the stream cannot be stopped)."""
        fmt, fields, dims, count, start, row = self._points_request(
            kind, dims, count, start, scramble, seed, dtype, shuffle, set_size)
        dt = _result_dtype(fmt)
        with self._lock:
            if self._streaming:
                raise QmcdError(QMC_EINVAL, "points_chunks: another stream is open on this "
                                "client")
            self._streaming = True
            finished = False
            try:
                per = self.max_points or count
                done = 0
                while done < count:
                    n = min(per, count - done)
                    fields["start"], fields["count"] = start + done, n
                    for got, pts, view in self._stream(wire.POINTS, fields, n, row,
                                                       start + done):
                        yield start + done + got, \
                            np.frombuffer(view, dtype=dt).reshape(pts, dims)
                    done += n
                finished = True
            finally:
                self._streaming = False
                if not finished and not self.closed:
                    # Left mid-stream: the rest is on its way and cannot be
                    # stopped, so the connection goes (as libqmcclient does).
                    self.close()

    @staticmethod
    def _out(out, shape, fmt):
        dt = _result_dtype(fmt)
        if out is None:
            return np.empty(shape, dtype=dt)
        if out.shape != tuple(shape) or out.dtype != dt or not out.flags.c_contiguous or \
                not out.flags.writeable:
            raise ValueError("out: want a writable C-contiguous %s array of shape %s, not %s %s"
                             % (dt, tuple(shape), out.dtype, out.shape))
        return out

    # -- pixel tiles --
    def pixels(self, sampler, resolution, spp, dims, tile=None, samples=None, seed=0, frame=0,
               dtype="f32", out=None):
        """A tile of a pixel sampler (protocol version 4) as an array of shape
        (tile height, tile width, sample count, dims): what `qmc pixels`
        writes for the same options, value for value.

        sampler: zsobol, padded-sobol, sobol.  resolution: (width, height)
        of the whole image.  tile: (x, y, width, height), default the whole
        image.  samples: (start, count) of each pixel's samples, default
        (0, spp).  seed: pbrt-v4's int seed (a negative int is taken as
        its 32 bits).  dtype: "f32" (default), "f64" or "u32".
        """
        fmt = format_of(dtype)
        if sampler not in wire.PIXEL_SAMPLERS:
            raise ValueError("sampler %r: want one of %s"
                             % (sampler, ", ".join(wire.PIXEL_SAMPLERS)))
        width, height = (int(v) for v in resolution)
        x, y, tw, th = (int(v) for v in (tile if tile is not None else (0, 0, width, height)))
        s0, sn = (int(v) for v in (samples if samples is not None else (0, spp)))
        seed = int(seed)
        if not -2**31 <= seed < 2**32:
            raise ValueError("seed %d: pbrt-v4's int seed, -2^31 .. 2^32 - 1" % seed)
        arr = self._out(out, (th, tw, sn, int(dims)), fmt)
        total = tw * th * sn
        row = int(dims) * wire.FORMAT_BYTES[fmt]
        flat = memoryview(arr).cast("B")
        fields = {"sampler": sampler, "format": fmt, "width": width, "height": height,
                  "seed": seed % 2**32, "frame": int(frame), "dims": int(dims), "spp": int(spp)}
        with self._lock:
            self._need(wire.VERSION_PIXELS, "pixels")
            if total == 0:
                # An empty tile: the daemon says what is wrong with it.
                fields.update(x=x, y=y, tile_width=tw, tile_height=th, sample_start=s0,
                              sample_count=sn)
                self._fill(wire.PIXELS, fields, 0, row, 0, flat[:0])
                return arr
            per = self.max_points or total
            done = 0
            while done < total:
                px, py, pw, ph, ps0, psn = tile_piece((x, y, tw, th, s0, sn), done, per)
                n = pw * ph * psn
                f = dict(fields, x=px, y=py, tile_width=pw, tile_height=ph, sample_start=ps0,
                         sample_count=psn)
                self._fill(wire.PIXELS, f, n, row, 0, flat[done * row:(done + n) * row])
                done += n
        return arr

    # -- jobs --
    def submit(self, integrand=None, dims=None, **options):
        """Starts an integration job on the daemon; returns a qmcd.Job.
        The options are `qmc integrate`'s (see qmcd.jobs.job_request)."""
        from .jobs import Job, job_request
        request = job_request(integrand, dims, **options)
        with self._lock:
            if request.fields["sampling"]["scramble"] == "fast-owen":
                self._need(wire.VERSION_PIXELS, "scramble fast-owen")
            rid = self._send(wire.INTEGRATE, request.fields)
            msg = self._answer(rid, wire.JOB_ACCEPTED)
            if any(j.id == msg["job_id"] for j in self._jobs.values()):
                raise self._break(ProtocolError("protocol error: job id %d given twice"
                                                % msg["job_id"]))
            job = Job(self, rid, msg["job_id"], request)
            self._jobs[rid] = job
            return job

    def run(self, integrand=None, dims=None, **options):
        """submit(...).wait(): the job's JobResult."""
        return self.submit(integrand, dims, **options).wait()

    # -- integration sessions: the caller's own function --
    def session(self, dims, method="auto", **options):
        """Opens an integration session for a function of dims dimensions
        (protocol version 5); returns a qmcd.Session to drive with next()
        and tell().  options: as integrate()'s."""
        from .sessions import Session, ring_for, session_fields
        fields, request = session_fields(dims, method, **options)
        with self._lock:
            self._need(wire.VERSION_SESSIONS, "sessions")
            if method in ("auto", "mc", "stratified", "lhs", "qmc", "rqmc") and \
                    self._ring is None and not self._shm_off and self.unix:
                # Sampling batches are large: a ring they fit in whole.
                slots, slot_bytes = ring_for(fields["dims"], fields["max_batch"])
                try:
                    self.attach_shm(slots, slot_bytes)
                except QmcdError:
                    if self.closed:
                        raise
                    self._shm_off = True
            fields["transport"] = "shm" if self._ring is not None else "inline"
            return self._start_session(wire.SESSION_OPEN, fields, fields["dims"], request)

    def resume(self, ticket, request=None):
        """Takes up a session again (SESSION_RESUME) from its ticket, (id,
        token), on this connection: the batch it waits for is served again.
        The daemon refuses (-ENOENT) a session of another identity, with a
        wrong token, or past its park_ms."""
        from .sessions import SessionRequest
        sid, token = ticket
        with self._lock:
            self._need(wire.VERSION_SESSIONS, "sessions")
            fields = {"session_id": sid, "token": token,
                      "transport": "shm" if self._ring is not None else "inline"}
            return self._start_session(wire.SESSION_RESUME, fields, 0,
                                       request or SessionRequest({}, "f", "auto", 0.95))

    def _start_session(self, mtype, fields, dims, request):
        from .sessions import Session
        rid = self._id()
        s = Session(self, rid, dims, request)
        self._sessions[rid] = s
        self._send(mtype, fields, rid=rid)
        while s.state == 0:  # opening: until SESSION_OPENED or the refusal
            self._pump()
        if s.done:
            self._sessions.pop(rid, None)
            raise s._error
        return s

    def integrate(self, f, dims, method="auto", *, retries=3, on_report=None, **options):
        """Integrates the caller's own function over [0,1)^dims on the
        daemon: f takes an (n, dims) float64 array (read-only) and returns
        n values; the daemon's integrator asks for the batches it needs
        and keeps the estimate, its error bar and the flags, as for a job.
        Returns a SessionResult (json() as `qmc integrate --json`).

        options: method and tol_rel, tol_abs, n, reps, seq, scramble,
        shuffle, split_net, seed, max_evals, max_memory, confidence (as
        submit() and `qmc integrate` take them); smoothness of f
        ("continuous" by default; "analytic" lets auto choose a rule for
        smooth functions), exact (its integral, when known: tests), name,
        max_batch.  on_report(report) is called after each batch.  When the
        connection drops, the client reconnects and resumes the session,
        at most `retries` times; the values of the batch that was waiting
        are sent again, not recomputed.
        """
        from .errors import ConnectionLost, Timeout
        import numpy as _np
        s = self.session(dims, method, **options)
        request = s.request
        ticket = s.ticket
        kept = None  # (seq, values) of the last batch evaluated
        tries = 0
        while True:
            try:
                while True:
                    b = s.next()
                    if b is None:
                        break
                    if kept is not None and kept[0] == b.seq and len(kept[1]) == b.count:
                        v = kept[1]
                    else:
                        v = _np.asarray(f(b.points), dtype=_np.float64).reshape(-1)
                        if len(v) != b.count:
                            s.close()
                            raise ValueError("f returned %d values for %d points"
                                             % (len(v), b.count))
                        kept = (b.seq, v.copy())
                    s.tell(v)
                    if on_report is not None:
                        on_report(s.report)
                return s.result()
            except (ConnectionLost, Timeout):
                tries += 1
                if tries > retries:
                    raise
                self.reconnect()
                s = self.resume(ticket, request)


def tile_piece(tile, done, max_samples):
    """The piece of tile (x, y, w, h, sample_start, sample_count) whose
    output starts at sample `done` of the tile's output and holds at most
    max_samples: whole rows where a row fits, else whole pixels of one
    row, else part of one pixel's samples (core/pixel_piece.c's rule, so
    the pieces laid end to end are the tile's output)."""
    x, y, w, h, s0, n = tile
    pixel, s = divmod(done, n)
    row, col = divmod(pixel, w)
    px, py, pw, ph, ps0, psn = x + col, y + row, 1, 1, s0 + s, n - s
    if s == 0 and col == 0 and n <= max_samples // w:
        pw, ph = w, min(max_samples // (w * n), h - row)
    elif s == 0 and n <= max_samples:
        pw = min(max_samples // n, w - col)
    elif psn > max_samples:
        psn = max_samples
    return px, py, pw, ph, ps0, psn


def connect(endpoint=None, auth_key=None, timeout=DEFAULT_TIMEOUT, shm=True):
    """A Client connected to qmcd and past the handshake.

    endpoint: "unix:PATH", "tcp:HOST:PORT" or "tcp:[V6]:PORT"; default
    $QMC_ENDPOINT.  auth_key: the path of a key file (mode 0600, 16-1024
    bytes), or the key itself as bytes; default $QMC_AUTH_KEY_FILE when
    set.  With a key, a tcp: daemon must prove it holds it too (as `qmc`
    insists).  timeout: seconds each answer (each frame) may take, None
    for no limit.  shm: use a shared-memory ring for bulk data over a Unix
    socket.
    """
    return Client(endpoint, auth_key, timeout, shm)
