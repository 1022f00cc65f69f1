#!/bin/sh
# test_points_cli.sh - end-to-end tests of `qmc points` against the real
# binary.
#
# Known answers (the Joe-Kuo Sobol' points); SciPy as a live oracle for
# unscrambled Sobol' (exact, after Gray-code reordering) and Halton (1e-15);
# the f64, f32, u32 and CSV formats are the same numbers; random access
# (--start S --count 1) equals the batch for every kind; the same command
# gives the same bytes; error paths exit 2 with exactly one "qmc: " line on
# stderr and nothing on stdout; --out is atomic.
#
# Env: QMC = path to the qmc binary, BUILD = the build directory.  Needs
# Debian's /usr/bin/python3 with python3-scipy (build-aux/deps.sh test).
# Prints "N passed, M failed" last; exits 1 if anything failed.
set -u

: "${QMC:?set QMC to the qmc binary}"
: "${BUILD:?set BUILD to the build directory}"
PY=/usr/bin/python3
. "$(dirname "$0")/lib.sh"

# ---- known answers ------------------------------------------------------------
# The first 8 points of Sobol' in 3D (Joe & Kuo, new-joe-kuo-6.21201).
cat >"$tmp/sobol3.want" <<'EOF'
0,0,0
0.5,0.5,0.5
0.25,0.75,0.75
0.75,0.25,0.25
0.125,0.625,0.375
0.625,0.125,0.875
0.375,0.375,0.625
0.875,0.875,0.125
EOF
if "$QMC" points --seq sobol --dims 3 --count 8 >"$tmp/sobol3.got" 2>"$tmp/err" &&
   cmp -s "$tmp/sobol3.got" "$tmp/sobol3.want" && [ ! -s "$tmp/err" ]; then
    ok
else
    bad "sobol d=3 known answers: $(tr '\n' ' ' <"$tmp/sobol3.got") $(cat "$tmp/err")"
fi

# ---- SciPy oracle ---------------------------------------------------------------
# oracle NAME PYTHON-CHECK QMC-ARGS...: writes f64 to $tmp/NAME.f64, then runs
# the check with argv[1] = that file; the check prints why it failed.
oracle() {
    name=$1 check=$2
    shift 2
    if ! "$QMC" points "$@" --format f64 >"$tmp/$name.f64" 2>"$tmp/err"; then
        bad "$name: qmc failed: $(cat "$tmp/err")"
        return
    fi
    if "$PY" -c "$check" "$tmp/$name.f64" >"$tmp/why" 2>&1; then
        ok
    else
        bad "$name: $(tail -n 3 "$tmp/why" | tr '\n' ' ')"
    fi
}
# SciPy's step i is the Gray-code point: our index i ^ (i >> 1).
sobol_check='import sys, numpy as np
from scipy.stats import qmc
n = 1024
got = np.fromfile(sys.argv[1], dtype="<f8")
assert got.size == n * d, "size %d" % got.size
got = got.reshape(n, d)
i = np.arange(n); g = i ^ (i >> 1)
want = qmc.Sobol(d, scramble=False, bits=32).random(n)
diff = np.nonzero(got[g] != want)
assert diff[0].size == 0, "first mismatch at step %d dim %d: %r vs %r" % (
    diff[0][0], diff[1][0], got[g][diff][0], want[diff][0])
'
for d in 5 50; do
    oracle "scipy_sobol_$d" "d = $d
$sobol_check" --seq sobol --dims "$d" --count 1024
done
halton_check='
import sys, numpy as np
from scipy.stats import qmc
d, n = 10, 1024
got = np.fromfile(sys.argv[1], dtype="<f8")
assert got.size == n * d, "size %d" % got.size
got = got.reshape(n, d)
want = qmc.Halton(d, scramble=False).random(n)
err = float(np.max(np.abs(got - want)))
assert err <= 1e-15, "max |diff| %r" % err
'
oracle scipy_halton_10 "$halton_check" --seq halton --dims 10 --count 1024

# ---- formats agree --------------------------------------------------------------
fmt_args="--seq sobol --scramble owen --seed 7 --dims 4 --count 100 --start 12345"
fmt_ok=1
for f in f64 f32 u32 csv; do
    # shellcheck disable=SC2086
    if ! "$QMC" points $fmt_args --format "$f" >"$tmp/fmt.$f" 2>"$tmp/err"; then
        bad "format $f: $(cat "$tmp/err")"
        fmt_ok=0
    fi
