#!/bin/sh
# End-to-end checks of the Modbus integration block (protocol/MODBUS.md
# section 9): python3-pymodbus devices (tests/e2e/modbus_device.py) integrate
# f(x) = prod (pi/2) sin(pi x_j), whose integral is 1, through a real qmcd on
# an ephemeral loopback port, reading each point, measuring, writing the
# value with its request number, polling the status until done.
#
#   1. three devices (rqmc over FC23, auto in CDAB order, mc with u16
#      points) each within the reported bar of the closed form; a stale
#      request number refused, a retried write acknowledged; STATS counts
#      the open session and its bytes, and nothing once it is over;
#   2. the memory caps: with modbus-integration-memory = 3B/2 and
#      modbus-integration-memory-total = 10B (B: one session's bytes, as the
#      daemon reports them), a peer's third session and a larger one are
#      refused (status 8) and counted, a closed one makes room;
#   3. a bank left idle is dropped after idle-timeout-ms with its session:
#      modbus_integrations and modbus_integration_bytes fall to 0;
#   5. a device on a serial line (one end of a socat pty pair) integrates
#      through the RTU transport, its session counted in STATS;
#   4. bad values of the new keys are one line and exit 2.
# Env: QMC, QMCD, BUILD.  Prints "N passed, M failed".
set -u
: "${QMC:?QMC must name the qmc binary}"
: "${QMCD:?QMCD must name the qmcd binary}"
: "${BUILD:?BUILD must name the build directory}"
here=$(cd "$(dirname "$0")" && pwd)
DEVICE="$here/modbus_device.py"
. "$(dirname "$0")/lib.sh"
pid= socat_pid=
term_vars="pid socat_pid"
check() { if [ "$2" -eq 0 ]; then ok; else bad "$1"; fi; }
export QMC

# start_modbus NAME ARGS...: qmcd on a Unix socket and an ephemeral
# loopback Modbus port, read back into $port.
start_modbus() {
    e2e_n=$1
    shift
    "$QMCD" --foreground --listen "unix:$tmp/$e2e_n.sock" --modbus tcp:127.0.0.1:0 \
        --ready-file "$tmp/$e2e_n.ready" "$@" 2> "$tmp/$e2e_n.log" &
    pid=$!
    wait_ready pid "$tmp/$e2e_n.ready" "$tmp/$e2e_n.log"
    port=$(sed -n 's/^modbus:tcp:127\.0\.0\.1:\([0-9]*\)$/\1/p' "$tmp/$e2e_n.ready")
    [ -n "$port" ] || { echo "FAIL: no Modbus port in $(cat "$tmp/$e2e_n.ready")"; exit 1; }
}
stop() { kill "$pid"; wait "$pid"; pid=; }
stats() { "$QMC" stats --connect "unix:$tmp/$1.sock" > "$tmp/stats" 2>&1; }
stat() { awk -v k="$1" '$1 == k { print $2 }' "$tmp/stats"; }

# ---- 4. bad values: one line, exit 2 -----------------------------------------
for args in "--modbus-integration-memory 2T" "--modbus-integration-memory-total x" \
            "--modbus-integration-memory-per-peer -1"; do
    # shellcheck disable=SC2086
    "$QMCD" --foreground --listen "unix:$tmp/x.sock" $args > "$tmp/out" 2> "$tmp/err"
    rc=$?
    [ $rc -eq 2 ] && [ "$(wc -l < "$tmp/err")" -eq 1 ] && [ ! -e "$tmp/x.sock" ]
    check "bad setting '$args': exit $rc, $(cat "$tmp/err")" $?
done

# ---- 1. three devices against the closed form ------------------------------
start_modbus a
run_peer "$DEVICE" run 127.0.0.1 "$port" "$tmp/a.sock"
/usr/bin/python3 "$DEVICE" bytes 127.0.0.1 "$port" > "$tmp/bytes.out" 2>&1
one=$(sed -n 's/^bytes \([0-9]*\)$/\1/p' "$tmp/bytes.out")
tally "$tmp/bytes.out" > /dev/null
[ -n "$one" ] && [ "$one" -gt 0 ]
check "one fixed rqmc session's bytes: $(cat "$tmp/bytes.out")" $?
stats a
[ "$(stat modbus_integrations)" = 0 ] && [ "$(stat modbus_integration_bytes)" = 0 ] &&
    [ "$(stat modbus_refused_integrations)" = 0 ]
check "STATS after the devices: nothing held, nothing refused: $(grep integration "$tmp/stats" | tr '\n' ' ')" $?
stop
[ -z "${one:-}" ] && finish

# ---- 2. the caps --------------------------------------------------------------
start_modbus b --modbus-integration-memory $((one * 3 / 2)) \
    --modbus-integration-memory-total $((one * 10))
run_peer "$DEVICE" memory 127.0.0.1 "$port" "$tmp/b.sock" "$one"
stop

# ---- 3. idle banks go with their sessions ---------------------------------------
# The device must still hold its session when it asks STATS (a Unix
# round trip after its last Modbus request): 500 ms of idleness, which a
# loaded machine can spend there, closed it first; 5 s cannot be.
start_modbus c --idle-timeout-ms 5000
run_peer "$DEVICE" hold 127.0.0.1 "$port" "$tmp/c.sock"
# Order, not time: poll until the idle rule has run (bounded at 30 s).
i=0
while :; do
    stats c
    [ "$(stat modbus_sessions)" = 0 ] && break
    i=$((i + 1))
    [ $i -gt 300 ] && break
    sleep 0.1
done
[ "$(stat modbus_sessions)" = 0 ] && [ "$(stat modbus_integrations)" = 0 ] &&
    [ "$(stat modbus_integration_bytes)" = 0 ]
check "idle banks dropped with their sessions: $(grep 'modbus_sessions \|integration' "$tmp/stats" | tr '\n' ' ')" $?
stop

# ---- 5. a serial line ------------------------------------------------------------
pty_pair "$tmp/ttyq" "$tmp/ttyc" || finish
"$QMCD" --foreground --listen "unix:$tmp/d.sock" --modbus "rtu:$tmp/ttyq:19200:N:8:1:5" \
    --ready-file "$tmp/d.ready" 2> "$tmp/d.log" &
pid=$!
wait_ready pid "$tmp/d.ready" "$tmp/d.log"
run_peer "$DEVICE" rtu "$tmp/ttyc" "$tmp/d.sock"
stop
finish
