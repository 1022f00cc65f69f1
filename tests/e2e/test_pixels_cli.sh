#!/bin/sh
# test_pixels_cli.sh - `qmc pixels` end to end, in-process and against a
# real daemon (Unix socket and TCP, started on a scratch socket and port 0,
# stopped by PID).
#
#   1. pbrt-v4's own values (tests/vectors/pixels_pbrt.txt, made by pbrt's
#      code outside this tree): a spread of them through the CLI, as u32,
#      in-process and remote;
#   2. formats and layout, checked in Python: f64 is u32 / 2^32, f32 is
#      floor(u32 / 2^8) / 2^24, and a tile is the same bytes as its place
#      in a larger tile (pixel rows y, then x; samples; dims);
#   3. remote == in-process byte for byte for each sampler and format,
#      over Unix (a tile large enough for the shared-memory ring) and TCP,
#      and through a daemon whose max-points makes the client split tiles;
#   4. the distributed split: node k of K renders samples [k*N/K,
#      (k+1)*N/K) of each pixel (some nodes local, some remote); Python
#      reassembles them per pixel into one request's bytes;
#   5. bad input: one line naming the problem, exit 2, no output, the same
#      line in-process and remote; the daemon's max-seq-memory refusal;
#   6. the daemon answers bad PIXELS requests (sent raw, past the CLI's
#      checks) with one-line ERRORs while it streams a tile to another
#      client, and a client that negotiated version 3 gets QMC_ENOTSUP
#      (tests/e2e/pixelpeer.py on qmcpeer.py's independent codec);
#   7. --out: the same bytes as stdout; nothing left behind on error;
#   8. STATS counts the requests, the samples sent and the ring attached;
#   9. SIGTERM while a client holds a tile half read: the stream is cut at
#      shutdown-timeout-ms (no END), and the daemon exits 0.
# Env: QMC, QMCD (binaries).  Prints "N passed, M failed".
set -u
: "${QMC:?QMC must name the qmc binary}"
: "${QMCD:?QMCD must name the qmcd binary}"
PY=/usr/bin/python3
HERE="$(cd "$(dirname "$0")" && pwd)"
VECTORS="$HERE/../vectors/pixels_pbrt.txt"
. "$(dirname "$0")/lib.sh"
# Daemons in $pid and $pid2 get SIGTERM at exit.
pid=
pid2=
term_vars="pid pid2"

# ---- daemons ------------------------------------------------------------------
"$QMCD" --foreground --listen "unix:$tmp/qmcd.sock" --listen tcp:127.0.0.1:0 \
    --shutdown-timeout-ms 1000 --ready-file "$tmp/ready" 2> "$tmp/qmcd.log" &
pid=$!
wait_ready pid "$tmp/ready" "$tmp/qmcd.log"
UNIX="unix:$tmp/qmcd.sock"
TCP=$(grep '^tcp:' "$tmp/ready" | head -n 1)
# A daemon that takes 1000 samples a request (the client cuts tiles) and
# holds at most 1 MiB of sampler tables.
"$QMCD" --foreground --listen "unix:$tmp/small.sock" --max-points 1000 --max-seq-memory 1M \
    --ready-file "$tmp/ready2" 2> "$tmp/qmcd2.log" &
pid2=$!
wait_ready pid2 "$tmp/ready2" "$tmp/qmcd2.log"
SMALL="unix:$tmp/small.sock"

