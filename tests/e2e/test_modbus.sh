#!/bin/sh
# End-to-end checks of the Modbus bridge (protocol/MODBUS.md) against the
# real daemon and real Modbus peers.  qmcd listens on ephemeral loopback
# ports (IPv4 and IPv6, read back from its --ready-file) and on one end of
# a socat pty pair; everything started here is stopped by PID.
#
#   - mbpoll (-0, -B, -t 3:hex, -t 3:float) reads exactly the registers
#     `qmc points` predicts, in both word orders, over TCP and RTU;
#   - the libmodbus C client (tests/e2e/modbus_client.c) does it with one
#     modbus_write_and_read_registers per point over TCP v4 and v6, and
#     over the RTU line (unit 5; unit 6 gets no answer; FC17 works there);
#   - python3-pymodbus: FC03/04/06/16/23, FC17, FC43/14, exceptions 01..03,
#     auto-advance, the retried request, the counters;
#   - a client dribbling one byte every 100 ms while another completes 22
#     requests in between; 200 connections at once; a client from
#     127.0.0.2 outside modbus-allow closed and counted; bad MBAP headers;
#     a half-sent frame closed by the partial-frame deadline; exception 06
#     past modbus-max-sessions and a close past modbus-max-connections; a
#     client that never reads its replies closed after write-timeout-ms;
#   - bad settings are one line and a non-zero exit, and a listener off
#     loopback without modbus-allow refuses to start (exit 2, nothing
#     bound; --check-config says so too).
# Env: QMC, QMCD, BUILD.  Prints "N passed, M failed".
set -u
: "${QMC:?QMC must name the qmc binary}"
: "${QMCD:?QMCD must name the qmcd binary}"
: "${BUILD:?BUILD must name the build directory}"
here=$(cd "$(dirname "$0")" && pwd)
CLIENT="$BUILD/tests/modbus-client"
PEER="/usr/bin/python3 $here/modbus_peer.py"
. "$(dirname "$0")/lib.sh"
# Every process here gets SIGTERM at exit, peers first, socat last; each
# variable is cleared once the test has stopped that process itself.
pid= socat_pid= stall_pid= lim_pid=
term_vars="stall_pid lim_pid pid socat_pid"
# expect NAME CONDITION-EXIT-STATUS: ok when the previous command's test held.
check() { if [ "$2" -eq 0 ]; then ok; else bad "$1"; fi; }

# ---- 0. settings refused before anything is bound ---------------------------
for spec in tcp:0.0.0.0:0 "tcp:[::]:0" tcp:192.0.2.1:0; do
    "$QMCD" --foreground --listen "unix:$tmp/x.sock" --modbus "$spec" > /dev/null 2> "$tmp/err"
    rc=$?
    [ $rc -eq 2 ] && grep -q "needs modbus-allow" "$tmp/err" && [ "$(wc -l < "$tmp/err")" -eq 1 ] &&
        [ ! -e "$tmp/x.sock" ]
    check "$spec without modbus-allow: exit $rc, $(cat "$tmp/err")" $?
done
printf 'modbus = tcp:0.0.0.0:1502\n' > "$tmp/open.conf"
"$QMCD" --check-config --config "$tmp/open.conf" > /dev/null 2> "$tmp/err"
rc=$?
[ $rc -eq 2 ] && grep -q "needs modbus-allow" "$tmp/err"
check "--check-config sees the missing modbus-allow: exit $rc, $(cat "$tmp/err")" $?
printf 'modbus = tcp:0.0.0.0:1502\nmodbus-allow = 10.0.0.0/8\n' > "$tmp/open.conf"
"$QMCD" --check-config --config "$tmp/open.conf" > /dev/null 2> "$tmp/err"
check "--check-config accepts it with modbus-allow: $(cat "$tmp/err")" $?
for args in "--modbus rtu:$tmp/tty:19200:E:8:1:248" "--modbus rtu:$tmp/tty:19200:Q:8:1" \
            "--modbus udp:127.0.0.1:1502" "--modbus-allow 300.1.1.1" "--modbus-allow 10.0.0.0/40" \
            "--modbus tcp:127.0.0.1:99999"; do
    # shellcheck disable=SC2086
    "$QMCD" --foreground --listen "unix:$tmp/x.sock" $args > /dev/null 2> "$tmp/err"
    rc=$?
    [ $rc -eq 2 ] && [ "$(wc -l < "$tmp/err")" -eq 1 ]
    check "bad setting '$args': exit $rc, $(cat "$tmp/err")" $?
