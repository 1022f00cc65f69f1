"""qmcd.sessions - integration sessions (protocol version 5, PROTOCOL.md
section 6.21): the daemon runs the integrator and hands out batches of
points; the client evaluates the caller's own function at them and sends
the values back; the daemon keeps the estimate, the error bar, the flags
and the stopping rule.  A built-in integrand answered through a session
gives INTEGRATE's result bit for bit, so a Python function that computes
the same values gets `qmc integrate`'s numbers.

Session is the ask/tell handle (next() a batch, tell() its values);
Client.integrate(f, dims, ...) drives one with a function, and when the
connection drops it reconnects and resumes the session (SESSION_RESUME
with its id and token): the batch that was waiting is served again, and
the values already computed for it are sent again rather than
recomputed.

Batches come inline or, over a Unix socket, in the shared-memory ring:
then the points are a view of the ring slot and the values are written
into the slot after them (the only writing into the ring a client does),
with no copy either way when the batch fits one slot.

Must not: send values for a batch the daemon did not hand out, release a
ring slot before the values in it are sent, or keep a view of the ring
past the batch it belongs to (the arrays handed out are valid until the
next tell()).
"""
import time

import numpy as np

from . import parts, wire
from .errors import ProtocolError, QmcdError, ServerError, QMC_EINVAL
from .jobs import JobResult, JobRequest

_OPENING, _WAITING, _READY, _TELLING, _DONE = range(5)
_F64 = np.dtype("<f8")


class SessionBatch:
    """A batch: .seq, .count, .points (a read-only (count, dims) float64
    array) and .values (a float64 array of count to fill, or pass your own
    to tell())."""

    def __init__(self, seq, points, values):
        self.seq, self.points, self.values = seq, points, values
        self.count = len(points)

    def __repr__(self):
        return "<qmcd.SessionBatch %d: %d points of %d dims>" % (
            self.seq, self.count, self.points.shape[1])


class SessionReport:
    """SESSION_REPORT: batches answered, values received (evals), how many
    were NaN or infinite, end (running, converged, complete, budget,
    cannot_tell, failed), and the running result where the method has one
    (has_estimate: estimate, error, error_kind, interval, flags)."""

    def __init__(self, msg):
        self.raw = msg
        self.batches, self.evals, self.nonfinite = msg["batches"], msg["evals"], msg["nonfinite"]
        self.end, self.err = msg["end"], msg["err"]
        self.has_estimate = msg["has_estimate"]
        self.estimate = msg["estimate"] if self.has_estimate else None
        kind = msg["error_kind"]
        self.error_kind = kind
        self.error = msg["error"] if self.has_estimate and kind != "none" else None
        self.interval = (msg["ci_low"], msg["ci_high"]) if self.error is not None else None
        self.flags = tuple(wire.flag_names(msg["flags"]))

    def __repr__(self):
        est = "" if self.estimate is None else ", estimate %.17g" % self.estimate
        return "<qmcd.SessionReport %s: %d batches, %d values%s>" % (
            self.end, self.batches, self.evals, est)


class SessionRequest(JobRequest):
    """What a session's report needs of its request: the label (the
    function's name in full, or "f"), the method asked for, the
    confidence; and, for a part's file, the `qmc integrate` words the
    session's options stand for (cli_args)."""

    cli_args = ()


def _wire_name(name):
    """The first SESSION_NAME_MAX bytes of name that are whole UTF-8
    characters: the daemon's label for the session (its logs).  The report
    prints the name in full, as `qmc integrate --command` prints the
    command it sends as "command"."""
    raw = name.encode("utf-8")[:wire.SESSION_NAME_MAX]
    return raw.decode("utf-8", errors="ignore")


