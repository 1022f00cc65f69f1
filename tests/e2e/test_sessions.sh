#!/bin/sh
# Integration sessions through a real qmcd (PROTOCOL.md section 6.21):
#   1. a built-in integrand evaluated by a client of libqmcclient
#      (tests/e2e/session_peer.c, which builds it with qmc_job_new as the CLI
#      does) gives `qmc integrate --json`'s result bit for bit, every method,
#      over a Unix socket (batches through the shared-memory ring) and TCP
#      (inline), with the callback and with ask/tell, and at small batches;
#   2. a dropped connection loses nothing: the session resumes from another
#      process, the unanswered batch is served again, and the result is
#      still the built-in job's;
#   3. ownership: another uid (nobody, through a socket it may use) with the
#      token is refused; over TCP another address is (sessionpeer.py);
#   4. NaN, Inf and 1e308 from the client are counted and flagged;
#   5. hostile values and frames, the ring's values, takeover, close,
#      expiry, the caps and STATS (tests/e2e/sessionpeer.py, from the spec);
# and the daemon serves another client throughout and exits cleanly.
# Env: QMC, QMCD, BUILD (for build/tests/session-peer).  Prints "N passed, M failed".
set -u
: "${QMC:?QMC must name the qmc binary}"
: "${QMCD:?QMCD must name the qmcd binary}"
: "${BUILD:?BUILD must name the build directory}"
HERE="$(cd "$(dirname "$0")" && pwd)"
. "$HERE/lib.sh"
PEER="$BUILD/tests/session-peer"
[ -x "$PEER" ] || { echo "FAIL: $PEER is missing (make $PEER)"; echo "0 passed, 1 failed"; exit 1; }
PY=/usr/bin/python3

# stop PID: SIGTERM, and a clean exit status.
stop() {
    kill -TERM "$1"
    if wait "$1"; then ok; else bad "daemon $1 did not exit cleanly: $(tail -n 5 "$2")"; fi
    forget "$1"
}

# same NAME A.json B.json: the fields of a result both print are equal,
# numbers bit for bit (Python's float reads %.17g exactly).
same() {
    if "$PY" - "$2" "$3" > "$tmp/same.out" 2>&1 <<'PYEOF'
import json, sys
a = json.load(open(sys.argv[1]))
b = json.load(open(sys.argv[2]))
keys = ["method_used", "detail", "auto_reason", "estimate", "stderr", "error_estimate",
        "ci_low", "ci_high", "n", "evals", "dims", "nonfinite", "flags"]
bad = [(k, a.get(k), b.get(k)) for k in keys if a.get(k) != b.get(k)]
print(bad or "same")
sys.exit(1 if bad else 0)
PYEOF
    then ok; else bad "$1: $(cat "$tmp/same.out")"; fi
}

serve() {
    start "$@" || exit 1
}

# ---- 1. bit for bit, every method ------------------------------------------------------
serve main --threads 2 --listen "unix:$tmp/s.sock" --listen tcp:127.0.0.1:0
D=$pid
U="unix:$tmp/s.sock"
T=$(grep -o 'tcp:127.0.0.1:[0-9]*' "$tmp/main.ready" | head -n 1)
[ -n "$T" ] || bad "no TCP address in the ready file: $(cat "$tmp/main.ready")"

while read -r m dims integrand extra; do
    # shellcheck disable=SC2086
    job="--integrand $integrand --dims $dims --method $m $extra"
    # shellcheck disable=SC2086
    if ! "$QMC" integrate $job --json > "$tmp/cli.json" 2> "$tmp/cli.err"; then
        bad "qmc integrate $job: $(cat "$tmp/cli.err")"; continue
    fi
    for how in "run $U" "asktell $U" "run $T" "asktell $T"; do
        # shellcheck disable=SC2086
        if $PEER $how $job > "$tmp/peer.json" 2> "$tmp/peer.err"; then
            same "$m ($integrand, $how)" "$tmp/peer.json" "$tmp/cli.json"
        else
            bad "session-peer $how $job: $(cat "$tmp/peer.err")"
        fi
    done
