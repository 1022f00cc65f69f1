#!/bin/sh
# bench_daemon.sh - qmcd under load, against Redis measured in the same run
# (issue 4).  Run by `make bench` as: sh bench/bench_daemon.sh BUILD_DIR
#
# Starts qmcd from BUILD_DIR (--threads 2, a Unix socket in a temporary
# directory and loopback TCP port 0; readiness from --ready-file) and
# redis-server (loopback, a free port and a Unix socket, no persistence),
# then measures, REPS times interleaved, median reported:
#   (a) redis-benchmark -t ping_mbulk, 50 clients, -P 1 and -P 16;
#   (b) qmc-load PING and 1-point POINTS (sobol d=8 f64), 50 connections,
#       the same pipelining, over TCP (Redis's transport) and the Unix
#       socket (against redis-benchmark on Redis's Unix socket);
#   (c) one POINTS stream, sobol d=32, 2^22 points f64 (1 GiB), over the
#       Unix socket - inline (POINTS_CHUNK frames) and through a shared-
#       memory ring (qmc-load --bulk --shm: libqmcclient with 8 slots of
#       1 MiB, each chunk touched and released as a client would) - against
#       qmc_seq_fill in-process and against the raw AF_UNIX socketpair
#       ceiling, with qmcd's VmRSS before, at its peak during, and after
#       each stream.
# Each small-request run also reports the server's CPU time per request
# (utime + stime from /proc/PID/stat), which does not depend on how fast
# the load generator is.
# Prints a table and "met"/"MISSED" verdicts (reported, never asserted),
# writes BUILD_DIR/bench/daemon.csv, daemon-bulk.csv and daemon-rates.png (and .svg).
# Everything it starts is stopped by PID on exit; nothing listens beyond
# loopback; each run is capped in requests and seconds (about 90 s total).
# Env: BENCH_DAEMON_REPS (3), BENCH_DAEMON_N1 (150000 requests at -P 1),
# BENCH_DAEMON_N16 (1500000 at -P 16), BENCH_DAEMON_CAP_S (3 s per run).
set -u
. "$(dirname "$0")/lib.sh"

BUILD=${1:-build}
QMCD=$BUILD/qmcd
LOAD=$BUILD/bench/qmc-load
OUT=$BUILD/bench
REPS=${BENCH_DAEMON_REPS:-3}
N1=${BENCH_DAEMON_N1:-150000}
N16=${BENCH_DAEMON_N16:-1500000}
CAP_S=${BENCH_DAEMON_CAP_S:-3}
CLIENTS=50
OUT_BUFFER=4194304      # qmcd --out-buffer-bytes, named so RSS can be judged
BULK_DIMS=32
BULK_COUNT=4194304
SHM_SLOTS=8             # the ring of the shm bulk run: slots x slot bytes
SHM_SLOT_BYTES=1048576

bench_need bench_daemon "$QMCD" "$LOAD"
for c in redis-server redis-benchmark redis-cli; do
    command -v "$c" > /dev/null || { echo "bench_daemon: $c missing (sh build-aux/deps.sh bench)" >&2; exit 1; }
done
mkdir -p "$OUT"
tmp=$(mktemp -d "${TMPDIR:-/tmp}/qmcd-bench.XXXXXX")
qpid=""
rpid=""

cleanup() {
    bench_stop "$qpid"
    bench_stop "$rpid"
    rm -rf "$tmp"
}
trap cleanup EXIT
trap 'exit 130' INT TERM HUP

# ---- qmcd ------------------------------------------------------------------
QSOCK=$tmp/qmcd.sock
bench_start_qmcd bench_daemon "$tmp" "$QMCD" --threads 2 --listen "unix:$QSOCK" \
    --listen tcp:127.0.0.1:0 --out-buffer-bytes "$OUT_BUFFER" --log-level notice || exit 1
QTCP=$(grep '^tcp:' "$tmp/qmcd.ready" | head -n 1)
QUNIX=unix:$QSOCK

