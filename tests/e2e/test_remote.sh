#!/bin/sh
# End-to-end checks of the remote CLI against the real daemon: qmcd is
# started on a temporary Unix socket and an ephemeral TCP port, waited for
# through its --ready-file (no fixed sleeps), and stopped by PID.
#
#   - `qmc points --connect` writes the same bytes as in-process for every
#     sequence kind and scramble, in csv and f64 (and across chunks);
#   - `qmc integrate --connect` prints the same JSON and text (but for the
#     seconds) for rqmc, cubature, auto and a scene; `qmc spectrum` the same
#     files;
#   - ping and stats work, QMC_ENDPOINT works and --connect wins over it;
#   - errors (unreachable, malformed endpoint, the server refusing a
#     request over its limit, invalid requests) are one line on stderr, exit
#     2, nothing on stdout - and the same line as in-process where both
#     check the same thing;
#   - a count past the daemon's max-points is split by the client: the same
#     bytes as in-process.
# Env: QMC, QMCD (binaries).  Prints "N passed, M failed".
set -u
: "${QMC:?QMC must name the qmc binary}"
: "${QMCD:?QMCD must name the qmcd binary}"
. "$(dirname "$0")/lib.sh"
# The daemon in $pid gets SIGTERM at exit; the test clears pid once it has
# stopped it itself and checked the exit status.
pid=
term_vars=pid

if [ ! -x "$QMCD" ]; then
    echo "test_remote: no daemon at $QMCD"
    echo "0 passed, 1 failed"
    exit 1
fi

# ---- start the daemon ------------------------------------------------------
# A small max-points so that an over-limit request is cheap to make.
MAXPTS=200000
"$QMCD" --foreground --listen "unix:$tmp/qmcd.sock" --listen tcp:127.0.0.1:0 \
    --ready-file "$tmp/ready" --max-points $MAXPTS --log-level info 2> "$tmp/qmcd.log" &
pid=$!
# Ready when the ready file exists (written by rename once listening); give
# up if the daemon dies or after about 20 s.
wait_ready pid "$tmp/ready" "$tmp/qmcd.log"
UNIX="unix:$tmp/qmcd.sock"
TCP=$(grep '^tcp:' "$tmp/ready" | head -n 1)
case "$TCP" in tcp:127.0.0.1:[1-9]*) ok ;; *) bad "no TCP address in the ready file: $(cat "$tmp/ready")";; esac

# same_out NAME ENDPOINT ARGS...: remote stdout and status == in-process.
same_out() {
    name=$1 ep=$2
    shift 2
    "$QMC" "$@" > "$tmp/local.out" 2> "$tmp/local.err"
    lrc=$?
    "$QMC" "$@" --connect "$ep" > "$tmp/remote.out" 2> "$tmp/remote.err"
    rrc=$?
    if [ $lrc -eq 0 ] && [ $rrc -eq 0 ] && [ -s "$tmp/local.out" ] &&
       cmp -s "$tmp/local.out" "$tmp/remote.out"; then ok
    else bad "$name: remote differs (exit $lrc local, $rrc remote): $(head -c 200 "$tmp/remote.err")"; fi
}

# ---- 1. points: every kind, csv and f64, over both transports --------------
n=0
while read -r args; do
    for fmt in csv f64; do
        n=$((n + 1))
        if [ $((n % 2)) -eq 0 ]; then ep=$UNIX; else ep=$TCP; fi
        # shellcheck disable=SC2086
        same_out "points $args --format $fmt" "$ep" points $args --format $fmt
    done