done <<'EOF'
auto 3 genz-gaussian
auto 6 genz-discontinuous --max-evals 200000
auto 2 genz-continuous
auto 8 genz-product-peak --max-evals 300000
mc 3 genz-oscillatory --seed 5
stratified 2 genz-product-peak
lhs 4 genz-corner-peak --seed 9
qmc 3 genz-gaussian --n 4096
qmc 3 genz-gaussian --n 1000 --seq halton --scramble faure
rqmc 5 genz-gaussian --reps 8 --n 16384 --seed 3
rqmc 4 genz-continuous --tol-rel 1e-4 --seed 2
rqmc 6 genz-discontinuous --reps 8 --split-net --n 8192
midpoint 2 genz-oscillatory
trapezoid 2 genz-gaussian --n 20
simpson 3 genz-product-peak --n 9
gauss-legendre 3 genz-gaussian --n 12
gauss-kronrod 1 exp
gauss-kronrod 1 inv-sqrt
cubature 3 genz-corner-peak
clenshaw-curtis 2 genz-oscillatory
EOF

# Small batches (max_batch below a block: the engine's chunks of 256) and
# large ones give the same bytes too.
"$QMC" integrate --integrand genz-gaussian --dims 4 --method rqmc --n 8192 --json > "$tmp/cli.json"
for mb in 100 4096 1048576; do
    if $PEER asktell "$U" --integrand genz-gaussian --dims 4 --method rqmc --n 8192 \
        --max-batch $mb > "$tmp/peer.json" 2> "$tmp/peer.err"; then
        same "rqmc, max_batch $mb" "$tmp/peer.json" "$tmp/cli.json"
    else
        bad "max_batch $mb: $(cat "$tmp/peer.err")"
    fi
done

# Batches of more than half the ring (262144 points of 4 dims and their
# values: three of its four 4 MiB slots), one after another: the client
# gives the slots back at each report, or the next batch would wait for a
# release that never comes (until write-timeout-ms) - the daemon sends each
# batch right behind its report, before it sums the values.
"$QMC" integrate --integrand genz-gaussian --dims 4 --method rqmc --n 65536 --json > "$tmp/cli.json"
if $PEER asktell "$U" --integrand genz-gaussian --dims 4 --method rqmc --n 65536 \
    --max-batch 262144 > "$tmp/peer.json" 2> "$tmp/peer.err"; then
    same "rqmc, batches of 3/4 of the ring" "$tmp/peer.json" "$tmp/cli.json"
else
    bad "batches of 3/4 of the ring: $(cat "$tmp/peer.err")"
fi

# ---- 2. a dropped connection: resumed from another process -------------------------
JOB="--integrand genz-product-peak --dims 5 --method rqmc --reps 16 --n 8192"
# shellcheck disable=SC2086
"$QMC" integrate $JOB --json > "$tmp/cli.json"
JOB="$JOB --max-batch 8192" # a batch a replicate: the dropped one is batch 1 of 16
for ep in "$U" "$T"; do
    rm -f "$tmp/ticket"
    # shellcheck disable=SC2086
    if $PEER drop "$ep" "$tmp/ticket" $JOB > "$tmp/drop.out" 2> "$tmp/drop.err"; then ok
    else bad "drop on $ep: $(cat "$tmp/drop.err")"; fi
    # shellcheck disable=SC2086
    if $PEER resume "$ep" "$tmp/ticket" $JOB > "$tmp/resume.out" 2> "$tmp/resume.err"; then
        grep -q '^served again: yes' "$tmp/resume.out" && ok ||
            bad "resume on $ep: the dropped batch was not served again: $(cat "$tmp/resume.out")"
        tail -n 1 "$tmp/resume.out" > "$tmp/peer.json"
        same "resumed on $ep, the built-in job's result" "$tmp/peer.json" "$tmp/cli.json"
    else
        bad "resume on $ep: $(cat "$tmp/resume.out" "$tmp/resume.err")"
    fi
done

