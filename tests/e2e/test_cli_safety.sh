#!/bin/sh
# End-to-end checks that qmc loses, clobbers and half-writes nothing
# (issue 15, findings 3 and 4, and the client side of 5):
#   1. --out: devices and FIFOs written in place (a null device stays one,
#      as root too); read-only files refused even for root; another user's
#      file refused (as that user's neighbour, via setpriv, and as root in a
#      sticky directory); the target's mode kept, 0666 & ~umask for a new
#      file; links followed; SIGTERM, SIGHUP and SIGINT leave no *.tmp.*;
#      another user's link in a sticky, world-writable directory (the
#      last component or one inside the path, a file or an output
#      directory) refused, ours and the directory owner's followed, and
#      a link planted under a temporary file's name never written through
#      (issue 22, finding 6);
#   2. write errors: > /dev/full and --out /dev/full fail with one line;
#   3. spectrum: an unwritable --png leaves no CSV (and an old CSV as it
#      was); --png and --csv naming one file are refused;
#   4. merge: an edited part, bad seconds, a version-1 part are refused; a
#      different job names both fingerprints;
#   5. remote: a daemon with --max-points 1000 serves any count, the same
#      bytes as in-process; a daemon killed mid-stream gives "the daemon
#      closed the connection after N of M points" and leaves no temp file.
# No wall clock is asserted: waits poll for a state, with a bound only
# against hanging.  Env: QMC, QMCD.  Prints "N passed, M failed".
set -u
: "${QMC:?QMC must name the qmc binary}"
: "${QMCD:?QMCD must name the qmcd binary}"
tmp=$(mktemp -d)
# The daemon's and a background qmc's PIDs while they run (cleared once
# waited for, so that a reused PID is never signalled).
dpid=
bg=
cleanup() {
    for p in $dpid $bg; do kill "$p" 2>/dev/null; wait "$p" 2>/dev/null; done
    rm -rf "$tmp"
}
trap cleanup EXIT
trap 'exit 1' INT TERM
pass=0
fail=0
ok() { pass=$((pass + 1)); }
bad() { fail=$((fail + 1)); echo "FAIL: $*"; }
unset QMC_ENDPOINT

# one_error NAME: the last command ($rc, $tmp/err) failed with exit 2 and
# exactly one "qmc: " line.
one_error() {
    if [ "$rc" -eq 2 ] && [ "$(wc -l < "$tmp/err")" -eq 1 ] && grep -q '^qmc: ' "$tmp/err"; then ok
    else bad "$1: exit $rc, stderr: $(cat "$tmp/err")"; fi
}
# no_temp DIR NAME: no temporary file of NAME is left in DIR.
no_temp() {
    left=$(find "$1" -maxdepth 1 -name "*.tmp.*" | head -n 1)
    if [ -z "$left" ]; then ok; else bad "$2: left $left"; fi
}
mode_of() { stat -c %a "$1"; }
P="points --seq sobol --dims 3 --count 100"
"$QMC" $P > "$tmp/ref.csv"

# ---- 1. --out ----------------------------------------------------------------
d=$tmp/files
mkdir "$d"
(umask 027; "$QMC" $P --out "$d/new.csv")
if [ "$(mode_of "$d/new.csv")" = 640 ] && cmp -s "$d/new.csv" "$tmp/ref.csv"; then ok
else bad "new file under umask 027: mode $(mode_of "$d/new.csv")"; fi
(umask 0; "$QMC" $P --out "$d/new0.csv")
[ "$(mode_of "$d/new0.csv")" = 666 ] && ok || bad "new file under umask 0: $(mode_of "$d/new0.csv")"
echo old > "$d/keep.csv"; chmod 0604 "$d/keep.csv"
"$QMC" $P --out "$d/keep.csv"
if [ "$(mode_of "$d/keep.csv")" = 604 ] && cmp -s "$d/keep.csv" "$tmp/ref.csv"; then ok
else bad "replaced file's mode: $(mode_of "$d/keep.csv")"; fi

