#!/usr/bin/python3
"""Scan narrow Genz peaks for silent misses of a deterministic rule.

Draws genz-gaussian (or another family) cases with a log-uniform in
[A_LO, A_HI] per axis, u uniform, d = 1..3, runs `qmc integrate --json`
with the given method and classifies each against the closed form the CLI
prints as "exact" (core/genz.c, checked against scipy in test_testfn):
  ok      |est - exact| <= 3 * error bar
  flagged error_unreliable is set (the bar says it cannot tell)
  silent  neither: a wrong answer with a trusted bar.
A_LO = 0 draws ordinary parameters instead (--difficulty testpack).
Usage: peak_scan.py QMC METHOD [CASES] [SEED] [FAMILY] [A_LO] [A_HI]
"""
import json, math, random, subprocess, sys

qmc, method = sys.argv[1], sys.argv[2]
cases = int(sys.argv[3]) if len(sys.argv) > 3 else 60
seed = int(sys.argv[4]) if len(sys.argv) > 4 else 1
family = sys.argv[5] if len(sys.argv) > 5 else "genz-gaussian"
a_lo = float(sys.argv[6]) if len(sys.argv) > 6 else 30.0
a_hi = float(sys.argv[7]) if len(sys.argv) > 7 else 3000.0
extra = sys.argv[8].split() if len(sys.argv) > 8 else []
rng = random.Random(seed)
counts = {"ok": 0, "flagged": 0, "silent": 0, "ok_flagged": 0}
evals = 0
secs = 0.0
for i in range(cases):
    d = rng.randint(1, 3)
    if a_lo <= 0:  # ordinary parameters: Genz's testpack draw from the seed, d = 1..5
        d = rng.randint(1, 5)
        a, u = [0.0], [0.0]
        cmd = [qmc, "integrate", "--integrand", family, "--dims", str(d),
               "--difficulty", "testpack", "--seed", str(seed * 1000 + i),
               "--method", method, "--max-evals", "20000000", "--json"] + extra
    else:
        a = [math.exp(rng.uniform(math.log(a_lo), math.log(a_hi))) for _ in range(d)]
        u = [rng.random() for _ in range(d)]
        cmd = [qmc, "integrate", "--integrand", family, "--dims", str(d),
               "--a", ",".join("%.6g" % v for v in a),
               "--u", ",".join("%.6g" % v for v in u),
               "--method", method, "--max-evals", "20000000", "--seed", "12345",
               "--json"] + extra
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        print("refused", " ".join(cmd[2:]), p.stderr.strip())
        counts.setdefault("refused", 0)
        counts["refused"] += 1
        continue
    r = json.loads(p.stdout)
    err = r["error_estimate"] if r["error_estimate"] is not None else math.inf
    bad = not (r["abs_error"] <= 3 * err)
    flagged = "error_unreliable" in r["flags"]
    evals += r["evals"]
    secs += r["seconds"]
    if bad and not flagged:
        counts["silent"] += 1
        print("SILENT d=%d a=%s u=%s est=%.4g err=%.2g exact=%.4g flags=%s evals=%d"
              % (d, ",".join("%.4g" % v for v in a), ",".join("%.4g" % v for v in u),
                 r["estimate"], err, r["exact"], r["flags"], r["evals"]))
    elif flagged:
        counts["flagged"] += 1
        if not bad:
            counts["ok_flagged"] += 1
    else:
        counts["ok"] += 1
print(method, family, "cases", cases, counts, "evals", evals, "seconds %.3f" % secs)
