#!/bin/sh
# End-to-end checks of authentication (PROTOCOL.md section 4.1,
# docs/SECURITY.md) and of the request-id edges of section 3, against the
# real daemon on a temporary Unix socket and an ephemeral loopback port,
# waited for through --ready-file and stopped by PID:
#
#   - a TCP listener off loopback (0.0.0.0, [::]) without --auth-key is
#     refused before anything is bound; a key file open to others (0644),
#     too short, or not a regular file (a FIFO, a directory) is refused at
#     start, and on SIGHUP (the old key stays) - a FIFO at once, without
#     waiting for a writer, by qmcd and by qmc alike (issue 22, finding 5;
#     those qmcd and qmc run under `timeout`, so a regression fails rather
#     than hangs);
#   - with a key: qmc without one is refused, with --auth-key or
#     QMC_AUTH_KEY_FILE it is served, remote points byte-identical to local;
#     a wrong key gets ERROR and a closed connection; the Unix socket keeps
#     its permissions as access control (no key needed), or with auth-unix 1
#     asks for the key too; a key rotated by SIGHUP takes effect;
#   - tests/e2e/authpeer.py: the handshake against Python's HMAC, the
#     server's proof, reflection and downgrade refused, and guessing slowed
#     without locking anyone out (issue 22, finding 3): the right key
#     served after N failures from its address, only a network's share of
#     challenges outstanding at once, a wrong proof from a network that
#     failed often held back while others are served, the log saying so;
#     an unanswered challenge timing out naming AUTH_RESPONSE; PING on a
#     live POINTS id, a duplicate POINTS id, id 0; STATS jobs_dropped.
# Env: QMC, QMCD (binaries).  Prints "N passed, M failed".
set -u
: "${QMC:?QMC must name the qmc binary}"
: "${QMCD:?QMCD must name the qmcd binary}"
. "$(dirname "$0")/lib.sh"
# The daemon in $pid gets SIGTERM at exit; the test clears pid once it has
# stopped it itself and checked the exit status.
pid=
term_vars=pid
PEER="$(cd "$(dirname "$0")" && pwd)/authpeer.py"

# peer SCENARIO ARGS...: runs an authpeer scenario and counts its lines.
peer() {
    /usr/bin/python3 "$PEER" "$@" > "$tmp/peer.out" 2>&1
    while IFS= read -r line; do
        case "$line" in
            "ok "*) ok ;;
            "FAIL "*) bad "authpeer: ${line#FAIL }" ;;
            *) echo "authpeer: $line" ;;
        esac
    done < "$tmp/peer.out"
    grep -q '^ok ' "$tmp/peer.out" || bad "authpeer $1 printed no checks"
}

umask 077
mkfifo "$tmp/fifo"
mkdir "$tmp/dir"
head -c 32 /dev/urandom > "$tmp/key"
head -c 32 /dev/urandom > "$tmp/key2"
head -c 32 /dev/urandom > "$tmp/wrong"
head -c 8 /dev/urandom > "$tmp/short"
cp "$tmp/key" "$tmp/open"
chmod 600 "$tmp/key" "$tmp/key2" "$tmp/wrong" "$tmp/short"
chmod 644 "$tmp/open"

# ---- refusals at start (nothing is bound: the address is never used) ----
for addr in tcp:0.0.0.0:0 'tcp:[::]:0'; do
    "$QMCD" --foreground --listen "$addr" --ready-file "$tmp/r0" 2> "$tmp/err" > /dev/null
    rc=$?
    if [ $rc -ne 0 ] && [ ! -e "$tmp/r0" ] && grep -q -- '--auth-key' "$tmp/err" &&
        [ "$(wc -l < "$tmp/err")" -eq 1 ]; then ok; else
        bad "$addr without a key: rc $rc, $(cat "$tmp/err")"; fi
done
"$QMCD" --foreground --listen tcp::0 --listen tcp:127.0.0.9:0 --ready-file "$tmp/r1" \
    2> "$tmp/err" & p1=$!
wait_nonempty "$tmp/r1" $p1
if grep -q '^tcp:127.0.0.1:' "$tmp/r1" 2>/dev/null && grep -q '^tcp:127.0.0.9:' "$tmp/r1"; then
    ok; else bad "tcp::0 is not loopback or 127.0.0.9 refused: $(cat "$tmp/r1" "$tmp/err")"; fi
