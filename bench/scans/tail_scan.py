#!/usr/bin/python3
"""Silent misses of plain MC on an endpoint singularity, over seeds.

Runs `qmc integrate --integrand NAME --dims 1 --method mc --n N --seed S`
for S = 1..SEEDS and counts, against the closed form the CLI prints:
  miss    |est - exact| > 3 reported errors
  flagged error_unreliable set (heavy_tail or another)
  silent  a miss without error_unreliable
  ci_silent  the truth outside the printed interval, unflagged.
Usage: tail_scan.py QMC NAME N [SEEDS] [METHOD]
"""
import json, subprocess, sys

qmc, name, n = sys.argv[1], sys.argv[2], sys.argv[3]
seeds = int(sys.argv[4]) if len(sys.argv) > 4 else 100
method = sys.argv[5] if len(sys.argv) > 5 else "mc"
miss = flagged = silent = heavy = ci_silent = 0
for seed in range(1, seeds + 1):
    dims = "1"
    extra = []
    if name.startswith("genz-"):
        dims = str(1 + seed % 4)
        extra = ["--difficulty", "fixed"]
    cmd = [qmc, "integrate", "--integrand", name, "--dims", dims, "--method", method,
           "--n", n, "--seed", str(seed), "--json"] + extra
    r = json.loads(subprocess.run(cmd, capture_output=True, text=True, check=True).stdout)
    err = r["stderr"] if r["stderr"] is not None else float("inf")
    bad = not (r["abs_error"] <= 3 * err)
    fl = "error_unreliable" in r["flags"]
    miss += bad
    flagged += fl
    heavy += "heavy_tail" in r["flags"]
    silent += bad and not fl
    ci_silent += not (r["ci_low"] <= r["exact"] <= r["ci_high"]) and not fl
print("%s %s n=%s seeds=%d miss=%d flagged=%d heavy_tail=%d silent=%d ci_silent=%d"
      % (method, name, n, seeds, miss, flagged, heavy, silent, ci_silent))