# A character device stays one, as root too.  As root the devices are our
# own nodes in $tmp (the same major/minor as /dev/null and /dev/full): a
# qmc that renamed over its target would otherwise replace the machine's
# /dev/null.  Without root, /dev itself cannot be written, so use it.
if [ "$(id -u)" -eq 0 ] && mknod -m 666 "$tmp/null" c 1 3 2>/dev/null &&
   mknod -m 666 "$tmp/full" c 1 7 2>/dev/null; then
    NULL_DEV=$tmp/null FULL_DEV=$tmp/full
else
    NULL_DEV=/dev/null FULL_DEV=/dev/full
fi
"$QMC" $P --out "$NULL_DEV" 2> "$tmp/err"; rc=$?
if [ $rc -eq 0 ] && [ -c "$NULL_DEV" ]; then ok; else bad "--out $NULL_DEV: $rc $(cat "$tmp/err")"; fi

# a FIFO is written through, and stays a FIFO (timeout only keeps a qmc
# that renames over the FIFO from hanging the reader, and the suite)
mkfifo "$d/fifo"
timeout 30 cat "$d/fifo" > "$d/from-fifo" &
bg=$!
"$QMC" $P --out "$d/fifo" 2> "$tmp/err"; rc=$?
wait "$bg"; bg=
if [ $rc -eq 0 ] && [ -p "$d/fifo" ] && cmp -s "$d/from-fifo" "$tmp/ref.csv"; then ok
else bad "--out FIFO: exit $rc, $(cat "$tmp/err")"; fi

# read-only: refused, even for root; nothing changed, nothing left
echo precious > "$d/ro"; chmod 0444 "$d/ro"
"$QMC" $P --out "$d/ro" 2> "$tmp/err"; rc=$?
one_error "--out read-only"
grep -q 'read-only' "$tmp/err" || bad "read-only message: $(cat "$tmp/err")"
[ "$(cat "$d/ro")" = precious ] && [ "$(mode_of "$d/ro")" = 444 ] && ok || bad "read-only file changed"
"$QMC" $P --out "$d" 2> "$tmp/err"; rc=$?
one_error "--out a directory"

# a symbolic link: the file it names is replaced, the link stays
echo old > "$d/real"; ln -s real "$d/link"
"$QMC" $P --out "$d/link"
if [ -L "$d/link" ] && cmp -s "$d/real" "$tmp/ref.csv"; then ok; else bad "--out through a link"; fi
ln -s missing "$d/dangling"
"$QMC" $P --out "$d/dangling" 2> "$tmp/err"; rc=$?
one_error "--out a dangling link"
no_temp "$d" "--out checks"

