#!/bin/sh
# `make install` into a temporary DESTDIR and `make uninstall` back out:
# every file lands where docs/OPERATIONS.md says (programs, static and
# shared libraries with the soname and its symlinks, headers, qmcclient.pc,
# man pages, units with this PREFIX's paths, sysusers.d and tmpfiles.d
# snippets, the example config, bash completion); the client example builds
# against the installed pkg-config file (PKG_CONFIG_PATH and
# PKG_CONFIG_SYSROOT_DIR), runs against the installed qmcd, and prints the
# points `qmc points` prints; the in-process example builds against qmc.pc
# (libqmc alone) and finds its callback and ask/tell answers equal; each man page renders with no warning; the
# installed units verify; install never overwrites a config and uninstall
# leaves a modified one.
# Env: QMC, QMCD, BUILD.  Prints "N passed, M failed".
set -u
: "${QMC:?QMC must name the qmc binary}"
: "${QMCD:?QMCD must name the qmcd binary}"
: "${BUILD:?BUILD must name the build directory}"
HERE="$(cd "$(dirname "$0")" && pwd)"
TOP="$(cd "$HERE/../.." && pwd)"
. "$(dirname "$0")/lib.sh"
check() { if eval "$1"; then ok; else bad "$2"; fi; }

D="$tmp/root"
P=/usr/local
R="$D$P"
mk() { make -s --no-print-directory -C "$TOP" BUILD="$BUILD" PREFIX=$P DESTDIR="$D" "$@"; }
if ! mk install > "$tmp/install.out" 2>&1; then
    bad "make install failed: $(tail -n 5 "$tmp/install.out")"
    echo "$pass passed, $fail failed"
    exit 1
fi

# ---- 1. the files ----------------------------------------------------------
for f in bin/qmc sbin/qmcd; do check "[ -x '$R/$f' ]" "$f not installed executable"; done
for f in lib/libqmc.a lib/libqmcproto.a lib/libqmcclient.a lib/libqmcclient.so.0.1.0 \
    lib/pkgconfig/qmcclient.pc lib/pkgconfig/qmc.pc include/qmc/client.h include/qmc/seq.h \
    include/qmc/session.h \
    share/man/man1/qmc.1 share/man/man5/qmcd.conf.5 share/man/man8/qmcd.8 \
    lib/systemd/system/qmcd.service lib/systemd/system/qmcd.socket \
    lib/sysusers.d/qmcd.conf lib/tmpfiles.d/qmcd.conf \
    share/bash-completion/completions/qmc share/doc/qmcd/OPERATIONS.md; do
    check "[ -f '$R/$f' ]" "$f not installed"
done
check "[ \"\$(readlink '$R/lib/libqmcclient.so.0')\" = libqmcclient.so.0.1.0 ]" \
    "libqmcclient.so.0 is not a link to libqmcclient.so.0.1.0"
check "[ \"\$(readlink '$R/lib/libqmcclient.so')\" = libqmcclient.so.0 ]" \
    "libqmcclient.so is not a link to the soname"
soname=$(readelf -d "$R/lib/libqmcclient.so.0.1.0" | sed -n 's/.*SONAME.*\[\(.*\)\]/\1/p')
check "[ '$soname' = libqmcclient.so.0 ]" "soname is '$soname'"
check "cmp -s '$D/etc/qmcd/qmcd.conf' '$TOP/systemd/qmcd.conf'" "example config not installed"
check "grep -q '^ExecStart=$P/sbin/qmcd --foreground --config /etc/qmcd/qmcd.conf' \
    '$R/lib/systemd/system/qmcd.service'" "installed unit's ExecStart= does not name $P/sbin/qmcd"
check "! grep -q '@[A-Z]*@' '$R/lib/systemd/system/qmcd.service' '$R/lib/pkgconfig/qmcclient.pc' \
    '$R/lib/pkgconfig/qmc.pc'" \
    "a @VARIABLE@ left unsubstituted"
check "'$R/sbin/qmcd' --check-config --config '$D/etc/qmcd/qmcd.conf' > /dev/null" \
    "the installed qmcd rejects the installed config"

# ---- 2. man pages render without warnings ------------------------------------
for m in man1/qmc.1 man5/qmcd.conf.5 man8/qmcd.8; do
    w=$(MANWIDTH=80 man --warnings -l "$R/share/man/$m" 2>&1 > "$tmp/page.txt")
    if [ -z "$w" ] && [ -s "$tmp/page.txt" ]; then ok; else bad "man $m: ${w:-empty page}"; fi
done
# every config key qmcd knows is documented in qmcd.conf(5)
for k in $("$QMCD" --help | sed -n 's/^  --\([a-z-]*\) .*/\1/p') listen log-level ready-file foreground; do
    MANWIDTH=200 man -l "$R/share/man/man5/qmcd.conf.5" 2>/dev/null | grep -q -- "^ *$k\b" ||
        bad "qmcd.conf(5) does not document $k"
