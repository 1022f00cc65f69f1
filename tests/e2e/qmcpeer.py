#!/usr/bin/python3
"""qmcpeer.py - an independent client of the qmcd wire protocol, written
from protocol/PROTOCOL.md with nothing but struct and socket, so that the
e2e test checks the daemon against the spec rather than against our own
C codec.  It also holds the e2e scenarios that need a real peer; each one
prints "ok NAME" or "FAIL NAME: why" lines and exits non-zero on failure.

    qmcpeer.py SCENARIO ADDR [ARGS...]

ADDR is unix:PATH, tcp:HOST:PORT or tcp:[V6]:PORT.  Every wait is bounded
by a socket timeout; every loop by a count or a deadline.  The shared-memory
transport (protocol version 2, PROTOCOL.md section 10) is spoken with
os.memfd_create, fcntl seals and socket.send_fds, from the spec as well.
"""
import fcntl
import json
import math
import mmap
import os
import signal
import socket
import struct
import sys
import threading
import time

# ---- the wire format (PROTOCOL.md) ------------------------------------------

MAGIC = b"QMCD"
VERSION = 1
HEADER = struct.Struct("<4sBBHQII")  # magic, version, type, flags, id, len, reserved
MSG = dict(HELLO=1, HELLO_OK=2, PING=3, PONG=4, POINTS=5, POINTS_CHUNK=6, END=7,
           INTEGRATE=8, JOB_ACCEPTED=9, JOB_PROGRESS=10, JOB_RESULT=11,
           JOB_STATUS=12, JOB_STATE=13, JOB_CANCEL=14, STATS=15, STATS_REPLY=16,
           ERROR=17, SHM_ATTACH=18, SHM_OK=19, POINTS_SHM_CHUNK=20, SHM_RELEASE=21,
           AUTH_CHALLENGE=22, AUTH_RESPONSE=23, AUTH_OK=24, PIXELS=25,
           SESSION_OPEN=26, SESSION_OPENED=27, SESSION_BATCH=28, SESSION_VALUES=29,
           SESSION_REPORT=30, SESSION_RESULT=31, SESSION_RESUME=32, SESSION_CLOSE=33)
NAME = {v: k for k, v in MSG.items()}
KIND = dict(sobol=1, halton=2, hammersley=3, random=4, stratified=5, lhs=6)
SCRAMBLE = {"none": 0, "shift": 1, "owen": 2, "faure": 3, "fast-owen": 4}
FORMAT = dict(f64=(1, 8), f32=(2, 4), u32=(3, 4))
METHODS = ["auto", "mc", "stratified", "lhs", "qmc", "rqmc", "midpoint", "trapezoid",
           "simpson", "gauss-legendre", "gauss-kronrod", "cubature", "clenshaw-curtis"]
SAMPLERS = ["mc", "stratified", "lhs", "qmc", "rqmc"]
JOB_STATES = {1: "queued", 2: "running", 3: "done", 4: "cancelled", 5: "failed",
              6: "unknown"}
MIS_POWER = 5
# Result flag bits each protocol version defines (PROTOCOL.md section 5);
# a peer refuses a JOB_RESULT with any other bit set, as one built for that
# version must.
RESULT_FLAGS_V1 = ["nonfinite", "heavy_tail", "not_pow2", "dims_past_good", "not_converged",
                   "budget", "roundoff", "max_subdiv", "memory_bound", "few_reps",
                   "error_unreliable", "zero_pdf"]
RESULT_FLAGS_V3 = RESULT_FLAGS_V1 + ["few_nonzero", "zero_spread", "tail_untested",
                                     "unresolved", "mis_undersampled"]
RESULT_FLAGS = {1: RESULT_FLAGS_V1, 2: RESULT_FLAGS_V1, 3: RESULT_FLAGS_V3, 4: RESULT_FLAGS_V3,
                5: RESULT_FLAGS_V3}
# version 4 adds PIXELS (section 6.20), version 5 sessions (6.21); no flag bits
NEWEST_VERSION = 5
SESSION_ENDS = ["running", "converged", "complete", "budget", "cannot_tell", "failed"]
PIXEL_SAMPLER = {"zsobol": 1, "padded-sobol": 2, "sobol": 3}


def flag_bit(name):
    return 1 << RESULT_FLAGS_V3.index(name)


def flag_names(flags):
    return [n for i, n in enumerate(RESULT_FLAGS_V3) if flags >> i & 1] + \
        ["bit%d" % i for i in range(len(RESULT_FLAGS_V3), 32) if flags >> i & 1]
QMC_ETOOBIG = -1011
QMC_EPROTO = -1010
QMC_EINVAL = -1001
QMC_ENOTSUP = -1012
ECANCELED = -125
ETIMEDOUT = -110
ESHUTDOWN = -108


def str16(b):
    if isinstance(b, str):
        b = b.encode()
    return struct.pack("<H", len(b)) + b


def frame(mtype, rid, payload=b""):
    return HEADER.pack(MAGIC, VERSION, mtype, 0, rid, len(payload), 0) + payload


class Reader:
    """A bounded cursor over one payload: short input is an error."""

    def __init__(self, b):
        self.b, self.off = b, 0

    def take(self, n):
        if self.off + n > len(self.b):
            raise ValueError("payload too short")
        v = self.b[self.off:self.off + n]
        self.off += n
        return v

    def u(self, fmt):
        s = struct.Struct("<" + fmt)
        return s.unpack(self.take(s.size))[0]

    def s16(self):
        return self.take(self.u("H")).decode()

    def done(self):
        if self.off != len(self.b):
            raise ValueError("%d payload bytes left over" % (len(self.b) - self.off))


def sampling_spec(sampler="mc", seq="sobol", scramble="none", flags=0, seed=0, n=4096,
                  confidence=0.95, reps=1, split_net=0):
    return struct.pack("<BBBBIQQdIB3x", SAMPLERS.index(sampler), KIND.get(seq, 0),
                       SCRAMBLE[scramble], 0, flags, seed, n, confidence, reps, split_net)


def read_sampling(r):
    sampler, seq, scr, zero, flags = r.u("B"), r.u("B"), r.u("B"), r.u("B"), r.u("I")
    seed, n, conf, reps, split_net = r.u("Q"), r.u("Q"), r.u("d"), r.u("I"), r.u("B")
    r.take(3)
    return dict(sampler=SAMPLERS[sampler], seq=seq, scramble=scr, flags=flags, seed=seed,
                n=n, confidence=conf, reps=reps, split_net=split_net)


