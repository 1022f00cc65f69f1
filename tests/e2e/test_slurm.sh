#!/bin/sh
# docs/OPERATIONS.md's batch recipes on a real scheduler: a one-node Slurm
# cluster of the test's own (Debian's slurmctld, slurmd and munge; a munge
# key it makes; slurm.conf, state, spool, pid and log files all in the
# scratch directory; loopback and free private ports only), started once
# for every case and stopped by PID at exit, on failure too.  Cases:
#   1. integration: a job array of 8 tasks, task i running
#      `qmc integrate ... --part $((i+1))/8`, and a merge job that waits for
#      it (--dependency=afterok): its `qmc merge --json` equals one in-process
#      run byte for byte but for "seconds", for rqmc, mc and a scene;
#   2. pixels (when this qmc has `qmc pixels`): a tile split over 4 array
#      tasks by sample range; the parts, put side by side per pixel, equal
#      one request's bytes;
#   3. a task killed while it runs (scancel of one array task): the merge
#      that waits for the array does not run (Slurm 22.05 keeps it PENDING
#      with Reason=DependencyNeverSatisfied: unless DependencyParameters
#      has kill_invalid_depend, it is neither run nor cancelled), also
#      after every other task has finished; re-running that one task and pointing the merge at it
#      (scontrol update ... dependency=afterok:RERUN) completes the merge,
#      equal to one run;
#   4. the part and pixel scripts it submits are the ones
#      docs/OPERATIONS.md shows (but for qmc's path and the hold lines).
# The job completion log (jobcomp/filetxt, in the scratch directory) is the
# record of what ran: no accounting daemon is needed, so no sacct.
# It prints the Slurm version it started and how many tasks completed.
# Skips (one line naming what is missing) only when a program of the
# packages is absent: build-aux/deps.sh test installs them.
# Env: QMC.  Prints "N passed, M failed".
set -u
: "${QMC:?QMC must name the qmc binary}"
PY=/usr/bin/python3
HERE="$(cd "$(dirname "$0")" && pwd)"
SCENES="$(cd "$HERE/../scenes" && pwd)"

for prog in munged:munge mungekey:munge slurmctld:slurmctld slurmd:slurmd \
            sbatch:slurm-client squeue:slurm-client scontrol:slurm-client \
            scancel:slurm-client sinfo:slurm-client; do
    if ! command -v "${prog%%:*}" > /dev/null 2>&1; then
        echo "skip: test_slurm needs ${prog%%:*} (Debian package ${prog#*:}; sh build-aux/deps.sh test installs it)"
        exit 0
    fi
done

. "$HERE/lib.sh"
# A cluster left behind outlives the test: a closed pipe (sh test | head)
# or a hangup ends the test through cleanup too, as INT and TERM do.
trap 'exit 1' HUP PIPE INT TERM

# A caller inside a Slurm job (or with SBATCH_* defaults) would hand its
# job's settings to every sbatch here: the test's cluster starts clean.
for v in $(env | sed -n 's/^\(\(SLURM\|SBATCH\|SQUEUE\|SINFO\|SCANCEL\|SCONTROL\)_[A-Za-z0-9_]*\)=.*/\1/p'); do
    unset "$v"
done
export SLURM_CONF="$tmp/slurm.conf"

# ---- the cluster --------------------------------------------------------------
MUNGED='' SLURMCTLD='' SLURMD=''
# Jobs first (their slurmstepd processes report to slurmctld, so it must
# outlive them), then slurmd, slurmctld and munged, each by PID.
stop_cluster() {
    if [ -n "$SLURMCTLD" ] && kill -0 "$SLURMCTLD" 2>/dev/null; then
        jobs_left=$(squeue -h -o %A 2>/dev/null)
        # shellcheck disable=SC2086
        [ -z "$jobs_left" ] || scancel $jobs_left 2>/dev/null
        e2e_i=0
        while [ -n "$(squeue -h -o %A 2>/dev/null)" ] && [ $e2e_i -lt 200 ]; do
            sleep 0.05; e2e_i=$((e2e_i + 1))
        done
    fi
    for d in SLURMD SLURMCTLD MUNGED; do
        eval "p=\$$d"
        [ -n "$p" ] || continue
        kill "$p" 2>/dev/null
        wait_exit "$p" 10 || kill -9 "$p" 2>/dev/null
        wait "$p" 2>/dev/null
        eval "$d="
    done
}
cleanup() {
    stop_cluster
    for e2e_p in $pids; do kill -9 "$e2e_p" 2>/dev/null; done
    if [ -n "${KEEP_TMP:-}" ]; then echo "kept $tmp"; else rm -rf "$tmp"; fi
}

