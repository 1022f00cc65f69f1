#!/usr/bin/python3
"""Scan random frequencies and peak positions for tensor-rule bars that lie.

Issue 23: regular grids alias, and two nested levels that see a frequency
at the same phase (or both miss a peak) agree, so |fine - coarse| says
"exact".  The tensor rules now check the bar (core/quad_tensor.c): sibling
levels at the sizes just above the coarse one, a rounding probe, and the
node watch's unresolved test against the rule's own integral of |f|
(core/rule_evidence.c).  This scan measures what each check catches.

Families (closed-form truths, printed by `qmc integrate --json` as "exact"):
  cos    cos(a x), d = 1, a uniform in [1, 400]
  osc    genz-oscillatory, d = 1..3, a_j uniform in [0, 150], u uniform
  gauss  genz-gaussian peaks, d = 1..3, a_j log-uniform in [30, 3000]
  pp     genz-product-peak, d = 1..3, a_j log-uniform in [10, 1e4]
  round  cos(a x), d = 1, a log-uniform in [10, 2e5], half of them rounded
         to 2 pi k (periodic: a grid sums them to 0 up to rounding), with
         n log-uniform in [100, 3e5] (the rounding class)
Other families get n from N_LIST (0: the rule's default, 16 or 17).

Each run is classified as the stability matrix does (docs/STABILITY.md):
  ok       |est - exact| <= 3 bars + 64 ulps of max(|exact|, int |f|)
  silent   not ok, and no flag at all
  flagged  not ok, some flag
and `false` counts ok runs that carry error_unreliable (a false alarm).
With QMC_BEFORE (a qmc without the check), each run is also made with it;
a run silent before and not after is "caught", by
  scale     the bar is the same (only the unresolved test's scale moved)
  rounding  roundoff is set (the probe's floor raised the bar)
  siblings  the bar grew without roundoff
and "new_false" counts runs ok and unflagged before, ok with
error_unreliable after.  evals before/after give the check's share.

Usage: alias_scan.py QMC METHOD FAMILY [CASES] [SEED] [N_LIST] [QMC_BEFORE]
"""
import json, math, random, subprocess, sys

qmc, method, family = sys.argv[1], sys.argv[2], sys.argv[3]
cases = int(sys.argv[4]) if len(sys.argv) > 4 else 100
seed = int(sys.argv[5]) if len(sys.argv) > 5 else 1
n_list = [int(v) for v in sys.argv[6].split(",")] if len(sys.argv) > 6 else [0]
before = sys.argv[7] if len(sys.argv) > 7 else None
rng = random.Random(seed)


def draw():
    n = rng.choice(n_list)
    if family == "cos":
        return "cos", 1, [rng.uniform(1, 400)], None, n
    if family == "round":
        a = math.exp(rng.uniform(math.log(10), math.log(2e5)))
        if rng.random() < 0.5:
            a = 2 * math.pi * round(a / (2 * math.pi))
        return "cos", 1, [a], None, int(math.exp(rng.uniform(math.log(100), math.log(3e5))))
    d = rng.randint(1, 3)
    u = [rng.random() for _ in range(d)]
    if family == "osc":
        return "genz-oscillatory", d, [rng.uniform(0, 150) for _ in range(d)], u, n
    lo, hi = (30, 3000) if family == "gauss" else (10, 1e4)
    a = [math.exp(rng.uniform(math.log(lo), math.log(hi))) for _ in range(d)]
    return "genz-gaussian" if family == "gauss" else "genz-product-peak", d, a, u, n


def run(q, name, d, a, u, n):
    cmd = [q, "integrate", "--integrand", name, "--dims", str(d),
           "--a", ",".join(repr(v) for v in a)]
    if u:
        cmd += ["--u", ",".join(repr(v) for v in u)]
    if n:
        cmd += ["--n", str(n + 1 if method == "simpson" and n % 2 == 0 else n)]
    cmd += ["--method", method, "--seed", "12345", "--json"]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        return None, cmd
    return json.loads(p.stdout), cmd


def classify(r):
    scale = max(abs(r["exact"]), r.get("abs_integral") or 0.0)
    ok = r["abs_error"] <= 3 * r["error_estimate"] + 64 * 2.220446049250313e-16 * scale
    if ok:
        return "false" if "error_unreliable" in r["flags"] else "ok"
    return "flagged" if r["flags"] else "silent"


counts = {"ok": 0, "false": 0, "flagged": 0, "silent": 0, "refused": 0}
before_counts = dict(counts)
caught = {"scale": 0, "rounding": 0, "siblings": 0}
new_false = 0
evals = [0, 0]
log_ratio, ratios = 0.0, 0
for i in range(cases):
    name, d, a, u, n = draw()
    r, cmd = run(qmc, name, d, a, u, n)
    if r is None:
        counts["refused"] += 1
        continue
    c = classify(r)
    counts[c] += 1
    evals[1] += r["evals"]
    if c == "silent":
        print("SILENT", " ".join(cmd[2:]), "est=%.6g err=%.3g exact=%.6g"
              % (r["estimate"], r["error_estimate"], r["exact"]))
    if before:
        b, _ = run(before, name, d, a, u, n)
        if b is None:
            before_counts["refused"] += 1
            continue
        cb = classify(b)
        before_counts[cb] += 1
        evals[0] += b["evals"]
        log_ratio += math.log(r["evals"] / b["evals"])
        ratios += 1
        if cb == "silent" and c != "silent":
            if "roundoff" in r["flags"]:
                caught["rounding"] += 1
            elif r["error_estimate"] > b["error_estimate"]:
                caught["siblings"] += 1
            else:
                caught["scale"] += 1
        if cb == "ok" and c == "false":
            new_false += 1
out = [method, family, "n=%s" % ",".join(map(str, n_list)), "cases", cases, "after", counts,
       "evals", evals[1]]
if before:
    out += ["before", before_counts, "evals", evals[0], "caught", caught, "new_false", new_false,
            "evals_ratio_geomean %.3f" % math.exp(log_ratio / max(ratios, 1))]
print(*out)
