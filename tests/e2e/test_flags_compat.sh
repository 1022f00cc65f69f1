#!/bin/sh
# Result flags across protocol versions (PROTOCOL.md section 5): bits 12-16
# are version 3's.  A real daemon, spoken to by the independent peer
# (tests/e2e/qmcpeer.py) as version 1, 2 and 3, on jobs that raise
# unresolved, tail_untested and few_nonzero: the old versions get no bit
# they do not define and error_unreliable in their place, version 3 gets
# the bits, and the rest of each result is the same.  The qmc CLI (the
# client library, version 3) sees the bit too.
# Env: QMC, QMCD (binaries).  Prints "N passed, M failed".
set -u
: "${QMC:?QMC must name the qmc binary}"
: "${QMCD:?QMCD must name the qmcd binary}"
PEER="$(cd "$(dirname "$0")" && pwd)/qmcpeer.py"
. "$(dirname "$0")/lib.sh"

SOCK="$tmp/qmcd.sock"
start main --threads 1 --listen "unix:$SOCK" || finish

run_peer "$PEER" flags_compat "unix:$SOCK"

# The library's client negotiates version 3 and decodes for it: the flag
# arrives, and with it the JSON key.
if "$QMC" integrate --connect "unix:$SOCK" --integrand genz-gaussian --dims 2 \
        --a 5000,5000 --u 0.123,0.777 --method clenshaw-curtis --json > "$tmp/cli.json" \
        2> "$tmp/cli.err" && grep -q '"unresolved"' "$tmp/cli.json" &&
        grep -q '"error_unreliable"' "$tmp/cli.json"; then
    ok
else
    bad "qmc --connect: no unresolved flag: $(cat "$tmp/cli.json" "$tmp/cli.err")"
fi
finish