done

# ---- 1. the serial line: a socat pty pair ----------------------------------
pty_pair "$tmp/ttyq" "$tmp/ttyc" || finish

# RS-485 mode on a line whose driver cannot switch direction (a pty): one
# line naming the problem, before anything is served.
"$QMCD" --foreground --listen "unix:$tmp/x.sock" --modbus "rtu:$tmp/ttyq:19200:E:8:1:5:rs485" \
    > /dev/null 2> "$tmp/err"
rc=$?
[ $rc -ne 0 ] && [ "$(wc -l < "$tmp/err")" -eq 1 ] && grep -q "RS-485" "$tmp/err" &&
    [ ! -e "$tmp/x.sock" ]
check "rtu ...:rs485 on a pty: exit $rc, $(cat "$tmp/err")" $?

# ---- 2. the daemon -----------------------------------------------------------
# The same keys work in the config file: the transports and the allow list
# come from it (two modbus-allow lines add up), the limits from flags.  All
# of loopback is one peer (test_modbus_isolation.sh): its cap is raised
# here so that the 200 connections of section 5 fit.  The partial-frame
# deadline (10 s) must outlast the dribbling client's whole frame (11
# bytes 100 ms apart, 22 answers to another client between them) on a
# loaded machine; the stalled client below waits for it longer still.
cat > "$tmp/qmcd.conf" <<EOF
modbus = tcp:127.0.0.1:0
modbus = tcp:[::1]:0
modbus = rtu:$tmp/ttyq:19200:E:8:1:5
modbus-allow = 127.0.0.1/32
modbus-allow = ::1
EOF
"$QMCD" --foreground --config "$tmp/qmcd.conf" --listen "unix:$tmp/qmcd.sock" \
    --modbus-frame-timeout-ms 10000 --modbus-max-connections-per-peer 256 \
    --ready-file "$tmp/ready" --log-level info \
    2> "$tmp/qmcd.log" &
pid=$!
wait_ready pid "$tmp/ready" "$tmp/qmcd.log"
P4=$(sed -n 's/^modbus:tcp:127\.0\.0\.1:\([0-9]*\)$/\1/p' "$tmp/ready")
P6=$(sed -n 's/^modbus:tcp:\[::1\]:\([0-9]*\)$/\1/p' "$tmp/ready")
grep -q "^modbus:rtu:$tmp/ttyq:19200:E:8:1:5$" "$tmp/ready"
check "ready file names the RTU line: $(cat "$tmp/ready")" $?
if [ -z "$P4" ] || [ -z "$P6" ]; then
    echo "FAIL: no Modbus ports in the ready file: $(cat "$tmp/ready")"; echo "0 passed, 1 failed"
    exit 1
fi

# Half a frame, then silence, from the start: closed by the deadline later.
$PEER stall 127.0.0.1 "$P4" > "$tmp/stall.out" 2>&1 &
stall_pid=$!

# words KIND DIMS SCRAMBLE SEED INDEX f32|u32: the point's 32-bit values as
# 8-digit hex, one per line, from `qmc points` (little-endian raw output).
words() {
    "$QMC" points --seq "$1" --dims "$2" --scramble "$3" --seed "$4" --start "$5" \
        --count 1 --format "$6" | od -An -v -tx4 | tr -s ' ' '\n' | sed '/^$/d'
}