# ---- 1. pbrt-v4's values ----------------------------------------------------------
# Every 61st vector of the file (about 100, all three samplers, odd and even
# log2(spp), seeds, pixels past 65535), each asked for as a one-pixel,
# one-sample tile of DIM + 2 values; values DIM and DIM + 1 (DIM alone for
# sobol lines) must be pbrt's.  In-process, and remote over Unix and TCP
# where a sample fits a chunk (the daemon refuses one of more than 1 MiB:
# DIM 1048576 is asked for in-process only).
if "$PY" - "$QMC" "$VECTORS" "$UNIX" "$TCP" > "$tmp/pbrt.out" 2>&1 <<'PYEOF'
import struct, subprocess, sys
qmc, path, unix, tcp = sys.argv[1:5]
lines = [l.split() for l in open(path) if l.strip() and not l.startswith("#")]
picked = lines[::61]
seen, bad = set(), []
for i, f in enumerate(picked):
    sampler, spp, w, h, seed, x, y, sample, dim = f[:9]
    want = [int(v) for v in f[9:]]
    args = [qmc, "pixels", "--sampler", sampler, "--resolution", w + "," + h, "--spp", spp,
            "--seed", seed, "--tile", "%s,%s,1,1" % (x, y), "--samples", sample + ":1",
            "--dims", str(int(dim) + 2), "--format", "u32"]
    remote = [["--connect", unix if i % 2 else tcp]] if (int(dim) + 2) * 4 <= 1 << 20 else []
    for where in [[]] + remote:
        r = subprocess.run(args + where, capture_output=True)
        got = list(struct.unpack("<%dI" % (len(r.stdout) // 4), r.stdout))
        if r.returncode or got[int(dim):int(dim) + len(want)] != want:
            bad.append("%s %s: %r -> %r %s" % (" ".join(f), where, want, got,
                                              r.stderr.decode().strip()))
    seen.add(sampler)
print("%d vectors, samplers %s" % (len(picked), sorted(seen)))
for b in bad[:5]:
    print("mismatch:", b)
sys.exit(1 if bad or len(seen) != 3 or len(picked) < 90 else 0)
PYEOF
then ok; else bad "pbrt-v4 vectors: $(tr '\n' ' ' < "$tmp/pbrt.out" | head -c 600)"; fi

# ---- 2. formats and layout ----------------------------------------------------------
# For each sampler, the 8x8 tile at (4,2) and the 3x2 tile at (7,5) with
# samples 2..5, as u32, f32 and f64.
for s in zsobol padded-sobol sobol; do
    base="--sampler $s --resolution 37,23 --spp 8 --seed 11 --frame 3 --dims 5"
    for f in u32 f32 f64; do
        # shellcheck disable=SC2086
        "$QMC" pixels $base --tile 4,2,8,8 --format $f > "$tmp/big.$s.$f" 2> "$tmp/err" ||
            bad "$s big $f: $(cat "$tmp/err")"
        # shellcheck disable=SC2086
        "$QMC" pixels $base --tile 7,5,3,2 --samples 2:4 --format $f > "$tmp/sub.$s.$f" \
            2> "$tmp/err" || bad "$s sub $f: $(cat "$tmp/err")"
    done
    if "$PY" - "$tmp" "$s" > "$tmp/why" 2>&1 <<'PYEOF'
import sys, numpy as np
d, s = sys.argv[1], sys.argv[2]
def load(name, fmt, shape):
    a = np.fromfile("%s/%s.%s.%s" % (d, name, s, fmt), dtype={"u32": "<u4", "f32": "<f4", "f64": "<f8"}[fmt])
    assert a.size == np.prod(shape), "%s %s: %d values, want %d" % (name, fmt, a.size, np.prod(shape))
    return a.reshape(shape)
for name, shape in (("big", (8, 8, 8, 5)), ("sub", (2, 3, 4, 5))):
    u = load(name, "u32", shape).astype(np.float64)
    f64 = load(name, "f64", shape)
    f32 = load(name, "f32", shape).astype(np.float64)
    assert np.array_equal(f64, u / 2.0**32), name + ": f64 != u32 / 2^32"
    assert np.array_equal(f32, np.floor(u / 2.0**8) / 2.0**24), name + ": f32 != floor(u32/2^8)/2^24"
    assert f32.max() < 1.0 and f64.max() < 1.0, name + ": a value of 1.0"
# rows y 5..6, columns x 7..9, samples 2..5 of the big tile at (4, 2)
big, sub = load("big", "u32", (8, 8, 8, 5)), load("sub", "u32", (2, 3, 4, 5))
assert np.array_equal(big[3:5, 3:6, 2:6, :], sub), "the sub-tile is not its place in the big one"
# scrambled values look like 32-bit hashes, not a constant or a counter
# (sobol's dims 0 and 1 place the sample in the image: not scrambled)
rest = big[..., 2:]
assert len(np.unique(rest)) > 0.99 * rest.size, "repeated values"
PYEOF
    then ok; else bad "$s formats/layout: $(tail -n 2 "$tmp/why" | tr '\n' ' ')"; fi
done

# ---- 3. remote == in-process --------------------------------------------------------
# same_out NAME ENDPOINT ARGS...: remote stdout and exit == in-process.
same_out() {
    name=$1 ep=$2
    shift 2
    "$QMC" pixels "$@" > "$tmp/local.out" 2> "$tmp/local.err"
    lrc=$?
    "$QMC" pixels "$@" --connect "$ep" > "$tmp/remote.out" 2> "$tmp/remote.err"
    rrc=$?
    if [ $lrc -eq 0 ] && [ $rrc -eq 0 ] && [ -s "$tmp/local.out" ] &&
       cmp -s "$tmp/local.out" "$tmp/remote.out"; then ok
    else bad "$name: remote differs (exit $lrc local, $rrc remote): $(head -c 300 "$tmp/remote.err")"; fi
}
n=0
for s in zsobol padded-sobol sobol; do
    for f in u32 f32 f64; do
        n=$((n + 1))
        for ep in "$UNIX" "$TCP" "$SMALL"; do
            same_out "$s $f via $ep" "$ep" --sampler $s --resolution 300,200 --spp 16 \
                --seed $n --frame $((n % 3)) --tile 17,33,40,9 --samples 3:11 --dims 6 --format $f
        done
    done
    # 64 x 64 pixels x 16 samples x 8 dims of f32: 2 MiB, more than a chunk,
    # so over Unix the samples come through the shared-memory ring.
    same_out "$s large tile via Unix" "$UNIX" --sampler $s --resolution 1920,1080 --spp 16 \
        --tile 1856,1016,64,64 --dims 8
    same_out "$s large tile via TCP" "$TCP" --sampler $s --resolution 1920,1080 --spp 16 \
        --tile 0,0,64,64 --dims 8 --seed 5
done
# A sample of 1000 dims through the 1000-sample daemon: pieces of pixels.
same_out "sobol 1000 dims via the small daemon" "$SMALL" --sampler sobol --resolution 8,8 \
    --spp 64 --tile 1,1,5,3 --dims 1000 --format u32
# One pixel of 4096 samples: pieces of one pixel's samples.
same_out "zsobol 4096 samples of one pixel, split" "$SMALL" --sampler zsobol \
    --resolution 70000,3 --spp 4096 --tile 69999,2,1,1 --dims 3 --format f64

# ---- 4. the distributed split -----------------------------------------------------
# split SAMPLER SPP K: node k of K renders --samples k*SPP/K:SPP/K (node 0
# in-process, the others over Unix, TCP, Unix, ...); Python interleaves
# the nodes' samples per pixel and must get one request's bytes.
split() {
    s=$1 spp=$2 K=$3
    args="--sampler $s --resolution 640,480 --spp $spp --seed 3 --tile 100,200,24,16 --dims 7"
    # shellcheck disable=SC2086
    "$QMC" pixels $args --format u32 > "$tmp/whole" 2> "$tmp/err" ||
        { bad "split $s: the whole tile: $(cat "$tmp/err")"; return; }
    k=0
    while [ $k -lt "$K" ]; do
        case $((k % 3)) in 0) where="" ;; 1) where="--connect $UNIX" ;; *) where="--connect $TCP" ;; esac
        # shellcheck disable=SC2086
        "$QMC" pixels $args --format u32 --samples $((k * spp / K)):$((spp / K)) $where \
            > "$tmp/node.$k" 2> "$tmp/err" || bad "split $s node $k: $(cat "$tmp/err")"
        k=$((k + 1))
    done
    if "$PY" - "$tmp" "$K" "$spp" > "$tmp/why" 2>&1 <<'PYEOF'
import sys
d, K, spp = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
pixels, dims = 24 * 16, 7
per = spp // K                 # samples each node renders per pixel
sample = dims * 4              # bytes of one sample (u32 values)
nodes = [open("%s/node.%d" % (d, k), "rb").read() for k in range(K)]
for k, b in enumerate(nodes):
    assert len(b) == pixels * per * sample, "node %d: %d bytes" % (k, len(b))
# Per pixel: node 0's samples, then node 1's, ...: the order of one render.
out = bytearray()
for p in range(pixels):
    for b in nodes:
        out += b[p * per * sample:(p + 1) * per * sample]
whole = open(d + "/whole", "rb").read()
assert len(whole) == pixels * spp * sample, "whole: %d bytes" % len(whole)
assert bytes(out) == whole, "reassembled nodes differ from one request"
PYEOF
    then ok; else bad "split $s spp $spp over $K nodes: $(tail -n 1 "$tmp/why")"; fi
}
split zsobol 64 4
split padded-sobol 32 8
split sobol 48 3

