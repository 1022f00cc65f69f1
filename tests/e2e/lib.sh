# tests/e2e/lib.sh: the harness the end-to-end shell tests share, so that
# each test says only what it checks.  Sourced, never run:
#     . "$(dirname "$0")/lib.sh"
# after the test's own checks of its environment (QMC, QMCD, skips).
# POSIX sh: the Makefile runs every test with `sh`.  Its own variables are
# e2e_*, so that a test's loop counters (i, p, ...) survive a call.
#
# Set up when sourced:
#   tmp       a fresh directory (mktemp -d), removed at exit, unless
#             KEEP_TMP is set in the environment (then kept and named).
#   pids      PIDs the test started, separated by blanks; add one with
#             `pids="$pids $!"`.  At exit each gets SIGKILL: a test stops
#             what it started by PID, never by name.
#   term_vars names of variables holding PIDs that are instead stopped
#             with SIGTERM and waited for at exit, in the order named (an
#             empty variable is skipped): for a test that checks its
#             daemon's exit status and clears the variable once it has.
#   cleanup   the EXIT trap calls it by name: a test that must clean up
#             still otherwise redefines cleanup() after sourcing.  SIGINT
#             and SIGTERM exit the test, so cleanup runs then too.
#   QMC_ENDPOINT and QMC_AUTH_KEY_FILE are unset (a test sets its own).
#   pass, fail  the counters; `ok` counts a pass, `bad MSG` a failure and
#             prints "FAIL: MSG".
#
# Functions:
#   forget PID              drops PID from pids once the test has waited for
#                           it, so that cleanup cannot signal a reused PID.
#   finish                  prints "N passed, M failed" and exits 0 only if
#                           nothing failed: the last line every test prints.
#   tally FILE              adds FILE's "ok ..." lines to pass and its
#                           "FAIL ..." lines to fail, and prints the latter;
#                           1 if it has neither (a peer that printed no
#                           check at all: the caller says which).
#   run_peer SCRIPT SCENARIO ARGS...  runs the Python peer SCRIPT (with
#                           /usr/bin/python3) on SCENARIO ARGS, its output in
#                           $tmp/peer.out, and tallies it; a peer that printed
#                           no check at all is a failure naming the scenario.
#   wait_file FILE [STEPS]  polls in 50 ms steps, at most STEPS (default
#                           200, 10 s), until FILE exists; 0 if it does.
#   wait_gone PID [STEPS]   polls in 50 ms steps, at most STEPS (default
#                           200), until PID no longer exists; 0 if so.
#   wait_exit PID SECONDS   the same for a child of this shell, where a
#                           zombie (exited, not yet waited for) counts too.
#   start NAME ARGS...      qmcd --foreground --ready-file $tmp/NAME.ready
#                           ARGS in the background, stderr to $tmp/NAME.log;
#                           sets $pid, adds it to pids and waits (wait_file)
#                           for the ready file; else bad and returns 1.
#   wait_ready VAR FILE LOG  the stricter readiness wait: 10 ms steps, at
#                           most 2000, until FILE is non-empty.  If the
#                           daemon whose PID is in $VAR exits first (VAR is
#                           then cleared, so cleanup leaves it alone: LOG is
#                           printed) or time runs out, prints "FAIL: ..."
#                           and "0 passed, 1 failed" and exits 1.
#   wait_nonempty FILE PID  10 ms steps, at most 2000, until FILE is
#                           non-empty or PID has exited; the caller checks.
#   release_fifo FIFO       opens FIFO for writing without waiting and
#                           closes it, so that a qmcd stuck reading it (the
#                           bug issue 22 found) gets EOF and moves on;
#                           nothing when no reader has it open.
#   pty_pair A B            a serial line for Modbus RTU: socat joins two
#                           ptys linked at A and B (its log $tmp/socat.log),
#                           sets $socat_pid (name it in term_vars) and waits
#                           in 10 ms steps, at most 2000, for both links;
#                           else bad and returns 1.

tmp=$(mktemp -d)
pids=""
term_vars=""
cleanup() {
    for e2e_v in $term_vars; do
        eval "e2e_p=\${$e2e_v:-}"
        if [ -n "$e2e_p" ]; then kill "$e2e_p" 2>/dev/null; wait "$e2e_p" 2>/dev/null; fi
    done
    for e2e_p in $pids; do kill -9 "$e2e_p" 2>/dev/null; done
    if [ -n "${KEEP_TMP:-}" ]; then echo "kept $tmp"; else rm -rf "$tmp"; fi
}
trap cleanup EXIT
# An interrupted test exits, so that the EXIT trap still stops its daemons.
trap 'exit 1' INT TERM
# The caller's own daemon and key are not the test's: with these set every
# qmc command would go to it.  A test that wants them sets them itself.
unset QMC_ENDPOINT QMC_AUTH_KEY_FILE
pass=0
fail=0
ok() { pass=$((pass + 1)); }
bad() { fail=$((fail + 1)); echo "FAIL: $*"; }

