"""Integration sessions (protocol version 5) from Python: a function
written here in numpy, computing the same values as a built-in integrand
of libqmc (the same IEEE operations in the same order, libm's exp, pow and
through Python's math), gives `qmc integrate`'s result for that integrand
bit for bit - the daemon's promise that a session equals INTEGRATE,
checked from the outside - over the ring and inline, at small batches;
its report is the line `qmc integrate --command PROGRAM --json` prints
for a program computing the same function (cmdprog.py), byte for byte
but for the clock, against the daemon and in-process, for sampling
methods, auto and rules, a singular and a NaN-valued function among them;
a dropped connection is resumed with the batch's values sent again, not
recomputed; a ticket resumes from another client; NaN values are counted
and flagged; close() ends it; a fake server's broken session frames and
refusals are met with clear exceptions; a version-4 server is refused
before anything is sent."""
import json
import os
import shlex
import sys
import unittest

import numpy as np

import support
from support import pin_seconds
import qmcd
from qmcd import wire, errors
from pinproxy import CutProxy
from test_hostile import Fake, read_frame, hello_ok, T
import integrands
from integrands import gaussian, continuous, corner, discontinuous, poly


def setUpModule():
    global plain
    plain = support.daemon("plain")


# Each: CLI options naming a built-in integrand, its smoothness, and the
# same function in numpy.
A3, U3 = integrands.A3, integrands.U3
CASES = [
    ("genz-gaussian", 3, "--a 1.5,2,2.5 --u 0.5,0.3,0.7", "analytic", gaussian(A3, U3)),
    ("genz-continuous", 3, "--a 1.5,2,2.5 --u 0.5,0.3,0.7", "continuous",
     continuous(A3, U3)),
    ("genz-corner-peak", 4, "--a 0.5,0.25,0.125,1 --u 0.1,0.2,0.3,0.4", "analytic",
     corner([0.5, 0.25, 0.125, 1.0])),
    ("genz-discontinuous", 3, "--a 1.5,2,2.5 --u 0.5,0.3,0.7", "discontinuous",
     discontinuous(A3, U3)),
    ("poly", 1, "--a 1,-2,3,0.5", "analytic", poly([1.0, -2.0, 3.0, 0.5])),
]
METHODS = ["rqmc --n 4096", "mc --n 8192 --seed 3", "qmc --n 1000", "stratified", "lhs --n 500",
           "auto --tol-rel 1e-6", "cubature --tol-rel 1e-5", "gauss-legendre --n 9",
           "rqmc --tol-rel 1e-5 --reps 8", "rqmc --n 4096 --split-net --scramble fast-owen"]
ONE_D = ["gauss-kronrod", "simpson --n 33", "clenshaw-curtis --tol-rel 1e-9"]
KEYS = ["method_used", "detail", "auto_reason", "estimate", "stderr", "error_estimate",
        "ci_low", "ci_high", "n", "evals", "dims", "nonfinite", "flags"]


def options(words):
    """Keyword arguments for `qmc integrate` method options."""
    w = words.split()
    kw = {"method": w[0]}
    i = 1
    while i < len(w):
        k = w[i][2:].replace("-", "_")
        if k == "split_net":
            kw[k] = True
            i += 1
            continue
        v = w[i + 1]
        kw[k] = float(v) if k.startswith("tol") else (v if k == "scramble" else int(v))
        i += 2
    return kw


def cli(name, dims, params, method):
    out = support.qmc("integrate", "--integrand", name, "--dims", dims, "--json",
                      *(params.split() + ["--method"] + method.split()))
    return json.loads(out)


