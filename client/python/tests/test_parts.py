"""Part sessions from Python (protocol version 6, PROTOCOL.md section
6.22): client.integrate(f, ..., part=(k, p)) computes part k of p of a
fixed-n sampling job on the daemon, and its --part file is the one `qmc
integrate --command PROGRAM --part k/p` writes in-process for a PROGRAM
computing f (cmdprog.py) - byte for byte but for the wall time (the
`seconds` line and the digest over it), as test_session_parts.sh compares
the CLI's own files - over the ring and inline; `qmc merge` of the
Python-written parts (which checks every digest) equals the whole run's
report but for seconds; the hex floats are glibc's printf("%a"), checked
against libc itself; a fake server's part frames out of order, past the
part or missing are a ProtocolError; a version-5 server is refused before
anything is sent."""
import ctypes
import ctypes.util
import json
import os
import random
import shlex
import struct
import sys
import unittest

import numpy as np

import support
import qmcd
from qmcd import errors, parts, wire
from test_hostile import Fake, read_frame, hello_ok, T
from pinproxy import CutProxy
import integrands

HERE = os.path.dirname(os.path.abspath(__file__))


def setUpModule():
    global plain
    plain = support.daemon("plain")


def timeless(raw):
    """A part file without its wall time: the seconds and digest lines."""
    return b"".join(line for line in raw.splitlines(True)
                    if not line.startswith((b"seconds ", b"digest sha256 ")))


def command(name):
    return " ".join(shlex.quote(w) for w in (sys.executable, os.path.join(HERE, "cmdprog.py"),
                                             name))


# Each: the integrands.FUNCS name, its smoothness, P, the options.
CASES = [
    ("gaussian", "analytic", 3, dict(method="rqmc", n=8192, reps=4, seed=7)),
    ("gaussian", "continuous", 4, dict(method="rqmc", n=4096, reps=6, seed=2, scramble="shift")),
    ("gaussian", "analytic", 3, dict(method="mc", n=40000, seed=3)),
    ("discontinuous", "discontinuous", 3, dict(method="stratified", n=27000, seed=4)),
    ("gaussian", "analytic", 2, dict(method="lhs", n=20000, reps=2, seed=6)),
    ("gaussian", "analytic", 3, dict(method="qmc", n=16384)),
]


class SameFileAsTheCLI(unittest.TestCase):
    maxDiff = None

    def test_parts_equal_the_clis_and_merge_into_the_whole_run(self):
        scratch = support.scratch()
        with qmcd.connect(plain.unix) as u, qmcd.connect(plain.tcp) as t:
            for i, (name, smooth, P, opts) in enumerate(CASES):
                with self.subTest(f=name, opts=opts):
                    self.one(u if i % 2 == 0 else t, scratch, i, name, smooth, P, opts)
            self.assertIn("shared memory", repr(u))

    def one(self, c, scratch, i, name, smooth, P, opts):
        dims, f = integrands.FUNCS[name]
        cmd = command(name)
        files = []
        for k in range(1, P + 1):
            p = c.integrate(f, dims, smoothness=smooth, name=cmd, part=(k, P), **opts)
            self.assertIsInstance(p, qmcd.PartResult)
            self.assertEqual((p.part_k, p.part_p, len(p.sums)), (k, P, p.count))
            # The CLI's words for the same job; it writes --command-format
            # among them, so this file carries it too.
            args = p.args + ["--command-format", "f64"]
            cli = support.qmc("integrate", *args, "--part", "%d/%d" % (k, P))
            mine = p.data(args)
            self.assertIn(b"\nsums ", mine)
            self.assertEqual(timeless(mine), timeless(cli), "part %d/%d" % (k, P))
            path = os.path.join(scratch, "part%d.%d" % (i, k))
            with open(path, "wb") as fh:
                p.write(fh, args)
            files.append(path)
        whole = json.loads(support.qmc("integrate", *args, "--json"))
        merged = json.loads(support.qmc("merge", "--json", *reversed(files)))
        for r in (whole, merged):
            r.pop("seconds")
        self.assertEqual(merged, whole)

    def test_an_empty_part(self):
        # 2 blocks in 3 parts: part 1 is [0, 0), no sums, the same file.
        dims, f = integrands.FUNCS["gaussian"]
        with qmcd.connect(plain.unix) as c:
            p = c.integrate(f, dims, name=command("gaussian"), method="rqmc", n=4096, reps=2,
                            seed=1, part=(1, 3))
        self.assertEqual((p.first, p.count, len(p.sums), p.blocks), (0, 0, 0, 2))
        args = p.args + ["--command-format", "f64"]
        cli = support.qmc("integrate", *args, "--part", "1/3")
        self.assertNotIn(b"\nsums ", cli)
        self.assertEqual(timeless(p.data(args)), timeless(cli))

    def test_refusals(self):
        dims, f = integrands.FUNCS["gaussian"]
        with qmcd.connect(plain.unix) as c:
            for bad in ((0, 3), (4, 3), (1,), "1/3"):
                with self.subTest(bad), self.assertRaises(ValueError):
                    c.integrate(f, dims, method="rqmc", part=bad)
            # A rule has no blocks: the daemon's reason.
            with self.assertRaises(qmcd.ServerError) as cm:
                c.integrate(f, dims, method="cubature", tol_rel=1e-3, part=(1, 2))
            self.assertEqual(cm.exception.code, errors.QMC_EINVAL)
            s = c.session(dims, method="qmc", n=64)
            while True:
                b = s.next()
                if b is None:
                    break
                s.tell(f(b.points))
            with self.assertRaisesRegex(qmcd.QmcdError, "not a part session"):
                s.part()
            self.assertGreaterEqual(c.ping(), 0)


