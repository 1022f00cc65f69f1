#!/bin/sh
# test_command_cli.sh - `qmc integrate --command 'PROGRAM ARGS'`: a program
# of the user's (Python here, as a user would write it) evaluates f.
#
#   1. Python programs integrate their own functions: numpy reading whole
#      text batches, a line-by-line program, and f64; the closed form sits
#      in the interval.
#   2. The same bytes as the built-in integrand: genz-product-peak in numpy
#      (text and f64) and genz-oscillatory with math.cos, line by line,
#      give every field of `qmc integrate --integrand X`'s JSON for every
#      kind of method (sampling, adaptive sampling, auto, the rules) - the
#      oracle is the C integrand, reimplemented apart in Python with the
#      same operations in the same order.
#   3. What qmc writes: every number is Python's repr of itself (the
#      shortest round-trip decimal), D of them a line, an empty line after
#      each batch; f64 batches are a count and count x D doubles.
#   4. A singular function is flagged (heavy_tail), as the built-in is.
#   5. Every way a program can fail - early exit, not a number, an empty
#      line, too few values, too many (in a batch and after the last), a
#      hang past --command-timeout, a failing exit, a missing program, a
#      batch far larger than the pipes that it reads whole before writing
#      (the deadlock case, which must succeed) - gives one line naming
#      what happened and what was computed so far, exit 2, nothing on
#      stdout, and leaves no process behind; each run is under `timeout`
#      so that a regression fails instead of hanging.  The running
#      estimate named is the job's with the replicates done so far.
#   6. The program's stderr passes through; SIGTERM and SIGINT of qmc
#      kill and reap the program.
#   7. --part K/P files merge into the whole run's bytes, and a part's
#      block sums equal the built-in part's (through the daemon:
#      test_session_parts.sh).
#   8. Option errors: one line, exit 2; `qmc help integrate` and bash
#      completion name the options.
#   9. Remote (--connect, a session on qmcd) gives the in-process bytes,
#      and the same failure lines.
# Env: QMC, QMCD.  Needs /usr/bin/python3 with numpy.  Prints "N passed, M failed".
set -u
: "${QMC:?set QMC to the qmc binary}"
. "$(dirname "$0")/lib.sh"
PY=/usr/bin/python3
T="timeout 120"

# ---- the programs ------------------------------------------------------------------
# A vectorised numpy program: reads a whole batch (text or f64), answers it
# (tests/e2e/batchfn.py, shared with test_session_parts.sh; copied into the
# scratch dir so the --command line has no spaces from the checkout's path).
cp "$(dirname "$0")/batchfn.py" "$tmp/vec.py"
# Line by line with math: genz-oscillatory, as core/genz.c computes it.
cat > "$tmp/line.py" <<'EOF'
import math, sys
a = [float(v) for v in sys.argv[1].split(",")]
c0 = 2.0 * math.pi * float(sys.argv[2].split(",")[0])
for line in sys.stdin:
    if not line.strip():
        sys.stdout.flush()
        continue
    s = c0
    for aj, xj in zip(a, map(float, line.split())):
        s += aj * xj
    print(repr(math.cos(s)))
EOF
# Checks what qmc writes: D shortest round-trip numbers in [0,1) a line,
# an empty line after each batch.  Violations go to argv[2].
cat > "$tmp/check.py" <<'EOF'
import sys
d, bad = int(sys.argv[1]), open(sys.argv[2], "w")
n = numbers = batches = 0
for line in sys.stdin:
    if line == "\n":
        print("\n".join(["0.5"] * n), flush=True)
        n, batches = 0, batches + 1
        continue
    t = line.split()
    if len(t) != d or line != " ".join(t) + "\n":
        bad.write("line %r\n" % line)
    for tok in t:
        x = float(tok)
        numbers += 1
        if not (0 <= x < 1) or (tok != repr(x) and not (x == 0 and tok == "0")):
            bad.write("number %r (repr %r)\n" % (tok, repr(x)))
    n += 1
bad.write("") if batches and numbers else bad.write("nothing read\n")
EOF

# stderr without AddressSanitizer's note that it does not fully support
# swapcontext (a session's fiber, in `make sanitize`'s build): not ours.
errlines() { grep -v "^==[0-9]*==WARNING: ASan doesn't fully support makecontext/swapcontext" "$tmp/err"; }

