#!/bin/sh
# Golden digests of qmc output (points, and integration results from every
# kind of integrator, auto over a VEGAS map included): the same request must
# give the same bytes
# from every build (gcc -O2 for `make test`, clang -O1 with sanitizers for
# `make sanitize`, and any instruction set the CPU dispatch picks), today
# and after any refactoring.  A changed digest means changed numbers:
# regenerate tests/vectors/golden.sha256 only for an intended change
# (tests/e2e/test_golden.sh --update), and say so in the commit.
# Env: QMC = the qmc binary.
set -u
here=$(cd "$(dirname "$0")" && pwd)
golden=$here/../vectors/golden.sha256
: "${QMC:?QMC must name the qmc binary}"

cases() {
    cat <<'CASES'
sobol-none-f64      points --seq sobol --dims 40 --count 5000 --start 977 --format f64
sobol-shift-f64     points --seq sobol --dims 40 --count 5000 --scramble shift --seed 9 --format f64
sobol-owen-f64      points --seq sobol --dims 40 --count 5000 --scramble owen --seed 9 --format f64
sobol-owen-u32      points --seq sobol --dims 300 --count 300 --scramble owen --seed 3 --format u32
sobol-owen-f32-shuf points --seq sobol --dims 5 --count 4096 --scramble owen --shuffle --seed 3 --format f32
sobol-fowen-f64     points --seq sobol --dims 40 --count 5000 --scramble fast-owen --seed 9 --format f64
sobol-fowen-u32-d5  points --seq sobol --dims 5 --count 4096 --start 3 --scramble fast-owen --seed 0x123456789 --format u32
sobol-large-f64     points --seq sobol --dims 32 --count 20000 --start 4294900000 --format f64
halton-none-f64     points --seq halton --dims 46 --count 20000 --start 1000000 --format f64
halton-faure-csv    points --seq halton --dims 7 --count 300 --scramble faure
halton-owen-f64     points --seq halton --dims 9 --count 3000 --scramble owen --seed 4 --format f64
hammersley-f64      points --seq hammersley --dims 12 --count 4096 --format f64
random-f64          points --seq random --dims 6 --count 3000 --seed 11 --format f64
stratified-f64      points --seq stratified --dims 3 --count 4096 --seed 11 --format f64
lhs-f64             points --seq lhs --dims 6 --count 3000 --seed 11 --format f64
integrate-rqmc      integrate --integrand genz-oscillatory --dims 8 --method rqmc --n 4096 --seed 5 --json
integrate-cubature  integrate --integrand genz-gaussian --dims 4 --method cubature --max-evals 200000 --json
integrate-cc        integrate --integrand genz-corner-peak --dims 4 --method clenshaw-curtis --max-evals 300000 --json
integrate-gl        integrate --integrand genz-product-peak --dims 3 --method gauss-legendre --n 12 --json
integrate-auto-map  integrate --integrand genz-continuous --dims 20 --method auto --max-evals 400000 --seed 2 --json
integrate-auto-split integrate --integrand genz-discontinuous --dims 5 --method auto --max-evals 200000 --seed 4 --json
integrate-scene     integrate --scene tests/scenes/phong_sphere.scene --method rqmc --n 1024 --strategy mis-power --json
CASES
}

# integrate --json prints its wall time: every other byte is digested.
digest() {
    case $1 in
    integrate*)
        # shellcheck disable=SC2086
        (cd "$here/../.." && "$QMC" $1) | sed 's/"seconds":[^,]*,//' | sha256sum | cut -d' ' -f1 ;;
    *)
        # shellcheck disable=SC2086
        "$QMC" $1 | sha256sum | cut -d' ' -f1 ;;
    esac
}

if [ "${1:-}" = "--update" ]; then
    cases | while read -r name args; do
        echo "$name $(digest "$args")"
    done > "$golden"
    echo "wrote $golden"
    exit 0
fi

pass=0
fail=0
while read -r name args; do
    want=$(awk -v n="$name" '$1 == n {print $2}' "$golden")
    got=$(digest "$args")
    if [ -n "$want" ] && [ "$got" = "$want" ]; then
        pass=$((pass + 1))
    else
        fail=$((fail + 1))
        echo "FAIL $name: qmc $args"
        echo "     digest $got, golden ${want:-missing}"
    fi
done <<EOF2
$(cases)
EOF2
echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