# ---- redis -----------------------------------------------------------------
# A free loopback port: a random one not listened on; retried if redis
# still loses the race for it.
RSOCK=$tmp/redis.sock
rport=""
for _ in 1 2 3 4 5 6 7 8; do
    p=$((20000 + $(od -An -N2 -tu2 /dev/urandom | tr -d ' ') % 40000))
    [ -n "$(ss -Hltn "sport = :$p" 2> /dev/null)" ] && continue
    redis-server --bind 127.0.0.1 --port "$p" --unixsocket "$RSOCK" --unixsocketperm 700 \
        --save '' --appendonly no --daemonize no --dir "$tmp" \
        --logfile "$tmp/redis.log" > /dev/null 2>&1 &
    rpid=$!
    if bench_wait_for 10 sh -c "[ \"\$(redis-cli -h 127.0.0.1 -p $p ping)\" = PONG ]" &&
        kill -0 "$rpid" 2> /dev/null; then
        rport=$p
        break
    fi
    bench_stop "$rpid"
    rpid=""
done
[ -n "$rport" ] || { echo "bench_daemon: redis-server did not start" >&2; exit 1; }

echo "qmcd $QTCP and $QUNIX (pid $qpid, --threads 2); redis-server $(redis-server --version |
    sed -n 's/.*v=\([^ ]*\).*/\1/p') 127.0.0.1:$rport and $RSOCK (pid $rpid); $(nproc) CPUs"
echo "$CLIENTS connections; requests per run: $N1 at pipeline 1, $N16 at pipeline 16 (at most" \
    "$CAP_S s per qmc-load run); $REPS interleaved repetitions, median by rate"

# ---- (a), (b): small requests -------------------------------------------------
raw=$tmp/raw.csv
: > "$raw"

TICK=$(getconf CLK_TCK)
# cpu_ticks PID: user + system CPU time of PID, in clock ticks.
cpu_ticks() { awk '{ print $14 + $15 }' "/proc/$1/stat"; }
# us_per_req TICKS0 TICKS1 REQUESTS: server CPU microseconds per request.
us_per_req() { awk -v a="$1" -v b="$2" -v n="$3" -v t="$TICK" \
    'BEGIN { if (n > 0) printf "%.2f", (b - a) * 1e6 / t / n; else print "n/a" }'; }

# kv KEY LINE: the value of KEY=... in a RESULT line.
kv() { printf '%s\n' "$2" | tr ' ' '\n' | sed -n "s/^$1=//p"; }

# run_redis TRANSPORT PIPELINE N
run_redis() {
    if [ "$1" = tcp ]; then where="-h 127.0.0.1 -p $rport"; else where="-s $RSOCK"; fi
    c0=$(cpu_ticks "$rpid")
    # shellcheck disable=SC2086
    line=$(timeout 120 redis-benchmark $where -c $CLIENTS -n "$3" -P "$2" -t ping_mbulk --csv \
        2> /dev/null | grep '^"PING_MBULK"' | tr -d '"')
    c1=$(cpu_ticks "$rpid")
    # test,rps,avg,min,p50,p95,p99,max (milliseconds)
    rate=$(echo "$line" | cut -d, -f2)
    p50=$(echo "$line" | awk -F, '{printf "%.1f", $5 * 1000}')
    p99=$(echo "$line" | awk -F, '{printf "%.1f", $7 * 1000}')
    [ -n "$rate" ] || { rate=0; p50=n/a; p99=n/a; }
    echo "redis,$1,ping,$2,$rate,$p50,$p99,n/a,0,$(us_per_req "$c0" "$c1" "$3")" >> "$raw"
}