# another user's file.  As root: refused in a sticky directory, and
# elsewhere replaced with its owner kept.  As nobody (setpriv): root's
# files are refused, writable or not.
if [ "$(id -u)" -eq 0 ] && command -v setpriv > /dev/null && id nobody > /dev/null 2>&1; then
    chmod 0711 "$tmp"
    sh=$tmp/shared
    mkdir "$sh"; chmod 1777 "$sh"
    echo theirs > "$sh/theirs"; chown nobody "$sh/theirs"; chmod 0666 "$sh/theirs"
    "$QMC" $P --out "$sh/theirs" 2> "$tmp/err"; rc=$?
    one_error "root, another user's file in a sticky directory"
    grep -q 'sticky' "$tmp/err" || bad "sticky message: $(cat "$tmp/err")"
    [ "$(cat "$sh/theirs")" = theirs ] && ok || bad "the sticky directory's file changed"
    plain=$tmp/plain
    mkdir "$plain"
    echo theirs > "$plain/theirs"; chown nobody "$plain/theirs"; chmod 0640 "$plain/theirs"
    "$QMC" $P --out "$plain/theirs" 2> "$tmp/err"
    if [ "$(stat -c %U:%a "$plain/theirs")" = nobody:640 ] && cmp -s "$plain/theirs" "$tmp/ref.csv"
    then ok; else bad "root replacing nobody's file: $(stat -c %U:%a "$plain/theirs") $(cat "$tmp/err")"; fi
    as_nobody() { setpriv --reuid=nobody --regid=nogroup --clear-groups "$@"; }
    # nobody must be able to run qmc: a copy in $tmp, since the checkout
    # may sit below a directory only root can enter (CI's clone, /root).
    # Where even / is closed to nobody (a chroot unpacked into a 0700
    # directory), nothing can run as nobody, and these checks say so.
    cp "$QMC" "$tmp/qmc-as-nobody"; chmod 0755 "$tmp/qmc-as-nobody"
    if as_nobody "$tmp/qmc-as-nobody" --version > /dev/null 2>&1; then
        QMC_ORIG=$QMC
        QMC=$tmp/qmc-as-nobody
        echo mine > "$sh/roots"; chmod 0644 "$sh/roots"
        echo mine > "$sh/roots-rw"; chmod 0666 "$sh/roots-rw"
        as_nobody "$QMC" $P --out "$sh/roots" 2> "$tmp/err"; rc=$?
        one_error "nobody, root's 0644 file"
        as_nobody "$QMC" $P --out "$sh/roots-rw" 2> "$tmp/err"; rc=$?
        one_error "nobody, root's 0666 file in a sticky directory"
        grep -q 'belongs to uid 0' "$tmp/err" || bad "owner message: $(cat "$tmp/err")"
        [ "$(cat "$sh/roots")$(cat "$sh/roots-rw")" = minemine ] && ok || bad "nobody changed root's files"
        as_nobody sh -c "umask 022; \"$QMC\" $P --out \"$sh/nobodys\"" 2> "$tmp/err"
        if [ "$(stat -c %U:%a "$sh/nobodys" 2>/dev/null)" = nobody:644 ]; then ok
        else bad "nobody's new file: $(stat -c %U:%a "$sh/nobodys" 2>&1) $(cat "$tmp/err")"; fi
        QMC=$QMC_ORIG
    else
        echo "skip: files as nobody (nobody cannot run a program here: is / or /tmp closed to other users?)"
    fi
    no_temp "$sh" "other users' files"
    chmod 0700 "$tmp"
else
    echo "skip: other users' files (needs root, setpriv and the nobody user)"
fi

