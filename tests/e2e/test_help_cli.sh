#!/bin/sh
# test_help_cli.sh - `qmc help` and `qmc help COMMAND`.
#
#   - `qmc help` prints what `qmc --help` prints: every command, each with a
#     one-line summary (the list is checked against the commands named
#     here, so a command cannot silently drop out of it);
#   - `qmc help X` prints byte for byte what `qmc X --help` prints, exit 0,
#     for every command, and never contacts a daemon;
#   - an unknown COMMAND, or more than one, is one line on stderr naming
#     the problem, exit 2, nothing on stdout.
# Env: QMC (binary).  Prints "N passed, M failed" last; exits 1 on failure.
set -u
: "${QMC:?set QMC to the qmc binary}"
. "$(dirname "$0")/lib.sh"

COMMANDS="points pixels discrepancy spectrum integrate merge ping stats compare stability help"

# ---- the list ------------------------------------------------------------------
if "$QMC" help >"$tmp/list" 2>"$tmp/err" && [ ! -s "$tmp/err" ]; then ok
else bad "qmc help: exit $?, stderr '$(cat "$tmp/err")'"; fi
"$QMC" --help >"$tmp/dashdash"
if cmp -s "$tmp/list" "$tmp/dashdash"; then ok; else bad "qmc help differs from qmc --help"; fi
for c in $COMMANDS; do
    # "  NAME  summary": the name, then at least one word of summary.
    if grep -Eq "^  $c +[^ ]+ [^ ]+" "$tmp/list"; then ok
    else bad "qmc help does not list '$c' with a summary"; fi
done
listed=$(awk '/^commands:/ { on = 1; next } on && /^  [a-z]/ { print $1 } on && /^$/ { exit }' "$tmp/list")
if [ "$(echo $listed)" = "$COMMANDS" ]; then ok
else bad "qmc help lists '$(echo $listed)', expected '$COMMANDS'"; fi
if grep -q 'qmc help COMMAND' "$tmp/list"; then ok; else bad "the list does not say how to get a command's options"; fi

# ---- qmc help COMMAND == qmc COMMAND --help ------------------------------------------
# An endpoint nobody listens on: help must not try to connect.
export QMC_ENDPOINT="unix:$tmp/nobody.sock"
for c in $COMMANDS; do
    "$QMC" help "$c" >"$tmp/a" 2>"$tmp/aerr"
    ra=$?
    "$QMC" "$c" --help >"$tmp/b" 2>"$tmp/berr"
    rb=$?
    if [ $ra -eq 0 ] && [ $rb -eq 0 ] && [ -s "$tmp/a" ] && cmp -s "$tmp/a" "$tmp/b" &&
       [ ! -s "$tmp/aerr" ]; then ok
    else bad "qmc help $c (exit $ra, '$(head -c 200 "$tmp/aerr")') != qmc $c --help (exit $rb)"; fi
    if head -n 1 "$tmp/a" | grep -q "^usage: qmc $c"; then ok
    else bad "qmc help $c: first line '$(head -n 1 "$tmp/a")'"; fi
done
unset QMC_ENDPOINT
# A command's own help is what it documents (spot checks of the content).
if "$QMC" help discrepancy | grep -q SQUARED; then ok; else bad "qmc help discrepancy lacks its text"; fi
if "$QMC" help merge | grep -q 'never contacts the daemon'; then ok; else bad "qmc help merge lacks the --connect note"; fi

# ---- errors --------------------------------------------------------------------------
expect_fail() { # NAME PATTERN ARGS...: exit 2, one stderr line matching PATTERN, no stdout
    name=$1 pattern=$2
    shift 2
    "$QMC" "$@" >"$tmp/out" 2>"$tmp/err"
    rc=$?
    if [ "$rc" -eq 2 ] && [ "$(wc -l <"$tmp/err")" -eq 1 ] && [ ! -s "$tmp/out" ] &&
       grep -q "$pattern" "$tmp/err"; then ok
    else bad "$name: rc=$rc, stderr '$(cat "$tmp/err")', stdout '$(head -c 200 "$tmp/out")'"; fi
}
expect_fail "help unknown" "^qmc: help: unknown command 'frobnicate'" help frobnicate
expect_fail "help two words" "^qmc: help: give one COMMAND" help points spectrum
expect_fail "help an option" "unknown command '--json'" help --json
expect_fail "unknown command" "^qmc: unknown command 'hlep' (qmc help lists them)" hlep

finish
