"""support.py - what the qmcd package's tests share: where the tree and
its programs are, a qmcd daemon of a test's own (a Unix socket and a
loopback port 0 in a temporary directory, readiness from --ready-file,
stopped by PID), and running `qmc`.

The programs come from $QMC and $QMCD (the Makefile sets them), else the
tree's build/.  A test needing what is missing is skipped with the reason;
tests/e2e/test_python_client.sh runs with QMCD_TEST_REQUIRE=1, which turns
every skip into a failure.  Must not: leave a daemon running, write
outside a mkdtemp() directory, or wait without a bound.
"""
import atexit
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", "..", ".."))
sys.path.insert(0, os.path.dirname(HERE))  # the package, importable from the tree

QMC = os.environ.get("QMC") or os.path.join(ROOT, "build", "qmc")
QMCD = os.environ.get("QMCD") or os.path.join(ROOT, "build", "qmcd")


def tree_file(*parts):
    """A file of the qmcd tree, or a skip when the package runs without it."""
    path = os.path.join(ROOT, *parts)
    if not os.path.exists(path):
        raise unittest.SkipTest("not in the qmcd tree: %s is missing" % path)
    return path


def need_programs():
    for p in (QMC, QMCD):
        if not os.access(p, os.X_OK):
            raise unittest.SkipTest("%s is not built (make all, or set QMC and QMCD)" % p)


def scratch():
    d = tempfile.mkdtemp(prefix="qmcd-py-test.")
    atexit.register(shutil.rmtree, d, True)
    return d


class Daemon:
    """qmcd --foreground on unix:DIR/qmcd.sock and tcp:127.0.0.1:0, with
    extra arguments; .unix, .tcp, .pid.  Stopped by stop() or at exit."""

    def __init__(self, *args, threads=2):
        need_programs()
        self.dir = scratch()
        sock = os.path.join(self.dir, "qmcd.sock")
        ready = os.path.join(self.dir, "ready")
        self.log = open(os.path.join(self.dir, "log"), "w+")
        self.proc = subprocess.Popen(
            [QMCD, "--foreground", "--listen", "unix:" + sock, "--listen", "tcp:127.0.0.1:0",
             "--threads", str(threads), "--log-level", "warning", "--ready-file", ready]
            + list(args), stdout=self.log, stderr=self.log)
        self.pid = self.proc.pid
        atexit.register(self.stop)
        # The ready file is written by rename once every listener is up.
        for _ in range(2000):
            if os.path.exists(ready) and os.path.getsize(ready):
                break
            if self.proc.poll() is not None:
                break
            time.sleep(0.01)
        else:
            self.stop()
            raise RuntimeError("qmcd not ready within 20 s")
        if self.proc.poll() is not None:
            self.log.seek(0)
            raise RuntimeError("qmcd exited: " + self.log.read())
        with open(ready) as f:
            lines = f.read().split()
        self.unix = "unix:" + sock
        self.tcp = [x for x in lines if x.startswith("tcp:")][0]

    def stop(self):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(10)
        self.log.close()


_shared = {}


def daemon(name="plain", *args, threads=2):
    """One daemon per name for the whole test run (a module's setUpClass
    asks; the first ask starts it)."""
    if name not in _shared:
        _shared[name] = Daemon(*args, threads=threads)
    return _shared[name]


def pin_seconds(line):
    """A report line (bytes) with its "seconds" replaced by 0, the one
    field of `qmc integrate --json` that is a clock; AssertionError unless
    it held a non-negative finite number."""
    import math
    import re
    m = re.search(rb'"seconds":([^,}]*)', line)
    if m is None:
        raise AssertionError("no seconds in %r" % line)
    v = float(m.group(1))
    if not (math.isfinite(v) and v >= 0):
        raise AssertionError("seconds %r in %r" % (v, line))
    return line[:m.start(1)] + b"0" + line[m.end(1):]


def qmc(*args, input=None, check=True):
    """Runs qmc; returns its stdout bytes (CalledProcessError if it fails)."""
    need_programs()
    env = dict(os.environ)
    env.pop("QMC_ENDPOINT", None)
    env.pop("QMC_AUTH_KEY_FILE", None)
    p = subprocess.run([QMC] + [str(a) for a in args], input=input, stdout=subprocess.PIPE,
                       stderr=subprocess.PIPE, env=env, timeout=300)
    if check and p.returncode != 0:
        raise AssertionError("qmc %s: exit %d: %s" % (" ".join(map(str, args)), p.returncode,
                                                      p.stderr.decode(errors="replace")))
    return p.stdout
