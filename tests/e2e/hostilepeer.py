#!/usr/bin/python3
"""hostilepeer.py - hostile clients, load and faults against a live qmcd.

Scenarios for tests/e2e/test_hostile.sh, spoken with qmcpeer.py's
independent codec (written from protocol/PROTOCOL.md).  After every hostile
case the same three things are asserted: the daemon is alive, it serves
another client correctly (points equal to what `qmc points` printed
in-process, byte for byte), and its VmRSS stays under a stated bound.  Every
loop is bounded by a count; socket timeouts only guard against hangs.

    hostilepeer.py SCENARIO ADDR PID REFERENCE_FILE RSS_LIMIT_MB [ARGS...]

REFERENCE_FILE holds `qmc points --seq sobol --dims 4 --count 4096
--scramble owen --seed 9 --format f64`: the correct answer to compare with.
"""
import random
import socket
import struct
import sys
import threading

import qmcpeer as q
from qmcpeer import HEADER, MAGIC, MSG, Peer, PeerError, check, frame

REF_DIMS, REF_COUNT = 4, 4096


class Daemon:
    """The daemon under attack: its address, PID, the reference points
    and the VmRSS budget every case must stay within."""

    def __init__(self, addr, pid, ref_file, limit_mb):
        self.addr, self.pid = addr, int(pid)
        self.ref = open(ref_file, "rb").read()
        assert len(self.ref) == REF_DIMS * REF_COUNT * 8
        self.base_kb = q.vmrss_kb(self.pid)
        self.limit_kb = int(limit_mb) * 1024
        self.peak_kb = self.base_kb

    def points_ok(self, p, start, count):
        data, _ = p.points(dims=REF_DIMS, count=count, start=start, scramble="owen", seed=9)
        lo, hi = start * REF_DIMS * 8, (start + count) * REF_DIMS * 8
        return data == self.ref[lo:hi]

    def still_fine(self, after):
        """Alive, serves another client the right bytes, RSS in bounds."""
        self.peak_kb = max(self.peak_kb, q.vmrss_kb(self.pid))
        try:
            p = Peer(self.addr, timeout=30)
            good = p.ping(b"after") and self.points_ok(p, 17, 100)
            p.close()
        except Exception as e:  # reported as the check's reason
            good = False
            after += " (%s: %s)" % (type(e).__name__, e)
        check("after %s: daemon alive and serving correct points" % after, good)
        check("after %s: VmRSS %d kB, within %d kB of the start (%d kB)"
              % (after, self.peak_kb, self.limit_kb, self.base_kb),
              self.peak_kb - self.base_kb < self.limit_kb)


def drain(p, limit=64):
    """Frames until EOF (or limit); returns the ERROR dicts seen and
    whether the connection ended."""
    errs = []
    try:
        for _ in range(limit):
            r = p.recv()
            if r is None:
                return errs, True
            if r[0] == "ERROR":
                errs.append(r[2])
    except (ConnectionResetError, BrokenPipeError):
        return errs, True
    except (socket.timeout, ValueError):
        return errs, False
    return errs, False


def header(mtype=MSG["PING"], rid=7, plen=0, magic=MAGIC, version=1, flags=0, res=0):
    return HEADER.pack(magic, version, mtype, flags, rid, plen, res)


