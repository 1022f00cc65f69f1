"""The scipy-style engines against scipy itself and against closed forms:
unscrambled Sobol equals scipy.stats.qmc.Sobol point for point in Gray
order, and is scipy's points permuted by k -> k ^ (k >> 1) in natural
order, across calls of any size, fast_forward, reset and integers;
Halton equals the exact radical inverse rounded once (Fraction), and
scipy's to a few ulps (scipy's
sums drift); scrambled nets keep their balance;
LHS and stratified sets have one point per stratum; the Sobol table the
daemon fingerprints is Joe & Kuo's file, recomputed here."""
import struct
import unittest
import warnings
from fractions import Fraction

import numpy as np

import support
import qmcd

try:
    from scipy.stats import qmc as scipy_qmc
except ImportError:  # pragma: no cover - Debian's python3-scipy is a test dependency
    scipy_qmc = None


def setUpModule():
    global client
    client = qmcd.connect(support.daemon("plain").unix)


def tearDownModule():
    client.close()


def need_scipy():
    if scipy_qmc is None:
        raise unittest.SkipTest("scipy is not installed (python3-scipy)")


def quiet(f, *a, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return f(*a, **kw)


class SobolVsScipy(unittest.TestCase):
    def setUp(self):
        need_scipy()

    def test_gray_order_point_for_point(self):
        for d in (1, 2, 7, 100, 1111):
            s = scipy_qmc.Sobol(d, scramble=False)
            e = qmcd.Sobol(d, scramble=False, client=client)
            for n in (1, 7, 64, 100, 1000, 3, 4096, 5):
                with self.subTest(d=d, n=n, before=e.num_generated):
                    np.testing.assert_array_equal(quiet(e.random, n), quiet(s.random, n))
            self.assertEqual(e.num_generated, s.num_generated)
            s.fast_forward(12345)
            e.fast_forward(12345)
            np.testing.assert_array_equal(e.random(50), s.random(50))
            s.reset()
            e.reset()
            np.testing.assert_array_equal(e.random_base2(10), s.random_base2(10))
            np.testing.assert_array_equal(e.integers(3, u_bounds=[10] * d, n=33),
                                          s.integers(3, u_bounds=[10] * d, n=33))
            np.testing.assert_array_equal(e.integers(7, n=9, endpoint=True),
                                          s.integers(7, n=9, endpoint=True))

    def test_natural_order_is_the_gray_permutation(self):
        s = scipy_qmc.Sobol(6, scramble=False).random(4096)
        e = qmcd.Sobol(6, scramble=False, order="natural", client=client)
        x = np.concatenate([quiet(e.random, 1000), e.random(3096)])
        k = np.arange(4096)
        np.testing.assert_array_equal(s, x[k ^ (k >> 1)])
        # ... and is what client.points gives.
        np.testing.assert_array_equal(x, client.points("sobol", 6, 4096))
        # A run of 2^m from a multiple of 2^m is the same set in both orders.
        g = qmcd.Sobol(6, scramble=False, client=client)
        g.fast_forward(1024)
        a = g.random_base2(10)
        b = x[1024:2048]
        self.assertEqual(sorted(map(tuple, a)), sorted(map(tuple, b)))

    def test_scipy_checks(self):
        e = qmcd.Sobol(2, scramble=False, client=client)
        with self.assertWarnsRegex(UserWarning, "power of 2"):
            e.random(3)
        with self.assertRaisesRegex(ValueError, "balance properties"):
            e.random_base2(2)
        with self.assertRaisesRegex(ValueError, "Bounds are not consistent"):
            e.integers(5, u_bounds=3)
        with self.assertRaisesRegex(ValueError, "must be integers"):
            e.integers(1.5)
        b = qmcd.Sobol(2, scramble=False, bits=4, client=client)
        b.random(16)
        with self.assertRaisesRegex(ValueError, "At most 2\\*\\*4=16"):
            b.random(1)
        with self.assertRaisesRegex(ValueError, "Maximum supported dimensionality"):
            qmcd.Sobol(21202, client=client)

    def test_scrambled_nets_keep_their_balance(self):
        # Owen scrambling keeps (0, m, 1)-nets in each coordinate: 2^m points,
        # one in each of the 2^m intervals [k/2^m, (k+1)/2^m); and the pairs
        # of the first two coordinates are a (0, m, 2)-net.
        for scramble in (True, "fast-owen", "shift"):
            e = qmcd.Sobol(5, scramble=scramble, seed=11, client=client)
            x = e.random_base2(8)
            for j in range(5):
                cells = np.floor(x[:, j] * 256).astype(int)
                self.assertEqual(sorted(cells), list(range(256)), (scramble, j))
            for m1 in range(9):
                cells = np.floor(x[:, 0] * 2**m1).astype(int) * 2**(8 - m1) + \
                    np.floor(x[:, 1] * 2**(8 - m1)).astype(int)
                self.assertEqual(len(set(cells)), 256, (scramble, m1))
            self.assertGreater(len(set(x[:, 0])), 1)
        # The same seed, the same points; reset replays them.
        a = qmcd.Sobol(3, seed=5, client=client).random(64)
        e = qmcd.Sobol(3, seed=np.random.default_rng(1), client=client)
        b = e.random(64)
        self.assertFalse(np.array_equal(a, b))
        np.testing.assert_array_equal(e.reset().random(64), b)
        np.testing.assert_array_equal(qmcd.Sobol(3, seed=5, client=client).random(64), a)


def radical_inverse(i, b):
    """The exact van der Corput value of i in base b, as a Fraction."""
    x, f = Fraction(0), Fraction(1, b)
    while i:
        i, digit = divmod(i, b)
        x += digit * f
        f /= b
    return x


class Halton(unittest.TestCase):
    def test_exact_and_against_scipy(self):
        primes = [2, 3, 5, 7, 11, 13]
        e = qmcd.Halton(6, scramble=False, client=client)
        e.fast_forward(1000)
        x = e.random(500)
        for i in range(500):
            for j, b in enumerate(primes):
                self.assertEqual(x[i, j], float(radical_inverse(1000 + i, b)), (i, j))
        need_scipy()
        s = scipy_qmc.Halton(6, scramble=False)
        s.fast_forward(1000)
        y = s.random(500)
        # scipy sums the digits in floating point and drifts by a few ulps
        # (up to 3 over 10^5 points here); qmcd's value is the exact one
        # rounded once, as checked above.
        ulp = np.spacing(np.maximum(np.abs(x), np.abs(y)))
        self.assertTrue(np.all(np.abs(x - y) <= 4 * ulp))
        self.assertGreater(np.mean(x == y), 0.5)

    def test_scrambles(self):
        for scramble in ("owen", "faure", True):
            x = qmcd.Halton(4, scramble=scramble, seed=3, client=client).random(243)
            # Base 3 in coordinate 1: any digit scramble keeps one point in
            # each of the 243 intervals of width 3^-5.
            # (+1e-9: a point at k/243 may be stored a hair below it.)
            cells = np.floor(x[:, 1] * 243 + 1e-9).astype(int)
            self.assertEqual(sorted(cells), list(range(243)), scramble)


class FiniteSets(unittest.TestCase):
    def test_lhs(self):
        e = qmcd.LatinHypercube(4, seed=9, client=client)
        a, b = e.random(100), e.random(100)
        for x in (a, b):
            for j in range(4):
                self.assertEqual(sorted(np.floor(x[:, j] * 100).astype(int)), list(range(100)))
        self.assertFalse(np.array_equal(a, b))  # a fresh design each call
        np.testing.assert_array_equal(e.reset().random(100), a)
        with self.assertRaises(ValueError):
            qmcd.LatinHypercube(2, scramble=False, client=client)

    def test_stratified_and_hammersley(self):
        x = qmcd.Stratified(2, seed=1, client=client).random(64)
        cells = np.floor(x * 8).astype(int)
        self.assertEqual(len(set(map(tuple, cells))), 64)
        with self.assertRaises(qmcd.ServerError) as cm:
            qmcd.Stratified(2, client=client).random(10)
        self.assertEqual(cm.exception.code, qmcd.errors.QMC_ECOUNT)
        h = qmcd.Hammersley(3, client=client).random(50)
        self.assertEqual(h[:, 0].tolist(), [i / 50 for i in range(50)])
        self.assertEqual(h[7, 1], float(radical_inverse(7, 2)))

    def test_random(self):
        r = qmcd.Random(3, seed=4, client=client)
        a = r.random(10)
        np.testing.assert_array_equal(r.reset().random(10), a)
        self.assertTrue(np.all((a >= 0) & (a < 1)))


class Table(unittest.TestCase):
    def test_joe_kuo_fingerprint(self):
        # FNV-1a over (degree, coefficients, m_1..m_s) as u32 little-endian,
        # dimension 1 (degree 0, no numbers) first, as core/seq_sobol.c says.
        h = 0xCBF29CE484222325

        def feed(v):
            nonlocal h
            for byte in struct.pack("<I", v):
                h = ((h ^ byte) * 0x100000001B3) % 2**64
        feed(0)
        feed(0)
        with open(support.tree_file("data", "new-joe-kuo-6.21201")) as f:
            next(f)
            for line in f:
                w = line.split()
                if w:
                    feed(int(w[1]))
                    feed(int(w[2]))
                    for m in w[3:3 + int(w[1])]:
                        feed(int(m))
        self.assertEqual(h, qmcd.JOE_KUO_TABLE_HASH)
        self.assertEqual(client.sobol_table_hash, h)
        self.assertTrue(client.sobol_table_matches)
        info = client.info(pings=3)
        self.assertEqual((info["sobol_table"], info["sobol_table_matches"], len(info["rtt_ms"])),
                         ("%016x" % h, True, 3))


if __name__ == "__main__":
    unittest.main()
