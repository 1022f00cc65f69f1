#!/bin/sh
# End-to-end checks of qmcd against a real, independent peer
# (tests/e2e/qmcpeer.py: Python struct + socket, written from
# protocol/PROTOCOL.md).  Daemons run on a temporary Unix socket and on
# loopback TCP port 0 (IPv4 and IPv6); readiness is a --ready-file polled
# briefly; every daemon is stopped by PID.  Checks: handshake and HELLO_OK
# fields, PING, POINTS byte-for-byte against `qmc points`, INTEGRATE
# bit-for-bit against `qmc integrate --json`, pipelining, 200 concurrent
# clients, a client vanishing mid-stream, a client that never reads (VmRSS
# stays bounded), job cancel and time limit, malformed and oversized
# frames, partial-frame and handshake deadlines, STATS, SIGHUP reload,
# max-connections, stale and live sockets, SIGTERM with jobs running,
# daemonizing, and the shared-memory transport (the same bytes as inline,
# the memfd rules, no descriptor left in the daemon, releases, a client
# that never releases, TCP refused, max-shm-bytes, its write timeout).
# Env: QMC, QMCD (binaries), BUILD.  Prints "N passed, M failed".
set -u
: "${QMC:?QMC must name the qmc binary}"
: "${QMCD:?QMCD must name the qmcd binary}"
PY=/usr/bin/python3
PEER="$(cd "$(dirname "$0")" && pwd)/qmcpeer.py"
. "$(dirname "$0")/lib.sh"

# peer SCENARIO ARGS...: runs a qmcpeer scenario and counts its ok/FAIL lines.
peer() { run_peer "$PEER" "$@"; }

FP=$("$QMC" --version | sed -n 's/.*fingerprint: *//p')

# The main daemon keeps the default handshake, frame and job deadlines.
# A short job-time-limit-ms here raced the scenarios that must find a long
# job still running - JOB_CANCEL's, and SIGTERM's - which a slow machine
# would see answered ETIMEDOUT instead; short frame and handshake
# deadlines were margins every other scenario had to keep.  Section 10's
# own daemon has the short ones, so that they are still seen quickly.
cat > "$tmp/qmcd.conf" <<EOF
threads = 2
log-level = info
max-inflight = 16
# 200 concurrent clients below are one peer (this uid): let them all in.
max-connections-per-peer = 1024
shutdown-timeout-ms = 1500
EOF
SOCK="$tmp/qmcd.sock"
start main --config "$tmp/qmcd.conf" --listen "unix:$SOCK" --listen tcp:127.0.0.1:0 \
    --listen "tcp:[::1]:0" || { echo "$pass passed, $((fail + 1)) failed"; exit 1; }
MAIN=$pid
U="unix:$SOCK"
T4=$(grep '^tcp:127' "$tmp/main.ready")
T6=$(grep '^tcp:\[' "$tmp/main.ready")
case $T4 in tcp:127.0.0.1:0 | "") bad "no bound IPv4 port in the ready file" ;; *) ok ;; esac
if [ "$(stat -c %a "$SOCK")" = 660 ]; then ok; else bad "socket mode $(stat -c %a "$SOCK")"; fi

# 1. Handshake, PING on every listener.
peer hello "$U" "$FP"
peer ping "$T4"
peer ping "$T6"

# 2. POINTS equal `qmc points --format F` byte for byte (chunks concatenated).
# kind dims scramble seed set_size start count format flags (shuffle = 1)
while read -r kind dims scr seed set start count fmt flags; do
    peer points "$T4" "$tmp/d.bin" "$kind" "$dims" "$scr" "$seed" "$set" "$start" "$count" "$fmt" "$flags"
    extra=""
    [ "$set" != 0 ] && extra="--set-size $set"
    [ "$flags" = 1 ] && extra="$extra --shuffle"
    # shellcheck disable=SC2086
    "$QMC" points --seq "$kind" --dims "$dims" --scramble "$scr" --seed "$seed" --start "$start" \
        --count "$count" --format "$fmt" $extra > "$tmp/c.bin"
    if cmp -s "$tmp/d.bin" "$tmp/c.bin"; then ok
    else bad "POINTS $kind $dims $scr $fmt differs from qmc points ($(wc -c < "$tmp/d.bin") vs $(wc -c < "$tmp/c.bin") bytes)"; fi