# json FIELD < file: a top-level field of a one-line object.
json() { sed -n "s/.*\"$1\":\\([^,}]*\\).*/\\1/p"; }
# Every field of two reports but the integrand's name and the seconds,
# and those of |f| (known for a built-in integrand, not for a program).
same_json() { # A B: 0 when equal
    $PY - "$1" "$2" <<'EOF'
import json, sys
a, b = (json.load(open(f)) for f in sys.argv[1:3])
for r in (a, b):
    for k in ("integrand", "seconds", "abs_integral", "error_vs_abs_integral"):
        r.pop(k, None)
sys.exit(0 if a == b and a else 1)
EOF
}

# ---- 1. own functions, closed forms in the interval ------------------------------------
inside() { # FILE: the exact value within the interval (2 half-widths of slack)
    awk -v lo="$(json ci_low < "$1")" -v hi="$(json ci_high < "$1")" -v x="$(json exact < "$1")" \
        'BEGIN { w = (hi - lo) / 2; exit !(lo - w <= x && x <= hi + w && hi > lo) }'
}
for fmt in text f64; do
    $T "$QMC" integrate --dims 4 --command "$PY $tmp/vec.py $fmt prod 4" --command-format $fmt \
        --method rqmc --exact 1 --json > "$tmp/own.json" 2> "$tmp/err"
    if [ $? -eq 0 ] && inside "$tmp/own.json" && [ "$(json evals < "$tmp/own.json")" = 65536 ]; then ok
    else bad "numpy $fmt: prod 2x over [0,1)^4: $(cat "$tmp/own.json" "$tmp/err")"; fi
done
$T "$QMC" integrate --dims 2 --command "$PY $tmp/line.py 3,1 0.5" --method rqmc --n 1024 --reps 8 \
    --exact "$($PY -c 'from math import cos; print(repr(-(cos(3) - cos(4) - 1 + cos(1)) / 3))')" \
    --smoothness smooth --json > "$tmp/own.json" 2> "$tmp/err"
if [ $? -eq 0 ] && inside "$tmp/own.json"; then ok
else bad "line by line: cos(pi + 3x + y): $(cat "$tmp/own.json" "$tmp/err")"; fi

# ---- 2. the built-in integrand's bytes --------------------------------------------------
PP="--a 5,3,2 --u 0.3,0.6,0.45"
for m in "rqmc" "mc --n 5000" "lhs" "stratified" "qmc --n 4096" "rqmc --tol-rel 1e-5" \
         "auto --tol-rel 1e-6" "cubature --tol-rel 1e-7" "gauss-legendre --n 9" \
         "clenshaw-curtis --tol-rel 1e-9" "simpson --n 7"; do
    # shellcheck disable=SC2086
    "$QMC" integrate --integrand genz-product-peak --dims 3 $PP --method $m --seed 9 --json \
        > "$tmp/b.json"
    ex=$(json exact < "$tmp/b.json")
    for fmt in text f64; do
        # shellcheck disable=SC2086
        $T "$QMC" integrate --dims 3 --command "$PY $tmp/vec.py $fmt ppeak 3 5,3,2 0.3,0.6,0.45" \
            --command-format $fmt --smoothness smooth --exact "$ex" --method $m --seed 9 --json \
            > "$tmp/c.json" 2> "$tmp/err"
        if same_json "$tmp/b.json" "$tmp/c.json"; then ok
        else bad "ppeak $m ($fmt) differs from the built-in: $(cat "$tmp/err")"
             diff "$tmp/b.json" "$tmp/c.json"; fi
    done
done
for m in "rqmc --n 1024 --reps 4" "gauss-kronrod --tol-rel 1e-12" "auto --tol-rel 1e-8"; do
    # shellcheck disable=SC2086
    "$QMC" integrate --integrand genz-oscillatory --dims 1 --a 7 --u 0.2 --method $m --json \
        > "$tmp/b.json"
    # shellcheck disable=SC2086
    $T "$QMC" integrate --dims 1 --command "$PY $tmp/line.py 7 0.2" --smoothness smooth \
        --exact "$(json exact < "$tmp/b.json")" --method $m --json > "$tmp/c.json" 2> "$tmp/err"
    if same_json "$tmp/b.json" "$tmp/c.json"; then ok
    else bad "oscillatory $m (line by line) differs: $(cat "$tmp/err")"; diff "$tmp/b.json" "$tmp/c.json"; fi
