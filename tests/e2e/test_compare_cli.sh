#!/bin/sh
# End-to-end checks of `qmc compare`:
#   - in-process: DIR gets compare.csv with the named columns and one row
#     a run (R seeds for randomized methods, one for the rules), the three
#     charts as PNG and SVG, REPORT.md with the time-budget and honesty
#     sections; a progress line goes to stderr;
#   - actual_error is |estimate - exact| with the exact value computed
#     here by scipy (independent of the C closed form);
#   - --connect runs the same jobs on a real qmcd (temporary Unix socket,
#     ready file, stopped by PID) and gets the same estimates, bit for bit;
#   - bad input: one line on stderr, exit 2, and DIR neither created nor
#     touched (an existing DIR keeps its files and gains none).
# Env: QMC, QMCD (binaries).  Prints "N passed, M failed".
set -u
: "${QMC:?QMC must name the qmc binary}"
: "${QMCD:?QMCD must name the qmcd binary}"
. "$(dirname "$0")/lib.sh"
# The daemon in $pid gets SIGTERM at exit unless the test has stopped it.
pid=
term_vars=pid
PY=/usr/bin/python3

JOB="--integrand genz-gaussian --dims 2 --a 3,4 --u 0.3,0.6"
METHODS=mc,rqmc/sobol/owen,gauss-legendre,cubature
"$QMC" compare $JOB --methods $METHODS --budgets 1e3:1e4 --reps 2 --out "$tmp/local" \
    > "$tmp/out.txt" 2> "$tmp/err.txt"
rc=$?
[ $rc -eq 0 ] && ok || bad "compare exited $rc: $(cat "$tmp/err.txt")"
for f in compare.csv REPORT.md error-time.png error-time.svg error-evals.png error-evals.svg \
         honesty.png honesty.svg; do
    [ -s "$tmp/local/$f" ] && ok || bad "no $f"
done
for f in error-time error-evals honesty; do
    head -c 8 "$tmp/local/$f.png" | od -An -tx1 | grep -q '89 50 4e 47' && ok || bad "$f.png"
    grep -q '<svg' "$tmp/local/$f.svg" && ok || bad "$f.svg"
done
grep -q 'qmc compare: run 1/' "$tmp/err.txt" && ok || bad "no progress line on stderr"
grep -q 'runs done' "$tmp/err.txt" && ok || bad "progress line does not finish"

head -n 1 "$tmp/local/compare.csv" | grep -q '^method,budget,rep,estimate,reported_error,actual_error,seconds,evals,flags' &&
    ok || bad "compare.csv header: $(head -n 1 "$tmp/local/compare.csv")"
# mc and rqmc: 2 budgets x 2 seeds; gauss-legendre and cubature: 2 budgets
rows=$(($(wc -l < "$tmp/local/compare.csv") - 1))
[ "$rows" -eq 12 ] && ok || bad "compare.csv has $rows runs, want 12"
[ "$(awk -F, '$1 == "mc"' "$tmp/local/compare.csv" | wc -l)" -eq 4 ] && ok || bad "mc rows"
[ "$(awk -F, '$1 == "gauss-legendre"' "$tmp/local/compare.csv" | wc -l)" -eq 2 ] && ok ||
    bad "gauss-legendre rows"
# evaluations never exceed the budget
over=$(awk -F, 'NR > 1 && $8 != "" && $8 + 0 > $2 + 0' "$tmp/local/compare.csv")
[ -z "$over" ] && ok || bad "runs over their budget: $over"

# actual_error against scipy's exact value
$PY - "$tmp/local/compare.csv" <<'PYEOF' && ok || bad "actual_error is not |estimate - exact|"
import csv, math, sys
from scipy.special import erf
exact = 1.0
for a, u in ((3, 0.3), (4, 0.6)):
    exact *= math.sqrt(math.pi) / (2 * a) * (erf(a * (1 - u)) + erf(a * u))
for row in csv.DictReader(open(sys.argv[1])):
    est, act = float(row["estimate"]), float(row["actual_error"])
    # (the CSV keeps 6 digits of actual_error)
    assert abs(act - abs(est - exact)) <= 1e-5 * abs(est - exact) + 1e-15, (row, exact)
PYEOF

grep -q '^## Which method is most accurate within each time budget' "$tmp/local/REPORT.md" &&
    ok || bad "REPORT.md lacks the time-budget section"
