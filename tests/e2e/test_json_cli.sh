#!/bin/sh
# test_json_cli.sh - `--json` of `qmc discrepancy`, `qmc spectrum` and
# `qmc ping`, parsed by Python's json module and checked field by field.
#
#   - discrepancy: every method's value against scipy.stats.qmc.discrepancy
#     (and bit for bit against the text output), `squared` and `exact` as
#     the help documents them, the point and dimension counts;
#   - spectrum: radial_power against a periodogram computed by NumPy from
#     the same points, and bit for bit against the --csv file; csv/png name
#     the files written, null when not asked for;
#   - ping: against a qmcd started here on a temporary Unix socket (waited
#     for through --ready-file, stopped by PID): the limits it was started
#     with, the Sobol fingerprint `qmc --version` prints, one rtt per PING;
#   - errors stay one line on stderr, exit 2, nothing on stdout, --json or
#     not.
# Env: QMC, QMCD (binaries).  Needs /usr/bin/python3 with python3-scipy.
# Prints "N passed, M failed" last; exits 1 if anything failed.
set -u
: "${QMC:?set QMC to the qmc binary}"
: "${QMCD:?set QMCD to the qmcd binary}"
PY=/usr/bin/python3
. "$(dirname "$0")/lib.sh"
# The daemon in $pid gets SIGTERM at exit unless the test has stopped it.
pid=
term_vars=pid

# check NAME FILE PYTHON-CODE [ARGS...]: runs the code with `j` the JSON
# object parsed from FILE (which must hold exactly one line) and sys.argv[1:]
# the ARGS; any exception or failed assert is a failure, reported by NAME.
check() {
    name=$1 file=$2 code=$3
    shift 3
    if "$PY" - "$file" "$@" >"$tmp/check.err" 2>&1 <<PYEOF
import json, math, sys
text = open(sys.argv[1]).read()
assert text.endswith("\n") and text.count("\n") == 1, "not one line: %r" % text[:200]
j = json.loads(text)
assert isinstance(j, dict), "not an object"
sys.argv = sys.argv[1:]
$code
PYEOF
    then ok; else bad "$name: $(tail -n 3 "$tmp/check.err")"; fi
}

# ---- discrepancy -------------------------------------------------------------
"$PY" - "$tmp/pts.csv" "$tmp/scipy.txt" <<'PYEOF'
import sys
import numpy as np
from scipy.stats import qmc
x = np.random.default_rng(12).random((150, 3))
with open(sys.argv[1], "w") as f:
    for row in x:
        f.write(",".join(repr(float(v)) for v in row) + "\n")
with open(sys.argv[2], "w") as f:
    for cli, m in (("l2-star", "L2-star"), ("cd", "CD"), ("wd", "WD"), ("md", "MD")):
        f.write("%s %r\n" % (cli, float(qmc.discrepancy(x, method=m))))
PYEOF
while read -r method want; do
    squared=True
    [ "$method" = l2-star ] && squared=False
    if "$QMC" discrepancy --method "$method" --in "$tmp/pts.csv" --json \
           >"$tmp/d.json" 2>"$tmp/err" && [ ! -s "$tmp/err" ]; then ok
    else bad "discrepancy $method --json: $(cat "$tmp/err")"; continue; fi
    text=$("$QMC" discrepancy --method "$method" --in "$tmp/pts.csv")
    check "discrepancy $method fields" "$tmp/d.json" '
want, text, squared = float(sys.argv[1]), sys.argv[2], sys.argv[3] == "True"
assert j["method"] == sys.argv[4], j["method"]
assert abs(j["value"] - want) <= 1e-10 * abs(want), (j["value"], want)
assert j["value"] == float(text), ("text and JSON differ", j["value"], text)
assert j["squared"] is squared, j["squared"]
assert j["exact"] is True, j["exact"]
assert j["points"] == 150 and j["dims"] == 3, (j["points"], j["dims"])
assert set(j) == {"method", "value", "squared", "exact", "points", "dims"}, sorted(j)
' "$want" "$text" "$squared" "$method"
done <"$tmp/scipy.txt"

