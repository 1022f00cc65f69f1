#!/bin/sh
# End-to-end checks that no Modbus TCP client can take the Modbus server
# from the others (issue 22, finding 4 and two of 7), with
# tests/e2e/modbus_isolation.py as the hostile clients:
#
#   - at the defaults, 256 silent sockets from loopback (127.0.0.2..5, one
#     peer) leave a newcomer served 12 times of 12 (before: refused 12 of
#     12, modbus-max-connections was all theirs); the same with the
#     issue's modbus-max-connections 50 and 50 sockets;
#   - at the defaults, FC03 reads of 4 addresses x 256 unit ids make no
#     bank, and a newcomer's FC17, FC43 and FC03 are answered (before: the
#     reads made 1024 banks and the newcomer got exception 06);
#   - modbus-max-connections-per-peer, peer by peer: loopback is one peer,
#     an IPv6 /64 is one, an IPv4 address off loopback is one; a newcomer
#     from another peer is served while one holds its cap; the server-wide
#     cap still holds; STATS counts each;
#   - modbus-max-sessions-per-peer: a refused write leaves no bank; a peer
#     past its share gets exception 06 for a new bank but still reads,
#     FC17 and FC43; another peer gets a bank; with the table full writes
#     to new banks get 06, reads are answered, written banks keep state;
#   - modbus-allow entries written IPv4-mapped (::ffff:127.0.0.3) match
#     IPv4 peers; a mapped network shorter than /96 is refused at load;
#   - a Modbus host name that does not resolve says so (not "off loopback").
#
# The per-peer rules need peers that are not loopback.  Run as root, the
# script re-runs itself in a network namespace of its own (unshare -n) and
# puts documentation addresses (192.0.2.0/24, RFC 5737; 2001:db8::/32,
# RFC 3849) on that namespace's lo: no packet can leave it.  Without
# unshare those parts are skipped, and say so.
# Env: QMC, QMCD, BUILD.  Prints "N passed, M failed".
set -u
: "${QMC:?QMC must name the qmc binary}"
: "${QMCD:?QMCD must name the qmcd binary}"
if [ -z "${QMC_E2E_NETNS:-}" ] && [ "$(id -u)" -eq 0 ] && command -v unshare > /dev/null &&
    command -v ip > /dev/null && unshare -n true 2> /dev/null; then
    QMC_E2E_NETNS=1
    export QMC_E2E_NETNS
    exec unshare -n sh "$0" "$@"
fi
here=$(cd "$(dirname "$0")" && pwd)
PEER="$here/modbus_isolation.py"
. "$here/lib.sh"
export QMC

netns=0
if [ "${QMC_E2E_NETNS:-}" = 1 ] && ip link set lo up &&
    for a in 192.0.2.1 192.0.2.2 192.0.2.3 192.0.2.4 192.0.2.5; do
        ip addr add "$a/32" dev lo || exit 1
    done &&
    for a in 2001:db8:0:1::1 2001:db8:0:2::1 2001:db8:0:2::2 2001:db8:0:2::3 2001:db8:0:3::1; do
        ip -6 addr add "$a/128" dev lo nodad || exit 1
    done; then
    netns=1
else
    echo "skip: the per-peer checks against other peers (need root and unshare -n)"
fi

# stop PID: SIGTERM, and a clean exit status.
stop() {
    kill -TERM "$1"
    if wait "$1"; then ok; else bad "qmcd $1 did not exit cleanly"; fi
    forget "$1"
}
stat_of() { "$QMC" stats --connect "unix:$1" | awk -v k="$2" '$1 == k { print $2 }'; }
# ports NAME: P4 and P6, the Modbus ports in $tmp/NAME.ready.
ports() {
    P4=$(sed -n 's/^modbus:tcp:[0-9.]*:\([0-9]*\)$/\1/p' "$tmp/$1.ready")
    P6=$(sed -n 's/^modbus:tcp:\[[0-9a-f:]*\]:\([0-9]*\)$/\1/p' "$tmp/$1.ready")
}

# ---- 0. settings: one clear line ----------------------------------------------
# (Bounded: a daemon that took the setting would serve until killed.)
timeout 20 "$QMCD" --foreground --listen "unix:$tmp/x.sock" --modbus tcp:127.0.0.1:0 \
    --modbus-allow ::ffff:10.0.0.0/64 > /dev/null 2> "$tmp/err"
