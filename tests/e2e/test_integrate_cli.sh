#!/bin/sh
# End-to-end checks of `qmc integrate` and `qmc merge` against the real
# binary: answers inside their intervals, the same numbers for any thread
# count and any --part split, every diagnostic flag, and every error path
# (one line on stderr, exit 2, nothing on stdout).
# Env: QMC = the qmc binary.  Prints "N passed, M failed".
set -u
: "${QMC:?QMC must name the qmc binary}"
. "$(dirname "$0")/lib.sh"

# json FIELD < file: the raw value of a top-level field of a one-line object.
json() { sed -n "s/.*\"$1\":\\([^,}]*\\).*/\\1/p"; }
# without the wall time, which is the one field allowed to differ
strip_seconds() { sed 's/"seconds":[^,]*,//'; }

# 1. Estimates inside their intervals, per method; the exact value printed.
for m in mc stratified lhs rqmc; do
    "$QMC" integrate --integrand genz-gaussian --dims 4 --method $m --n 4096 --seed 3 --json \
        > "$tmp/r.json" 2> "$tmp/err" || { bad "$m exited non-zero: $(cat "$tmp/err")"; continue; }
    if awk -v lo="$(json ci_low < "$tmp/r.json")" -v hi="$(json ci_high < "$tmp/r.json")" \
           -v x="$(json exact < "$tmp/r.json")" 'BEGIN { exit !(lo <= x && x <= hi) }'; then ok
    else bad "$m: exact value outside the interval: $(cat "$tmp/r.json")"; fi
done

# 2. Quadrature: Gauss-Legendre with n points is exact for degree 2n-1.
"$QMC" integrate --integrand poly --a 1,2,3,4,5,6 --dims 1 --method gauss-legendre --n 3 --json > "$tmp/r.json"
if awk -v e="$(json abs_error < "$tmp/r.json")" 'BEGIN { exit !(e < 1e-14) }'; then ok
else bad "gauss-legendre 3 points on degree 5: $(cat "$tmp/r.json")"; fi

# 3. Threads never change the numbers.
A="--integrand genz-oscillatory --dims 6 --method rqmc --n 20000 --reps 8 --seed 11 --json"
# shellcheck disable=SC2086
"$QMC" integrate $A --threads 1 | strip_seconds > "$tmp/t1"
# shellcheck disable=SC2086
"$QMC" integrate $A --threads 2 | strip_seconds > "$tmp/t2"
# shellcheck disable=SC2086
"$QMC" integrate $A --threads 7 | strip_seconds > "$tmp/t7"
if cmp -s "$tmp/t1" "$tmp/t2" && cmp -s "$tmp/t1" "$tmp/t7"; then ok
else bad "thread counts 1, 2, 7 gave different results"; fi

# 4. --part K/P + merge == the single run, in any order of parts.
for k in 1 2 3 4; do
    # shellcheck disable=SC2086
    "$QMC" integrate $A --part $k/4 > "$tmp/p$k" || bad "part $k/4 failed"
done
"$QMC" merge --json "$tmp/p3" "$tmp/p1" "$tmp/p4" "$tmp/p2" | strip_seconds > "$tmp/merged"
if cmp -s "$tmp/t1" "$tmp/merged"; then ok
else bad "merge differs from the single run"; diff "$tmp/t1" "$tmp/merged" | head -5; fi

# A split net (replicates cut from one scrambled sequence) splits and
# merges the same way, and differs from independent replicates.
S="--integrand genz-discontinuous --dims 3 --method rqmc --reps 8 --n 8192 --seed 4 --json"
# shellcheck disable=SC2086
"$QMC" integrate $S --split-net | strip_seconds > "$tmp/s1"
for k in 1 2 3; do
    # shellcheck disable=SC2086
    "$QMC" integrate $S --split-net --part $k/3 > "$tmp/sp$k" || bad "split part $k/3 failed"
done
"$QMC" merge --json "$tmp/sp2" "$tmp/sp3" "$tmp/sp1" | strip_seconds > "$tmp/smerged"
# shellcheck disable=SC2086
"$QMC" integrate $S | strip_seconds > "$tmp/s0"
if cmp -s "$tmp/s1" "$tmp/smerged" && grep -q 'split from one net' "$tmp/s1" &&
   ! cmp -s "$tmp/s0" "$tmp/s1"; then ok
else bad "split net: merge or labels wrong"; diff "$tmp/s1" "$tmp/smerged" | head -5; fi

