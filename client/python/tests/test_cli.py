"""The Python client against the C path, byte for byte: points and pixel
tiles equal what `qmc points` / `qmc pixels` write in-process (no daemon:
an oracle the daemon does not produce) over a Unix socket with the ring,
over TCP inline, and from a daemon whose max-points cuts requests into
pieces and whose ring is off; jobs print the JSON `qmc integrate --json
--connect` prints, through a proxy that pins the one field that is not a
function of the request (the daemon's compute time) and checks that both
clients sent the same INTEGRATE bytes, and equal what `qmc integrate
--json` prints in-process; the known integral of |f| comes from the
daemon (protocol version 6) to both clients, and a version-5 daemon's
silence on it is met as documented.  The daemon's refusals arrive as
exceptions with its code and the CLI's own words."""
import json
import os
import unittest

import numpy as np

import support
import qmcd
from qmcd import errors
from pinproxy import PinProxy, PINNED_SECONDS

CUT_POINTS = 777  # the small daemon's max-points: requests come in pieces


def setUpModule():
    global plain, small
    plain = support.daemon("plain")
    small = support.daemon("small", "--max-points", str(CUT_POINTS), "--max-shm-bytes", "0")


def cli_points(kind, dims, count, start=0, scramble="none", seed=0, fmt="f64", shuffle=False):
    args = ["points", "--connect", "", "--seq", kind, "--dims", dims, "--count", count,
            "--start", start, "--scramble", scramble, "--seed", seed, "--format", fmt]
    return support.qmc(*(args + (["--shuffle"] if shuffle else [])))