class Resume(unittest.TestCase):
    def test_cut_while_the_sums_stream(self):
        """A part of 8192 blocks (5 MB of sums in five SESSION_PART_SUMS
        frames) on a daemon with a 2 MiB output buffer, so that it still
        owes sums, and the result, when the connection goes: the
        connection drops after the first frame; integrate() reconnects
        and resumes the finished session, which sends its sums again,
        whole - the same as an uncut run's - and f is not evaluated
        again."""
        small = support.daemon("small-out", "--out-buffer-bytes", "2097152")
        def f(x):
            calls.append(len(x))
            return x[:, 0]
        opts = dict(method="mc", n=32 << 20, seed=9, part=(1, 1))
        calls = []
        with qmcd.connect(small.unix) as c:
            want = c.integrate(f, 1, **opts)
        self.assertEqual((want.count, sum(calls)), (8192, (32 << 20) + 4))
        proxy = CutProxy(small.unix[5:], support.scratch(), after=1,
                         mtype=wire.SESSION_PART_SUMS)
        self.addCleanup(proxy.close)
        calls = []
        with qmcd.connect(proxy.endpoint) as c:
            got = c.integrate(f, 1, **opts)
        self.assertTrue(proxy.cut.is_set())
        self.assertEqual(sum(calls), (32 << 20) + 4)
        self.assertEqual((got.fingerprint, got.blocks, got.first, got.count),
                         (want.fingerprint, want.blocks, want.first, want.count))
        self.assertEqual(got.sums.tobytes(), want.sums.tobytes())
        self.assertEqual(timeless(got.data()), timeless(want.data()))


class HexFloats(unittest.TestCase):
    def test_glibc_printf_a(self):
        """parts.hex_float against libc's own snprintf("%a")."""
        libc = ctypes.CDLL(ctypes.util.find_library("c"))
        buf = ctypes.create_string_buffer(64)

        def c_a(v):
            libc.snprintf(buf, 64, b"%a", ctypes.c_double(v))
            return buf.value.decode()
        rng = random.Random(5)
        vals = [0.0, -0.0, 1.0, -1.5, 0.1, 7.0 / 4096, 1e308 * 10, -1e308 * 10,
                float("nan"), -float("nan"), 5e-324, 2.2250738585072014e-308,
                2.225073858507201e-308, 1.7976931348623157e308, 2.0 ** -1074 * 3]
        vals += [struct.unpack("<d", struct.pack("<Q", rng.getrandbits(64)))[0]
                 for _ in range(3000)]
        vals += [struct.unpack("<d", struct.pack("<Q", rng.getrandbits(52)))[0]
                 for _ in range(300)]  # subnormals
        for v in vals:
            self.assertEqual(parts.hex_float(v), c_a(v), repr(v))
            if v == v:
                self.assertEqual(float.fromhex(parts.hex_float(v)), v)


def part_server(frames_after_report, early=b""):
    """A fake version-6 server: one batch of 4 points (the probes) and the
    frames early(rid) makes, then after its values a report,
    frames_after_report(rid) and a result."""
    def script(f, s):
        t, rid, _ = read_frame(s)
        s.sendall(hello_ok(rid, version=6))
        t, rid, p = read_frame(s)
        f.seen.append(wire.decode_payload(t, p))
        data = bytes(8 * 4 * 2)
        s.sendall(wire.encode(wire.SESSION_OPENED, rid, {
            "session_id": 9, "token": bytes(32), "dims": 2, "max_batch": 100,
            "memory_bytes": 1, "park_ms": 1}) + wire.encode(wire.SESSION_BATCH, rid, dict(
                seq=0, count=4, first=0, points=4, dims=2, transport="inline", slot=0,
                data_len=len(data), data=data)) + (early(rid) if early else b""))
        fr = read_frame(s)
        if fr is None or fr[0] != wire.SESSION_VALUES:
            return
        s.sendall(wire.encode(wire.SESSION_REPORT, rid, dict(
            session_id=9, batches=1, evals=4, nonfinite=0, end="complete", has_estimate=False,
            error_kind="none", flags=0, err=0, dims=0, res_n=0, res_evals=0, res_nonfinite=0,
            estimate=0.0, error=0.0, ci_low=0.0, ci_high=0.0, abs_integral=0.0)))
        s.sendall(frames_after_report(rid))
        res = dict(RESULT)
        s.sendall(wire.encode(wire.SESSION_RESULT, rid, res))
        read_frame(s)
    return script


