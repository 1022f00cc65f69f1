#!/bin/sh
# `qmc stats --format prometheus` and `qmc stats --json` against a real
# daemon: the Prometheus text is read by a strict parser written apart from
# the C code (tests/e2e/promparse.py, which first proves on known-bad input
# that it refuses what it should); the JSON by Python's json module.  The
# numbers are checked against what the test did (37 PINGs, one POINTS of
# 1000 points, one job), the histogram against the daemon's own percentile
# entries (two derivations of one histogram), and every metric name against
# docs/OPERATIONS.md, where they are documented.
# Env: QMC, QMCD.  Prints "N passed, M failed".
set -u
: "${QMC:?QMC must name the qmc binary}"
: "${QMCD:?QMCD must name the qmcd binary}"
PY=/usr/bin/python3
HERE="$(cd "$(dirname "$0")" && pwd)"
TOP="$(cd "$HERE/../.." && pwd)"
. "$(dirname "$0")/lib.sh"

if "$PY" "$HERE/promparse.py" --selftest > "$tmp/self.out"; then ok
else bad "the Prometheus parser accepts bad input: $(cat "$tmp/self.out")"; fi

S="$tmp/qmcd.sock"
"$QMCD" --foreground --threads 1 --listen "unix:$S" --ready-file "$tmp/ready" 2> "$tmp/qmcd.log" &
D=$!
pids="$pids $D"
wait_file "$tmp/ready"
U="unix:$S"
"$QMC" ping --connect "$U" --count 37 > /dev/null || bad "ping failed"
"$QMC" points --seq sobol --dims 4 --count 1000 --format f64 --connect "$U" > /dev/null ||
    bad "points failed"
"$QMC" integrate --integrand genz-gaussian --dims 3 --method rqmc --n 1024 --reps 8 \
    --connect "$U" > /dev/null || bad "integrate failed"
"$QMC" stats --connect "$U" --format prometheus > "$tmp/prom.txt" || bad "stats --format prometheus failed"
"$QMC" stats --connect "$U" --json > "$tmp/stats.json" || bad "stats --json failed"
"$QMC" stats --connect "$U" --format json > "$tmp/stats2.json" || bad "stats --format json failed"
if "$QMC" stats --connect "$U" --format xml > "$tmp/xml.out" 2>&1; then bad "--format xml accepted"
elif [ "$(wc -l < "$tmp/xml.out")" -eq 1 ] && grep -q "format 'xml'" "$tmp/xml.out"; then ok
else bad "--format xml: $(cat "$tmp/xml.out")"; fi

if "$PY" "$HERE/promparse.py" "$tmp/prom.txt" > "$tmp/parsed.txt"; then ok
else bad "prometheus output refused: $(cat "$tmp/parsed.txt")"; fi

"$PY" - "$tmp/parsed.txt" "$tmp/stats.json" "$tmp/stats2.json" "$TOP/docs/OPERATIONS.md" <<'PYEOF' > "$tmp/check.out" 2>&1
import json, math, re, sys
parsed, js, js2, ops = sys.argv[1:5]
samples, fams = {}, {}
for line in open(parsed):
    if line.startswith("# family "):
        _, _, name, typ = line.split()
        fams[name] = typ
    else:
        key, v = line.rsplit(" ", 1)
        samples[key] = float(v)
st = json.load(open(js))          # strict: json raises on any error
json.load(open(js2))
def check(cond, what):
    print(("ok " if cond else "FAIL ") + what)
check(all(isinstance(v, int) and v >= 0 for v in st.values()), "json values are unsigned integers")
# what the test did (the pings: exactly 37 PING requests)
check(samples.get('qmcd_requests_total{type="PING"}') == 37, "37 PINGs counted")
check(samples.get('qmcd_requests_total{type="POINTS"}') == 1 and st["requests_POINTS"] == 1,
      "one POINTS request")
check(samples.get("qmcd_points_sent_total") == 1000 == st["points_sent"], "1000 points sent")
check(samples.get("qmcd_jobs_accepted_total") == 1 and samples.get("qmcd_jobs_done_total") == 1,
      "one job accepted and done")
