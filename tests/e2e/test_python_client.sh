#!/bin/sh
# End-to-end checks of the Python client (client/python, package qmcd):
#
#   - its own tests (client/python/tests/run.py, one "ok"/"FAIL" line each,
#     counted here; every skip is a failure under make check): the codec
#     against tests/vectors/proto and PROTOCOL.md's tables, hostile fake
#     servers (garbage, truncation, oversized frames, drips, lies about the
#     ring, bad proofs: a clear exception, never a hang), byte-identical
#     points, tiles and job JSON against the C CLI, the HMAC handshake
#     against qmcd --auth-key, the scipy-style engines against scipy,
#     integration sessions with Python functions equal to built-in
#     integrands giving `qmc integrate`'s results bit for bit and the
#     JSON bytes `qmc integrate --command` prints for a program computing
#     the same function, resumed after a dropped connection, and part
#     sessions whose --part files equal the CLI's and merge into the whole run;
#   - the package installs offline from a copy of the tree with Debian's
#     pip and setuptools (pip install --no-build-isolation --target DIR)
#     and, installed, talks to a daemon;
#   - the README's example scripts run against a daemon, importing the
#     package from the tree without installing it.
# Env: QMC, QMCD (binaries).  Prints "N passed, M failed".
set -u
: "${QMC:?QMC must name the qmc binary}"
: "${QMCD:?QMCD must name the qmcd binary}"
. "$(dirname "$0")/lib.sh"
root=$(cd "$(dirname "$0")/../.." && pwd)
py=/usr/bin/python3
pid=
term_vars=pid

# No bytecode caches in the tree: the tests write only under $tmp.
export PYTHONDONTWRITEBYTECODE=1
if ! $py -c 'import numpy' > "$tmp/numpy.err" 2>&1; then
    echo "FAIL: $py cannot import numpy (python3-numpy; sh build-aux/deps.sh test)"
    echo "0 passed, 1 failed"
    exit 1
fi

# What client/python holds now: nothing the tests do may add to it.
(cd "$root" && find client/python | sort) > "$tmp/tree.before"

# ---- the package's own tests -------------------------------------------------
QMC=$QMC QMCD=$QMCD QMCD_TEST_REQUIRE=1 TMPDIR=$tmp $py -W error::ResourceWarning \
    "$root/client/python/tests/run.py" > "$tmp/unit.out" 2>&1
rc=$?
tally "$tmp/unit.out" || bad "client/python/tests/run.py printed no result: $(tail -c 500 "$tmp/unit.out")"
[ $rc -eq 0 ] || grep -q '^FAIL ' "$tmp/unit.out" ||
    bad "client/python/tests/run.py exited $rc: $(tail -c 500 "$tmp/unit.out")"

# ---- a daemon for the installed package and the examples ----------------------
"$QMCD" --foreground --listen "unix:$tmp/qmcd.sock" --threads 2 --log-level warning \
    --ready-file "$tmp/ready" 2> "$tmp/qmcd.log" &
pid=$!
wait_ready pid "$tmp/ready" "$tmp/qmcd.log"
ep="unix:$tmp/qmcd.sock"

# ---- pip install, offline, from a copy (pip builds in the source tree) -------
# --no-build-isolation: the build uses Debian's setuptools instead of
# fetching one; --no-deps: numpy is Debian's python3-numpy, which a
# --target directory does not see as installed.
cp -R "$root/client/python" "$tmp/src"
rm -rf "$tmp/src/build" "$tmp/src"/*.egg-info
if PIP_NO_INDEX=1 PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_NO_CACHE_DIR=1 PIP_ROOT_USER_ACTION=ignore \
    $py -m pip install --no-build-isolation --no-deps --target "$tmp/site" "$tmp/src" \
    > "$tmp/pip.log" 2>&1; then
    ok
else
    bad "pip install --no-build-isolation failed: $(tail -c 800 "$tmp/pip.log")"
fi
# Installed: imported from the target, not from the tree, and it works.
out=$(cd "$tmp" && PYTHONPATH="$tmp/site" $py -c '
import sys, qmcd
print(qmcd.__file__)
with qmcd.connect(sys.argv[1]) as c:
    x = c.points("sobol", 3, 4, dtype="u32")
    print(x.tolist(), c.sobol_table_matches)
' "$ep" 2>&1)
case $out in
"$tmp/site/qmcd/__init__.py"*"[[0, 0, 0], [2147483648, 2147483648, 2147483648], [1073741824, 3221225472, 3221225472], [3221225472, 1073741824, 1073741824]] True")
    ok ;;
*) bad "the installed package: $out" ;;
esac

# ---- the README's examples, from the tree ----------------------------------------
for ex in points_example job_example tile_example integrate_example; do
    if (cd "$tmp" && QMC_ENDPOINT=$ep PYTHONPATH="$root/client/python" \
        $py "$root/client/python/examples/$ex.py" > "$tmp/$ex.out" 2>&1); then
        ok
    else
        bad "$ex.py: $(tail -c 500 "$tmp/$ex.out")"
    fi
done
grep -q '^estimate   1\.0000000' "$tmp/points_example.out" ||
    bad "points_example: $(cat "$tmp/points_example.out")"
grep -q '^{"integrand":"genz-gaussian"' "$tmp/job_example.out" && ok ||
    bad "job_example: $(cat "$tmp/job_example.out")"
grep -q '^node 2/4   the same values: True' "$tmp/tile_example.out" && ok ||
    bad "tile_example: $(cat "$tmp/tile_example.out")"
grep -q '^ended      converged' "$tmp/integrate_example.out" &&
    grep -q '^auto       clenshaw-curtis: 1.0000000000' "$tmp/integrate_example.out" && ok ||
    bad "integrate_example: $(cat "$tmp/integrate_example.out")"

(cd "$root" && find client/python | sort) > "$tmp/tree.after"
cmp -s "$tmp/tree.before" "$tmp/tree.after" && ok ||
    bad "the tests or the install left files in client/python: $(diff "$tmp/tree.before" "$tmp/tree.after" | head -5)"

finish
