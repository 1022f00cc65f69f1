#!/usr/bin/python3
"""sessionpeer.py - integration sessions (protocol version 5, PROTOCOL.md
section 6.21) spoken from the spec with struct and socket, for
tests/e2e/test_sessions.sh: the frames a C client of libqmcclient never
sends (hostile values, wrong counts, stale batches, values before and
after a batch, malformed frames), the ring's values, takeover, close,
expiry, ownership by address, the caps, STATS, and a part session
refused on version 5 (its sums need version 6).  Frames come from
qmcpeer.py's codec (itself written from the spec); the session frames a
client sends are built here.  Each scenario prints "ok NAME" or "FAIL NAME:
why" lines.

    sessionpeer.py SCENARIO ADDR [ARGS...]
"""
import math
import os
import struct
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import qmcpeer as q  # noqa: E402
from qmcpeer import MSG, Peer, check, frame, sampling_spec  # noqa: E402

ENOENT = -2
SMOOTH = dict(analytic=0, continuous=1, discontinuous=2, singular=3)


def open_frame(rid, dims, method="rqmc", n=4096, reps=2, seed=7, transport=0, max_batch=0,
               max_evals=100000000, tol_rel=0.0, smoothness="continuous", name="py",
               reserved=b"\0\0\0", n_given=1, part=(0, 0)):
    sampler = method if method in q.SAMPLERS else "mc"
    spec = sampling_spec(sampler=sampler, seq="sobol" if method in ("qmc", "rqmc") else "none",
                         scramble="owen" if method == "rqmc" else "none", seed=seed, n=n,
                         reps=reps)
    head = struct.pack("<BBBBIIB", q.METHODS.index(method), SMOOTH[smoothness], transport,
                       n_given, dims, 0, 0) + reserved + struct.pack(
        "<IIQQQddd", part[0], part[1], max_evals, 64 << 20, max_batch, 0.0, tol_rel, 0.0)
    return frame(MSG["SESSION_OPEN"], rid, head + spec + q.str16(name))


def values_frame(rid, session_id, seq, first, values, transport=0, slot=0, count=None,
                 data_len=None, reserved=b"\0\0\0"):
    count = len(values) if count is None else count
    data = b"" if transport else struct.pack("<%dd" % len(values), *values)
    data_len = len(data) if data_len is None else data_len
    body = struct.pack("<QQQIB", session_id, seq, first, count, transport) + reserved + \
        struct.pack("<II", slot, data_len)
    return frame(MSG["SESSION_VALUES"], rid, body + data)


def resume_frame(rid, session_id, token, transport=0):
    return frame(MSG["SESSION_RESUME"], rid, struct.pack("<Q32sB7x", session_id, token, transport))


def close_frame(rid, session_id, token):
    return frame(MSG["SESSION_CLOSE"], rid, struct.pack("<Q32s", session_id, token))


