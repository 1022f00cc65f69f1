#!/bin/sh
# test_session_parts.sh - `qmc integrate --command ... --part K/P` through
# qmcd (a part session, protocol version 6: SESSION_PART and
# SESSION_PART_SUMS carry its block sums) gives the in-process part file,
# and `qmc merge` of the parts gives the whole run, bit for bit.
#
#   1. For mc, stratified, lhs, qmc and rqmc, every part of K (3, and 4
#      for rqmc), over a unix: socket (batches through the shared-memory
#      ring) and, for rqmc, over TCP (inline): each part file equals the
#      in-process one but for its wall time (the `seconds` line, and so
#      the digest over it); merging the daemon's parts gives every field
#      of the whole run's JSON (in-process and on the daemon), and the
#      merge of the in-process parts the same.
#   2. The oracle independent of the program: f = exp(x1 + x2 + x3) has
#      the integral (e - 1)^3; each merged estimate lies within 5 of its
#      own standard errors of it (and the bar is below 1e-2 of it, so the
#      check can fail); plain qmc, which has no bar, within 1e-3.
#   3. A part of no blocks (P above the job's blocks) is the same file
#      both ways.
#   4. An oversized part (its block sums past max-sessions-memory-per-peer)
#      gets one clear line and exit 2, and the daemon serves on.
#   5. Through libqmcclient's API (tests/e2e/session_peer.c) with built-in
#      integrands: a part's sums (qmc_client_session_part) are libqmc's
#      in-process qmc_session_part, bit for bit, over unix: and tcp:; the
#      parts no CLI would send - k > p, 0/p, a tolerance, a rule, a budget
#      past its budget - are refused with the core's reason (0/p once
#      made the daemon size it as 2^64 bytes); and on a
#      connection that chose version 5 (sessionpeer.py) a part is refused
#      with ENOTSUP naming version 6.
#   6. A part session whose client went after its last batch, before its
#      sums, is resumed: done, its sums whole and libqmc's.
# Env: QMC, QMCD, BUILD (for build/tests/session-peer).  Needs /usr/bin/python3 with numpy.  Prints "N passed, M failed".
set -u
: "${QMC:?set QMC to the qmc binary}"
: "${QMCD:?set QMCD to the qmcd binary}"
: "${BUILD:?BUILD must name the build directory}"
. "$(dirname "$0")/lib.sh"
PY=/usr/bin/python3
T="timeout 300"

# exp(x1 + ... + xd), reading whole batches (text or f64), as a user would
# (tests/e2e/batchfn.py, shared with test_command_cli.sh).
cp "$(dirname "$0")/batchfn.py" "$tmp/batchfn.py"

errlines() { grep -v "^==[0-9]*==WARNING: ASan doesn't fully support makecontext/swapcontext" "$tmp/err"; }
# A part file without its wall time: the seconds line and the digest over it.
timeless() { grep -v -e '^seconds ' -e '^digest sha256 ' "$1"; }
# Every field of two reports but the seconds.
same_json() { # A B: 0 when equal
    $PY - "$1" "$2" <<'EOF'
import json, sys
a, b = (json.load(open(f)) for f in sys.argv[1:3])
for r in (a, b):
    r.pop("seconds", None)
sys.exit(0 if a == b and a else 1)
EOF
}
# The merged estimate against (e - 1)^3, within 5 standard errors; for
# plain qmc, which has no bar, within 1e-3 of it (Sobol's error for this
# smooth f at 65536 points is about 2e-5 relative).
near_exact() { # JSON
    $PY - "$1" <<'EOF'
import json, math, sys
r = json.load(open(sys.argv[1]))
exact = (math.e - 1.0) ** 3
est, se = r["estimate"], r["stderr"]
if r["method"].startswith("qmc"):
    ok = abs(est - exact) <= 1e-3 * exact
else:
    ok = se is not None and 0 < se < 1e-2 * exact and abs(est - exact) <= 5 * se
print("estimate %.17g stderr %.3g exact %.17g: %s" % (est, se or 0, exact, "ok" if ok else "off"))
sys.exit(0 if ok else 1)
EOF
}

start d --listen "unix:$tmp/d.sock" --listen tcp:127.0.0.1:0 || finish
U="unix:$tmp/d.sock"
tcp=$(grep '^tcp:' "$tmp/d.ready")

