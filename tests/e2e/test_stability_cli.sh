#!/bin/sh
# End-to-end checks of `qmc stability` on a small slice of its matrix:
#   - --out writes stability.csv (the named columns, one row a cell),
#     REPORT.md (the count of silent cells, the matrix table), the heat map
#     as PNG and SVG; --json is one JSON object with the same counts;
#   - the references are independent: closed forms checked here against
#     scipy (python3-scipy) for the Gaussian peak and the step;
#   - the classification catches a deliberately wrong method: with
#     --strip-flags (every flag dropped) a case whose answer is wrong must
#     come out SILENT and --fail-on-silent must exit 1, while an honest
#     control cell stays OK;
#   - the matrix is the same on 1 and 2 threads (but for the seconds);
#   - bad input: one line on stderr, exit 2, nothing left in --out.
# Env: QMC (binary).  Prints "N passed, M failed".
set -u
: "${QMC:?QMC must name the qmc binary}"
. "$(dirname "$0")/lib.sh"
PY=/usr/bin/python3

CASES=jump-step-1d,peak-gauss-1d,overflow-disc-2d,jump-disc-2d
METHODS=gauss-legendre,mc,qmc/sobol/none,rqmc/sobol/owen
"$QMC" stability --quick --cases $CASES --methods $METHODS --out "$tmp/st" \
    > "$tmp/summary.txt" 2> "$tmp/err.txt"
rc=$?
[ $rc -eq 0 ] && ok || bad "stability exited $rc: $(cat "$tmp/err.txt")"
for f in stability.csv REPORT.md stability.png stability.svg stability.gp; do
    [ -s "$tmp/st/$f" ] && ok || bad "no $f"
done
ls -a "$tmp/st" | grep -q '\.tmp' && bad "temporary files left in --out" || ok

# PNG signature and an SVG document
head -c 8 "$tmp/st/stability.png" | od -An -tx1 | grep -q '89 50 4e 47 0d 0a 1a 0a' && ok ||
    bad "stability.png is not a PNG"
grep -q '<svg' "$tmp/st/stability.svg" && ok || bad "stability.svg is not SVG"

# The CSV: named columns, 4 x 4 cells
head -n 1 "$tmp/st/stability.csv" | grep -q '^case,category,method,class,runs,ok_runs,ok_flagged_runs,flagged_runs,refused_runs,silent_runs,seed,method_used,estimate,error_kind,reported_error,truth,truth_error,truth_source,abs_error,ratio,flags,evals,seconds,reason$' &&
    ok || bad "stability.csv header: $(head -n 1 "$tmp/st/stability.csv")"
rows=$(($(wc -l < "$tmp/st/stability.csv") - 1))
[ "$rows" -eq 16 ] && ok || bad "stability.csv has $rows cells, want 16"
# every class is one of the four
bad_class=$(awk -F, 'NR > 1 && $4 !~ /^(OK|FLAGGED|REFUSED|SILENT)$/' "$tmp/st/stability.csv")
[ -z "$bad_class" ] && ok || bad "unknown classes: $bad_class"

# REPORT.md states the silent count and holds the matrix
silent=$(awk -F, 'NR > 1 && $4 == "SILENT"' "$tmp/st/stability.csv" | wc -l)
grep -q "^\*\*Silent cells: $silent\.\*\*" "$tmp/st/REPORT.md" && ok ||
    bad "REPORT.md does not say 'Silent cells: $silent'"
grep -q '^| case | gauss-legendre | mc | qmc/sobol/none | rqmc/sobol/owen |$' "$tmp/st/REPORT.md" &&
    ok || bad "REPORT.md has no matrix header"
grep -q "SILENT $silent" "$tmp/summary.txt" && ok || bad "summary does not count $silent silent"