finish() {
    echo "$pass passed, $fail failed"
    [ "$fail" -eq 0 ]
    exit
}

forget() {
    e2e_keep=""
    for e2e_p in $pids; do [ "$e2e_p" = "$1" ] || e2e_keep="$e2e_keep $e2e_p"; done
    pids=$e2e_keep
}

tally() {
    e2e_ok=$(grep -c '^ok ' "$1")
    e2e_bad=$(grep -c '^FAIL ' "$1")
    pass=$((pass + e2e_ok))
    fail=$((fail + e2e_bad))
    grep '^FAIL ' "$1"
    [ "$e2e_ok" -gt 0 ] || [ "$e2e_bad" -gt 0 ]
}

run_peer() {
    e2e_script=$1
    shift
    /usr/bin/python3 "$e2e_script" "$@" > "$tmp/peer.out" 2>&1
    tally "$tmp/peer.out" ||
        bad "$(basename "$e2e_script" .py) $1 printed nothing: $(head -c 300 "$tmp/peer.out")"
}

wait_file() {
    e2e_i=0
    while [ ! -e "$1" ] && [ $e2e_i -lt "${2:-200}" ]; do sleep 0.05; e2e_i=$((e2e_i + 1)); done
    [ -e "$1" ]
}

wait_gone() {
    e2e_i=0
    while kill -0 "$1" 2>/dev/null && [ $e2e_i -lt "${2:-200}" ]; do
        sleep 0.05
        e2e_i=$((e2e_i + 1))
    done
    ! kill -0 "$1" 2>/dev/null
}

# kill -0 succeeds on a zombie, and a child stays one until the shell
# waits for it: ask ps for the state instead.
wait_exit() {
    e2e_i=0
    e2e_lim=$(($2 * 20))
    while kill -0 "$1" 2>/dev/null && [ $e2e_i -lt $e2e_lim ]; do
        case $(ps -o stat= -p "$1" 2>/dev/null) in Z*) return 0 ;; esac
        sleep 0.05
        e2e_i=$((e2e_i + 1))
    done
    ! kill -0 "$1" 2>/dev/null || case $(ps -o stat= -p "$1" 2>/dev/null) in Z*) true ;; *) false ;; esac
}

start() {
    e2e_name=$1
    shift
    rm -f "$tmp/$e2e_name.ready"
    "$QMCD" --foreground --ready-file "$tmp/$e2e_name.ready" "$@" 2> "$tmp/$e2e_name.log" &
    pid=$!
    pids="$pids $pid"
    if ! wait_file "$tmp/$e2e_name.ready"; then
        bad "$e2e_name: not ready within 10 s: $(head -c 500 "$tmp/$e2e_name.log")"
        return 1
    fi
}

# The ready file is written by rename once every listener is up, so a
# non-empty file is a daemon that serves.
wait_ready() {
    e2e_pid=
    eval "e2e_pid=\$$1"
    e2e_i=0
    while [ ! -s "$2" ]; do
        if ! kill -0 "$e2e_pid" 2>/dev/null; then
            echo "FAIL: qmcd exited before it was ready:"; cat "$3"
            eval "$1="; echo "0 passed, 1 failed"; exit 1
        fi
        e2e_i=$((e2e_i + 1))
        if [ $e2e_i -gt 2000 ]; then echo "FAIL: qmcd not ready"; echo "0 passed, 1 failed"; exit 1; fi
        sleep 0.01
    done
}

release_fifo() {
    /usr/bin/python3 -c 'import os, sys
try:
    os.close(os.open(sys.argv[1], os.O_WRONLY | os.O_NONBLOCK))
except OSError:
    pass' "$1"
}

pty_pair() {
    socat pty,raw,echo=0,link="$1" pty,raw,echo=0,link="$2" 2> "$tmp/socat.log" &
    socat_pid=$!
    e2e_i=0
    while [ ! -e "$1" ] || [ ! -e "$2" ]; do
        e2e_i=$((e2e_i + 1))
        if [ $e2e_i -gt 2000 ] || ! kill -0 $socat_pid 2>/dev/null; then
            bad "socat pty pair not up: $(cat "$tmp/socat.log")"
            return 1
        fi
        sleep 0.01
    done
}

wait_nonempty() {
    e2e_i=0
    while [ ! -s "$1" ] && kill -0 "$2" 2>/dev/null && [ $e2e_i -lt 2000 ]; do
        e2e_i=$((e2e_i + 1))
        sleep 0.01
    done
}