# ---- 1 and 2: every part, both ways, merged --------------------------------------------
n=0
for spec in "3 f64 $U rqmc --n 16384 --reps 8 --seed 5" \
            "4 text $U rqmc --n 8192 --reps 6 --seed 2" \
            "3 f64 $tcp rqmc --n 8192 --reps 4 --seed 7" \
            "3 f64 $U mc --n 40000 --seed 3" \
            "3 text $U stratified --n 27000 --seed 4" \
            "3 f64 $U lhs --n 20000 --reps 2 --seed 6" \
            "3 f64 $U qmc --n 65536"; do
    n=$((n + 1))
    # shellcheck disable=SC2086
    set -- $spec
    K=$1 fmt=$2 ep=$3
    shift 3
    C="$PY $tmp/batchfn.py $fmt expsum 3"
    J="--dims 3 --command-format $fmt --smoothness smooth --method $*"
    # shellcheck disable=SC2086
    $T "$QMC" integrate --command "$C" $J --json > "$tmp/whole$n.json" 2> "$tmp/err" ||
        bad "case $n: the whole run failed: $(errlines)"
    # shellcheck disable=SC2086
    $T "$QMC" integrate --connect "$ep" --command "$C" $J --json > "$tmp/rwhole$n.json" \
        2> "$tmp/err" || bad "case $n: the whole run on the daemon failed: $(errlines)"
    locals="" remotes=""
    k=1
    while [ $k -le "$K" ]; do
        # shellcheck disable=SC2086
        $T "$QMC" integrate --command "$C" $J --part $k/$K > "$tmp/l$n.$k" 2> "$tmp/err" ||
            bad "case $n: in-process part $k/$K failed: $(errlines)"
        # shellcheck disable=SC2086
        $T "$QMC" integrate --connect "$ep" --command "$C" $J --part $k/$K > "$tmp/r$n.$k" \
            2> "$tmp/err" || bad "case $n: part $k/$K on the daemon failed: $(errlines)"
        timeless "$tmp/l$n.$k" > "$tmp/lt"
        timeless "$tmp/r$n.$k" > "$tmp/rt"
        if grep -q '^sums ' "$tmp/lt" && cmp -s "$tmp/lt" "$tmp/rt"; then ok
        else bad "case $n ($*): part $k/$K from the daemon differs from in-process"
             diff "$tmp/lt" "$tmp/rt" | head -5; fi
        locals="$locals $tmp/l$n.$k"
        remotes="$tmp/r$n.$k $remotes" # merged in another order
        k=$((k + 1))
    done
    # shellcheck disable=SC2086
    "$QMC" merge --json $remotes > "$tmp/merged$n.json" 2> "$tmp/err" ||
        bad "case $n: merging the daemon's parts failed: $(errlines)"
    # shellcheck disable=SC2086
    "$QMC" merge --json $locals > "$tmp/lmerged$n.json" 2> "$tmp/err" ||
        bad "case $n: merging the in-process parts failed: $(errlines)"
    if same_json "$tmp/whole$n.json" "$tmp/merged$n.json"; then ok
    else bad "case $n ($*): the daemon's parts merged differ from the whole run"
         diff "$tmp/whole$n.json" "$tmp/merged$n.json"; fi
    if same_json "$tmp/rwhole$n.json" "$tmp/merged$n.json" &&
       same_json "$tmp/lmerged$n.json" "$tmp/merged$n.json"; then ok
    else bad "case $n ($*): merged parts differ from the daemon's whole run or the local merge"; fi
    if near_exact "$tmp/merged$n.json" > "$tmp/near"; then ok
    else bad "case $n ($*): $(cat "$tmp/near")"; fi
done

# ---- 3. a part of no blocks (2 blocks in 3 parts: part 1 is [0, 0)) --------------------------------------------------------------
J="--dims 3 --command-format f64 --method rqmc --n 4096 --reps 2 --seed 1"
# shellcheck disable=SC2086
$T "$QMC" integrate --command "$PY $tmp/batchfn.py f64 expsum 3" $J --part 1/3 > "$tmp/e.l" 2> "$tmp/err"
lrc=$?
# shellcheck disable=SC2086
$T "$QMC" integrate --connect "$U" --command "$PY $tmp/batchfn.py f64 expsum 3" $J --part 1/3 \
    > "$tmp/e.r" 2> "$tmp/err"
rrc=$?
timeless "$tmp/e.l" > "$tmp/lt"
timeless "$tmp/e.r" > "$tmp/rt"
if [ $lrc -eq 0 ] && [ $rrc -eq 0 ] && ! grep -q '^sums ' "$tmp/rt" && cmp -s "$tmp/lt" "$tmp/rt"
then ok
else bad "an empty part: exit $lrc / $rrc, $(errlines)"; diff "$tmp/lt" "$tmp/rt" | head -5; fi

# ---- 4. an oversized part ------------------------------------------------------------------
start small --listen "unix:$tmp/small.sock" --max-sessions-memory-per-peer 8388608 || finish
# 64 x 2^20 points: 16384 blocks, 10 MB of block sums for part 1/1.
$T "$QMC" integrate --connect "unix:$tmp/small.sock" --command "$PY $tmp/batchfn.py f64 expsum 3" \
    --dims 3 --command-format f64 --method rqmc --n 1048576 --reps 64 --part 1/1 \
    > "$tmp/out" 2> "$tmp/err"