done
# The text report too, line for line but the integrand's, the time, and
# the error against the integral of |f| (known built in, estimated here).
"$QMC" integrate --integrand genz-product-peak --dims 3 $PP --method rqmc --json > "$tmp/b.json"
"$QMC" integrate --integrand genz-product-peak --dims 3 $PP --method rqmc > "$tmp/b.txt"
$T "$QMC" integrate --dims 3 --command "$PY $tmp/vec.py text ppeak 3 5,3,2 0.3,0.6,0.45" \
    --smoothness smooth --exact "$(json exact < "$tmp/b.json")" --method rqmc > "$tmp/c.txt"
grep -v '^integrand\|^work\|^abs error' "$tmp/b.txt" > "$tmp/b2.txt"
grep -v '^integrand\|^work\|^abs error' "$tmp/c.txt" > "$tmp/c2.txt"
if [ -s "$tmp/b2.txt" ] && cmp -s "$tmp/b2.txt" "$tmp/c2.txt" &&
   grep -q "^integrand  $PY $tmp/vec.py text ppeak 3 5,3,2 0.3,0.6,0.45 (3 dims)$" "$tmp/c.txt"; then ok
else bad "the text report differs"; diff "$tmp/b.txt" "$tmp/c.txt"; fi

# ---- 3. what qmc writes ----------------------------------------------------------------
for m in "rqmc --n 4096" "cubature --tol-rel 1e-3" "mc --n 3000"; do
    rm -f "$tmp/bad"
    # shellcheck disable=SC2086
    $T "$QMC" integrate --dims 3 --command "$PY $tmp/check.py 3 $tmp/bad" --method $m \
        > "$tmp/out" 2> "$tmp/err"
    if [ $? -eq 0 ] && [ -f "$tmp/bad" ] && [ ! -s "$tmp/bad" ]; then ok
    else bad "$m: what qmc wrote: $(head -c 300 "$tmp/bad") $(cat "$tmp/err")"; fi
done
# f64: a little-endian u32 count, count x D doubles (rqmc 2 x 4096: one
# batch of 8192 distinct points in [0,1)^2), answered by 8192 doubles.
cat > "$tmp/dump.py" <<'EOF'
import struct, sys
inp = sys.stdin.buffer
h = inp.read(4)
(n,) = struct.unpack("<I", h)
body = inp.read(n * 2 * 8)
open(sys.argv[1], "wb").write(h + body)
sys.stdout.buffer.write(struct.pack("<%dd" % n, *([0.25] * n)))
sys.stdout.flush()
sys.exit(0 if inp.read() == b"" else 1)
EOF
$T "$QMC" integrate --dims 2 --command "$PY $tmp/dump.py $tmp/batch" --command-format f64 \
    --method rqmc --n 4096 --reps 2 --seed 3 > "$tmp/out" 2> "$tmp/err"
if $PY - "$tmp/batch" <<'EOF'
import struct, sys
b = open(sys.argv[1], "rb").read()
(n,) = struct.unpack("<I", b[:4])
x = struct.unpack("<%dd" % (2 * n), b[4:])
sys.exit(0 if n == 8192 and len(b) == 4 + 16 * n and all(0 <= v < 1 for v in x)
         and len(set(x)) > n else 1)
EOF
then ok; else bad "f64 batch: $(od -An -tu4 -N4 "$tmp/batch") $(cat "$tmp/err")"; fi
if grep -q '^estimate   0.25$' "$tmp/out"; then ok; else bad "f64 answer of 0.25s: $(cat "$tmp/out")"; fi

# ---- 4. a singular function is flagged, as the built-in is ------------------------------
"$QMC" integrate --integrand inv-sqrt --dims 1 --method mc --n 100000 --json > "$tmp/b.json"
$T "$QMC" integrate --dims 1 --command "$PY $tmp/vec.py text invsqrt 1" --smoothness singular \
    --exact 2 --method mc --n 100000 --json > "$tmp/c.json" 2> "$tmp/err"
