#!/usr/bin/python3
"""cancelpeer.py - e2e scenarios for cancelling the methods that run no
sampling blocks (cubature, tensor rules and their Gauss-Legendre nodes),
which stop through qmc_integrate's interrupt hook.  It speaks the protocol
through qmcpeer.py (the independent peer) and prints "ok NAME" or
"FAIL NAME: why" lines like it.

    cancelpeer.py race ADDR METHOD
    cancelpeer.py timelimit LIMITED_ADDR REFERENCE_ADDR METHOD
    cancelpeer.py sigterm ADDR METHOD MARKER

No wall-clock thresholds: each check compares a stopped job with a twin
that was not stopped, started at the same time, of the same kind but at
most half the work: the stopped job must be answered while its twin still runs,
which it could not be if it ran to its end.  Times are printed for the
log only.  Every wait is bounded by the peer's socket timeout.
"""
import os
import struct
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import qmcpeer  # noqa: E402
from qmcpeer import (ECANCELED, ESHUTDOWN, ETIMEDOUT, MSG, Peer,  # noqa: E402
                     check, frame)

# Jobs of seconds that stop only on their budget, as (heavy, light) with
# the light one at most half the work: cubature to a tolerance it cannot reach
# (2^28 or 2^27 evaluations of 298-point region pairs in 6 dimensions), and
# a one-dimensional Gauss-Legendre rule, whose O(n^2) nodes alone (n = 65536
# or 32768) take tens of seconds before the first evaluation.
CUBATURE = dict(integrand="genz-oscillatory", dims=6, method="cubature", tol_rel=1e-15)
GL = dict(integrand="exp", dims=1, method="gauss-legendre", max_evals=1 << 20)
JOBS = {
    "cubature": (dict(CUBATURE, max_evals=1 << 28, max_memory=256 << 20),
                 dict(CUBATURE, max_evals=1 << 27, max_memory=256 << 20)),
    "gauss-legendre": (dict(GL, n_axis=65536), dict(GL, n_axis=32768)),
}


def submit(p, method, light=False):
    rid = p.rid()
    p.send(p.integrate_frame(rid, **JOBS[method][1 if light else 0]))
    t, r, d = p.recv()
    if t != "JOB_ACCEPTED" or r != rid:
        raise ValueError("INTEGRATE %s answered %s %r" % (method, t, d))
    return rid, d["job_id"]


def status(p, job):
    """JOB_STATE of job (skipping progress frames)."""
    s = p.rid()
    p.send(frame(MSG["JOB_STATUS"], s, struct.pack("<Q", job)))
    for _ in range(1000):
        t, r, d = p.recv()
        if t == "JOB_STATE" and r == s:
            return d
        if t not in ("JOB_PROGRESS",):
            raise ValueError("unexpected %s %r while waiting for JOB_STATE" % (t, d))
    raise ValueError("no JOB_STATE")


def wait_running(p, jobs, seconds=0.0):
    """Polls JOB_STATUS until every job runs and has run for `seconds` by
    the daemon's clock, so that a cancel lands mid-computation (bounded
    count; the pool has a worker for each)."""
    for _ in range(2000):
        states = [status(p, j) for j in jobs]
        if all(d["state"] == "running" and d["seconds"] >= seconds for d in states):
            return True
        time.sleep(0.005)
    return False


def cancel(p, rid, job):
    """JOB_CANCEL: returns (JOB_STATE state, ERROR code of the INTEGRATE,
    frames that came in between)."""
    c = p.rid()
    p.send(frame(MSG["JOB_CANCEL"], c, struct.pack("<Q", job)))
    state, code, other = None, None, []
    for _ in range(1000):
        t, r, d = p.recv()
        if t == "JOB_STATE" and r == c:
            state = d["state"]
        elif t == "ERROR" and r == rid:
            code = d["code"]
            break
        else:
            other.append((t, r))
    return state, code, other


def sc_race(addr, method):
    """A job and its lighter twin start together; the job is cancelled: its
    answer must come while the twin still runs."""
    p = Peer(addr)
    ra, ja = submit(p, method)
    rb, jb = submit(p, method, light=True)
    check("%s race: both jobs running" % method, wait_running(p, [ja, jb], 0.2))
    t0 = time.time()
    state, code, other = cancel(p, ra, ja)
    dt = time.time() - t0
    check("%s: JOB_CANCEL -> JOB_STATE cancelled" % method, state == "cancelled", state)
    check("%s: cancelled INTEGRATE -> ERROR -ECANCELED (%.3f s)" % (method, dt),
          code == ECANCELED and not other, "code %r, also got %r" % (code, other))
    twin = status(p, jb)
    check("%s: answered while a lighter uncancelled twin still runs (%.3f s in)"
          % (method, twin["seconds"]), twin["state"] == "running", repr(twin))
    state, code, other = cancel(p, rb, jb)
    check("%s: the twin cancels too" % method, state == "cancelled" and code == ECANCELED,
          "%r %r %r" % (state, code, other))
    p.close()


def sc_timelimit(limited, reference, method):
    """A job on a daemon with a short job-time-limit-ms, its lighter twin on
    one without: the limited one must be answered -ETIMEDOUT while the twin
    still runs."""
    lp, rp = Peer(limited), Peer(reference)
    rl, jl = submit(lp, method)
    rr, jr = submit(rp, method, light=True)
    t0 = time.time()
    t, r, d = lp.recv()
    dt = time.time() - t0
    check("%s: job-time-limit-ms -> ERROR -ETIMEDOUT (%.3f s)" % (method, dt),
          t == "ERROR" and r == rl and d["code"] == ETIMEDOUT and
          "job-time-limit-ms" in d["message"], "%s %r" % (t, d))
    twin = status(rp, jr)
    check("%s: timed out while a lighter unlimited twin still runs (%.3f s in)"
          % (method, twin["seconds"]), twin["state"] == "running", repr(twin))
    state, code, other = cancel(rp, rr, jr)
    check("%s: the unlimited twin cancels" % method, code == ECANCELED, repr(code))
    lp.close()
    rp.close()


def sc_sigterm(addr, method, marker):
    """A job runs; the shell sends SIGTERM once the marker exists.  At the
    drain deadline the job must stop and be answered -ESHUTDOWN before the
    daemon closes the connection (a job that ignored its cancel would be
    cut off without an answer)."""
    p = Peer(addr)
    rid, job = submit(p, method)
    check("%s sigterm: job running" % method, wait_running(p, [job], 0.2))
    open(marker, "w").close()
    errors = []
    for _ in range(1000):
        f = p.recv()
        if f is None:
            break
        if f[0] == "ERROR" and f[1] == rid:
            errors.append(f[2])
    check("%s sigterm: the running job answered ERROR -ESHUTDOWN before close" % method,
          len(errors) == 1 and errors[0]["code"] == ESHUTDOWN, repr(errors))
    p.close()


SCENARIOS = dict(race=sc_race, timelimit=sc_timelimit, sigterm=sc_sigterm)


if __name__ == "__main__":
    sys.exit(qmcpeer.main(sys.argv, SCENARIOS, "cancelpeer.py"))