# ---- 3. mbpoll ---------------------------------------------------------------
MB="mbpoll -m tcp -p $P4 -a 1 -0 -1 -o 5"
# FC16: sobol, 4 dims, owen, seed 7, float32, index 123, request 42.
$MB -t 4 -r 0 127.0.0.1 1 4 1 0 7 0 0 0 0 123 42 > "$tmp/mb.out" 2>&1
check "mbpoll FC16 write: $(tail -n 2 "$tmp/mb.out")" $?
$MB -t 3:hex -r 0 -c 14 127.0.0.1 > "$tmp/mb.out" 2>&1
check "mbpoll -t 3:hex read" $?
sed -n 's/^\[\([0-9]*\)\]:[[:space:]]*0x\(....\)$/\2/p' "$tmp/mb.out" | tr 'A-F' 'a-f' > "$tmp/got"
{ printf '002a\n0000\n0000\n0000\n0000\n007b\n'
  words sobol 4 owen 7 123 f32 | sed 's/^\(....\)\(....\)$/\1\n\2/'; } > "$tmp/want"
cmp -s "$tmp/got" "$tmp/want"
check "mbpoll registers == qmc points (ABCD): $(tr '\n' ' ' < "$tmp/got") vs $(tr '\n' ' ' < "$tmp/want")" $?
$MB -t 4:hex -r 100 -c 14 127.0.0.1 2>&1 | sed -n 's/^\[\([0-9]*\)\]:[[:space:]]*0x\(....\)$/\2/p' |
    tr 'A-F' 'a-f' | cmp -s - "$tmp/want"
check "mbpoll holding 100.. == input 0.." $?
# -B floats: mbpoll's %g of the float32 qmc points gives.
$MB -t 3:float -B -r 6 -c 4 127.0.0.1 2>&1 | sed -n 's/^\[[0-9]*\]:[[:space:]]*//p' > "$tmp/got"
words sobol 4 owen 7 123 f32 | /usr/bin/python3 -c '
import struct, sys
for w in sys.stdin.read().split():
    print("%g" % struct.unpack("<f", struct.pack("<I", int(w, 16)))[0])' > "$tmp/want"
[ -s "$tmp/got" ] && cmp -s "$tmp/got" "$tmp/want"
check "mbpoll -B floats == qmc points: $(tr '\n' ' ' < "$tmp/got") vs $(tr '\n' ' ' < "$tmp/want")" $?
# Word order CDAB (register 12 = 1) with request 43: mbpoll without -B.
$MB -t 4 -r 10 127.0.0.1 43 0 1 > /dev/null 2>&1
$MB -t 3:float -r 6 -c 4 127.0.0.1 2>&1 | sed -n 's/^\[[0-9]*\]:[[:space:]]*//p' | cmp -s - "$tmp/want"
check "mbpoll CDAB floats (no -B) == qmc points" $?
# Exceptions through mbpoll: dims 33 is an illegal value.
$MB -t 4 -r 1 127.0.0.1 33 > "$tmp/mb.out" 2>&1
[ $? -ne 0 ] && grep -qi "illegal data value" "$tmp/mb.out"
check "mbpoll dims 33: illegal data value" $?

# ---- 4. the libmodbus C client: FC23 per point -------------------------------
# point_case EP UNIT KIND K D SCR S SEED FMT ORDER INDEX REQ
point_case() {
    ep=$1 unit=$2 kind=$3 k=$4 d=$5 scr=$6 s=$7 seed=$8 fmt=$9
    shift 9
    order=$1 index=$2 req=$3
    out=$("$CLIENT" "$ep" "$unit" point "$k" "$d" "$s" "$seed" "$fmt" "$order" "$index" "$req" 2>&1)
    rc=$?
    case $fmt in 1) qf=u32 ;; 2) qf=u32 ;; *) qf=f32 ;; esac
    want=$(words "$kind" "$d" "$scr" "$seed" "$index" "$qf" | while read -r w; do
        hi=$(echo "$w" | cut -c1-4) lo=$(echo "$w" | cut -c5-8)
        if [ "$fmt" = 1 ]; then echo "$hi"
        elif [ "$order" = 1 ]; then echo "$lo"; echo "$hi"
        else echo "$hi"; echo "$lo"; fi
    done | tr '\n' ' ' | sed 's/ $//')
    head=$(printf '%04x 0000 %04x %04x %04x %04x' "$req" $((index >> 48 & 65535)) \
        $((index >> 32 & 65535)) $((index >> 16 & 65535)) $((index & 65535)))
    [ $rc -eq 0 ] && [ "$out" = "$head
$want" ]
    check "C client $ep unit $unit $kind d$d $scr fmt$fmt order$order index $index: got '$out' want '$head $want'" $?
}
for ep in "tcp:127.0.0.1:$P4" "tcp:::1:$P6" "rtu:$tmp/ttyc"; do
    unit=7
    case $ep in rtu:*) unit=5 ;; esac
    point_case "$ep" $unit sobol 1 3 none 0 0 0 0 6 1
    point_case "$ep" $unit sobol 1 16 owen 1 123456 0 1 65535 2
    point_case "$ep" $unit halton 2 5 faure 3 99 2 0 4294967295 3
    point_case "$ep" $unit sobol 1 6 fast-owen 4 4294967295 2 1 1000003 5
    point_case "$ep" $unit random 3 2 none 0 31337 1 0 77 4
