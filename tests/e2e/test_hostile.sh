#!/bin/sh
# Hostile clients, load and faults against a live qmcd
# (tests/e2e/hostilepeer.py, on qmcpeer.py's independent codec).  After
# every case: the daemon is alive, serves another client the same bytes as
# `qmc points` in-process, and its VmRSS grew by less than RSS_MB.
#   - hostile frames: bad magic, version, flags, lengths 0 / max / 2^32-1,
#     unknown and server-only types, short and long payloads (POINTS,
#     INTEGRATE, PIXELS), bad codes in PIXELS, a header cut
#     short (EOF, and silence until frame-timeout-ms);
#   - invalid POINTS and INTEGRATE specs (an ERROR, the connection lives);
#   - 10,000 random frames; 40 slow-loris clients;
#   - 200 clients x 1000 mixed requests (PING, POINTS, INTEGRATE), every
#     answer checked, none lost;
#   - a saturated worker pool (jobs queue or are refused, never vanish);
#   - a client killed mid-stream, SIGKILL and restart on the stale socket,
#     SIGTERM with jobs running (exit 0, socket and lock file removed).
# Env: QMC, QMCD.  Prints "N passed, M failed".
set -u
: "${QMC:?QMC must name the qmc binary}"
: "${QMCD:?QMCD must name the qmcd binary}"
PY=/usr/bin/python3
HERE="$(cd "$(dirname "$0")" && pwd)"
. "$(dirname "$0")/lib.sh"
# Sanitizers and a loaded CI machine make the daemon larger, never the
# growth a leak or an unbounded buffer would cause (hundreds of MB).
RSS_MB=${HOSTILE_RSS_MB:-96}

# hostile SCENARIO ARGS...: runs a hostilepeer scenario, counts its lines.
hostile() {
    scenario=$1
    shift
    "$PY" "$HERE/hostilepeer.py" "$scenario" "unix:$SOCK" "$MAIN" "$tmp/ref.f64" "$RSS_MB" \
        "$@" > "$tmp/h.out" 2>&1
    tally "$tmp/h.out"
    h_st=$?
    [ -n "${HOSTILE_VERBOSE:-}" ] && grep -E "^ok (load|saturated|after)" "$tmp/h.out"
    [ $h_st -eq 0 ] || bad "hostile peer printed nothing: $(head -c 300 "$tmp/h.out")"
}

# start: this test's own, not lib.sh's: one daemon on $SOCK with
# $tmp/qmcd.conf, its log appended across restarts, its PID in $MAIN.  Here
# every wait_file is given 400 steps and every wait_gone 1200, twice and six
# times lib.sh's default: the daemon is waited for under the hostile load.
start() {
    rm -f "$tmp/ready"
    "$QMCD" --foreground --ready-file "$tmp/ready" --config "$tmp/qmcd.conf" \
        --listen "unix:$SOCK" 2>> "$tmp/qmcd.log" &
    MAIN=$!
    pids="$pids $MAIN"
    wait_file "$tmp/ready" 400 || { bad "qmcd not ready: $(tail -c 500 "$tmp/qmcd.log")"; return 1; }
}

cat > "$tmp/qmcd.conf" <<CONF
threads = 2
max-frame = 1048576
handshake-timeout-ms = 2000
frame-timeout-ms = 1500
job-time-limit-ms = 60000
shutdown-timeout-ms = 3000
max-jobs = 1024
max-jobs-per-conn = 16
# The load test's 200 clients are one peer (this uid): let them all in.
max-connections-per-peer = 1024
CONF
SOCK="$tmp/qmcd.sock"
"$QMC" points --seq sobol --dims 4 --count 4096 --scramble owen --seed 9 --format f64 \
    > "$tmp/ref.f64"
"$QMC" integrate --integrand genz-gaussian --dims 3 --method rqmc --n 1024 --reps 8 \
    --seed 5 --json > "$tmp/job.json"
start || { echo "$pass passed, $((fail + 1)) failed"; exit 1; }

hostile frames
hostile specs
hostile random_frames 10000 1
hostile slowloris 40
hostile load 200 1000 "$tmp/job.json"
hostile saturate 20

# A client killed mid-stream (SIGKILL, the socket reset), then others.
"$QMC" points --connect "unix:$SOCK" --seq sobol --dims 64 --count 50000000 \
    --format f64 > "$tmp/fifo.bin" 2>/dev/null &
CL=$!
i=0
while [ "$(stat -c %s "$tmp/fifo.bin" 2>/dev/null || echo 0)" -lt 1000000 ] && [ $i -lt 400 ]; do
    sleep 0.05; i=$((i + 1))
done
kill -9 "$CL" 2>/dev/null
wait "$CL" 2>/dev/null
hostile specs

# SIGKILL and restart: the stale socket file is replaced.
kill -9 "$MAIN"
wait_gone "$MAIN" 1200
wait "$MAIN" 2>/dev/null
if [ -S "$SOCK" ]; then ok; else bad "SIGKILL left no socket file to test"; fi
start || { echo "$pass passed, $((fail + 1)) failed"; exit 1; }
if grep -q "replaced a stale socket" "$tmp/qmcd.log"; then ok
else bad "restart after SIGKILL: stale socket not replaced"; fi
hostile specs

# SIGTERM with jobs running: exit 0, socket and lock file removed.
"$PY" "$HERE/qmcpeer.py" sigterm_jobs "unix:$SOCK" "$tmp/jobs.marker" > "$tmp/sigterm.out" 2>&1 &
PEER=$!
if wait_file "$tmp/jobs.marker" 400; then
    kill -TERM "$MAIN"
    if wait_gone "$MAIN" 1200; then
        wait "$MAIN"
        st=$?
        if [ $st -eq 0 ] && [ ! -e "$SOCK" ] && [ ! -e "$SOCK.lock" ]; then ok
        else bad "SIGTERM with jobs: exit $st, socket or lock file left"; fi
    else
        bad "SIGTERM with jobs: qmcd still running"
    fi
else
    bad "the SIGTERM peer never got its jobs accepted"
fi
wait "$PEER"
if grep -q '^FAIL' "$tmp/sigterm.out"; then bad "$(grep '^FAIL' "$tmp/sigterm.out")"; else ok; fi

if grep -q "ERROR: AddressSanitizer\|runtime error:" "$tmp/qmcd.log"; then
    bad "sanitizer report in the daemon log: $(grep -m1 "AddressSanitizer\|runtime error:" "$tmp/qmcd.log")"
fi
finish