# run_qmcd TRANSPORT REQUEST PIPELINE N
run_qmcd() {
    if [ "$1" = tcp ]; then ep=$QTCP; else ep=$QUNIX; fi
    c0=$(cpu_ticks "$qpid")
    res=$(timeout 60 "$LOAD" --connect "$ep" --clients $CLIENTS --requests "$4" --seconds "$CAP_S" \
        --pipeline "$3" --mix "$2=1" --timeout 20 2> "$tmp/load.err" | grep '^RESULT')
    c1=$(cpu_ticks "$qpid")
    if [ -z "$res" ]; then
        echo "bench_daemon: qmc-load $1 $2 P$3 failed: $(head -c 300 "$tmp/load.err")" >&2
        echo "qmcd,$1,$2,$3,0,n/a,n/a,n/a,1,n/a" >> "$raw"
        return
    fi
    printf 'qmcd,%s,%s,%s,%s,%.1f,%.1f,%.1f,%s,%s\n' "$1" "$2" "$3" "$(kv rate "$res")" \
        "$(kv p50_us "$res")" "$(kv p99_us "$res")" "$(kv p999_us "$res")" \
        "$(kv errors "$res")" "$(us_per_req "$c0" "$c1" "$(kv requests "$res")")" >> "$raw"
    setup_ms=$(kv setup_ms "$res")
}

setup_ms=""
rep=1
while [ $rep -le "$REPS" ]; do
    printf 'repetition %s/%s ...' "$rep" "$REPS"
    for P in 1 16; do
        if [ $P = 1 ]; then N=$N1; else N=$N16; fi
        for tr in tcp unix; do
            run_redis $tr $P "$N"
            run_qmcd $tr ping $P "$N"
            run_qmcd $tr points $P "$N"
        done
    done
    echo " done"
    rep=$((rep + 1))
done

# Median row by rate for each (server, transport, request, pipeline).
CSV=$OUT/daemon.csv
echo "server,transport,request,pipeline,clients,rate_per_s,p50_us,p99_us,p999_us,errors,server_cpu_us_per_req" > "$CSV"
sort -t, -k1,1 -k2,2 -k3,3 -k4,4n -k5,5g "$raw" | awk -F, -v C=$CLIENTS '
    { key = $1 "," $2 "," $3 "," $4; n[key]++; row[key, n[key]] = $0; if (!(key in seen)) { seen[key] = 1; order[++k] = key } }
    END { for (i = 1; i <= k; i++) { key = order[i]; m = int((n[key] + 1) / 2); split(row[key, m], f, ",");
          printf "%s,%s,%s,%s,%d,%.0f,%s,%s,%s,%s,%s\n", f[1], f[2], f[3], f[4], C, f[5], f[6], f[7], f[8], f[9], f[10] } }' >> "$CSV"

# get SERVER TRANSPORT REQUEST PIPELINE FIELD(6 rate, 7 p50, 8 p99, 9 p99.9, 10 errors,
#     11 server CPU us/request)
get() { awk -F, -v s="$1" -v t="$2" -v r="$3" -v p="$4" -v f="$5" \
    '$1 == s && $2 == t && $3 == r && $4 == p { print $f }' "$CSV"; }
ratio() { awk -v a="$1" -v b="$2" 'BEGIN { if (b > 0) printf "%.2f", a / b; else print "n/a" }'; }

echo
echo "Small requests, $CLIENTS connections, rate in requests/s, latency in microseconds"
echo "(redis-benchmark reports no p99.9); ratio = qmcd rate / Redis PING rate, same transport"
echo "and pipelining; cpu/req = the server's CPU microseconds per request."
printf '%-6s %3s %-7s %-7s %10s %9s %9s %9s %7s %8s %8s\n' transp P server request rate p50 p99 p99.9 errors cpu/req ratio
for tr in tcp unix; do
    for P in 1 16; do
        rr=$(get redis $tr ping $P 6)
        for sr in "redis ping" "qmcd ping" "qmcd points"; do
            # shellcheck disable=SC2086
            set -- $sr
            r=$(get "$1" $tr "$2" $P 6)
            printf '%-6s %3s %-7s %-7s %10s %9s %9s %9s %7s %8s %8s\n' $tr $P "$1" "$2" "$r" \
                "$(get "$1" $tr "$2" $P 7)" "$(get "$1" $tr "$2" $P 8)" "$(get "$1" $tr "$2" $P 9)" \
                "$(get "$1" $tr "$2" $P 10)" "$(get "$1" $tr "$2" $P 11)" "$([ "$1" = qmcd ] && echo "$(ratio "$r" "$rr")x" || echo -)"
        done
    done