done
# mbpoll as the RTU master too: FC16 then FC04, the same registers as TCP.
MBR="mbpoll -m rtu -b 19200 -P even -a 5 -0 -1 -o 5"
$MBR -t 4 -r 0 "$tmp/ttyc" 1 4 1 0 7 0 0 0 0 123 42 > "$tmp/mb.out" 2>&1
check "mbpoll RTU FC16 write: $(tail -n 2 "$tmp/mb.out")" $?
$MBR -t 3:hex -r 0 -c 14 "$tmp/ttyc" 2>&1 | sed -n 's/^\[\([0-9]*\)\]:[[:space:]]*0x\(....\)$/\2/p' |
    tr 'A-F' 'a-f' > "$tmp/got"
{ printf '002a\n0000\n0000\n0000\n0000\n007b\n'
  words sobol 4 owen 7 123 f32 | sed 's/^\(....\)\(....\)$/\1\n\2/'; } > "$tmp/want"
cmp -s "$tmp/got" "$tmp/want"
check "mbpoll RTU registers == qmc points: $(tr '\n' ' ' < "$tmp/got")" $?
out=$("$CLIENT" "rtu:$tmp/ttyc" 5 report 2>&1)
case $out in "51 ff qmcd "*" sobol:"*) ok ;; *) bad "RTU FC17: '$out'" ;; esac
# A unit that is not on the line never answers: wait 1 s for it, not the
# client's default 10 s (which every answered call gets, so that a slow
# daemon is never mistaken for a silent one).
MODBUS_CLIENT_TIMEOUT_MS=1000 "$CLIENT" "rtu:$tmp/ttyc" 6 input 0 1 > "$tmp/out" 2>&1
[ $? -eq 3 ] && grep -qi "timed out" "$tmp/out"
check "RTU unit 6 (not ours) gets no answer: $(cat "$tmp/out")" $?
# libmodbus then takes the next frame on the line for unit 6's answer and
# ignores it (a multi-drop bus would carry one); a master retries after
# its timeout (1 s the first time), and the retry is served.
out=$(MODBUS_CLIENT_TIMEOUT_MS=1000 "$CLIENT" "rtu:$tmp/ttyc" 5 input 0 1 2>&1) ||
    out=$("$CLIENT" "rtu:$tmp/ttyc" 5 input 0 1 2>&1)
[ "$out" = "42" ]
check "RTU serves unit 5 again after the foreign frame: '$out'" $?

# ---- 5. pymodbus, hostile and crowded clients ---------------------------------
QMC="$QMC" $PEER pymodbus 127.0.0.1 "$P4" > "$tmp/peer.out" 2>&1
check "pymodbus peer" $?
QMC="$QMC" $PEER pymodbus ::1 "$P6" >> "$tmp/peer.out" 2>&1
check "pymodbus peer over IPv6" $?
$PEER dribble 127.0.0.1 "$P4" >> "$tmp/peer.out" 2>&1
check "dribble" $?
$PEER many 127.0.0.1 "$P4" 200 >> "$tmp/peer.out" 2>&1
check "200 connections" $?
$PEER refused 127.0.0.1 "$P4" 127.0.0.2 >> "$tmp/peer.out" 2>&1
check "refused" $?
$PEER raw 127.0.0.1 "$P4" >> "$tmp/peer.out" 2>&1
check "raw MBAP" $?
wait $stall_pid
check "stall: $(cat "$tmp/stall.out")" $?
stall_pid=
cat "$tmp/stall.out" >> "$tmp/peer.out"
grep -q "FAIL" "$tmp/peer.out" && grep "FAIL" "$tmp/peer.out"
n_ok=$(grep -c "^ok " "$tmp/peer.out")
pass=$((pass + n_ok))
grep -q "modbus: tcp:127.0.0.1:$P4: refused 127.0.0.2:" "$tmp/qmcd.log"
check "the refusal is logged" $?
grep -q "frame unfinished after 10000 ms" "$tmp/qmcd.log"
check "the stalled frame is logged" $?

