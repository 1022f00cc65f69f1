#!/bin/sh
# `qmcd --check-config`: a valid file exits 0 with one line on stdout; each
# kind of bad file or flag exits 2 with one line on stderr naming the file
# and line (or the flag) and nothing on stdout; checking binds nothing.
# systemd/qmcd.conf names every option qmcd has (tried uncommented, it is
# still valid), and qmcd.conf(5) documents them (test_install.sh).
# Env: QMCD.  Prints "N passed, M failed".
set -u
: "${QMCD:?QMCD must name the qmcd binary}"
HERE="$(cd "$(dirname "$0")" && pwd)"
TOP="$(cd "$HERE/../.." && pwd)"
EXAMPLE="$TOP/systemd/qmcd.conf"
. "$(dirname "$0")/lib.sh"

# expect_bad WHAT PATTERN ARGS...: exit 2, stdout empty, one stderr line
# matching PATTERN (grep -E).
expect_bad() {
    what=$1
    pat=$2
    shift 2
    "$QMCD" --check-config "$@" > "$tmp/out" 2> "$tmp/err"
    st=$?
    if [ $st -eq 2 ] && [ ! -s "$tmp/out" ] && [ "$(wc -l < "$tmp/err")" -eq 1 ] &&
        grep -Eq -- "$pat" "$tmp/err"; then ok
    else bad "$what: exit $st, stdout '$(cat "$tmp/out")', stderr '$(cat "$tmp/err")'"; fi
}

if "$QMCD" --check-config --config "$EXAMPLE" > "$tmp/out" 2> "$tmp/err" &&
    [ "$(wc -l < "$tmp/out")" -eq 1 ] && [ ! -s "$tmp/err" ]; then ok
else bad "the example config: $(cat "$tmp/out" "$tmp/err")"; fi

# Every #key = value line of the example, uncommented, is valid too.
sed 's/^#\([a-z-]* = \)/\1/' "$EXAMPLE" > "$tmp/uncommented.conf"
if "$QMCD" --check-config --config "$tmp/uncommented.conf" > /dev/null 2> "$tmp/err"; then ok
else bad "the example's commented settings: $(cat "$tmp/err")"; fi
# ... and names every option.
for k in $("$QMCD" --help | sed -n 's/^  --\([a-z-]*\) .*/\1/p') listen log-level ready-file foreground; do
    grep -Eq "^#?$k = " "$EXAMPLE" || bad "systemd/qmcd.conf does not show $k"
done
ok

# name | file contents (printf format) | the error it must give
while IFS='|' read -r name text pat; do
    # shellcheck disable=SC2059
    printf "$text" > "$tmp/$name.conf"
    expect_bad "$name" "^qmcd: $tmp/$name.conf:$pat" --config "$tmp/$name.conf"
done <<EOF
number|threads = 2\n# fine so far\nmax-points = lots\n|3: max-points: 'lots' is not a number
range|max-frame = 16G\n|1: max-frame: .* is outside 4096\.\.
zero|\n\nmax-connections = 0\n|3: max-connections: 0 is outside
unknown|log-level = info\nthreads = 1\nmax-pointz = 5\n|3: unknown key 'max-pointz'
noequals|threads 2\n|1: expected 'key = value'
listen|listen = ftp:example.org\n|1: listen: 'ftp:example.org' is neither
level|log-level = loud\n|1: log-level: 'loud' is not one of
foreground|foreground = maybe\n|1: foreground: 'maybe' is not yes or no
empty|ready-file =\n|1: ready-file: value is empty
nul|threads = 1\nthreads = 2\000\n|2: a NUL byte
suffix|max-points = 4T\n|1: max-points: '4T' is not a number
EOF
awk 'BEGIN { for (i = 0; i < 17; i++) printf "listen = unix:/tmp/x%d.sock\n", i }' > "$tmp/many.conf"
expect_bad "17 listeners" "many.conf:17: listen: more than 16" --config "$tmp/many.conf"
awk 'BEGIN { printf "threads = 1\n# "; for (i = 0; i < 1100; i++) printf "x"; printf "\n" }' > "$tmp/long.conf"
expect_bad "long line" "long.conf:2: line longer than 1022 bytes" --config "$tmp/long.conf"
expect_bad "missing file" "missing.conf: cannot open" --config "$tmp/missing.conf"
# flags are checked over the file, and name themselves
expect_bad "bad flag value" "^qmcd: --max-jobs: 0 is outside" --config "$EXAMPLE" --max-jobs 0
expect_bad "unknown flag" "^qmcd: unknown option '--bogus-flag'" --config "$EXAMPLE" --bogus-flag 1
# a valid check binds nothing and starts nothing
if "$QMCD" --check-config --config "$EXAMPLE" --listen "unix:$tmp/never.sock" > /dev/null &&
    [ ! -e "$tmp/never.sock" ]; then ok
else bad "--check-config created its listener"; fi
# 1M suffixes and the file's settings are what a run would use
printf 'max-points = 1M\nthreads = 1\n' > "$tmp/good.conf"
if "$QMCD" --check-config --config "$tmp/good.conf" | grep -q "good.conf: configuration is valid"; then ok
else bad "a valid file was not reported valid"; fi
finish