done <<EOF
sobol 3 none 0 0 0 1000 f64 0
sobol 32 owen 7 0 100 20000 f64 0
sobol 5 shift 3 0 12345 777 f64 0
sobol 4 owen 9 0 0 3000 f64 1
sobol 21 fast-owen 4294967296 0 77 5000 u32 0
sobol 40 fast-owen 7 0 3 2000 f64 0
sobol 21201 none 0 0 5 7 f64 0
halton 4 faure 0 0 10 500 f64 0
halton 6 owen 5 0 0 999 f32 0
hammersley 2 none 0 1024 0 1024 f64 0
random 3 none 5 0 0 400 u32 0
stratified 2 none 4 256 0 256 f64 0
lhs 4 none 3 1000 0 1000 f64 0
EOF

# 3. Refused POINTS: the library's one-line reason, the connection lives on.
peer points_error "$U" sobol 30000 none 0 0 8 -1005
peer points_error "$U" stratified 2 none 10 0 10 -1007
peer points_error "$U" halton 2 fast-owen 0 0 10 -1004
peer points_error "$U" sobol 2 none 0 4294967295 5 -1006
peer points_error "$U" sobol 2 none 0 0 100000000 -1011

# 4. INTEGRATE equals `qmc integrate --json` (estimate and stderr bits).
while read -r fn dims method n reps seed; do
    nopt=""
    [ "$n" != 0 ] && nopt="--n $n"
    [ "$reps" != 0 ] && nopt="$nopt --reps $reps"
    # shellcheck disable=SC2086
    "$QMC" integrate --integrand "$fn" --dims "$dims" --method "$method" $nopt --seed "$seed" \
        --json > "$tmp/cli.json"
    peer integrate "$U" "$tmp/cli.json" "$fn" "$dims" "$method" "$n" "$reps" "$seed"
done <<EOF
genz-gaussian 4 rqmc 4096 0 3
genz-oscillatory 6 rqmc 20000 8 11
genz-product-peak 5 auto 0 0 2
genz-gaussian 2 auto 0 0 0
genz-corner-peak 3 mc 10000 0 4
EOF

# 5. Pipelining, max-inflight; 6. 200 concurrent clients.
peer pipeline "$U" 16
peer concurrent "$U" 200
# 7. A client vanishing mid-stream; 8. one that never reads.
peer disconnect "$T4"
peer noread "$U" "$MAIN" 48
# 8b. The shared-memory ring (PROTOCOL.md section 10).
peer shm "$U" "$T4" "$MAIN" 16
# 8c. `qmc points --connect unix:` takes a ring by itself: while the stream
# runs (held up by a pipe we read slowly) the daemon maps the client's
# memfd; the bytes equal the in-process ones.
mkfifo "$tmp/fifo"
"$QMC" points --seq sobol --dims 16 --count 400000 --scramble owen --seed 3 --format f64 \
    --connect "$U" > "$tmp/fifo" 2> "$tmp/shmcli.err" &
QPID=$!
exec 3< "$tmp/fifo"
dd bs=65536 count=16 iflag=fullblock <&3 > "$tmp/shm1.bin" 2> /dev/null
maps=$(grep -c "memfd:qmc-client-ring" "/proc/$MAIN/maps")
cat <&3 >> "$tmp/shm1.bin"
exec 3<&-
wait "$QPID"
st=$?
"$QMC" points --seq sobol --dims 16 --count 400000 --scramble owen --seed 3 --format f64 \
    > "$tmp/shm2.bin"
if [ "$maps" -ge 1 ]; then ok; else bad "qmc points --connect unix: attached no ring"; fi
if [ $st -eq 0 ] && cmp -s "$tmp/shm1.bin" "$tmp/shm2.bin"; then ok
else bad "qmc points through the ring differs from in-process (exit $st): $(head -c 200 "$tmp/shmcli.err")"; fi
# 9. Jobs: cancel (the time limit is section 10's).
peer cancel "$U"
# 10. Malformed, oversized frames; then, on a daemon of their own with
# short deadlines, the job time limit, a partial frame, the handshake, and
# a pipelining client that stops reading, which frame-timeout-ms must not
# cut (the daemon, not the peer, holds its frames back).
peer malformed "$T4"
cat > "$tmp/deadline.conf" <<EOF
threads = 2
log-level = info
handshake-timeout-ms = 1000
frame-timeout-ms = 1000
job-time-limit-ms = 2500
EOF
if start dl --config "$tmp/deadline.conf" --listen "unix:$tmp/dl.sock"; then
    DL=$pid
    peer timeout "unix:$tmp/dl.sock"
    peer partial "unix:$tmp/dl.sock"
    peer laggard "unix:$tmp/dl.sock"
    kill -TERM "$DL"
    # The wait only bounds a hang (a sanitized daemon exits slowly).
    if wait_exit "$DL" 60 && wait "$DL"; then ok; else bad "deadline daemon: SIGTERM"; fi
    forget "$DL"
