#!/bin/sh
# Scale-out behind HAProxy: systemd/haproxy-qmcd.cfg, its server and bind
# lines replaced, balances three qmcd replicas on loopback.  Checks: the
# shipped file is valid; the protocol health check (HELLO, PING) marks the
# three replicas UP and an echo server, which accepts TCP but is no qmcd,
# DOWN; POINTS and INTEGRATE through HAProxy equal the in-process bytes and
# are spread over the replicas; a replica killed (by PID) in the middle of
# a run of clients is marked DOWN and every client after it is still
# served, with the same bytes.
# Env: QMC, QMCD.  Prints "N passed, M failed".
set -u
: "${QMC:?QMC must name the qmc binary}"
: "${QMCD:?QMCD must name the qmcd binary}"
PY=/usr/bin/python3
HERE="$(cd "$(dirname "$0")" && pwd)"
TOP="$(cd "$HERE/../.." && pwd)"
CFG="$TOP/systemd/haproxy-qmcd.cfg"
. "$(dirname "$0")/lib.sh"

if haproxy -c -f "$CFG" > "$tmp/c.out" 2>&1; then ok; else bad "haproxy -c: $(cat "$tmp/c.out")"; fi

# ---- three replicas on free loopback ports, and an impostor -------------------
for r in 1 2 3; do
    "$QMCD" --foreground --threads 1 --listen tcp:127.0.0.1:0 --ready-file "$tmp/r$r.ready" \
        2> "$tmp/r$r.log" &
    eval "R$r=\$!"
    pids="$pids $!"
done
for r in 1 2 3; do
    wait_file "$tmp/r$r.ready"
    eval "P$r=\$(sed -n 's/^tcp:127.0.0.1://p' '$tmp/r$r.ready')"
done
[ -n "$P1" ] && [ -n "$P2" ] && [ -n "$P3" ] || { bad "replicas did not start"; finish; }
# An echo server: accepts connections and sends back what it gets (the
# HELLO itself), which is not HELLO_OK: the check must fail on it.
"$PY" -c '
import socket, sys, threading
s = socket.socket(); s.bind(("127.0.0.1", 0)); s.listen(16)
open(sys.argv[1] + ".tmp", "w").write(str(s.getsockname()[1]))
import os; os.rename(sys.argv[1] + ".tmp", sys.argv[1])
def echo(c):
    with c:
        try:
            while True:
                d = c.recv(4096)
                if not d: return
                c.sendall(d)
        except OSError:
            return
while True:
    c, _ = s.accept()
    threading.Thread(target=echo, args=(c,), daemon=True).start()
' "$tmp/echo.port" &
pids="$pids $!"
wait_file "$tmp/echo.port"
PE=$(cat "$tmp/echo.port")

