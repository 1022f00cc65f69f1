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
. "$(dirname "$0")/lib.sh"

BUILD=${1:-build}
QMCD=$BUILD/qmcd
LOAD=$BUILD/bench/pixels-load
OUT=$BUILD/bench
bench_need bench_pixels_remote "$QMCD" "$LOAD"
mkdir -p "$OUT"
tmp=$(mktemp -d "${TMPDIR:-/tmp}/qmcd-pixels.XXXXXX")
qpid=""

cleanup() {
    bench_stop "$qpid"
    rm -rf "$tmp"
}
trap cleanup EXIT
trap 'exit 130' INT TERM HUP

bench_start_qmcd bench_pixels_remote "$tmp" "$QMCD" --threads 2 --listen "unix:$tmp/qmcd.sock" \
    --log-level notice || exit 1

echo "qmcd unix:$tmp/qmcd.sock (pid $qpid, --threads 2); $(nproc) CPUs"
timeout 300 "$LOAD" "unix:$tmp/qmcd.sock" "$OUT/pixels-remote.csv" ||
    { echo "bench_pixels_remote: pixels-load failed" >&2; exit 1; }
