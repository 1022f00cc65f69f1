#!/bin/sh
# test_quality_cli.sh - end-to-end tests of `qmc discrepancy` and
# `qmc spectrum` against live oracles.
#
# Discrepancies are compared with scipy.stats.qmc.discrepancy on random
# point sets made by NumPy with fixed seeds; the 2D star discrepancy with a
# brute-force count in Python; the PNG is checked chunk by chunk with
# Python's zlib (CRC-32, inflate).  Error paths must exit 2 with exactly one
# line on stderr and nothing on stdout.
#
# Env: QMC = path to the qmc binary, BUILD = the build directory.  Needs
# Debian's /usr/bin/python3 with python3-scipy (build-aux/deps.sh test).
# Prints "N passed, M failed" last; exits 1 if anything failed.
set -u

: "${QMC:?set QMC to the qmc binary}"
: "${BUILD:?set BUILD to the build directory}"
PY=/usr/bin/python3
. "$(dirname "$0")/lib.sh"

# rel_close GOT WANT TOL: |got - want| <= tol * max(|want|, 1e-300)
rel_close() {
    awk -v g="$1" -v w="$2" -v t="$3" 'BEGIN {
        d = g - w; if (d < 0) d = -d; a = w < 0 ? -w : w;
        if (a < 1e-300) a = 1e-300;
        exit !(g != "" && d <= t * a) }'
}

# ---- discrepancy vs scipy ---------------------------------------------------
# Each case: seed n dims.  The set includes points on the faces 0 and 1.
for case in "1 1 3" "2 7 1" "3 20 2" "4 64 3" "5 100 5" "6 33 10" \
            "7 250 2" "8 40 20"; do
    set -- $case
    seed=$1 n=$2 d=$3
    csv="$tmp/pts_$seed.csv"
    exp="$tmp/exp_$seed.txt"
    if ! "$PY" - "$seed" "$n" "$d" "$csv" "$exp" <<'PYEOF'
import sys
import numpy as np
from scipy.stats import qmc
seed, n, d = (int(a) for a in sys.argv[1:4])
rng = np.random.default_rng(seed)
x = rng.random((n, d))
if n > 2:
    x[0, 0] = 0.0
    x[1, -1] = 1.0
with open(sys.argv[4], "w") as f:
    for row in x:
        f.write(",".join(repr(float(v)) for v in row) + "\n")
with open(sys.argv[5], "w") as f:
    for cli, m in (("l2-star", "L2-star"), ("cd", "CD"), ("wd", "WD"),
                   ("md", "MD")):
        f.write("%s %r\n" % (cli, float(qmc.discrepancy(x, method=m))))
PYEOF
    then
        bad "oracle for case $case did not run"
        continue
    fi
    while read -r method want; do
        got=$("$QMC" discrepancy --method "$method" --in "$csv" 2>"$tmp/err")
        if [ $? -eq 0 ] && rel_close "$got" "$want" 1e-10; then
            ok
        else
            bad "discrepancy $method seed=$seed n=$n d=$d: got '$got' want $want ($(cat "$tmp/err"))"
        fi
    done <"$exp"
done

# stdin is the default input.
want=$(awk '$1 == "cd" { print $2 }' "$tmp/exp_3.txt")
got=$("$QMC" discrepancy --method cd <"$tmp/pts_3.csv")
if rel_close "$got" "$want" 1e-10; then ok; else bad "stdin: got '$got' want $want"; fi

# ---- star discrepancy vs brute force ---------------------------------------
"$PY" "$(dirname "$0")/star2d.py" 99 40 17 "$tmp/star.csv" "$tmp/star.txt"
want=$(cat "$tmp/star.txt")
got=$("$QMC" discrepancy --method star --in "$tmp/star.csv" 2>"$tmp/err")
if [ $? -eq 0 ] && rel_close "$got" "$want" 1e-12 && [ ! -s "$tmp/err" ]; then
    ok
else
    bad "star 2D: got '$got' want $want"
fi
# Above 2D with many points the result is a bound, said on stderr.
got=$("$QMC" discrepancy --method star --in "$tmp/pts_5.csv" 2>"$tmp/err")
if [ $? -eq 0 ] && [ -n "$got" ]; then ok; else bad "star 5D: '$got'"; fi

# ---- error paths --------------------------------------------------------------
# expect_fail NAME STDIN-TEXT ARGS...: exit 2, one stderr line, no stdout.
expect_fail() {
    name=$1 input=$2
    shift 2
    printf '%b' "$input" | "$QMC" "$@" >"$tmp/out" 2>"$tmp/err"
    rc=$?
    lines=$(wc -l <"$tmp/err")
    if [ "$rc" -eq 2 ] && [ "$lines" -eq 1 ] && [ ! -s "$tmp/out" ]; then
        ok
    else
        bad "$name: rc=$rc, $lines stderr lines, stdout '$(cat "$tmp/out")'"
    fi
}
expect_fail "ragged rows" '0.1,0.2\n0.3\n' discrepancy --method cd
expect_fail "not a number" '0.1,0.2\n0.3,x\n' discrepancy --method wd
expect_fail "empty field" '0.1,,0.2\n' discrepancy --method md
expect_fail "outside [0,1]" '0.1,0.2\n0.3,1.5\n' discrepancy --method l2-star
expect_fail "negative" '-0.1,0.2\n' discrepancy --method star
expect_fail "nan" '0.1,nan\n' discrepancy --method cd
expect_fail "unknown method" '0.1,0.2\n' discrepancy --method foo
expect_fail "no method" '0.1,0.2\n' discrepancy
expect_fail "no points" '' discrepancy --method cd
expect_fail "missing file" '' discrepancy --method cd --in "$tmp/nonexistent"
expect_fail "unknown option" '0.5\n' discrepancy --method cd --bogus
expect_fail "spectrum without count" '' spectrum --seq sobol --png "$tmp/a.png" --csv "$tmp/a.csv"
expect_fail "spectrum bad kind" '' spectrum --seq nope --count 8 --png "$tmp/a.png" --csv "$tmp/a.csv"
expect_fail "spectrum too much work" '' spectrum --seq random --count 1048576 --reps 1024 --freq 256 --png "$tmp/a.png" --csv "$tmp/a.csv"

