# bench/lib.sh - what the benchmark scripts that run qmcd share
# (bench_daemon.sh, bench_pixels_remote.sh): checking for the programs,
# stopping what they started by PID, polling, and starting qmcd on a
# ready file.  Sourced, never run:
#     . "$(dirname "$0")/lib.sh"
# POSIX sh.  Must not: signal a process it was not given the PID of, or
# make qmcd listen anywhere the caller did not name.

# bench_need NAME FILE...: exits 1, after "NAME: FILE is missing (make
# FILE)" on stderr, unless every FILE is an executable.
bench_need() {
    name=$1
    shift
    for f in "$@"; do
        [ -x "$f" ] || { echo "$name: $f is missing (make $f)" >&2; exit 1; }
    done
}

# bench_stop PID: SIGTERM, up to 3 s, then SIGKILL; only the process named
# (an empty PID is nothing to stop).
bench_stop() {
    [ -n "$1" ] || return 0
    kill "$1" 2> /dev/null || return 0
    i=0
    while kill -0 "$1" 2> /dev/null && [ $i -lt 60 ]; do sleep 0.05; i=$((i + 1)); done
    kill -9 "$1" 2> /dev/null
    wait "$1" 2> /dev/null
    return 0
}

# bench_wait_for SECONDS CMD...: polls CMD every 50 ms until it succeeds;
# 1 when SECONDS pass first.
bench_wait_for() {
    lim=$(($1 * 20))
    shift
    i=0
    while ! "$@" > /dev/null 2>&1; do
        i=$((i + 1))
        [ $i -ge $lim ] && return 1
        sleep 0.05
    done
}

# bench_start_qmcd NAME DIR QMCD ARGS...: starts QMCD --foreground ARGS
# with its ready file DIR/qmcd.ready and its log DIR/qmcd.log, sets qpid,
# and waits up to 10 s for the ready file.  1, after "NAME: qmcd not
# ready in 10 s: <the log's start>" on stderr, when it does not come or
# qmcd exits first.
bench_start_qmcd() {
    name=$1
    dir=$2
    bin=$3
    shift 3
    "$bin" --foreground "$@" --ready-file "$dir/qmcd.ready" 2> "$dir/qmcd.log" &
    qpid=$!
    i=0
    while [ ! -e "$dir/qmcd.ready" ]; do
        i=$((i + 1))
        if [ $i -ge 200 ] || ! kill -0 "$qpid" 2> /dev/null; then
            echo "$name: qmcd not ready in 10 s: $(head -c 500 "$dir/qmcd.log")" >&2
            return 1
        fi
        sleep 0.05
    done
}
