#!/bin/sh
# test_readme.sh - the README's five-minute tour, run as a reader would run
# it, so that the README cannot drift from the programs.
#
# tests/e2e/readme_tour.py extracts the tour (the ```sh blocks between the
# tour:begin and tour:end comments of README.md) and runs its blocks in
# order in one bash shell with `set -e -o pipefail`; a ```text block right
# after a ```sh block is the stdout the block must print (`...` inside a
# line matches any text, a line that is only `...` any number of lines).
# The full convention is at the top of readme_tour.py and of the tour.
#
# The shell starts in a temporary directory standing in for the repository
# root: its build/ holds links to the qmc and qmcd under test, PATH holds
# only the system directories (an installed qmc cannot stand in for the
# tour's own set-up), TMPDIR points inside the temporary directory (the
# tour's `mktemp -d` and the daemon's socket land there), and
# QMC_ENDPOINT is unset.  Every process the tour starts carries a token in
# its environment; the tour must stop its daemon itself (the test fails if
# anything is left running once it ends), and whatever is left is stopped
# here by PID.
#
# Env: QMC, QMCD (binaries).  README (default: the README.md beside
# tests/).  Needs bash and /usr/bin/python3.  Prints "N passed, M failed".
set -u
: "${QMC:?set QMC to the qmc binary}"
: "${QMCD:?set QMCD to the qmcd binary}"
here=$(cd "$(dirname "$0")" && pwd)
README=${README:-$here/../../README.md}
PY=/usr/bin/python3
TMP=$(mktemp -d "${TMPDIR:-/tmp}/qmc-readme.XXXXXX") || exit 1
token="qmc-readme-tour-$$-$(od -An -N8 -tx8 /dev/urandom | tr -d ' ')"

# The PIDs of our processes whose environment holds the token.
tour_pids() {
    for e in /proc/[0-9]*/environ; do
        p=${e#/proc/}
        p=${p%/environ}
        [ -O "$e" ] || continue
        if { tr '\0' '\n' <"$e"; } 2>/dev/null | grep -qx "QMC_TOUR_TOKEN=$token"; then
            echo "$p"
        fi
    done
}
cleanup() {
    for p in $(tour_pids); do kill "$p" 2>/dev/null; done
    rm -rf "$TMP"
}
trap cleanup EXIT
trap 'exit 1' INT TERM

mkdir -p "$TMP/root/build" "$TMP/tmp" "$TMP/run"
ln -s "$QMC" "$TMP/root/build/qmc"
ln -s "$QMCD" "$TMP/root/build/qmcd"

env -u QMC_ENDPOINT PATH=/usr/local/sbin:/usr/sbin:/sbin:/usr/bin:/bin \
    TMPDIR="$TMP/tmp" HOME="$TMP/root" QMC_TOUR_TOKEN="$token" \
    "$PY" "$here/readme_tour.py" "$README" "$TMP/root" "$TMP/run" >"$TMP/report"
rc=$?
grep -v -e '^ok   ' -e '^[0-9]* passed, [0-9]* failed$' "$TMP/report"

# Nothing the tour started may outlive it.  SIGTERM is asynchronous, so a
# daemon the tour stopped gets a moment to finish exiting (a hang guard,
# not a timing assertion: 30 s, for a sanitized daemon's exit on a loaded
# machine).
extra_fail=0
i=0
left=$(tour_pids)
while [ -n "$left" ] && [ $i -lt 1500 ]; do
    sleep 0.02
    i=$((i + 1))
    left=$(tour_pids)
done
if [ -n "$left" ]; then
    extra_fail=1
    echo "FAIL: the tour left processes running:"
    for p in $left; do echo "    $p: $(tr '\0' ' ' <"/proc/$p/cmdline" 2>/dev/null)"; done
fi

# readme_tour.py's last line is "N passed, M failed"; add the check above.
summary=$(tail -n 1 "$TMP/report")
passed=$(echo "$summary" | awk '{print $1}')
failed=$(echo "$summary" | awk '{print $3}')
case "$passed$failed" in
*[!0-9]* | '') echo "FAIL: readme_tour.py did not report (exit $rc)"; passed=0 failed=1 ;;
esac
if [ "$extra_fail" -eq 0 ]; then passed=$((passed + 1)); else failed=$((failed + 1)); fi
[ "$rc" -eq 0 ] || [ "$failed" -gt 0 ] || failed=1
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