# Symbolic links in sticky world-writable directories (issue 22, finding
# 6): qmc applies the kernel's protected_symlinks rule itself, whatever
# fs.protected_symlinks says.  A link there is followed only when it
# belongs to us or to the directory's owner; every link on the way is
# checked, the last one and the ones inside the path alike.  The victims
# are root's own files in $tmp/victims; the other owners are numeric uids
# (chown needs no account for them).  Each refusal must leave the victim
# as it was and no temporary file anywhere.
if [ "$(id -u)" -eq 0 ]; then
    OTHER=54321 THIRD=54322
    v=$tmp/victims
    mkdir "$v"
    # victim NAME: a fresh file of root's holding "victim NAME"
    victim() { echo "victim $1" > "$v/$1"; chmod 0644 "$v/$1"; }
    intact() { [ "$(cat "$v/$1" 2>/dev/null)" = "victim $1" ]; }
    # refused NAME LINKPATH VICTIM: --out LINKPATH is refused with one
    # line that says why, and the victim is as it was.
    refused() {
        "$QMC" $P --out "$2" > "$tmp/out" 2> "$tmp/err"; rc=$?
        one_error "$1"
        grep -q 'symbolic link' "$tmp/err" && grep -q 'sticky' "$tmp/err" ||
            bad "$1: the message does not say why: $(cat "$tmp/err")"
        intact "$3" && ok || bad "$1: the victim changed: $(head -n 1 "$v/$3")"
    }
    # followed NAME LINKPATH VICTIM: the link is followed, the file it
    # names replaced, the link kept.
    followed() {
        "$QMC" $P --out "$2" 2> "$tmp/err"; rc=$?
        if [ $rc -eq 0 ] && [ -L "$2" ] && cmp -s "$v/$3" "$tmp/ref.csv"; then ok
        else bad "$1: exit $rc, $(cat "$tmp/err")"; fi
    }
    st=$tmp/sticky-root            # sticky, world-writable, root's
    mkdir "$st"; chmod 1777 "$st"
    so=$tmp/sticky-other           # sticky, world-writable, uid OTHER's
    mkdir "$so"; chmod 1777 "$so"; chown "$OTHER" "$so"
    sg=$tmp/sticky-group           # sticky but not world-writable
    mkdir "$sg"; chmod 1770 "$sg"

    victim a; ln -s "$v/a" "$st/a"; chown -h "$OTHER" "$st/a"
    refused "another user's link in root's sticky directory" "$st/a" a
    victim b; ln -s "$v/b" "$st/b"
    followed "our own link in a sticky directory" "$st/b" b
    victim c; ln -s "$v/c" "$so/c"; chown -h "$OTHER" "$so/c"
    followed "the directory owner's link in a sticky directory" "$so/c" c
    victim d; ln -s "$v/d" "$so/d"; chown -h "$THIRD" "$so/d"
    refused "a third user's link in another user's sticky directory" "$so/d" d
    victim e; ln -s "$v/e" "$sg/e"; chown -h "$OTHER" "$sg/e"
    followed "another user's link in a sticky directory closed to others" "$sg/e" e
    # A chain: our own link to another user's link, both in the sticky
    # directory.  The second one decides.
    victim f; ln -s "$v/f" "$st/f2"; chown -h "$OTHER" "$st/f2"; ln -s f2 "$st/f1"
    refused "our link to another user's link" "$st/f1" f
    # A link inside the path: $st/dir -> $v, another user's.
    victim g; ln -s "$v" "$st/dir"; chown -h "$OTHER" "$st/dir"
    refused "another user's link to a directory, inside the path" "$st/dir/g" g
    "$QMC" $P --out "$st/dir/new" 2> "$tmp/err"; rc=$?
    one_error "a new file through another user's directory link"
    [ ! -e "$v/new" ] && ok || bad "a new file was created through another user's link"
    # ... and a relative path that reaches the link through ".." is no way round.
    victim g
    (cd "$v" && "$QMC" $P --out "../sticky-root/dir/g") 2> "$tmp/err"; rc=$?
    one_error "another user's link reached through .."
    intact g && ok || bad "the victim changed through a relative path"
    # The link's parent decides, not where the path was typed: cd into the
    # sticky directory and name the link bare.
    victim a
    (cd "$st" && "$QMC" $P --out a) 2> "$tmp/err"; rc=$?
    one_error "another user's link named from inside the sticky directory"
    intact a && ok || bad "the victim changed through a bare name"
    for dir in "$v" "$st" "$so" "$sg"; do no_temp "$dir" "links in sticky directories"; done

    # An output directory (stability --out DIR): DIR through another
    # user's link is refused like a file ...
    STAB="stability --quick --cases jump-step-1d --methods mc"
    victim h; mkdir "$v/hdir"; ln -s "$v/hdir" "$st/hlink"; chown -h "$OTHER" "$st/hlink"
    "$QMC" $STAB --out "$st/hlink" > "$tmp/out" 2> "$tmp/err"; rc=$?
    one_error "stability --out through another user's link"
    [ -z "$(ls -A "$v/hdir")" ] && ok || bad "stability wrote through the link: $(ls -A "$v/hdir")"
    # ... and its temporary files cannot be aimed either: DIR is the
    # sticky directory itself, and another user has planted a link under
    # the name the file would have had (.NAME.tmpPID on main; the shell's
    # PID is qmc's after exec).
    victim i
    sh -c 'for n in stability.csv REPORT.md stability-matrix.dat stability.gp; do
               ln -s "$2" "$1/.$n.tmp$$"; chown -h "$3" "$1/.$n.tmp$$"; done
           shift 3; exec "$@"' _ "$st" "$v/i" "$OTHER" "$QMC" $STAB --out "$st" \
        > "$tmp/out" 2> "$tmp/err"; rc=$?
    if [ $rc -eq 0 ] && [ -s "$st/stability.csv" ] && [ ! -L "$st/stability.csv" ]; then ok
    else bad "stability --out a sticky directory: exit $rc, $(cat "$tmp/err")"; fi
    intact i && ok || bad "stability --out wrote through a planted link: $(head -n 1 "$v/i")"
    [ -z "$(find "$st" -maxdepth 1 -name '.qmc-*')" ] && ok || bad "stability left its staging directory"
