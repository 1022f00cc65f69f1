#!/usr/bin/python3
"""An independent reference for the pixel samplers, frames included.

Written from docs/SEQUENCES.md ("Pixel samplers"), not from the C code:
Python's exact integers, the Joe-Kuo direction numbers through their m-form
recurrence, pbrt's digit loop as the docs state it, and the sobol sampler's
index found by searching its block for the point in the pixel (not by the
C code's GF(2) solve).  pbrt-v4's own values (pixels_pbrt.txt) prove frame
0; these vectors add every other frame, which pbrt has not, and prove the
page defines each value completely.

Usage: gen_pixel_oracle.py JOE_KUO_FILE > pixels_oracle.txt
Line format: SAMPLER SPP WIDTH HEIGHT SEED FRAME X Y SAMPLE DIM V
(V the 32-bit value); tests/unit/test_pixel_oracle.c checks every line.
"""
import random
import struct
import sys

M64 = (1 << 64) - 1
M32 = (1 << 32) - 1


# ---- pbrt-v4's pieces ----------------------------------------------------
def murmur(data):
    m, r = 0xC6A4A7935BD1E995, 47
    h = (len(data) * m) & M64
    full = len(data) // 8 * 8
    for off in range(0, full, 8):
        k = struct.unpack_from("<Q", data, off)[0]
        k = (k * m) & M64
        k ^= k >> r
        k = (k * m) & M64
        h ^= k
        h = (h * m) & M64
    tail = data[full:]
    if tail:
        h ^= int.from_bytes(tail, "little")
        h = (h * m) & M64
    h ^= h >> r
    h = (h * m) & M64
    h ^= h >> r
    return h


def phash(*words):
    return murmur(b"".join(struct.pack("<I", w & M32) for w in words))


def mix_bits(v):
    v ^= v >> 31
    v = (v * 0x7FB5D329728EA185) & M64
    v ^= v >> 27
    v = (v * 0x81DADEF4BC2DD44D) & M64
    v ^= v >> 33
    return v


def rev32(x):
    return int(format(x, "032b")[::-1], 2)


def fast_owen(v, seed):
    x = rev32(v)
    x ^= (x * 0x3D20ADEA) & M32
    x = (x + seed) & M32
    x = (x * ((seed >> 16) | 1)) & M32
    x ^= (x * 0x05526C56) & M32
    x ^= (x * 0x53A22864) & M32
    return rev32(x)


def permutation_element(i, l, p):
    w = l - 1
    for s in (1, 2, 4, 8, 16):
        w |= w >> s
    w &= M32
    while True:
        i ^= p
        i = (i * 0xE170893D) & M32
        i ^= p >> 16
        i ^= (i & w) >> 4
        i ^= p >> 8
        i = (i * 0x0929EB3F) & M32
        i ^= p >> 23
        i ^= (i & w) >> 1
        i = (i * (1 | p >> 27)) & M32
        i = (i * 0x6935FA69) & M32
        i ^= (i & w) >> 11
        i = (i * 0x74DCB303) & M32
        i ^= (i & w) >> 2
        i = (i * 0x9E501CC3) & M32
        i ^= (i & w) >> 2
        i = (i * 0xC860A3DF) & M32
        i &= w
        i ^= i >> 5
        if i < l:
            return ((i + p) & M32) % l


def morton2(x, y):
    m = 0
    for k in range(32):
        m |= ((x >> k) & 1) << (2 * k) | ((y >> k) & 1) << (2 * k + 1)
    return m


def frame_mix(f):
    return mix_bits((f * 0x9E3779B97F4A7C15) & M64)


def fh(h, F):
    return h if F == 0 else mix_bits(h ^ F)


PERM = [[int(c) for c in w] for w in
        "0123 0132 0213 0231 0321 0312 1023 1032 1203 1230 1320 1302 "
        "2103 2130 2013 2031 2301 2310 3120 3102 3210 3201 3021 3012".split()]