# ---- 5. bad input ----------------------------------------------------------------------
# expect_fail NAME PATTERN ARGS...: exit 2, one "qmc: " line on stderr
# matching PATTERN, no stdout; remote over Unix too, with the same line.
expect_fail() {
    name=$1 pat=$2
    shift 2
    "$QMC" pixels "$@" > "$tmp/out" 2> "$tmp/err" < /dev/null
    rc=$?
    lines=$(wc -l < "$tmp/err")
    if [ "$rc" -eq 2 ] && [ "$lines" -eq 1 ] && [ ! -s "$tmp/out" ] &&
       grep -q '^qmc: ' "$tmp/err" && grep -q -- "$pat" "$tmp/err"; then ok
    else bad "$name: rc=$rc, $lines stderr lines '$(cat "$tmp/err")', $(wc -c < "$tmp/out") stdout bytes"; fi
    "$QMC" pixels "$@" --connect "$UNIX" > "$tmp/rout" 2> "$tmp/rerr" < /dev/null
    rrc=$?
    if [ "$rrc" -eq 2 ] && [ ! -s "$tmp/rout" ] && cmp -s "$tmp/err" "$tmp/rerr"; then ok
    else bad "$name remote: rc=$rrc, '$(cat "$tmp/rerr")' vs '$(cat "$tmp/err")'"; fi
}
G="--sampler zsobol --resolution 64,32 --spp 16 --dims 4"
# shellcheck disable=SC2086
{
expect_fail "tile outside the image" "tile 60,0,8,8 reaches past the 64x32 image" $G --tile 60,0,8,8
expect_fail "tile below the image" "past the 64x32 image" $G --tile 0,32,1,1
expect_fail "empty tile" "empty tile" $G --tile 0,0,0,4
expect_fail "no samples" "empty tile" $G --tile 0,0,4,4 --samples 3:0
expect_fail "sample past spp" "sample 16 is past spp 16: ask for a larger spp (32 covers it)" \
    $G --tile 0,0,4,4 --samples 8:9
expect_fail "dims 0" "dims 0" --sampler zsobol --resolution 64,32 --spp 16 --dims 0 --tile 0,0,4,4
expect_fail "spp 0" "spp 0" --sampler zsobol --resolution 64,32 --spp 0 --dims 2 --tile 0,0,4,4
expect_fail "spp 24 for zsobol" "power of two" --sampler zsobol --resolution 64,32 --spp 24 \
    --dims 2 --tile 0,0,4,4
expect_fail "resolution 0" "resolution 0x32" --sampler zsobol --resolution 0,32 --spp 16 \
    --dims 2 --tile 0,0,4,4
expect_fail "sobol past 21201 dims" "21202" --sampler sobol --resolution 64,32 --spp 16 \
    --dims 21202 --tile 0,0,1,1
expect_fail "unknown sampler" "unknown sampler 'halton'" --sampler halton --resolution 64,32 \
    --spp 16 --dims 2 --tile 0,0,4,4
expect_fail "missing --tile" "--tile X,Y,W,H is required" $G
expect_fail "missing --sampler" "--sampler zsobol|padded-sobol|sobol is required" \
    --resolution 64,32 --spp 16 --dims 2 --tile 0,0,4,4
expect_fail "missing --dims" "--dims D is required" --sampler zsobol --resolution 64,32 \
    --spp 16 --tile 0,0,4,4
expect_fail "--resolution 64" "'64' is not W,H" $G --resolution 64 --tile 0,0,1,1
expect_fail "--resolution 64,32,1" "is not W,H" $G --resolution 64,32,1 --tile 0,0,1,1
expect_fail "--tile 1,2,3" "'1,2,3' is not X,Y,W,H" $G --tile 1,2,3
expect_fail "--tile with a word" "'a' is not a whole number" $G --tile 0,a,1,1
expect_fail "--tile past 2^32" "4294967296 is outside" $G --tile 4294967296,0,1,1
expect_fail "--samples 4" "'4' is not START:COUNT" $G --tile 0,0,1,1 --samples 4
expect_fail "--seed word" "--seed" $G --tile 0,0,1,1 --seed x
expect_fail "--seed past 2^32" "4294967296 is outside" $G --tile 0,0,1,1 --seed 4294967296
expect_fail "--format csv" "unknown format 'csv'" $G --tile 0,0,1,1 --format csv
expect_fail "--frame -1" "--frame" $G --tile 0,0,1,1 --frame -1
expect_fail "an unknown option" "unknown or incomplete option '--count'" $G --tile 0,0,1,1 --count 3
expect_fail "a stray argument" "unexpected argument 'stray'" $G --tile 0,0,1,1 stray
}
# A negative seed is pbrt's int: -1 is 0xffffffff.
"$QMC" pixels $G --tile 3,3,2,2 --seed -1 --format u32 > "$tmp/neg" 2> "$tmp/err"
"$QMC" pixels $G --tile 3,3,2,2 --seed 0xffffffff --format u32 > "$tmp/hex" 2>> "$tmp/err"
if [ -s "$tmp/neg" ] && cmp -s "$tmp/neg" "$tmp/hex" && [ ! -s "$tmp/err" ]; then ok
else bad "--seed -1 differs from --seed 0xffffffff: $(cat "$tmp/err")"; fi
# The daemon's own limit: a sobol sampler of 21201 dims (4.4 MB of tables)
# past the small daemon's max-seq-memory of 1 MiB.
"$QMC" pixels --sampler sobol --resolution 8,8 --spp 4 --tile 0,0,1,1 --dims 21201 \
    --connect "$SMALL" > "$tmp/out" 2> "$tmp/err"