done
ok

# ---- 3. the installed units and snippets -------------------------------------
mkdir -p "$tmp/units"
sed -e "s|^ExecStart=$P/sbin/qmcd|ExecStart=$R/sbin/qmcd|" -e "s|^ExecStartPre=$P/sbin/qmcd|ExecStartPre=$R/sbin/qmcd|" \
    "$R/lib/systemd/system/qmcd.service" > "$tmp/units/qmcd.service"
cp "$R/lib/systemd/system/qmcd.socket" "$tmp/units/"
out=$(cd "$tmp/units" && MANPATH="$R/share/man" systemd-analyze verify qmcd.service qmcd.socket 2>&1)
check "[ -z \"\$out\" ]" "installed units: systemd-analyze verify: $out"
mkdir -p "$tmp/sys/etc"
out=$(systemd-sysusers --root="$tmp/sys" "$R/lib/sysusers.d/qmcd.conf" 2>&1)
check "grep -q '^qmcd:' '$tmp/sys/etc/passwd' && grep -q '^qmc:' '$tmp/sys/etc/group'" \
    "sysusers.d snippet did not make the user qmcd and the group qmc: $out"
out=$(systemd-tmpfiles --root="$tmp/sys" --create "$R/lib/tmpfiles.d/qmcd.conf" 2>&1)
check "[ -d '$tmp/sys/run/qmcd' ] && [ \"\$(stat -c %a '$tmp/sys/run/qmcd')\" = 755 ]" \
    "tmpfiles.d snippet did not make /run/qmcd 0755: $out"

# ---- 4. the client example against the installed pkg-config file -------------
mkdir -p "$tmp/ex"
cp "$TOP/client/examples/points_example.c" "$TOP/client/examples/integrate_example.c" \
    "$TOP/client/examples/session_example.c" "$tmp/ex/"
# Under make sanitize the installed libraries are instrumented: so is the
# example then, or it could not load them.
EXCC=cc
EXFLAGS="-std=c11 -Wall -Wextra -O2"
if nm "$BUILD/libqmcclient.a" 2>/dev/null | grep -q __asan; then
    EXCC=clang
    EXFLAGS="$EXFLAGS -fsanitize=address,undefined"
fi
export PKG_CONFIG_PATH="$R/lib/pkgconfig" PKG_CONFIG_SYSROOT_DIR="$D"
check "pkg-config --cflags qmcclient | grep -q -- '-I$R/include'" \
    "pkg-config --cflags: $(pkg-config --cflags qmcclient 2>&1)"
if make -s -C "$tmp/ex" -f "$TOP/client/examples/Makefile" CC="$EXCC" CFLAGS="$EXFLAGS" \
    > "$tmp/ex.out" 2>&1; then ok
else bad "client example does not build against the installed qmcclient.pc: $(tail -n 5 "$tmp/ex.out")"; fi
# and statically, from the installed archives and Libs.private (libsodium,
# the handshake's HMAC, is Requires.private: linked as the system has it)
# shellcheck disable=SC2086
if $EXCC $EXFLAGS $(pkg-config --cflags qmcclient) -o "$tmp/ex/static_example" \
    "$tmp/ex/points_example.c" -L"$R/lib" -Wl,-Bstatic -lqmcclient -lqmcproto -lqmc \
    -Wl,-Bdynamic -lm -pthread $(pkg-config --libs libsodium) > "$tmp/ex-static.out" 2>&1; then ok
else bad "static link against the installed archives: $(tail -n 3 "$tmp/ex-static.out")"; fi
check "pkg-config --libs qmc | grep -q -- '-L$R/lib -lqmc'" "pkg-config --libs qmc: $(pkg-config --libs qmc 2>&1)"
unset PKG_CONFIG_PATH PKG_CONFIG_SYSROOT_DIR
# the in-process example: libqmc's callback and ask/tell APIs agree, and
# the interval covers the closed form (it exits 1 otherwise)
if "$tmp/ex/integrate_example" > "$tmp/integrate_example.txt" 2> "$tmp/integrate_example.err"; then
    check "[ \"\$(grep -c 'agrees with the callback bit for bit: yes' '$tmp/integrate_example.txt')\" = 2 ]" \
        "integrate_example: $(cat "$tmp/integrate_example.txt")"
    check "[ \"\$(grep -c 'covers the true value: yes' '$tmp/integrate_example.txt')\" = 2 ]" \
        "integrate_example: $(cat "$tmp/integrate_example.txt")"
else
    bad "integrate_example failed: $(cat "$tmp/integrate_example.txt" "$tmp/integrate_example.err")"