def decode(mtype, p, version=NEWEST_VERSION):
    """Payload bytes -> dict, checking every length as the spec says, and
    the result flags as the negotiated `version` defines them."""
    r = Reader(p)
    d = {"type": NAME.get(mtype, mtype)}
    if mtype == MSG["HELLO_OK"]:
        d["version"] = r.u("H")
        r.take(2)
        d["max_frame"], d["max_inflight"] = r.u("I"), r.u("I")
        r.take(4)
        d["max_points"], d["sobol_table_hash"] = r.u("Q"), r.u("Q")
        d["server"], d["engine"] = r.s16(), r.s16()
    elif mtype == MSG["PONG"]:
        d["data"] = r.take(r.u("H"))
    elif mtype == MSG["POINTS_CHUNK"]:
        d["first"], d["points"], dl = r.u("Q"), r.u("I"), r.u("I")
        d["data"] = r.take(dl)
    elif mtype == MSG["END"]:
        d["points"], d["bytes"] = r.u("Q"), r.u("Q")
    elif mtype == MSG["JOB_ACCEPTED"]:
        d["job_id"] = r.u("Q")
    elif mtype == MSG["JOB_PROGRESS"]:
        d["job_id"], d["evals"], d["seconds"] = r.u("Q"), r.u("Q"), r.u("d")
    elif mtype == MSG["JOB_STATE"]:
        d["job_id"], d["state"] = r.u("Q"), JOB_STATES.get(r.u("B"))
        r.take(7)
        d["evals"], d["seconds"] = r.u("Q"), r.u("d")
    elif mtype in (MSG["JOB_RESULT"], MSG["SESSION_RESULT"]):
        d["job_id"] = r.u("Q")
        d["method_used"] = METHODS[r.u("B")]
        d["error_kind"], d["reference_kind"], d["cv_used"] = r.u("B"), r.u("B"), r.u("B")
        d["dims"], d["flags"] = r.u("I"), r.u("I")
        defined = sum(1 << i for i in range(len(RESULT_FLAGS[version])))
        if d["flags"] & ~defined:
            raise ValueError("JOB_RESULT flags %#x: bits %#x are undefined in version %d"
                             % (d["flags"], d["flags"] & ~defined, version))
        r.take(4)
        for k in ("n", "evals", "nonfinite"):
            d[k] = r.u("Q")
        for k in ("estimate", "error", "ci_low", "ci_high", "abs_integral", "cv_beta",
                  "cv_variance_ratio", "seconds", "reference"):
            d[k] = r.u("d")
        d["sampling"] = read_sampling(r)
        d["detail"], d["auto_reason"] = r.s16(), r.s16()
    elif mtype == MSG["STATS_REPLY"]:
        d["stats"] = {}
        for _ in range(r.u("I")):
            name = r.s16()
            d["stats"][name] = r.u("Q")
    elif mtype == MSG["ERROR"]:
        d["code"], d["message"] = r.u("i"), r.s16()
    elif mtype == MSG["SHM_OK"]:
        d["slots"], d["slot_bytes"] = r.u("I"), r.u("I")
        if r.take(8) != bytes(8):
            raise ValueError("reserved bytes in SHM_OK")
    elif mtype == MSG["POINTS_SHM_CHUNK"]:
        d["first"], d["points"], d["data_len"], d["slot"] = r.u("Q"), r.u("I"), r.u("I"), r.u("I")
        if r.take(4) != bytes(4):
            raise ValueError("reserved bytes in POINTS_SHM_CHUNK")
    elif mtype == MSG["AUTH_CHALLENGE"]:
        d["version"] = r.u("H")
        if r.take(2) != bytes(2):
            raise ValueError("reserved bytes in AUTH_CHALLENGE")
        d["nonce"] = r.take(32)
    elif mtype == MSG["AUTH_OK"]:
        d["mac"] = r.take(32)
    elif mtype == MSG["SESSION_OPENED"]:
        d["session_id"], d["token"], d["dims"] = r.u("Q"), r.take(32), r.u("I")
        if r.take(4) != bytes(4):
            raise ValueError("reserved bytes in SESSION_OPENED")
        d["max_batch"], d["memory_bytes"], d["park_ms"] = r.u("Q"), r.u("Q"), r.u("Q")
    elif mtype == MSG["SESSION_BATCH"]:
        for k in ("seq", "count", "first"):
            d[k] = r.u("Q")
        d["points"], d["dims"], d["transport"] = r.u("I"), r.u("I"), r.u("B")
        if r.take(3) != bytes(3):
            raise ValueError("reserved bytes in SESSION_BATCH")
        d["slot"], d["data_len"] = r.u("I"), r.u("I")
        if d["data_len"] != d["points"] * d["dims"] * 8 or d["points"] < 1 or \
                d["first"] + d["points"] > d["count"]:
            raise ValueError("SESSION_BATCH sizes disagree: %r" % d)
        d["data"] = r.take(d["data_len"]) if d["transport"] == 0 else None
    elif mtype == MSG["SESSION_REPORT"]:
        d["session_id"], d["batches"], d["evals"], d["nonfinite"] = (r.u("Q"), r.u("Q"),
                                                                    r.u("Q"), r.u("Q"))
        d["end"] = SESSION_ENDS[r.u("B")]
        d["has_estimate"], d["error_kind"] = r.u("B"), r.u("B")
        r.take(1)
        d["flags"], d["err"], d["dims"] = r.u("I"), r.u("i"), r.u("I")
        defined = sum(1 << i for i in range(len(RESULT_FLAGS[version])))
        if d["flags"] & ~defined:
            raise ValueError("SESSION_REPORT flags %#x undefined in version %d"
                             % (d["flags"], version))
        for k in ("n", "res_evals", "res_nonfinite"):
            d[k] = r.u("Q")
        for k in ("estimate", "error", "ci_low", "ci_high", "abs_integral"):
            d[k] = r.u("d")
    else:
        raise ValueError("unexpected message type %r" % mtype)
    r.done()
    return d