if grep -q '"heavy_tail"' "$tmp/c.json" && grep -q '"error_unreliable"' "$tmp/c.json" &&
   same_json "$tmp/b.json" "$tmp/c.json"; then ok
else bad "x^-1/2 not flagged as the built-in is: $(cat "$tmp/c.json" "$tmp/err")"; fi

# ---- 5. failures: one line, exit 2, nothing on stdout, nothing left running -----------------
cat > "$tmp/fail.py" <<'EOF'
import os, sys, time
mode, pidfile = sys.argv[1], sys.argv[2]
open(pidfile + ".tmp", "w").write(str(os.getpid()))
os.rename(pidfile + ".tmp", pidfile)
n = 0
for line in sys.stdin:
    if line == "\n":
        if mode == "few":
            print("\n".join(["0.5"] * (n - 1)), flush=True)
            n = 0
        sys.stdout.flush()
        continue
    n += 1
    if mode == "exit" and n == 1000:
        sys.exit(3)
    if mode == "garbage" and n == 7:
        print("0.5x")
        continue
    if mode == "empty" and n == 9:
        print("")
        continue
    if mode == "hang":
        time.sleep(3600)
    if mode != "few":
        print(0.5)
    if mode == "many":
        print(0.5)
if mode == "extra":
    print(0.25)
if mode == "status":
    sys.exit(1)
EOF
# fails NAME PATTERN ARGS...: exit 2, one line matching PATTERN, no stdout,
# the program (its PID in $tmp/pid) gone.  fail.py says nothing on stderr;
# the shell's own "not found" passes through as any program's stderr.
fails() {
    name=$1 pattern=$2
    shift 2
    rm -f "$tmp/pid"
    $T "$QMC" integrate "$@" > "$tmp/out" 2> "$tmp/err"
    rc=$?
    if [ $rc -eq 2 ] && [ ! -s "$tmp/out" ] && [ "$(errlines | grep -vc '^sh: 1: ')" -eq 1 ] &&
       errlines | grep -q -- "$pattern"; then ok
    else bad "$name: exit $rc, stderr '$(errlines)', stdout $(wc -c < "$tmp/out") bytes"; fi
    if [ -s "$tmp/pid" ] && kill -0 "$(cat "$tmp/pid")" 2>/dev/null; then
        bad "$name: the program (pid $(cat "$tmp/pid")) is still there"
        kill -9 "$(cat "$tmp/pid")" 2>/dev/null
    fi
}
# Only the two cases that wait for --command-timeout get a short one (3 s):
# the others must be told apart by what the program did, which a Python
# start on a loaded machine must not turn into "nothing for 3000 ms".
F="--dims 2 --method rqmc --n 1024 --reps 4"
FT="$F --command-timeout 3000"
P="$PY $tmp/fail.py"
# shellcheck disable=SC2086
{
fails "early exit" "^qmc: --command: '.*fail.py exit .*' exited with status 3 after answering 999 of the 4096 points of batch 0; nothing was computed yet$" \
    --command "$P exit $tmp/pid" $F
fails "not a number" "answered batch 0 badly: '0.5x' is not a number (the value for point 7)" \
    --command "$P garbage $tmp/pid" $F
fails "an empty line" "answered batch 0 badly: an empty line where the value for point 9 was expected" \
    --command "$P empty $tmp/pid" $F
fails "too many" "answered more values than the 4096 points of batch 0" --command "$P many $tmp/pid" $F
fails "too few" "answered 4095 of the 4096 points of batch 0, then nothing for 3000 ms (--command-timeout): too few values" \
    --command "$P few $tmp/pid" $FT
fails "hang" "read and wrote nothing for 3000 ms (--command-timeout) during batch 0 (0 of its 4096 points answered)" \
    --command "$P hang $tmp/pid" $FT
fails "extra after the last batch" "wrote more after its last answer: more values than points; so far 4096 values in 1 batch, running estimate 0.5 (stderr 0)" \
    --command "$P extra $tmp/pid" $F
fails "failing exit" "exited with status 1 after answering every point: no result printed; so far 4096 values in 1 batch" \
    --command "$P status $tmp/pid" $F
fails "no such program" "'$tmp/no-such-program' exited with status 127" --command "$tmp/no-such-program" $F
}
# Exit after 3 of 16 replicates (f64, one batch each): the running estimate
# named is the job's with 3 replicates.
cat > "$tmp/three.py" <<'EOF'
import struct, sys
import numpy as np
inp, out = sys.stdin.buffer, sys.stdout.buffer
for b in range(3):
    (n,) = struct.unpack("<I", inp.read(4))
    x = np.frombuffer(inp.read(n * 2 * 8), dtype="<f8").reshape(n, 2)
    out.write((x[:, 0] * x[:, 1] * 4.0).astype("<f8").tobytes())
    out.flush()