grep -q '^- \*\*Within .*\*\*: `' "$tmp/local/REPORT.md" && ok ||
    bad "REPORT.md names no winner for a time budget"
grep -q '^## How honest each method' "$tmp/local/REPORT.md" && ok ||
    bad "REPORT.md lacks the honesty section"
grep -q '`rqmc/sobol/owen` | 4 |' "$tmp/local/REPORT.md" && ok || bad "honesty row for rqmc"
# the per-flag table counts the runs of compare.csv: correct = covered, with a bar
grep -q '^## What each flag was worth here' "$tmp/local/REPORT.md" && ok ||
    bad "REPORT.md lacks the per-flag section"
want=$(awk -F, 'NR > 1 && $10 != "none" && $11 != "REFUSED" { n++; if ($11 == "OK") c++ }
    END { printf "%d runs with a bar: %d correct (covered), %d wrong.", n, c, n - c }' \
    "$tmp/local/compare.csv")
grep -qF "$want" "$tmp/local/REPORT.md" && ok || bad "per-flag counts: want '$want'"
grep -q '^| any flag | ' "$tmp/local/REPORT.md" && ok || bad "per-flag table lacks 'any flag'"
grep -q 'slope' "$tmp/local/compare.gp" && ok || bad "no fitted slopes in the chart legend"
grep -q 'Pareto front' "$tmp/local/compare.gp" && ok || bad "no Pareto front in the chart"

# ---- against a daemon --------------------------------------------------------
if [ ! -x "$QMCD" ]; then
    bad "no daemon at $QMCD"
else
    "$QMCD" --foreground --listen "unix:$tmp/qmcd.sock" --ready-file "$tmp/ready" \
        --log-level info 2> "$tmp/qmcd.log" &
    pid=$!
    i=0
    while [ ! -s "$tmp/ready" ]; do
        if ! kill -0 "$pid" 2>/dev/null; then
            bad "qmcd exited before it was ready: $(cat "$tmp/qmcd.log")"; pid=; break
        fi
        i=$((i + 1))
        [ $i -gt 2000 ] && { bad "qmcd not ready"; break; }
        sleep 0.01
    done
    if [ -n "$pid" ] && [ -s "$tmp/ready" ]; then
        "$QMC" compare $JOB --methods $METHODS --budgets 1e3:1e4 --reps 2 \
            --connect "unix:$tmp/qmcd.sock" --out "$tmp/remote" > /dev/null 2> "$tmp/rerr.txt"
        rc=$?
        [ $rc -eq 0 ] && ok || bad "compare --connect exited $rc: $(cat "$tmp/rerr.txt")"
        # same runs, same estimates and errors (seconds aside)
        cut -d, -f1-6,8-11 "$tmp/local/compare.csv" > "$tmp/a.csv"
        cut -d, -f1-6,8-11 "$tmp/remote/compare.csv" > "$tmp/b.csv"
        cmp -s "$tmp/a.csv" "$tmp/b.csv" && ok || bad "daemon results differ from in-process"
        grep -q "ran on the daemon at \`unix:$tmp/qmcd.sock\`" "$tmp/remote/REPORT.md" && ok ||
            bad "REPORT.md does not say the jobs ran on the daemon"
        # the daemon counted the jobs
        "$QMC" stats --connect "unix:$tmp/qmcd.sock" > "$tmp/stats.txt" 2>&1 && ok ||
            bad "qmc stats after compare: $(cat "$tmp/stats.txt")"
        # --threads is in-process only
        "$QMC" compare $JOB --threads 2 --connect "unix:$tmp/qmcd.sock" --out "$tmp/rbad" \
            > /dev/null 2> "$tmp/err.txt"
        [ $? -eq 2 ] && [ ! -e "$tmp/rbad" ] && ok || bad "--threads with --connect"
    fi
    kill "$pid" 2>/dev/null; wait "$pid" 2>/dev/null; pid=
    # the daemon is gone: a clear error and no DIR
    "$QMC" compare $JOB --connect "unix:$tmp/qmcd.sock" --out "$tmp/gone" > /dev/null 2> "$tmp/err.txt"
    rc=$?
    [ $rc -eq 2 ] && [ ! -e "$tmp/gone" ] && [ "$(wc -l < "$tmp/err.txt")" -eq 1 ] && ok ||
        bad "no daemon: rc $rc, $(cat "$tmp/err.txt")"
fi

# ---- bad input ---------------------------------------------------------------
mkdir "$tmp/keep"
echo precious > "$tmp/keep/old.txt"
expect_error() {
    want="$1"; shift
    rm -rf "$tmp/bad"
    "$QMC" compare "$@" > "$tmp/out.txt" 2> "$tmp/err.txt"
    rc=$?
    [ $rc -eq 2 ] || { bad "compare $* exited $rc, want 2"; return; }
    [ "$(wc -l < "$tmp/err.txt")" -eq 1 ] || { bad "compare $*: not one line: $(cat "$tmp/err.txt")"; return; }
    grep -q -- "$want" "$tmp/err.txt" || { bad "compare $*: '$(cat "$tmp/err.txt")' lacks '$want'"; return; }
    [ ! -s "$tmp/out.txt" ] || { bad "compare $*: wrote to stdout"; return; }
    [ ! -e "$tmp/bad" ] || { bad "compare $*: created DIR"; return; }
    ok
}
expect_error "unknown test function" --integrand nope --dims 2 --out "$tmp/bad"
expect_error "--dims D is required" --integrand genz-gaussian --out "$tmp/bad"
expect_error "--out DIR is required" $JOB
expect_error "--budgets" $JOB --budgets 1e4:1e3 --out "$tmp/bad"
expect_error "--budgets" $JOB --budgets abc --out "$tmp/bad"
expect_error "unknown method 'bogus'" $JOB --methods mc,bogus --out "$tmp/bad"
expect_error "listed twice" $JOB --methods mc,mc --out "$tmp/bad"
expect_error "only qmc and rqmc" $JOB --methods mc/sobol --out "$tmp/bad"
expect_error "--reference" $JOB --reference 1x --out "$tmp/bad"
SCENES=$(dirname "$0")/../scenes
expect_error "no closed form" --scene "$SCENES/phong_sphere.scene" --reference exact --out "$tmp/bad"
expect_error "line 1, column 1" --scene /dev/null --out "$tmp/bad"
expect_error "either --integrand or --scene" $JOB --scene x --out "$tmp/bad"
expect_error "--reps" $JOB --reps 0 --out "$tmp/bad"
# the job's lists are read as qmc integrate reads them: a trailing comma
# is an empty item, not the end of the list
expect_error "--a: bad list '3,4,'" --integrand genz-gaussian --dims 2 --a 3,4, --out "$tmp/bad"
expect_error "^qmc: --threads is an in-process option: the daemon runs each job on its own pool (drop it, or --connect '' to run here)$" \
    $JOB --threads 2 --connect "unix:$tmp/none.sock" --out "$tmp/bad"
expect_error "--u: empty list" --integrand genz-gaussian --dims 2 --u "" --out "$tmp/bad"
# an existing DIR is left exactly as it was
"$QMC" compare $JOB --methods bogus --out "$tmp/keep" > /dev/null 2>&1
[ "$(ls -A "$tmp/keep")" = "old.txt" ] && [ "$(cat "$tmp/keep/old.txt")" = precious ] && ok ||
    bad "a failed compare touched an existing DIR: $(ls -A "$tmp/keep")"

# gnuplot failing late (here a stand-in on PATH): its reason in one line,
# exit 2, and nothing of the run left in DIR
mkdir "$tmp/fakebin"
printf '#!/bin/sh\necho "plot this"\necho "\\"x.gp\\", line 3: all points y value undefined!"\nexit 1\n' \
    > "$tmp/fakebin/gnuplot"
chmod +x "$tmp/fakebin/gnuplot"
PATH="$tmp/fakebin:$PATH" "$QMC" compare $JOB --methods mc --budgets 1e3 --reps 1 \
    --out "$tmp/late" > /dev/null 2> "$tmp/err.txt"
rc=$?
[ $rc -eq 2 ] && tail -n 1 "$tmp/err.txt" | grep -q 'all points y value undefined' &&
    [ ! -e "$tmp/late" ] && ok || bad "late gnuplot failure: rc $rc, $(tail -n 1 "$tmp/err.txt")"

"$QMC" compare --help | grep -q 'Pareto' && ok || bad "--help does not mention the Pareto front"

finish