class Peer:
    version = NEWEST_VERSION  # the protocol version, once HELLO_OK chose it

    def __init__(self, addr, timeout=15.0, hello=True, max_frame=16 << 20, version=1,
                 src=None):
        """A connection to addr (unix:PATH or tcp:HOST:PORT), with HELLO sent
        unless hello is False.  src: the TCP source address to bind first,
        so that a scenario can speak from an address of its own (all of
        127.0.0.0/8 is loopback)."""
        if addr.startswith("unix:"):
            self.s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            target = addr[5:]
        else:
            hp = addr[4:]
            host, port = hp.rsplit(":", 1)
            fam = socket.AF_INET6 if host.startswith("[") else socket.AF_INET
            self.s = socket.socket(fam, socket.SOCK_STREAM)
            target = (host.strip("[]"), int(port))
        self.s.settimeout(timeout)
        if src is not None:
            self.s.bind((src, 0))
        self.s.connect(target)
        self.buf = bytearray()
        self.next_id = 100
        self.info = None
        self.ring = None  # (mmap, slots, slot_bytes, next slot, slots held)
        if hello:
            self.info = self.hello(max_frame=max_frame, version=version)

    def close(self):
        self.s.close()

    def rid(self):
        self.next_id += 1
        return self.next_id

    def send(self, data):
        self.s.sendall(data)

    def recv(self):
        """One frame: (type name, request id, decoded dict); None at EOF."""
        while True:
            if len(self.buf) >= HEADER.size:
                magic, ver, mtype, flags, rid, plen, res = HEADER.unpack_from(self.buf)
                if magic != MAGIC or ver != VERSION or flags or res:
                    raise ValueError("bad frame header from the server")
                if len(self.buf) >= HEADER.size + plen:
                    p = bytes(self.buf[HEADER.size:HEADER.size + plen])
                    del self.buf[:HEADER.size + plen]
                    d = decode(mtype, p, self.version)
                    return d["type"], rid, d
            chunk = self.s.recv(1 << 20)
            if not chunk:
                if self.buf:
                    raise ValueError("EOF inside a frame")
                return None
            self.buf += chunk

    def call(self, data):
        self.send(data)
        return self.recv()

    def has_frame(self):
        """True when a whole frame is already buffered (no wait needed)."""
        if len(self.buf) < HEADER.size:
            return False
        return len(self.buf) >= HEADER.size + HEADER.unpack_from(self.buf)[5]

    def hello(self, max_frame=16 << 20, name="qmcpeer", version=1):
        t, rid, d = self.call(frame(MSG["HELLO"], 1, struct.pack("<HHI", 1, version, max_frame)
                                    + str16(name)))
        if t != "HELLO_OK":
            raise ValueError("HELLO answered with %s: %r" % (t, d))
        if d["version"] not in RESULT_FLAGS or d["version"] > version:
            raise ValueError("HELLO_OK chose version %d; we offered 1..%d" % (d["version"],
                                                                              version))
        self.version = d["version"]
        return d

    def ping_frame(self, rid, data=b"hello"):
        return frame(MSG["PING"], rid, str16(data))

    def ping(self, data=b"hello"):
        rid = self.rid()
        t, r, d = self.call(self.ping_frame(rid, data))
        return t == "PONG" and r == rid and d["data"] == data

    def points_frame(self, rid, kind="sobol", dims=2, scramble="none", seed=0, set_size=0,
                     start=0, count=8, fmt="f64", flags=0, transport=0):
        p = struct.pack("<BBBBII4xQQQQ", KIND[kind], SCRAMBLE[scramble], FORMAT[fmt][0],
                        transport, dims, flags, seed, set_size, start, count)
        return frame(MSG["POINTS"], rid, p)

    def attach(self, fd, slots, slot_bytes, ring=None, rid=None):
        """SHM_ATTACH with fd beside it (None: no descriptor); returns the
        answer (type, id, dict).  On SHM_OK the ring mmap is remembered."""
        rid = rid or self.rid()
        data = frame(MSG["SHM_ATTACH"], rid, struct.pack("<II8x", slots, slot_bytes))
        if fd is None:
            self.send(data)
        else:
            socket.send_fds(self.s, [data], [fd])
        t, r, d = self.recv()
        if t == "SHM_OK" and ring is not None:
            self.ring = [ring, slots, slot_bytes, 0, 0]
        return t, r, d

    def release(self, n=None, rid=0):
        n = self.ring[4] if n is None else n
        self.send(frame(MSG["SHM_RELEASE"], rid, struct.pack("<I", n)))
        if self.ring:
            self.ring[4] -= min(n, self.ring[4])

    def points_shm(self, release=True, max_chunks=1 << 20, **kw):
        """POINTS through the attached ring: (data bytes, END dict, chunks).
        Releases every held slot whenever no whole frame is buffered (one
        SHM_RELEASE for a batch), unless release is False."""
        rid = self.rid()
        self.send(self.points_frame(rid, transport=1, **kw))
        data, expect, chunks = bytearray(), kw.get("start", 0), 0
        ring, slots, slot_bytes = self.ring[0], self.ring[1], self.ring[2]
        for _ in range(max_chunks + 1):
            t, r, d = self.recv()
            if r != rid:
                raise ValueError("answer for request %d, expected %d" % (r, rid))
            if t == "ERROR":
                if self.ring[4]:
                    self.release()
                raise PeerError(d)
            if t == "END":
                if d["points"] != kw.get("count", 8) or d["bytes"] != len(data):
                    raise ValueError("END totals %r disagree with the chunks" % d)
                if self.ring[4] and release:
                    self.release()
                return bytes(data), d, chunks
            if t != "POINTS_SHM_CHUNK" or d["first"] != expect:
                raise ValueError("chunk out of order: %s first %r" % (t, d.get("first")))
            if d["slot"] != self.ring[3] or d["data_len"] > slot_bytes or self.ring[4] >= slots:
                raise ValueError("slot %d (%d bytes) with %d held; expected slot %d"
                                 % (d["slot"], d["data_len"], self.ring[4], self.ring[3]))
            self.ring[3] = (d["slot"] + 1) % slots
            self.ring[4] += 1
            off = d["slot"] * slot_bytes
            data += ring[off:off + d["data_len"]]
            expect += d["points"]
            chunks += 1
            if chunks >= max_chunks:
                return bytes(data), None, chunks
            if release and not self.has_frame():
                self.release()
        raise ValueError("too many chunks")

    def points(self, **kw):
        """Returns (data bytes, END dict) or raises with the ERROR."""
        rid = self.rid()
        self.send(self.points_frame(rid, **kw))
        data, expect = bytearray(), kw.get("start", 0)
        for _ in range(1 << 20):
            t, r, d = self.recv()
            if r != rid:
                raise ValueError("answer for request %d, expected %d" % (r, rid))
            if t == "ERROR":
                raise PeerError(d)
            if t == "END":
                if d["points"] != kw.get("count", 8) or d["bytes"] != len(data):
                    raise ValueError("END totals %r disagree with the chunks" % d)
                return bytes(data), d
            if t != "POINTS_CHUNK" or d["first"] != expect:
                raise ValueError("chunk out of order: %s first %r" % (t, d.get("first")))
            expect += d["points"]
            data += d["data"]
        raise ValueError("too many chunks")

    def integrate_frame(self, rid, integrand, dims, method="auto", sampling=None, n_given=0,
                        n_axis=0, tol_abs=0.0, tol_rel=0.0, max_evals=100000000,
                        max_memory=64 << 20, progress_ms=0, a=(), u=(), control="",
                        difficulty=-1):
        samp = sampling or sampling_spec()
        p = struct.pack("<BBBBIIIIIQQddd", METHODS.index(method), MIS_POWER,
                        255 if difficulty < 0 else difficulty, n_given, dims, 1, 1, n_axis,
                        progress_ms, max_evals, max_memory, 2.0, tol_abs, tol_rel)
        p += samp + str16(integrand) + str16(control)
        p += struct.pack("<I", len(a)) + b"".join(struct.pack("<d", x) for x in a)
        p += struct.pack("<I", len(u)) + b"".join(struct.pack("<d", x) for x in u)
        p += struct.pack("<I", 0)
        return frame(MSG["INTEGRATE"], rid, p)

    def stats(self):
        rid = self.rid()
        t, r, d = self.call(frame(MSG["STATS"], rid))
        if t != "STATS_REPLY" or r != rid:
            raise ValueError("STATS answered with %s" % t)
        return d["stats"]


class PeerError(Exception):
    def __init__(self, d):
        Exception.__init__(self, "ERROR %d: %s" % (d["code"], d["message"]))
        self.code, self.message = d["code"], d["message"]


# ---- reporting -------------------------------------------------------------

FAILED = []


def check(name, cond, why=""):
    if cond:
        print("ok %s" % name)
    else:
        print("FAIL %s: %s" % (name, why))
        FAILED.append(name)


def expect_closed(p, name):
    """Reads until EOF (bounded): returns the ERROR frames seen."""
    errors = []
    for _ in range(1000):
        try:
            f = p.recv()
        except (ConnectionResetError, socket.timeout, ValueError) as e:
            if isinstance(e, socket.timeout):
                errors.append({"code": 0, "message": "timeout: not closed"})
            break
        if f is None:
            break
        if f[0] == "ERROR":
            errors.append(f[2])
    return errors


# ---- scenarios ---------------------------------------------------------------

def sc_hello(addr, fingerprint):
    p = Peer(addr)
    h = p.info
    check("hello version", h["version"] == 1, repr(h))
    check("hello sobol hash = qmc --version fingerprint",
          "%016x" % h["sobol_table_hash"] == fingerprint,
          "%016x vs %s" % (h["sobol_table_hash"], fingerprint))
    check("hello limits", h["max_frame"] >= 4096 and h["max_inflight"] >= 1
          and h["max_points"] >= 1 and h["server"] == "qmcd" and h["engine"], repr(h))
    check("ping", p.ping(b"\x00\xffbinary"))
    p.close()


def sc_points(addr, out, kind, dims, scramble, seed, set_size, start, count, fmt, flags):
    p = Peer(addr)
    data, end = p.points(kind=kind, dims=int(dims), scramble=scramble, seed=int(seed),
                         set_size=int(set_size), start=int(start), count=int(count), fmt=fmt,
                         flags=int(flags))
    with open(out, "wb") as f:
        f.write(data)
    check("POINTS %s %s %s %s: %d chunks' worth, END totals agree" % (kind, dims, scramble, fmt,
          len(data)), len(data) == int(count) * int(dims) * FORMAT[fmt][1])
    p.close()


def sc_points_error(addr, kind, dims, scramble, set_size, start, count, want_code):
    p = Peer(addr)
    try:
        p.points(kind=kind, dims=int(dims), scramble=scramble, set_size=int(set_size),
                 start=int(start), count=int(count))
        check("points error %s/%s" % (kind, dims), False, "no ERROR")
    except PeerError as e:
        check("points error %s dims %s: %s" % (kind, dims, e.message),
              e.code == int(want_code) and "\n" not in e.message and e.message,
              "code %d" % e.code)
    check("connection survives a refused request", p.ping())
    p.close()