done
[ -n "$setup_ms" ] && echo "(qmc-load: $CLIENTS connections + HELLO took $setup_ms ms in the last run)"

# Chart: rates per scenario, log scale.
DAT=$OUT/daemon-rates.dat
{
    echo "scenario redis-ping qmcd-ping qmcd-points"
    for tr in tcp unix; do for P in 1 16; do
        echo "$tr-P$P $(get redis $tr ping $P 6) $(get qmcd $tr ping $P 6) $(get qmcd $tr points $P 6)"
    done; done
} > "$DAT"
if command -v gnuplot > /dev/null; then
    gnuplot -e "dat='$DAT'; png='$OUT/daemon-rates.png'" bench/daemon_rates.gp &&
        gnuplot -e "dat='$DAT'; svg='$OUT/daemon-rates.svg'" bench/daemon_rates.gp &&
        echo "charts: $OUT/daemon-rates.png, $OUT/daemon-rates.svg"
fi

# ---- (c): bulk ---------------------------------------------------------------------
echo
echo "Bulk: one POINTS stream, sobol d=$BULK_DIMS, $BULK_COUNT points, f64" \
    "($((BULK_COUNT * BULK_DIMS * 8 / 1048576)) MiB), median of 5"
inproc=$("$LOAD" --inprocess --dims $BULK_DIMS --count $BULK_COUNT --repeat 5 | grep '^RESULT')
ceil=$("$LOAD" --unix-ceiling --dims $BULK_DIMS --count $BULK_COUNT --repeat 5 | grep '^RESULT')
bulk=$(timeout 60 "$LOAD" --bulk --connect "$QUNIX" --dims $BULK_DIMS --count $BULK_COUNT --repeat 5 \
    --rss-pid "$qpid" --timeout 30 2> "$tmp/bulk.err" | grep '^RESULT')
[ -n "$bulk" ] || echo "bench_daemon: bulk failed: $(head -c 300 "$tmp/bulk.err")" >&2
shm=$(timeout 60 "$LOAD" --bulk --shm --slots $SHM_SLOTS --slot-bytes $SHM_SLOT_BYTES \
    --connect "$QUNIX" --dims $BULK_DIMS --count $BULK_COUNT --repeat 5 --rss-pid "$qpid" \
    --timeout 30 2> "$tmp/shm.err" | grep '^RESULT')
[ -n "$shm" ] || echo "bench_daemon: bulk --shm failed: $(head -c 300 "$tmp/shm.err")" >&2
BCSV=$OUT/daemon-bulk.csv
echo "what,mb_per_s,points_per_s,seconds,rss_before_kib,rss_peak_kib,rss_after_kib" > "$BCSV"
for r in "$inproc" "$ceil" "$bulk" "$shm"; do
    [ -n "$r" ] && echo "$(kv mode "$r"),$(kv mbps "$r"),$(kv points_per_s "$r"),$(kv seconds "$r")," \
        "$(kv rss_before_kib "$r"),$(kv rss_peak_kib "$r"),$(kv rss_after_kib "$r")" |
        tr -d ' ' >> "$BCSV"
