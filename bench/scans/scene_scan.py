#!/usr/bin/python3
"""Scan random scenes for what the scene audit's mis_undersampled is worth.

Draws Phong scenes (kd, ks, a log-uniform exponent in 1..5000, a random
view), a sphere light (distance 0.5..20, radius 1e-3..0.9 of it) or a
square rect light (side 0.01..200, height 0.01..10, offset), a strategy
(uniform, brdf, light, mis-balance, mis-power, mis-max; beta 0.05, 0.5 or
2) and a method (mc or rqmc, --n N), runs `qmc integrate --scene --json`
and judges each run against the scene reference the CLI prints
(qmc_scene_reference, a closed form or a quadrature aiming at 1e-12):
  correct  |est - reference| <= 3 x the bar (+ 1e-9 of the reference)
  silent   wrong, no flag at all
and counts mis_undersampled (and any flag) on correct and wrong runs.
Usage: scene_scan.py QMC [RUNS] [SEED] [N]   (SCAN_VERBOSE=1: print the silent runs)
SCAN_METHODS=m1,m2 draws the method from that list instead (deterministic
rules too: their --n is points an axis, SCAN_RULE_N, default 64), to
measure what the rules' checks (rule_confirm.h, rule_pilot.h) leave.
"""
import json, math, os, random, subprocess, sys, tempfile

qmc = sys.argv[1]
runs = int(sys.argv[2]) if len(sys.argv) > 2 else 200
seed = int(sys.argv[3]) if len(sys.argv) > 3 else 1
n = sys.argv[4] if len(sys.argv) > 4 else "4096"
rng = random.Random(seed)
methods = os.environ.get("SCAN_METHODS", "mc,rqmc").split(",")
rule_n = os.environ.get("SCAN_RULE_N", "64")


def logu(a, b):
    return a * (b / a) ** rng.random()


def scene():
    kd = rng.random()
    ks = max((1 - kd) * rng.random(), 0.001)
    vz = 0.2 + 0.8 * rng.random()
    vp = 2 * math.pi * rng.random()
    vr = math.sqrt(1 - vz * vz)
    text = ("point 0 0 0\nnormal 0 0 1\nview %.6f %.6f %.6f\n"
            "brdf phong kd %.4f ks %.4f exponent %.3f\n"
            % (vr * math.cos(vp), vr * math.sin(vp), vz, kd, ks, logu(1, 5000)))
    if rng.random() < 0.5:
        d, th, ph = logu(0.5, 20), math.acos(0.1 + 0.9 * rng.random()), 2 * math.pi * rng.random()
        r = d * logu(1e-3, 0.9)
        text += ("light sphere center %.6f %.6f %.6f radius %.6g radiance 1\n"
                 % (d * math.sin(th) * math.cos(ph), d * math.sin(th) * math.sin(ph),
                    d * math.cos(th), r))
    else:
        w, h = logu(0.01, 200), logu(0.01, 10)
        ox, oy = (rng.random() - 0.5) * 2 * w, (rng.random() - 0.5) * 2 * w
        text += ("light rect corner %.6f %.6f %.6f edge1 0 %.6f 0 edge2 %.6f 0 0 radiance 1\n"
                 % (ox - w / 2, oy - w / 2, h, w, w))
    return text


counts = {k: 0 for k in ("correct", "wrong", "silent", "mis_correct", "mis_wrong",
                         "any_correct", "any_wrong")}
with tempfile.TemporaryDirectory() as tmp:
    path = os.path.join(tmp, "s.scene")
    done = 0
    while done < runs:
        with open(path, "w") as f:
            f.write(scene())
        strategy = rng.choice(["uniform", "brdf", "light", "mis-balance", "mis-power", "mis-max"])
        beta = rng.choice(["0.05", "0.5", "2"])
        method = rng.choice(methods)
        n_run = n if method in ("mc", "rqmc", "lhs", "stratified") else rule_n
        p = subprocess.run([qmc, "integrate", "--scene", path, "--strategy", strategy,
                            "--beta", beta, "--method", method, "--n", n_run,
                            "--seed", str(1000 + done), "--json"],
                           capture_output=True, text=True)
        if p.returncode != 0:
            continue  # a scene the parser refuses (light below the horizon...)
        done += 1
        r = json.loads(p.stdout)
        ref = r["reference"] if r.get("reference") is not None else r["exact"]
        est = r["estimate"]
        bar = r["stderr"] if r.get("stderr") is not None else r.get("error_estimate")
        ok = bar is not None and abs(est - ref) <= 3 * bar + 1e-9 * abs(ref)
        side = "correct" if ok else "wrong"
        counts[side] += 1
        counts["mis_" + side] += "mis_undersampled" in r["flags"]
        counts["any_" + side] += bool(r["flags"])
        if not ok and not r["flags"]:
            counts["silent"] += 1
            if os.environ.get("SCAN_VERBOSE"):
                print("silent: %s %s beta %s: %.6g +- %.3g against %.6g\n%s"
                      % (method, strategy, beta, est, bar, ref, open(path).read()),
                      file=sys.stderr)
print("%d runs (n %s, seed %d): correct %d (any flag %d, mis_undersampled %d), "
      "wrong %d (any flag %d, mis_undersampled %d), silent %d"
      % (runs, n, seed, counts["correct"], counts["any_correct"], counts["mis_correct"],
         counts["wrong"], counts["any_wrong"], counts["mis_wrong"], counts["silent"]))
