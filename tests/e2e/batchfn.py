#!/usr/bin/python3
"""batchfn.py - an integrand program for `qmc integrate --command`, as a
user would write one with numpy: reads whole batches (text rows or f64
with a count), answers each with f at every point.  Used by
tests/e2e/test_command_cli.sh and test_session_parts.sh.

Usage: batchfn.py FORMAT FUNC DIMS [ARG ...]; FORMAT text or f64; FUNC
ppeak (ARGs a and u, comma lists), prod, invsqrt or expsum.  Must not:
print anything but the values (stdout is the protocol)."""
import os, struct, sys
import numpy as np
fmt, func, d = sys.argv[1], sys.argv[2], int(sys.argv[3])
arg = [np.array([float(v) for v in s.split(",")]) for s in sys.argv[4:]]
def f(x):
    if func == "ppeak":                      # genz-product-peak, as core/genz.c
        a, u = arg
        w = 1.0 / (a * a)
        p = np.ones(len(x))
        for j in range(d):
            t = x[:, j] - u[j]
            p /= w[j] + t * t
        return p
    if func == "prod":                       # prod 2 x_j: integral 1
        return np.prod(2.0 * x, axis=1)
    if func == "invsqrt":                    # inv-sqrt, as core/testfn_1d.c
        with np.errstate(divide="ignore"):
            return 1.0 / np.sqrt(x[:, 0])
    if func == "expsum":                     # exp(x1 + ... + xd): (e - 1)^d
        return np.exp(x.sum(axis=1))
    sys.exit("batchfn.py: unknown function " + func)
inp, out = sys.stdin.buffer, sys.stdout.buffer
while True:
    if fmt == "f64":
        h = inp.read(4)
        if len(h) < 4:
            sys.exit(0)
        (n,) = struct.unpack("<I", h)
        x = np.frombuffer(inp.read(n * d * 8), dtype="<f8").reshape(n, d)
        out.write(f(x).astype("<f8").tobytes())
    else:
        rows = []
        while True:
            line = inp.readline()
            if not line:
                sys.exit(0)
            if line == b"\n":
                break
            rows.append(line)
        x = np.array(b"".join(rows).split(), dtype=float).reshape(-1, d)
        out.write(("\n".join(map(repr, f(x).tolist())) + "\n").encode())
    out.flush()