# star: exact in 2D (brute force over the grid of critical boxes), a lower
# bound above it once the boxes are too many; stdin works with --json.
"$PY" "$(dirname "$0")/star2d.py" 5 30 9 "$tmp/star.csv" "$tmp/star.txt"
"$QMC" discrepancy --method star --json <"$tmp/star.csv" >"$tmp/d.json" 2>"$tmp/err"
check "star 2D" "$tmp/d.json" '
want = float(sys.argv[1])
assert abs(j["value"] - want) <= 1e-12, (j["value"], want)
assert j["exact"] is True and j["squared"] is False and j["method"] == "star", j
assert j["points"] == 30 and j["dims"] == 2, j
' "$(cat "$tmp/star.txt")"
"$QMC" points --seq sobol --dims 5 --count 3000 >"$tmp/p5.csv"
"$QMC" discrepancy --method star --json --in "$tmp/p5.csv" >"$tmp/d.json" 2>"$tmp/err"
check "star 5D is a bound" "$tmp/d.json" '
assert j["exact"] is False, j
assert 0 < j["value"] < 1 and j["dims"] == 5 and j["points"] == 3000, j
'
if grep -q 'lower bound' "$tmp/err"; then ok; else bad "star 5D --json: no stderr note"; fi

# ---- spectrum ----------------------------------------------------------------
# 200 Owen-scrambled Sobol points, 2 realisations (seeds 9 and 10), K = 6.
for s in 9 10; do
    "$QMC" points --seq sobol --dims 2 --scramble owen --seed $s --count 200 >"$tmp/sp$s.csv"
done
if "$QMC" spectrum --seq sobol --scramble owen --seed 9 --count 200 --reps 2 --freq 6 \
       --csv "$tmp/s.csv" --json >"$tmp/s.json" 2>"$tmp/err" && [ ! -s "$tmp/err" ] &&
   [ -s "$tmp/s.csv" ]; then ok; else bad "spectrum --json --csv: $(cat "$tmp/err")"; fi
check "spectrum fields and oracle" "$tmp/s.json" '
import numpy as np
csv_path, p9, p10 = sys.argv[1:4]
K = 6
assert (j["seq"], j["scramble"], j["seed"], j["dims"]) == ("sobol", "owen", 9, 2), j
assert (j["count"], j["reps"], j["freq"]) == (200, 2, K), j
assert j["csv"] == csv_path and j["png"] is None, (j["csv"], j["png"])
r = j["radial_power"]
assert len(r) == K + 1, len(r)
# The periodogram, by NumPy from the points qmc points wrote.
ks = np.arange(-K, K + 1)
kx, ky = np.meshgrid(ks, ks)
P = np.zeros(kx.shape)
for path in (p9, p10):
    x = np.loadtxt(path, delimiter=",")
    ph = np.exp(-2j * np.pi * (np.multiply.outer(x[:, 0], kx) + np.multiply.outer(x[:, 1], ky)))
    P += np.abs(ph.sum(axis=0)) ** 2 / len(x)
P /= 2
mag = np.sqrt(kx ** 2 + ky ** 2)
for b in range(K + 1):
    want = P[(mag >= b - 0.5) & (mag < b + 0.5)].mean()
    assert abs(r[b] - want) <= 1e-9 * max(1.0, abs(want)), (b, r[b], want)
assert r[0] == 200, r[0]
# The same numbers as the CSV, bit for bit.
rows = open(csv_path).read().split("\n")
assert rows[0] == "frequency,power", rows[0]
assert [float(line.split(",")[1]) for line in rows[1:] if line] == r, "CSV differs"
' "$tmp/s.csv" "$tmp/sp9.csv" "$tmp/sp10.csv"

# --json alone writes no file; --png alone keeps stdout empty, as before.
(cd "$tmp" && "$QMC" spectrum --seq halton --count 64 --freq 3 --json >"$tmp/h.json")
check "spectrum --json alone" "$tmp/h.json" '
assert j["csv"] is None and j["png"] is None and j["seq"] == "halton", j
assert j["scramble"] == "none" and len(j["radial_power"]) == 4, j
'
if [ "$(ls "$tmp" | grep -c '\.png$')" -eq 0 ]; then ok; else bad "spectrum --json alone wrote a PNG"; fi
"$QMC" spectrum --seq sobol --count 64 --freq 3 --png "$tmp/only.png" >"$tmp/out" 2>"$tmp/err"
if [ $? -eq 0 ] && [ ! -s "$tmp/out" ] && [ -s "$tmp/only.png" ] && [ ! -e "$tmp/s2.csv" ]
then ok; else bad "spectrum --png alone: $(cat "$tmp/err")"; fi