rc=$?
if [ $rc -eq 2 ] && [ "$(wc -l < "$tmp/err")" -eq 1 ] && grep -q "IPv4-mapped" "$tmp/err"; then ok
else bad "::ffff:10.0.0.0/64: exit $rc, $(head -n 3 "$tmp/err")"; fi
timeout 20 "$QMCD" --foreground --listen "unix:$tmp/x.sock" \
    --modbus tcp:qmcd-no-such-host.invalid:0 > /dev/null 2> "$tmp/err"
rc=$?
if [ $rc -ne 0 ] && [ "$(wc -l < "$tmp/err")" -eq 1 ] && grep -q "does not resolve" "$tmp/err" &&
    ! grep -q "off loopback" "$tmp/err"; then ok
else bad "an unresolvable Modbus host: exit $rc, $(cat "$tmp/err")"; fi

# ---- 1. the issue's attacks, at the defaults -------------------------------------
# (A daemon that does not start fails its part, and the others still run.)
if start dflt --listen "unix:$tmp/dflt.sock" --modbus tcp:127.0.0.1:0; then
ports dflt
run_peer "$PEER" readers "$P4" "$tmp/dflt.sock"
if [ $netns = 1 ]; then
    run_peer "$PEER" silent "$P4" "$tmp/dflt.sock" 256 192.0.2.1
    # 256 sockets, one peer: 64 (the default cap) let in, 192 refused.
    n=$(stat_of "$tmp/dflt.sock" modbus_refused_connections_per_peer)
    if [ "$n" = 192 ]; then ok; else bad "silent: refused per peer '$n', want 192"; fi
    grep -q "modbus-max-connections-per-peer (64) reached for loopback" "$tmp/dflt.log"
    if [ $? -eq 0 ]; then ok; else bad "silent: the refusal is not logged: $(tail -n 3 "$tmp/dflt.log")"; fi
fi
stop "$pid"
fi

# The issue's own numbers: modbus-max-connections 50 and 50 silent sockets.
# The per-peer cap left at its default is a quarter of the total (12), so
# lowering the total keeps the room for others.
if [ $netns = 1 ] && start fifty --listen "unix:$tmp/fifty.sock" --modbus tcp:127.0.0.1:0 \
    --modbus-max-connections 50; then
    ports fifty
    run_peer "$PEER" silent "$P4" "$tmp/fifty.sock" 50 192.0.2.1
    n=$(stat_of "$tmp/fifty.sock" modbus_refused_connections_per_peer)
    if [ "$n" = 38 ]; then ok; else bad "silent, 50 of 50: refused per peer '$n', want 38"; fi
    stop "$pid"
fi

# ---- 2. the per-peer caps, peer by peer -------------------------------------------
if [ $netns = 1 ]; then
    nets="127.0.0.0/8, ::1, 192.0.2.0/24, 2001:db8::/32"
    if start conns --listen "unix:$tmp/conns.sock" --modbus tcp:0.0.0.0:0 \
        --modbus "tcp:[::]:0" --modbus-allow "$nets" --modbus-max-connections 13 \
        --modbus-max-connections-per-peer 4; then
        ports conns
        run_peer "$PEER" conns "$P4" "$P6" "$tmp/conns.sock" 4 13
        stop "$pid"
    fi
    if start banks --listen "unix:$tmp/banks.sock" --modbus tcp:0.0.0.0:0 \
        --modbus "tcp:[::]:0" --modbus-allow "$nets" --modbus-max-sessions 8 \
        --modbus-max-sessions-per-peer 3; then
        ports banks
        run_peer "$PEER" banks "$P4" "$P6" "$tmp/banks.sock" 3 8
        stop "$pid"
    fi
fi

# ---- 3. modbus-allow written IPv4-mapped ---------------------------------------------
if start allow --listen "unix:$tmp/allow.sock" --modbus tcp:127.0.0.1:0 \
    --modbus-allow "::ffff:127.0.0.3, ::ffff:127.0.0.8/126"; then
    ports allow
    run_peer "$PEER" allow "$P4" 127.0.0.3,127.0.0.8,127.0.0.11 127.0.0.4,127.0.0.12
    stop "$pid"
fi

finish