sys.exit(4)
EOF
$T "$QMC" integrate --dims 2 --command "$PY $tmp/three.py" --command-format f64 --method rqmc \
    --n 65536 --reps 16 --seed 2 > "$tmp/out" 2> "$tmp/err"
rc=$?
# The same integrand built in: genz-product-peak is no product x y, so the
# oracle is a program of the same job with 3 replicates, run whole.
cat > "$tmp/xy.py" <<'EOF'
import struct, sys
import numpy as np
inp, out = sys.stdin.buffer, sys.stdout.buffer
while True:
    h = inp.read(4)
    if len(h) < 4:
        sys.exit(0)
    (n,) = struct.unpack("<I", h)
    x = np.frombuffer(inp.read(n * 2 * 8), dtype="<f8").reshape(n, 2)
    out.write((x[:, 0] * x[:, 1] * 4.0).astype("<f8").tobytes())
    out.flush()
EOF
$T "$QMC" integrate --dims 2 --command "$PY $tmp/xy.py" --command-format f64 --method rqmc \
    --n 65536 --reps 3 --seed 2 --json > "$tmp/r3.json"
rwant=$(awk -v e="$(json estimate < "$tmp/r3.json")" -v s="$(json stderr < "$tmp/r3.json")" \
    'BEGIN { printf "running estimate %.10g (stderr %.3g)", e, s }')
if [ $rc -eq 2 ] && [ "$(errlines | wc -l)" -eq 1 ] &&
   errlines | grep -q "exited with status 4 after answering 0 of the 65536 points of batch 3; so far 196608 values in 3 batches, $rwant$"; then ok
else bad "three replicates then exit: exit $rc, '$(errlines)', want '$rwant'"; fi
# The deadlock case: batches of 65536 points (2.4 MB of text each way
# and more than any pipe holds) to a program that reads each whole before
# writing a byte, and to one that writes as it reads.
$T "$QMC" integrate --dims 3 --command "$PY $tmp/vec.py text prod 3" --method rqmc --n 65536 \
    --reps 2 --exact 1 --json > "$tmp/big.json" 2> "$tmp/err"
if [ $? -eq 0 ] && [ "$(json evals < "$tmp/big.json")" = 131072 ] && inside "$tmp/big.json"; then ok
else bad "a whole-batch reader on 65536-point batches: $(cat "$tmp/err")"; fi
$T "$QMC" integrate --dims 1 --command "$PY $tmp/line.py 7 0.2" --method mc --n 65536 \
    > "$tmp/out" 2> "$tmp/err"
if [ $? -eq 0 ] && grep -q '^work       n 65536, evals 65536' "$tmp/out"; then ok
else bad "a line-by-line writer on a 65536-point batch: $(cat "$tmp/err")"; fi

# ---- 6. stderr passes through; signals stop the program ----------------------------------
cat > "$tmp/talk.py" <<'EOF'
import sys
sys.stderr.write("a note from f\n")
for line in sys.stdin:
    if line.strip():
        print("0.5")
    else:
        sys.stdout.flush()
EOF
$T "$QMC" integrate --dims 2 --command "$PY $tmp/talk.py" --method mc > "$tmp/out" 2> "$tmp/err"
if [ $? -eq 0 ] && [ "$(errlines)" = "a note from f" ] && grep -q '^estimate   0.5$' "$tmp/out"; then ok
else bad "stderr passthrough: '$(errlines)'"; fi
for sig in TERM INT; do
    rm -f "$tmp/pid"
    $PY - "$QMC" "$P" "$tmp/pid" $sig > "$tmp/sig.out" 2>&1 <<'EOF'
