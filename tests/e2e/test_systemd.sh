#!/bin/sh
# The systemd integration, with no systemd running as PID 1:
#  - systemd/qmcd.service and qmcd.socket pass `systemd-analyze verify`
#    silently (a copy with ExecStart= pointing at the built binary, and the
#    tree's man pages on MANPATH for Documentation=), and the service's
#    `systemd-analyze security --offline=yes` exposure is at most 2.0; the
#    Modbus RTU drop-in verifies too;
#  - systemd-socket-activate hands qmcd two listening sockets, clients are
#    served through both, and qmcd neither creates a default socket nor
#    removes the files it was handed;
#  - a notify socket of our own (tests/e2e/notifysock.py) with WATCHDOG_USEC
#    set receives READY=1, several WATCHDOG=1, RELOADING=1 and a STATUS=
#    line for a good and for a rejected SIGHUP, and STOPPING=1; qmcd started
#    without --foreground stays in the foreground there (no fork).
# Env: QMC, QMCD, BUILD.  Prints "N passed, M failed".
set -u
: "${QMC:?QMC must name the qmc binary}"
: "${QMCD:?QMCD must name the qmcd binary}"
PY=/usr/bin/python3
HERE="$(cd "$(dirname "$0")" && pwd)"
TOP="$(cd "$HERE/../.." && pwd)"
. "$(dirname "$0")/lib.sh"

# wait_for FILE PATTERN: polls (50 ms steps, at most 30 s) for a line of
# FILE matching the grep pattern.  The bounds here and in wait_count only
# stop a hang: a sanitized daemon's start and exit on a loaded machine
# must not be mistaken for a missing notification.
wait_for() {
    i=0
    while ! grep -q -- "$2" "$1" 2>/dev/null && [ $i -lt 600 ]; do sleep 0.05; i=$((i + 1)); done
    grep -q -- "$2" "$1" 2>/dev/null
}
# wait_count FILE PATTERN N: until at least N lines match.
wait_count() {
    i=0
    while [ "$(grep -c -- "$2" "$1" 2>/dev/null)" -lt "$3" ] && [ $i -lt 600 ]; do
        sleep 0.05
        i=$((i + 1))
    done
    [ "$(grep -c -- "$2" "$1" 2>/dev/null)" -ge "$3" ]
}

# ---- 1. systemd-analyze verify and security -----------------------------------
mkdir -p "$tmp/units" "$tmp/man/man8" "$tmp/man/man5" "$tmp/man/man1"
sed -e "s|@SBINDIR@|$(dirname "$QMCD")|g" -e "s|@SYSCONFDIR@|/etc|g" \
    "$TOP/systemd/qmcd.service" > "$tmp/units/qmcd.service"
# qmcd's binary is build/qmcd: the unit's qmcd must be the one we built
grep -q "^ExecStart=$QMCD --foreground" "$tmp/units/qmcd.service" || \
    bad "ExecStart= was not rewritten to $QMCD"
cp "$TOP/systemd/qmcd.socket" "$tmp/units/"
cp "$TOP/man/qmcd.8" "$tmp/man/man8/"
cp "$TOP/man/qmcd.conf.5" "$tmp/man/man5/"
cp "$TOP/man/qmc.1" "$tmp/man/man1/"
out=$(cd "$tmp/units" && MANPATH="$tmp/man" systemd-analyze verify qmcd.service qmcd.socket 2>&1)
if [ -z "$out" ]; then ok; else bad "systemd-analyze verify: $out"; fi
mkdir -p "$tmp/units/qmcd.service.d"
cp "$TOP/systemd/qmcd-modbus-rtu.conf" "$tmp/units/qmcd.service.d/modbus-rtu.conf"
out=$(cd "$tmp/units" && MANPATH="$tmp/man" systemd-analyze verify qmcd.service 2>&1)
if [ -z "$out" ]; then ok; else bad "verify with the Modbus RTU drop-in: $out"; fi
rm -r "$tmp/units/qmcd.service.d"
sec=$(systemd-analyze security --offline=yes --no-pager "$tmp/units/qmcd.service" 2>&1)
score=$(printf '%s\n' "$sec" | sed -n 's/.*Overall exposure level for qmcd.service: \([0-9.]*\).*/\1/p')
if [ -n "$score" ] && awk -v s="$score" 'BEGIN { exit !(s <= 2.0) }'; then ok
else bad "systemd-analyze security: exposure '$score' (want <= 2.0): $(printf '%s\n' "$sec" | tail -n 3)"; fi
echo "systemd-analyze security --offline=yes: exposure $score"