done <<EOF
--seq sobol --dims 5 --count 1000
--seq sobol --dims 3 --count 777 --start 1000 --scramble shift --seed 5
--seq sobol --dims 7 --count 513 --scramble owen --seed 0x2a
--seq sobol --dims 4 --count 300 --scramble owen --shuffle --seed 9
--seq sobol --dims 9 --count 1003 --start 5 --scramble fast-owen --seed 0x123456789
--seq halton --dims 6 --count 1000
--seq halton --dims 3 --count 400 --start 17 --scramble faure
--seq halton --dims 12 --count 500 --scramble owen --seed 3
--seq hammersley --dims 3 --count 256
--seq random --dims 4 --count 1000 --seed 77
--seq stratified --dims 2 --count 256 --seed 1
--seq lhs --dims 5 --count 1000 --seed 2
EOF
# Many chunks (8 MB of f64), f32 and u32, and --out.
same_out "points f64 in many chunks" "$UNIX" points --seq sobol --dims 10 --count 100000 --format f64
same_out "points f32" "$TCP" points --seq sobol --dims 3 --count 5000 --scramble owen --format f32
same_out "points fast-owen u32" "$UNIX" points --seq sobol --dims 21 --count 20000 --scramble fast-owen --seed 7 --format u32
same_out "points u32" "$UNIX" points --seq halton --dims 3 --count 5000 --format u32
"$QMC" points --seq sobol --dims 4 --count 50000 --format f64 --out "$tmp/l.bin"
"$QMC" points --seq sobol --dims 4 --count 50000 --format f64 --out "$tmp/r.bin" --connect "$TCP"
if cmp -s "$tmp/l.bin" "$tmp/r.bin"; then ok; else bad "points --out differs"; fi

# ---- 2. integrate: JSON and text, the seconds aside -----------------------------
strip_json() { sed 's/"seconds":[^,]*,//'; }
strip_text() { sed 's/^\(work .*\), [0-9.]* s$/\1/'; }
while read -r args; do
    for mode in json text; do
        if [ $mode = json ]; then j=--json; s=strip_json; else j=; s=strip_text; fi
        # shellcheck disable=SC2086
        "$QMC" integrate $args $j 2> "$tmp/le" | $s > "$tmp/l.txt"
        # shellcheck disable=SC2086
        "$QMC" integrate $args $j --connect "$UNIX" 2> "$tmp/re" | $s > "$tmp/r.txt"
        if [ -s "$tmp/l.txt" ] && cmp -s "$tmp/l.txt" "$tmp/r.txt"; then ok
        else bad "integrate $args ($mode): $(diff "$tmp/l.txt" "$tmp/r.txt" | head -3) $(cat "$tmp/re")"; fi
    done
done <<EOF
--integrand genz-gaussian --dims 4 --method rqmc --n 4096 --seed 3
--integrand genz-oscillatory --dims 3 --method cubature
--integrand genz-gaussian --dims 3 --method clenshaw-curtis --tol-rel 1e-12
--integrand genz-corner-peak --dims 6 --method auto --tol-rel 1e-4
--integrand genz-continuous --dims 20 --method auto --max-evals 400000 --seed 2
--integrand genz-gaussian --dims 4 --control genz-product-peak --method mc --seed 5
--integrand exp --dims 1 --method auto
--integrand genz-discontinuous --dims 5 --method auto --max-evals 200000 --seed 4
--integrand genz-discontinuous --dims 3 --method rqmc --reps 8 --n 2048 --split-net
--scene tests/scenes/lambert_sphere.scene --method rqmc --strategy mis-power
--scene tests/scenes/phong_sphere.scene --method rqmc --n 1024 --strategy light
EOF
# The seconds are the server's compute time: a number, not the local one.
"$QMC" integrate --integrand genz-gaussian --dims 4 --method rqmc --json --connect "$TCP" > "$tmp/r.json"
if grep -q '"seconds":[0-9]' "$tmp/r.json"; then ok; else bad "no seconds: $(cat "$tmp/r.json")"; fi

# ---- 3. spectrum: the same CSV and PNG -----------------------------------------
"$QMC" spectrum --seq sobol --scramble owen --count 1024 --reps 2 --freq 16 \
    --csv "$tmp/ls.csv" --png "$tmp/ls.png"