def job_frame(p, rid, spec):
    return p.integrate_frame(rid, **spec)


def cli_like_spec(integrand, dims, method, n=None, reps=None, seed=0):
    """The job `qmc integrate --integrand I --dims D --method M [--n N]
    [--reps R] --seed S` runs (cmd_integrate.c's defaults)."""
    if method in SAMPLERS:
        samp = sampling_spec(method, "sobol", "owen" if method == "rqmc" else "none",
                             0, seed, n or 4096, 0.95,
                             reps or (16 if method == "rqmc" else 1))
    else:
        samp = sampling_spec("mc", "sobol", "none", 0, seed, n or 4096, 0.95, 1)
    return dict(integrand=integrand, dims=dims, method=method, sampling=samp,
                n_given=1 if n else 0, n_axis=n or 0)


def long_job(seed):
    """A job that runs for many seconds (2^28 evaluations in 64 dimensions)
    but whose per-block sums stay small (65536 blocks, about 40 MB)."""
    spec = cli_like_spec("genz-oscillatory", 64, "rqmc", 1 << 24, 16, seed)
    spec["max_evals"] = 1 << 40
    return spec


def run_job(p, spec):
    rid = p.rid()
    p.send(job_frame(p, rid, spec))
    t, r, d = p.recv()
    if t == "ERROR":
        raise PeerError(d)
    if t != "JOB_ACCEPTED" or r != rid:
        raise ValueError("INTEGRATE answered %s" % t)
    for _ in range(100000):
        t, r, d = p.recv()
        if r != rid:
            raise ValueError("answer for %d, expected %d" % (r, rid))
        if t == "JOB_PROGRESS":
            continue
        if t == "ERROR":
            raise PeerError(d)
        return d
    raise ValueError("no result")


def same(a, b):
    if a is None:
        return b is None or (isinstance(b, float) and math.isnan(b))
    return struct.pack("<d", float(a)) == struct.pack("<d", b)


def sc_integrate(addr, cli_json, integrand, dims, method, n, reps, seed):
    want = json.load(open(cli_json))
    spec = cli_like_spec(integrand, int(dims), method, int(n) or None, int(reps) or None,
                         int(seed))
    p = Peer(addr)
    d = run_job(p, spec)
    std = d["error"] if d["error_kind"] == 1 else float("nan")
    name = "integrate %s %s" % (integrand, method)
    check(name + " estimate bits", same(want["estimate"], d["estimate"]),
          "%r vs %r" % (want["estimate"], d["estimate"]))
    check(name + " stderr bits", same(want["stderr"], std), "%r vs %r" % (want["stderr"], std))
    check(name + " ci and counts", same(want["ci_low"], d["ci_low"]) and
          want["n"] == d["n"] and want["evals"] == d["evals"] and
          want["method_used"] == d["method_used"] and want["detail"] == d["detail"],
          "%r vs %r" % (want, d))
    p.close()


def sc_flags_compat(addr):
    """Result flags 12-16 came with version 3: a peer that negotiated 1 or 2
    gets a result with none of them (recv() refuses undefined bits) and
    error_unreliable in their place; a version-3 peer gets them as they
    are.  Everything else in the result is the same at every version."""
    peak = dict(a=(400.0, 400.0), u=(0.123, 0.777))
    # Clenshaw-Curtis searches for mass while every node returns 0 and
    # finds the a = 400 peak; one 1/5000 wide outlasts its memory bound
    # still unresolved (test_stability_cc.c).
    narrow = dict(a=(5000.0, 5000.0), u=(0.123, 0.777))
    cases = [
        # Clenshaw-Curtis cannot resolve a very narrow peak: unresolved
        # (the engine also raises error_unreliable).
        ("clenshaw-curtis on an unresolved peak", "unresolved",
         dict(cli_like_spec("genz-gaussian", 2, "clenshaw-curtis"), **narrow)),
        # 64 MC points cannot test the tail (k = n / 20 < 8): tail_untested,
        # which alone does not raise error_unreliable in the engine.
        ("mc at n = 64", "tail_untested", cli_like_spec("genz-oscillatory", 2, "mc", 64)),
        # One QMC point set that saw the peak a few times, no bar at all.
        ("qmc on a missed peak", "few_nonzero",
         dict(cli_like_spec("genz-gaussian", 2, "qmc", 256), **peak)),
    ]
    old = sum(1 << i for i in range(len(RESULT_FLAGS_V1)))
    unreliable = flag_bit("error_unreliable")
    for name, want, spec in cases:
        got = {}
        for version in (1, 2, 3):
            p = Peer(addr, version=version)
            check("%s: version %d negotiated" % (name, version), p.version == version,
                  repr(p.info))
            got[version] = run_job(p, spec)
            p.close()
        new = got[3]
        check("%s: version 3 sees %s %s" % (name, want, flag_names(new["flags"])),
              new["flags"] & flag_bit(want), "%#x" % new["flags"])
        for version in (1, 2):
            d = got[version]
            check("%s: version %d sees %s, no bit past 11, error_unreliable"
                  % (name, version, flag_names(d["flags"])),
                  d["flags"] == (new["flags"] & old) | unreliable,
                  "%#x vs %#x" % (d["flags"], new["flags"]))
            same_rest = all(same(new[k], d[k]) for k in
                            ("estimate", "error", "ci_low", "ci_high", "abs_integral",
                             "reference")) and \
                all(new[k] == d[k] for k in ("n", "evals", "nonfinite", "dims",
                                             "method_used", "error_kind", "detail",
                                             "auto_reason", "sampling"))
            check("%s: version %d result otherwise identical" % (name, version), same_rest,
                  "%r vs %r" % (d, new))


def sc_pipeline(addr, max_inflight):
    p = Peer(addr)
    ids = {}
    batch = b""
    for i in range(5):
        rid = p.rid()
        ids[rid] = "PING"
        batch += p.ping_frame(rid, b"p%d" % i)
    big = p.rid()
    ids[big] = "POINTS"
    batch += p.points_frame(big, dims=16, count=200000)  # ~25 MB: many chunks
    job = p.rid()
    ids[job] = "INTEGRATE"
    batch += job_frame(p, job, cli_like_spec("genz-gaussian", 3, "rqmc", 4096, 8, 1))
    st = p.rid()
    ids[st] = "STATS"
    batch += frame(MSG["STATS"], st)
    p.send(batch)  # everything before reading anything
    done, chunks, late, pong_during = set(), 0, None, False
    for _ in range(100000):
        if len(done) == len(ids):
            break
        t, r, d = p.recv()
        if r not in ids:
            check("pipeline ids", False, "unknown id %d" % r)
            break
        if t == "POINTS_CHUNK":
            chunks += 1
            if chunks == 1:  # the stream is going: a PING must overtake it
                late = p.rid()
                ids[late] = "PING"
                p.send(p.ping_frame(late, b"late"))
        elif t == "PONG" and r == late:
            pong_during = big not in done
            done.add(r)
        elif t in ("PONG", "END", "JOB_RESULT", "STATS_REPLY", "ERROR"):
            done.add(r)
    check("pipelining: every request answered, matched by id", len(done) == len(ids),
          "%d of %d" % (len(done), len(ids)))
    check("pipelining: a PING sent mid-stream is answered before the stream's END",
          pong_during, "chunks %d" % chunks)
    # max-inflight: more POINTS than allowed, in one write.
    n = int(max_inflight) + 8
    reqs = [p.rid() for _ in range(n)]
    p.send(b"".join(p.points_frame(r, dims=1, count=300000) for r in reqs))
    left, refused, bad = set(reqs), 0, 0
    for _ in range(100000):
        if not left:
            break
        t, r, d = p.recv()
        if t == "ERROR":
            if d["code"] == QMC_ETOOBIG and "max-inflight" in d["message"]:
                refused += 1
            else:
                bad += 1
            left.discard(r)
        elif t == "END":
            left.discard(r)
    check("max-inflight enforced with ERROR ETOOBIG", not left and refused >= 8 and not bad,
          "left %d refused %d other errors %d" % (len(left), refused, bad))
    # Far more answers than the output buffer holds, requested in one go
    # while we read concurrently: every one must come back.
    n_ping, data = 20000, b"x" * 256
    first = p.next_id + 1
    blob = b"".join(p.ping_frame(first + i, data) for i in range(n_ping))
    p.next_id += n_ping
    sender = threading.Thread(target=p.send, args=(blob,))
    sender.start()
    got = 0
    for _ in range(n_ping):
        f = p.recv()
        if f is None or f[0] != "PONG":
            break
        got += 1
    sender.join(30)
    check("%d pipelined PINGs (5 MB of answers) all answered" % n_ping, got == n_ping,
          "%d answered" % got)
    # A request id still in flight is refused (EINVAL), and that ERROR is
    # the id's final answer: it ends the first request too (PROTOCOL.md
    # section 3), so nothing more comes for the id - a PING behind it shows.
    dup = p.rid()
    after = p.rid()
    p.send(p.points_frame(dup, dims=8, count=100000) + p.points_frame(dup, dims=1, count=1))
    dup_err, late = False, []
    for _ in range(100000):
        t, r, d = p.recv()
        if t == "ERROR" and r == dup:
            dup_err = d["code"] == -1001 and "already in flight" in d["message"]
            p.send(p.ping_frame(after))
            break
    for _ in range(100000):
        t, r, d = p.recv()
        if r == after:
            break
        late.append((t, r))
    check("duplicate request id in flight: ERROR EINVAL ends both requests",
          dup_err and not any(r == dup for _, r in late), repr(late[:4]))
    p.close()