class SameAsBuiltIn(unittest.TestCase):
    def check(self, c, name, dims, params, smooth, f, method, **extra):
        want = cli(name, dims, params, method)
        r = c.integrate(f, dims, smoothness=smooth, name=name[:31], **options(method), **extra)
        got = json.loads(r.json())
        bad = [(k, got.get(k), want.get(k)) for k in KEYS if got.get(k) != want.get(k)]
        self.assertEqual(bad, [], "%s %s via %s" % (name, method, c.endpoint))
        self.assertEqual(got["integrand"], name[:31])
        self.assertEqual(r.report.end in ("complete", "converged", "budget", "cannot_tell"),
                         True)
        self.assertEqual(r.report.evals, r.evals)
        return r

    def test_every_method_over_the_ring_and_inline(self):
        with qmcd.connect(plain.unix) as u, qmcd.connect(plain.tcp) as t:
            for name, dims, params, smooth, f in CASES:
                methods = METHODS if dims > 1 else ONE_D + METHODS[:3]
                for method in methods:
                    for c in (u, t):
                        with self.subTest(name=name, method=method, via=c.endpoint):
                            self.check(c, name, dims, params, smooth, f, method)
            self.assertIn("shared memory", repr(u))
            self.assertGreaterEqual(u.stats()["requests_SESSION_OPEN"], 1)

    def test_small_batches_and_a_small_ring(self):
        name, dims, params, smooth, f = CASES[0]
        # Batches of 256-point engine chunks; and batches bigger than a slot
        # of a ring attached before (8 x 64 KiB): they come in pieces.
        with qmcd.connect(plain.unix) as c:
            for mb in (100, 1000, 5000):
                with self.subTest(max_batch=mb):
                    self.check(c, name, dims, params, smooth, f, "rqmc --n 4096", max_batch=mb)
        with qmcd.connect(plain.unix) as c:
            c.attach_shm(8, 64 << 10)
            self.check(c, name, dims, params, smooth, f, "rqmc --n 4096", max_batch=20000)
            self.check(c, name, dims, params, smooth, f, "mc --n 8192 --seed 3")


# The CLI's words for the smoothness a caller declares.
CLI_SMOOTHNESS = {"analytic": "smooth", "continuous": "kinks", "discontinuous": "jumps",
                  "singular": "singular"}
# Each: an integrands.FUNCS name, its smoothness, the method options, and
# the built-in integrand computing the same function (name and options),
# whose exact value the caller then declares; None: no built-in twin, and
# nothing declared.
SAME_BYTES = [
    ("gaussian", "analytic", "rqmc --n 4096", ("genz-gaussian", "--a 1.5,2,2.5 --u 0.5,0.3,0.7")),
    ("gaussian", "continuous", "mc --n 8192 --seed 3", None),
    ("gaussian", "analytic", "auto --tol-rel 1e-6",
     ("genz-gaussian", "--a 1.5,2,2.5 --u 0.5,0.3,0.7")),
    ("gaussian", "continuous", "auto --tol-rel 1e-4", None),  # the twin is declared smooth
    ("gaussian", "analytic", "cubature --tol-rel 1e-5",
     ("genz-gaussian", "--a 1.5,2,2.5 --u 0.5,0.3,0.7")),
    ("discontinuous", "discontinuous", "rqmc --n 2048 --reps 8",
     ("genz-discontinuous", "--a 1.5,2,2.5 --u 0.5,0.3,0.7")),
    ("poly", "analytic", "gauss-kronrod", ("poly", "--a 1,-2,3,0.5")),
    ("poly", "analytic", "clenshaw-curtis --tol-rel 1e-9", None),
    # An integrable singularity: mc is flagged (heavy tails); auto takes
    # Gauss-Kronrod, whose converged bar a second run confirms.  NaN and
    # infinite values are counted, left out and flagged.
    ("inv-sqrt", "singular", "mc --n 100000", ("inv-sqrt", "")),
    ("inv-sqrt", "singular", "auto --tol-rel 1e-3", ("inv-sqrt", "")),
    ("nonfinite", "continuous", "mc --n 8192 --seed 1", None),
]
# What a built-in job knows that a session cannot: the integral of |f| in
# closed form (a session's report judges errors against its estimate of
# it); and the seconds of any run are its own.
ONLY_BUILT_IN = ("abs_integral", "error_vs_abs_integral")


def fields(line):
    """[(key, value as printed)] of a report line, in order."""
    return json.loads(line, object_pairs_hook=list, parse_float=str, parse_int=str,
                      parse_constant=str)