"$QMC" spectrum --seq sobol --scramble owen --count 1024 --reps 2 --freq 16 \
    --csv "$tmp/rs.csv" --png "$tmp/rs.png" --connect "$UNIX"
if cmp -s "$tmp/ls.csv" "$tmp/rs.csv" && cmp -s "$tmp/ls.png" "$tmp/rs.png"; then ok
else bad "spectrum files differ"; fi

# ---- 4. ping, stats, QMC_ENDPOINT, local-only commands --------------------------
if "$QMC" ping --connect "$UNIX" --count 3 > "$tmp/ping" 2>&1 &&
   grep -q '^server     qmcd' "$tmp/ping" && grep -q 'the same table as this qmc' "$tmp/ping" &&
   [ "$(grep -c '^rtt .* ms$' "$tmp/ping")" -eq 3 ]; then ok
else bad "ping: $(cat "$tmp/ping")"; fi
if QMC_ENDPOINT=$TCP "$QMC" ping > "$tmp/ping" 2>&1 && grep -q '^rtt' "$tmp/ping"; then ok
else bad "ping via QMC_ENDPOINT: $(cat "$tmp/ping")"; fi
if "$QMC" stats --connect "$TCP" > "$tmp/stats" 2>&1 &&
   [ "$(wc -l < "$tmp/stats")" -ge 3 ] &&
   awk 'NF != 2 || $2 !~ /^[0-9]+$/ { exit 1 }' "$tmp/stats"; then ok
else bad "stats: $(head -5 "$tmp/stats")"; fi
"$QMC" points --seq sobol --dims 2 --count 64 > "$tmp/l.csv"
QMC_ENDPOINT=$UNIX "$QMC" points --seq sobol --dims 2 --count 64 > "$tmp/r.csv" 2> "$tmp/err"
if cmp -s "$tmp/l.csv" "$tmp/r.csv"; then ok; else bad "QMC_ENDPOINT points: $(cat "$tmp/err")"; fi
# --connect wins over QMC_ENDPOINT
QMC_ENDPOINT=unix:$tmp/nowhere "$QMC" points --seq sobol --dims 2 --count 64 --connect "$TCP" \
    > "$tmp/r.csv" 2> "$tmp/err"
if cmp -s "$tmp/l.csv" "$tmp/r.csv"; then ok; else bad "--connect over QMC_ENDPOINT: $(cat "$tmp/err")"; fi
# and is really used: a bogus environment with no flag fails
if ! QMC_ENDPOINT=unix:$tmp/nowhere "$QMC" points --seq sobol --count 4 > /dev/null 2>&1; then ok
else bad "QMC_ENDPOINT was ignored"; fi
# discrepancy and merge take --connect for uniformity and stay local
"$QMC" discrepancy --method cd --in "$tmp/l.csv" > "$tmp/d1"
"$QMC" discrepancy --method cd --in "$tmp/l.csv" --connect "unix:$tmp/nowhere" > "$tmp/d2"
if [ -s "$tmp/d1" ] && cmp -s "$tmp/d1" "$tmp/d2"; then ok; else bad "discrepancy --connect"; fi
if "$QMC" merge --help --connect "$UNIX" | grep -q -- '--connect'; then ok
else bad "merge --help does not mention --connect"; fi