# ---- Sobol' matrices with 64 columns --------------------------------------
class Sobol:
    def __init__(self, path, dims):
        self.cols = [self._columns(None)]
        with open(path) as f:
            next(f)
            for line in f:
                if len(self.cols) >= dims:
                    break
                parts = [int(t) for t in line.split()]
                self.cols.append(self._columns((parts[1], parts[2], parts[3:])))

    @staticmethod
    def _columns(poly):
        """m_1 .. m_64 by Joe & Kuo's recurrence; column c = top 32 bits of
        m_(c+1) << (63 - c)."""
        if poly is None:
            m = [1] * 64
        else:
            s, a, m = poly[0], poly[1], list(poly[2])
            for k in range(s, 64):       # m[k] is m_(k+1)
                v = m[k - s] ^ (m[k - s] << s)
                for i in range(1, s):
                    if (a >> (s - 1 - i)) & 1:
                        v ^= m[k - i] << i
                m.append(v)
        return [((m[c] << (63 - c)) >> 32) & M32 for c in range(64)]

    def value(self, j, i):
        v, c = 0, 0
        while i:
            if i & 1:
                v ^= self.cols[j][c]
            i >>= 1
            c += 1
        return v


def ceil_log2(n):
    return (n - 1).bit_length()


# ---- the samplers, as docs/SEQUENCES.md defines them ----------------------
def zsobol(sob, spp, W, H, s, f, x, y, i, d):
    L, R, F = spp.bit_length() - 1, ceil_log2(max(W, H)), frame_mix(f)
    dim = d & ~1
    morton = (morton2(x, y) << L) | i
    odd = L % 2
    D = R + (L + 1) // 2
    salt = ((0x55555555 * dim) & M32) ^ F
    index = 0
    for t in range(D - 1, odd - 1, -1):
        b = 2 * t - odd
        p = (mix_bits((morton >> (b + 2)) ^ salt) >> 24) % 24
        index |= PERM[p][(morton >> b) & 3] << b
    if odd:
        index |= (morton & 1) ^ (mix_bits((morton >> 1) ^ salt) & 1)
    h = fh(phash(dim + 2, s), F)
    if d & 1:
        return fast_owen(sob.value(1, index), h >> 32)
    return fast_owen(sob.value(0, index), h & M32)


def padded(sob, spp, W, H, s, f, x, y, i, d):
    h = fh(phash(x, y, d & ~1, s), frame_mix(f))
    j = permutation_element(i, spp, h & M32)
    if d & 1:
        return fast_owen(sob.value(1, j), h >> 32)
    return fast_owen(sob.value(0, j), h & M32)


def sobol_index(sob, m, x, y, fs):
    if m == 0:
        return fs
    base = fs << (2 * m)
    for i in range(base, base + (1 << (2 * m))):
        if sob.value(0, i) >> (32 - m) == x and sob.value(1, i) >> (32 - m) == y:
            return i
    raise AssertionError("no point in the pixel")


def sobol(sob, spp, W, H, s, f, x, y, fs, d):
    m, F = ceil_log2(max(W, H)), frame_mix(f)
    index = sobol_index(sob, m, x, y, fs)
    w = (sob.value(d, index) << m) & M32 if d < 2 else sob.value(d, index)
    if f == 0:
        return w if d < 2 else fast_owen(w, phash(d, s) & M32)
    return fast_owen(w, mix_bits(phash(x, y, d, s) ^ F) & M32)


def main():
    rng = random.Random(20)
    sob = Sobol(sys.argv[1], 64)
    print("# pixels_oracle.txt: made by tests/vectors/gen_pixel_oracle.py from")
    print("# docs/SEQUENCES.md (independently of the C code); frames 0 and others.")
    print("# SAMPLER SPP WIDTH HEIGHT SEED FRAME X Y SAMPLE DIM V")
    frames = [0, 1, 2, 77, 0xFFFFFFFF]
    cases = [("zsobol", zsobol, [1, 2, 8, 16, 128, 256], [(64, 64), (1920, 1080), (3, 70000)]),
             ("padded-sobol", padded, [1, 3, 16, 100, 256, 1 << 32],
              [(64, 64), (100000, 7)]),
             ("sobol", sobol, [1, 16, 256], [(8, 8), (13, 5), (64, 32)])]
    for name, fn, spps, sizes in cases:
        for spp in spps:
            for (W, H) in sizes:
                for _ in range(6):
                    s = rng.choice([0, 7, 123456789, 2147483647, rng.getrandbits(32)])
                    f = rng.choice(frames)
                    x, y = rng.randrange(W), rng.randrange(H)
                    i = rng.randrange(spp if name != "sobol" else 1 << 20)
                    dmax = 40 if name == "sobol" else 1000
                    d = rng.randrange(dmax) if rng.random() < 0.7 else rng.randrange(4)
                    v = fn(sob, spp, W, H, s, f, x, y, i, d)
                    print(name, spp, W, H, s, f, x, y, i, d, v)


if __name__ == "__main__":
    main()
