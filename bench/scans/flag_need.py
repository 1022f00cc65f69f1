#!/usr/bin/python3
"""Which error_unreliable flags on correct runs did a wrong answer need?

A flag on a correct run is a false alarm only if the cell's bar holds
without it.  One run cannot say; many seeds of the same cell can.  This
runs `qmc stability` twice:
  1. the matrix as it is (--seeds 5, --quick if asked), and
  2. the randomized cells that carry error_unreliable on a correct run,
     K seeds each (default 100), with --strip-flags: every miss of 3 bars
     counts, flagged or not;
and calls a cell's flags *needed* when its misses in 2 are more than an
honest 3-sigma bar misses by chance: the matrix's own binomial test
(p = 1%, alpha = 1e-3; 6 or more of 100).  It prints, per cell, the misses
and the verdict, then the correct runs of 1 flagged error_unreliable,
split into cells that need the flag, cells that do not, and cells not
calibrated (deterministic rules: one run, nothing to repeat).
Usage: flag_need.py QMC [K] [--quick]    (about 25 CPU minutes at K = 100)
Nothing is written but stdout; the two JSON documents go to a temporary
directory that is removed.
"""
import json, math, subprocess, sys, tempfile

qmc = sys.argv[1]
k = int(sys.argv[2]) if len(sys.argv) > 2 and sys.argv[2].isdigit() else 100
quick = ["--quick"] if "--quick" in sys.argv else []

DETERMINISTIC = {"midpoint", "trapezoid", "simpson", "gauss-legendre", "gauss-kronrod",
                 "cubature", "clenshaw-curtis"}


def run(args):
    out = subprocess.run([qmc, "stability", "--json"] + quick + args, check=True,
                         capture_output=True, text=True).stdout
    return json.loads(out)


def needed_threshold(n, p=0.01, alpha=1e-3):
    """The smallest s with P(Bin(n, p) >= s) < alpha, as qmc_stab_silent_threshold."""
    tail, best = 0.0, n + 1
    for s in range(n, 0, -1):
        tail += math.comb(n, s) * p ** s * (1 - p) ** (n - s)
        if tail < alpha:
            best = s
        else:
            break
    return min(best, n)


def eu_correct(cell):
    return cell["flag_runs"]["flags"].get("error_unreliable", [0, 0])[0]


matrix = run([])
cells = [c for c in matrix["cells"] if not c["tiny"]]
doubt = [c for c in cells if eu_correct(c) and c["method"] not in DETERMINISTIC]
cases = sorted({c["case"] for c in doubt})
methods = sorted({c["method"] for c in doubt})
calib = run(["--seeds", str(k), "--strip-flags", "--cases", ",".join(cases),
             "--methods", ",".join(methods)])
verdict = {}
print("| cell | runs | misses of 3 bars, flags stripped | flags needed |")
print("|---|---|---|---|")
for c in calib["cells"]:
    fr = c["flag_runs"]
    n = fr["correct"] + fr["wrong"]
    key = (c["case"], c["method"])
    if n == 0 or not any(key == (d["case"], d["method"]) for d in doubt):
        continue
    t = needed_threshold(n)
    verdict[key] = fr["wrong"] >= t
    print("| %s %s | %d | %d | %s |" % (c["case"], c["method"], n, fr["wrong"],
                                        "yes" if verdict[key] else "no"))
correct = sum(c["flag_runs"]["correct"] for c in cells)
split = {"needed": 0, "not needed": 0, "not calibrated": 0}
for c in cells:
    key = (c["case"], c["method"])
    name = ("needed" if verdict[key] else "not needed") if key in verdict else "not calibrated"
    split[name] += eu_correct(c)
total = sum(split.values())
print()
print("correct runs %d, flagged error_unreliable %d (%.1f%%):" % (correct, total,
                                                                 100.0 * total / correct))
for name, v in split.items():
    print("  %-15s %4d (%.1f%% of the correct runs)" % (name, v, 100.0 * v / correct))
