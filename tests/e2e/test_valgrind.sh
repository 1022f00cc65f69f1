#!/bin/sh
# One end-to-end pass of qmcd under valgrind's memcheck: handshake, points
# (inline and through the shared-memory ring), integration jobs (one
# cancelled), malformed frames, hostile and invalid requests, STATS, SIGHUP,
# then SIGTERM.  valgrind must report no errors and no definite or indirect
# leaks (--error-exitcode), and qmcd must exit 0.  A sanitizer build cannot
# run under valgrind: `make sanitize` passes ASan binaries, which this
# test recognises and skips (the plain pass runs it).
# valgrind runs one thread at a time under a lock that is not fair by
# default: a worker deep in a job could hold it for seconds and starve the
# event loop, so a JOB_CANCEL went unread past the peer's 15 s socket
# timeout on a slow CI machine.  --fair-sched=yes hands the lock round in
# turn, as the kernel would.
# Env: QMC, QMCD.  Prints "N passed, M failed".
set -u
: "${QMC:?QMC must name the qmc binary}"
: "${QMCD:?QMCD must name the qmcd binary}"
PY=/usr/bin/python3
HERE="$(cd "$(dirname "$0")" && pwd)"
if nm "$QMCD" 2>/dev/null | grep -q __asan_init; then
    echo "test_valgrind: skipped for a sanitizer build"
    echo "0 passed, 0 failed"
    exit 0
fi
. "$(dirname "$0")/lib.sh"
count() { tally "$1" || bad "peer printed nothing: $(head -c 300 "$1")"; }
SOCK="$tmp/v.sock"
cat > "$tmp/qmcd.conf" <<CONF
threads = 2
max-inflight = 16
frame-timeout-ms = 3000
handshake-timeout-ms = 5000
shutdown-timeout-ms = 20000
CONF
valgrind --tool=memcheck --error-exitcode=99 --leak-check=full \
    --errors-for-leak-kinds=definite,indirect --show-leak-kinds=definite,indirect \
    --track-fds=no --fair-sched=yes --log-file="$tmp/valgrind.log" \
    "$QMCD" --foreground --config "$tmp/qmcd.conf" --listen "unix:$SOCK" \
    --ready-file "$tmp/ready" 2> "$tmp/qmcd.log" &
VPID=$!
pids="$pids $VPID"
# valgrind starts qmcd many times slower: six times lib.sh's default wait
wait_file "$tmp/ready" 1200
if [ ! -e "$tmp/ready" ]; then
    bad "qmcd under valgrind not ready: $(tail -c 500 "$tmp/valgrind.log")"
    echo "$pass passed, $fail failed"
    exit 1
fi
U="unix:$SOCK"
"$QMC" points --seq sobol --dims 5 --count 2000 --scramble owen --seed 4 --format f64 > "$tmp/ref5"
"$QMC" points --connect "$U" --seq sobol --dims 5 --count 2000 --scramble owen --seed 4 \
    --format f64 > "$tmp/got5" 2> "$tmp/cli.err"
if cmp -s "$tmp/ref5" "$tmp/got5"; then ok; else bad "points under valgrind differ: $(cat "$tmp/cli.err")"; fi
"$QMC" points --seq sobol --dims 4 --count 4096 --scramble owen --seed 9 --format f64 > "$tmp/ref.f64"
for sc in "ping $U" "pipeline $U 16" "concurrent $U 20" "disconnect $U" "cancel $U" \
          "malformed $U" "stats $U"; do
    # shellcheck disable=SC2086
    "$PY" "$HERE/qmcpeer.py" $sc > "$tmp/p.out" 2>&1
    count "$tmp/p.out"
done
"$QMC" integrate --integrand genz-gaussian --dims 3 --method rqmc --n 1024 --reps 8 --seed 5 \
    --json > "$tmp/job.json"
"$QMC" integrate --connect "$U" --integrand genz-gaussian --dims 3 --method rqmc --n 1024 \
    --reps 8 --seed 5 --json > "$tmp/rjob.json" 2> "$tmp/cli.err"
if cmp -s "$tmp/job.json" "$tmp/rjob.json" || \
   "$PY" -c 'import json,sys; a,b=(json.load(open(f)) for f in sys.argv[1:]); sys.exit(a["estimate"]!=b["estimate"] or a["stderr"]!=b["stderr"])' \
       "$tmp/job.json" "$tmp/rjob.json"; then ok
else bad "remote integrate under valgrind differs: $(cat "$tmp/cli.err")"; fi
for sc in "specs" "frames"; do
    "$PY" "$HERE/hostilepeer.py" $sc "$U" "$VPID" "$tmp/ref.f64" 512 > "$tmp/p.out" 2>&1
    count "$tmp/p.out"
done
kill -HUP "$VPID"
"$PY" "$HERE/qmcpeer.py" ping "$U" > "$tmp/p.out" 2>&1
count "$tmp/p.out"
kill -TERM "$VPID"
wait_gone "$VPID" 1200
wait "$VPID"
st=$?
forget "$VPID"
if [ $st -eq 0 ]; then ok
else bad "qmcd under valgrind exited $st: $(grep -A4 -m3 'Invalid\|uninitialised\|definitely lost\|indirectly lost' "$tmp/valgrind.log" | head -20)"; fi
if grep -q "ERROR SUMMARY: 0 errors" "$tmp/valgrind.log"; then ok
else bad "valgrind: $(grep 'ERROR SUMMARY' "$tmp/valgrind.log")"; fi
[ -n "${VALGRIND_VERBOSE:-}" ] && grep -E "ERROR SUMMARY|definitely|indirectly|in use at exit" "$tmp/valgrind.log"
finish