SAMPLING = dict(sampler="rqmc", seq="sobol", scramble="owen", seq_flags=0, seed=7, n=4096,
                confidence=0.95, reps=16, split_net=False)
RESULT = dict(job_id=9, method_used="auto", error_kind="none", reference_kind="none",
              cv_used=False, dims=0, flags=0, n=0, evals=0, nonfinite=0, estimate=0.0,
              error=0.0, ci_low=0.0, ci_high=0.0, abs_integral=0.0, cv_beta=0.0,
              cv_variance_ratio=0.0, seconds=0.0, reference=0.0,
              sampling=dict(SAMPLING, sampler="mc", seq="none", scramble="none", seed=0, n=0,
                            confidence=0.0, reps=0),
              detail="", auto_reason="", has_known_abs=False, known_abs=0.0)


def head(rid, k=2, p=3, sid=9):
    first, count = wire.part_range(16, k, p)
    return wire.encode(wire.SESSION_PART, rid, dict(
        session_id=sid, fingerprint=0x1234, blocks=16, first=first, count=count, part_k=k,
        part_p=p, sampling=SAMPLING))


def sums(rid, first, n, sid=9):
    r = np.zeros(n, dtype=wire.PART_RECORD)
    r["count"] = 4096
    r["f"][:, 0] = np.arange(n) + 1.0
    return wire.encode(wire.SESSION_PART_SUMS, rid, dict(session_id=sid, first=first, n=n,
                                                         records=r.tobytes()))


class Hostile(unittest.TestCase):
    def run_part(self, frames, early=None):
        f = Fake(part_server(frames, early))
        self.addCleanup(f.close)
        with qmcd.connect(f.endpoint, timeout=T, shm=False) as c:
            return c.integrate(lambda x: x[:, 0], 2, method="rqmc", n=4096, reps=16, seed=7,
                               scramble="owen", part=(2, 3), retries=0), f

    def test_a_good_part(self):
        p, f = self.run_part(lambda rid: head(rid) + sums(rid, 5, 2) + sums(rid, 7, 3))
        self.assertEqual((f.seen[0]["part_k"], f.seen[0]["part_p"], f.seen[0]["name"]),
                         (2, 3, "command"))
        self.assertEqual((p.first, p.count, p.fingerprint), (5, 5, 0x1234))
        self.assertEqual(p.sums["f"][:, 0].tolist(), [1.0, 2.0, 1.0, 2.0, 3.0])
        self.assertIn(b"\nsums 9 4096 0 0x1.8p+1 ", p.data())

    def test_broken_parts(self):
        cases = [
            (lambda rid: head(rid) + sums(rid, 6, 2), "out of order"),
            (lambda rid: head(rid) + sums(rid, 5, 6), "past the part's blocks"),
            (lambda rid: head(rid) + sums(rid, 5, 2), "after 2 of the part's 5 block sums"),
            (lambda rid: sums(rid, 5, 5), "block sums before SESSION_PART"),
            (lambda rid: head(rid, k=1), "another part than the one opened"),
            (lambda rid: head(rid) + head(rid), "SESSION_PART again"),
            (lambda rid: head(rid, sid=8), "for another session"),
            (lambda rid: b"", "without its block sums"),
        ]
        for frames, why in cases:
            with self.subTest(why), self.assertRaisesRegex(qmcd.ProtocolError, why):
                self.run_part(frames)
        # Sums while the batch waits for its values.
        with self.assertRaisesRegex(qmcd.ProtocolError, "a part's sums while the session runs"):
            self.run_part(lambda rid: b"", early=head)

    def test_version_5_server(self):
        def script(f, s):
            t, rid, _ = read_frame(s)
            s.sendall(hello_ok(rid, version=5))
            f.seen.append(read_frame(s))
        f = Fake(script)
        self.addCleanup(f.close)
        with qmcd.connect(f.endpoint, timeout=T) as c, self.assertRaises(qmcd.QmcdError) as cm:
            c.integrate(lambda x: x[:, 0], 2, method="rqmc", part=(1, 2))
        self.assertEqual(cm.exception.code, errors.QMC_ENOTSUP)
        self.assertIn("protocol version 5", str(cm.exception))
        f.close()
        self.assertEqual(f.seen, [None])  # nothing was sent after the handshake


if __name__ == "__main__":
    unittest.main()