# Independent references: scipy against the truth column
if $PY -c 'import scipy' 2>/dev/null; then
    want=$($PY -c '
from scipy.integrate import quad
import math
print("%.12e" % quad(lambda x: math.exp(-300**2 * (x - 0.37)**2), 0, 1, points=[0.37], epsabs=0, epsrel=1e-13, limit=200)[0])')
    got=$(awk -F, '$1 == "peak-gauss-1d" && $3 == "mc" { print $16 }' "$tmp/st/stability.csv")
    $PY -c "import sys; sys.exit(0 if abs($got - $want) <= 1e-5 * $want else 1)" && ok ||
        bad "peak-gauss-1d truth $got, scipy $want"
else
    bad "python3-scipy is missing (a test peer)"
fi
got=$(awk -F, '$1 == "jump-step-1d" && $3 == "mc" { print $16 }' "$tmp/st/stability.csv")
[ "$got" = "0.7071" ] && ok || bad "jump-step-1d truth $got, want 0.7071"
# the overflowing integral has no finite truth
got=$(awk -F, '$1 == "overflow-disc-2d" && $3 == "mc" { print $16 }' "$tmp/st/stability.csv")
[ "$got" = "inf" ] && ok || bad "overflow-disc-2d truth '$got', want inf"

# A deliberately wrong method: flags stripped, the overflowing integral's
# finite estimate must be SILENT, and the gate must fail; the honest
# control (rqmc on a jump, a covered bar) stays OK.
"$QMC" stability --quick --cases overflow-disc-2d,jump-disc-2d --methods mc,rqmc/sobol/owen \
    --strip-flags --fail-on-silent --out "$tmp/strip" > "$tmp/strip.txt" 2>&1
rc=$?
[ $rc -eq 1 ] && ok || bad "--fail-on-silent with silent cells exited $rc, want 1"
cls=$(awk -F, '$1 == "overflow-disc-2d" && $3 == "mc" { print $4 }' "$tmp/strip/stability.csv")
[ "$cls" = "SILENT" ] && ok || bad "stripped overflow-disc-2d x mc is '$cls', want SILENT"
cls=$(awk -F, '$1 == "jump-disc-2d" && $3 == "rqmc/sobol/owen" { print $4 }' "$tmp/strip/stability.csv")
[ "$cls" = "OK" ] && ok || bad "jump-disc-2d x rqmc is '$cls', want OK"
# without stripping, the same overflow cell is caught by its flags
"$QMC" stability --quick --cases overflow-disc-2d --methods mc --fail-on-silent > "$tmp/flag.txt" 2>&1
rc=$?
[ $rc -eq 0 ] && ok || bad "flagged overflow cell failed the gate (rc $rc): $(cat "$tmp/flag.txt")"

# JSON: one object, the same counts as the CSV
"$QMC" stability --quick --cases $CASES --methods $METHODS --json > "$tmp/st.json" 2> /dev/null
$PY - "$tmp/st.json" "$silent" <<'PYEOF' && ok || bad "JSON output"
import json, sys
d = json.load(open(sys.argv[1]))
assert d["counts"]["SILENT"] == int(sys.argv[2]), d["counts"]
assert len(d["cells"]) == 16
assert sum(d["counts"].values()) == 16
# what each flag was worth: counts within the runs they are shares of
for budget in ("normal_budget", "tiny_budget"):
    fp = d["flag_precision"][budget]
    for key, (on_ok, on_bad) in fp["flags"].items():
        assert 0 <= on_ok <= fp["correct"] and 0 <= on_bad <= fp["wrong"], (key, fp)
assert d["flag_precision"]["normal_budget"]["correct"] + \
    d["flag_precision"]["normal_budget"]["wrong"] > 0
# each cell's own flag counts add up to the matrix's
for budget, tiny in (("normal_budget", False), ("tiny_budget", True)):
    fp = d["flag_precision"][budget]
    cells = [c["flag_runs"] for c in d["cells"] if c["tiny"] == tiny]
    assert sum(c["correct"] for c in cells) == fp["correct"], budget
    assert sum(c["wrong"] for c in cells) == fp["wrong"], budget
    for key, (on_ok, on_bad) in fp["flags"].items():
        assert sum(c["flags"].get(key, [0, 0])[0] for c in cells) == on_ok, key
        assert sum(c["flags"].get(key, [0, 0])[1] for c in cells) == on_bad, key
PYEOF
grep -q '^## What each flag is worth' "$tmp/st/REPORT.md" && ok ||
    bad "REPORT.md lacks the per-flag section"
grep -q '^| error_unreliable | ' "$tmp/st/REPORT.md" && ok ||
    bad "REPORT.md has no error_unreliable row"

# Same matrix on one thread (seconds aside)
"$QMC" stability --quick --cases $CASES --methods $METHODS --threads 1 --out "$tmp/st1" \
    > /dev/null 2>&1
cut -d, -f1-22 "$tmp/st/stability.csv" > "$tmp/a.csv"
cut -d, -f1-22 "$tmp/st1/stability.csv" > "$tmp/b.csv"
cmp -s "$tmp/a.csv" "$tmp/b.csv" && ok || bad "1 and 2 threads differ"

# Bad input: one line, exit 2, --out untouched
expect_error() {
    want="$1"; shift
    rm -rf "$tmp/bad"
    "$QMC" stability "$@" > "$tmp/out.txt" 2> "$tmp/err.txt"
    rc=$?
    [ $rc -eq 2 ] || { bad "stability $* exited $rc, want 2"; return; }
    [ "$(wc -l < "$tmp/err.txt")" -eq 1 ] || { bad "stability $*: not one line: $(cat "$tmp/err.txt")"; return; }
    grep -q -- "$want" "$tmp/err.txt" || { bad "stability $*: '$(cat "$tmp/err.txt")' lacks '$want'"; return; }
    [ ! -s "$tmp/out.txt" ] || { bad "stability $*: wrote to stdout"; return; }
    [ ! -e "$tmp/bad" ] || { bad "stability $*: created --out"; return; }
    ok
}
expect_error "no case named 'nope'" --cases nope --out "$tmp/bad"
expect_error "not a column" --methods rqmc/halton/faure --out "$tmp/bad"
expect_error "unknown method" --methods bogus --out "$tmp/bad"
expect_error "--threads" --threads 0 --out "$tmp/bad"
expect_error "runs in-process" --connect unix:/nonexistent --out "$tmp/bad"
: > "$tmp/file"
"$QMC" stability --quick --cases jump-step-1d --methods mc --out "$tmp/file" > /dev/null 2> "$tmp/err.txt"
rc=$?
[ $rc -eq 2 ] && grep -q "not a directory" "$tmp/err.txt" && [ ! -s "$tmp/file" ] && ok ||
    bad "--out on a file: rc $rc, $(cat "$tmp/err.txt")"

"$QMC" stability --help | grep -q 'SILENT' && ok || bad "--help does not explain SILENT"

finish