done
for f in "f64 3200" "f32 1600" "u32 1600"; do
    # shellcheck disable=SC2086
    set -- $f
    size=$(wc -c <"$tmp/fmt.$1" | tr -d ' ')
    if [ "$size" -eq "$2" ]; then ok; else bad "format $1: $size bytes, want $2"; fi
done
if [ "$fmt_ok" -eq 1 ] && "$PY" - "$tmp/fmt" >"$tmp/why" 2>&1 <<'PYEOF'
import sys, numpy as np
p = sys.argv[1]
x = np.fromfile(p + ".f64", dtype="<f8").reshape(100, 4)
u = np.fromfile(p + ".u32", dtype="<u4").reshape(100, 4)
f = np.fromfile(p + ".f32", dtype="<f4").reshape(100, 4)
assert np.all((x >= 0) & (x < 1)), "f64 outside [0,1)"
# Exact in double: x has at most 53 significant bits, times 2^k is exact.
assert np.array_equal(u.astype(np.uint64), np.floor(x * 2.0**32).astype(np.uint64)), "u32 != floor(f64 * 2^32)"
assert np.array_equal(f.astype(np.float64), np.floor(x * 2.0**24) / 2.0**24), "f32 != floor(f64 * 2^24) / 2^24"
rows = open(p + ".csv").read().split("\n")
assert rows[-1] == "" and len(rows) == 101, "csv has %d lines" % (len(rows) - 1)
c = np.array([[float(v) for v in r.split(",")] for r in rows[:-1]])
assert np.array_equal(c, x), "csv != f64"
assert all(repr(float(v)) == repr(float(w)) for v, w in zip(c.ravel(), x.ravel()))
PYEOF
then ok; else bad "formats disagree: $(tail -n 2 "$tmp/why" | tr '\n' ' ')"; fi

# ---- random access == batch ----------------------------------------------------
# ra NAME START0 COUNT "S1 S2 ..." QMC-ARGS...: the batch [start0, start0 +
# count) as CSV; each S alone must equal row S - start0, byte for byte;
# every coordinate in [0, 1).
ra() {
    name=$1 s0=$2 n=$3 picks=$4
    shift 4
    if ! "$QMC" points "$@" --start "$s0" --count "$n" >"$tmp/batch" 2>"$tmp/err"; then
        bad "$name batch: $(cat "$tmp/err")"
        return
    fi
    if [ "$(wc -l <"$tmp/batch")" -eq "$n" ] &&
       awk -F, '{ for (i = 1; i <= NF; i++) if (!($i >= 0 && $i < 1)) exit 1 }' "$tmp/batch"
    then ok; else bad "$name: batch not $n rows in [0,1)"; fi
    for s in $picks; do
        one=$("$QMC" points "$@" --start "$s" --count 1 2>"$tmp/err")
        row=$(sed -n "$((s - s0 + 1))p" "$tmp/batch")
        if [ -n "$one" ] && [ "$one" = "$row" ]; then
            ok
        else
            bad "$name: --start $s gives '$one', batch row is '$row' $(cat "$tmp/err")"
        fi
    done
}
ra "sobol none" 1000 300 "1000 1001 1255 1299" --seq sobol --dims 6
ra "sobol shift" 0 256 "0 1 128 255" --seq sobol --dims 6 --scramble shift --seed 3
ra "sobol owen" 4090 200 "4090 4095 4096 4289" --seq sobol --dims 6 --scramble owen --seed 0x2a
ra "sobol shuffle" 0 512 "0 7 300 511" --seq sobol --dims 4 --scramble owen --shuffle --seed 9
ra "sobol fast-owen" 4090 200 "4090 4095 4096 4289" --seq sobol --dims 6 --scramble fast-owen --seed 0x2a
ra "halton none" 500 200 "500 511 512 699" --seq halton --dims 8
ra "halton faure" 0 300 "0 1 242 243 299" --seq halton --dims 8 --scramble faure --seed 4
ra "halton owen" 0 300 "0 1 242 243 299" --seq halton --dims 8 --scramble owen --seed 5
ra "hammersley" 0 1000 "0 1 500 999" --seq hammersley --dims 5 --set-size 1000
ra "hammersley owen" 100 400 "100 250 499" --seq hammersley --dims 5 --set-size 1000 --scramble owen --seed 6
ra "random" 77 200 "77 78 200 276" --seq random --dims 5 --seed 11
ra "stratified" 0 1024 "0 1 513 1023" --seq stratified --dims 2 --set-size 1024 --seed 12
ra "lhs" 0 1000 "0 1 500 999" --seq lhs --dims 3 --set-size 1000 --seed 13