# The messages name the line.
printf '0.1,0.2\n0.3,0.4\n0.5\n' | "$QMC" discrepancy --method cd 2>"$tmp/err" >/dev/null
if grep -q 'line 3: 1 coordinate, expected 2' "$tmp/err"; then ok; else bad "ragged message: $(cat "$tmp/err")"; fi
printf '0.1,0.2\n0.3,1.5\n' | "$QMC" discrepancy --method cd 2>"$tmp/err" >/dev/null
if grep -q 'line 2: coordinate 1.5 outside \[0,1\]' "$tmp/err"; then ok; else bad "range message: $(cat "$tmp/err")"; fi
# Too many points: the cap is stated.
awk 'BEGIN { for (i = 0; i < 10001; i++) print (i % 97) / 97 }' >"$tmp/big.csv"
"$QMC" discrepancy --method cd --in "$tmp/big.csv" >"$tmp/out" 2>"$tmp/err"
if [ $? -eq 2 ] && grep -q '10000 points' "$tmp/err" && [ ! -s "$tmp/out" ]; then ok; else bad "point cap: $(cat "$tmp/err")"; fi

# --help documents the squaring.
if "$QMC" discrepancy --help | grep -q SQUARED; then ok; else bad "--help"; fi

# ---- spectrum -------------------------------------------------------------------
check_png() { # FILE WIDTH: signature, CRCs, IDAT inflates to h * (w + 1)
    "$PY" - "$1" "$2" <<'PYEOF'
import struct, sys, zlib
b = open(sys.argv[1], "rb").read()
assert b[:8] == b"\x89PNG\r\n\x1a\n", "signature"
p, chunks, idat = 8, [], b""
while p < len(b):
    n, = struct.unpack(">I", b[p:p + 4])
    t, d = b[p + 4:p + 8], b[p + 8:p + 8 + n]
    crc, = struct.unpack(">I", b[p + 8 + n:p + 12 + n])
    assert zlib.crc32(t + d) == crc, "crc of %r" % t
    chunks.append(t)
    if t == b"IDAT":
        idat += d
    p += 12 + n
assert chunks[0] == b"IHDR" and chunks[-1] == b"IEND", chunks
w, h, depth, ctype = struct.unpack(">IIBB", b[16:26])
assert (depth, ctype) == (8, 0) and w == h == int(sys.argv[2]), (w, h)
raw = zlib.decompress(idat)
assert len(raw) == h * (w + 1), len(raw)
assert all(raw[r * (w + 1)] == 0 for r in range(h)), "filter bytes"
PYEOF
}
# K = 20: side 41, scaled by ceil(256/41) = 7 to 287 pixels.
if "$QMC" spectrum --seq sobol --count 256 --freq 20 \
       --png "$tmp/s.png" --csv "$tmp/s.csv" 2>"$tmp/err" &&
   check_png "$tmp/s.png" 287; then ok; else bad "sobol spectrum png: $(cat "$tmp/err")"; fi
if [ "$(head -n 1 "$tmp/s.csv")" = "frequency,power" ] &&
   [ "$(wc -l <"$tmp/s.csv")" -eq 22 ] &&
   [ "$(sed -n 2p "$tmp/s.csv")" = "0,256" ]; then ok; else bad "sobol spectrum csv"; fi
# K = 200: side 401 > 256, no scaling; one IDAT of several stored blocks.
if "$QMC" spectrum --seq random --seed 5 --count 64 --reps 3 --freq 200 \
       --png "$tmp/r.png" --csv "$tmp/r.csv" 2>"$tmp/err" &&
   check_png "$tmp/r.png" 401; then ok; else bad "random spectrum png: $(cat "$tmp/err")"; fi
# Random points: mean power near 1 away from DC (3 reps, many k per bin).
if awk -F, 'NR > 20 { s += $2; n++ } END { m = s / n; exit !(m > 0.8 && m < 1.2) }' "$tmp/r.csv"
then ok; else bad "random spectrum level"; fi
# Sobol: the low-frequency hole (random points give about 1 there).
if awk -F, 'NR >= 3 && NR <= 5 { if ($2 > 0.25) bad = 1 } END { exit bad }' "$tmp/s.csv"
then ok; else bad "sobol low-frequency hole: $(sed -n 3,5p "$tmp/s.csv")"; fi

finish
