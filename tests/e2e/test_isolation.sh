#!/bin/sh
# End-to-end checks that one client cannot take qmcd from everyone else
# (issue 15, finding 2), with tests/e2e/greedypeer.py as the greedy client:
# many sockets from one peer (TCP 127.0.0.2, and one Unix-socket uid),
# streams that are never read, jobs that never end, quota floods, and a
# shared-memory ring punched full of holes.  Each attempt is followed by
# "the daemon is alive, serves another client correctly, VmRSS under a
# stated bound".  Daemons listen on a temporary Unix socket and loopback
# port 0, are waited for through --ready-file and stopped by PID.
# Issue 22's findings 1 and 2 (tests/e2e/floodpeer.py): clients without the
# key flooding the handshake from 127.0.0.2..5 while a Unix client and a key
# holder are served; the handshake budget counted per network; one peer's
# endless jobs leaving room for another peer's.  The per-network parts need
# peers off loopback: run as root, the script re-runs itself in a network
# namespace of its own (unshare -n) and puts documentation addresses
# (192.0.2.0/24, RFC 5737; 2001:db8::/32, RFC 3849) on that namespace's lo,
# as test_modbus_isolation.sh does; without unshare those parts are skipped
# and say so.
# Env: QMC, QMCD (binaries), BUILD.  Prints "N passed, M failed".
set -u
: "${QMCD:?QMCD must name the qmcd binary}"
if [ -z "${QMC_E2E_NETNS:-}" ] && [ "$(id -u)" -eq 0 ] && command -v unshare > /dev/null &&
    command -v ip > /dev/null && unshare -n true 2> /dev/null; then
    QMC_E2E_NETNS=1
    export QMC_E2E_NETNS
    exec unshare -n sh "$0" "$@"
fi
GREEDY="$(cd "$(dirname "$0")" && pwd)/greedypeer.py"
BACKFILL="$(cd "$(dirname "$0")" && pwd)/backfillpeer.py"
FLOOD="$(cd "$(dirname "$0")" && pwd)/floodpeer.py"
. "$(dirname "$0")/lib.sh"

netns=0
if [ "${QMC_E2E_NETNS:-}" = 1 ] && ip link set lo up &&
    for a in 192.0.2.1 192.0.2.2 192.0.2.3 192.0.2.4; do
        ip addr add "$a/32" dev lo || exit 1
    done &&
    for a in 2001:db8:0:1::1 2001:db8:0:2::1 2001:db8:0:2::2 2001:db8:0:3::1; do
        ip -6 addr add "$a/128" dev lo nodad || exit 1
    done; then
    netns=1
else
    echo "skip: the checks that need peers off loopback (need root and unshare -n)"
fi

# greedy SCENARIO ARGS...: runs a greedypeer scenario, counts its lines.
greedy() { run_peer "$GREEDY" "$@"; }

# serve NAME ARGS...: lib.sh's start, on its own Unix socket and a loopback
# port; sets $pid, $U (the socket) and $T (the TCP address).
serve() {
    name=$1
    shift
    start "$name" --listen "unix:$tmp/$name.sock" --listen tcp:127.0.0.1:0 \
        --log-level notice "$@" || return 1
    U="unix:$tmp/$name.sock"
    T=$(grep '^tcp:' "$tmp/$name.ready")
}

# stop PID: SIGTERM, and a clean exit status.
stop() {
    kill -TERM "$1"
    if wait "$1"; then ok; else bad "daemon $1 did not exit cleanly"; fi
    forget "$1"
}

# 1. Connection slots: one peer cannot take them all.  Another uid on the
# same Unix socket is another peer, so the socket (and the directory) must
# let uid 65534 in for the test.
serve peers --max-connections 1024 --max-connections-per-peer 64 || exit 1
chmod 755 "$tmp"
chmod 666 "$tmp/peers.sock"
greedy peers "$T" "$U" "$pid" 64
stop "$pid"

# 2. Output memory: 200 connections (one peer, its limit raised for the
# test) ask for 1M-point streams and never read.  Without a global cap each
# filled its 4 MiB out-buffer-bytes (RSS 5 MB -> 789 MB); with
# out-buffer-total-bytes 32M the bound is 32 MiB plus a 128 KiB floor per
# connection (25 MiB), so +80 MiB.
serve noread --max-connections-per-peer 256 --out-buffer-total-bytes 32M || exit 1
greedy noread "$U" "$pid" 200 80
stop "$pid"

# 3. Workers: one connection's 8 endless jobs (rqmc blocks, then cubature
# that runs none) against another's tiny job, asserted by order: the tiny
# job is answered while all 8 still run or wait, with the same bits as on
# an idle daemon.  (Before the fair pool it waited behind them: 60 s
# socket timeout.)  max-job-evals is raised so the 8 never end by budget;
# at 2^40 evaluations an adaptive job may hold 94 GB of block sums, so
# max-jobs-memory-total is raised with it (test 6 tries that limit).
serve starve --threads 2 --max-job-evals 1099511627776 --max-jobs-memory-total 4096G || exit 1
greedy starve "$U"
# One peer with 6 connections x 2 such jobs would take all 10 runners; it
# gets all but 2 (threads), and 127.0.0.1's job still runs and finishes.
greedy starve_peers "$T" 6
stop "$pid"

# 4. Quotas: jobs in flight and cancels, per connection.
serve quota --threads 1 --max-jobs-per-conn 3 --max-cancels-per-conn 4 \
    --max-job-evals 1099511627776 --max-jobs-memory-total 4096G || exit 1
