#!/bin/sh
# bench_pixels_remote.sh - a pixel tile from qmcd against the same tile
# filled in-process, in one run (issue 20: over the shared-memory ring at
# least 0.5x the in-process rate).  Run by `make bench` as:
#   sh bench/bench_pixels_remote.sh BUILD_DIR
#
# Starts qmcd from BUILD_DIR (--threads 2, a Unix socket in a temporary
# directory, readiness from --ready-file), runs pixels-load against it
# (bench/pixels_load.c: in-process, ring with a copy into the caller's
# buffer, ring read in place, inline), prints its table and verdict
# (reported, never asserted) and writes BUILD_DIR/bench/pixels-remote.csv.
# The daemon is stopped by PID on exit; it listens on nothing but its
# socket in the temporary directory.
set -u

BUILD=${1:-build}
QMCD=$BUILD/qmcd
LOAD=$BUILD/bench/pixels-load
OUT=$BUILD/bench
for f in "$QMCD" "$LOAD"; do
    [ -x "$f" ] || { echo "bench_pixels_remote: $f is missing (make $f)" >&2; exit 1; }
done
mkdir -p "$OUT"
tmp=$(mktemp -d "${TMPDIR:-/tmp}/qmcd-pixels.XXXXXX")
qpid=""

# stop PID: SIGTERM, up to 3 s, then SIGKILL; only the process we started.
stop() {
    [ -n "$1" ] || return 0
    kill "$1" 2> /dev/null || return 0
    i=0
    while kill -0 "$1" 2> /dev/null && [ $i -lt 60 ]; do sleep 0.05; i=$((i + 1)); done
    kill -9 "$1" 2> /dev/null
    wait "$1" 2> /dev/null
    return 0
}
cleanup() {
    stop "$qpid"
    rm -rf "$tmp"
}
trap cleanup EXIT
trap 'exit 130' INT TERM HUP

"$QMCD" --foreground --threads 2 --listen "unix:$tmp/qmcd.sock" --log-level notice \
    --ready-file "$tmp/qmcd.ready" 2> "$tmp/qmcd.log" &
qpid=$!
i=0
while [ ! -e "$tmp/qmcd.ready" ]; do
    i=$((i + 1))
    if [ $i -ge 200 ] || ! kill -0 "$qpid" 2> /dev/null; then
        echo "bench_pixels_remote: qmcd not ready in 10 s: $(head -c 500 "$tmp/qmcd.log")" >&2
        exit 1
    fi
    sleep 0.05
done

echo "qmcd unix:$tmp/qmcd.sock (pid $qpid, --threads 2); $(nproc) CPUs"
timeout 300 "$LOAD" "unix:$tmp/qmcd.sock" "$OUT/pixels-remote.csv" ||
    { echo "bench_pixels_remote: pixels-load failed" >&2; exit 1; }