# ---- 6. the limits, on a second daemon ---------------------------------------------
"$QMCD" --foreground --listen "unix:$tmp/lim.sock" --modbus tcp:127.0.0.1:0 \
    --modbus-max-sessions 2 --modbus-max-connections 3 --write-timeout-ms 200 \
    --modbus-max-connections-per-peer 3 --modbus-max-sessions-per-peer 2 \
    --ready-file "$tmp/lim.ready" \
    2> "$tmp/lim.log" &
lim_pid=$!
wait_nonempty "$tmp/lim.ready" $lim_pid
LP=$(sed -n 's/^modbus:tcp:127\.0\.0\.1:\([0-9]*\)$/\1/p' "$tmp/lim.ready")
$PEER limits 127.0.0.1 "$LP" > "$tmp/lim.out" 2>&1
check "limits: $(grep FAIL "$tmp/lim.out")" $?
pass=$((pass + $(grep -c "^ok " "$tmp/lim.out")))
$PEER nonreader 127.0.0.1 "$LP" > "$tmp/lim.out" 2>&1
check "nonreader: $(cat "$tmp/lim.out")" $?
pass=$((pass + $(grep -c "^ok " "$tmp/lim.out")))
grep -q "no reply taken for 200 ms" "$tmp/lim.log"
check "the write stall is logged" $?
kill $lim_pid; wait $lim_pid
check "the second daemon exits 0" $?
lim_pid=

# ---- 7. SIGHUP keeps the transports and the banks --------------------------------
kill -HUP "$pid"
i=0
while ! grep -q "configuration reloaded" "$tmp/qmcd.log" && [ $i -lt 2000 ]; do
    i=$((i + 1)); sleep 0.01
done
out=$("$CLIENT" "tcp:::1:$P6" 7 input 0 1 2>&1)
[ "$out" = "4" ]
check "after SIGHUP the bank of (::1, unit 7) still answers request 4: '$out'" $?

# ---- 8. the protocol listener still works; SIGTERM exits 0 -----------------------
"$QMC" ping --connect "unix:$tmp/qmcd.sock" > /dev/null 2>&1
check "qmc ping beside the Modbus listeners" $?
# STATS carries the Modbus counters: requests from every peer above, the
# refusal from 127.0.0.2, the three bad MBAP headers (RTU frames dropped
# by libmodbus count as malformed too).
"$QMC" stats --connect "unix:$tmp/qmcd.sock" > "$tmp/stats" 2>&1
stat() { awk -v k="$1" '$1 == k { print $2 }' "$tmp/stats"; }
[ "$(stat modbus_requests)" -gt 100 ] && [ "$(stat modbus_exceptions)" -ge 8 ] &&
    [ "$(stat modbus_connections_refused)" -eq 1 ] && [ "$(stat modbus_malformed_frames)" -ge 3 ] &&
    [ "$(stat modbus_connections_accepted)" -gt 200 ]
check "qmc stats shows the Modbus counters: $(grep modbus_ "$tmp/stats" | tr '\n' ' ')" $?
kill "$pid"
wait "$pid"
rc=$?
pid=
check "qmcd exits 0 on SIGTERM with Modbus transports (rc $rc)" $rc
if grep -E "error|err:" "$tmp/qmcd.log" > /dev/null; then bad "errors in the log:"; cat "$tmp/qmcd.log"; else ok; fi

finish