greedy quota "$U" 3 4
stop "$pid"

# 5. Shared memory: after SHM_OK the client punches holes in its ring (and
# tries MADV_REMOVE), so that the daemon's writes would allocate the pages
# again, charged to the daemon.  Before the seal: a 64 MiB ring went
# RssShmem 64 MiB -> 0 -> 64 MiB (allocated anew by the daemon).  Now both
# fail with EPERM and the memfd's blocks never change.
serve punch || exit 1
greedy punch "$U" "$pid" 16
stop "$pid"

# 6. Job memory: 8 cubature jobs from 4 peers (127.0.0.1, .2, .3, a Unix
# uid), each filling 24 MiB of regions, under max-jobs-memory-total 56M:
# at most 2 run at once and the rest wait their turn, all answered with
# the bits of an idle daemon; VmRSS under +56 + 24 MiB.  Without the
# total all 8 ran at once: VmRSS 5 MB -> 202 MB.  A job whose own bound is
# over the total is refused.
# Under ASan (make sanitize) freed blocks sit in its quarantine (256 MB by
# default), which would count the jobs that ended: a quarantine smaller
# than one job's workspace lets them go back as glibc's would.
ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}quarantine_size_mb=8"
export ASAN_OPTIONS
serve jobmem --threads 2 --max-jobs-memory-total 56M || exit 1
greedy jobmem "$T" "$U" "$pid" 56 24 24
stop "$pid"

# 7. Backfill: a 40 MiB job runs under max-jobs-memory-total 64M, a second
# one waits, 3 small jobs of another peer finish meanwhile
# (job-memory-overtakes 3), the 4th waits until the big one has started;
# STATS counts the backfills and waits exactly and accepted = done +
# failed + cancelled + dropped + open (tests/e2e/backfillpeer.py).
serve backfill --threads 2 --max-jobs-memory-total 64M --max-job-evals 2199023255552 \
    --job-memory-overtakes 3 || exit 1
run_peer "$BACKFILL" backfill "$T" "$U" 3
stop "$pid"

# 8. The handshake is its own budget (issue 22, finding 1).  The issue's
# attack: with max-connections 100 and max-connections-per-peer 25, 4
# loopback addresses keep 25 keyless connections each and re-open every
# one closed.  Before: every slot was theirs, and a key holder over TCP and
# a Unix-socket client were refused ("max-connections (100) reached") 30
# times of 30.  Now connections in the handshake live in
# max-preauth-connections (64), loopback holding a quarter of it: the Unix
# client and a key holder from another network are served every round.
umask 077
head -c 32 /dev/urandom > "$tmp/key"
umask 022
if [ $netns = 1 ]; then tcp_any=tcp:0.0.0.0:0; else tcp_any=tcp:127.0.0.1:0; fi
start preauth --listen "unix:$tmp/preauth.sock" --listen "$tcp_any" --auth-key "$tmp/key" \
    --max-connections 100 --max-connections-per-peer 25 --log-level notice || exit 1
port=$(sed -n 's/^tcp:[0-9.]*:\([0-9]*\)$/\1/p' "$tmp/preauth.ready")
if [ $netns = 1 ]; then
    run_peer "$FLOOD" preauth "$port" "unix:$tmp/preauth.sock" "$tmp/key" 20 192.0.2.2 192.0.2.1
else
    run_peer "$FLOOD" preauth "$port" "unix:$tmp/preauth.sock" "$tmp/key" 20
fi
stop "$pid"

# 9. ... counted per network: loopback is one, an IPv6 /64 is one, an IPv4
# address off loopback is one; past a network's share its oldest
# handshake makes room, past the total the busiest network's does.
if [ $netns = 1 ]; then
    start nets --listen "unix:$tmp/nets.sock" --listen tcp:0.0.0.0:0 --listen "tcp:[::]:0" \
        --auth-key "$tmp/key" --max-preauth-connections 13 \
        --max-preauth-connections-per-peer 4 --handshake-timeout-ms 60000 \
        --log-level notice || exit 1
    p4=$(sed -n 's/^tcp:[0-9.]*:\([0-9]*\)$/\1/p' "$tmp/nets.ready")
    p6=$(sed -n 's/^tcp:\[[0-9a-f:]*\]:\([0-9]*\)$/\1/p' "$tmp/nets.ready")
    run_peer "$FLOOD" nets "$p4" "$p6" "unix:$tmp/nets.sock" 4 13
    stop "$pid"
fi

# 10. Jobs are shared per peer (issue 22, finding 2).  One uid's 8
# connections x 8 endless jobs took all of max-jobs (64) before, and every
# other peer's INTEGRATE was refused ("max-jobs: 64 jobs already open")
# until job-time-limit-ms; now it gets max-jobs-per-peer (a quarter: 16),
# and 127.0.0.1's job and uid 65534's are accepted and answered.
serve jobshare --threads 2 --max-job-evals 1099511627776 --max-jobs-memory-total 4096G || exit 1
chmod 755 "$tmp"
chmod 666 "$tmp/jobshare.sock"
run_peer "$FLOOD" jobshare "$U" "$T" 8 8 16
stop "$pid"

if grep -l -E "AddressSanitizer|LeakSanitizer|runtime error" "$tmp"/*.log; then
    bad "sanitizer report in a daemon log"
else ok; fi
if [ $fail -ne 0 ]; then
    for f in "$tmp"/*.log; do echo "--- $f (tail)"; tail -n 20 "$f"; done
fi
finish