def read_batch(p, rid, ring=None):
    """Frames of request rid until a whole batch: (batch dict with the
    points as floats, reports seen).  Ring pieces are read from the mmap."""
    pts, pieces, reports, b = [], [], [], None
    for _ in range(100000):
        t, r, d = p.recv()
        if r != rid:
            raise ValueError("frame %s for request %d while reading %d" % (t, r, rid))
        if t == "SESSION_REPORT":
            reports.append(d)
            continue
        if t in ("ERROR", "SESSION_RESULT", "SESSION_OPENED"):
            return (t, d), reports
        if t != "SESSION_BATCH":
            raise ValueError("unexpected %s" % t)
        if d["first"] != len(pts) // d["dims"]:
            raise ValueError("piece out of order")
        if d["transport"] == 0:
            raw = d["data"]
        else:
            m, slot_bytes = ring
            raw = m[d["slot"] * slot_bytes:d["slot"] * slot_bytes + d["data_len"]]
            pieces.append((d["first"], d["points"], d["slot"]))
        pts.extend(struct.unpack("<%dd" % (len(raw) // 8), raw))
        if d["first"] + d["points"] == d["count"]:
            b = dict(seq=d["seq"], count=d["count"], dims=d["dims"], points=pts, pieces=pieces)
            return ("SESSION_BATCH", b), reports
    raise ValueError("no batch")


def start(p, dims=2, **kw):
    """SESSION_OPEN; returns (rid, OPENED dict, first batch) or raises."""
    rid = p.rid()
    p.send(open_frame(rid, dims, **kw))
    t, r, d = p.recv()
    if t != "SESSION_OPENED" or r != rid:
        raise q.PeerError(d) if t == "ERROR" else ValueError("OPEN answered %s" % t)
    (t, b), _ = read_batch(p, rid)
    if t != "SESSION_BATCH":
        raise ValueError("no first batch: %s %r" % (t, b))
    return rid, d, b


def f_at(points, dims):
    """Any function: the sum of the coordinates (the tests compare counts
    and states here; bits are test_sessions.sh's C peer's business)."""
    return [sum(points[i * dims:(i + 1) * dims]) for i in range(len(points) // dims)]


def expect_error(p, rid, code, name, what=""):
    t, r, d = p.recv()
    check(name, t == "ERROR" and r == rid and d["code"] == code and what in d["message"] and
          "\n" not in d["message"], repr((t, r, d)))
    return d


def alive(addr, name):
    """Another connection is served at once: the daemon kept serving."""
    o = Peer(addr, version=5)
    ok = o.ping()
    o.close()
    check(name, ok)


def finish(p, rid, sid, batch, values_of=f_at):
    """Answers every batch to the end: (last report, final frame)."""
    report = None
    while True:
        v = values_of(batch["points"], batch["dims"])
        p.send(values_frame(p.rid(), sid, batch["seq"], 0, v))
        (t, batch), reports = read_batch(p, rid)
        if reports:
            report = reports[-1]
        if t != "SESSION_BATCH":
            return report, (t, batch)


# ---- scenarios --------------------------------------------------------------------------

def sc_hostile(addr):
    """Values and frames a session must survive, each one ERROR (or, for a
    malformed frame, a closed connection), the session usable after."""
    # Version 4 knows no sessions: ENOTSUP, the connection stays.
    old = Peer(addr, version=4)
    rid = old.rid()
    old.send(open_frame(rid, 2))
    expect_error(old, rid, q.QMC_ENOTSUP, "SESSION_OPEN on version 4: ENOTSUP", "version 5")
    check("version 4: the connection is still served", old.ping())
    old.close()

    p = Peer(addr, version=5)
    # Bad specs, refused before anything is reserved.
    for name, kw, code, what in [
            ("dims 0", dict(dims=0), q.QMC_EINVAL, "dims"),
            ("dims 21202", dict(dims=21202), -1005, "dims"),
            ("a part", dict(part=(1, 2)), q.QMC_ENOTSUP, "part"),
            ("the ring without one", dict(transport=1), q.QMC_EINVAL, "SHM_ATTACH"),
            ("a budget below its cost", dict(max_evals=10), -1014, "")]:
        rid = p.rid()
        kw.setdefault("dims", 2)
        dims = kw.pop("dims")
        p.send(open_frame(rid, dims, **kw))
        expect_error(p, rid, code, "SESSION_OPEN refused: %s" % name, what)

    # 4 x 4096 points in batches of at most 8192: two batches.
    rid, opened, b = start(p, dims=2, n=4096, reps=4, max_batch=8192)
    sid = opened["session_id"]
    check("OPENED: a session id and a 32-byte token",
          sid > 0 and len(opened["token"]) == 32 and opened["token"] != bytes(32), repr(opened))
    check("the first batch: 2 x 4096 points of 2 dims", b["count"] == 8192 and b["dims"] == 2,
          repr((b["count"], b["dims"])))
    vals = f_at(b["points"], 2)

    def refused(name, data, code, what):
        v = p.rid()
        p.send(data(v))
        expect_error(p, v, code, "values refused: " + name, what)

    refused("no such session", lambda v: values_frame(v, sid + 1000, 0, 0, vals),
            ENOENT, "no session")
    refused("a batch not handed out", lambda v: values_frame(v, sid, 1, 0, vals),
            q.QMC_EINVAL, "not been handed out")
    refused("values from the wrong point", lambda v: values_frame(v, sid, 0, 5, vals[:10]),
            q.QMC_EINVAL, "from point 0")
    refused("more values than the batch", lambda v: values_frame(v, sid, 0, 0, vals + [1.0]),
            q.QMC_EINVAL, "run past")
    refused("through a ring it has not", lambda v: values_frame(v, sid, 0, 0, [], transport=1,
                                                                 count=8192),
            q.QMC_EINVAL, "ring")
    # Half the values, then a refusal: the half is dropped, the batch
    # waits for all of its values again.
    p.send(values_frame(p.rid(), sid, 0, 0, vals[:4096]))
    refused("a gap after half the values",
            lambda v: values_frame(v, sid, 0, 5000, vals[5000:]), q.QMC_EINVAL, "dropped")
    refused("the second half after the refusal",
            lambda v: values_frame(v, sid, 0, 4096, vals[4096:]), q.QMC_EINVAL, "from point 0")
    # NaN, infinities and 1e308 are values like any other: counted, flagged.
    vals[0], vals[1], vals[2], vals[3] = math.nan, math.inf, -math.inf, 1e308
    p.send(values_frame(p.rid(), sid, 0, 0, vals))
    # In the same write: values again for batch 0 - answered already (or
    # the next batch is still being computed): one ERROR either way.
    late = p.rid()
    p.send(values_frame(late, sid, 0, 0, vals))
    # The REPORT, the ERROR for the late values and the second batch come
    # in an order that depends on where the step ran; each comes once.
    frames, pts, second = [], [], None
    for _ in range(100):
        t, r, d = p.recv()
        if t == "SESSION_BATCH" and r == rid:
            pts.extend(struct.unpack("<%dd" % (len(d["data"]) // 8), d["data"]))
            if d["first"] + d["points"] == d["count"]:
                second = dict(seq=d["seq"], count=d["count"], dims=d["dims"], points=pts)
        else:
            frames.append((t, r, d))
        if second and any(t == "ERROR" for t, r, d in frames):
            break
    report = [d for t, r, d in frames if t == "SESSION_REPORT"]
    errors = [d for t, r, d in frames if t == "ERROR" and r == late]
    check("NaN, inf, -inf and 1e308 taken: the report counts 3 non-finite",
          len(report) == 1 and report[0]["nonfinite"] == 3 and report[0]["evals"] == 8192 and
          report[0]["batches"] == 1 and report[0]["flags"] & q.flag_bit("nonfinite"),
          repr(frames))
    check("values for a batch answered already: one ERROR",
          len(errors) == 1 and errors[0]["code"] == q.QMC_EINVAL, repr(frames))
    report, (t, d) = finish(p, rid, sid, second)
    check("the session ends: REPORT then SESSION_RESULT, 3 non-finite of 16384",
          t == "SESSION_RESULT" and d["nonfinite"] == 3 and d["evals"] == 16384 and
          "nonfinite" in q.flag_names(d["flags"]) and report["end"] == "cannot_tell",
          repr((t, d, report)))
    # After the end: the session is gone from this connection.
    v = p.rid()
    p.send(values_frame(v, sid, 1, 0, vals))
    expect_error(p, v, ENOENT, "values after the end: no session", "no session")
    check("the connection is still served", p.ping())

    # Values with request id 0 and values under an id in flight break the
    # protocol: the connection closes, the session parks.
    for name, rid_of in [("request id 0", lambda r: 0), ("the session's own id", lambda r: r)]:
        c = Peer(addr, version=5)
        r2, o2, b2 = start(c, dims=1, n=1024, reps=2)
        c.send(values_frame(rid_of(r2), o2["session_id"], 0, 0, f_at(b2["points"], 1)))
        errs = q.expect_closed(c, name)
        check("SESSION_VALUES under %s: EPROTO, closed" % name,
              any(e["code"] == q.QMC_EPROTO for e in errs), repr(errs))
        c.close()
    # Malformed session frames: closed, the daemon unhurt.
    good = open_frame(1, 2)
    for name, data in [
            ("OPEN with transport 2", open_frame(7, 2, transport=2)),
            ("OPEN with a reserved byte", open_frame(7, 2, reserved=b"\0\1\0")),
            ("OPEN one byte short", good[:16] + struct.pack("<I", len(good) - 25) + good[20:-1]),
            ("VALUES with data_len disagreeing",
             values_frame(9, 1, 0, 0, [1.0, 2.0], data_len=8)),
            ("VALUES with a reserved byte", values_frame(9, 1, 0, 0, [1.0], reserved=b"\1\0\0")),
            ("a SESSION_BATCH from the client", frame(MSG["SESSION_BATCH"], 9, bytes(44)))]:
        c = Peer(addr, version=5)
        c.send(data)
        errs = q.expect_closed(c, name)
        check("malformed %s: EPROTO, closed" % name,
              any(e["code"] == q.QMC_EPROTO for e in errs), repr(errs))
        c.close()
    alive(addr, "after the hostile frames another client is served")


def sc_ring(addr):
    """Batches through the client's ring, values written after the points
    in the same slot; a piece named wrong, or a slot released first, is
    refused."""
    p = Peer(addr, version=5)
    fd, _ = q.make_ring(4, 256 << 10)
    import mmap
    m = mmap.mmap(fd, 4 * (256 << 10), mmap.MAP_SHARED, mmap.PROT_READ | mmap.PROT_WRITE)
    t, r, d = p.attach(fd, 4, 256 << 10)
    os.close(fd)
    check("ring attached", t == "SHM_OK", repr((t, d)))
    rid = p.rid()
    # 3 dims: 32 bytes a point and its value, 8192 points a slot; 2 x 8192
    # points: two pieces.
    p.send(open_frame(rid, 3, n=8192, reps=4, transport=1, max_batch=16384))
    t, r, opened = p.recv()
    (t, b), _ = read_batch(p, rid, ring=(m, 256 << 10))
    check("a batch of 16384 points in two ring pieces",
          t == "SESSION_BATCH" and b["count"] == 16384 and len(b["pieces"]) == 2 and
          [x[1] for x in b["pieces"]] == [8192, 8192], repr(b.get("pieces")))
    sid = opened["session_id"]
    vals = f_at(b["points"], 3)
    # Wrong slot for the first piece: refused.
    first, pts, slot = b["pieces"][0]
    v = p.rid()
    p.send(values_frame(v, sid, 0, first, [], transport=1, slot=slot + 1, count=pts))
    expect_error(p, v, q.QMC_EINVAL, "ring values naming the wrong slot: refused", "slot")
    for first, pts, slot in b["pieces"]:
        off = slot * (256 << 10) + pts * 3 * 8
        m[off:off + 8 * pts] = struct.pack("<%dd" % pts, *vals[first:first + pts])
        p.send(values_frame(p.rid(), sid, 0, first, [], transport=1, slot=slot, count=pts))
    p.release(2)
    (t, b2), reports = read_batch(p, rid, ring=(m, 256 << 10))
    check("ring values taken: the report counts 16384", reports and reports[-1]["evals"] == 16384,
          repr(reports))
    # A slot released before its values were sent: refused.
    if t == "SESSION_BATCH":
        p.release(len(b2["pieces"]))
        first, pts, slot = b2["pieces"][0]
        v = p.rid()
        p.send(values_frame(v, sid, b2["seq"], first, [], transport=1, slot=slot, count=pts))
        expect_error(p, v, q.QMC_EINVAL, "ring values from a released slot: refused", "released")
    else:
        check("a second batch", False, repr((t, b2)))
    p.close()
    alive(addr, "after the ring session another client is served")


def sc_resume(addr, src_other):
    """Takeover, close, ownership by address: a session is its opener's."""
    owner = Peer(addr, version=5)
    rid, opened, b = start(owner, dims=2, n=1024, reps=4)
    sid, token = opened["session_id"], opened["token"]
    # Another address with the token: one answer, ENOENT, for resume and close.
    o = stranger(addr, src_other)
    r = o.rid()
    o.send(resume_frame(r, sid, token))
    expect_error(o, r, ENOENT, "another address, right token: resume refused", "no session")
    r = o.rid()
    o.send(close_frame(r, sid, token))
    expect_error(o, r, ENOENT, "another address, right token: close refused", "no session")
    o.close()
    # The owner's address with a wrong token: the same answer.
    b2 = Peer(addr, version=5)
    r = b2.rid()
    bad = bytes([token[0] ^ 1]) + token[1:]
    b2.send(resume_frame(r, sid, bad))
    expect_error(b2, r, ENOENT, "right address, wrong token: resume refused", "no session")
    # The right token from the owner's address takes it over.
    r = b2.rid()
    b2.send(resume_frame(r, sid, token))
    t, rr, d = b2.recv()
    check("resume on another connection: OPENED with the same id and token",
          t == "SESSION_OPENED" and rr == r and d["session_id"] == sid and d["token"] == token,
          repr((t, d)))
    (t, again), reports = read_batch(b2, r)
    check("resume: a REPORT, then the waiting batch served again whole",
          reports and t == "SESSION_BATCH" and again["seq"] == b["seq"] and
          again["points"] == b["points"], repr((t, again.get("seq") if t == "SESSION_BATCH" else again)))
    expect_error(owner, rid, -125, "taken over: the first connection's request ends ECANCELED",
                 "resumed on another connection")
    # Values on the old connection no longer reach it.
    v = owner.rid()
    owner.send(values_frame(v, sid, again["seq"], 0, f_at(again["points"], 2)))
    expect_error(owner, v, ENOENT, "values on the connection that lost it: no session",
                 "no session")
    owner.close()
    # Close from a third connection of the owner: its request ends, the
    # close is answered with the state.
    c = Peer(addr, version=5)
    r2 = c.rid()
    c.send(close_frame(r2, sid, token))
    t, rr, d = c.recv()
    check("close from another connection: a REPORT of the state",
          t == "SESSION_REPORT" and rr == r2 and d["session_id"] == sid and d["end"] == "running",
          repr((t, d)))
    expect_error(b2, r, -125, "closed: the attached request ends ECANCELED", "SESSION_CLOSE")
    r3 = c.rid()
    c.send(resume_frame(r3, sid, token))
    expect_error(c, r3, ENOENT, "a closed session cannot be resumed", "no session")
    c.close()
    b2.close()


def stranger(addr, src):
    """A peer of another identity: over TCP from another source address."""
    if addr.startswith("tcp:"):
        return Peer(addr, version=5, src=src)
    raise ValueError("a stranger needs a tcp: address")


def stat(addr, name):
    o = Peer(addr, version=5)
    s = o.stats()
    o.close()
    return s.get(name)


def sc_expire(addr):
    """A dropped session is parked, and gone after session-idle-timeout-ms:
    a late resume (and late values) find nothing."""
    before = stat(addr, "sessions_expired")
    p = Peer(addr, version=5)
    rid, opened, b = start(p, dims=2, n=1024, reps=2)
    p.close()
    # Wait (bounded) until the daemon says it expired it.
    for _ in range(400):
        if stat(addr, "sessions_expired") > before:
            break
        time.sleep(0.05)
    check("a parked session expires (sessions_expired moved)",
          stat(addr, "sessions_expired") == before + 1)
    c = Peer(addr, version=5)
    r = c.rid()
    c.send(resume_frame(r, opened["session_id"], opened["token"]))
    expect_error(c, r, ENOENT, "a late resume after the idle timeout: no session", "expired")
    c.close()


def sc_caps(addr, per_peer):
    """max-sessions-per-peer and the memory caps: one ERROR each, naming
    the limit; parked sessions count; the refused peer's others go on."""
    per_peer = int(per_peer)
    refused0 = stat(addr, "refused_sessions")
    # A session whose batches alone pass the memory caps.
    p = Peer(addr, version=5)
    r = p.rid()
    p.send(open_frame(r, 64, n=1 << 20, reps=8, max_batch=1 << 24))
    expect_error(p, r, q.QMC_ETOOBIG, "a session over the memory caps: refused", "memory")
    held = []
    for i in range(per_peer):
        p = Peer(addr, version=5)
        held.append((p,) + start(p, dims=1, n=1024, reps=2))
    # Park one: it still counts.
    held[0][0].close()
    p = Peer(addr, version=5)
    r = p.rid()
    p.send(open_frame(r, 1, n=1024, reps=2))
    expect_error(p, r, q.QMC_ETOOBIG, "one past max-sessions-per-peer (one of them parked)",
                 "max-sessions-per-peer")
    check("refused_sessions counted both", stat(addr, "refused_sessions") == refused0 + 2)
    # The others still work: answer one to its end.
    pp, rid, opened, b = held[1]
    report, (t, d) = finish(pp, rid, opened["session_id"], b)
    check("a held session still finishes", t == "SESSION_RESULT" and d["evals"] == 2048,
          repr((t, d)))
    for h in held[1:]:
        h[0].close()
    p.close()


def sc_stats(addr):
    """The session counters: what this test's scenarios did shows."""
    o = Peer(addr, version=5)
    s = o.stats()
    o.close()
    for k in ("sessions_opened", "sessions_done", "sessions_closed", "sessions_resumed",
              "sessions_parked", "refused_session_values", "session_batches", "session_values",
              "session_nonfinite_values", "requests_SESSION_OPEN", "requests_SESSION_VALUES",
              "requests_SESSION_RESUME", "requests_SESSION_CLOSE"):
        check("STATS %s > 0" % k, s.get(k, 0) > 0, repr(s.get(k)))
    check("STATS gauges present", "sessions_open" in s and "sessions_parked_now" in s and
          "session_memory_reserved_bytes" in s, repr(sorted(k for k in s if "session" in k)))


def sc_part5(addr):
    """A part session (part_p != 0) on a connection that chose version 5:
    its answer, block sums, has no message before version 6, so the open
    is refused with ENOTSUP naming the version, and the connection serves
    on (a whole session opens on it)."""
    p = Peer(addr, version=5)
    check("version 5 chosen", p.version == 5, repr(p.version))
    rid = p.rid()
    p.send(open_frame(rid, 2, part=(1, 2)))
    expect_error(p, rid, -1012, "a part on version 5 is refused with ENOTSUP",
                 "needs protocol version 6")
    rid, opened, batch = start(p, dims=2)
    check("a whole session opens on the same connection", opened["dims"] == 2)
    p.close()


SCENARIOS = {"hostile": sc_hostile, "ring": sc_ring, "resume": sc_resume,
             "expire": sc_expire, "caps": sc_caps, "stats": sc_stats, "part5": sc_part5}

if __name__ == "__main__":
    try:
        SCENARIOS[sys.argv[1]](*sys.argv[2:])
    except Exception as e:  # a peer error is a failed check, with its reason
        check("%s ran to its end" % sys.argv[1], False, "%s: %s" % (type(e).__name__, e))
    sys.exit(1 if q.FAILED else 0)