# ---- 2. socket activation ---------------------------------------------------
A="$tmp/a.sock"
B="$tmp/b.sock"
systemd-socket-activate -l "$A" -l "$B" "$QMCD" --foreground --threads 1 \
    --ready-file "$tmp/sa.ready" 2> "$tmp/sa.log" &
SA=$!
pids="$pids $SA"
i=0
while [ ! -S "$A" ] && [ $i -lt 200 ]; do sleep 0.05; i=$((i + 1)); done
# The first connection makes systemd-socket-activate exec qmcd with both
# listening descriptors (LISTEN_FDS=2); that client is then served.
if "$QMC" ping --connect "unix:$A" > "$tmp/ping1.out" 2>&1; then ok
else bad "ping through the activated socket: $(cat "$tmp/ping1.out")"; fi
if "$QMC" points --seq sobol --dims 3 --count 100 --format f64 --connect "unix:$B" > "$tmp/p.bin" &&
    "$QMC" points --seq sobol --dims 3 --count 100 --format f64 > "$tmp/q.bin" &&
    cmp -s "$tmp/p.bin" "$tmp/q.bin"; then ok
else bad "points through the second activated socket differ or failed"; fi
if [ "$(sed -n 's/^pid //p' "$tmp/sa.ready")" = "$SA" ]; then ok
else bad "systemd-socket-activate did not exec qmcd in place: ready file $(cat "$tmp/sa.ready")"; fi
# qmcd serves what it was given and adds no default socket of its own
if [ "$(grep -c '^unix:' "$tmp/sa.ready")" -eq 2 ] && ! grep -q "/run/qmcd" "$tmp/sa.ready"; then ok
else bad "activated qmcd listens on: $(tr '\n' ' ' < "$tmp/sa.ready")"; fi
kill -TERM "$SA"
if wait_gone "$SA" 600 && wait "$SA"; then ok; else bad "activated qmcd: SIGTERM did not exit 0"; fi
# the socket files belong to whoever created them (systemd): qmcd leaves them
if [ -S "$A" ] && [ -S "$B" ]; then ok; else bad "qmcd removed socket files it was handed"; fi

# ---- 3. the notify socket and the watchdog ----------------------------------
N="$tmp/notify.sock"
NLOG="$tmp/notify.log"
"$PY" "$HERE/notifysock.py" "$N" "$NLOG" &
NPID=$!
pids="$pids $NPID"
wait_for "$NLOG" '^LISTENING=1' || bad "notify socket stand-in did not start"
printf 'threads = 1\nlog-level = info\n' > "$tmp/good.conf"
# No --foreground: with NOTIFY_SOCKET set qmcd must not fork, so $! is qmcd.
# WATCHDOG_USEC=300000: a ping every 150 ms.
NOTIFY_SOCKET="$N" WATCHDOG_USEC=300000 "$QMCD" --config "$tmp/good.conf" \
    --listen "unix:$tmp/n.sock" --ready-file "$tmp/n.ready" 2> "$tmp/n.log" &
