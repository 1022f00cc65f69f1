"""qmcd.engines - scipy.stats.qmc's engine interface, with the points made
by the daemon: random(n), random_base2(m) (Sobol), integers(...),
reset(), fast_forward(n), d and num_generated, as QMCEngine has them, so
code written for scipy runs on the service.

Sobol's order is a choice.  qmcd numbers Sobol points in natural binary
order (docs/SEQUENCES.md: point i is the XOR of the direction numbers of
i's set bits); scipy in Gray-code order (its point k is qmcd's point
k ^ (k >> 1)).  order="gray" (the default) gives scipy's points, point for
point, when unscrambled; order="natural" gives `qmc points`' order.  Any
run of 2^m points from an index that is a multiple of 2^m is the same set
in both orders, so random_base2 gives the same net either way.

Scrambles are qmcd's (docs/SEQUENCES.md), not scipy's: a scrambled engine
gives a net as good as scipy's, not the same numbers.  seed is qmcd's
64-bit seed: an int, or drawn once from a numpy Generator / RandomState /
the OS when None (so reset() replays the same points, as scipy's does).

Must not: keep points between calls (each call asks the daemon), or hide
the daemon's errors (a QmcdError comes through as it is).
"""
import os
import warnings

import numpy as np

_U64 = 2**64


def _seed64(seed):
    if seed is None:
        return int.from_bytes(os.urandom(8), "little")
    if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
        return int(seed) % _U64
    if isinstance(seed, np.random.Generator):
        return int(seed.integers(0, _U64, dtype=np.uint64))
    if isinstance(seed, np.random.RandomState):
        return int(seed.randint(0, 2**32, dtype=np.uint64)) << 32 | \
            int(seed.randint(0, 2**32, dtype=np.uint64))
    raise ValueError("%r cannot seed a qmcd engine (an int, a numpy Generator or "
                     "RandomState, or None)" % (seed,))


def _scramble_name(scramble, default, allowed):
    if scramble is True:
        return default
    if scramble is False:
        return "none"
    if scramble in allowed:
        return scramble
    raise ValueError("scramble %r: want True, False or one of %s"
                     % (scramble, ", ".join(allowed)))


def gray_blocks(start, stop):
    """[start, stop) in Gray-code order as aligned blocks: yields (count,
    natural_start, offsets) where engine points start.. are the natural
    points natural_start + offsets.  A block of 2^j engine indices from a
    multiple m 2^j is the natural block gray(m) 2^j + [0, 2^j), permuted
    by r -> gray(r) ^ ((m & 1) << (j - 1))."""
    a = start
    while a < stop:
        j = 0
        while (a % (1 << (j + 1)) == 0) and a + (1 << (j + 1)) <= stop:
            j += 1
        size = 1 << j
        m = a >> j
        base = (m ^ (m >> 1)) << j
        r = np.arange(size, dtype=np.uint64)
        offsets = r ^ (r >> np.uint64(1))
        if j:
            offsets ^= np.uint64((m & 1) << (j - 1))
        yield size, base, offsets.astype(np.int64)
        a += size