else
    echo "skip: links in sticky directories (needs root to give links other owners)"
fi

# Signals while a temporary file exists: the file goes, the target stays
# as it was.  wait_for_temp polls for the state, not for a time.
wait_for_temp() {
    i=0
    while [ -z "$(find "$1" -maxdepth 1 -name "*.tmp.*" | head -n 1)" ]; do
        i=$((i + 1))
        if [ $i -gt 3000 ] || ! kill -0 "$2" 2>/dev/null; then return 1; fi
        sleep 0.01
    done
    return 0
}
BIG="points --seq sobol --dims 8 --count 4000000000"
for sig in TERM HUP; do
    s=$tmp/sig-$sig
    mkdir "$s"; echo old > "$s/target"
    # Through exec, with SIGTERM and SIGHUP at their defaults: a test run
    # under nohup inherits SIGHUP ignored, which qmc rightly keeps, and
    # would then write 4e9 points until the disk is full.
    /usr/bin/python3 -c 'import os, signal, sys
for s in (signal.SIGTERM, signal.SIGHUP):
    signal.signal(s, signal.SIG_DFL)
os.execv(sys.argv[1], sys.argv[1:])' "$QMC" $BIG --out "$s/target" 2> "$tmp/err" &
    p=$! bg=$!
    if wait_for_temp "$s" $p; then
        kill -$sig $p; wait $p; rc=$?; bg=
        if [ $rc -gt 128 ] && [ "$(cat "$s/target")" = old ]; then ok
        else bad "SIG$sig: exit $rc"; fi
        no_temp "$s" "SIG$sig during --out"
    else
        kill $p 2>/dev/null; wait $p; bg=
        bad "SIG$sig: no temporary file appeared: $(cat "$tmp/err")"
    fi