import os, signal, subprocess, sys, time
qmc, prog, pidfile, sig = sys.argv[1:5]
p = subprocess.Popen([qmc, "integrate", "--dims", "2", "--method", "mc", "--command",
                      prog + " hang " + pidfile], stderr=subprocess.DEVNULL,
                     preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
for _ in range(6000):
    if os.path.exists(pidfile):
        break
    time.sleep(0.01)
child = int(open(pidfile).read())
s = getattr(signal, "SIG" + sig)
p.send_signal(s)
rc = p.wait(timeout=60)
try:
    os.kill(child, 0)
    left = True
except ProcessLookupError:
    left = False
print("rc", rc, "child left", left)
sys.exit(0 if rc == -s and not left else 1)
EOF
    if [ $? -eq 0 ]; then ok; else bad "SIG$sig: $(cat "$tmp/sig.out")"; fi
done

# ---- 7. parts merge into the whole run --------------------------------------------------
J="--dims 3 --method rqmc --n 8192 --reps 6 --seed 5 --smoothness smooth"
C="$PY $tmp/vec.py f64 ppeak 3 5,3,2 0.3,0.6,0.45"
# shellcheck disable=SC2086
$T "$QMC" integrate --command "$C" --command-format f64 $J --json > "$tmp/whole.json"
for k in 1 2 3; do
    # shellcheck disable=SC2086
    $T "$QMC" integrate --command "$C" --command-format f64 $J --part $k/3 > "$tmp/part$k" ||
        bad "part $k/3 failed"
done
"$QMC" merge --json "$tmp/part3" "$tmp/part1" "$tmp/part2" > "$tmp/merged.json"
if same_json "$tmp/whole.json" "$tmp/merged.json"; then ok
else bad "merged parts differ from the whole run"; diff "$tmp/whole.json" "$tmp/merged.json"; fi
# shellcheck disable=SC2086
"$QMC" integrate --integrand genz-product-peak $PP --dims 3 --method rqmc --n 8192 --reps 6 --seed 5 \
    --part 2/3 > "$tmp/bpart2"
grep '^sums ' "$tmp/bpart2" > "$tmp/bsums"
grep '^sums ' "$tmp/part2" > "$tmp/csums"
if [ -s "$tmp/bsums" ] && cmp -s "$tmp/bsums" "$tmp/csums"; then ok
else bad "a --command part's sums differ from the built-in part's"; fi

# ---- 8. option errors --------------------------------------------------------------------
opt_fails() { # PATTERN ARGS...
    pattern=$1
    shift
    "$QMC" integrate "$@" > "$tmp/out" 2> "$tmp/err"
    rc=$?
    if [ $rc -eq 2 ] && [ ! -s "$tmp/out" ] && [ "$(errlines | wc -l)" -eq 1 ] &&
       errlines | grep -q -- "$pattern"; then ok
    else bad "qmc integrate $*: exit $rc, '$(errlines)'"; fi
}
opt_fails "--command needs --dims" --command "$PY $tmp/vec.py text prod 2" --method mc
opt_fails "the program is the integrand" --command cat --integrand poly --dims 1
opt_fails "declare what a --command computes" --integrand poly --dims 1 --smoothness smooth
opt_fails "want text or f64" --command cat --dims 1 --command-format csv
opt_fails "want smooth, kinks, jumps or singular" --command cat --dims 1 --smoothness wiggly
opt_fails "name the PROGRAM" --command " " --dims 1
opt_fails "one process" --command cat --dims 1 --threads 2
opt_fails "--part splits sampling methods" --command cat --dims 1 --method cubature --part 1/2
# (--part with --connect runs a part session on the daemon: test_session_parts.sh.)
opt_fails "outside 1..1024" --integrand genz-gaussian --dims 2000

# ---- help and completion name the options -----------------------------------------------
"$QMC" help integrate > "$tmp/help"
for o in "--command 'PROGRAM ARGS'" "--command-format F" "--command-timeout MS" "--smoothness S" \
         "--exact V"; do
    if grep -q -- "^  $o" "$tmp/help"; then ok; else bad "qmc help integrate lacks '$o'"; fi
done
comp="$(dirname "$0")/../../client/completion/qmc"
if command -v bash > /dev/null && [ -f "$comp" ]; then
    got=$(bash -c '. "$1"; COMP_WORDS=("$2" integrate --command-f); COMP_CWORD=2; _qmc
        echo "${COMPREPLY[*]}"
        COMP_WORDS=("$2" integrate --command-format ""); COMP_CWORD=3; _qmc; echo "${COMPREPLY[*]}"
        COMP_WORDS=("$2" integrate --smoothness s); COMP_CWORD=3; _qmc; echo "${COMPREPLY[*]}"' \
        _ "$comp" "$QMC" 2>&1)
    want=$(printf -- '--command-format\ntext f64\nsmooth singular')
    if [ "$got" = "$want" ]; then ok; else bad "bash completion: got '$got'"; fi
fi

# ---- 9. remote == in-process ---------------------------------------------------------------
# Over a unix: socket the batches sit in the shared-memory ring; over TCP
# they travel inline.
start d --listen "unix:$tmp/d.sock" --listen tcp:127.0.0.1:0 || finish
tcp=$(grep '^tcp:' "$tmp/d.ready")
for m in "rqmc" "auto --tol-rel 1e-6" "cubature --tol-rel 1e-7"; do
    for fmt in text f64; do
        # shellcheck disable=SC2086
        $T "$QMC" integrate --dims 3 --command "$PY $tmp/vec.py $fmt ppeak 3 5,3,2 0.3,0.6,0.45" \
            --command-format $fmt --smoothness smooth --method $m --json > "$tmp/local.json"
        # shellcheck disable=SC2086
        $T "$QMC" integrate --connect "unix:$tmp/d.sock" --dims 3 \
            --command "$PY $tmp/vec.py $fmt ppeak 3 5,3,2 0.3,0.6,0.45" \
            --command-format $fmt --smoothness smooth --method $m --json > "$tmp/remote.json" \
            2> "$tmp/err"
        sed 's/"seconds":[^,]*,//' "$tmp/local.json" > "$tmp/l"
        sed 's/"seconds":[^,]*,//' "$tmp/remote.json" > "$tmp/r"
        if [ -s "$tmp/l" ] && cmp -s "$tmp/l" "$tmp/r"; then ok
        else bad "remote $m ($fmt) differs from in-process: $(cat "$tmp/err")"; fi
    done
done
$T "$QMC" integrate --connect "$tcp" --dims 3 --command "$PY $tmp/vec.py f64 ppeak 3 5,3,2 0.3,0.6,0.45" \
    --command-format f64 --smoothness smooth --method mc --seed 4 --json > "$tmp/remote.json" 2> "$tmp/err"
"$QMC" integrate --integrand genz-product-peak --dims 3 $PP --method mc --seed 4 --json > "$tmp/b.json"
if grep -q '"exact":null' "$tmp/remote.json" &&
   [ "$(json estimate < "$tmp/remote.json")" = "$(json estimate < "$tmp/b.json")" ] &&
   [ "$(json stderr < "$tmp/remote.json")" = "$(json stderr < "$tmp/b.json")" ]; then ok
else bad "over TCP: $(cat "$tmp/err")"; fi
# shellcheck disable=SC2086
fails "remote: early exit" "exited with status 3 after answering 999 of the 4096 points of batch 0" \
    --connect "unix:$tmp/d.sock" --command "$P exit $tmp/pid" $F
# The running estimate the daemon reports is the in-process one.
$T "$QMC" integrate --connect "unix:$tmp/d.sock" --dims 2 --command "$PY $tmp/three.py" \
    --command-format f64 --method rqmc --n 65536 --reps 16 --seed 2 > "$tmp/out" 2> "$tmp/err"
if errlines | grep -q "exited with status 4 after answering 0 of the 65536 points of batch 3; so far 196608 values in 3 batches, $rwant$"; then ok
else bad "remote: three replicates then exit: '$(errlines)', want '$rwant'"; fi
# A failed run leaves no session on the daemon, open or parked.
"$QMC" stats --connect "unix:$tmp/d.sock" > "$tmp/stats"
if grep -q '^sessions_open  *0$' "$tmp/stats" && grep -q '^sessions_parked_now  *0$' "$tmp/stats" &&
   grep -q '^sessions_closed  *2$' "$tmp/stats"; then ok
else bad "sessions left on the daemon: $(grep session "$tmp/stats" | tr '\n' ' ')"; fi

finish