class QMCEngine:
    """The interface of scipy.stats.qmc.QMCEngine, on a qmcd client.

    client: a qmcd.Client; None connects one (qmcd.connect(): $QMC_ENDPOINT)
    the first time points are needed.
    """

    def __init__(self, d, *, seed=None, client=None):
        if isinstance(d, bool) or not isinstance(d, (int, np.integer)) or d < 1:
            raise ValueError("d must be a positive integer value")
        self.d = int(d)
        self.rng_seed = seed
        self.seed64 = _seed64(seed)
        self.num_generated = 0
        self._client = client

    @property
    def client(self):
        if self._client is None:
            from .client import connect
            self._client = connect()
        return self._client

    def _random(self, n):
        raise NotImplementedError  # pragma: no cover - every engine defines it

    def random(self, n=1, *, workers=1):
        """Draws n points in [0, 1)^d: an (n, d) float64 array."""
        n = int(n)
        if n < 0:
            raise ValueError("n must be >= 0")
        sample = self._random(n) if n else np.empty((0, self.d))
        self.num_generated += n
        return sample

    def integers(self, l_bounds, *, u_bounds=None, n=1, endpoint=False, workers=1):
        """n integer points from l_bounds (inclusive) to u_bounds (exclusive,
        inclusive with endpoint=True): floor((u - l) x + l), as scipy."""
        if u_bounds is None:
            u_bounds = l_bounds
            l_bounds = 0
        u_bounds = np.atleast_1d(u_bounds)
        l_bounds = np.atleast_1d(l_bounds)
        if endpoint:
            u_bounds = u_bounds + 1
        if not np.issubdtype(l_bounds.dtype, np.integer) or \
                not np.issubdtype(u_bounds.dtype, np.integer):
            raise ValueError("'u_bounds' and 'l_bounds' must be integers or array-like of "
                             "integers")
        try:
            lower = np.broadcast_to(l_bounds, self.d)
            upper = np.broadcast_to(u_bounds, self.d)
        except ValueError as exc:
            raise ValueError("'l_bounds' and 'u_bounds' must be broadcastable and respect "
                             "the sample dimension") from exc
        if not np.all(lower < upper):
            raise ValueError("Bounds are not consistent 'l_bounds' < 'u_bounds'")
        sample = self.random(n=n)
        return np.floor(sample * (upper - lower) + lower).astype(np.int64)

    def reset(self):
        """Back to the first point (the same points again)."""
        self.num_generated = 0
        return self

    def fast_forward(self, n):
        """Skips n points."""
        self.num_generated += int(n)
        return self


class _Sequence(QMCEngine):
    """An infinite sequence served by index: random(n) is points
    num_generated .. + n."""
    kind = None

    def __init__(self, d, *, scramble, seed, client):
        QMCEngine.__init__(self, d, seed=seed, client=client)
        self.scramble = scramble

    def _fetch(self, start, count):
        return self.client.points(self.kind, self.d, count, start=start,
                                  scramble=self.scramble, seed=self.seed64)

    def _random(self, n):
        return self._fetch(self.num_generated, n)


class Sobol(_Sequence):
    """Sobol' points (Joe & Kuo's directions).  scramble: True (qmcd's Owen
    scrambling), False, or "owen", "shift", "fast-owen", "none".  order:
    "gray" (scipy's, default) or "natural" (qmcd's).  bits: scipy's cap on
    2^bits points, at most 32 here (qmcd's points have 32 bits)."""
    MAXDIM = 21201
    kind = "sobol"

    def __init__(self, d, *, scramble=True, bits=None, seed=None, order="gray", client=None):
        if d > self.MAXDIM:
            raise ValueError("Maximum supported dimensionality is %d." % self.MAXDIM)
        if order not in ("gray", "natural"):
            raise ValueError("order %r: want 'gray' (scipy's) or 'natural' (qmcd's)"
                             % (order,))
        if bits is not None and not 1 <= bits <= 32:
            raise ValueError("bits %r: qmcd's Sobol points have 32 bits; want 1..32" % (bits,))
        _Sequence.__init__(self, d, scramble=_scramble_name(
            scramble, "owen", ("none", "shift", "owen", "fast-owen")), seed=seed, client=client)
        self.order = order
        self.bits = 32 if bits is None else bits
        self.maxn = 2**self.bits
        self._table_checked = False

    def _random(self, n):
        total = self.num_generated + n
        if total > self.maxn:
            raise ValueError("At most 2**%d=%d distinct points can be generated. %d points "
                             "have been previously generated, then: n=%d+%d=%d."
                             % (self.bits, self.maxn, self.num_generated,
                                self.num_generated, n, total))
        if self.num_generated == 0 and n & (n - 1):
            warnings.warn("The balance properties of Sobol' points require n to be a power "
                          "of 2.", stacklevel=3)
        if not self._table_checked:
            if not self.client.sobol_table_matches:
                warnings.warn("the daemon's Sobol table (%s) is not Joe & Kuo's "
                              "new-joe-kuo-6.21201: its points differ from scipy's"
                              % self.client.sobol_table, stacklevel=3)
            self._table_checked = True
        a = self.num_generated
        if self.order == "natural":
            return self._fetch(a, n)
        out = np.empty((n, self.d))
        done = 0
        for size, base, offsets in gray_blocks(a, a + n):
            out[done:done + size] = self._fetch(base, size)[offsets]
            done += size
        return out

    def random_base2(self, m):
        """2^m points, keeping the balance of the sequence (scipy's check:
        num_generated + 2^m must be a power of 2)."""
        n = 2**m
        total = self.num_generated + n
        if total & (total - 1):
            raise ValueError("The balance properties of Sobol' points require n to be a "
                             "power of 2. {0} points have been previously generated, then: "
                             "n={0}+2**{1}={2}. If you still want to do this, the function "
                             "'Sobol.random()' can be used.".format(self.num_generated, m,
                                                                     total))
        return self.random(n)


