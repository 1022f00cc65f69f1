#!/usr/bin/python3
"""bench_command.py - where the time of `qmc integrate --command` goes.

`qmc integrate --command 'PROGRAM'` runs a program of the user's as f; the
program should spend most of the time, not qmc (issue 21).  This runs a
vectorised numpy program (it reads a whole batch, evaluates it at once,
answers it) in both formats on the same job (d = 4, rqmc 16 x 65536 =
1048576 points in 16 batches of 65536) and splits the CPU time
(user + sys):

  - the program's own, from getrusage(RUSAGE_SELF) inside it at its exit
    (interpreter start and numpy import included: they are the program's);
  - qmc's, from wait4() on qmc, which also counts the children qmc waited
    for (the shell and the program), minus the program's own.

CPU time rather than wall time, so that other load on a shared machine
moves the split little.  Each case runs REPEAT times; the run with the
least total CPU is reported.  Usage: bench_command.py QMC [OUTDIR]
(writes OUTDIR/command.csv when given).  Exit 0 unless a run fails.
"""
import json
import os
import subprocess
import sys
import tempfile
import time

REPEAT = 3
DIMS = 4

PROGRAM = r'''
import atexit, json, os, resource, struct, sys
import numpy as np

def dump():
    r = resource.getrusage(resource.RUSAGE_SELF)
    with open(os.environ["QMC_BENCH_RUSAGE"], "w") as f:
        json.dump({"cpu": r.ru_utime + r.ru_stime}, f)
atexit.register(dump)
fmt, d = sys.argv[1], int(sys.argv[2])

def f(x):                                  # prod 2 x_j: integral 1
    return np.prod(2.0 * x, axis=1)

if fmt == "f64":
    inp, out = sys.stdin.buffer, sys.stdout.buffer
    while True:
        h = inp.read(4)
        if len(h) < 4:
            sys.exit(0)
        (n,) = struct.unpack("<I", h)
        x = np.frombuffer(inp.read(n * d * 8), dtype="<f8").reshape(n, d)
        out.write(f(x).astype("<f8").tobytes())
        out.flush()
buf = b""
while True:
    end = buf.find(b"\n\n")
    while end < 0:
        chunk = os.read(0, 1 << 20)
        if not chunk:
            sys.exit(0)
        buf += chunk
        end = buf.find(b"\n\n", max(0, len(buf) - len(chunk) - 1))
    batch, buf = buf[:end + 1], buf[end + 2:]
    x = np.array(batch.split(), dtype=float).reshape(-1, d)
    os.write(1, ("\n".join(map(repr, f(x).tolist())) + "\n").encode())
'''


def run(qmc, prog, fmt, scratch):
    ru_file = os.path.join(scratch, "rusage.json")
    env = dict(os.environ, QMC_BENCH_RUSAGE=ru_file)
    args = [qmc, "integrate", "--dims", str(DIMS), "--command",
            "/usr/bin/python3 %s %s %d" % (prog, fmt, DIMS), "--command-format", fmt,
            "--method", "rqmc", "--n", "65536", "--reps", "16", "--exact", "1", "--json"]
    t0 = time.monotonic()
    p = subprocess.Popen(args, env=env, stdout=subprocess.PIPE)
    out = p.stdout.read()
    _, status, ru = os.wait4(p.pid, 0)
    wall = time.monotonic() - t0
    if status != 0:
        sys.exit("bench_command: qmc %s failed (status %d)" % (fmt, status))
    res = json.loads(out)
    with open(ru_file) as f:
        prog_cpu = json.load(f)["cpu"]
    total = ru.ru_utime + ru.ru_stime
    return {"format": fmt, "evals": res["evals"], "wall": wall, "total": total,
            "program": prog_cpu, "qmc": total - prog_cpu}


def main():
    if len(sys.argv) < 2:
        sys.exit("usage: bench_command.py QMC [OUTDIR]")
    qmc = os.path.abspath(sys.argv[1])
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        prog = os.path.join(scratch, "f.py")
        with open(prog, "w") as f:
            f.write(PROGRAM)
        for fmt in ("text", "f64"):
            best = min((run(qmc, prog, fmt, scratch) for _ in range(REPEAT)),
                       key=lambda r: r["total"])
            rows.append(best)
    print("qmc integrate --command, a vectorised numpy program, d = %d, rqmc 16 x 65536 "
          "(best of %d by CPU)" % (DIMS, REPEAT))
    print("%-6s %9s %8s %8s %10s %8s %9s %9s" % ("format", "evals", "wall s", "CPU s",
                                                 "program s", "qmc s", "program", "qmc/point"))
    for r in rows:
        print("%-6s %9d %8.2f %8.2f %10.2f %8.2f %8.0f%% %7.0f ns" % (
            r["format"], r["evals"], r["wall"], r["total"], r["program"], r["qmc"],
            100 * r["program"] / r["total"], 1e9 * r["qmc"] / r["evals"]))
    if len(sys.argv) > 2:
        with open(os.path.join(sys.argv[2], "command.csv"), "w") as f:
            f.write("format,evals,wall_s,cpu_s,program_s,qmc_s\n")
            for r in rows:
                f.write("%s,%d,%.4f,%.4f,%.4f,%.4f\n" % (r["format"], r["evals"], r["wall"],
                                                       r["total"], r["program"], r["qmc"]))


if __name__ == "__main__":
    main()
