#!/usr/bin/python3
"""An independent reference for every sequence kind and scramble.

Written from docs/SEQUENCES.md, not from the C code, and run against
`qmc points` by tests/e2e/test_seq_oracle.sh.  It uses Python's exact
integers and fractions: the direction numbers come from Joe & Kuo's file
through their own recurrence (in m-form, not the C code's scaled form), the
radical inverses are exact fractions rounded once, and Faure's permutations
are built as whole arrays rather than evaluated digit by digit.  The golden
digests only show that nothing changed; this shows the numbers are the
ones the definitions say.

fast-owen's per-dimension seeds come from MurmurHash64A, written here
from the page's pseudo-code (tests/vectors/pbrt_sobol_fast_owen.h holds
pbrt-v4's own values for the unit test).

Usage: seq_oracle.py QMC JOE_KUO_FILE [CASES] [SEED]
Prints "N passed, M failed" and exits non-zero on any mismatch.
"""
import random
import struct
import subprocess
import sys
from fractions import Fraction

M64 = (1 << 64) - 1
M32 = (1 << 32) - 1
TAG = dict(owen=0x6F77656E, shift=0x73686674, shuffle=0x73686666,
           jitter=0x6A697472, perm=0x7065726D)
ONE_MINUS_EPS = 1.0 - 2.0 ** -53


# ---- hashes (docs/SEQUENCES.md, "Hashes") ---------------------------------
def mix64(x):
    x ^= x >> 27
    x = (x * 0x3C79AC492BA7B653) & M64
    x ^= x >> 33
    x = (x * 0x1C69B3F74AC4AE35) & M64
    x ^= x >> 27
    return x


def hash3(a, b, c):
    h = mix64((a + 0x9E3779B97F4A7C15) & M64)
    h = mix64(h ^ ((b * 0xD1B54A32D192ED03 + 0x8BB84B93962EACC9) & M64))
    return mix64(h ^ ((c * 0xAEF17502108EF2D9 + 0x4B33A62ED433D4A3) & M64))


def u01(h):
    return (h >> 11) * 2.0 ** -53


def below_one(x):
    return min(x, ONE_MINUS_EPS)


def permute(i, n, s):
    w = (1 << (n - 1).bit_length()) - 1 if n > 1 else 0
    while True:
        i ^= s
        i = (i * 0xE170893D) & w
        i ^= s >> 16
        i ^= (i & w) >> 4
        i ^= s >> 8
        i = (i * 0x0929EB3F) & w
        i ^= s >> 23
        i ^= (i & w) >> 1
        i = (i * (1 | s >> 27)) & w
        i = (i * 0x6935FA69) & w
        i ^= (i & w) >> 11
        i = (i * 0x74DCB303) & w
        i ^= (i & w) >> 2
        i = (i * 0x9E501CC3) & w
        i ^= (i & w) >> 2
        i = (i * 0xC860A3DF) & w
        i &= w
        i ^= i >> 5
        if i < n:
            return i


def reverse32(x):
    return int("{:032b}".format(x)[::-1], 2)


def lk(x, s):
    x ^= (x * 0x3D20ADEA) & M32
    x = (x + s) & M32
    x = (x * ((s >> 16) | 1)) & M32
    x ^= (x * 0x05526C56) & M32
    x ^= (x * 0x53A22864) & M32
    return x


def nested(x, s):
    return reverse32(lk(reverse32(x), s))


def murmur64a(data):
    """MurmurHash64A, seed 0, as docs/SEQUENCES.md spells it out."""
    m = 0xC6A4A7935BD1E995
    h = (len(data) * m) & M64
    whole = len(data) - len(data) % 8
    for o in range(0, whole, 8):
        k = int.from_bytes(data[o:o + 8], "little")
        k = (k * m) & M64
        k ^= k >> 47
        k = (k * m) & M64
        h = ((h ^ k) * m) & M64
    if len(data) % 8:
        h = ((h ^ int.from_bytes(data[whole:], "little")) * m) & M64
    h ^= h >> 47
    h = (h * m) & M64
    return h ^ (h >> 47)