check(fams.get("qmcd_connections_open") == "gauge" and fams.get("qmcd_jobs_open") == "gauge",
      "gauges typed gauge")
check(fams.get("qmcd_request_latency_seconds") == "histogram", "latency is a histogram")
# the isolation limits' counters (test_isolation.sh makes them move): typed,
# and still zero here, where no limit was reached
lim = ("refused_connections_per_peer", "out_buffer_waits", "refused_jobs_per_conn",
       "refused_jobs", "refused_cancels_per_conn", "refused_job_memory", "job_memory_waits")
check(all(fams.get("qmcd_%s_total" % k) == "counter" and samples.get("qmcd_%s_total" % k) == 0
          == st[k] for k in lim), "the isolation counters are typed counter and at 0")
check(fams.get("qmcd_job_memory_reserved_bytes") == "gauge" and
      st["job_memory_reserved_bytes"] == 0, "job_memory_reserved_bytes is a gauge, 0 when idle")
# the histogram and the daemon's percentile entries are two readings of
# one histogram: rank = ceil(q n); the p-quantile entry is the top of the
# fine bucket holding that rank, so every exported edge below it holds
# fewer than rank requests and every edge at or above it at least rank.
buckets = sorted((float(re.search(r'le="([^"]+)"', k).group(1)), v)
                 for k, v in samples.items() if k.startswith("qmcd_request_latency_seconds_bucket"))
n = samples["qmcd_request_latency_seconds_count"]
check(n >= 37 + 3, "latency count covers the requests (%d)" % n)
# --json was fetched second: it counts the requests since, the STATS that
# served the Prometheus text among them, whose latency is unknown (on a
# loaded machine it may be the slowest of all).  So the percentiles are
# checked against --json's own buckets (one snapshot), and the Prometheus
# buckets against those: never more, and short by at most the requests
# between the two fetches.
jb = sorted((float(k[len("latency_le_us_"):]) / 1e6, v) for k, v in st.items()
            if k.startswith("latency_le_us_"))
nj = st["latency_count"]
extra = nj - n
check(0 <= extra <= 2, "--json counts %d request(s) more than the Prometheus text" % extra)
jcount = dict((round(le * 1e6), c) for le, c in jb)
check(all(0 <= jcount.get(round(le * 1e6), -1) - c <= extra for le, c in buckets
          if not math.isinf(le)), "Prometheus buckets agree with --json's (within %d)" % extra)
for q, key in ((0.5, "latency_p50_us"), (0.99, "latency_p99_us")):
    rank = max(1, math.ceil(q * nj))
    p_s = st[key] / 1e6
    good = all((c < rank) if le < p_s - 1e-12 else (c >= rank) for le, c in jb)
    check(good, "buckets agree with %s = %d us" % (key, st[key]))
# (--json was fetched second: its sum holds the first STATS's latency too)
check(0 < samples["qmcd_request_latency_seconds_sum"] <= st["latency_sum_us"] / 1e6 + 1e-9,
      "_sum is latency_sum_us in seconds")
# the counters that did not move between the two fetches agree exactly
for k in ("points_sent", "jobs_accepted", "jobs_done", "malformed_frames", "config_reloads"):
    check(samples.get("qmcd_%s_total" % k) == st[k], "%s agrees with --json" % k)
# every family is documented
doc = open(ops).read()
for f in fams:
    check(re.search(r"`%s[`{]" % re.escape(f), doc) is not None,
          "%s documented in docs/OPERATIONS.md" % f)
PYEOF
n_ok=$(grep -c '^ok ' "$tmp/check.out")
n_bad=$(grep -c '^FAIL' "$tmp/check.out")
pass=$((pass + n_ok))
fail=$((fail + n_bad))
grep -v '^ok ' "$tmp/check.out"
[ "$n_ok" -gt 0 ] || bad "the metrics check printed nothing"
kill -TERM "$D"
wait "$D" || bad "qmcd: SIGTERM did not exit 0"
if grep -l -E "AddressSanitizer|LeakSanitizer|runtime error" "$tmp"/*.log; then
    bad "sanitizer report in the daemon log"
else ok; fi
finish