fi
# 11. STATS; 12. SIGHUP reload without reconnecting.
peer stats "$U"
peer reload "$U" "$tmp/qmcd.conf" "$MAIN" "$tmp/main.log"
if grep -q "reload rejected.*no-such-key" "$tmp/main.log"; then ok
else bad "a bad config on SIGHUP was not logged with the problem"; fi

# 13. max-connections; live socket refused; stale socket replaced.
B="$tmp/b.sock"
start b --listen "unix:$B" --max-connections 2 --threads 1
BPID=$pid
peer maxconn "unix:$B" 2
if "$QMCD" --foreground --listen "unix:$B" > "$tmp/live.out" 2>&1; then
    bad "a second qmcd started on a live socket"
elif [ "$(wc -l < "$tmp/live.out")" -eq 1 ] && grep -q "another server is listening" "$tmp/live.out"; then ok
else bad "live socket: unexpected message: $(cat "$tmp/live.out")"; fi
if [ ! -e "$B.lock" ]; then ok; else bad "lock file left beside a path qmcd refused"; fi
kill -9 "$BPID"
wait_exit "$BPID" 5
[ -S "$B" ] || bad "the killed daemon's socket file is gone; no stale file to test"
start b2 --listen "unix:$B" --threads 1 --write-timeout-ms 1000 --max-shm-bytes 1M
B2PID=$pid
if grep -q "replaced a stale socket" "$tmp/b2.log"; then ok; else bad "stale socket not reported"; fi
peer ping "unix:$B"
peer stall "unix:$B"
peer shm_limits "unix:$B" 1048576
kill -TERM "$B2PID"
# Exit waits here bound a hang only: a sanitized daemon on a loaded machine
# (LeakSanitizer's scan at exit) may take seconds.
if wait_exit "$B2PID" 60 && wait "$B2PID" && [ ! -e "$B" ] && [ ! -e "$B.lock" ]; then ok
else bad "idle daemon: SIGTERM did not exit 0 and remove its socket and lock file"; fi

# 13b. Listener specs that would bind something else than was asked:
# port 70000 (getaddrinfo takes it mod 65536), a non-numeric port, and
# unix: with no path (Linux's abstract autobind, no file permissions).
for spec in tcp:127.0.0.1:70000 tcp:127.0.0.1:http tcp:127.0.0.1:-1 unix:; do
    if "$QMCD" --foreground --listen "$spec" > "$tmp/spec.out" 2>&1; then
        bad "qmcd started with --listen $spec"
    elif [ "$(wc -l < "$tmp/spec.out")" -eq 1 ] && grep -q "${spec%%:*}:" "$tmp/spec.out"; then ok
    else bad "--listen $spec: unexpected message: $(cat "$tmp/spec.out")"; fi
done

# 14. Bad configuration: one line naming file and line, exit 2.
printf 'threads = 2\nmax-points = lots\n' > "$tmp/bad.conf"
"$QMCD" --foreground --config "$tmp/bad.conf" --listen "unix:$tmp/x.sock" > "$tmp/bad.out" 2>&1
st=$?
if [ $st -eq 2 ] && [ "$(wc -l < "$tmp/bad.out")" -eq 1 ] && grep -q "bad.conf:2: max-points" "$tmp/bad.out"; then ok
else bad "bad config: exit $st, $(cat "$tmp/bad.out")"; fi

# 15. Daemonized (no --foreground): the parent returns once ready.
if "$QMCD" --listen "unix:$tmp/d.sock" --ready-file "$tmp/d.ready" --threads 1 2> "$tmp/d.log"; then
    DPID=$(sed -n 's/^pid //p' "$tmp/d.ready")
    pids="$pids $DPID"
    peer ping "unix:$tmp/d.sock"
    kill -TERM "$DPID"
    wait_gone "$DPID" 1200
    if ! kill -0 "$DPID" 2>/dev/null && [ ! -e "$tmp/d.sock" ]; then ok
    else bad "daemonized qmcd did not stop on SIGTERM"; fi
else
    bad "daemonized start failed: $(cat "$tmp/d.log")"
fi