class Halton(_Sequence):
    """Halton points.  scramble: True (qmcd's Owen scrambling of the digits,
    docs/SEQUENCES.md), False, "faure" or "owen"."""
    kind = "halton"

    def __init__(self, d, *, scramble=True, seed=None, client=None):
        _Sequence.__init__(self, d, scramble=_scramble_name(scramble, "owen",
                                                            ("none", "owen", "faure")),
                           seed=seed, client=client)


class Random(_Sequence):
    """Plain Monte Carlo: qmcd's counter-based uniform points (kind
    random), a pure function of (seed, index, dimension)."""
    kind = "random"

    def __init__(self, d, *, seed=None, client=None):
        _Sequence.__init__(self, d, scramble="none", seed=seed, client=client)


class _FiniteSet(QMCEngine):
    """A finite kind (a set of N points, not a sequence): random(n) is a
    whole set of n points, a fresh one each call (call c uses seed
    seed64 + c * 0x9e3779b97f4a7c15), as scipy's LatinHypercube draws a
    fresh design per call; reset() starts the calls over; fast_forward(n)
    skips one call, as QMCEngine's does (it draws and drops n points)."""
    kind = None
    scramble = "none"

    def __init__(self, d, *, seed=None, client=None):
        QMCEngine.__init__(self, d, seed=seed, client=client)
        self._calls = 0

    def _random(self, n):
        seed = (self.seed64 + self._calls * 0x9E3779B97F4A7C15) % _U64
        self._calls += 1
        return self.client.points(self.kind, self.d, n, scramble=self.scramble, seed=seed,
                                  set_size=n)

    def reset(self):
        self._calls = 0
        return QMCEngine.reset(self)

    def fast_forward(self, n):
        self._calls += 1
        return QMCEngine.fast_forward(self, n)


class LatinHypercube(_FiniteSet):
    """Latin hypercube sets, jittered within their cells (scipy's
    scramble=True; a centred design is not served)."""
    kind = "lhs"

    def __init__(self, d, *, scramble=True, seed=None, client=None):
        if scramble is not True:
            raise ValueError("qmcd's lhs places each point at random within its cell "
                             "(scramble=True); a centred design is not served")
        _FiniteSet.__init__(self, d, seed=seed, client=client)


class Stratified(_FiniteSet):
    """Jittered stratified sets: n must be k^d (k strata per dimension)."""
    kind = "stratified"


class Hammersley(_FiniteSet):
    """Hammersley sets of n points: coordinate 0 is i / n, the others
    Halton's.  scramble: False, True ("owen") or "faure"."""
    kind = "hammersley"

    def __init__(self, d, *, scramble=False, seed=None, client=None):
        _FiniteSet.__init__(self, d, seed=seed, client=client)
        self.scramble = _scramble_name(scramble, "owen", ("none", "owen", "faure"))