# ---- HAProxy with the shipped file --------------------------------------------
# A free port for the frontend: the kernel picks one and we release it (a
# retry covers the rare case of someone taking it in between).  Checks run
# every 100 ms and one failure marks a replica DOWN, so that the kill is
# seen at once; without `timeout check` HAProxy would also give the whole
# check (HELLO, PING) only `inter`, 100 ms, which a sanitized replica on a
# loaded machine can take, marking a live replica DOWN.  A dead one still
# fails at once: its connect is refused.
start_haproxy() {
    FP=$("$PY" -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
    sed -e "s|^\( *\)bind .*|\1bind 127.0.0.1:$FP|" \
        -e '/^ *server /d' \
        -e "s|^\( *\)log /dev/log.*|\1log stdout format raw local0\n\1stats socket $tmp/admin.sock mode 600 level admin|" \
        -e 's|^\( *\)default-server .*|\1default-server inter 100ms fastinter 100ms downinter 100ms fall 1 rise 1\n\1timeout check 10s|' \
        "$CFG" > "$tmp/haproxy.cfg"
    for r in 1 2 3; do
        eval "echo \"    server qmcd$r 127.0.0.1:\$P$r check\"" >> "$tmp/haproxy.cfg"
    done
    echo "    server impostor 127.0.0.1:$PE check" >> "$tmp/haproxy.cfg"
    haproxy -db -f "$tmp/haproxy.cfg" > "$tmp/haproxy.log" 2>&1 &
    HA=$!
    pids="$pids $HA"
    i=0
    while [ ! -S "$tmp/admin.sock" ] && kill -0 "$HA" 2>/dev/null && [ $i -lt 200 ]; do
        sleep 0.05
        i=$((i + 1))
    done
    [ -S "$tmp/admin.sock" ]
}
start_haproxy || { sleep 0.2; start_haproxy; } || { bad "haproxy did not start: $(tail -n 5 "$tmp/haproxy.log")"; finish; }
# status SERVER: its state in HAProxy (UP, DOWN, ...)
status() {
    echo "show stat" | socat - "UNIX-CONNECT:$tmp/admin.sock" 2>/dev/null |
        awk -F, -v s="$1" '$1 == "qmcd_replicas" && $2 == s { print $18 }'
}
# wait_status SERVER STATE: polls, at most 10 s
wait_status() {
    i=0
    while [ "$(status "$1")" != "$2" ] && [ $i -lt 200 ]; do sleep 0.05; i=$((i + 1)); done
    [ "$(status "$1")" = "$2" ]
}
for r in 1 2 3; do
    if wait_status qmcd$r UP; then ok; else bad "qmcd$r not UP: $(status qmcd$r)"; fi
done
if wait_status impostor DOWN; then ok; else bad "the echo server passed the health check: $(status impostor)"; fi
# the checks speak the protocol: each replica has answered PINGs
for r in 1 2 3; do
    eval "p=\$P$r"
    n=$("$QMC" stats --connect "tcp:127.0.0.1:$p" --json | "$PY" -c 'import json, sys; print(json.load(sys.stdin)["requests_PING"])')
    if [ "$n" -ge 1 ]; then ok; else bad "qmcd$r got no PING from the health check"; fi
done

# ---- byte-identical points and jobs through the balancer ----------------------
H="tcp:127.0.0.1:$FP"
"$QMC" points --seq sobol --dims 8 --scramble owen --seed 5 --start 1000 --count 5000 --format f64 \
    > "$tmp/want.bin"
"$QMC" integrate --integrand genz-oscillatory --dims 4 --method rqmc --n 2048 --reps 8 --seed 3 --json \
    > "$tmp/want.json"
same_job() {
    "$PY" - "$1" "$2" <<'PYEOF'
import json, sys
a, b = (json.load(open(f)) for f in sys.argv[1:3])
for d in (a, b):
    d.pop("seconds", None)   # the one field that is measured, not computed
sys.exit(0 if a == b else 1)
PYEOF
}
good=0
for i in 1 2 3 4 5 6; do
    "$QMC" points --seq sobol --dims 8 --scramble owen --seed 5 --start 1000 --count 5000 --format f64 \
        --connect "$H" > "$tmp/got.bin" 2> "$tmp/got.err" && cmp -s "$tmp/got.bin" "$tmp/want.bin" &&
        good=$((good + 1))
    "$QMC" integrate --integrand genz-oscillatory --dims 4 --method rqmc --n 2048 --reps 8 --seed 3 \
        --json --connect "$H" > "$tmp/got.json" 2> "$tmp/got.err" && same_job "$tmp/got.json" "$tmp/want.json" &&
        good=$((good + 1))
done
if [ $good -eq 12 ]; then ok; else bad "only $good of 12 answers through HAProxy were identical: $(cat "$tmp/got.err")"; fi
served=0
for r in 1 2 3; do
    eval "p=\$P$r"
    n=$("$QMC" stats --connect "tcp:127.0.0.1:$p" --json | "$PY" -c 'import json, sys; d = json.load(sys.stdin); print(d["requests_POINTS"] + d["requests_INTEGRATE"])')
    [ "$n" -ge 1 ] && served=$((served + 1))
done
if [ $served -ge 2 ]; then ok; else bad "HAProxy sent every request to one replica"; fi

# ---- a replica dies in the middle of a run of clients -------------------------
# A long job (10^9 evaluations) goes through HAProxy to some replica; we
# find which from the replicas' jobs_open gauge.  Then 40 clients run one
# after another, and after the 10th the replica running the long job is
# killed (SIGKILL, by PID).  The long job's client loses its connection and
# must say so in one line with a non-zero exit (its retry is the caller's);
# every one of the 40 clients must be served, with the same bytes, and the
# dead replica is marked DOWN while the other two stay UP.
"$QMC" integrate --integrand genz-gaussian --dims 8 --method mc --n 1000000000 --max-evals 1000000000 --connect "$H" \
    > "$tmp/long.out" 2> "$tmp/long.err" &
LONG=$!
pids="$pids $LONG"
victim=""
i=0
while [ -z "$victim" ] && [ $i -lt 200 ]; do
    for r in 1 2 3; do
        eval "p=\$P$r"
        n=$("$QMC" stats --connect "tcp:127.0.0.1:$p" --json 2>/dev/null |
            "$PY" -c 'import json, sys; print(json.load(sys.stdin)["jobs_open"])' 2>/dev/null)
        [ "${n:-0}" -ge 1 ] && victim=$r
    done
    [ -z "$victim" ] && sleep 0.05
    i=$((i + 1))
done
[ -n "$victim" ] || { bad "the long job never started on a replica"; finish; }
eval "VPID=\$R$victim"
(
    for i in $(seq 1 40); do
        if "$QMC" points --seq sobol --dims 8 --scramble owen --seed 5 --start 1000 --count 5000 \
            --format f64 --connect "$H" > "$tmp/run$i.bin" 2> "$tmp/run$i.err" &&
            cmp -s "$tmp/run$i.bin" "$tmp/want.bin"; then
            echo "$i ok" >> "$tmp/run.log"
        else
            echo "$i failed" >> "$tmp/run.log"
        fi
        if [ "$i" -eq 10 ]; then
            touch "$tmp/kill.now"
            while [ ! -e "$tmp/killed" ]; do sleep 0.02; done
        fi
    done
) &
RUN=$!
i=0
while [ ! -e "$tmp/kill.now" ] && [ $i -lt 400 ]; do sleep 0.05; i=$((i + 1)); done
kill -9 "$VPID"
wait "$VPID" 2>/dev/null
# Waited for: its PID may be reused, and cleanup must not SIGKILL a stranger.
forget "$VPID"
touch "$tmp/killed"
wait "$RUN"
n_ok=$(grep -c ' ok$' "$tmp/run.log")
if [ "$n_ok" -eq 40 ]; then ok
else bad "with qmcd$victim killed mid-run only $n_ok of 40 clients were served: $(cat "$tmp"/run*.err | sort -u | head -n 3)"; fi
wait "$LONG"
long_rc=$?
forget "$LONG"
if [ $long_rc -eq 0 ]; then
    bad "the long job's client exited 0 though its replica was killed"
elif [ "$(wc -l < "$tmp/long.err")" -eq 1 ] && [ ! -s "$tmp/long.out" ]; then ok
else bad "the cut job's client: stdout $(wc -c < "$tmp/long.out") bytes, stderr: $(cat "$tmp/long.err")"; fi
if wait_status "qmcd$victim" DOWN; then ok; else bad "the killed replica is still $(status "qmcd$victim")"; fi
for r in 1 2 3; do
    [ "$r" = "$victim" ] && continue
    if wait_status "qmcd$r" UP; then ok; else bad "qmcd$r is $(status qmcd$r) after qmcd$victim died"; fi
done
# and a job now is served too, with the same numbers
if "$QMC" integrate --integrand genz-oscillatory --dims 4 --method rqmc --n 2048 --reps 8 --seed 3 \
    --json --connect "$H" > "$tmp/got.json" && same_job "$tmp/got.json" "$tmp/want.json"; then ok
else bad "no identical job after the kill"; fi
echo "long job's client after its replica died: $(cat "$tmp/long.err")"

kill -TERM "$HA"
wait "$HA" 2>/dev/null
forget "$HA"
for r in 1 2 3; do
    [ "$r" = "$victim" ] && continue
    eval "kill -TERM \$R$r; wait \$R$r" || bad "qmcd$r: SIGTERM did not exit 0"
    eval "forget \$R$r"
done
if grep -l -E "AddressSanitizer|LeakSanitizer|runtime error" "$tmp"/r*.log; then
    bad "sanitizer report in a replica log"
else ok; fi
finish