class SameBytesAsTheCommandPath(unittest.TestCase):
    maxDiff = None
    """client.integrate(f) prints what `qmc integrate --command PROGRAM
    --json` prints for a PROGRAM computing f (cmdprog.py), byte for byte
    but for the clock: the CLI on the same daemon, and the CLI in-process
    (no daemon: an oracle the daemon does not make); and, where f is a
    built-in integrand, the built-in job's line but for the integral of
    |f| only the built-in knows in closed form."""

    def test_sessions_print_the_clis_bytes(self):
        prog = os.path.join(os.path.dirname(os.path.abspath(__file__)), "cmdprog.py")
        with qmcd.connect(plain.unix) as u, qmcd.connect(plain.tcp) as t:
            for name, smooth, method, twin in SAME_BYTES:
                with self.subTest(f=name, method=method):
                    self.one(u, t, prog, name, smooth, method, twin)

    def one(self, u, t, prog, name, smooth, method, twin):
        dims, f = integrands.FUNCS[name]
        exact = None
        if twin is not None:
            built = support.qmc("integrate", "--integrand", twin[0], "--dims", dims, "--json",
                                *(twin[1].split() + ["--method"] + method.split()))
            exact = json.loads(built)["exact"]
        cmd = " ".join(shlex.quote(w) for w in (sys.executable, prog, name))
        args = ["integrate", "--command", cmd, "--command-format", "f64", "--dims", dims,
                "--smoothness", CLI_SMOOTHNESS[smooth], "--json", "--method"] + method.split()
        if exact is not None:
            args += ["--exact", repr(exact)]
        remote = support.qmc(*args, "--connect", plain.unix)
        local = support.qmc(*args)
        self.assertEqual(pin_seconds(remote), pin_seconds(local))
        for c in (u, t):
            r = c.integrate(f, dims, smoothness=smooth, name=cmd, exact=exact,
                            **options(method))
            line = (r.json() + "\n").encode()
            self.assertEqual(pin_seconds(line), pin_seconds(remote), c.endpoint)
            # seconds is the caller's wall time, the daemon's compute in it.
            self.assertGreaterEqual(r.seconds, r.server_seconds)
        got = fields(line)
        if name == "inv-sqrt" and method.startswith("mc"):
            self.assertIn("heavy_tail", r.flags)
        if name == "nonfinite":
            self.assertGreater(r.nonfinite, 0)
            self.assertEqual(r.flags[:1], ("nonfinite",))
        if twin is None:
            return
        # The built-in job's line: the same keys in the same order, the
        # same bytes but for the closed form of the integral of |f|.
        r = u.integrate(f, dims, smoothness=smooth, name=twin[0], exact=exact,
                        **options(method))
        got = fields(r.json())
        want = fields(built)
        self.assertEqual([k for k, _ in got], [k for k, _ in want])
        skip = ONLY_BUILT_IN + ("seconds",)
        self.assertEqual([kv for kv in got if kv[0] not in skip],
                         [kv for kv in want if kv[0] not in skip])


class Lifecycle(unittest.TestCase):
    def test_resume_after_the_connection_drops(self):
        name, dims, params, smooth, f = CASES[0]
        want = cli(name, dims, params, "rqmc --tol-rel 1e-7 --reps 8")
        proxy = CutProxy(plain.unix[5:], support.scratch(), after=3)
        self.addCleanup(proxy.close)
        calls = []

        def counting(x):
            calls.append(len(x))
            return f(x)
        with qmcd.connect(proxy.endpoint) as c:
            r = c.integrate(counting, dims, smoothness=smooth, max_batch=4096,
                            **options("rqmc --tol-rel 1e-7 --reps 8"))
        self.assertTrue(proxy.cut.is_set())
        got = json.loads(r.json())
        self.assertEqual([(k, got.get(k)) for k in KEYS], [(k, want.get(k)) for k in KEYS])
        # Every batch was evaluated once: the one waiting when the
        # connection dropped was served again and its values sent again.
        self.assertEqual(sum(calls), r.evals)
        self.assertGreater(r.report.batches, 3)

    def test_ticket_resumes_on_another_connection(self):
        name, dims, params, smooth, f = CASES[1]
        want = cli(name, dims, params, "rqmc --n 4096")
        a = qmcd.connect(plain.unix)
        s = a.session(dims, smoothness=smooth, max_batch=4096, **options("rqmc --n 4096"))
        b1 = s.next()
        first = b1.points.copy()
        s.tell(f(b1.points))
        b2 = s.next()
        seq = b2.seq
        ticket = s.ticket
        a.close()  # dropped with batch 2 waiting: the session is parked
        with qmcd.connect(plain.unix) as c:
            s = c.resume(ticket)
            b = s.next()
            self.assertEqual(b.seq, seq)  # the batch it waited for, served again
            self.assertFalse(np.array_equal(b.points, first))
            while b is not None:
                s.tell(f(b.points))
                b = s.next()
            r = s.result()
            self.assertEqual([r.estimate, r.error, r.evals],
                             [want["estimate"], want["stderr"], want["evals"]])
        with qmcd.connect(plain.unix) as c, self.assertRaises(qmcd.ServerError) as cm:
            c.resume(ticket)  # ended: unknown from then on
        self.assertEqual(cm.exception.code, errors.ENOENT)
        with qmcd.connect(plain.unix) as c, self.assertRaises(qmcd.ServerError) as cm:
            c.resume((ticket[0], bytes(32)))
        self.assertEqual(cm.exception.code, errors.ENOENT)

    def test_nonfinite_values_are_counted_and_flagged(self):
        def f(x):
            v = x[:, 0] * 2.0
            v[::1000] = np.nan
            v[1::1000] = np.inf
            return v
        with qmcd.connect(plain.unix) as c:
            r = c.integrate(f, 2, method="mc", n=8192, seed=1)
        self.assertEqual(r.nonfinite, r.report.nonfinite)
        self.assertGreater(r.nonfinite, 0)
        self.assertIn("nonfinite", r.flags)
        self.assertIn("error_unreliable", r.flags)

    def test_close_and_local_checks(self):
        with qmcd.connect(plain.unix) as c:
            s = c.session(2, method="rqmc", n=4096)
            b = s.next()
            with self.assertRaises(qmcd.QmcdError) as cm:
                s.tell(np.zeros(b.count + 1))
            self.assertEqual(cm.exception.code, errors.QMC_EINVAL)
            rep = s.close()
            self.assertEqual(rep.end, "running")
            with self.assertRaises(qmcd.ServerError) as cm:
                s.result()
            self.assertEqual(cm.exception.code, errors.ECANCELED)
            with self.assertRaises(ValueError):
                c.session(2, smoothness="wobbly")
            with self.assertRaises(ValueError):
                c.session(0)
            with self.assertRaises(qmcd.ServerError) as cm:
                c.session(30000)
            self.assertEqual((cm.exception.code, cm.exception.message),
                             (errors.QMC_EDIMS, "a session needs dims in 1..21201, not 30000"))
            with self.assertRaisesRegex(ValueError, "returned 3 values"):
                c.integrate(lambda x: np.zeros(3), 2, method="qmc", n=64)
            self.assertGreaterEqual(c.ping(), 0)