# Fails the test at once with a daemon's log: nothing below can run.
give_up() {
    bad "$1"
    for f in "$tmp"/munged.log "$tmp"/slurmctld.log "$tmp"/slurmd.log "$tmp"/slurmd.err; do
        [ -s "$f" ] && { echo "--- $f"; tail -n 15 "$f"; }
    done
    finish
}

# Polls COMMAND (a shell string) in 50 ms steps for at most SECONDS until
# it succeeds; 1 if it never did.
poll() {
    e2e_i=0
    e2e_lim=$(($1 * 20))
    while ! eval "$2"; do
        e2e_i=$((e2e_i + 1))
        [ $e2e_i -lt $e2e_lim ] || return 1
        sleep 0.05
    done
}

mungekey --create --keyfile="$tmp/munge.key" 2> "$tmp/munged.log" ||
    give_up "mungekey could not make a key"
# -f: the scratch directory is the test's own, whatever munged thinks of /tmp.
munged --foreground --force --key-file="$tmp/munge.key" --socket="$tmp/munge.sock" \
    --pid-file="$tmp/munged.pid" --seed-file="$tmp/munged.seed" \
    --log-file="$tmp/munged.log" 2>> "$tmp/munged.log" &
MUNGED=$!
poll 10 '[ -S "$tmp/munge.sock" ] || ! kill -0 $MUNGED 2>/dev/null'
[ -S "$tmp/munge.sock" ] || give_up "munged did not make its socket"