rc=$?
if [ $rc -eq 2 ] && [ "$(wc -l < "$tmp/err")" -eq 1 ] && [ ! -s "$tmp/out" ] &&
   grep -q "^qmc: max-seq-memory: .* 1048576-byte limit" "$tmp/err"; then ok
else bad "max-seq-memory: rc=$rc '$(cat "$tmp/err")'"; fi
# A daemon that is not there: one line, exit 2.
"$QMC" pixels $G --tile 0,0,1,1 --connect "unix:$tmp/nobody.sock" > "$tmp/out" 2> "$tmp/err"
rc=$?
if [ $rc -eq 2 ] && [ "$(wc -l < "$tmp/err")" -eq 1 ] && [ ! -s "$tmp/out" ]; then ok
else bad "no daemon: rc=$rc '$(cat "$tmp/err")'"; fi

# ---- 6. the daemon's ERRORs, while it serves another client ---------------------------
"$QMC" pixels --sampler padded-sobol --resolution 512,512 --spp 64 --tile 0,0,128,128 \
    --dims 4 --format u32 > "$tmp/ref.u32"
run_peer "$HERE/pixelpeer.py" errors "$UNIX" "$QMC" "$tmp/ref.u32"
run_peer "$HERE/pixelpeer.py" errors "$TCP" "$QMC" "$tmp/ref.u32"
run_peer "$HERE/pixelpeer.py" version "$UNIX"
run_peer "$HERE/pixelpeer.py" ring "$UNIX" "$tmp/ref.u32"