def sc_frames(d):
    """The hostile frames of PROTOCOL.md's error rules, one connection each:
    each is answered with one ERROR and a close, or (a header cut short,
    then silence) closed at frame-timeout-ms."""
    p0 = Peer(d.addr)
    pts = p0.points_frame(5, dims=2, count=4)[HEADER.size:]
    p0.close()
    ping = struct.pack("<H", 5) + b"hello"
    # PIXELS (version 4, PROTOCOL.md section 6.20): zsobol 64x32, 16 spp,
    # 2 dims, the 4x4 tile at the origin, all samples, f32, inline.
    pix = struct.pack("<BBBBIIIIIQIIIIQQ", 1, 2, 0, 0, 64, 32, 0, 0, 2, 16, 0, 0, 4, 4, 0, 16)
    cases = [
        ("bad magic", header(magic=b"QMCX")),
        ("bad version 0", header(version=0)),
        ("bad version 255", header(version=255)),
        ("nonzero flags", header(flags=1)),
        ("nonzero reserved", header(res=1)),
        ("length 2^32-1", header(plen=0xFFFFFFFF)),
        ("length just past max-frame", header(plen=(1 << 20) + 1)),
        ("unknown type 0", header(mtype=0)),
        ("unknown type 200", header(mtype=200, plen=3) + b"abc"),
        ("PING length 0", header(plen=0)),
        ("PING short payload", header(plen=3) + ping[:3]),
        ("PING long payload", header(plen=len(ping) + 9) + ping + bytes(9)),
        ("POINTS short payload", frame(MSG["POINTS"], 9, pts[:-1])),
        ("POINTS long payload", frame(MSG["POINTS"], 9, pts + b"\0")),
        ("POINTS length 0", frame(MSG["POINTS"], 9)),
        ("INTEGRATE length 0", frame(MSG["INTEGRATE"], 9)),
        ("PIXELS short payload", frame(MSG["PIXELS"], 9, pix[:-1])),
        ("PIXELS long payload", frame(MSG["PIXELS"], 9, pix + b"\0")),
        ("PIXELS length 0", frame(MSG["PIXELS"], 9)),
        ("PIXELS sampler 0", frame(MSG["PIXELS"], 9, b"\0" + pix[1:])),
        ("PIXELS format 9", frame(MSG["PIXELS"], 9, pix[:1] + b"\x09" + pix[2:])),
        ("PIXELS reserved byte", frame(MSG["PIXELS"], 9, pix[:3] + b"\x01" + pix[4:])),
        ("INTEGRATE 3 bytes", frame(MSG["INTEGRATE"], 9, b"\x01\x02\x03")),
        ("JOB_CANCEL short", frame(MSG["JOB_CANCEL"], 9, b"\x01")),
        ("STATS with payload", frame(MSG["STATS"], 9, b"x")),
        ("a server-only type (END)", frame(MSG["END"], 9, bytes(16))),
        ("a truncated header, then EOF", header()[:11]),
    ]
    for name, data in cases:
        p = Peer(d.addr, timeout=30)
        p.send(data)
        if name.endswith("then EOF"):
            p.s.shutdown(socket.SHUT_WR)
        errs, closed = drain(p)
        check("hostile frame (%s): at most one ERROR, then the connection ends" % name,
              closed and len(errs) <= 1 and all(e["code"] < 0 for e in errs), repr(errs))
        p.close()
    d.still_fine("%d hostile frames" % len(cases))
    # A header cut short and then silence: closed at frame-timeout-ms.
    p = Peer(d.addr, timeout=60)
    p.send(header()[:11])
    errs, closed = drain(p)
    check("a header cut short, then silence: closed with ETIMEDOUT",
          closed and len(errs) == 1 and errs[0]["code"] == q.ETIMEDOUT, repr(errs))
    p.close()
    d.still_fine("a stalled header")


def sc_specs(d):
    """Well-formed frames with invalid requests: each gets an ERROR naming
    the problem and the connection goes on."""
    p = Peer(d.addr, timeout=30)
    bad_points = [
        dict(dims=0), dict(dims=21202), dict(kind="halton", dims=4097),
        dict(start=1 << 32), dict(scramble="faure"),
        dict(kind="stratified", dims=2, set_size=10, count=4),
        dict(kind="lhs", set_size=0), dict(fmt="f64", dims=1 << 20),
        dict(count=(1 << 62)),
    ]
    for kw in bad_points:
        try:
            p.points(**kw)
            check("invalid POINTS %r refused" % kw, False, "no ERROR")
        except PeerError as e:
            check("invalid POINTS %r: ERROR %d, one line" % (kw, e.code),
                  e.code < 0 and e.message and "\n" not in e.message)
    bad_jobs = [
        dict(integrand="no-such-integrand", dims=2),
        dict(integrand="genz-gaussian", dims=0),
        dict(integrand="genz-gaussian", dims=1 << 20),
        dict(integrand="genz-gaussian", dims=2, a=(1.0,) * 3),
        dict(integrand="genz-gaussian", dims=2, tol_rel=float("nan")),
        dict(integrand="genz-gaussian", dims=2, tol_abs=-1.0),
        dict(integrand="genz-gaussian", dims=2, max_evals=0),
    ]
    # Some of these the decoder itself rejects (malformed: ERROR, then the
    # connection closes, PROTOCOL.md section 6); others are refused with
    # the connection left open.  Each gets a connection of its own.
    for kw in bad_jobs:
        j = Peer(d.addr, timeout=30)
        rid = j.rid()
        j.send(j.integrate_frame(rid, **kw))
        t, r, dd = j.recv()
        while t == "JOB_ACCEPTED" or t == "JOB_PROGRESS":
            t, r, dd = j.recv()
        check("invalid INTEGRATE %r: ERROR, one line" % kw,
              t == "ERROR" and r in (rid, 0) and dd["code"] < 0 and dd["message"] and
              "\n" not in dd["message"], "%s %r" % (t, dd))
        j.close()
    check("after invalid specs: the same connection still works",
          p.ping() and d.points_ok(p, 0, 64))
    p.close()
    d.still_fine("invalid specs")