fi
ldd "$tmp/ex/static_example" | grep -q libqmcclient && bad "the static example loads libqmcclient.so"
S="$tmp/qmcd.sock"
"$R/sbin/qmcd" --foreground --threads 1 --listen "unix:$S" --ready-file "$tmp/ready" 2> "$tmp/qmcd.log" &
QPID=$!
pids="$pids $QPID"
wait_file "$tmp/ready"
"$QMC" points --seq sobol --dims 2 --count 8 --format csv | awk -F, '{ printf "point %d  %s, %s\n", NR - 1, $1, $2 }' > "$tmp/want.txt"
for ex in points_example static_example; do
    if LD_LIBRARY_PATH="$R/lib" "$tmp/ex/$ex" "unix:$S" > "$tmp/$ex.txt" 2> "$tmp/$ex.err"; then
        grep '^point ' "$tmp/$ex.txt" > "$tmp/$ex.points"
        check "cmp -s '$tmp/$ex.points' '$tmp/want.txt'" "$ex's points differ from qmc points"
    else
        bad "$ex failed against the installed qmcd: $(cat "$tmp/$ex.err")"
    fi
done
# the session example: a function of its own through the installed daemon,
# callback and ask/tell, the same bytes as libqmc in-process (it exits 1
# otherwise), three methods
if LD_LIBRARY_PATH="$R/lib" "$tmp/ex/session_example" "unix:$S" > "$tmp/session_example.txt" \
    2> "$tmp/session_example.err"; then
    check "[ \"\$(grep -c 'agree bit for bit: yes' '$tmp/session_example.txt')\" = 3 ]" \
        "session_example: $(cat "$tmp/session_example.txt")"
    check "[ \"\$(grep -c 'covers the true value: yes' '$tmp/session_example.txt')\" = 3 ]" \
        "session_example: $(cat "$tmp/session_example.txt")"
else
    bad "session_example failed against the installed qmcd: $(cat "$tmp/session_example.txt" "$tmp/session_example.err")"
fi
check "LD_LIBRARY_PATH='$R/lib' ldd '$tmp/ex/points_example' | grep -q '$R/lib/libqmcclient.so.0 '" \
    "the example does not load the installed libqmcclient.so.0"
kill -TERM "$QPID"
wait "$QPID" || bad "installed qmcd: SIGTERM did not exit 0"

# ---- 5. bash completion ----------------------------------------------------------
if command -v bash > /dev/null; then
    got=$(bash -c '. "$1"; COMP_WORDS=("$2" po); COMP_CWORD=1; _qmc; echo "${COMPREPLY[*]}";
        COMP_WORDS=("$2" points --se); COMP_CWORD=2; _qmc; echo "${COMPREPLY[*]}";
        COMP_WORDS=("$2" points --seq ha); COMP_CWORD=3; _qmc; echo "${COMPREPLY[*]}";
        COMP_WORDS=("$2" stats --format p); COMP_CWORD=3; _qmc; echo "${COMPREPLY[*]}"' \
        _ "$R/share/bash-completion/completions/qmc" "$R/bin/qmc" 2>&1)
    want=$(printf 'points\n--seed --seq --set-size\nhalton hammersley\nprometheus')
    check "[ \"\$got\" = \"\$want\" ]" "bash completion: got '$got'"
fi

# ---- 6. reinstall keeps a config; uninstall leaves only a modified one ----------
echo "threads = 3" >> "$D/etc/qmcd/qmcd.conf"
mk install > "$tmp/install2.out" 2>&1 || bad "second make install failed"
check "tail -n 1 '$D/etc/qmcd/qmcd.conf' | grep -q '^threads = 3'" "make install overwrote a modified config"
check "grep -q 'keeping the existing' '$tmp/install2.out'" "install did not say it kept the config"
mk uninstall > "$tmp/uninstall.out" 2>&1 || bad "make uninstall failed: $(cat "$tmp/uninstall.out")"
left=$(cd "$D" && find . ! -type d | sort | tr '\n' ' ')
check "[ '$left' = './etc/qmcd/qmcd.conf ' ]" "after uninstall (modified config) left: $left"
check "grep -q 'was modified; left in place' '$tmp/uninstall.out'" "uninstall did not say it kept the config"
rm "$D/etc/qmcd/qmcd.conf"
mk install > /dev/null 2>&1 && mk uninstall > /dev/null 2>&1 || bad "install + uninstall failed"
left=$(cd "$D" && find . ! -type d | sort | tr '\n' ' ')
check "[ -z '$left' ]" "after install + uninstall left: $left"

if grep -l -E "AddressSanitizer|LeakSanitizer|runtime error" "$tmp"/*.log "$tmp"/*.err 2>/dev/null; then
    bad "sanitizer report"
else ok; fi
finish