def fast_owen_seed(seed, j):
    width = 4 if seed < 1 << 32 else 8
    return murmur64a(j.to_bytes(4, "little") + seed.to_bytes(width, "little")) & M32


# ---- Sobol -------------------------------------------------------------------
class Sobol:
    def __init__(self, path):
        self.lines = open(path).read().split("\n")[1:]
        self.cache = {}

    def directions(self, j):
        """v_1..v_32 of dimension j (0-based), from m_k (Joe & Kuo eq. 3)."""
        if j in self.cache:
            return self.cache[j]
        if j == 0:
            m = [1] * 32
        else:
            f = self.lines[j - 1].split()
            s, a = int(f[1]), int(f[2])
            m = [int(t) for t in f[3:3 + s]]
            abits = [(a >> (s - 1 - i)) & 1 for i in range(1, s)]  # a_1..a_{s-1}
            for k in range(s, 32):
                x = (m[k - s] << s) ^ m[k - s]
                for i in range(1, s):
                    if abits[i - 1]:
                        x ^= m[k - i] << i
                m.append(x)
        v = [m[k] << (31 - k) for k in range(32)]  # v_{k+1} = m_{k+1} 2^(32-(k+1))
        self.cache[j] = v
        return v

    def bits(self, i, j, scramble, seed, shuffle):
        if shuffle:
            i = nested(i, hash3(seed, 0, TAG["shuffle"]) & M32)
        v = self.directions(j)
        x = 0
        for k in range(32):
            if (i >> k) & 1:
                x ^= v[k]
        if scramble == "shift":
            return x ^ (hash3(seed, j, TAG["shift"]) & M32)
        if scramble == "owen":
            return nested(x, hash3(seed, j, TAG["owen"]) & M32)
        if scramble == "fast-owen":
            return nested(x, fast_owen_seed(seed, j))
        return x


# ---- Halton / Hammersley ---------------------------------------------------------
def primes(n):
    out, c = [], 2
    while len(out) < n:
        if all(c % p for p in out if p * p <= c):
            out.append(c)
        c += 1
    return out