def sc_concurrent(addr, n):
    n = int(n)
    results = [None] * n
    sem = threading.Semaphore(n)

    def client(i):
        with sem:
            try:
                p = Peer(addr, timeout=30)
                ok = p.ping(b"c%d" % i)
                data, _ = p.points(dims=3, count=64, start=i)
                ok = ok and len(data) == 64 * 3 * 8
                p.close()
                results[i] = ok
            except Exception as e:  # reported below
                results[i] = repr(e)

    threads = [threading.Thread(target=client, args=(i,)) for i in range(n)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(60)
    bad = [r for r in results if r is not True]
    check("%d concurrent clients all served" % n, not bad, "%d failed: %r" % (len(bad), bad[:3]))


def sc_disconnect(addr):
    a = Peer(addr)
    a.send(a.points_frame(a.rid(), dims=64, count=1 << 24))
    a.recv()  # one chunk, then vanish mid-stream
    a.s.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
    a.close()
    b = Peer(addr)
    check("client gone mid-stream: others still served", b.ping())
    ok = True
    for _ in range(5):  # and the daemon dropped the stream, not the others
        ok = ok and b.ping()
    check("daemon alive after the disconnect", ok)
    b.close()


def sc_laggard(addr):
    """A client that pipelines more PINGs than its answers' buffers hold,
    then reads nothing for a while: the daemon stops reading it (its
    answers back up), so the rest of a frame may wait in the socket - the
    peer is not late with it, and frame-timeout-ms must not cut it
    (write-timeout-ms, 60 s by default, judges a reader).  Run where
    frame-timeout-ms is short (1 s): the 3 s pause is three of them.  A
    slow machine can only make the pause look shorter to the daemon, never
    fail a daemon that waits."""
    p = Peer(addr)
    n, data = 40000, b"x" * 256  # 11 MB of answers: more than 4 MB of out-buffer-bytes
    first = p.next_id + 1
    blob = b"".join(p.ping_frame(first + i, data) for i in range(n))
    p.next_id += n

    def send():
        try:
            p.send(blob)
        except OSError:  # cut off: the check below says so
            pass

    sender = threading.Thread(target=send, daemon=True)
    sender.start()
    sender.join(3.0)
    held = sender.is_alive()  # the daemon stopped reading: our send blocks
    time.sleep(3.0)
    got, other = 0, None
    try:
        for _ in range(n):
            f = p.recv()
            if f is None or f[0] != "PONG":
                other = f and (f[0], f[2])
                break
            got += 1
    except (ConnectionResetError, socket.timeout, ValueError) as e:
        other = repr(e)
    sender.join(30)
    check("a pipelining client that stops reading for 3 s: the daemon stops reading it (%s) "
          "and still answers all %d PINGs (%d), no frame-timeout-ms" % (held, n, got),
          held and got == n, repr(other))
    p.close()


def vmrss_kb(pid):
    with open("/proc/%d/status" % pid) as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return -1


def sc_noread(addr, pid, limit_mb):
    pid, limit = int(pid), int(limit_mb) * 1024
    a = Peer(addr)
    a.s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    base = vmrss_kb(pid)
    a.send(a.points_frame(a.rid(), dims=16, count=1 << 26))  # 8 GiB if it were all sent
    b = Peer(addr)
    # A fixed number of rounds, each checked, not "as many as fit in N
    # seconds": a loaded machine must not turn this into a failure.
    peak, served, rounds = base, 0, 200
    for i in range(rounds):
        data, _ = b.points(dims=4, count=1000, start=i)
        ref, _ = b.points(dims=4, count=1, start=i)
        served += b.ping() and len(data) == 1000 * 4 * 8 and data[:32] == ref
        peak = max(peak, vmrss_kb(pid))
    check("a reader that never reads: others served (%d of %d rounds)" % (served, rounds),
          served == rounds)
    check("a reader that never reads: VmRSS bounded (%d kB -> peak %d kB, limit +%d kB)"
          % (base, peak, limit), peak - base < limit)
    st = b.stats()
    a.close()
    b.close()
    return st


def sc_stall(addr):
    """A reader that never reads is cut off after write-timeout-ms: the
    stalled connection itself must reach end-of-stream (what the daemon had
    queued, then EOF or a reset), not merely some counter move."""
    a = Peer(addr)
    a.s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    a.send(a.points_frame(a.rid(), dims=16, count=1 << 26))
    b = Peer(addr)
    before = b.stats().get("connections_timed_out", 0)
    # Wait for the daemon's timer by watching its counter (state), then
    # drain the stalled socket: it must end.  The socket timeout only
    # guards against a hang; it is never what the check measures.
    for _ in range(600):
        if b.stats().get("connections_timed_out", 0) > before:
            break
        time.sleep(0.05)
    a.s.settimeout(30.0)
    drained, closed = 0, False
    try:
        while True:
            chunk = a.s.recv(1 << 20)
            if not chunk:
                closed = True
                break
            drained += len(chunk)
            if drained > (1 << 31):
                break
    except ConnectionResetError:
        closed = True
    except socket.timeout:
        closed = False
    check("a reader that never reads: its own connection is closed (%d bytes queued before)"
          % drained, closed and drained < (1 << 26) * 16 * 8)
    check("a reader that never reads: others still served", b.ping())
    a.close()
    b.close()


def sc_cancel(addr):
    p = Peer(addr)
    rid = p.rid()
    spec = long_job(1)
    spec["progress_ms"] = 100
    p.send(job_frame(p, rid, spec))
    t, r, d = p.recv()
    check("INTEGRATE answered JOB_ACCEPTED at once", t == "JOB_ACCEPTED" and r == rid, t)
    job = d.get("job_id", 0)
    progress = None
    for _ in range(100):
        t, r, d = p.recv()
        if t == "JOB_PROGRESS" and d["evals"] > 0:
            progress = d
            break
    check("JOB_PROGRESS reports evals", progress is not None and r == rid, repr(progress))
    s = p.rid()
    t, r, d = p.call(frame(MSG["JOB_STATUS"], s, struct.pack("<Q", job)))
    while t == "JOB_PROGRESS":
        t, r, d = p.recv()
    check("JOB_STATUS: running with evals", t == "JOB_STATE" and r == s and
          d["state"] == "running" and d["evals"] > 0, repr(d))
    c = p.rid()
    p.send(frame(MSG["JOB_CANCEL"], c, struct.pack("<Q", job)))
    got_state = got_err = got_result = False
    for _ in range(1000):
        t, r, d = p.recv()
        if t == "JOB_STATE" and r == c:
            got_state = d["state"] == "cancelled"
        elif t == "ERROR" and r == rid:
            got_err = d["code"] == ECANCELED
            break
        elif t == "JOB_RESULT" and r == rid:
            got_result = True
            break
    check("JOB_CANCEL -> JOB_STATE cancelled", got_state)
    # Order, not time: the job (2^40 evaluations allowed) is answered
    # ECANCELED instead of running on to a result.
    check("cancelled INTEGRATE -> ERROR ECANCELED, never a result",
          got_err and not got_result)
    t, r, d = p.call(frame(MSG["JOB_STATUS"], p.rid(), struct.pack("<Q", job)))
    check("finished job is unknown afterwards", t == "JOB_STATE" and d["state"] == "unknown")
    p.close()


def sc_timeout(addr):
    p = Peer(addr)
    spec = long_job(2)
    t0 = time.time()
    try:
        run_job(p, spec)
        check("job time limit", False, "finished?")
    except PeerError as e:
        check("job time limit: ERROR ETIMEDOUT after %.1f s" % (time.time() - t0),
              e.code == ETIMEDOUT and "job-time-limit-ms" in e.message, e.message)
    p.close()


def sc_jobs_for_sigterm(addr, marker):
    """Starts long jobs, signals readiness through a file, then expects
    the daemon to answer them (ERROR: shutting down) and close."""
    p = Peer(addr)
    rids = []
    for i in range(3):
        rid = p.rid()
        p.send(job_frame(p, rid, long_job(10 + i)))
        rids.append(rid)
    accepted = 0
    for _ in range(3):
        t, r, d = p.recv()
        accepted += t == "JOB_ACCEPTED"
    open(marker, "w").close()
    errors = expect_closed(p, "sigterm")
    check("SIGTERM: jobs accepted (%d) then answered ERROR before close" % accepted,
          accepted == 3 and len(errors) >= 3 and
          all(e["code"] in (ESHUTDOWN, ECANCELED) for e in errors[:3]), repr(errors))


def log_count(log, text):
    with open(log, errors="replace") as f:
        return f.read().count(text)


def sc_reload(addr, config, pid, log):
    """SIGHUP reloads; each wait is for the daemon's state (STATS
    config_reloads, the rejection in its log `log`), bounded by a deadline
    that only stops a hang."""
    pid = int(pid)
    p = Peer(addr)
    before = p.stats().get("config_reloads", 0)
    try:
        p.points(dims=1, count=1000)
        ok = True
    except PeerError:
        ok = False
    check("before reload: 1000 points allowed", ok)
    text = open(config).read()
    with open(config, "w") as f:
        f.write(text + "\nmax-points = 500\n")
    os.kill(pid, signal.SIGHUP)
    end = time.monotonic() + 60
    while p.stats().get("config_reloads", 0) == before and time.monotonic() < end:
        time.sleep(0.02)
    err = None
    try:
        p.points(dims=1, count=1000)
    except PeerError as e:
        err = e
    check("SIGHUP reload: new max-points enforced without reconnecting",
          err is not None and err.code == QMC_ETOOBIG and "max-points" in err.message,
          repr(err))
    check("SIGHUP reload counted", p.stats().get("config_reloads", 0) == before + 1)
    with open(config, "w") as f:
        f.write(text + "\nmax-points = 500\nno-such-key = 1\n")
    rejected = log_count(log, "reload rejected")
    os.kill(pid, signal.SIGHUP)
    end = time.monotonic() + 60
    while log_count(log, "reload rejected") == rejected and time.monotonic() < end:
        time.sleep(0.02)
    check("bad config on SIGHUP: the daemon logs the rejection",
          log_count(log, "reload rejected") == rejected + 1)
    try:
        p.points(dims=1, count=1000)
        kept = False
    except PeerError as e:
        kept = "max-points" in e.message
    check("bad config on SIGHUP rejected, old one kept", kept and p.ping() and
          p.stats().get("config_reloads", 0) == before + 1)
    with open(config, "w") as f:
        f.write(text)
    os.kill(pid, signal.SIGHUP)
    p.close()


def sc_malformed(addr):
    other = Peer(addr)
    cases = [
        ("garbage bytes", b"GET / HTTP/1.1\r\n\r\n", QMC_EPROTO),
        ("bad magic", b"QMCX" + bytes(20), QMC_EPROTO),
        ("oversized payload_len", HEADER.pack(MAGIC, 1, MSG["PING"], 0, 7, 0x7fffffff, 0),
         QMC_ETOOBIG),
        ("bad enum in POINTS", frame(MSG["POINTS"], 9, struct.pack("<BBBBII4xQQQQ", 99, 0, 1,
                                                                     0, 2, 0, 0, 0, 0, 8)),
         QMC_EPROTO),
        ("server-only type", frame(MSG["PONG"], 9, str16(b"x")), QMC_EPROTO),
        ("unknown type", HEADER.pack(MAGIC, 1, 99, 0, 1, 0, 0), QMC_EPROTO),
    ]
    for name, data, code in cases:
        p = Peer(addr)
        p.send(data)
        errs = expect_closed(p, name)
        check("malformed (%s): ERROR then close" % name,
              len(errs) == 1 and errs[0]["code"] == code, repr(errs))
        p.close()
        check("malformed (%s): other clients served" % name, other.ping())
    p = Peer(addr)
    p.send(frame(MSG["HELLO"], 2, struct.pack("<HHI", 1, 1, 1 << 20) + str16("again")))
    errs = expect_closed(p, "second hello")
    check("second HELLO: ERROR EPROTO then close", len(errs) == 1 and
          errs[0]["code"] == QMC_EPROTO, repr(errs))
    p = Peer(addr, hello=False)
    p.send(frame(MSG["HELLO"], 1, struct.pack("<HHI", 1, 1, 4096) + str16("tiny")))
    errs = expect_closed(p, "small max_frame")
    check("HELLO max_frame below 65536: ERROR EINVAL then close", len(errs) == 1 and
          errs[0]["code"] == -1001, repr(errs))
    p = Peer(addr, hello=False)
    p.send(frame(MSG["HELLO"], 1, struct.pack("<HHI", 9, 10, 1 << 20) + str16("future")))
    errs = expect_closed(p, "version")
    check("no common version: ERROR ENOTSUP then close", len(errs) == 1 and
          errs[0]["code"] == -1012, repr(errs))
    p = Peer(addr, hello=False)
    p.send(p.ping_frame(5))
    errs = expect_closed(p, "no hello")
    check("request before HELLO: ERROR then close", len(errs) == 1 and
          errs[0]["code"] == QMC_EPROTO, repr(errs))
    other.close()


def sc_partial(addr):
    p = Peer(addr)
    t0 = time.time()
    p.send(p.ping_frame(3)[:30])  # half a frame, then silence
    errs = expect_closed(p, "partial")
    check("partial frame: ERROR and disconnect after %.1f s" % (time.time() - t0),
          len(errs) == 1 and errs[0]["code"] == ETIMEDOUT and
          "frame-timeout-ms" in errs[0]["message"], repr(errs))
    p = Peer(addr, hello=False)
    t0 = time.time()
    errs = expect_closed(p, "handshake")
    check("no HELLO: ERROR and disconnect after %.1f s" % (time.time() - t0),
          len(errs) == 1 and "handshake-timeout-ms" in errs[0]["message"], repr(errs))


def sc_maxconn(addr, limit):
    peers = [Peer(addr) for _ in range(int(limit))]
    extra = Peer(addr, hello=False)
    errs = expect_closed(extra, "maxconn")
    check("max-connections: the next client gets ERROR and is closed",
          len(errs) == 1 and errs[0]["code"] == QMC_ETOOBIG and
          "max-connections" in errs[0]["message"], repr(errs))
    check("max-connections: existing clients served", all(p.ping() for p in peers))
    for p in peers:
        p.close()


def sc_stats(addr):
    p = Peer(addr)
    st = p.stats()
    need = ["connections_accepted", "bytes_in", "bytes_out", "requests_PING",
            "requests_POINTS", "requests_INTEGRATE", "jobs_done", "errors_sent",
            "requests_SHM_ATTACH", "requests_SHM_RELEASE",
            "latency_p50_us", "latency_p99_us", "latency_p999_us"]
    missing = [k for k in need if k not in st]
    check("STATS has the counters", not missing, "missing %r" % missing)
    check("STATS values plausible", not missing and st["requests_PING"] > 0 and
          st["bytes_out"] > st["bytes_in"] > 0 and
          st["latency_p50_us"] <= st["latency_p99_us"] <= st["latency_p999_us"], repr(st))
    p.close()


def sc_ping(addr):
    p = Peer(addr)
    check("ping over %s" % addr.split(":")[0] + (" v6" if "[" in addr else ""), p.ping())
    p.close()


# ---- the shared-memory transport (PROTOCOL.md section 10) -------------------

def make_ring(slots, slot_bytes, seal=True, populate=True, size=None, name="qmcpeer-ring"):
    """A memfd for a ring as the spec asks (sealed, every page written) or
    deliberately not; returns (fd, read-only mmap of it or None)."""
    size = size if size is not None else slots * slot_bytes
    fd = os.memfd_create(name, os.MFD_CLOEXEC | os.MFD_ALLOW_SEALING)
    os.ftruncate(fd, size)
    if populate and size:
        os.pwrite(fd, bytes(size), 0)
    if seal:
        # Not F_SEAL_SEAL: the server adds F_SEAL_FUTURE_WRITE after mapping.
        fcntl.fcntl(fd, fcntl.F_ADD_SEALS, fcntl.F_SEAL_SHRINK | fcntl.F_SEAL_GROW)
    m = mmap.mmap(fd, size, mmap.MAP_SHARED, mmap.PROT_READ) if size else None
    return fd, m


def shm_peer(addr, slots=4, slot_bytes=64 << 10, timeout=15.0):
    """A version-2 peer with a ring attached (fd closed once sent)."""
    p = Peer(addr, version=2, timeout=timeout)
    fd, m = make_ring(slots, slot_bytes)
    t, r, d = p.attach(fd, slots, slot_bytes, ring=m)
    os.close(fd)
    if t != "SHM_OK" or d["slots"] != slots or d["slot_bytes"] != slot_bytes:
        raise ValueError("SHM_ATTACH answered %s %r" % (t, d))
    return p


def settle(cond, seconds=30.0):
    """Polls cond() until it holds or `seconds` pass: the wait for a state
    the daemon reaches on its own (closing its side of a connection we
    closed); the deadline only bounds a hang.  Returns cond()'s last value."""
    end = time.monotonic() + seconds
    while not cond() and time.monotonic() < end:
        time.sleep(0.01)
    return cond()


def fd_count(pid):
    return len(os.listdir("/proc/%d/fd" % pid))


def ring_maps(pid, name="qmcpeer-ring"):
    with open("/proc/%d/maps" % pid) as f:
        return sum(1 for line in f if ("memfd:" + name) in line)


def refused(p, fd, slots, slot_bytes, name, code, text):
    t, r, d = p.attach(fd, slots, slot_bytes)
    check("SHM_ATTACH %s: ERROR %d '%s'" % (name, code, text),
          t == "ERROR" and d["code"] == code and text in d["message"] and
          "\n" not in d["message"], repr((t, d)))


def sc_shm(addr, tcp_addr, pid, limit_mb):
    """The ring: same bytes as inline, the memfd rules, descriptors never
    leak, releases and stalls, TCP.  limit_mb bounds the daemon's VmRSS
    growth while a client stalls its ring (sanitizers need more)."""
    pid, limit = int(pid), int(limit_mb) * 1024
    fds0 = fd_count(pid)
    # Version negotiation: 1..2 gets 2, 1..1 still gets 1.
    check("HELLO 1..2 chooses version 2", Peer(addr, version=2).info["version"] == 2)
    check("HELLO 1..1 chooses version 1", Peer(addr).info["version"] == 1)

    # 1. Byte for byte against the inline stream, small slots (many laps).
    p = shm_peer(addr, slots=4, slot_bytes=64 << 10)
    check("ring attached: the daemon maps the memfd", ring_maps(pid) == 1)
    inline = Peer(addr)
    for kw in (dict(kind="sobol", dims=32, count=20000, start=100),
               dict(kind="sobol", dims=5, scramble="owen", seed=9, count=30001, fmt="f32"),
               dict(kind="halton", dims=6, scramble="owen", seed=5, count=9999),
               dict(kind="sobol", dims=21, scramble="fast-owen", seed=7, count=25003, fmt="u32"),
               dict(kind="random", dims=3, seed=5, count=40000, fmt="u32"),
               dict(kind="sobol", dims=2, count=1)):
        a, _ = inline.points(**kw)
        b, end, chunks = p.points_shm(**kw)
        check("shm == inline, %s d=%d %s x%d (%d chunks)" % (kw["kind"], kw["dims"],
              kw.get("fmt", "f64"), kw["count"], chunks), a == b and len(a) == end["bytes"],
              "%d vs %d bytes" % (len(a), len(b)))
    # A point larger than a slot; POINTS transport 1 interleaved with inline.
    try:
        p.points_shm(kind="sobol", dims=21201, count=3)
        check("a point larger than a slot is refused", False, "no ERROR")
    except PeerError as e:
        check("a point larger than a slot: ERROR ETOOBIG", e.code == QMC_ETOOBIG, e.message)
    a, _ = p.points(kind="sobol", dims=4, count=5000)
    b, _, _ = p.points_shm(kind="sobol", dims=4, count=5000)
    check("inline and shm streams on one ringed connection agree", a == b)
    fd, m = make_ring(4, 64 << 10)
    refused(p, fd, 4, 64 << 10, "a second ring", QMC_EINVAL, "already attached")
    os.close(fd)
    check("connection usable after the refusal", p.ping())
    p.close()
    inline.close()

    # 2. The memfd rules: each refusal leaves the connection usable.
    q = Peer(addr, version=2)
    fd, m = make_ring(2, 64 << 10, seal=False)
    refused(q, fd, 2, 64 << 10, "unsealed", QMC_EINVAL, "F_SEAL_SHRINK")
    os.close(fd)
    fd, m = make_ring(2, 64 << 10, size=(64 << 10) + 4096)
    refused(q, fd, 2, 64 << 10, "too small", QMC_EINVAL, "less than")
    os.close(fd)
    fd, m = make_ring(2, 64 << 10, populate=False)
    refused(q, fd, 2, 64 << 10, "unpopulated", QMC_EINVAL, "not populated")
    os.close(fd)
    refused(q, None, 2, 64 << 10, "without a descriptor", QMC_EINVAL, "without a file descriptor")
    rd, wr = os.pipe()
    refused(q, rd, 2, 64 << 10, "a pipe", QMC_EINVAL, "not a memfd")
    os.close(rd)
    os.close(wr)
    q.send(q.points_frame(q.rid(), transport=1))
    t, r, d = q.recv()
    check("POINTS transport 1 without a ring: ERROR EINVAL",
          t == "ERROR" and d["code"] == QMC_EINVAL and "SHM_ATTACH" in d["message"], repr(d))
    check("connection usable after the refusals", q.ping())
    q.close()

    # 3. A descriptor with any other frame is closed, and so is the connection.
    other = Peer(addr)
    before = fd_count(pid)
    for i in range(5):
        x = Peer(addr, version=2)
        fd, m = make_ring(2, 64 << 10)
        socket.send_fds(x.s, [x.ping_frame(x.rid())], [fd])
        os.close(fd)
        errs = expect_closed(x, "fd with PING")
        if i == 0:
            check("a descriptor with a PING: ERROR EPROTO then close",
                  len(errs) == 1 and errs[0]["code"] == QMC_EPROTO, repr(errs))
        x.close()
    x = Peer(addr, version=2)
    fd, m = make_ring(2, 64 << 10)
    fd2, m2 = make_ring(2, 64 << 10)
    data = frame(MSG["SHM_ATTACH"], x.rid(), struct.pack("<II8x", 2, 64 << 10))
    socket.send_fds(x.s, [data], [fd, fd2])
    errs = expect_closed(x, "two fds")
    check("two descriptors at once: ERROR EPROTO then close",
          len(errs) == 1 and errs[0]["code"] == QMC_EPROTO, repr(errs))
    for f in (fd, fd2):
        os.close(f)
    x.close()
    # The daemon closes its side of those connections when it sees our
    # close: wait for that state (a deadline bounds only a hang).
    settle(lambda: fd_count(pid) <= before and ring_maps(pid) == 0)
    after = fd_count(pid)
    check("descriptors passed with the wrong frame are closed (daemon fds %d -> %d)"
          % (before, after), after <= before)
    check("no ring mapped after those connections", ring_maps(pid) == 0)
    check("other clients served meanwhile", other.ping())

    # 4. Releasing more than held: ERROR EPROTO and close; others served.
    x = shm_peer(addr, slots=2, slot_bytes=64 << 10)
    x.points_shm(kind="sobol", dims=8, count=100)  # held slots released
    x.release(1)
    errs = expect_closed(x, "over-release")
    check("SHM_RELEASE of more slots than held: ERROR EPROTO then close",
          len(errs) == 1 and errs[0]["code"] == QMC_EPROTO and "holds" in errs[0]["message"],
          repr(errs))
    x.close()
    x = shm_peer(addr, slots=2, slot_bytes=64 << 10)
    x.points_shm(kind="sobol", dims=8, count=1000, release=False)
    x.release(1, rid=77)
    errs = expect_closed(x, "release with an id")
    check("SHM_RELEASE with a request id: ERROR EPROTO then close",
          len(errs) == 1 and errs[0]["code"] == QMC_EPROTO, repr(errs))
    x.close()
    check("other clients served after the violations", other.ping())

    # 5. A client that never releases stalls only its ring streams.
    base = vmrss_kb(pid)
    stuck = shm_peer(addr, slots=4, slot_bytes=64 << 10)
    got = stuck.points_shm(kind="sobol", dims=16, count=1 << 24, release=False,
                           max_chunks=4)[2]
    stuck.s.settimeout(0.5)
    try:
        more = stuck.recv()
    except socket.timeout:
        more = None
    check("a client that never releases gets one ring's worth (%d chunks), then nothing"
          % got, got == 4 and more is None, repr(more))
    stuck.s.settimeout(15.0)
    check("its other requests are still answered", stuck.ping())
    # Meanwhile another ring client streams (the daemon's memory stays
    # flat: nothing piles up for the stalled one), and an inline one too.
    peak, rounds, want = base, 0, 20
    y = shm_peer(addr, slots=4, slot_bytes=64 << 10)
    for i in range(want):
        a, _, _ = y.points_shm(kind="sobol", dims=4, count=20000, start=i)
        rounds += other.ping() and len(a) == 20000 * 4 * 8
        peak = max(peak, vmrss_kb(pid))
    b, _ = other.points(kind="sobol", dims=4, count=20000, start=want - 1)
    check("others served while it stalls (%d of %d rounds)" % (rounds, want),
          rounds == want and a == b)
    check("daemon VmRSS flat while it stalls (%d kB -> peak %d kB, limit +%d kB)"
          % (base, peak, limit), peak - base < limit)
    # Releasing lets it go on: the next chunk lands in slot 0 again.
    stuck.release()
    t, r, d = stuck.recv()
    check("after SHM_RELEASE the stalled stream goes on",
          t == "POINTS_SHM_CHUNK" and d["slot"] == 0 and d["first"] == 4 * 512, repr(d))
    stuck.close()
    y.close()

    # 6. TCP: ENOTSUP (no descriptor can travel there).
    t = Peer(tcp_addr, version=2)
    tt, r, d = t.attach(None, 2, 64 << 10)
    check("SHM_ATTACH over TCP: ERROR ENOTSUP", tt == "ERROR" and d["code"] == QMC_ENOTSUP,
          repr(d))
    t.send(t.points_frame(t.rid(), transport=1))
    tt, r, d = t.recv()
    check("POINTS transport 1 over TCP: ERROR ENOTSUP",
          tt == "ERROR" and d["code"] == QMC_ENOTSUP, repr(d))
    check("TCP connection usable", t.ping())
    t.close()
    other.close()
    settle(lambda: fd_count(pid) <= fds0 and ring_maps(pid) == 0)
    check("no descriptor left behind (daemon fds %d -> %d), no ring mapped"
          % (fds0, fd_count(pid)), fd_count(pid) <= fds0 and ring_maps(pid) == 0)


def sc_shm_limits(addr, limit):
    """max-shm-bytes, and write-timeout-ms for a ring nobody releases."""
    limit = int(limit)
    p = Peer(addr, version=2)
    slot = 1 << 20
    n = max(2, limit // slot + 1)
    fd, m = make_ring(n, slot)
    refused(p, fd, n, slot, "over max-shm-bytes", QMC_ETOOBIG, "max-shm-bytes")
    os.close(fd)
    p.close()
    # 60 s: only a hang guard; the daemon closes it after write-timeout-ms (1 s)
    stuck = shm_peer(addr, slots=2, slot_bytes=64 << 10, timeout=60.0)
    stuck.points_shm(kind="sobol", dims=16, count=1 << 20, release=False, max_chunks=2)
    t0 = time.time()
    errs = expect_closed(stuck, "ring stall")
    check("every slot held past write-timeout-ms: ERROR ETIMEDOUT then close (%.1f s)"
          % (time.time() - t0), len(errs) == 1 and errs[0]["code"] == ETIMEDOUT and
          "SHM_RELEASE" in errs[0]["message"], repr(errs))


SCENARIOS = dict(hello=sc_hello, points=sc_points, points_error=sc_points_error,
                 integrate=sc_integrate, pipeline=sc_pipeline, concurrent=sc_concurrent,
                 disconnect=sc_disconnect, noread=sc_noread, stall=sc_stall, cancel=sc_cancel,
                 timeout=sc_timeout, sigterm_jobs=sc_jobs_for_sigterm, reload=sc_reload,
                 malformed=sc_malformed, partial=sc_partial, maxconn=sc_maxconn,
                 stats=sc_stats, ping=sc_ping, shm=sc_shm, shm_limits=sc_shm_limits,
                 laggard=sc_laggard,
                 flags_compat=sc_flags_compat)


def main(argv, scenarios=None, prog="qmcpeer.py"):
    """Runs scenario argv[1] with the rest of argv; other peers (cancelpeer.py)
    pass their own scenarios and share the checks."""
    scenarios = SCENARIOS if scenarios is None else scenarios
    if len(argv) < 3 or argv[1] not in scenarios:
        sys.stderr.write("usage: %s {%s} ADDR [ARGS...]\n" % (prog, ",".join(scenarios)))
        return 2
    try:
        scenarios[argv[1]](*argv[2:])
    except Exception as e:  # one line, counted as a failure
        check(argv[1], False, "%s: %s" % (type(e).__name__, e))
    return 1 if FAILED else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