# ---- determinism ---------------------------------------------------------------
det_args="--seq sobol --dims 8 --scramble owen --seed 0xdeadbeef --count 65536 --format f64"
# shellcheck disable=SC2086
"$QMC" points $det_args >"$tmp/det1" 2>/dev/null
# shellcheck disable=SC2086
"$QMC" points $det_args >"$tmp/det2" 2>/dev/null
if [ "$(wc -c <"$tmp/det1")" -eq $((65536 * 8 * 8)) ] && cmp -s "$tmp/det1" "$tmp/det2"
then ok; else bad "owen 2^16 f64: two runs differ or wrong size"; fi

# ---- error paths ---------------------------------------------------------------
# expect_fail NAME GREP-PATTERN ARGS...: exit 2, exactly one stderr line
# starting "qmc: " and matching the pattern, no stdout.
expect_fail() {
    name=$1 pat=$2
    shift 2
    "$QMC" points "$@" >"$tmp/out" 2>"$tmp/err" </dev/null
    rc=$?
    lines=$(wc -l <"$tmp/err")
    if [ "$rc" -eq 2 ] && [ "$lines" -eq 1 ] && [ ! -s "$tmp/out" ] &&
       grep -q '^qmc: ' "$tmp/err" && grep -q -- "$pat" "$tmp/err"; then
        ok
    else
        bad "$name: rc=$rc, $lines stderr lines '$(cat "$tmp/err")', $(wc -c <"$tmp/out") stdout bytes"
    fi
}
expect_fail "unknown --seq" "nope" --seq nope
expect_fail "missing --seq" "--seq" --dims 2
expect_fail "--dims 0" "--dims" --seq sobol --dims 0
expect_fail "sobol --dims 21202" "21202" --seq sobol --dims 21202
expect_fail "halton --dims 5000" "5000" --seq halton --dims 5000
expect_fail "sobol faure" "faure" --seq sobol --scramble faure
expect_fail "random owen" "owen" --seq random --scramble owen
expect_fail "halton fast-owen" "sobol only" --seq halton --scramble fast-owen
expect_fail "hammersley fast-owen" "sobol only" --seq hammersley --scramble fast-owen --count 8
expect_fail "unknown scramble lists fast-owen" "fast-owen" --seq sobol --scramble fastowen
expect_fail "--count 0" "--count" --seq sobol --count 0
expect_fail "--count abc" "abc" --seq sobol --count abc
expect_fail "past 2^32" "4294967296" --seq sobol --start 4294967295 --count 2
expect_fail "stratified 10" "9 and 16" --seq stratified --dims 2 --count 10
expect_fail "sobol --set-size" "set" --seq sobol --set-size 8
expect_fail "halton --shuffle" "shuffl" --seq halton --shuffle
expect_fail "--format xml" "xml" --seq sobol --format xml
expect_fail "--foo" "--foo" --seq sobol --foo
expect_fail "stray argument" "stray" --seq sobol stray

# ---- --out ---------------------------------------------------------------------
out_args="--seq halton --scramble owen --seed 3 --dims 7 --count 5000 --format f64"
# shellcheck disable=SC2086
"$QMC" points $out_args >"$tmp/stdout.f64" 2>/dev/null
# shellcheck disable=SC2086
if "$QMC" points $out_args --out "$tmp/file.f64" >"$tmp/out" 2>"$tmp/err" &&
   [ ! -s "$tmp/out" ] && [ ! -s "$tmp/err" ] && [ -s "$tmp/stdout.f64" ] &&
   cmp -s "$tmp/file.f64" "$tmp/stdout.f64"; then
    ok
else
    bad "--out differs from stdout: $(cat "$tmp/err")"
fi
mkdir "$tmp/o"
expect_fail "--out with bad --dims" "--dims" --seq sobol --dims 0 --out "$tmp/o/bad.csv"
if [ -z "$(ls -A "$tmp/o")" ]; then ok; else bad "--out error left: $(ls -A "$tmp/o")"; fi
expect_fail "--out past the end" "4294967296" --seq sobol --start 4294967295 --count 2 --out "$tmp/o/end.csv"
if [ -z "$(ls -A "$tmp/o")" ]; then ok; else bad "--out range error left: $(ls -A "$tmp/o")"; fi
expect_fail "--out missing dir" "--out" --seq sobol --out "$tmp/nonexistent/p.csv"
if [ ! -e "$tmp/nonexistent" ]; then ok; else bad "--out created a directory"; fi

finish