def sc_random_frames(d, count="10000", seed="1"):
    """count random frames: valid headers around random types and payloads,
    and raw random bytes, over as many connections as the daemon closes.
    Nothing may crash, hang or leak; clients between them are served."""
    rng = random.Random(int(seed))
    count = int(count)
    sent = conns = 0
    types = list(MSG.values()) + [0, 22, 99, 255]
    while sent < count:
        p = Peer(d.addr, timeout=30)
        conns += 1
        burst = rng.randrange(1, 64)
        data = bytearray()
        for _ in range(min(burst, count - sent)):
            r = rng.random()
            if r < 0.7:
                plen = rng.choice([0, 1, 2, 8, 16, 24, 40, 64, rng.randrange(300)])
                data += header(rng.choice(types), rng.getrandbits(64), plen)
                data += rng.randbytes(plen)
            elif r < 0.9:
                data += rng.randbytes(rng.randrange(1, 48))
            else:  # a valid frame with a few bytes flipped
                f = bytearray(p.points_frame(rng.getrandbits(32), dims=rng.randrange(1, 9),
                                             count=rng.randrange(1, 64)))
                for _ in range(rng.randrange(1, 4)):
                    f[rng.randrange(len(f))] = rng.getrandbits(8)
                data += f
            sent += 1
        try:
            p.send(bytes(data))
            p.s.shutdown(socket.SHUT_WR)
            drain(p, limit=1 << 16)
        except (BrokenPipeError, ConnectionResetError):
            pass
        p.close()
        if conns % 50 == 0:
            d.peak_kb = max(d.peak_kb, q.vmrss_kb(d.pid))
    d.still_fine("%d random frames over %d connections" % (sent, conns))


def sc_slowloris(d, clients="40"):
    """Clients that trickle a frame a byte at a time: each is cut off at
    frame-timeout-ms, and a client beside them is served all along."""
    n = int(clients)
    slow = [Peer(d.addr, timeout=60) for _ in range(n)]
    frm = slow[0].ping_frame(3)
    served = 0
    # Interleave: one byte to every slow client, then a full round trip
    # for the good one.  The good one's answers are counted by state.
    good = Peer(d.addr, timeout=30)
    for b in range(len(frm) - 1):
        for p in slow:
            try:
                p.send(frm[b:b + 1])
            except (BrokenPipeError, ConnectionResetError):
                pass
        served += good.ping(b"good%d" % b) and d.points_ok(good, b, 8)
    check("slow-loris: a normal client served on every round (%d of %d)"
          % (served, len(frm) - 1), served == len(frm) - 1)
    # Their frames never complete: each must end with ETIMEDOUT.
    ended = 0
    for p in slow:
        errs, closed = drain(p)
        ended += closed and len(errs) == 1 and errs[0]["code"] == q.ETIMEDOUT
        p.close()
    check("slow-loris: all %d trickling clients cut off with ETIMEDOUT (%d)" % (n, ended),
          ended == n)
    good.close()
    d.still_fine("%d slow-loris clients" % n)