kill $p1 2>/dev/null; wait $p1 2>/dev/null
for k in open short fifo dir; do
    # -k: qmcd blocks SIGTERM before it reads the key.
    timeout -k 5 30 "$QMCD" --foreground --listen "unix:$tmp/x.sock" --auth-key "$tmp/$k" \
        --ready-file "$tmp/r2" 2> "$tmp/err" > /dev/null
    rc=$?
    release_fifo "$tmp/fifo"
    if [ $rc -eq 2 ] && [ ! -e "$tmp/r2" ] && [ ! -e "$tmp/x.sock" ] &&
        grep -q "auth-key $tmp/$k" "$tmp/err" && [ "$(wc -l < "$tmp/err")" -eq 1 ]; then ok; else
        bad "key file $k accepted: rc $rc, $(cat "$tmp/err")"; fi
done
grep -q "auth-key $tmp/dir: is a directory, not a regular file" "$tmp/err" && ok ||
    bad "a directory key: $(cat "$tmp/err")"
grep -q 'chmod 600' "$tmp/err" 2>/dev/null || true

# ---- the daemon with a key ----------------------------------------------------
# Wrong proofs from loopback slow its next ones down to 3 s apart at most
# (auth-delay-max-ms), a network holds 8 handshakes at once, and an
# unanswered challenge times out after 4 s (authpeer.py relies on these).
MAXF=3
PERNET=8
"$QMCD" --foreground --listen "unix:$tmp/qmcd.sock" --listen tcp:127.0.0.1:0 \
    --auth-key "$tmp/key" --auth-max-failures $MAXF --auth-lockout-ms 3600000 \
    --auth-delay-max-ms 3000 --max-preauth-connections-per-peer $PERNET \
    --handshake-timeout-ms 4000 \
    --ready-file "$tmp/ready" --log-level info 2> "$tmp/qmcd.log" &
pid=$!
wait_ready pid "$tmp/ready" "$tmp/qmcd.log"
UNIX="unix:$tmp/qmcd.sock"
TCP=$(grep '^tcp:' "$tmp/ready")

# expect_fail NAME PATTERN CMD...: exit 2, nothing on stdout, PATTERN on stderr.
expect_fail() {
    name=$1 pat=$2; shift 2
    "$@" > "$tmp/out" 2> "$tmp/err"
    rc=$?
    if [ $rc -eq 2 ] && [ ! -s "$tmp/out" ] && grep -q -- "$pat" "$tmp/err" &&
        [ "$(wc -l < "$tmp/err")" -eq 1 ]; then ok; else
        bad "$name: rc $rc, stderr: $(cat "$tmp/err")"; fi
}

expect_fail "no key over TCP" "requires authentication" "$QMC" ping --connect "$TCP" --count 1
expect_fail "wrong key over TCP" "not the server's" \
    "$QMC" ping --connect "$TCP" --count 1 --auth-key "$tmp/wrong"
expect_fail "client key file 0644" "chmod 600" \
    "$QMC" ping --connect "$TCP" --count 1 --auth-key "$tmp/open"
expect_fail "client key file a FIFO" "auth key $tmp/fifo: is a FIFO, not a regular file" \
    timeout -k 5 30 "$QMC" ping --connect "$TCP" --count 1 --auth-key "$tmp/fifo"
release_fifo "$tmp/fifo"
expect_fail "QMC_AUTH_KEY_FILE a FIFO" "is a FIFO" \
    env QMC_AUTH_KEY_FILE="$tmp/fifo" timeout -k 5 30 "$QMC" ping --connect "$TCP" --count 1
release_fifo "$tmp/fifo"
if "$QMC" ping --connect "$TCP" --count 1 --auth-key "$tmp/key" > /dev/null 2> "$tmp/err"; then
    ok; else bad "--auth-key: $(cat "$tmp/err")"; fi
if QMC_AUTH_KEY_FILE="$tmp/key" "$QMC" stats --connect "$TCP" > "$tmp/stats" 2> "$tmp/err" &&
    grep -q '^jobs_dropped ' "$tmp/stats" && grep -q '^auth_failures  *1$' "$tmp/stats"; then
    ok; else bad "QMC_AUTH_KEY_FILE / stats: $(cat "$tmp/err" "$tmp/stats")"; fi
# The Unix socket's permissions are its access control: no key asked.
if "$QMC" ping --connect "$UNIX" --count 1 > /dev/null 2> "$tmp/err"; then ok; else
    bad "unix socket without a key: $(cat "$tmp/err")"; fi
# A key over TCP to a server that asks for none is refused by the client.
"$QMCD" --foreground --listen tcp:127.0.0.1:0 --ready-file "$tmp/r3" 2> /dev/null & p3=$!
wait_nonempty "$tmp/r3" $p3
expect_fail "key to a keyless server" "did not ask for authentication" \
    "$QMC" ping --connect "$(grep '^tcp:' "$tmp/r3")" --count 1 --auth-key "$tmp/key"
