#!/usr/bin/python3
"""backfillpeer.py - e2e scenario for backfill behind a job waiting for
memory (issue 15, isolation between clients): under
max-jobs-memory-total, small jobs start while a big one waits, at most
job-memory-overtakes of them, and STATS stays consistent.  Speaks the
protocol through qmcpeer.py and greedypeer.py's helpers and prints
"ok NAME" / "FAIL NAME: why" lines like them.

    backfillpeer.py backfill TCP_ADDR UNIX_ADDR OVERTAKES

No wall-clock thresholds: order and state only.  Every wait is bounded by
a socket timeout and every loop by a count.
"""
import os
import socket
import struct
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import qmcpeer  # noqa: E402
from greedypeer import (GREEDY_HOST, TINY, TcpPeer, job_states,  # noqa: E402
                        serves_correctly, tiny_result)
from qmcpeer import MSG, Peer, check, frame  # noqa: E402


def holder_job():
    """A job that reserves about 40 MiB and runs until it is cancelled: the
    midpoint rule at 1.3M points an axis in 2 dimensions (its nodes and
    weights are the 40 MiB; 1.7e12 evaluations are hours of work)."""
    spec = qmcpeer.cli_like_spec("genz-oscillatory", 2, "midpoint", n=1310720)
    spec["max_evals"] = 1 << 41
    return spec


def cancel_job(p, jid, rid_job):
    """JOB_CANCEL, then the job's own answer; returns its ERROR dict."""
    p.send(frame(MSG["JOB_CANCEL"], p.rid(), struct.pack("<Q", jid)))
    for _ in range(100):
        t, r, d = p.recv()
        if r == rid_job and t == "ERROR":
            return d
    return None


def submit(p, spec):
    """INTEGRATE; returns (job id, request id) once JOB_ACCEPTED."""
    rid = p.rid()
    p.send(p.integrate_frame(rid, **spec))
    t, r, d = p.recv()
    if t != "JOB_ACCEPTED" or r != rid:
        raise ValueError("INTEGRATE answered %s %r" % (t, d))
    return d["job_id"], rid


def poll_until(what, cond, tries=400):
    """Polls cond() (state, not time: each try is a round trip) a bounded
    number of times; True once it held."""
    for _ in range(tries):
        if cond():
            return True
        time.sleep(0.05)
    print("# gave up waiting for " + what)
    return False


def job_counts_add_up(st, st0):
    """accepted = done + failed + cancelled + dropped + open, as deltas."""
    keys = ("jobs_done", "jobs_failed", "jobs_cancelled", "jobs_dropped")
    acc = st["jobs_accepted"] - st0["jobs_accepted"]
    parts = [st[k] - st0[k] for k in keys] + [st["jobs_open"] - st0["jobs_open"]]
    return acc == sum(parts), "accepted %d, done/failed/cancelled/dropped/open %r" % (acc, parts)