# ---- 7. --out ---------------------------------------------------------------------------
"$QMC" pixels $G --tile 5,6,7,8 > "$tmp/stdout.f32"
if "$QMC" pixels $G --tile 5,6,7,8 --out "$tmp/file.f32" > "$tmp/out" 2> "$tmp/err" &&
   [ ! -s "$tmp/out" ] && [ ! -s "$tmp/err" ] && [ -s "$tmp/stdout.f32" ] &&
   cmp -s "$tmp/file.f32" "$tmp/stdout.f32"; then ok
else bad "--out differs from stdout: $(cat "$tmp/err")"; fi
if "$QMC" pixels $G --tile 5,6,7,8 --out "$tmp/file2.f32" --connect "$TCP" 2> "$tmp/err" &&
   cmp -s "$tmp/file2.f32" "$tmp/stdout.f32"; then ok
else bad "remote --out differs: $(cat "$tmp/err")"; fi
mkdir "$tmp/o"
"$QMC" pixels $G --tile 60,0,8,8 --out "$tmp/o/bad.f32" 2> /dev/null
"$QMC" pixels $G --tile 60,0,8,8 --out "$tmp/o/bad.f32" --connect "$UNIX" 2> /dev/null
if [ -z "$(ls -A "$tmp/o")" ]; then ok; else bad "--out error left: $(ls -A "$tmp/o")"; fi
echo "keep me" > "$tmp/o/keep"
chmod 0444 "$tmp/o/keep"
"$QMC" pixels $G --tile 0,0,1,1 --out "$tmp/o/keep" > "$tmp/out" 2> "$tmp/err"
if [ $? -eq 2 ] && [ "$(cat "$tmp/o/keep")" = "keep me" ] && [ "$(wc -l < "$tmp/err")" -eq 1 ]
then ok; else bad "--out over a read-only file: '$(cat "$tmp/err")'"; fi