kill $p3 2>/dev/null; wait $p3 2>/dev/null

# auth-unix 1: the Unix socket asks for the key too.
"$QMCD" --foreground --listen "unix:$tmp/u.sock" --auth-key "$tmp/key" --auth-unix 1 \
    --ready-file "$tmp/r4" 2> /dev/null & p4=$!
wait_nonempty "$tmp/r4" $p4
expect_fail "auth-unix 1 without a key" "requires authentication" \
    "$QMC" ping --connect "unix:$tmp/u.sock" --count 1
if "$QMC" ping --connect "unix:$tmp/u.sock" --count 1 --auth-key "$tmp/key" > /dev/null \
    2> "$tmp/err"; then ok; else bad "auth-unix 1 with the key: $(cat "$tmp/err")"; fi
kill $p4 2>/dev/null; wait $p4 2>/dev/null

# Remote output is still the same bytes as local.
for spec in "--seq sobol --dims 5 --scramble owen --seed 3 --count 5000" \
            "--seq halton --dims 3 --count 777 --start 9"; do
    # shellcheck disable=SC2086
    "$QMC" points $spec --format f64 > "$tmp/local" &&
    QMC_AUTH_KEY_FILE="$tmp/key" "$QMC" points $spec --format f64 --connect "$TCP" \
        > "$tmp/remote" 2> "$tmp/err"
    if [ -s "$tmp/local" ] && cmp -s "$tmp/local" "$tmp/remote"; then ok; else
        bad "authenticated remote points differ from local ($spec): $(cat "$tmp/err")"; fi
done

# ---- the independent peer -----------------------------------------------------
peer auth "$TCP" "$tmp/key" $MAXF "$UNIX" $PERNET
if grep -q 'authentication failed: wrong key (failure 3 from loopback' "$tmp/qmcd.log" &&
    grep -q 'proofs from loopback now wait 100 ms' "$tmp/qmcd.log" &&
    grep -q 'held back .* ms: loopback made ' "$tmp/qmcd.log"; then ok; else
    bad "the log does not record the failures and the delays"; fi
peer edges "$UNIX"

# ---- SIGHUP: the key file is checked again, and keys rotate -------------------
# wait_log N PATTERN: until the log has N lines matching (bounded).
wait_log() {
    i=0
    while [ "$(grep -c -- "$2" "$tmp/qmcd.log")" -lt "$1" ] && [ $i -lt 2000 ]; do
        i=$((i + 1)); sleep 0.01; done
}
chmod 644 "$tmp/key"
kill -HUP "$pid"
wait_log 1 'reload rejected'
chmod 600 "$tmp/key"
if grep -q "reload rejected.*auth-key $tmp/key: is readable" "$tmp/qmcd.log" &&
    "$QMC" ping --connect "$TCP" --count 1 --auth-key "$tmp/key" > /dev/null 2>&1; then
    ok; else bad "SIGHUP with a 0644 key: not refused, or the old key lost"; fi
# The key swapped for a FIFO: refused at once, and the daemon serves on
# with the old key (on main it froze until someone wrote to the FIFO).
mv "$tmp/key" "$tmp/key.saved"
mkfifo "$tmp/key"
kill -HUP "$pid"
wait_log 2 'reload rejected'
if grep -q "reload rejected.*auth-key $tmp/key: is a FIFO, not a regular file" "$tmp/qmcd.log"
then ok; else bad "SIGHUP with a FIFO key: $(tail -n 2 "$tmp/qmcd.log")"; fi
if timeout -k 5 30 "$QMC" ping --connect "$TCP" --count 1 --auth-key "$tmp/key.saved" \
    > /dev/null 2> "$tmp/err"; then ok
else bad "PING after SIGHUP with a FIFO key: $(cat "$tmp/err")"; fi
release_fifo "$tmp/key"
rm -f "$tmp/key"
mv "$tmp/key.saved" "$tmp/key"
cp "$tmp/key2" "$tmp/key"
kill -HUP "$pid"
wait_log 1 'configuration reloaded'
if "$QMC" ping --connect "$TCP" --count 1 --auth-key "$tmp/key2" > /dev/null 2>&1; then ok; else
    bad "the rotated key is not accepted after SIGHUP"; fi
expect_fail "the old key after rotation" "not the server's" \
    "$QMC" ping --connect "$TCP" --count 1 --auth-key "$tmp/wrong"

kill "$pid"
wait "$pid"
rc=$?
pid=
[ $rc -eq 0 ] && ok || bad "qmcd exit status $rc after SIGTERM"
finish