D=$!
pids="$pids $D"
if wait_for "$NLOG" '^READY=1'; then ok; else bad "no READY=1: $(cat "$tmp/n.log")"; fi
if [ "$(sed -n 's/^pid //p' "$tmp/n.ready")" = "$D" ]; then ok
else bad "qmcd forked under NOTIFY_SOCKET (ready file: $(head -n 1 "$tmp/n.ready"), started $D)"; fi
if grep -q '^STATUS=serving' "$NLOG"; then ok; else bad "no STATUS= line at startup"; fi
# READY=1 came before any WATCHDOG=1 was needed, and pings keep coming.
if wait_count "$NLOG" '^WATCHDOG=1$' 3; then ok
else bad "fewer than 3 WATCHDOG=1 ($(grep -c '^WATCHDOG=1' "$NLOG"))"; fi
"$QMC" ping --connect "unix:$tmp/n.sock" > /dev/null 2>&1 || bad "notify daemon does not serve"
# a good reload, then a bad one: RELOADING=1, READY=1 again, STATUS says why
kill -HUP "$D"
if wait_for "$NLOG" 'STATUS=serving; configuration reloaded' && grep -q '^RELOADING=1' "$NLOG" &&
    grep -q '^MONOTONIC_USEC=[0-9]' "$NLOG"; then ok
else bad "SIGHUP: no RELOADING=1 / MONOTONIC_USEC / STATUS: $(tr '\n' ' ' < "$NLOG" | tail -c 300)"; fi
printf 'threads = 1\nmax-jobs = many\n' > "$tmp/good.conf"
kill -HUP "$D"
if wait_for "$NLOG" 'STATUS=serving; reload rejected: .*good.conf:2: max-jobs'; then ok
else bad "a rejected SIGHUP did not say why in STATUS="; fi
if [ "$(grep -c '^READY=1' "$NLOG")" -ge 3 ]; then ok
else bad "READY=1 not sent again after each reload"; fi
"$QMC" ping --connect "unix:$tmp/n.sock" > /dev/null 2>&1 && ok || bad "no service after a rejected reload"
before=$(grep -c '^WATCHDOG=1$' "$NLOG")
wait_count "$NLOG" '^WATCHDOG=1$' $((before + 2)) && ok || bad "watchdog pings stopped after the reloads"
kill -TERM "$D"
if wait_for "$NLOG" '^STOPPING=1'; then ok; else bad "no STOPPING=1 on SIGTERM"; fi
if grep -q '^STATUS=stopping (SIGTERM): 0 job(s)' "$NLOG"; then ok; else bad "no STATUS= for the drain"; fi
if wait_gone "$D" 600 && wait "$D"; then ok; else bad "notify daemon: SIGTERM did not exit 0"; fi
# STOPPING=1 is the last state sent before the exit (a ping may follow it,
# the drain's loop still turns, but READY=1 must not)
if sed -n '/^STOPPING=1/,$p' "$NLOG" | grep -q '^READY=1'; then bad "READY=1 after STOPPING=1"; else ok; fi
# Without WATCHDOG_USEC there are no pings.
: > "$NLOG"
NOTIFY_SOCKET="$N" "$QMCD" --foreground --threads 1 --listen "unix:$tmp/w.sock" 2> "$tmp/w.log" &
W=$!
pids="$pids $W"
wait_for "$NLOG" '^READY=1' || bad "no READY=1 without a watchdog"
"$QMC" ping --connect "unix:$tmp/w.sock" --count 5 > /dev/null 2>&1 || bad "no service without a watchdog"
kill -TERM "$W"
wait_for "$NLOG" '^STOPPING=1' || bad "no STOPPING=1 without a watchdog"
wait_gone "$W" 600
if grep -q '^WATCHDOG=1' "$NLOG"; then bad "WATCHDOG=1 sent with no WATCHDOG_USEC"; else ok; fi
kill "$NPID"

if grep -l -E "AddressSanitizer|LeakSanitizer|runtime error" "$tmp"/*.log; then
    bad "sanitizer report in a daemon log"
else ok; fi
finish