def session_fields(dims, method="auto", *, smoothness="continuous", exact=None, name="",
                   max_batch=0, n=None, reps=None, seq=None, scramble=None, shuffle=False,
                   split_net=False, seed=0, tol_abs=0.0, tol_rel=0.0, max_evals=100000000,
                   max_memory=64 << 20, confidence=0.95, part=None):
    """SESSION_OPEN's fields (but transport) for a function of dims
    dimensions: the method and sampling spec as `qmc integrate` builds them
    for the same options (jobs.job_request), plus what the caller declares
    about f.  part: (k, p), part k of p of a fixed-n sampling job
    (protocol version 6); such a session is named "command" on the wire,
    as `qmc integrate --command` names its sessions, since the name
    enters the job's fingerprint and parts must agree on it to merge."""
    part_k = part_p = 0
    if part is not None:
        try:
            part_k, part_p = (int(x) for x in part)
        except (TypeError, ValueError):
            raise ValueError("part %r: want (k, p) with 1 <= k <= p" % (part,)) from None
        if not 1 <= part_k <= part_p < 2**32:
            raise ValueError("part %d/%d: want 1 <= k <= p" % (part_k, part_p))
    from .jobs import job_request
    if smoothness not in wire.SMOOTHNESS:
        raise ValueError("smoothness %r: want one of %s" % (smoothness,
                                                            ", ".join(wire.SMOOTHNESS)))
    # The integrate part exactly as for a built-in integrand of these
    # dims (its name only satisfies job_request's checks).
    job = job_request("genz-gaussian", dims, method=method, n=n, reps=reps, seq=seq,
                      scramble=scramble, shuffle=shuffle, split_net=split_net, seed=seed,
                      tol_abs=tol_abs, tol_rel=tol_rel, max_evals=max_evals,
                      max_memory=max_memory, confidence=confidence)
    j = job.fields
    fields = {"method": method, "smoothness": smoothness, "n_given": j["n_given"],
              "dims": j["dims"], "n_axis": j["n_axis"], "has_exact": exact is not None,
              "part_k": part_k, "part_p": part_p, "max_evals": j["max_evals"],
              "max_memory": j["max_memory"], "max_batch": int(max_batch),
              "tol_abs": j["tol_abs"], "tol_rel": j["tol_rel"],
              "exact": 0.0 if exact is None else float(exact), "sampling": j["sampling"],
              "name": "command" if part_p else _wire_name(name or "")}
    fields["transport"] = "inline"
    wire.LAYOUTS[wire.SESSION_OPEN].encode(fields)  # refused here, not on the wire
    request = SessionRequest(fields, name or "f", method, float(confidence))
    request.cli_args = parts.cli_args(
        dims, method, smoothness, name or "f", exact,
        dict(n=n, reps=reps, seq=seq, scramble=scramble, shuffle=shuffle, split_net=split_net,
             seed=seed, tol_abs=tol_abs, tol_rel=tol_rel, max_evals=max_evals,
             max_memory=max_memory, confidence=confidence))
    return fields, request


