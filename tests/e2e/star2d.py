#!/usr/bin/python3
"""star2d.py - the exact 2D star discrepancy of a point set, by brute force
over the grid of critical boxes: an oracle written apart from the C code.

    star2d.py SEED N STEPS CSV WANT

writes N points of NumPy's default_rng(SEED), rounded down to multiples of
1/(STEPS - 1) (so there are ties, and coordinates equal to 1), to CSV (one
"x,y" line each) and their star discrepancy to WANT (one number).  For
every corner (a, b) on the grid of coordinates and 1, the box [0, a) x
[0, b) and its closure bound the count; the largest gap is the answer.
"""
import sys

import numpy as np


def main(seed, n, steps, csv_path, want_path):
    rng = np.random.default_rng(int(seed))
    x = np.floor(rng.random((int(n), 2)) * int(steps)) / (int(steps) - 1)
    with open(csv_path, "w") as f:
        for row in x:
            f.write("%r,%r\n" % (float(row[0]), float(row[1])))
    gx = sorted(set(x[:, 0]) | {1.0})
    gy = sorted(set(x[:, 1]) | {1.0})
    best = 0.0
    for a in gx:
        for b in gy:
            o = np.sum((x[:, 0] < a) & (x[:, 1] < b)) / len(x)
            c = np.sum((x[:, 0] <= a) & (x[:, 1] <= b)) / len(x)
            best = max(best, a * b - o, c - a * b)
    with open(want_path, "w") as f:
        f.write("%r\n" % best)


if __name__ == "__main__":
    if len(sys.argv) != 6:
        sys.stderr.write(__doc__)
        sys.exit(2)
    main(*sys.argv[1:])