done
# SIGINT: a shell's background job ignores it, so start qmc from Python
# with SIGINT at its default (qmc keeps an ignored signal ignored).
s=$tmp/sig-INT
mkdir "$s"
/usr/bin/python3 - "$QMC" "$s" <<'EOF'
import os, signal, subprocess, sys, time
qmc, d = sys.argv[1], sys.argv[2]
p = subprocess.Popen([qmc, "points", "--seq", "sobol", "--dims", "8", "--count",
                      "4000000000", "--out", d + "/target"], stderr=subprocess.DEVNULL,
                     preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
for _ in range(3000):  # poll for the state; the bound only stops a hang
    if any(".tmp." in n for n in os.listdir(d)) or p.poll() is not None:
        break
    time.sleep(0.01)
p.send_signal(signal.SIGINT)
rc = p.wait()
left = [n for n in os.listdir(d)]
sys.exit(0 if rc == -signal.SIGINT and left == [] else 1)
EOF
[ $? -eq 0 ] && ok || bad "SIGINT during --out left $(ls "$s")"

# ---- 2. write errors -----------------------------------------------------------
"$QMC" integrate --integrand exp --dims 1 --method rqmc --n 4096 --part 1/2 > /dev/full 2> "$tmp/err"
rc=$?
one_error "--part > /dev/full"
grep -q 'No space left' "$tmp/err" || bad "/dev/full message: $(cat "$tmp/err")"
"$QMC" $P > /dev/full 2> "$tmp/err"; rc=$?
one_error "points > /dev/full"
"$QMC" $P --out "$FULL_DEV" 2> "$tmp/err"; rc=$?
one_error "points --out $FULL_DEV"
[ -c "$FULL_DEV" ] && ok || bad "--out $FULL_DEV is no longer a device"
"$QMC" discrepancy --method cd --in "$tmp/ref.csv" > /dev/full 2> "$tmp/err"; rc=$?
one_error "discrepancy > /dev/full"

# ---- 3. spectrum: all or nothing -----------------------------------------------
S="spectrum --seq sobol --count 256 --freq 4"
sp=$tmp/spec
mkdir "$sp"
"$QMC" $S --csv "$sp/a.csv" --png "$sp/nodir/a.png" 2> "$tmp/err"; rc=$?
one_error "spectrum, unwritable --png"
[ ! -e "$sp/a.csv" ] && ok || bad "spectrum left the CSV"
echo old > "$sp/b.csv"; echo old > "$sp/ro.png"; chmod 0444 "$sp/ro.png"
"$QMC" $S --csv "$sp/b.csv" --png "$sp/ro.png" 2> "$tmp/err"; rc=$?
one_error "spectrum, read-only --png"
[ "$(cat "$sp/b.csv")" = old ] && ok || bad "spectrum changed the CSV"
for pair in "x x" "x ./x" "./y $sp/y" "b.csv b.csv"; do
    set -- $pair
    (cd "$sp" && "$QMC" $S --csv "$1" --png "$2") 2> "$tmp/err"; rc=$?
    one_error "spectrum --csv $1 --png $2"
    grep -q 'both name' "$tmp/err" || bad "same-file message: $(cat "$tmp/err")"
done
ln -s b.csv "$sp/alias"
"$QMC" $S --csv "$sp/b.csv" --png "$sp/alias" 2> "$tmp/err"; rc=$?
one_error "spectrum --png a link to the CSV"
[ "$(cat "$sp/b.csv")" = old ] && ok || bad "a refused spectrum changed the CSV"
"$QMC" $S --csv "$sp/good.csv" --png "$sp/good.png"
if [ -s "$sp/good.csv" ] && [ -s "$sp/good.png" ]; then ok; else bad "spectrum wrote nothing"; fi
no_temp "$sp" "spectrum"

# ---- 4. merge: integrity and fields ----------------------------------------------
m=$tmp/merge
mkdir "$m"
A="integrate --integrand genz-gaussian --dims 3 --method rqmc --n 8192 --reps 8 --seed 1"
"$QMC" $A --json > "$m/whole"
"$QMC" $A --part 1/2 > "$m/p1"
"$QMC" $A --part 2/2 > "$m/p2"
strip() { sed 's/"seconds":[^,]*,//'; }
if "$QMC" merge --json "$m/p2" "$m/p1" | strip | cmp -s - "$(strip < "$m/whole" > "$m/w"; echo "$m/w")"
then ok; else bad "merge of good parts differs from the single run"; fi
# The writer's digest is SHA-256 of everything before its line (sha256sum
# is the independent oracle).
want=$(sed -n 's/^digest sha256 //p' "$m/p1")
got=$(sed '/^digest sha256 /,$d' "$m/p1" | sha256sum | cut -d ' ' -f 1)
if [ -n "$want" ] && [ "$want" = "$got" ] && [ "$(tail -n 1 "$m/p1")" = end ]; then ok
else bad "part digest $want, sha256sum says $got"; fi
# An edited sums line: the first block's first sum.
awk '/^sums / && !done { $5 = "0x1p+30"; done = 1 } { print }' "$m/p1" > "$m/edited"
cmp -s "$m/p1" "$m/edited" && bad "the edit changed nothing"
"$QMC" merge "$m/edited" "$m/p2" > "$tmp/out" 2> "$tmp/err"; rc=$?
one_error "merge, an edited sums line"
grep -q 'digest does not match' "$tmp/err" && [ ! -s "$tmp/out" ] && ok || bad "edited: $(cat "$tmp/err")"
for v in nan -nan inf -1e308 -1 1e999 0x1p+1000 '' ' 1'; do
    sed "s/^seconds .*/seconds $v/" "$m/p1" > "$m/bad"
    "$QMC" merge "$m/bad" "$m/p2" > "$tmp/out" 2> "$tmp/err"; rc=$?
    one_error "merge, seconds '$v'"
    grep -q 'line 4' "$tmp/err" || bad "seconds '$v' message: $(cat "$tmp/err")"
done
sed 's/^blocks .*/blocks -16/' "$m/p1" > "$m/bad"
"$QMC" merge "$m/bad" "$m/p2" 2> "$tmp/err"; rc=$?
one_error "merge, blocks -16"
sed '1s/.*/qmc-partial 1/' "$m/p1" > "$m/bad"
"$QMC" merge "$m/bad" "$m/p2" 2> "$tmp/err"; rc=$?
one_error "merge, a version-1 part"
"$QMC" integrate --integrand genz-gaussian --dims 3 --method rqmc --n 8192 --reps 8 --seed 2 \
    --part 2/2 > "$m/other"
"$QMC" merge "$m/p1" "$m/other" 2> "$tmp/err"; rc=$?
one_error "merge, a different job"
fp1=$(sed -n 's/^fingerprint //p' "$m/p1"); fp2=$(sed -n 's/^fingerprint //p' "$m/other")
if [ "$fp1" != "$fp2" ] && grep -q "$fp1" "$tmp/err" && grep -q "$fp2" "$tmp/err"; then ok
else bad "fingerprint message should name $fp1 and $fp2: $(cat "$tmp/err")"; fi
head -c 300 "$m/p2" > "$m/cut"
"$QMC" merge "$m/p1" "$m/cut" 2> "$tmp/err"; rc=$?
one_error "merge, a truncated part"

# ---- 5. remote: splitting past max-points, a daemon that dies ------------------------
# start_daemon DIR: a daemon on DIR/qmcd.sock and a loopback port, max-points
# 1000; sets $dpid, $UNIX and $TCP.
start_daemon() {
    "$QMCD" --foreground --listen "unix:$1/qmcd.sock" --listen tcp:127.0.0.1:0 \
        --ready-file "$1/ready" --max-points 1000 --log-level warning 2> "$1/qmcd.log" &
    dpid=$!
    i=0
    while [ ! -s "$1/ready" ]; do
        if ! kill -0 "$dpid" 2>/dev/null || [ $i -gt 2000 ]; then
            echo "FAIL: qmcd not ready:"; cat "$1/qmcd.log"; return 1
        fi
        i=$((i + 1))
        sleep 0.01
    done
    UNIX="unix:$1/qmcd.sock"
    TCP=$(grep '^tcp:' "$1/ready" | head -n 1)
}
r=$tmp/remote
mkdir "$r"
if [ -x "$QMCD" ] && start_daemon "$r"; then
    n=0
    while read -r args; do
        n=$((n + 1))
        if [ $((n % 2)) -eq 0 ]; then ep=$UNIX; else ep=$TCP; fi
        "$QMC" points $args > "$r/l" 2> "$r/le"
        "$QMC" points $args --connect "$ep" > "$r/r" 2> "$r/re"
        if [ -s "$r/l" ] && cmp -s "$r/l" "$r/r"; then ok
        else bad "split points $args ($ep): $(cat "$r/re")"; fi
    done <<EOF
--seq sobol --dims 3 --count 2500
--seq sobol --dims 3 --count 2500 --format f64
--seq sobol --dims 2 --count 20000 --start 123 --scramble owen --seed 7 --format f64
--seq sobol --dims 5 --count 1001 --shuffle --scramble owen --seed 3 --format u32
--seq halton --dims 4 --count 3001 --scramble faure --format f32
--seq hammersley --dims 2 --count 2999 --set-size 5000 --start 1000
--seq lhs --dims 3 --count 4096 --seed 9 --format f64
--seq stratified --dims 2 --count 4096 --seed 4 --format f64
--seq random --dims 2 --count 1000 --seed 5
--seq random --dims 2 --count 1 --start 999 --seed 5
EOF
    "$QMC" points --seq sobol --dims 4 --count 5000 --format f64 --out "$r/lo"
    "$QMC" points --seq sobol --dims 4 --count 5000 --format f64 --out "$r/ro" --connect "$UNIX"
    cmp -s "$r/lo" "$r/ro" && ok || bad "split points --out differs"
    "$QMC" spectrum --seq sobol --scramble owen --count 3000 --freq 3 --reps 2 \
        --csv "$r/l.csv" --png "$r/l.png"
    "$QMC" spectrum --seq sobol --scramble owen --count 3000 --freq 3 --reps 2 \
        --csv "$r/r.csv" --png "$r/r.png" --connect "$TCP"
    cmp -s "$r/l.csv" "$r/r.csv" && cmp -s "$r/l.png" "$r/r.png" && ok || bad "split spectrum differs"
    # a range error is found before any output, as in-process
    "$QMC" points --seq hammersley --set-size 1500 --start 100 --count 1450 --connect "$UNIX" \
        > "$tmp/out" 2> "$tmp/err"; rc=$?
    one_error "split request past the set"
    [ ! -s "$tmp/out" ] && ok || bad "past the set: $(wc -c < "$tmp/out") bytes on stdout"

    # The daemon dies mid-stream: the message says how far it got.
    for kind in unix tcp; do
        if [ $kind = unix ]; then ep=$UNIX; else ep=$TCP; fi
        rm -f "$r/stream"
        "$QMC" points --seq sobol --dims 4 --count 400000000 --format f64 --connect "$ep" \
            > "$r/stream" 2> "$tmp/err" &
        p=$! bg=$!
        i=0
        while [ ! -s "$r/stream" ] && kill -0 $p 2>/dev/null && [ $i -lt 3000 ]; do
            i=$((i + 1)); sleep 0.01
        done
        kill -KILL "$dpid"; wait "$dpid" 2>/dev/null; dpid=
        wait $p; rc=$?; bg=
        one_error "daemon killed mid-stream ($ep)"
        if grep -q 'the daemon closed the connection after [0-9]* of 400000000 points' "$tmp/err"
        then ok; else bad "mid-stream message ($ep): $(cat "$tmp/err")"; fi
        got=$(sed -n 's/.*after \([0-9]*\) of.*/\1/p' "$tmp/err")
        [ "$((got * 32))" -eq "$(wc -c < "$r/stream")" ] && ok ||
            bad "the message says $got points, stdout holds $(wc -c < "$r/stream") bytes"
        rm -f "$r/qmcd.sock" "$r/ready"
        start_daemon "$r" || break
    done
    # ... and with --out, leaves neither a temporary file nor a target.
    "$QMC" points --seq sobol --dims 4 --count 400000000 --format f64 --connect "$UNIX" \
        --out "$r/never" 2> "$tmp/err" &
    p=$! bg=$!
    if wait_for_temp "$r" $p; then
        kill -KILL "$dpid"; wait "$dpid" 2>/dev/null; dpid=
        wait $p; rc=$?; bg=
        one_error "daemon killed during --out"
        [ ! -e "$r/never" ] && ok || bad "daemon death left the --out target"
        no_temp "$r" "daemon death during --out"
    else
        kill $p 2>/dev/null; wait $p; bg=
        bad "--out never started: $(cat "$tmp/err")"
    fi
else
    bad "no daemon at $QMCD"
fi

echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