done
m_in=$(kv mbps "$inproc")
m_ceil=$(kv mbps "$ceil")
m_bulk=$(kv mbps "$bulk")
m_shm=$(kv mbps "$shm")
rss0=$(kv rss_before_kib "$bulk")
rssp=$(kv rss_peak_kib "$bulk")
rss1=$(kv rss_after_kib "$bulk")
srss0=$(kv rss_before_kib "$shm")
srssp=$(kv rss_peak_kib "$shm")
srss1=$(kv rss_after_kib "$shm")
RING_KIB=$((SHM_SLOTS * SHM_SLOT_BYTES / 1024))
printf '  %-44s %10s MB/s %12s points/s\n' "in-process qmc_seq_fill (1 MiB chunks)" "$m_in" "$(kv points_per_s "$inproc")"
printf '  %-44s %10s MB/s   (no generation: the transport bound)\n' "AF_UNIX socketpair, 1 MiB sends" "$m_ceil"
printf '  %-44s %10s MB/s %12s points/s\n' "qmcd over its Unix socket, inline chunks" "$m_bulk" "$(kv points_per_s "$bulk")"
printf '  %-44s %10s MB/s %12s points/s\n' "qmcd over its Unix socket, shm ring $SHM_SLOTS x $((SHM_SLOT_BYTES / 1024)) KiB" "$m_shm" "$(kv points_per_s "$shm")"
growth=$(( ${rssp:-0} - ${rss0:-0} ))
sgrowth=$(( ${srssp:-0} - ${srss0:-0} ))
echo "  qmcd VmRSS, inline: before $rss0 KiB, peak during $rssp KiB (+$growth KiB), after $rss1 KiB;" \
    "out-buffer-bytes $((OUT_BUFFER / 1024)) KiB"
echo "  qmcd VmRSS, shm:    before $srss0 KiB, peak during $srssp KiB (+$sgrowth KiB), after $srss1 KiB;" \
    "the client's ring, mapped: $RING_KIB KiB"

# ---- verdicts ---------------------------------------------------------------------
# verdict TEXT RATIO TARGET
verdict() {
    v=$(awk -v r="$2" -v t="$3" 'BEGIN { print (r != "n/a" && r + 0 >= t) ? "met" : "MISSED" }')
    printf '  %-46s %7sx  (target >= %sx: %s)\n' "$1" "$2" "$3" "$v"
}
echo
echo "Targets (issue 4), this run:"
for tr in tcp unix; do
    for P in 1 16; do
        rr=$(get redis $tr ping $P 6)
        verdict "qmcd PING / redis PING, $tr, P=$P" "$(ratio "$(get qmcd $tr ping $P 6)" "$rr")" 1.0
        verdict "qmcd POINTS(1 pt) / redis PING, $tr, P=$P" "$(ratio "$(get qmcd $tr points $P 6)" "$rr")" 1.0
    done
done
verdict "bulk over unix, shm ring / in-process fill" "$(ratio "$m_shm" "$m_in")" 0.5
echo "  (for reference: inline / in-process $(ratio "$m_bulk" "$m_in")x; inline / socketpair" \
    "ceiling $(ratio "$m_bulk" "$m_ceil")x; ceiling / in-process $(ratio "$m_ceil" "$m_in")x;" \
    "shm / inline $(ratio "$m_shm" "$m_bulk")x)"
# "Near the output buffer": the peak grows by at most twice out-buffer-bytes
# (the buffer, plus the copy made while it doubles to its cap).
if [ -n "$rssp" ] && [ "$growth" -le $((2 * OUT_BUFFER / 1024)) ]; then v=met; else v=MISSED; fi
printf '  %-46s %7s KiB (target <= 2 x out-buffer-bytes = %s KiB: %s)\n' \
    "qmcd RSS growth during the 1 GiB stream" "$growth" "$((2 * OUT_BUFFER / 1024))" "$v"
# Through the ring the daemon's own memory should not grow: what it gains
# is the client's ring, mapped (shared pages the client allocated).
own=$((sgrowth - RING_KIB))
if [ -n "$srssp" ] && [ "$own" -le $((2 * OUT_BUFFER / 1024)) ]; then v=met; else v=MISSED; fi
printf '  %-46s %7s KiB (target <= 2 x out-buffer-bytes = %s KiB: %s)\n' \
    "qmcd RSS growth, shm stream, less its ring" "$own" "$((2 * OUT_BUFFER / 1024))" "$v"
echo "csv: $CSV $BCSV"