# A scene's audit flags survive --part and merge: the balance heuristic on
# a tiny light (issue 13) is flagged mis_undersampled either way.
printf 'point 0 0 0\nnormal 0 0 1\nbrdf lambert 0.8\nlight sphere center 1 0.5 5 radius 0.005 radiance 10\n' \
    > "$tmp/tiny.scene"
T="--scene $tmp/tiny.scene --strategy mis-balance --method rqmc --n 4096 --seed 5 --json"
# shellcheck disable=SC2086
"$QMC" integrate $T | strip_seconds > "$tmp/m0"
for k in 1 2; do
    # shellcheck disable=SC2086
    "$QMC" integrate $T --part $k/2 > "$tmp/mp$k" || bad "scene part $k/2 failed"
done
"$QMC" merge --json "$tmp/mp2" "$tmp/mp1" | strip_seconds > "$tmp/mmerged"
if cmp -s "$tmp/m0" "$tmp/mmerged" && grep -q '"mis_undersampled"' "$tmp/m0"; then ok
else bad "scene merge lost the audit's flag"; diff "$tmp/m0" "$tmp/mmerged" | head -5; fi

# 5. Adaptive stopping meets the tolerance, or says it ran out of budget.
"$QMC" integrate --integrand genz-gaussian --dims 5 --method rqmc --tol-rel 1e-6 --json > "$tmp/r.json"
if awk -v e="$(json estimate < "$tmp/r.json")" -v h="$(json ci_high < "$tmp/r.json")" \
       'BEGIN { exit !(h - e <= 1e-6 * e) }' && ! grep -q not_converged "$tmp/r.json"; then ok
else bad "adaptive rqmc missed 1e-6: $(cat "$tmp/r.json")"; fi
"$QMC" integrate --integrand genz-gaussian --dims 5 --method mc --tol-rel 1e-9 --max-evals 100000 \
    --json > "$tmp/r.json"
if grep -q '"budget"' "$tmp/r.json" && grep -q '"not_converged"' "$tmp/r.json"; then ok
else bad "budget exhaustion not flagged: $(cat "$tmp/r.json")"; fi

# 6. Diagnostics: each failure mode raises its flag.
flag_case() { # FLAG ARGS...
    want=$1; shift
    if "$QMC" integrate "$@" --json 2>/dev/null | grep -q "\"$want\""; then ok
    else bad "flag $want not raised by: qmc integrate $*"; fi
}
flag_case heavy_tail --integrand inv-sqrt --dims 1 --method mc --n 100000
flag_case nonfinite --integrand log --dims 1 --method qmc --n 1024
flag_case not_pow2 --integrand genz-gaussian --dims 3 --method qmc --n 1000
flag_case dims_past_good --integrand genz-gaussian --dims 12 --method qmc --seq halton --n 1024
flag_case few_reps --integrand genz-gaussian --dims 3 --method rqmc --reps 4
flag_case not_converged --integrand step --dims 1 --method gauss-kronrod --tol-rel 1e-15 --max-evals 2000
flag_case memory_bound --integrand genz-corner-peak --dims 6 --method cubature --tol-rel 1e-14 --max-memory 65536

# 7. auto says what it chose and why.
out=$("$QMC" integrate --integrand genz-continuous --dims 3 --method auto --tol-rel 1e-5)
if echo "$out" | grep -q '^auto       chose cubature'; then ok; else bad "auto at d=3: $out"; fi
out=$("$QMC" integrate --integrand genz-gaussian --dims 12 --method auto --tol-rel 1e-5)
if echo "$out" | grep -q '^auto       chose rqmc'; then ok; else bad "auto at d=12: $out"; fi

# 8. Scenes: every strategy's interval holds the closed form; MIS consumes
#    2 dims per sample; the reference is labelled as such without one.
scenes=$(cd "$(dirname "$0")/../scenes" && pwd)
for st in uniform brdf light mis-balance mis-power mis-max; do
    "$QMC" integrate --scene "$scenes/lambert_sphere.scene" --method rqmc --n 8192 --reps 16 \
        --strategy $st --seed 2 --json > "$tmp/r.json" 2> "$tmp/err" ||
        { bad "scene strategy $st: $(cat "$tmp/err")"; continue; }
    lo=$(json ci_low < "$tmp/r.json"); hi=$(json ci_high < "$tmp/r.json"); x=$(json exact < "$tmp/r.json")
    # 4-sigma slack around the 95% interval: six strategies must not flake.
    if awk -v lo="$lo" -v hi="$hi" -v x="$x" 'BEGIN { w = (hi - lo) / 2; exit !(lo - w <= x && x <= hi + w) }'; then ok
    else bad "scene strategy $st misses the exact value: $(cat "$tmp/r.json")"; fi