# ---- 3. ownership: another uid with the token ------------------------------------------
if [ "$(id -u)" -eq 0 ] && command -v setpriv > /dev/null && id nobody > /dev/null 2>&1; then
    chmod 0711 "$tmp"
    chmod 0666 "$tmp/s.sock"
    cp "$PEER" "$tmp/peer-as-nobody"
    chmod 0755 "$tmp/peer-as-nobody"
    rm -f "$tmp/ticket"
    # shellcheck disable=SC2086
    $PEER drop "$U" "$tmp/ticket" $JOB > /dev/null 2> "$tmp/drop.err" || bad "drop: $(cat "$tmp/drop.err")"
    chmod 0644 "$tmp/ticket"
    if setpriv --reuid=nobody --regid=nogroup --clear-groups "$tmp/peer-as-nobody" \
        steal "$U" "$tmp/ticket" > "$tmp/steal.out" 2> "$tmp/steal.err"; then
        grep -q '^resume: -2 no session' "$tmp/steal.out" && ok ||
            bad "another uid with the token: $(cat "$tmp/steal.out" "$tmp/steal.err")"
    else
        bad "the peer as nobody: $(cat "$tmp/steal.out" "$tmp/steal.err")"
    fi
    # ... and the owner still can, after the stranger's try.
    # shellcheck disable=SC2086
    if $PEER resume "$U" "$tmp/ticket" $JOB > "$tmp/resume.out" 2> "$tmp/resume.err"; then
        tail -n 1 "$tmp/resume.out" > "$tmp/peer.json"
        same "the owner resumes after another uid was refused" "$tmp/peer.json" "$tmp/cli.json"
    else
        bad "the owner's resume: $(cat "$tmp/resume.err")"
    fi
else
    echo "(skipped: another uid needs root, setpriv and nobody)"
fi

# ---- 4. non-finite values from the client ----------------------------------------------
if $PEER hostile "$U" > "$tmp/hostile.out" 2> "$tmp/hostile.err"; then
    grep -q '^sent nonfinite 2; report nonfinite 2 end cannot_tell; result err 0 nonfinite 2 flags.* nonfinite' \
        "$tmp/hostile.out" && ok || bad "NaN and Inf: $(cat "$tmp/hostile.out")"
    grep -q 'error_unreliable' "$tmp/hostile.out" && ok || bad "not flagged: $(cat "$tmp/hostile.out")"
else
    bad "hostile values: $(cat "$tmp/hostile.err")"
fi

# ---- 5. the Python peer: hostile frames, the ring, takeover, close -------------------
run_peer "$HERE/sessionpeer.py" hostile "$U"
run_peer "$HERE/sessionpeer.py" ring "$U"
run_peer "$HERE/sessionpeer.py" resume "$T" 127.0.0.2
run_peer "$HERE/sessionpeer.py" stats "$U"
# The daemon still serves a plain job, with the CLI's bytes.
"$QMC" integrate --integrand genz-gaussian --dims 3 --method rqmc --json > "$tmp/a.json"
"$QMC" integrate --integrand genz-gaussian --dims 3 --method rqmc --json --connect "$U" > "$tmp/b.json" ||
    bad "a job after the sessions"
same "a job after all the sessions" "$tmp/a.json" "$tmp/b.json"
stop "$D" "$tmp/main.log"

# ---- 6. expiry and caps, on daemons with small limits ---------------------------------
# Each on its own daemon: caps parks a session and needs it still counted
# when its next SESSION_OPEN arrives, which a 300 ms idle timeout would
# race on a slow machine (the parked session gone, the open accepted).
serve small --threads 1 --listen "unix:$tmp/small.sock" --session-idle-timeout-ms 300
run_peer "$HERE/sessionpeer.py" expire "unix:$tmp/small.sock"
grep -q 'session [0-9]* expired: parked for' "$tmp/small.log" && ok ||
    bad "no expiry logged: $(tail -n 5 "$tmp/small.log")"
stop "$pid" "$tmp/small.log"
serve caps --threads 1 --listen "unix:$tmp/caps.sock" --max-sessions-per-peer 3
run_peer "$HERE/sessionpeer.py" caps "unix:$tmp/caps.sock" 3
stop "$pid" "$tmp/caps.log"

finish
