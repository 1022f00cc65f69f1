"""qmcd.client - one connection to qmcd: the handshake (with the HMAC
proofs when the daemon asks), PING and STATS, the shared-memory ring, jobs,
and the frame loop every request shares; points and pixel tiles are in
streams.py, sessions in sessions.py (mixed into Client).

Answers are matched by request id (PROTOCOL.md section 3).  A frame for
another request in flight - a job's result arriving while points stream,
a session's batch - is filed with that request; anything else is a
protocol error that closes the connection.  Over a Unix socket a request
of more than one chunk first attaches a shared-memory ring (ring.py).

Must not: print, block past the timeout on any read, send a message the
negotiated version lacks, or keep a connection whose stream went wrong.
"""
import os
import threading
import time

from . import auth as _auth
from . import wire
from .conn import Conn, open_socket, parse_endpoint
from .errors import (AuthError, FrameTooBig, ProtocolError, QmcdError, ServerError, QMC_EINVAL,
                     QMC_ENOTSUP)
from .ring import Ring
from .sessions import SessionsMixin
from .streams import Streams, AUTO_SLOT_BYTES

CLIENT_NAME = "qmcd-python/0.1.0"
# The largest payload we accept: a 1 MiB chunk and its prefix, with room.
MAX_FRAME = wire.CHUNK_BYTES + 4096
DEFAULT_TIMEOUT = 30.0
AUTO_SLOTS = 8
# Joe & Kuo's new-joe-kuo-6.21201, as qmc_sobol_table_hash() fingerprints
# it (FNV-1a over degree, coefficients and initial numbers; see
# core/seq_sobol.c).  Sobol points equal scipy's only from this table; the
# unit tests recompute the fingerprint from data/new-joe-kuo-6.21201.
JOE_KUO_TABLE_HASH = 0xD2213C5F4111BE68


class Client(Streams, SessionsMixin):
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
        """Gives back every ring slot handled, before we might block."""
        if not self._conn.whole_frame_buffered():
            self._give_back()

    def _give_back(self):
        """SHM_RELEASE of every slot held, now (a session's report calls it
        too: sessions.py).  Release is oldest first: while a session's
        batch holds slots (pinned until its values are sent) nothing goes
        back."""
        ring = self._ring
        if ring is not None and ring.held and not ring.pinned:
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
