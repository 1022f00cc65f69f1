"""cmdprog.py NAME - a program for `qmc integrate --command`: it reads
batches in the f64 format (a little-endian u32 count, then count x D
little-endian doubles; docs/SESSIONS.md) on stdin and writes integrands.
FUNCS[NAME] at each point, count little-endian doubles, until its input
ends.  test_sessions.py compares the CLI's report of it with the Python
client's for the same function, byte for byte.

Must not: write anything but the values to stdout, or read ahead of the
batch it answers.
"""
import os
import struct
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from integrands import FUNCS  # noqa: E402


def read_exact(f, n):
    out = bytearray()
    while len(out) < n:
        b = f.read(n - len(out))
        if not b:
            return None
        out += b
    return bytes(out)


def main():
    dims, f = FUNCS[sys.argv[1]]
    inp, out = sys.stdin.buffer, sys.stdout.buffer
    while True:
        head = read_exact(inp, 4)
        if head is None:
            return
        n = struct.unpack("<I", head)[0]
        x = np.frombuffer(read_exact(inp, 8 * n * dims), dtype="<f8").reshape(n, dims)
        out.write(np.asarray(f(x), dtype="<f8").tobytes())
        out.flush()


if __name__ == "__main__":
    main()