rc=$?
if [ $rc -eq 2 ] && [ ! -s "$tmp/out" ] && [ "$(errlines | wc -l)" -eq 1 ] &&
   errlines | grep -q 'max-sessions-memory-per-peer'; then ok
else bad "an oversized part: exit $rc, '$(errlines)'"; fi
# The daemon serves on: a small part there is the in-process file.
J="--dims 3 --command-format f64 --smoothness smooth --method rqmc --n 8192 --reps 4 --seed 7"
# shellcheck disable=SC2086
$T "$QMC" integrate --connect "unix:$tmp/small.sock" --command "$PY $tmp/batchfn.py f64 expsum 3" $J \
    --part 2/3 > "$tmp/s.r" 2> "$tmp/err" || bad "after the refusal: $(errlines)"
timeless "$tmp/s.r" > "$tmp/rt"
timeless "$tmp/l3.2" > "$tmp/lt"
if grep -q '^sums ' "$tmp/rt" && cmp -s "$tmp/lt" "$tmp/rt"; then ok
else bad "a part after the refusal differs from in-process"; fi

# ---- 5. the client API, hostile parts, version 5 -------------------------------------------
PEER="$BUILD/tests/session-peer"
G="--integrand genz-gaussian --dims 3"
for c in "$U 2/3 $G --method rqmc --n 4096 --reps 16 --seed 7" \
         "$tcp 3/3 $G --method rqmc --n 4096 --reps 16 --seed 7" \
         "$U 1/1 $G --method mc --n 10000 --seed 2" \
         "$U 4/5 $G --method lhs --n 9000 --reps 3" \
         "$U 2/2 $G --method rqmc --n 8192 --reps 8 --max-batch 256"; do
    # shellcheck disable=SC2086
    set -- $c
    ep=$1 kp=$2
    shift 2
    if "$PEER" part "$ep" "$kp" "$@" > "$tmp/p.out" 2> "$tmp/p.err" &&
       grep -q "^part $kp: .*: the in-process sums$" "$tmp/p.out"; then ok
    else bad "session-peer part $kp $*: $(cat "$tmp/p.out" "$tmp/p.err")"; fi
done
refused() { # CODE TEXT K/P JOB...: the open is refused with CODE and TEXT
    code=$1 text=$2 kp=$3
    shift 3
    "$PEER" part "$U" "$kp" "$@" > "$tmp/p.out" 2> "$tmp/p.err"
    if grep -q "^refused QMC_$code: .*$text" "$tmp/p.out"; then ok
    else bad "part $kp $* not refused with $code ($text): $(cat "$tmp/p.out" "$tmp/p.err")"; fi
}
refused EINVAL "is not k/p with 1 <= k <= p" 3/2 $G --method rqmc
refused EINVAL "is not k/p with 1 <= k <= p" 0/2 $G --method rqmc
refused EINVAL "with a fixed n: no tolerance" 1/2 $G --method rqmc --tol-rel 1e-3
refused EINVAL "a part needs a sampling method" 1/2 $G --method cubature
refused EBUDGET "exceed the budget" 1/2 $G --method mc --n 100000 --max-evals 1000
"$PY" "$(dirname "$0")/sessionpeer.py" part5 "$U" > "$tmp/peer.out" 2>&1
tally "$tmp/peer.out" || bad "sessionpeer.py part5 printed no check"

# ---- 6. a finished part resumed ------------------------------------------------------------
# The client drops its connection after its last batch, before the sums:
# 8192 blocks are 5 MB of them, more than the daemon's smallest output
# buffer (2 MiB) and the socket's together, so the session cannot have
# sent them all and is parked; resumed, it is done and sends them whole.
start tiny --listen "unix:$tmp/tiny.sock" --out-buffer-bytes 2097152 || finish
R="$G --method rqmc --n 2097152 --reps 16 --seed 3"
# shellcheck disable=SC2086
"$PEER" partdrop "unix:$tmp/tiny.sock" "$tmp/ticket" 1/1 $R > "$tmp/p.out" 2> "$tmp/p.err"
# shellcheck disable=SC2086
if grep -q "^dropped part 1/1" "$tmp/p.out" &&
   "$PEER" partresume "unix:$tmp/tiny.sock" "$tmp/ticket" 1/1 $R > "$tmp/p.out" 2> "$tmp/p.err" &&
   grep -q "^part 1/1: blocks 8192, first 0, count 8192: the in-process sums$" "$tmp/p.out"
then ok
else bad "a finished part resumed: $(cat "$tmp/p.out" "$tmp/p.err")"; fi

finish
