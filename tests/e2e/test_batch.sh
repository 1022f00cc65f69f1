#!/bin/sh
# Batch sharding as docs/OPERATIONS.md's GNU parallel recipe runs it, with
# the remote side played locally: P = 7 parts of one integration job, each
# `qmc integrate ... --part K/7` a separate process (xargs -P 7, as
# parallel's ssh workers would be), merged by `qmc merge` in a shuffled
# order, must equal the single run bit for bit (every field of --json but
# the measured seconds).  Also: merge refuses a missing and a duplicated
# part with one line and exit 2.  Env: QMC.  Prints "N passed, M failed".
set -u
: "${QMC:?QMC must name the qmc binary}"
PY=/usr/bin/python3
. "$(dirname "$0")/lib.sh"

same_json() {
    "$PY" - "$1" "$2" <<'PYEOF'
import json, sys
a, b = (json.load(open(f)) for f in sys.argv[1:3])
for d in (a, b):
    d.pop("seconds", None)   # measured: the merge sums the parts'
diff = sorted(k for k in set(a) | set(b) if a.get(k) != b.get(k))
if diff:
    print("differ in: " + ", ".join(diff))
sys.exit(1 if diff else 0)
PYEOF
}

# job-name | the job's options (fixed-n sampling: what --part splits)
while IFS='|' read -r name opts; do
    # shellcheck disable=SC2086
    "$QMC" integrate $opts --json > "$tmp/$name.single.json" || { bad "$name: single run failed"; continue; }
    mkdir -p "$tmp/$name"
    # the recipe's remote side: one process per part, all at once
    export QMC opts name tmp
    seq 1 7 | xargs -P 7 -I K sh -c \
        '"$QMC" integrate $opts --part K/7 > "$tmp/$name/part-K.txt"' ||
        { bad "$name: a part failed"; continue; }
    # merge in an order other than 1..7: the parts say which blocks they hold
    if "$QMC" merge --json "$tmp/$name"/part-5.txt "$tmp/$name"/part-2.txt "$tmp/$name"/part-7.txt \
        "$tmp/$name"/part-1.txt "$tmp/$name"/part-6.txt "$tmp/$name"/part-3.txt \
        "$tmp/$name"/part-4.txt > "$tmp/$name.merged.json" 2> "$tmp/$name.err"; then
        if out=$(same_json "$tmp/$name.merged.json" "$tmp/$name.single.json"); then ok
        else bad "$name: 7 merged parts differ from the single run: $out"; fi
    else
        bad "$name: merge failed: $(cat "$tmp/$name.err")"
    fi
    # six of seven parts, or one twice: refused in one line
    "$QMC" merge "$tmp/$name"/part-[1-6].txt > "$tmp/m6.out" 2> "$tmp/m6.err"
    st=$?
    if [ $st -eq 2 ] && [ ! -s "$tmp/m6.out" ] && [ "$(wc -l < "$tmp/m6.err")" -eq 1 ]; then ok
    else bad "$name: merge of 6 of 7 parts: exit $st, $(cat "$tmp/m6.err")"; fi
    "$QMC" merge "$tmp/$name"/part-*.txt "$tmp/$name"/part-3.txt > "$tmp/m8.out" 2> "$tmp/m8.err"
    st=$?
    if [ $st -eq 2 ] && [ ! -s "$tmp/m8.out" ] && [ "$(wc -l < "$tmp/m8.err")" -eq 1 ]; then ok
    else bad "$name: merge with a part twice: exit $st, $(cat "$tmp/m8.err")"; fi
done <<EOF
rqmc|--integrand genz-gaussian --dims 6 --method rqmc --n 4096 --reps 14 --seed 9
mc|--integrand genz-oscillatory --dims 5 --method mc --n 700000 --seed 4
scene|--scene $(cd "$(dirname "$0")/../scenes" && pwd)/phong_sphere.scene --method rqmc --n 2048 --reps 7
EOF
finish