def sc_backfill(tcp_addr, unix_addr, overtakes):
    """Backfill behind a job waiting for memory (max-jobs-memory-total 64M,
    job-memory-overtakes K): a 40 MiB job runs, a second one waits (24 MiB
    free), and K small jobs from another peer finish meanwhile with the
    bits of an idle daemon; the (K+1)-th waits for the big one (so a stream
    of small jobs cannot starve it) and runs once it has started; one more,
    queued when its connection closes, is dropped.  STATS: the backfills
    and waits are counted exactly, and accepted = done + failed +
    cancelled + dropped + open at every quiet point."""
    k = int(overtakes)
    idle = Peer(unix_addr, timeout=60.0)
    alone = tiny_result(idle)
    st0 = idle.stats()
    h = Peer(unix_addr, timeout=60.0)
    hjid, hrid = submit(h, holder_job())
    poll_until("the holder to run", lambda: job_states(h, [hjid]) == ["running"])
    b = TcpPeer(tcp_addr, GREEDY_HOST)
    bjid, brid = submit(b, holder_job())
    waiting = poll_until("a job waiting for memory",
                         lambda: idle.stats()["job_memory_waiting"] == 1)
    check("a second 40 MiB job waits for memory (64 MiB total, 40 held)",
          waiting and job_states(b, [bjid]) == ["queued"], repr(job_states(b, [bjid])))
    s = TcpPeer(tcp_addr, "127.0.0.3")
    results = [tiny_result(s) for _ in range(k)]
    states = job_states(h, [hjid]) + job_states(b, [bjid])
    check("%d small jobs finished while the big one waited for memory (%s)"
          % (k, ",".join(states)), states == ["running", "queued"])
    check("the small jobs that passed it have the bits of an idle daemon",
          all(qmcpeer.same(r["estimate"], alone["estimate"]) and
              qmcpeer.same(r["error"], alone["error"]) for r in results))
    st = idle.stats()
    check("STATS job_memory_backfills counts the %d that passed (%d)"
          % (k, st["job_memory_backfills"] - st0["job_memory_backfills"]),
          st["job_memory_backfills"] - st0["job_memory_backfills"] == k)
    ok, why = job_counts_add_up(st, st0)
    check("with jobs running and waiting, accepted = done + failed + cancelled + dropped + "
          "open", ok, why)
    # The (K+1)-th: it would fit, but K passed the big one already.
    ljid, lrid = submit(s, TINY)
    d = TcpPeer(tcp_addr, "127.0.0.4")
    submit(d, TINY)
    # Queued when its connection breaks (a reset: a half-close would still
    # get its answer): dropped.
    d.s.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
    d.close()
    dropped = poll_until("the dropped job", lambda: idle.stats()["jobs_dropped"] ==
                         st0["jobs_dropped"] + 1)
    held = job_states(s, [ljid])
    check("the next small job (it fits, but %d passed the big one) waits too (%s)"
          % (k, ",".join(map(str, held))), dropped and held == ["queued"])
    # The holder ends: the big one starts first, then the late small one.
    gone = cancel_job(h, hjid, hrid)
    late = None
    for _ in range(100):
        t, r, dd = s.recv()
        if r == lrid and t in ("JOB_RESULT", "ERROR"):
            late = dd if t == "JOB_RESULT" else None
            break
    big_state = job_states(b, [bjid])
    check("the holder cancelled is answered ECANCELED",
          gone is not None and gone.get("code") == qmcpeer.ECANCELED, repr(gone))
    # (Admitted after the big one - the backfill count below says so - but
    # its slot may come first: JOB_STATE says running only once a job
    # computes.)
    check("once the holder ended the late small job ran, with the bits of an idle daemon, "
          "while the big one had its memory (big %s)" % ",".join(map(str, big_state)),
          late is not None and big_state in (["queued"], ["running"]) and
          qmcpeer.same(late["estimate"], alone["estimate"]))
    st = idle.stats()
    # (The dropped one started cancelled, reserving nothing: no wait.)
    check("STATS: still %d backfills (the late one passed no one: %d), and the big and the "
          "late one waited (%d)" % (k, st["job_memory_backfills"] - st0["job_memory_backfills"],
                                    st["job_memory_waits"] - st0["job_memory_waits"]),
          st["job_memory_backfills"] - st0["job_memory_backfills"] == k and
          st["job_memory_waits"] - st0["job_memory_waits"] == 2)
    gone = cancel_job(b, bjid, brid)
    check("the big job cancelled is answered ECANCELED",
          gone is not None and gone.get("code") == qmcpeer.ECANCELED, repr(gone))
    poll_until("every job to end", lambda: idle.stats()["jobs_open"] == 0)
    st = idle.stats()
    ok, why = job_counts_add_up(st, st0)
    check("at the end accepted = done + failed + cancelled + dropped (%d accepted: %d done, "
          "%d cancelled, %d dropped)" % tuple(st[x] - st0[x] for x in (
              "jobs_accepted", "jobs_done", "jobs_cancelled", "jobs_dropped")),
          ok and st["jobs_open"] == 0 and st["jobs_dropped"] - st0["jobs_dropped"] == 1 and
          st["jobs_done"] - st0["jobs_done"] == k + 1 and
          st["jobs_cancelled"] - st0["jobs_cancelled"] == 2, why)
    check("nothing reserved and nothing waiting at the end",
          st["job_memory_reserved_bytes"] == 0 and st["job_memory_waiting"] == 0,
          repr((st["job_memory_reserved_bytes"], st["job_memory_waiting"])))
    for p in (h, b, s, idle):
        p.close()
    serves_correctly(unix_addr, "after the backfill")


SCENARIOS = dict(backfill=sc_backfill)

if __name__ == "__main__":
    sys.exit(qmcpeer.main(sys.argv, SCENARIOS, "backfillpeer.py"))