class Points(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.clients = {"unix+ring": qmcd.connect(plain.unix), "tcp": qmcd.connect(plain.tcp),
                       "cut, no ring": qmcd.connect(small.unix)}

    @classmethod
    def tearDownClass(cls):
        for c in cls.clients.values():
            c.close()

    def same(self, want, **kw):
        for name, c in self.clients.items():
            with self.subTest(via=name, **kw):
                got = c.points(**kw)
                self.assertEqual(got.shape, (kw["count"], kw["dims"]))
                self.assertEqual(got.tobytes(), want)

    def test_every_kind_scramble_and_format(self):
        combos = [("sobol", s) for s in ("none", "shift", "owen", "fast-owen")] + \
                 [("halton", s) for s in ("none", "owen", "faure")] + \
                 [("hammersley", s) for s in ("none", "owen", "faure")] + \
                 [("random", "none"), ("lhs", "none")]
        for kind, scramble in combos:
            for fmt in ("f64", "f32", "u32"):
                want = cli_points(kind, 3, 1000, 0, scramble, 7, fmt)
                self.same(want, kind=kind, dims=3, count=1000, scramble=scramble, seed=7,
                          dtype=fmt)

    def test_start_shuffle_and_stratified(self):
        want = cli_points("sobol", 5, 3000, 123456, "owen", 99, "f64", shuffle=True)
        self.same(want, kind="sobol", dims=5, count=3000, start=123456, scramble="owen",
                  seed=99, shuffle=True)
        want = cli_points("stratified", 2, 1024, 0, "none", 5)
        self.same(want, kind="stratified", dims=2, count=1024, seed=5)

    def test_bulk_through_the_ring(self):
        want = cli_points("sobol", 32, 100000)
        c = self.clients["unix+ring"]
        got = c.points("sobol", 32, 100000)
        self.assertEqual(got.tobytes(), want)
        self.assertIn("shared memory", repr(c))
        self.assertGreaterEqual(c.stats()["requests_SHM_ATTACH"], 1)
        # numpy dtypes name the formats too, and out= fills in place.
        out = np.empty((100000, 32), dtype=np.float32)
        self.assertIs(c.points("sobol", 32, 100000, dtype=np.float32, out=out), out)
        self.assertEqual(out.tobytes(), cli_points("sobol", 32, 100000, fmt="f32"))

    def test_refusals_carry_the_code_and_the_cli_words(self):
        cases = [(dict(kind="stratified", dims=2, count=10), errors.QMC_ECOUNT,
                  ["--seq", "stratified", "--dims", 2, "--count", 10]),
                 (dict(kind="halton", dims=3, count=3, scramble="shift"), errors.QMC_ESCRAMBLE,
                  ["--seq", "halton", "--dims", 3, "--count", 3, "--scramble", "shift"]),
                 (dict(kind="halton", dims=5000, count=1), errors.QMC_EDIMS,
                  ["--seq", "halton", "--dims", 5000, "--count", 1]),
                 (dict(kind="sobol", dims=3, count=5, start=2**32 - 2), errors.QMC_ERANGE,
                  ["--seq", "sobol", "--dims", 3, "--count", 5, "--start", 2**32 - 2])]
        for kw, code, args in cases:
            with self.subTest(**kw):
                with self.assertRaises(qmcd.ServerError) as cm:
                    self.clients["unix+ring"].points(**kw)
                self.assertEqual(cm.exception.code, code)
                self.assertEqual(cm.exception.message, self.cli_error(args))
                self.assertGreaterEqual(self.clients["unix+ring"].ping(), 0)

    def cli_error(self, args):
        import subprocess
        p = subprocess.run([support.QMC, "points", "--connect", ""] + [str(a) for a in args],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=60)
        self.assertEqual(p.returncode, 2)
        return p.stderr.decode().strip().split("qmc: ", 1)[1]


def cli_pixels(sampler, res, spp, dims, tile, samples, seed, frame, fmt):
    return support.qmc("pixels", "--connect", "", "--sampler", sampler, "--resolution",
                       "%d,%d" % res, "--spp", spp, "--dims", dims, "--tile",
                       ",".join(map(str, tile)), "--samples", "%d:%d" % samples, "--seed",
                       seed, "--frame", frame, "--format", fmt)


class Pixels(unittest.TestCase):
    def test_tiles(self):
        clients = [qmcd.connect(plain.unix), qmcd.connect(plain.tcp), qmcd.connect(small.unix)]
        self.addCleanup(lambda: [c.close() for c in clients])
        cases = [("zsobol", (64, 48), 16, 5, (3, 5, 20, 11), (4, 8), 0, 0, "f32"),
                 ("padded-sobol", (64, 48), 16, 3, (0, 0, 64, 48), (0, 16), -5, 3, "u32"),
                 ("sobol", (100, 30), 8, 4, (90, 20, 10, 10), (0, 8), 1234, 1, "f64"),
                 ("zsobol", (1920, 1080), 16, 8, (0, 0, 64, 64), (0, 16), 0, 0, "f32")]
        for sampler, res, spp, dims, tile, samples, seed, frame, fmt in cases:
            want = cli_pixels(sampler, res, spp, dims, tile, samples, seed, frame, fmt)
            for c in clients:
                with self.subTest(sampler=sampler, tile=tile, client=c.endpoint):
                    got = c.pixels(sampler, res, spp, dims, tile=tile, samples=samples,
                                   seed=seed, frame=frame, dtype=fmt)
                    self.assertEqual(got.shape, (tile[3], tile[2], samples[1], dims))
                    self.assertEqual(got.tobytes(), want)

    def test_readme_values(self):
        # README's tour: pixel (5, 9), samples 0 and 1, as pbrt-v4 computes them.
        with qmcd.connect(plain.unix) as c:
            t = c.pixels("zsobol", (64, 64), 16, 4, tile=(5, 9, 1, 1), samples=(0, 2),
                         dtype="u32")
        self.assertEqual(t.ravel().tolist(), [137651436, 1928852625, 2766910451, 884977949,
                                              2707618131, 478237227, 1873622936, 1390527787])

    def test_refusal(self):
        with qmcd.connect(plain.unix) as c, self.assertRaises(qmcd.ServerError) as cm:
            c.pixels("zsobol", (1920, 1080), 16, 8, tile=(0, 0, 64, 64), samples=(12, 8))
        self.assertEqual(cm.exception.code, errors.QMC_ERANGE)
        self.assertIn("ask for a larger spp (32 covers it)", cm.exception.message)


LAMBERT = """point 0 0 0
normal 0 0 1
brdf lambert 0.8
light sphere center 1 0.5 5 radius 0.6 radiance 10
"""

# `qmc integrate` options, each a case: the CLI takes them as they are;
# kwargs() turns them into the Python call's keyword arguments.
JOBS = [
    "--integrand genz-gaussian --dims 5 --method rqmc --n 4096",
    "--integrand genz-oscillatory --dims 3 --method auto --tol-rel 1e-8",
    "--integrand inv-sqrt --dims 1 --method mc --n 100000",
    "--integrand genz-gaussian --dims 2 --a 5000,5000 --u 0.123,0.777 "
    "--method clenshaw-curtis",
    "--integrand exp --dims 1 --method gauss-legendre --n 8",
    "--integrand genz-gaussian --dims 4 --method clenshaw-curtis --tol-rel 1e-12",
    "--integrand genz-discontinuous --dims 6 --method rqmc --reps 8 --n 8192 --split-net",
    "--integrand genz-gaussian --dims 4 --control genz-product-peak --method mc",
    "--integrand genz-corner-peak --dims 20 --difficulty testpack --seed 7 --method rqmc "
    "--n 4096",
    "--integrand poly --dims 1 --a 1,-2,3 --method qmc --n 1024",
    "--integrand poly --dims 1 --method qmc --n 1000",
    "--integrand cos --dims 1 --a 7 --method midpoint --n 33",
    "--integrand log --dims 1 --method trapezoid --n 64",
    "--integrand step --dims 1 --u 0.3 --method simpson --n 65",
    "--integrand genz-product-peak --dims 3 --method stratified",
    "--integrand genz-continuous --dims 2 --method lhs --n 1000 --seed 3",
    "--integrand genz-gaussian --dims 3 --method cubature --tol-rel 1e-6",
    "--integrand exp --dims 1 --method gauss-kronrod",
    "--integrand genz-oscillatory --dims 2 --method qmc --seq halton --scramble faure",
    "--integrand genz-gaussian --dims 3 --method rqmc --scramble fast-owen --shuffle "
    "--confidence 0.99 --reps 4",
    "--integrand genz-gaussian --dims 2 --method auto --max-evals 10000",
    "--integrand genz-oscillatory --dims 4 --method mc --tol-abs 1e-3 --max-evals 200000",
    "--scene SCENE --method rqmc --strategy mis-power",
    "--scene SCENE --method stratified --strategy brdf",
    "--scene SCENE --method mc --strategy mis-balance --samples 2/3 --n 2000",
]


def kwargs(args, scene_path):
    """The Python call for CLI options: (integrand, dims, options)."""
    words = args.split()
    out, integrand, dims, i = {}, None, None, 0
    while i < len(words):
        w = words[i][2:]
        if w in ("split-net", "shuffle"):
            out[w.replace("-", "_")] = True
            i += 1
            continue
        v = words[i + 1]
        i += 2
        if w == "integrand":
            integrand = v
        elif w == "dims":
            dims = int(v)
        elif w == "scene":
            with open(scene_path) as f:
                out["scene"] = f.read()
            out["scene_label"] = scene_path
        elif w in ("a", "u"):
            out[w] = [float(x) for x in v.split(",")]
        elif w == "samples":
            out[w] = tuple(int(x) for x in v.split("/"))
        elif w in ("n", "reps", "seed", "max-evals"):
            out[w.replace("-", "_")] = int(v)
        elif w in ("tol-rel", "tol-abs", "confidence"):
            out[w.replace("-", "_")] = float(v)
        else:
            out[w] = v
    return integrand, dims, out


class Jobs(unittest.TestCase):
    def test_json_equals_the_cli(self):
        d = support.scratch()
        scene = os.path.join(d, "lambert.scene")
        with open(scene, "w") as f:
            f.write(LAMBERT)
        proxy = PinProxy(plain.unix[5:], d)
        self.addCleanup(proxy.close)
        c = qmcd.connect(proxy.endpoint)
        self.addCleanup(c.close)
        for args in JOBS:
            args = args.replace("SCENE", scene)
            with self.subTest(args):
                n = len(proxy.requests)
                want = support.qmc("integrate", "--json", "--connect", proxy.endpoint,
                                   *args.split())
                integrand, dims, kw = kwargs(args, scene)
                r = c.run(integrand, dims, **kw)
                self.assertEqual(len(proxy.requests), n + 2)
                self.assertEqual(proxy.requests[n + 1], proxy.requests[n],
                                 "the two clients sent different INTEGRATE requests")
                self.assertEqual(r.seconds, PINNED_SECONDS)
                self.assertEqual((r.json() + "\n").encode(), want)
                # In-process (no daemon: libqmc's own integral of |f|, not
                # the wire's), the same line but for the clock.
                here = support.qmc("integrate", "--json", *args.split())
                self.assertEqual(support.pin_seconds(here), support.pin_seconds(want))
                self.assertTrue(r.known_abs_told)

    def test_the_integral_of_abs_f_comes_from_the_daemon(self):
        """Both clients print the known integral of |f| the daemon sends
        (protocol version 6), not one of their own: a proxy puts 0.5 in
        its place; and a session's f has none, its estimate stands in."""
        proxy = PinProxy(plain.unix[5:], support.scratch(), known_abs=0.5)
        self.addCleanup(proxy.close)
        args = "--integrand genz-oscillatory --dims 3 --method rqmc --n 1024"
        cli = support.qmc("integrate", "--json", "--connect", proxy.endpoint, *args.split())
        with qmcd.connect(proxy.endpoint) as c:
            r = c.run(*kwargs(args, None)[:2], **kwargs(args, None)[2])
        self.assertEqual((r.json() + "\n").encode(), cli)
        self.assertEqual(r.known_abs, 0.5)
        self.assertIn(b'"abs_integral":0.5,', cli)
        with qmcd.connect(plain.unix) as c:
            unknown = c.run(*kwargs(args, None)[:2], **kwargs(args, None)[2])
            known = c.run("genz-gaussian", 3, method="rqmc", n=1024)
            s = c.integrate(lambda x: x[:, 0], 1, method="gauss-legendre", n=4)
        self.assertEqual((unknown.known_abs_told, unknown.known_abs), (True, None))
        self.assertEqual(known.known_abs, known.exact)  # a positive f's
        self.assertEqual((s.known_abs_told, s.known_abs), (True, None))
        self.assertIn('"abs_integral":%s,' % ("%.17g" % s.abs_integral), s.json())

    def test_a_version_5_daemon_says_nothing_of_abs_f(self):
        """Against a daemon of protocol version 5 (a fake one: the frames of
        that version), the CLI prints the closed form of the integrand it
        builds itself, the Python client (which builds none) the result's
        estimate; the rest of the line is the same."""
        from test_hostile import Fake, read_frame, hello_ok
        from qmcd import wire
        args = ["--integrand", "genz-gaussian", "--dims", "2", "--method", "qmc", "--n", "64"]
        here = json.loads(support.qmc("integrate", "--json", *args))  # libqmc in-process
        closed = here["abs_integral"]
        self.assertNotEqual(closed, 0.25)

        def script(f, s):
            t, rid, _ = read_frame(s)
            s.sendall(hello_ok(rid, version=5))
            t, rid, _ = read_frame(s)
            f.seen.append(t)
            s.sendall(wire.encode(wire.JOB_ACCEPTED, rid, {"job_id": 9}, 5))
            s.sendall(wire.encode(wire.JOB_RESULT, rid, dict(
                job_id=9, method_used="qmc", error_kind="none", reference_kind="exact",
                cv_used=False, dims=2, flags=0, n=64, evals=64, nonfinite=0, estimate=0.3,
                error=0.0, ci_low=0.0, ci_high=0.0, abs_integral=0.25, cv_beta=0.0,
                cv_variance_ratio=0.0, seconds=0.125, reference=here["exact"],
                sampling=dict(sampler="qmc", seq="sobol", scramble="none", seq_flags=0,
                              seed=0, n=64, confidence=0.95, reps=1, split_net=False),
                detail="a fake", auto_reason=""), 5))
            read_frame(s)  # until the client hangs up
        f = Fake(script, conns=2)
        self.addCleanup(f.stop.set)
        cli = support.qmc("integrate", "--json", "--connect", f.endpoint, *args)
        with qmcd.connect(f.endpoint) as c:
            r = c.run("genz-gaussian", 2, method="qmc", n=64)
        self.assertEqual(f.seen, [wire.INTEGRATE, wire.INTEGRATE])
        self.assertEqual((r.known_abs_told, r.known_abs), (False, None))
        cli, py = json.loads(cli), json.loads(r.json())
        self.assertEqual((cli["abs_integral"], py["abs_integral"]), (closed, 0.25))
        del cli["abs_integral"], cli["error_vs_abs_integral"]
        del py["abs_integral"], py["error_vs_abs_integral"]
        self.assertEqual(cli, py)

    def test_result_object(self):
        with qmcd.connect(plain.unix) as c:
            r = c.run("inv-sqrt", 1, method="mc", n=100000)
            self.assertEqual(r.error_kind, "stderr")
            self.assertEqual(r.interval[0] < r.estimate < r.interval[1], True)
            self.assertIn("heavy_tail", r.flags)
            self.assertIn("error_unreliable", r.flags)
            self.assertEqual(r.meanings()["heavy_tail"],
                             "heavy tails: the variance may be infinite")
            self.assertFalse(r.reliable)
            self.assertEqual(r.exact, 2.0)
            self.assertEqual(r.flag_bits, sum(1 << b for b, k, _ in qmcd.wire.FLAGS
                                              if k in r.flags))
            q = c.run("exp", 1, method="gauss-legendre", n=8)
            self.assertEqual((q.error_kind, q.stderr is None, q.error == q.error_estimate),
                             ("estimate", True, True))
            none = c.run("poly", 1, method="qmc", n=1024)
            self.assertEqual((none.error_kind, none.error, none.interval), ("none", None, None))

    def test_refused_job(self):
        with qmcd.connect(plain.unix) as c:
            with self.assertRaises(qmcd.ServerError) as cm:
                c.submit("genz-nope", 3)
            self.assertEqual(cm.exception.code, errors.QMC_EINVAL)
            import subprocess
            p = subprocess.run([support.QMC, "integrate", "--integrand", "genz-nope", "--dims",
                                "3"], stderr=subprocess.PIPE, timeout=60)
            self.assertEqual(cm.exception.message,
                             p.stderr.decode().strip().split("qmc: ", 1)[1])
            with self.assertRaises(ValueError):
                c.submit("genz-gaussian", 3, method="rqmc", split_net=True, seq="halton",
                         scramble="owen", n=0)

    def test_progress_cancel_and_wait(self):
        # One worker, and a job of 9e8 evaluations: it is still running when
        # the cancel arrives, whatever the machine's speed.
        d = support.daemon("one-thread", threads=1)
        with qmcd.connect(d.unix) as c:
            small_job = c.submit("genz-gaussian", 2, method="rqmc", n=1024)
            big = c.submit("genz-gaussian", 20, method="mc", n=900000000,
                           max_evals=1000000000, progress_ms=10)
            self.assertEqual(small_job.wait().evals, 16 * 1024)
            for _ in range(1000):
                if big.last_progress is not None:
                    break
                try:
                    big.wait(timeout=0.05)
                except qmcd.Timeout:
                    pass
            self.assertIsNotNone(big.last_progress)
            self.assertGreater(big.last_progress.evals, 0)
            self.assertIn(big.progress().state, ("queued", "running"))
            self.assertEqual(big.cancel(), "cancelled")
            with self.assertRaises(qmcd.ServerError) as cm:
                big.wait()
            self.assertEqual(cm.exception.code, errors.ECANCELED)
            self.assertEqual(cm.exception.name, "ECANCELED")
            self.assertEqual(big.progress().state, "unknown")
            self.assertGreaterEqual(c.ping(), 0)

    def test_results_filed_while_streaming(self):
        # A job's result that arrives while points stream is kept for it.
        with qmcd.connect(plain.unix) as c:
            j = c.submit("genz-gaussian", 3, method="rqmc", n=4096)
            x = c.points("sobol", 16, 200000)
            self.assertEqual(x.shape, (200000, 16))
            r = j.wait()
            self.assertEqual(r.evals, 65536)


if __name__ == "__main__":
    unittest.main()