# ---- 8. STATS -------------------------------------------------------------------------------
"$QMC" stats --connect "$UNIX" --json > "$tmp/stats.json" 2> "$tmp/err"
if "$PY" - "$tmp/stats.json" > "$tmp/why" 2>&1 <<'PYEOF'
import json, sys
st = json.load(open(sys.argv[1]))
c = st.get("counters", st)
assert c["requests_PIXELS"] > 50, "requests_PIXELS %r" % c.get("requests_PIXELS")
assert c["pixel_samples_sent"] >= 128 * 128 * 64, "pixel_samples_sent %r" % c.get("pixel_samples_sent")
# the CLI's large tiles over Unix came through the ring
assert c["requests_SHM_ATTACH"] >= 1, "requests_SHM_ATTACH %r" % c.get("requests_SHM_ATTACH")
PYEOF
then ok; else bad "STATS: $(tail -n 1 "$tmp/why") $(cat "$tmp/err")"; fi

# ---- 9. draining -------------------------------------------------------------------
# SIGTERM while a client holds a tile half read: the daemon cuts that
# stream at shutdown-timeout-ms and exits 0; the client sees no END.
"$PY" "$HERE/pixelpeer.py" hold "$UNIX" "$tmp/holding" "$tmp/gone" > "$tmp/hold.out" 2>&1 &
hold=$!
pids="$pids $hold"
if wait_file "$tmp/holding" 400; then ok; else bad "hold: the tile never started: $(cat "$tmp/hold.out")"; fi
kill "$pid"
if wait "$pid"; then ok; else bad "qmcd did not exit 0 on SIGTERM with a tile open: $(tail -n 3 "$tmp/qmcd.log")"; fi
pid=
touch "$tmp/gone"
wait "$hold"
forget "$hold"
tally "$tmp/hold.out" || bad "hold printed nothing"

# The other daemon stops cleanly.
for v in pid2; do
    eval "p=\$$v"
    kill "$p"
    if wait "$p"; then ok; else bad "$v: qmcd did not exit 0 on SIGTERM: $(tail -n 3 "$tmp/qmcd.log")"; fi
    eval "$v="
done
finish
