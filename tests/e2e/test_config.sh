#!/bin/sh
# `qmcd --check-config`: a valid file exits 0 with one line on stdout; each
# kind of bad file or flag exits 2 with one line on stderr naming the file
# and line (or the flag) and nothing on stdout; checking binds nothing.
# systemd/qmcd.conf names every option qmcd has (tried uncommented, it is
# still valid), and qmcd.conf(5) documents them (test_install.sh).
# A FIFO, a directory or a device where the config or key file is
# expected is refused at once, naming what it is - by --check-config, at
# start, and on SIGHUP, where the running configuration stays (issue 22,
# finding 5).  Every qmcd here runs under `timeout` (-k: a started qmcd
# blocks SIGTERM), so that one waiting for a FIFO's writer fails the test
# instead of hanging it.  --ready-file in a sticky directory writes through
# no link another user planted under its temporary name.
# Env: QMCD, QMC.  Prints "N passed, M failed".
set -u
: "${QMCD:?QMCD must name the qmcd binary}"
: "${QMC:?QMC must name the qmc binary}"
HERE="$(cd "$(dirname "$0")" && pwd)"
TOP="$(cd "$HERE/../.." && pwd)"
EXAMPLE="$TOP/systemd/qmcd.conf"
. "$(dirname "$0")/lib.sh"

# expect_bad WHAT PATTERN ARGS...: exit 2, stdout empty, one stderr line
# matching PATTERN (grep -E).
expect_bad() {
    what=$1
    pat=$2
    shift 2
    timeout -k 5 30 "$QMCD" --check-config "$@" > "$tmp/out" 2> "$tmp/err"
    st=$?
    if [ $st -eq 2 ] && [ ! -s "$tmp/out" ] && [ "$(wc -l < "$tmp/err")" -eq 1 ] &&
        grep -Eq -- "$pat" "$tmp/err"; then ok
    else bad "$what: exit $st, stdout '$(cat "$tmp/out")', stderr '$(cat "$tmp/err")'"; fi
}

if "$QMCD" --check-config --config "$EXAMPLE" > "$tmp/out" 2> "$tmp/err" &&
    [ "$(wc -l < "$tmp/out")" -eq 1 ] && [ ! -s "$tmp/err" ]; then ok
else bad "the example config: $(cat "$tmp/out" "$tmp/err")"; fi

# Every #key = value line of the example, uncommented, is valid too.
sed 's/^#\([a-z-]* = \)/\1/' "$EXAMPLE" > "$tmp/uncommented.conf"
if "$QMCD" --check-config --config "$tmp/uncommented.conf" > /dev/null 2> "$tmp/err"; then ok
else bad "the example's commented settings: $(cat "$tmp/err")"; fi
# ... and names every option.
for k in $("$QMCD" --help | sed -n 's/^  --\([a-z-]*\) .*/\1/p') listen log-level ready-file foreground; do
    grep -Eq "^#?$k = " "$EXAMPLE" || bad "systemd/qmcd.conf does not show $k"
done
ok

# name | file contents (printf format) | the error it must give
while IFS='|' read -r name text pat; do
    # shellcheck disable=SC2059
    printf "$text" > "$tmp/$name.conf"
    expect_bad "$name" "^qmcd: $tmp/$name.conf:$pat" --config "$tmp/$name.conf"