def sc_load(d, clients="200", requests="1000", job_file=""):
    """clients connections at once, each making requests mixed requests
    (PING, POINTS slices of the reference, and now and then a small
    INTEGRATE compared with `qmc integrate --json`), pipelined 8 deep.
    Every answer is checked; none may be lost or wrong."""
    import json
    n, m = int(clients), int(requests)
    job = json.load(open(job_file)) if job_file else None
    spec = q.cli_like_spec("genz-gaussian", 3, "rqmc", 1024, 8, 5)
    results = [None] * n
    depth = 8

    def client(c):
        rng = random.Random(c)
        try:
            p = Peer(d.addr, timeout=120)
            want, done, wrong, jobs_open = {}, 0, 0, 0
            i = 0
            while done < m:
                while i < m and len(want) < depth:
                    rid = p.rid()
                    r = rng.random()
                    if r < 0.45:
                        want[rid] = ("PONG", b"c%dr%d" % (c, i))
                        p.send(p.ping_frame(rid, want[rid][1]))
                    elif r < 0.99 or job is None or jobs_open:
                        start = rng.randrange(REF_COUNT - 8)
                        cnt = rng.randrange(1, 9)
                        want[rid] = ("POINTS", start, cnt, bytearray())
                        p.send(p.points_frame(rid, dims=REF_DIMS, count=cnt, start=start,
                                              scramble="owen", seed=9))
                    else:  # one job at a time per client: the pool, not max-jobs, is tested
                        want[rid] = ("JOB",)
                        jobs_open = 1
                        p.send(q.job_frame(p, rid, spec))
                    i += 1
                t, rid, dd = p.recv()
                w = want.get(rid)
                if w is None:
                    wrong += 1
                    continue
                if w[0] == "PONG":
                    wrong += not (t == "PONG" and dd["data"] == w[1])
                elif w[0] == "POINTS":
                    if t == "POINTS_CHUNK":
                        w[3].extend(dd["data"])
                        continue
                    lo = w[1] * REF_DIMS * 8
                    wrong += not (t == "END" and bytes(w[3]) ==
                                  d.ref[lo:lo + w[2] * REF_DIMS * 8])
                else:
                    if t in ("JOB_ACCEPTED", "JOB_PROGRESS"):
                        continue
                    wrong += not (t == "JOB_RESULT" and q.same(job["estimate"], dd["estimate"])
                                  and job["evals"] == dd["evals"])
                    jobs_open = 0
                del want[rid]
                done += 1
            p.close()
            results[c] = (done, wrong)
        except Exception as e:  # counted below
            results[c] = repr(e)

    threads = [threading.Thread(target=client, args=(c,)) for c in range(n)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(600)
    failed = [r for r in results if not isinstance(r, tuple)]
    answered = sum(r[0] for r in results if isinstance(r, tuple))
    wrong = sum(r[1] for r in results if isinstance(r, tuple))
    check("load: %d clients x %d requests: %d answered, none lost" % (n, m, answered),
          not failed and answered == n * m, repr(failed[:3]))
    check("load: every answer equal to the in-process engine (%d wrong)" % wrong, wrong == 0)
    d.still_fine("%d x %d mixed requests" % (n, m))


def sc_saturate(d, jobs="12"):
    """More long jobs than the pool can run: each one is accepted (queued)
    or refused with a clear ERROR, none vanishes, and a small job and
    points are still answered meanwhile; cancelling frees them all."""
    jobs = int(jobs)
    p = Peer(d.addr, timeout=60)
    rids, accepted, refused = [], {}, 0
    for k in range(jobs):
        rid = p.rid()
        p.send(q.job_frame(p, rid, q.long_job(100 + k)))
        rids.append(rid)
    for _ in range(jobs):
        t, rid, dd = p.recv()
        if t == "JOB_ACCEPTED":
            accepted[rid] = dd["job_id"]
        elif t == "ERROR":
            refused += "\n" not in dd["message"] and "max-jobs" in dd["message"]
    check("saturated pool: %d jobs each accepted (%d) or refused with a reason (%d)"
          % (jobs, len(accepted), refused), len(accepted) + refused == jobs and
          len(accepted) > 2)
    other = Peer(d.addr, timeout=60)
    check("saturated pool: points still served to another client", d.points_ok(other, 5, 50))
    states = []
    for rid, job in accepted.items():
        c = p.rid()
        t, r, dd = p.call(frame(MSG["JOB_STATUS"], c, struct.pack("<Q", job)))
        while r != c:
            t, r, dd = p.recv()
        states.append(dd["state"])
    check("saturated pool: every accepted job is queued or running (%s)"
          % ",".join(sorted(set(states))), all(s in ("queued", "running") for s in states))
    for job in accepted.values():
        p.send(frame(MSG["JOB_CANCEL"], p.rid(), struct.pack("<Q", job)))
    answered = set()
    for _ in range(1000):
        if len(answered) == len(accepted):
            break
        t, r, dd = p.recv()
        if r in accepted and t == "ERROR" and dd["code"] == q.ECANCELED:
            answered.add(r)
    check("saturated pool: every cancelled job answered ECANCELED (%d of %d)"
          % (len(answered), len(accepted)), len(answered) == len(accepted))
    p.close()
    other.close()
    d.still_fine("a saturated pool")


SCENARIOS = dict(frames=sc_frames, specs=sc_specs, random_frames=sc_random_frames,
                 slowloris=sc_slowloris, load=sc_load, saturate=sc_saturate)


def main(argv):
    if len(argv) < 6 or argv[1] not in SCENARIOS:
        sys.stderr.write("usage: hostilepeer.py {%s} ADDR PID REFERENCE RSS_LIMIT_MB [ARGS...]\n"
                         % ",".join(SCENARIOS))
        return 2
    try:
        d = Daemon(*argv[2:6])
        SCENARIOS[argv[1]](d, *argv[6:])
    except Exception as e:  # one line, counted as a failure
        check(argv[1], False, "%s: %s" % (type(e).__name__, e))
    return 1 if q.FAILED else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