# 16. SIGTERM with jobs running: answered, exit 0 within the deadline, socket removed.
"$PY" "$PEER" sigterm_jobs "$U" "$tmp/jobs.marker" > "$tmp/sigterm.out" 2>&1 &
PEERPID=$!
if wait_file "$tmp/jobs.marker"; then
    kill -TERM "$MAIN"
    # State, not time: the jobs were answered (the peer checks ERROR
    # ESHUTDOWN before the close), the exit status is 0 and nothing is
    # left on disk.  The 60 s wait only guards against a hang.
    if wait_exit "$MAIN" 60; then
        wait "$MAIN"
        st=$?
        if [ $st -eq 0 ]; then ok
        else bad "SIGTERM with jobs: exit $st"; fi
        if [ ! -e "$SOCK" ]; then ok; else bad "socket file left after SIGTERM"; fi
        if [ ! -e "$SOCK.lock" ]; then ok; else bad "lock file left after SIGTERM"; fi
    else
        bad "SIGTERM with jobs: still running after 60 s"
    fi
else
    bad "sigterm peer never got its jobs accepted"
fi
wait "$PEERPID"
n_ok=$(grep -c '^ok ' "$tmp/sigterm.out")
pass=$((pass + n_ok))
if grep '^FAIL' "$tmp/sigterm.out"; then fail=$((fail + 1)); fi
[ "$n_ok" -gt 0 ] || bad "sigterm peer: $(cat "$tmp/sigterm.out")"

# ---- 17. Cancelling the methods that run no sampling blocks -----------------
# Cubature, tensor rules and Gauss-Legendre's nodes stop through
# qmc_integrate's interrupt hook (tests/e2e/cancelpeer.py).  Each stopped
# job is compared with a twin of at most half its work started with it and
# left running, never with a wall-clock threshold: after a JOB_CANCEL or
# the job time limit it must be answered while the twin still runs; at the
# SIGTERM drain deadline it must be answered before the daemon closes.
CPEER="$(cd "$(dirname "$0")" && pwd)/cancelpeer.py"
cpeer() {
    saved_peer=$PEER
    PEER=$CPEER
    peer "$@"
    PEER=$saved_peer
}
cat > "$tmp/cancel.conf" <<EOF
threads = 2
log-level = info
shutdown-timeout-ms = 300
EOF
if start cx --config "$tmp/cancel.conf" --listen "unix:$tmp/cx.sock"; then
    CX=$pid
    if start cy --threads 1 --job-time-limit-ms 300 --listen "unix:$tmp/cy.sock"; then
        CY=$pid
        for m in cubature gauss-legendre; do
            cpeer race "unix:$tmp/cx.sock" "$m"
            cpeer timelimit "unix:$tmp/cy.sock" "unix:$tmp/cx.sock" "$m"
        done
        kill -TERM "$CY"
        if wait_exit "$CY" 60 && wait "$CY"; then ok; else bad "time-limit daemon: SIGTERM"; fi
    fi
    # SIGTERM with a Gauss-Legendre job in its nodes: answered at the drain
    # deadline, exit 0, and no job left to force the exit.
    "$PY" "$CPEER" sigterm "unix:$tmp/cx.sock" gauss-legendre "$tmp/cx.marker" \
        > "$tmp/cx-sigterm.out" 2>&1 &
    CPEERPID=$!
    if wait_file "$tmp/cx.marker"; then
        kill -TERM "$CX"
        if wait_exit "$CX" 60 && wait "$CX"; then ok
        else bad "SIGTERM with a gauss-legendre job: no clean exit"; fi
        if grep -q "ignored their cancel" "$tmp/cx.log"; then
            bad "SIGTERM: a job ignored its cancel: $(grep 'ignored' "$tmp/cx.log")"
        else ok; fi
    else
        bad "cancel sigterm peer never got its job running: $(cat "$tmp/cx-sigterm.out")"
    fi
    wait "$CPEERPID"
    n_ok=$(grep -c '^ok ' "$tmp/cx-sigterm.out")
    pass=$((pass + n_ok))
    n_bad=$(grep -c '^FAIL' "$tmp/cx-sigterm.out")
    fail=$((fail + n_bad))
    grep '^FAIL' "$tmp/cx-sigterm.out"
    [ "$n_ok" -gt 0 ] || bad "cancel sigterm peer: $(cat "$tmp/cx-sigterm.out")"
fi

# Sanitized builds: any report in a daemon's log is a failure.
if grep -l -E "AddressSanitizer|LeakSanitizer|runtime error" "$tmp"/*.log; then
    bad "sanitizer report in a daemon log"
else ok; fi
if [ $fail -ne 0 ]; then
    echo "--- main daemon log (tail)"
    tail -n 30 "$tmp/main.log"
fi
finish