done <<EOF
number|threads = 2\n# fine so far\nmax-points = lots\n|3: max-points: 'lots' is not a number
range|max-frame = 16G\n|1: max-frame: .* is outside 4096\.\.
zero|\n\nmax-connections = 0\n|3: max-connections: 0 is outside
unknown|log-level = info\nthreads = 1\nmax-pointz = 5\n|3: unknown key 'max-pointz'
noequals|threads 2\n|1: expected 'key = value'
listen|listen = ftp:example.org\n|1: listen: 'ftp:example.org' is neither
level|log-level = loud\n|1: log-level: 'loud' is not one of
foreground|foreground = maybe\n|1: foreground: 'maybe' is not yes or no
empty|ready-file =\n|1: ready-file: value is empty
nul|threads = 1\nthreads = 2\000\n|2: a NUL byte
suffix|max-points = 4T\n|1: max-points: '4T' is not a number
EOF
awk 'BEGIN { for (i = 0; i < 17; i++) printf "listen = unix:/tmp/x%d.sock\n", i }' > "$tmp/many.conf"
expect_bad "17 listeners" "many.conf:17: listen: more than 16" --config "$tmp/many.conf"
awk 'BEGIN { printf "threads = 1\n# "; for (i = 0; i < 1100; i++) printf "x"; printf "\n" }' > "$tmp/long.conf"
expect_bad "long line" "long.conf:2: line longer than 1022 bytes" --config "$tmp/long.conf"
expect_bad "missing file" "missing.conf: cannot open" --config "$tmp/missing.conf"
# flags are checked over the file, and name themselves
expect_bad "bad flag value" "^qmcd: --max-jobs: 0 is outside" --config "$EXAMPLE" --max-jobs 0
expect_bad "unknown flag" "^qmcd: unknown option '--bogus-flag'" --config "$EXAMPLE" --bogus-flag 1
# a valid check binds nothing and starts nothing
if "$QMCD" --check-config --config "$EXAMPLE" --listen "unix:$tmp/never.sock" > /dev/null &&
    [ ! -e "$tmp/never.sock" ]; then ok
else bad "--check-config created its listener"; fi

# ---- files that are not regular files ------------------------------------
printf 'threads = 1\n' > "$tmp/plain.conf"
mkfifo "$tmp/fifo.conf" "$tmp/fifo.key"
mkdir "$tmp/dir.conf"
expect_bad "a FIFO config" "^qmcd: $tmp/fifo.conf: is a FIFO, not a regular file" \
    --config "$tmp/fifo.conf"
expect_bad "a directory config" "^qmcd: $tmp/dir.conf: is a directory, not a regular file" \
    --config "$tmp/dir.conf"
expect_bad "a FIFO key" "^qmcd: auth-key $tmp/fifo.key: is a FIFO, not a regular file" \
    --config "$tmp/plain.conf" --auth-key "$tmp/fifo.key"
printf 'auth-key = %s\n' "$tmp/fifo.key" > "$tmp/fifokey.conf"
expect_bad "a FIFO key named in the file" "^qmcd: auth-key $tmp/fifo.key: is a FIFO" \
    --config "$tmp/fifokey.conf"
# A device: our own node with the numbers of the null device, as root (a
# test names no system path).
if [ "$(id -u)" -eq 0 ] && mknod -m 600 "$tmp/chr" c 1 3 2>/dev/null; then
    expect_bad "a device key" "^qmcd: auth-key $tmp/chr: is a character device" \
        --config "$tmp/plain.conf" --auth-key "$tmp/chr"
    expect_bad "a device config" "^qmcd: $tmp/chr: is a character device" --config "$tmp/chr"
else
    echo "skip: device files (needs root to make one)"
fi
release_fifo "$tmp/fifo.conf"; release_fifo "$tmp/fifo.key"
# At start (not --check-config), before and after the signals are blocked:
# exit 2, one line, nothing bound.
for how in "--config $tmp/fifo.conf" "--config $tmp/plain.conf --auth-key $tmp/fifo.key"; do
    # shellcheck disable=SC2086
    timeout -k 5 30 "$QMCD" --foreground $how --listen "unix:$tmp/start.sock" \
        --ready-file "$tmp/start.ready" > "$tmp/out" 2> "$tmp/err"
    st=$?
    release_fifo "$tmp/fifo.conf"; release_fifo "$tmp/fifo.key"
    if [ $st -eq 2 ] && [ "$(wc -l < "$tmp/err")" -eq 1 ] && grep -q 'is a FIFO' "$tmp/err" &&
        [ ! -e "$tmp/start.sock" ] && [ ! -e "$tmp/start.ready" ]; then ok
    else bad "start with $how: exit $st, $(cat "$tmp/err")"; fi