def faure_table(b, memo={2: [0, 1]}):
    """sigma_b as a whole array (Faure 1992)."""
    if b in memo:
        return memo[b]
    if b == 1:
        return [0]
    if b % 2 == 0:
        h = faure_table(b // 2)
        t = [2 * x for x in h] + [2 * x + 1 for x in h]
    else:
        c = (b - 1) // 2
        prev = [x + 1 if x >= c else x for x in faure_table(b - 1)]
        t = prev[:c] + [c] + prev[c:]
    memo[b] = t
    return t


def digits(i, b, n):
    out = []
    for _ in range(n):
        out.append(i % b)
        i //= b
    return out


def radical(i, b, dim_seed_index, scramble, seed):
    if scramble == "owen":
        kmax = 0
        while b ** (kmax + 1) <= 1 << 53:
            kmax += 1
        o = hash3(seed, dim_seed_index, TAG["owen"]) & M32
        r, p = 0, 1
        for k, d in enumerate(digits(i, b, kmax)):
            r = r * b + permute(d, b, hash3(o, k, p))
            p = p * b + d
        return below_one(float(Fraction(r, b ** kmax)))
    K = 0
    while b ** K < 1 << 32:
        K += 1
    ds = digits(i, b, K)
    if scramble == "faure":
        sig = faure_table(b)
        ds = [sig[d] for d in ds]
    return float(sum(Fraction(d, b ** (k + 1)) for k, d in enumerate(ds)))


PRIMES = primes(4096)


def halton(i, j, scramble, seed):
    return radical(i, PRIMES[j], j, scramble, seed)


def hammersley(i, j, n, scramble, seed):
    if j == 0:
        return i / n
    return radical(i, PRIMES[j - 1], j, scramble, seed)


# ---- the others -----------------------------------------------------------------
def rand(i, j, seed):
    return u01(hash3(seed, i, j))


def stratified(i, j, n, dims, seed):
    k = 1
    while (k + 1) ** dims <= n:
        k += 1
    digit = (i // k ** j) % k if k > 1 else 0
    return below_one((float(digit) + u01(hash3(seed ^ TAG["jitter"], i, j))) / float(k))


def lhs(i, j, n, seed):
    stratum = permute(i, n, hash3(seed, j, TAG["perm"]))
    return below_one((float(stratum) + u01(hash3(seed ^ TAG["jitter"], i, j))) / float(n))


# ---- the comparison -----------------------------------------------------------------
def run(qmc, args, fmt):
    out = subprocess.run([qmc, "points"] + args + ["--format", fmt],
                         check=True, capture_output=True).stdout
    code = {"f64": "d", "u32": "I", "f32": "f"}[fmt]
    return list(struct.unpack("<%d%s" % (len(out) // struct.calcsize(code), code), out))


def f32_of(x):
    return float(int(x * 2.0 ** 24)) * 2.0 ** -24


def main():
    qmc, table = sys.argv[1], sys.argv[2]
    cases = int(sys.argv[3]) if len(sys.argv) > 3 else 400
    rng = random.Random(int(sys.argv[4]) if len(sys.argv) > 4 else 20261201)
    sob = Sobol(table)
    passed = failed = 0

    def check(what, got, want):
        nonlocal passed, failed
        if got == want:
            passed += 1
        else:
            failed += 1
            if failed <= 20:
                print("FAIL %s: qmc %r, oracle %r" % (what, got, want))

    kinds = ["sobol", "halton", "hammersley", "random", "stratified", "lhs"]
    for c in range(cases):
        kind = kinds[c % len(kinds)]
        seed = rng.choice([0, 1, 7, rng.getrandbits(32), rng.getrandbits(64)])
        count = rng.choice([1, 2, 3, 5, 9])  # 1-2 take the per-point path, more the batch fill
        fmt = "f64"
        args = ["--seq", kind, "--seed", str(seed), "--count", str(count)]
        if kind == "sobol":
            dims = rng.choice([1, 2, 3, 7, 8, 9, 31, 32, 33, 100, rng.randrange(1, 21202)])
            scramble = rng.choice(["none", "shift", "owen"])
            shuffle = rng.random() < 0.25
            start = rng.choice([0, rng.randrange(1 << 10), rng.randrange((1 << 32) - count)])
            fmt = rng.choice(["u32", "f64", "f32"])
            args += ["--dims", str(dims), "--scramble", scramble, "--start", str(start)]
            args += ["--shuffle"] if shuffle else []
            # Checking every coordinate of a 21201-dim point costs the
            # oracle seconds: a random sample of 24 dimensions per case.
            js = sorted(rng.sample(range(dims), min(dims, 24)))

            def want(i, j):
                y = sob.bits(i, j, scramble, seed, shuffle)
                return {"u32": y, "f64": y * 2.0 ** -32, "f32": f32_of(y * 2.0 ** -32)}[fmt]
        elif kind in ("halton", "hammersley"):
            dims = rng.choice([1, 2, 5, 10, 40, rng.randrange(1, 4097)])
            scramble = rng.choice(["none", "faure", "owen"])
            start = rng.choice([0, rng.randrange(1 << 12), rng.randrange((1 << 32) - count)])
            js = sorted(rng.sample(range(dims), min(dims, 24)))
            args += ["--dims", str(dims), "--scramble", scramble, "--start", str(start)]
            if kind == "halton":
                def want(i, j):
                    return halton(i, j, scramble, seed)
            else:
                n = start + count + rng.choice([0, 1, 1000])
                args += ["--set-size", str(n)]

                def want(i, j):
                    return hammersley(i, j, n, scramble, seed)
        elif kind == "random":
            dims = rng.choice([1, 3, 16, 1000])
            start = rng.choice([0, rng.randrange((1 << 32) - count)])
            js = sorted(rng.sample(range(dims), min(dims, 24)))
            args += ["--dims", str(dims), "--start", str(start)]

            def want(i, j):
                return rand(i, j, seed)
        elif kind == "stratified":
            dims = rng.choice([1, 2, 3, 4])
            k = rng.choice([1, 2, 3, 7, 16])
            n = k ** dims
            count = min(count, n)
            start = rng.randrange(n - count + 1)
            js = list(range(dims))
            args += ["--dims", str(dims), "--set-size", str(n), "--start", str(start)]
            args[args.index("--count") + 1] = str(count)

            def want(i, j):
                return stratified(i, j, n, dims, seed)
        else:
            dims = rng.choice([1, 2, 5, 20])
            n = rng.choice([count, 10, 1000, rng.randrange(count, 1 << 32)])
            start = rng.randrange(n - count + 1)
            js = sorted(rng.sample(range(dims), min(dims, 24)))
            args += ["--dims", str(dims), "--set-size", str(n), "--start", str(start)]

            def want(i, j):
                return lhs(i, j, n, seed)
        if kind != "sobol":
            fmt = rng.choice(["f64", "f64", "u32", "f32"])
            want_x = want

            def want(i, j):
                x = want_x(i, j)
                return {"f64": x, "u32": int(x * 2.0 ** 32), "f32": f32_of(x)}[fmt]
        got = run(qmc, args, fmt)
        if len(got) != count * dims:
            check("%s: %d values" % (" ".join(args), count * dims), len(got), count * dims)
            continue
        for p in range(count):
            for j in js:
                check("%s %s index %d dim %d" % (" ".join(args), fmt, start + p, j),
                      got[p * dims + j], want(start + p, j))
    # fast-owen, from its own random stream so that the cases above stay
    # the ones they always were: seeds on both sides of 2^32 (4 or 8 seed
    # bytes in the hash), counts past 8 * dims (the packed fill) too.
    frng = random.Random(rng.getrandbits(64))
    for c in range(max(cases // 8, 20)):
        seed = frng.choice([0, 1, 7, M32, 1 << 32, frng.getrandbits(32), frng.getrandbits(64)])
        dims = frng.choice([1, 2, 3, 5, 8, 9, 16, 31, 32, 33, 100, frng.randrange(1, 21202)])
        count = frng.choice([1, 2, 3, 9, 8 * dims + 5]) if dims < 32 else frng.choice([1, 3, 9])
        start = frng.choice([0, frng.randrange(1 << 10), frng.randrange((1 << 32) - count)])
        shuffle = frng.random() < 0.2
        fmt = frng.choice(["u32", "f64", "f32"])
        args = ["--seq", "sobol", "--seed", str(seed), "--count", str(count), "--dims", str(dims),
                "--scramble", "fast-owen", "--start", str(start)] + (["--shuffle"] if shuffle else [])
        js = sorted(frng.sample(range(dims), min(dims, 24)))
        ps = sorted(frng.sample(range(count), min(count, 12)))
        got = run(qmc, args, fmt)
        if len(got) != count * dims:
            check("%s: %d values" % (" ".join(args), count * dims), len(got), count * dims)
            continue
        for p in ps:
            for j in js:
                y = sob.bits(start + p, j, "fast-owen", seed, shuffle)
                want = {"u32": y, "f64": y * 2.0 ** -32, "f32": f32_of(y * 2.0 ** -32)}[fmt]
                check("%s %s index %d dim %d" % (" ".join(args), fmt, start + p, j),
                      got[p * dims + j], want)
    print("seq_oracle: %d passed, %d failed" % (passed, failed))
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