# Two free loopback ports for slurmctld and slurmd (the kernel's choice,
# released just before the daemons bind them).
ports=$("$PY" -c '
import socket
s = [socket.socket() for _ in range(2)]
for x in s:
    x.bind(("127.0.0.1", 0))
print(*(x.getsockname()[1] for x in s))')
CTLD_PORT=${ports% *}
SLURMD_PORT=${ports#* }
host=$(uname -n | cut -d. -f1)
mkdir -p "$tmp/state" "$tmp/spool"
: > "$tmp/plugstack.conf"
# slurmctld accepts only the host SlurmctldHost names; the node is a name
# of ours on 127.0.0.1.  The daemons run as the test's user (root or not:
# jobs then run as that user too).  CPUs=16 (config_overrides: whatever
# the machine has) lets the 8 tasks of a case, 2 CPUs each, run at once,
# and batch_sched_delay=0 starts jobs as they come instead of in rounds
# 3 s apart (the default, for clusters that take thousands of jobs a
# second).  No cgroups, no systemd: linuxproc tracks a job's processes by
# parentage, task/none binds nothing.  MailProg is never called (no job
# asks for mail); naming a program that exists keeps slurmctld quiet.
cat > "$SLURM_CONF" <<EOF
ClusterName=qmctest
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$CTLD_PORT
SlurmdPort=$SLURMD_PORT
SlurmUser=$(id -un)
SlurmdUser=$(id -un)
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$tmp/munge.sock
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool/%n
SlurmctldPidFile=$tmp/slurmctld.pid
SlurmdPidFile=$tmp/slurmd.pid
SlurmctldLogFile=$tmp/slurmctld.log
SlurmdLogFile=$tmp/slurmd.log
PlugStackConfig=$tmp/plugstack.conf
TmpFS=$tmp
MailProg=/bin/true
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/filetxt
JobCompLoc=$tmp/jobcomp.txt
MpiDefault=none
SchedulerParameters=batch_sched_delay=0
ReturnToService=2
SlurmdParameters=config_overrides
NodeName=qmcnode NodeHostname=$host NodeAddr=127.0.0.1 CPUs=16 State=UNKNOWN
PartitionName=qmc Nodes=qmcnode Default=YES MaxTime=INFINITE State=UP
EOF
slurmctld -D -f "$SLURM_CONF" 2> "$tmp/slurmctld.err" &
SLURMCTLD=$!
# Slurm 22.05's slurmd loads its cgroup plugin whatever the task and
# proctrack plugins are, and gives up when /sys/fs/cgroup is empty (a bare
# chroot's is).  Then it runs in a private mount namespace of its own where
# the hierarchies /proc/self/cgroup names are mounted again (v1, or the v2
# tree), which nothing outside sees (unshare -m makes mounts private;
# unshare execs, so $! is slurmd).
if [ -n "$(ls -A /sys/fs/cgroup 2>/dev/null)" ] && [ -z "${QMC_TEST_SLURMD_NS:-}" ]; then
    slurmd -D -N qmcnode -f "$SLURM_CONF" 2> "$tmp/slurmd.err" &
else
    echo "slurm: /sys/fs/cgroup is empty here: slurmd mounts its cgroups in a private mount namespace"
    # shellcheck disable=SC2016
    # --propagation unchanged: in a chroot / is no mount point, so
    # unshare's default (making / private) fails; /sys is one, and is made
    # private here, in the new namespace only.
    unshare -m --propagation unchanged sh -c '
        set -e
        mount --make-rprivate /sys
        mount -t tmpfs -o mode=755 qmc-cgroups /sys/fs/cgroup
        if [ "$(cut -d: -f1 /proc/self/cgroup)" = 0 ]; then
            umount /sys/fs/cgroup; mount -t cgroup2 none /sys/fs/cgroup
        else
            for h in $(cut -d: -f2 /proc/self/cgroup | grep -v "^$"); do
                d=${h#name=}; mkdir -p "/sys/fs/cgroup/$d"
                mount -t cgroup -o "$h" none "/sys/fs/cgroup/$d"
            done
        fi
        exec slurmd -D -N qmcnode -f "$1"' sh "$SLURM_CONF" 2> "$tmp/slurmd.err" &
fi
SLURMD=$!
node_idle() { [ "$(sinfo -h -n qmcnode -o %t 2>/dev/null)" = idle ]; }
poll 30 'node_idle || ! kill -0 $SLURMCTLD 2>/dev/null || ! kill -0 $SLURMD 2>/dev/null'
node_idle || give_up "the Slurm node did not come up (slurmctld pid $SLURMCTLD, slurmd pid $SLURMD)"
ctld_version=$(scontrol show config | sed -n 's/^SLURM_VERSION *= *//p')
node_version=$(sinfo -h -n qmcnode -o %v)
munge_version=$(munged --version 2>&1 | head -n 1 | cut -d' ' -f1)
echo "slurm: slurmctld $ctld_version and slurmd $node_version up on" \
     "127.0.0.1:$CTLD_PORT,$SLURMD_PORT ($munge_version)"

# submit DIR SBATCH-ARGS...: sbatch in DIR (as docs/OPERATIONS.md runs it
# in the job's directory); prints the job id.
submit() {
    (cd "$1" && shift && sbatch --parsable "$@") | cut -d';' -f1
}
# jobstate ID: the JobState scontrol gives for a job or array task.
jobstate() { scontrol -o show job "$1" 2>/dev/null | sed -n 's/.* JobState=\([A-Z_]*\) .*/\1/p' | head -n 1; }
reason() { scontrol -o show job "$1" 2>/dev/null | sed -n 's/.* Reason=\([^ ]*\) .*/\1/p' | head -n 1; }
# completions ARRAY STATE: the array's tasks the completion log has in STATE.
completions() {
    e2e_n=$(grep -c " JobState=$2 .* ArrayJobId=$1 " "$tmp/jobcomp.txt" 2>/dev/null)
    echo "${e2e_n:-0}"
}

# strip JSON-FILE: the merged or single result without its measured seconds.
strip() { sed 's/"seconds":[^,]*,//' "$1"; }

# ---- 1. integration parts: write the scripts, submit everything ----------------
# The part script is docs/OPERATIONS.md's; P is written into it, since a
# re-run of one index (sbatch --array=K) has SLURM_ARRAY_TASK_COUNT=1.
# The hold file is the test's one addition: the task of part K, while a
# file hold-K exists, says it runs (running-K) and waits there, for at
# most 2 minutes, until the test kills it.
part_script() {
    cat <<EOF
#!/bin/sh
#SBATCH --job-name=qmc-part
#SBATCH --array=0-$(($2 - 1))
#SBATCH --cpus-per-task=2
#SBATCH --output=log/%A_%a.out
JOB='$1'
P=$2
K=\$((SLURM_ARRAY_TASK_ID + 1))
if [ -e hold-\$K ]; then
    : > running-\$K
    i=0; while [ -e hold-\$K ] && [ \$i -lt 1200 ]; do sleep 0.1; i=\$((i + 1)); done
fi
exec "$QMC" integrate \$JOB --threads "\$SLURM_CPUS_PER_TASK" --part \$K/\$P > part-\$K.txt
EOF
}
merge_cmd="\"$QMC\" merge --json part-*.txt > result.json"

cases="rqmc mc scene"
opts_rqmc="--integrand genz-gaussian --dims 6 --method rqmc --n 4096 --reps 16 --seed 9"
opts_mc="--integrand genz-oscillatory --dims 5 --method mc --n 700000 --seed 4"
opts_scene="--scene $SCENES/phong_sphere.scene --method rqmc --n 2048 --reps 8"
# The killed case: a job of its own, part 3 of 8 held and then cancelled.
opts_killed="--integrand genz-corner-peak --dims 4 --method rqmc --n 2048 --reps 8 --seed 2"

for c in $cases killed; do
    eval "opts=\$opts_$c"
    mkdir -p "$tmp/$c/log"
    part_script "$opts" 8 > "$tmp/$c/part.sbatch"
done
: > "$tmp/killed/hold-3"
for c in $cases killed; do
    arr=$(submit "$tmp/$c" part.sbatch)
    mrg=$(submit "$tmp/$c" --dependency=afterok:"$arr" --output=log/merge.out --wrap "$merge_cmd")
    if [ -z "$arr" ] || [ -z "$mrg" ]; then give_up "$c: sbatch gave no job ids"; fi
    eval "arr_$c=\$arr mrg_$c=\$mrg"
done

# ---- 2. pixels: 4 tasks, samples k*N/4 .. (k+1)*N/4 - 1 of each pixel ---------
PIX_SPP=64 PIX_K=4 PIX_DIMS=6 PIX_W=16 PIX_H=8
pix_args="--sampler zsobol --resolution 64,48 --spp $PIX_SPP --seed 5"
pix_args="$pix_args --tile 8,4,$PIX_W,$PIX_H --dims $PIX_DIMS --format u32"
if "$QMC" help pixels > /dev/null 2>&1; then
    mkdir -p "$tmp/pixels/log"
    cat > "$tmp/pixels/pixels.sbatch" <<EOF
#!/bin/sh
#SBATCH --job-name=qmc-pixels
#SBATCH --array=0-$((PIX_K - 1))
#SBATCH --output=log/%A_%a.out
N=$PIX_SPP K=$PIX_K k=\$SLURM_ARRAY_TASK_ID
exec "$QMC" pixels $pix_args \\
    --samples \$((k * N / K)):\$((N / K)) --out node-\$k.u32
EOF
    arr_pixels=$(submit "$tmp/pixels" pixels.sbatch)
    [ -n "$arr_pixels" ] || give_up "pixels: sbatch gave no job id"
else
    arr_pixels=
    echo "skip: the pixels case (this qmc has no 'qmc pixels')"
fi

# The scripts are the ones docs/OPERATIONS.md shows, but for the path of
# qmc and the hold lines: doc_script NAME FILE compares the doc's script
# with that job name (exactly one) and FILE.
doc_script() {
    "$PY" - "$HERE/../../docs/OPERATIONS.md" "$1" "$2" "$QMC" <<'PYEOF'
import re, sys
doc, name, path, qmc = sys.argv[1:5]
pat = r"```sh\n(#!/bin/sh\n#SBATCH --job-name=%s\n.*?)```" % re.escape(name)
shown = re.findall(pat, open(doc).read(), re.S)
mine = open(path).read().replace('"%s"' % qmc, "qmc")
mine = re.sub(r"if \[ -e hold-\$K \]; then\n.*?\nfi\n", "", mine, flags=re.S)
if len(shown) != 1:
    sys.exit("%d scripts named %s in the doc" % (len(shown), name))
if shown[0] != mine:
    sys.exit("the doc shows\n%sthe test runs\n%s" % (shown[0], mine))
PYEOF
}
if out=$(doc_script qmc-part "$tmp/rqmc/part.sbatch" 2>&1); then ok
else bad "part.sbatch is not docs/OPERATIONS.md's: $out"; fi
if [ -n "$arr_pixels" ]; then
    if out=$(doc_script qmc-pixels "$tmp/pixels/pixels.sbatch" 2>&1); then ok
    else bad "pixels.sbatch is not docs/OPERATIONS.md's: $out"; fi
fi

# The single runs the merges must equal, in-process, while Slurm works.
for c in $cases killed; do
    eval "opts=\$opts_$c"
    # shellcheck disable=SC2086
    "$QMC" integrate $opts --json > "$tmp/$c/single.json" 2> "$tmp/$c/single.err" ||
        bad "$c: the single run failed: $(cat "$tmp/$c/single.err")"
done
if [ -n "$arr_pixels" ]; then
    # shellcheck disable=SC2086
    "$QMC" pixels $pix_args --out "$tmp/pixels/whole.u32" 2> "$tmp/pixels/whole.err" ||
        bad "pixels: the whole tile failed: $(cat "$tmp/pixels/whole.err")"
fi

# ---- 3. the killed task -------------------------------------------------------------
# Part 3 is RUNNING (its task made running-3) when scancel kills it.
if poll 60 '[ -e "$tmp/killed/running-3" ]' && [ "$(jobstate "${arr_killed}_2")" = RUNNING ]; then ok
else bad "killed: task 2 (part 3) never ran: $(jobstate "${arr_killed}_2")"; fi
scancel "${arr_killed}_2"
if poll 60 '[ "$(jobstate "${arr_killed}_2")" = CANCELLED ]'; then ok
else bad "killed: task 2 is $(jobstate "${arr_killed}_2") after scancel, not CANCELLED"; fi
# Once every other task has completed, the merge still has not run: Slurm
# 22.05 marks the dependency failed and holds the job.
if poll 90 '[ "$(completions "$arr_killed" COMPLETED)" -eq 7 ]'; then ok
else bad "killed: $(completions "$arr_killed" COMPLETED) of the 7 other tasks completed"; fi
poll 30 '[ "$(reason "$mrg_killed")" = DependencyNeverSatisfied ]'
st=$(jobstate "$mrg_killed") why=$(reason "$mrg_killed")
dep=$(scontrol -o show job "$mrg_killed" | sed -n 's/.* Dependency=\([^ ]*\) .*/\1/p')
if [ "$st" = PENDING ] && [ "$why" = DependencyNeverSatisfied ] &&
   [ "$dep" = "afterok:${arr_killed}_*(failed)" ] && [ ! -e "$tmp/killed/result.json" ] &&
   ! grep -q "^JobId=$mrg_killed " "$tmp/jobcomp.txt"; then ok
else bad "killed: the merge is $st ($why, dependency $dep), result.json $(ls "$tmp/killed/result.json" 2>&1)"; fi
if squeue -h -j "$mrg_killed" -o '%T %r' 2>/dev/null | grep -qx 'PENDING DependencyNeverSatisfied'; then ok
else bad "killed: squeue shows the merge as '$(squeue -h -j "$mrg_killed" -o '%T %r' 2>&1)'"; fi
# Re-run part 3 alone (the same script, --array on the command line wins)
# and let the held merge wait for that instead.
rm -f "$tmp/killed/hold-3"
rerun=$(submit "$tmp/killed" --array=2 part.sbatch)
if [ -n "$rerun" ] && scontrol update jobid="$mrg_killed" dependency=afterok:"$rerun"; then ok
else bad "killed: the re-run ($rerun) or the merge's new dependency failed"; fi

# ---- every job ends --------------------------------------------------------------
# ... or only jobs are left that wait for a failed one, and will not move.
stuck() { ! squeue -h -o %r | grep -qvx DependencyNeverSatisfied; }
if poll 120 'stuck' && [ -z "$(squeue -h -o %A)" ]; then ok
else bad "jobs still queued: $(squeue -h -o '%i %T %r' | tr '\n' ';')"; fi

for c in $cases killed; do
    eval "arr=\$arr_$c mrg=\$mrg_$c"
    n=$(completions "$arr" COMPLETED)
    [ "$c" = killed ] && n=$((n + $(completions "$rerun" COMPLETED)))
    if [ "$n" -eq 8 ]; then ok; else bad "$c: $n of 8 array tasks completed"; fi
    if [ "$(jobstate "$mrg")" = COMPLETED ] && [ -s "$tmp/$c/result.json" ]; then
        if [ "$(strip "$tmp/$c/result.json")" = "$(strip "$tmp/$c/single.json")" ] &&
           grep -q '"estimate":' "$tmp/$c/result.json"; then ok
        else bad "$c: the merged result differs from the single run:
$(cat "$tmp/$c/result.json")
$(cat "$tmp/$c/single.json")"; fi
    else
        bad "$c: the merge is $(jobstate "$mrg"): $(cat "$tmp/$c/log/merge.out" 2>&1)"
    fi
done
# The merge ran only after the re-run: its start is not before the re-run's end.
rr_end=$(sed -n "s/.* JobState=COMPLETED .*EndTime=\([^ ]*\) .* ArrayJobId=$rerun .*/\1/p" "$tmp/jobcomp.txt")
m_start=$(sed -n "s/^JobId=$mrg_killed .* StartTime=\([^ ]*\) .*/\1/p" "$tmp/jobcomp.txt")
if [ -n "$rr_end" ] && [ -n "$m_start" ] && ! expr "$m_start" \< "$rr_end" > /dev/null; then ok
else bad "killed: the merge started at '$m_start', the re-run ended at '$rr_end'"; fi
if [ "$(completions "$arr_killed" CANCELLED)" -eq 1 ]; then ok
else bad "killed: the completion log has $(completions "$arr_killed" CANCELLED) cancelled tasks, not 1"; fi

if [ -n "$arr_pixels" ]; then
    n=$(completions "$arr_pixels" COMPLETED)
    if [ "$n" -eq "$PIX_K" ]; then ok; else bad "pixels: $n of $PIX_K array tasks completed"; fi
    # Per pixel (rows y, then x), node 0's samples, then node 1's, ...:
    # the order of one request, which must be the same bytes.
    if "$PY" - "$tmp/pixels" "$PIX_K" "$PIX_SPP" $((PIX_W * PIX_H)) "$PIX_DIMS" > "$tmp/why" 2>&1 <<'PYEOF'
import sys
d, K, spp, pixels, dims = sys.argv[1], *map(int, sys.argv[2:6])
per = spp // K * dims * 4          # bytes of one pixel's run on one node
nodes = [open("%s/node-%d.u32" % (d, k), "rb").read() for k in range(K)]
for k, b in enumerate(nodes):
    assert len(b) == pixels * per, "node %d: %d bytes" % (k, len(b))
assert len(set(nodes)) == K, "two nodes wrote the same bytes"
out = b"".join(b[p * per:(p + 1) * per] for p in range(pixels) for b in nodes)
whole = open(d + "/whole.u32", "rb").read()
assert len(whole) == pixels * spp * dims * 4, "whole: %d bytes" % len(whole)
assert out == whole, "the reassembled nodes differ from one request"
PYEOF
    then ok; else bad "pixels: $(tail -n 1 "$tmp/why")"; fi
fi

total=$(grep -c ' JobState=COMPLETED .* ArrayTaskId=[0-9]* ' "$tmp/jobcomp.txt")
merges=$(grep ' JobState=COMPLETED ' "$tmp/jobcomp.txt" | grep -vc ' ArrayJobId=')
cancelled=$(grep -c ' JobState=CANCELLED ' "$tmp/jobcomp.txt")
failed=$(grep -c ' JobState=FAILED ' "$tmp/jobcomp.txt")
echo "slurm $ctld_version: $total array tasks and $merges merge jobs completed," \
     "$cancelled cancelled, $failed failed"
finish