done
# SIGHUP after the config was swapped for a FIFO: the reload is refused
# with the reason, the daemon serves PING with its old settings (the
# max-points it reports), and a good file after that is taken again.
printf 'max-points = 1234\n' > "$tmp/live.conf"
if start live --config "$tmp/live.conf" --listen "unix:$tmp/live.sock"; then
    live=$pid
    # wait_log PATTERN: until the daemon's log has a line matching (bounded).
    wait_log() {
        i=0
        while ! grep -q -- "$1" "$tmp/live.log" && [ $i -lt 2000 ]; do i=$((i + 1)); sleep 0.01; done
    }
    mv "$tmp/live.conf" "$tmp/live.saved"
    mkfifo "$tmp/live.conf"
    kill -HUP "$live"
    wait_log 'reload rejected'
    if grep -q "reload rejected, keeping the running configuration: $tmp/live.conf: is a FIFO" \
        "$tmp/live.log"; then ok
    else bad "SIGHUP with a FIFO config: $(tail -n 3 "$tmp/live.log")"; fi
    timeout -k 5 30 "$QMC" ping --connect "unix:$tmp/live.sock" --count 1 > "$tmp/out" 2> "$tmp/err"
    st=$?
    if [ $st -eq 0 ] && grep -q '1234 points a request' "$tmp/out"; then ok
    else bad "PING after SIGHUP with a FIFO config: exit $st, $(cat "$tmp/out" "$tmp/err")"; fi
    release_fifo "$tmp/live.conf"
    rm -f "$tmp/live.conf"
    printf 'max-points = 4321\n' > "$tmp/live.conf"
    kill -HUP "$live"
    wait_log 'configuration reloaded'
    timeout -k 5 30 "$QMC" ping --connect "unix:$tmp/live.sock" --count 1 > "$tmp/out" 2>&1
    grep -q '4321 points a request' "$tmp/out" && ok ||
        bad "a good config after the FIFO was not taken: $(cat "$tmp/out")"
    kill "$live"
    if wait_exit "$live" 30; then wait "$live"; st=$?; forget "$live"; else st=stuck; fi
    [ "$st" = 0 ] && ok || bad "qmcd after the FIFO reload: exit status $st"
fi

# --ready-file in a sticky, world-writable directory: another user's link
# planted under the temporary name qmcd wrote the file under (READY.tmp on
# main) is not written through; the ready file is a file of its own.
if [ "$(id -u)" -eq 0 ]; then
    sticky=$tmp/sticky
    mkdir "$sticky"; chmod 1777 "$sticky"
    echo "victim" > "$tmp/victim"
    ln -s "$tmp/victim" "$sticky/r.ready.tmp"; chown -h 54321 "$sticky/r.ready.tmp"
    "$QMCD" --foreground --listen "unix:$tmp/r.sock" \
        --ready-file "$sticky/r.ready" 2> "$tmp/r.log" & rpid=$!
    pids="$pids $rpid"
    wait_nonempty "$sticky/r.ready" "$rpid"
    if [ "$(cat "$tmp/victim")" = victim ] && [ ! -L "$sticky/r.ready" ] &&
        grep -q "^pid $rpid\$" "$sticky/r.ready"; then ok
    else bad "--ready-file wrote through a planted link: victim '$(head -n 1 "$tmp/victim")', $(cat "$tmp/r.log")"; fi
    kill "$rpid"
    if wait_exit "$rpid" 30; then wait "$rpid"; forget "$rpid"; fi
else
    echo "skip: --ready-file in a sticky directory (needs root to give a link another owner)"
fi

# 1M suffixes and the file's settings are what a run would use
printf 'max-points = 1M\nthreads = 1\n' > "$tmp/good.conf"
if "$QMCD" --check-config --config "$tmp/good.conf" | grep -q "good.conf: configuration is valid"; then ok
else bad "a valid file was not reported valid"; fi
finish