class RingRelease(unittest.TestCase):
    """Batches of three of the ring's four slots, one after another: the
    daemon sends each batch right behind the report on the last, into the
    one slot free, and waits for the others.  The client must give the
    last batch's slots back at its report (once they are half the ring,
    libqmcclient's rule): had it waited until no whole frame is buffered,
    the next batch's first piece - already in its buffer - would pin the
    slots behind it, and the daemon would wait for a release that never
    comes until its write-timeout-ms (short here) cut the connection.  So
    the session must end on the connection it opened on, with nothing
    timed out on the daemon, and give the built-in job's bytes."""

    def test_batches_of_three_quarters_of_the_ring(self):
        d = support.daemon("short-write", "--write-timeout-ms", "2000")
        a, u = [1.5, 2.0, 2.5, 1.0], [0.5, 0.3, 0.7, 0.2]
        want = cli("genz-gaussian", 4, "--a 1.5,2,2.5,1 --u 0.5,0.3,0.7,0.2",
                   "rqmc --n 65536")
        reports = []
        with qmcd.connect(d.unix) as c:
            r = c.integrate(gaussian(a, u), 4, smoothness="analytic", name="genz-gaussian",
                            method="rqmc", n=65536, max_batch=262144, retries=0,
                            on_report=lambda rep: reports.append(rep.batches))
            ring = c._ring
            # Four slots of 4 MiB; a batch (262144 points and their
            # values, 10 MiB) takes three: two in flight exceed the ring.
            self.assertEqual((ring.slots, ring.slot_bytes), (4, 4 << 20))
            self.assertGreater(-(-262144 * 5 * 8 // ring.slot_bytes), ring.slots // 2)
            stats = c.stats()
        self.assertEqual(reports, [1, 2, 3, 4])  # 16 x 65536 points: four batches
        self.assertEqual(stats["connections_timed_out"], 0)
        got = json.loads(r.json())
        self.assertEqual([(k, got.get(k)) for k in KEYS], [(k, want.get(k)) for k in KEYS])


def session_server(batches, refuse_first=False):
    """A fake server: handshake at version 5, SESSION_OPENED for dims 2,
    then batches(rid) frames; with refuse_first, the first SESSION_VALUES
    is refused and the second answered with a report and a result."""
    def script(f, s):
        t, rid, _ = read_frame(s)
        s.sendall(hello_ok(rid, version=5))
        t, rid, p = read_frame(s)
        s.sendall(wire.encode(wire.SESSION_OPENED, rid, {
            "session_id": 9, "token": bytes(32), "dims": 2, "max_batch": 100,
            "memory_bytes": 1, "park_ms": 1}) + b"".join(fr(rid) for fr in batches))
        refused = not refuse_first
        while True:
            fr = read_frame(s)
            if fr is None:
                return
            if fr[0] == wire.SESSION_VALUES:
                if not refused:
                    refused = True
                    s.sendall(wire.encode(wire.ERROR, fr[1], {"code": errors.QMC_EINVAL,
                                                              "message": "not now"}))
                    continue
                s.sendall(wire.encode(wire.SESSION_REPORT, rid, dict(
                    session_id=9, batches=1, evals=1, nonfinite=0, end="complete",
                    has_estimate=True, error_kind="none", flags=0, err=0, dims=2, res_n=1,
                    res_evals=1, res_nonfinite=0, estimate=0.5, error=0.0, ci_low=0.5,
                    ci_high=0.5, abs_integral=0.5)))
                # Version 5's layout, as negotiated: no known integral of |f|.
                res = wire.decode_payload(wire.JOB_RESULT, wire.encode(
                    wire.JOB_RESULT, rid, RESULT, 5)[24:], 5)
                s.sendall(wire.encode(wire.SESSION_RESULT, rid, dict(res, job_id=9), 5))
    return script


RESULT = dict(job_id=9, method_used="qmc", error_kind="none", reference_kind="none",
              cv_used=False, dims=2, flags=0, n=1, evals=1, nonfinite=0, estimate=0.5,
              error=0.0, ci_low=0.5, ci_high=0.5, abs_integral=0.5, cv_beta=0.0,
              cv_variance_ratio=0.0, seconds=0.0, reference=0.0,
              sampling=dict(sampler="qmc", seq="sobol", scramble="none", seq_flags=0, seed=0,
                            n=1, confidence=0.95, reps=1, split_net=False),
              detail="fake", auto_reason="")


def batch(rid, seq=0, count=1, first=0, points=1, dims=2, data=None):
    data = data if data is not None else bytes(8 * points * dims)
    return wire.encode(wire.SESSION_BATCH, rid, dict(
        seq=seq, count=count, first=first, points=points, dims=dims, transport="inline",
        slot=0, data_len=len(data), data=data))


class Hostile(unittest.TestCase):
    def fake(self, script):
        f = Fake(script)
        self.addCleanup(f.close)
        return f

    def test_refusal_then_acceptance(self):
        f = self.fake(session_server([lambda rid: batch(rid)], refuse_first=True))
        with qmcd.connect(f.endpoint, timeout=T, shm=False) as c:
            s = c.session(2, method="qmc", n=1)
            b = s.next()
            with self.assertRaises(qmcd.ServerError) as cm:
                s.tell([1.0])
            self.assertEqual((cm.exception.code, cm.exception.message),
                             (errors.QMC_EINVAL, "not now"))
            s.tell([1.0])  # the batch still waited
            self.assertIsNone(s.next())
            self.assertEqual(s.result().detail, "fake")
            self.assertEqual(b.count, 1)

    def test_broken_batches(self):
        cases = [([lambda rid: batch(rid, dims=3, data=bytes(24))], "3 dims in a session of 2"),
                 ([lambda rid: batch(rid, seq=0), lambda rid: batch(rid, seq=5)],
                  "a batch while none was expected"),
                 ([lambda rid: batch(rid, count=200, points=1)], "larger than max_batch"),
                 ([lambda rid: batch(rid, count=2, first=0, points=1),
                   lambda rid: batch(rid, count=2, first=0, points=1)], "out of order"),
                 ([lambda rid: wire.header(wire.SESSION_BATCH, rid, 44 + 16) +
                   bytes(60)], "malformed SESSION_BATCH")]
        for frames, why in cases:
            with self.subTest(why):
                f = self.fake(session_server(frames))
                with self.assertRaisesRegex(qmcd.ProtocolError, why):
                    with qmcd.connect(f.endpoint, timeout=T, shm=False) as c:
                        s = c.session(2, method="qmc", n=1)
                        b = s.next()
                        s.tell(np.zeros(b.count))
                        s.next()

    def test_version_4_server(self):
        def script(f, s):
            t, rid, _ = read_frame(s)
            s.sendall(hello_ok(rid, version=4))
            f.seen.append(read_frame(s))
        f = self.fake(script)
        with qmcd.connect(f.endpoint, timeout=T) as c, self.assertRaises(qmcd.QmcdError) as cm:
            c.integrate(lambda x: x[:, 0], 2)
        self.assertEqual(cm.exception.code, errors.QMC_ENOTSUP)
        self.assertIn("protocol version 4", str(cm.exception))
        f.close()
        self.assertEqual(f.seen, [None])  # nothing was sent after the handshake


if __name__ == "__main__":
    unittest.main()