# ---- 5. errors: one line, exit 2, nothing on stdout ------------------------------
# fails_once NAME ARGS...: exit 2, empty stdout, one "qmc: " line on stderr.
fails_once() {
    name=$1
    shift
    "$QMC" "$@" > "$tmp/out" 2> "$tmp/err"
    rc=$?
    if [ $rc -eq 2 ] && [ ! -s "$tmp/out" ] && [ "$(wc -l < "$tmp/err")" -eq 1 ] &&
       grep -q '^qmc: ' "$tmp/err"; then ok
    else bad "$name: exit $rc, stdout $(wc -c < "$tmp/out") bytes, stderr: $(cat "$tmp/err")"; fi
}
fails_once "unreachable unix" points --seq sobol --connect "unix:$tmp/nowhere"
grep -q 'cannot connect to unix:.*no such file' "$tmp/err" || bad "unreachable: $(cat "$tmp/err")"
fails_once "refused tcp" ping --connect tcp:127.0.0.1:1
fails_once "malformed endpoint" points --seq sobol --connect tcp:localhost
grep -q 'malformed endpoint' "$tmp/err" || bad "malformed: $(cat "$tmp/err")"
fails_once "malformed endpoint (ipv6)" integrate --integrand exp --dims 1 --connect 'tcp:::1:80'
# Past the daemon's max-points the client splits the request itself: the
# same bytes as in-process (test_cli_safety.sh does this more thoroughly).
same_out "points past max-points" "$UNIX" points --seq sobol --count $((MAXPTS + 1)) --format f64
"$QMC" spectrum --seq sobol --count $((MAXPTS + 1)) --freq 1 --csv "$tmp/lx.csv" --png "$tmp/lx.png"
"$QMC" spectrum --seq sobol --count $((MAXPTS + 1)) --freq 1 --csv "$tmp/x.csv" --png "$tmp/x.png" \
    --connect "$TCP"
if cmp -s "$tmp/lx.csv" "$tmp/x.csv" && cmp -s "$tmp/lx.png" "$tmp/x.png"; then ok
else bad "spectrum past max-points differs from in-process"; fi
fails_once "--threads remote" integrate --integrand exp --dims 1 --threads 2 --connect "$UNIX"
fails_once "--part remote" integrate --integrand exp --dims 1 --part 1/2 --connect "$UNIX"
fails_once "ping without an endpoint" ping
# --out leaves nothing behind when the server refuses
fails_once "--out refused" points --seq sobol --dims 30000 --out "$tmp/o.bin" --connect "$UNIX"
left=no
for f in "$tmp"/o.bin*; do [ -e "$f" ] && left=$f; done
if [ "$left" = no ]; then ok; else bad "--out left $left"; fi

# same_err NAME ARGS...: in-process and remote print the same error line.
same_err() {
    name=$1
    shift
    "$QMC" "$@" > /dev/null 2> "$tmp/le"
    lrc=$?
    "$QMC" "$@" --connect "$UNIX" > "$tmp/out" 2> "$tmp/re"
    rrc=$?
    if [ $lrc -eq 2 ] && [ $rrc -eq 2 ] && [ ! -s "$tmp/out" ] && cmp -s "$tmp/le" "$tmp/re"; then ok
    else bad "$name: local [$lrc] $(cat "$tmp/le") / remote [$rrc] $(cat "$tmp/re")"; fi
}
same_err "past the set" points --seq hammersley --set-size 100 --start 90 --count 20
same_err "past 2^32" points --seq sobol --start 4294967295 --count 2
same_err "stratified not k^d" points --seq stratified --dims 2 --count 10
same_err "bad scramble" points --seq lhs --scramble owen --count 4
same_err "fast-owen is sobol only" points --seq halton --scramble fast-owen --count 4
same_err "too many dims" points --seq halton --dims 5000 --count 4
same_err "integrate over budget" integrate --integrand genz-gaussian --dims 6 \
    --method gauss-legendre --n 20 --max-evals 1000
same_err "integrate bad name" integrate --integrand nope --dims 2
same_err "integrate bad scene" integrate --scene "$tmp/l.csv"

# ---- the daemon saw no malformed frame from us; stop it by PID -------------------
"$QMC" stats --connect "$UNIX" > "$tmp/stats"
if grep -q '^malformed_frames  *0$' "$tmp/stats"; then ok
else bad "malformed frames: $(grep malformed "$tmp/stats")"; fi
kill "$pid"
if wait "$pid"; then ok; else bad "qmcd did not exit 0 on SIGTERM"; fi
pid=

finish