def ring_for(dims, max_batch):
    """(slots, slot_bytes) of a ring the session's largest batch fits in
    whole, points and values (client/lib/session.c sizes it alike: one
    slot if it can, and three: one in use, one filling, one spare)."""
    row = (dims + 1) * 8
    pts = max_batch
    if not pts:
        fit = (32 << 20) // row  # QMC_SESSION_BATCH_BYTES
        pts = min(fit or 1, 65536)  # QMC_SESSION_MAX_BATCH
    nbytes = pts * row
    slot = min(max(nbytes, wire.SHM_MIN_SLOT_BYTES), wire.SHM_MAX_SLOT_BYTES)
    slot = -(-slot // wire.SHM_SLOT_ALIGN) * wire.SHM_SLOT_ALIGN
    n = -(-nbytes // slot) + 1 if nbytes > slot else 3
    return min(n, wire.SHM_MAX_SLOTS), slot


class Session:
    """An integration session on a client (Client.session, Client.resume).

    next() -> SessionBatch, or None once the session has ended; tell(values)
    for that batch; report (the latest SessionReport); result() (a
    SessionResult, or the daemon's error); close().  ticket: (session id,
    token), what resume() needs on another connection or process.
    """

    def __init__(self, client, request_id, dims, request):
        self.client = client
        self.request_id = request_id
        self.request = request
        self.dims = dims
        self.state = _OPENING
        self.id = None
        self.token = None
        self.max_batch = self.memory_bytes = self.park_ms = None
        self.report = None
        self.reports = 0
        self._result = None
        self._error = None
        self._seq = self._count = self._got = 0
        self._last_seq = None
        self._ring = False
        self._pieces = []       # (first, points, slot) of a ring batch
        self._pinned = 0
        self._points = self._values = None
        self._batch = None
        self._v_lo = self._v_hi = 0
        self._refusal = None
        self._refusals = 0
        f = request.fields
        self._part = parts.Gather(f.get("part_k", 0), f.get("part_p", 0))
        self.t0 = time.monotonic()  # the result's seconds count from here

    def __repr__(self):
        return "<qmcd.Session %s: %s>" % (self.id, ("opening", "waiting", "batch ready",
                                                    "telling", "ended")[self.state])

    @property
    def ticket(self):
        return (self.id, self.token)

    @property
    def done(self):
        return self.state == _DONE

    # -- frames, from the client's frame loop --
    def _bad(self, what):
        return self.client._break(ProtocolError("protocol error: session %s: %s"
                                                % (self.id, what)))

    def _end(self, error=None, result=None):
        self._error, self._result = error, result
        self.state = _DONE
        self._unpin()

    def _unpin(self):
        ring = self.client._ring
        if ring is not None and self._pinned:
            ring.pinned -= min(self._pinned, ring.pinned)
        self._pinned = 0
        self._batch = None

    def _file(self, mtype, msg):
        """A frame of the session's own request."""
        if mtype == wire.SESSION_OPENED:
            if self.state != _OPENING or msg["dims"] == 0 or msg["max_batch"] == 0 or \
                    (self.dims and msg["dims"] != self.dims):
                raise self._bad("SESSION_OPENED out of turn, or for other dims")
            self.id, self.token = msg["session_id"], msg["token"]
            self.dims, self.max_batch = msg["dims"], msg["max_batch"]
            self.memory_bytes, self.park_ms = msg["memory_bytes"], msg["park_ms"]
            self.state = _WAITING
        elif mtype == wire.SESSION_BATCH:
            self._file_batch(msg)
        elif mtype == wire.SESSION_REPORT:
            if self.state == _OPENING or msg["session_id"] != self.id:
                raise self._bad("a report out of turn")
            self.report = SessionReport(msg)
            self.reports += 1
            if self.state == _TELLING:
                # The values are in: the batch's ring slots may go back.
                self._unpin()
                self._got = 0
                self.state = _WAITING
                # And go back now, once they are half the ring (as
                # libqmcclient does, PROTOCOL.md 6.21): the daemon sends
                # the next batch right behind this report, so the buffer
                # is seldom found without a whole frame before we would
                # block (Client._release), and a batch of more than half
                # the ring would wait for a release that never comes, the
                # next batch's first piece pinning the slots behind it,
                # until write-timeout-ms cuts the connection.  Every slot
                # held is handled by now: this batch's and older ones.
                ring = self.client._ring
                if ring is not None and ring.held > ring.slots // 2 and not ring.pinned:
                    self.client._give_back()
        elif mtype in (wire.SESSION_PART, wire.SESSION_PART_SUMS):
            # After the last report, with no batch on its way.
            if self.state == _WAITING and self._got == 0:
                why = self._part.file(mtype, msg, self.id)
            else:
                why = "a part's sums while the session runs"
            if why:
                raise self._bad(why)
        elif mtype == wire.SESSION_RESULT:
            if self.state == _OPENING or msg["job_id"] != self.id:
                raise self._bad("a result out of turn")
            why = self._part.end()
            if why:
                raise self._bad(why)
            self._end(result=SessionResult(msg, self.request, self))
        elif mtype == wire.ERROR:
            self._end(error=ServerError(msg["code"], msg["message"], self.request_id))
        else:
            raise self._bad("%s is not a session's frame" % wire.type_name(mtype))
        return True

    def _file_batch(self, b):
        if self.state != _WAITING:
            raise self._bad("a batch while none was expected")
        if b["dims"] != self.dims:
            raise self._bad("a batch of %d dims in a session of %d" % (b["dims"], self.dims))
        ring_piece = b["transport"] == "shm"
        if self._got == 0:
            if b["first"] != 0 or b["count"] == 0 or b["count"] > self.max_batch or \
                    (self._last_seq is not None and
                     b["seq"] not in (self._last_seq, self._last_seq + 1)):
                raise self._bad("batch %d of %d points does not follow batch %s, or is larger "
                                "than max_batch %d" % (b["seq"], b["count"], self._last_seq,
                                                       self.max_batch))
            self._seq, self._count, self._ring = b["seq"], b["count"], ring_piece
            self._pieces = []
            self._batch = None
        elif b["seq"] != self._seq or b["count"] != self._count or b["first"] != self._got \
                or ring_piece != self._ring:
            raise self._bad("a batch piece out of order")
        pts = b["points"]
        if pts > self._count - self._got:
            raise self._bad("a batch piece past its batch")
        whole = ring_piece and b["first"] == 0 and pts == self._count
        if not whole and (self._points is None or len(self._points) < self._count):
            self._points = np.empty((self._count, self.dims), dtype=_F64)
            self._values = np.empty(self._count, dtype=_F64)
        if ring_piece:
            ring = self.client._ring
            if ring is None or b["slot"] != ring.next or ring.held >= ring.slots or \
                    b["data_len"] + 8 * pts > ring.slot_bytes or \
                    len(self._pieces) >= wire.SHM_MAX_SLOTS:
                raise self._bad("a batch piece in ring slot %d, which is not the next one or "
                                "too small" % b["slot"])
            ring.next = (ring.next + 1) % ring.slots
            ring.held += 1
            ring.pinned += 1
            self._pinned += 1
            self._pieces.append((b["first"], pts, b["slot"]))
            off = b["slot"] * ring.slot_bytes
            data = ring.view[off:off + b["data_len"]]
            if whole:
                points = np.frombuffer(data, dtype=_F64).reshape(pts, self.dims)
                points.flags.writeable = False
                values = np.frombuffer(ring.view[off + b["data_len"]:
                                                 off + b["data_len"] + 8 * pts], dtype=_F64)
                self._batch = SessionBatch(self._seq, points, values)
        else:
            data = b["data"]
        if not whole:
            first = b["first"]
            self._points[first:first + pts] = np.frombuffer(data, dtype=_F64).reshape(
                pts, self.dims)
        self._got += pts
        if self._got == self._count:
            self.state = _READY
            self._last_seq = self._seq
            if not whole:
                points = self._points[:self._count]
                view = points.view()
                view.flags.writeable = False
                self._batch = SessionBatch(self._seq, view, self._values[:self._count])

    def _refused(self, rid, msg):
        """An ERROR for values we sent: the first says why; the batch waits
        for its values from the start again."""
        if not (self._v_hi and self._v_lo <= rid <= self._v_hi):
            return False
        if self._refusal is None:
            self._refusal = ServerError(msg["code"], msg["message"], rid)
            self._refusals = self._v_hi - rid + 1
        if self._refusals:
            self._refusals -= 1
        return True

    # -- the caller's side --
    def _live(self):
        if self.client.closed:
            from .errors import ConnectionLost
            raise ConnectionLost("session %s: the connection is gone; resume it on a new one "
                                 "(Client.resume(ticket))" % self.id)

    def next(self):
        """The next batch (a SessionBatch), or None when the session has
        ended (see report.end and result())."""
        c = self.client
        with c._lock:
            while self.state not in (_READY, _DONE):
                self._live()
                c._pump()
            return self._batch if self.state == _READY else None

    def tell(self, values):
        """Sends the values of f at the batch's points (array-like of
        count floats; NaN and infinities are counted and flagged by the
        daemon, never refused) and waits for the report on them.  Raises
        ServerError when the daemon refuses them (the batch then waits for
        its values again)."""
        c = self.client
        with c._lock:
            self._live()
            if self.state != _READY:
                raise QmcdError(QMC_EINVAL, "session %s: no batch is waiting for values "
                                "(ask for it with next())" % self.id)
            v = np.ascontiguousarray(values, dtype=_F64).reshape(-1)
            if len(v) != self._count:
                raise QmcdError(QMC_EINVAL, "session %s: batch %d of %d points is waiting; "
                                "got %d values" % (self.id, self._seq, self._count, len(v)))
            self._refusal, self._refusals = None, 0
            reports = self.reports
            if self._ring:
                self._send_ring(v)
            else:
                self._send_inline(v)
            self.state = _TELLING
            while self.state == _TELLING and self.reports == reports and \
                    not (self._refusal is not None and self._refusals == 0):
                self._live()
                c._pump()
            self._v_lo = self._v_hi = 0
            if self.state == _TELLING:
                self.state = _READY
                raise self._refusal
            if self.state == _DONE and self._error is not None and self.reports == reports:
                raise self._error

    def _values_id(self, rid):
        if not self._v_lo:
            self._v_lo = rid
        self._v_hi = rid

    def _send_ring(self, v):
        c = self.client
        ring = c._ring
        for first, pts, slot in self._pieces:
            off = slot * ring.slot_bytes + pts * self.dims * 8
            dst = np.frombuffer(ring.view[off:off + 8 * pts], dtype=_F64)
            if not np.shares_memory(dst, v):
                dst[:] = v[first:first + pts]
            rid = c._id()
            self._values_id(rid)
            c._send(wire.SESSION_VALUES, {"session_id": self.id, "seq": self._seq,
                                          "first": first, "count": pts, "transport": "shm",
                                          "slot": slot, "data_len": 0}, rid=rid)

    def _send_inline(self, v):
        c = self.client
        per = min((c.max_frame - 40) // 8, wire.SESSION_MAX_VALUES)
        if per <= 0:
            raise c._break(ProtocolError("the server's max_frame (%d) holds no value"
                                         % c.max_frame))
        raw = v.view(np.uint8) if v.dtype.isnative or _F64.isnative else v.astype(_F64)
        for at in range(0, len(v), per):
            n = min(per, len(v) - at)
            rid = c._id()
            self._values_id(rid)
            c._send(wire.SESSION_VALUES, {"session_id": self.id, "seq": self._seq,
                                          "first": at, "count": n, "transport": "inline",
                                          "slot": 0, "data_len": 8 * n,
                                          "data": raw[8 * at:8 * (at + n)]}, rid=rid)

    def result(self):
        """The SessionResult once the session has ended; ServerError when
        the integrator failed or the session was closed; QmcdError
        (QMC_EAGAIN) while it runs."""
        if self.state != _DONE:
            raise QmcdError(-1009, "session %s is still running" % self.id)
        if self._error is not None:
            raise self._error
        return self._result

    def part(self):
        """A part session's answer once it has ended: a parts.PartResult
        (fingerprint, blocks, first, count, the block sums; write() makes
        the `--part` file); ServerError when it failed; QmcdError while it
        runs, or when the session is not a part."""
        self.result()  # raises unless it ended well
        if self._part.head is None:
            raise QmcdError(QMC_EINVAL, "session %s is not a part session (open it with "
                            "part=(k, p))" % self.id)
        return parts.PartResult(self._part, self.request.cli_args, self._result.seconds,
                                self.report)

    def close(self):
        """SESSION_CLOSE: frees the session on the daemon now; returns the
        report at close."""
        c = self.client
        with c._lock:
            if self.state in (_DONE, _OPENING) or c.closed:
                return self.report
            rid = c._send(wire.SESSION_CLOSE, {"session_id": self.id, "token": self.token})
            msg = c._answer(rid, wire.SESSION_REPORT)
            self._end(error=self._error or ServerError(-125, "session %s closed" % self.id))
            c._sessions.pop(self.request_id, None)
            return SessionReport(msg)


class SessionResult(JobResult):
    """A session's final result: what JobResult holds, with the session's
    id (job_id), the declared exact value as the reference, and the last
    report.  seconds is the wall time from opening the session to its
    result, f's evaluations included (what `qmc integrate --command`
    reports; Client.integrate counts from its call, across reconnections);
    server_seconds is the daemon's own compute time."""

    def __init__(self, msg, request, session):
        JobResult.__init__(self, msg, request)
        self.session_id = msg["job_id"]
        self.report = session.report
        self.server_seconds = msg["seconds"]
        self.seconds = time.monotonic() - session.t0


class SessionsMixin:
    """Client's integration sessions (a mixin: Client has the connection)."""

    # -- integration sessions: the caller's own function --
    def session(self, dims, method="auto", **options):
        """Opens an integration session for a function of dims dimensions
        (protocol version 5); returns a qmcd.Session to drive with next()
        and tell().  options: as integrate()'s."""
        fields, request = session_fields(dims, method, **options)
        with self._lock:
            self._need(wire.VERSION_SESSIONS, "sessions")
            if fields["part_p"]:
                self._need(wire.VERSION_PARTS, "part sessions")
            self._session_ring(fields)
            fields["transport"] = "shm" if self._ring is not None else "inline"
            return self._start_session(wire.SESSION_OPEN, fields, fields["dims"], request)

    def resume(self, ticket, request=None):
        """Takes up a session again (SESSION_RESUME) from its ticket, (id,
        token), on this connection: the batch it waits for is served again.
        The daemon refuses (-ENOENT) a session of another identity, with a
        wrong token, or past its park_ms."""
        sid, token = ticket
        with self._lock:
            self._need(wire.VERSION_SESSIONS, "sessions")
            if request is not None and request.fields.get("dims"):
                self._session_ring(request.fields)
            fields = {"session_id": sid, "token": token,
                      "transport": "shm" if self._ring is not None else "inline"}
            return self._start_session(wire.SESSION_RESUME, fields, 0,
                                       request or SessionRequest({}, "f", "auto", 0.95))

    def _session_ring(self, fields):
        """Sampling batches are large: over a Unix socket, a ring they fit
        in whole, if none is attached yet and the server takes it."""
        if fields["method"] in ("auto", "mc", "stratified", "lhs", "qmc", "rqmc") and \
                self._ring is None and not self._shm_off and self.unix:
            slots, slot_bytes = ring_for(fields["dims"], fields["max_batch"])
            try:
                self.attach_shm(slots, slot_bytes)
            except QmcdError:
                if self.closed:
                    raise
                self._shm_off = True

    def _start_session(self, mtype, fields, dims, request):
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
        Returns a SessionResult: json() is the line `qmc integrate
        --command PROGRAM --json` prints for a PROGRAM computing f, byte
        for byte but for seconds (wall time, here from this call).  With
        part=(k, p) (a fixed-n sampling method; protocol version 6) it
        computes part k of p of the job and returns a parts.PartResult,
        whose write() makes the file `qmc integrate --command PROGRAM
        --part k/p` writes, for `qmc merge`.

        options: method and tol_rel, tol_abs, n, reps, seq, scramble,
        shuffle, split_net, seed, max_evals, max_memory, confidence (as
        submit() and `qmc integrate` take them); smoothness of f
        ("continuous" by default; "analytic" lets auto choose a rule for
        smooth functions), exact (its integral, when known: the report
        then prints the actual error), name (the report's "integrand"; the
        daemon is told its first 31 bytes), max_batch.  on_report(report) is called after each batch.  When the
        connection drops, the client reconnects and resumes the session,
        at most `retries` times; the values of the batch that was waiting
        are sent again, not recomputed.
        """
        from .errors import ConnectionLost, Timeout
        import numpy as _np
        t0 = time.monotonic()
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
                r = s.result()
                r.seconds = time.monotonic() - t0
                if s._part.part_p:
                    p = s.part()
                    p.seconds = r.seconds
                    return p
                return r
            except (ConnectionLost, Timeout):
                tries += 1
                if tries > retries:
                    raise
                self.reconnect()
                s = self.resume(ticket, request)