done
"$QMC" integrate --scene "$scenes/lambert_rect.scene" --method rqmc --samples 2/3 --json > "$tmp/r.json"
if [ "$(json dims < "$tmp/r.json")" = 10 ]; then ok; else bad "MIS 2/3 should use 10 dims: $(cat "$tmp/r.json")"; fi
if "$QMC" integrate --scene "$scenes/phong_sphere.scene" --method rqmc | grep -q '^reference '; then ok
else bad "a scene without a closed form should print its reference as 'reference'"; fi
printf 'point 0 0 0\nnormal 0 0 1\nbrdf lambert 0.5\nlight sphere center 0 0 5 radius -1 radiance 1\n' > "$tmp/bad.scene"

# 9. Errors: one line, exit 2, nothing on stdout.
err_case() { # WORD ARGS...
    word=$1; shift
    "$QMC" "$@" > "$tmp/out" 2> "$tmp/err"
    rc=$?
    if [ $rc -eq 2 ] && [ ! -s "$tmp/out" ] && [ "$(wc -l < "$tmp/err")" -eq 1 ] &&
       grep -q "^qmc: " "$tmp/err" && grep -qi -- "$word" "$tmp/err"; then ok
    else bad "qmc $* -> exit $rc, stderr '$(cat "$tmp/err")', stdout $(wc -c < "$tmp/out") bytes"; fi
}
err_case "genz-nope" integrate --integrand genz-nope --dims 2 --method mc
err_case "--dims" integrate --integrand genz-gaussian --method mc
err_case "--a" integrate --integrand genz-gaussian --dims 2 --a 1,,2 --method mc
err_case "--integrand, a --scene or a --command" integrate --method mc
err_case "unknown method" integrate --integrand exp --dims 1 --method simpsons
err_case "evaluations" integrate --integrand genz-gaussian --dims 8 --method gauss-legendre --n 64
err_case "1D" integrate --integrand genz-gaussian --dims 2 --method gauss-kronrod
err_case "control variate" integrate --integrand genz-gaussian --dims 2 --control genz-product-peak --method simpson
err_case "rqmc" integrate --integrand genz-gaussian --dims 2 --method qmc --tol-rel 1e-3
err_case "reps" integrate --integrand genz-gaussian --dims 2 --method rqmc --reps 1
err_case "--split-net is for rqmc" integrate --integrand genz-gaussian --dims 2 --method mc --split-net
err_case "k^2" integrate --integrand genz-gaussian --dims 2 --method stratified --n 10
err_case "--part" integrate --integrand exp --dims 1 --method rqmc --part 4/3
# in-process options with --connect are refused before any connection
err_case "^qmc: --threads is an in-process option: the daemon runs the whole job on its own pool (drop it, or --connect '' to run here)$" \
    integrate --connect "unix:$tmp/none.sock" --integrand exp --dims 1 --threads 2
err_case "^qmc: --part is an in-process option: the daemon runs the whole job" \
    integrate --connect "unix:$tmp/none.sock" --integrand exp --dims 1 --method rqmc --part 1/2
err_case "fixed --n" integrate --integrand exp --dims 1 --method rqmc --tol-rel 1e-3 --part 1/2
err_case "budget" integrate --integrand genz-gaussian --dims 2 --method mc --n 1000000 --max-evals 1000
err_case "--difficulty" integrate --integrand genz-gaussian --dims 2 --difficulty hard --method mc
err_case "missing" merge "$tmp/p1" "$tmp/p2"
err_case "both" merge "$tmp/p1" "$tmp/p1" "$tmp/p2" "$tmp/p3" "$tmp/p4"
"$QMC" integrate --integrand genz-oscillatory --dims 6 --method rqmc --n 20000 --reps 8 --seed 12 \
    --part 2/4 > "$tmp/other"
err_case "different job" merge "$tmp/p1" "$tmp/other" "$tmp/p3" "$tmp/p4"
head -c 200 "$tmp/p2" > "$tmp/trunc"
err_case "truncated" merge "$tmp/p1" "$tmp/trunc" "$tmp/p3" "$tmp/p4"
err_case "not a qmc partial" merge /etc/hostname
err_case "line 4, column" integrate --scene "$tmp/bad.scene" --method rqmc
err_case "cannot open" integrate --scene "$tmp/none.scene" --method rqmc
err_case "do not apply" integrate --scene "$scenes/lambert_sphere.scene" --dims 3 --method rqmc
err_case "unknown strategy" integrate --scene "$scenes/lambert_sphere.scene" --strategy best --method rqmc
err_case "no scene" integrate --integrand exp --dims 1 --strategy light --method mc

finish