# ---- strings: the shared writer escapes what JSON requires ------------------------
# A scene file whose name holds a quote, a backslash and a tab: integrate's
# "integrand" member must give the exact name back.
odd="$tmp/a\"b\\c	d.scene"
printf 'point 0 0 0\nnormal 0 0 1\nbrdf lambert 0.8\nlight sphere center 1 0.5 5 radius 0.6 radiance 10\n' >"$odd"
"$QMC" integrate --scene "$odd" --method rqmc --n 256 --json >"$tmp/i.json" 2>"$tmp/err"
check "escaped string" "$tmp/i.json" '
assert j["integrand"] == sys.argv[1], (j["integrand"], sys.argv[1])
' "$odd"

# ---- errors: one line, exit 2, nothing on stdout --------------------------------
expect_fail() { # NAME STDIN-TEXT ARGS...
    name=$1 input=$2
    shift 2
    printf '%b' "$input" | "$QMC" "$@" >"$tmp/out" 2>"$tmp/err"
    rc=$?
    if [ "$rc" -eq 2 ] && [ "$(wc -l <"$tmp/err")" -eq 1 ] && [ ! -s "$tmp/out" ]; then ok
    else bad "$name: rc=$rc, stderr '$(cat "$tmp/err")', stdout '$(cat "$tmp/out")'"; fi
}
expect_fail "discrepancy --json bad input" '0.1,0.2\n0.3\n' discrepancy --method cd --json
expect_fail "discrepancy --json=x" '0.5\n' discrepancy --method cd --json=x
expect_fail "spectrum nothing to write" '' spectrum --seq sobol --count 8
expect_fail "spectrum --json bad kind" '' spectrum --seq nope --count 8 --json
expect_fail "ping --json without a daemon" '' ping --json
expect_fail "ping --json unreachable" '' ping --json --connect "unix:$tmp/nobody.sock"

# ---- ping, against a daemon started here ---------------------------------------
"$QMCD" --foreground --listen "unix:$tmp/qmcd.sock" --threads 1 --ready-file "$tmp/ready" \
    --max-frame 262144 --max-inflight 5 --max-points 123456 2>"$tmp/qmcd.log" &
pid=$!
i=0
while [ ! -s "$tmp/ready" ] && kill -0 "$pid" 2>/dev/null && [ $i -lt 2000 ]; do
    sleep 0.01
    i=$((i + 1))
done
if [ -s "$tmp/ready" ]; then
    ok
    fingerprint=$("$QMC" --version | sed -n 's/^Sobol table fingerprint: //p')
    if "$QMC" ping --connect "unix:$tmp/qmcd.sock" --count 3 --json >"$tmp/p.json" 2>"$tmp/err" &&
       [ ! -s "$tmp/err" ]; then ok; else bad "ping --json: $(cat "$tmp/err")"; fi
    check "ping fields" "$tmp/p.json" '
fp = sys.argv[1]
assert len(fp) == 16, fp
assert j["server"] == "qmcd" and j["engine"].startswith("libqmc "), (j["server"], j["engine"])
assert j["sobol_table"] == fp and j["sobol_table_matches"] is True, (j["sobol_table"], fp)
assert (j["max_frame_bytes"], j["max_inflight"], j["max_points"]) == (262144, 5, 123456), j
assert len(j["rtt_ms"]) == 3 and all(isinstance(t, float) and t > 0 for t in j["rtt_ms"]), j["rtt_ms"]
' "$fingerprint"
    # QMC_ENDPOINT works for --json too, and the text still says the same.
    QMC_ENDPOINT="unix:$tmp/qmcd.sock" "$QMC" ping --json >"$tmp/p1.json" 2>"$tmp/err"
    check "ping --json via QMC_ENDPOINT" "$tmp/p1.json" '
assert len(j["rtt_ms"]) == 1, j
'
    "$QMC" ping --connect "unix:$tmp/qmcd.sock" >"$tmp/p.txt"
    if grep -q "^sobol      $fingerprint (the same table as this qmc)$" "$tmp/p.txt"
    then ok; else bad "ping text: $(cat "$tmp/p.txt")"; fi
else
    bad "qmcd not ready: $(cat "$tmp/qmcd.log")"
fi
if [ -n "$pid" ]; then
    kill "$pid"
    if wait "$pid"; then ok; else bad "qmcd exited non-zero on SIGTERM"; fi
    pid=
fi

finish
