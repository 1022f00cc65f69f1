#!/usr/bin/python3
"""greedypeer.py - e2e scenarios for issue 15's finding 2: one client
trying to take the daemon from everyone else (many sockets, streams it
never reads, jobs that never end, quota floods, a shared-memory ring it
punches holes in).  Every scenario ends with the same proof: the daemon is
alive, serves another client correctly (answers checked against closed
forms, not against the daemon's own output), and its VmRSS stayed under a
stated bound.  It speaks the protocol through qmcpeer.py (the independent
peer) and prints "ok NAME" / "FAIL NAME: why" lines like it.

    greedypeer.py peers TCP_ADDR UNIX_ADDR PID PER_PEER
    greedypeer.py noread ADDR PID CONNS LIMIT_MB
    greedypeer.py starve ADDR
    greedypeer.py quota ADDR JOBS_PER_CONN CANCELS_PER_CONN
    greedypeer.py punch ADDR PID
    greedypeer.py jobmem TCP_ADDR UNIX_ADDR PID TOTAL_MB JOB_MB SLACK_MB

No wall-clock thresholds: order and state only ("the small job finished
while the big ones still ran").  Every wait is bounded by a socket timeout
and every loop by a count.
"""
import ctypes
import errno
import fcntl
import math
import mmap
import os
import resource
import socket
import struct
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import qmcpeer  # noqa: E402
from qmcpeer import (MSG, QMC_ETOOBIG, Peer, PeerError, check, frame,  # noqa: E402
                     vmrss_kb)

GREEDY_HOST = "127.0.0.2"  # the greedy peer's source address; the legit one is 127.0.0.1


def parents(path):
    """Every directory from / down to the one holding path."""
    out, d = [], os.path.dirname(os.path.abspath(path))
    while True:
        out.append(d)
        if d == "/":
            return out[::-1]
        d = os.path.dirname(d)

def radical_inverse2(i):
    """Van der Corput in base 2: Sobol's first dimension (Joe & Kuo 2008)."""
    x, f = 0.0, 0.5
    while i:
        if i & 1:
            x += f
        i >>= 1
        f /= 2
    return x


def serves_correctly(addr, name, start=0):
    """A fresh client: HELLO, PING, and 64 two-dimensional Sobol points equal
    to the closed form (the radical inverse, and dimension 2's direction
    numbers XORed over the bits of the index)."""
    try:
        p = Peer(addr, timeout=20.0)
        alive = p.ping()
        data, _ = p.points(kind="sobol", dims=2, count=64, start=start)
        p.close()
    except (OSError, ValueError, PeerError) as e:
        check(name + ": another client served", False, "%s: %s" % (type(e).__name__, e))
        return False
    got = struct.unpack("<%dd" % (len(data) // 8), data)
    want = []
    for i in range(start, start + 64):
        want += [radical_inverse2(i), sobol_index_dim2(i)]
    ok = alive and list(got) == want
    check(name + ": another client served correctly (PING, 64 Sobol points = closed form)",
          ok, "ping %r, first got %r want %r" % (alive, got[:6], want[:6]))
    return ok


def sobol_index_dim2(i):
    """Dimension 2 of Sobol point i in index (not Gray-code) order: the XOR of
    direction numbers v_k for the set bits k of i."""
    v = 1 << 31
    x, k = 0, 0
    while i:
        if i & 1:
            x ^= v
        i >>= 1
        v ^= v >> 1
        k += 1
    return x / float(1 << 32)


def rss_check(pid, base_kb, bound_mb, name):
    now = vmrss_kb(pid)
    check("%s: VmRSS %d kB -> %d kB, under +%d MiB" % (name, base_kb, now, bound_mb),
          now - base_kb < bound_mb * 1024, "grew %d kB" % (now - base_kb))


def stats_of(addr):
    """The daemon's STATS, from a fresh connection."""
    p = Peer(addr, timeout=20.0)
    st = p.stats()
    p.close()
    return st


def raise_nofile(n):
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft < n:
        resource.setrlimit(resource.RLIMIT_NOFILE, (min(n, hard), hard))


def hello_frame():
    return frame(MSG["HELLO"], 1, struct.pack("<HHI", 1, 1, 1 << 20) + qmcpeer.str16("greedy"))


def first_frame(s, buf):
    """Reads one frame from a raw socket (bounded by its timeout); None at EOF
    or on a reset (a reset is what an unclear refusal looks like)."""
    while True:
        if len(buf) >= qmcpeer.HEADER.size:
            plen = qmcpeer.HEADER.unpack_from(buf)[5]
            if len(buf) >= qmcpeer.HEADER.size + plen:
                mtype = qmcpeer.HEADER.unpack_from(buf)[2]
                d = qmcpeer.decode(mtype, bytes(buf[qmcpeer.HEADER.size:
                                                     qmcpeer.HEADER.size + plen]))
                del buf[:qmcpeer.HEADER.size + plen]
                return d
        try:
            chunk = s.recv(65536)
        except (ConnectionResetError, BrokenPipeError, socket.timeout):
            return None
        if not chunk:
            return None
        buf += chunk


def flood(make_socket, n, limits=("max-connections-per-peer",)):
    """Opens n sockets with make_socket(), sends HELLO on each and reads the
    first answer of each: returns (sockets kept, HELLO_OK count, clear
    refusals - an ERROR naming one of limits -, unclear endings)."""
    socks = []
    for _ in range(n):
        s = make_socket()
        try:
            s.sendall(hello_frame())
        except (BrokenPipeError, ConnectionResetError):
            pass  # counted below as unclear if no ERROR can be read
        socks.append(s)
    kept, ok, clear, unclear = [], 0, 0, 0
    for s in socks:
        d = first_frame(s, bytearray())
        if d and d["type"] == "HELLO_OK":
            ok += 1
            kept.append(s)
            continue
        if d and d["type"] == "ERROR" and d["code"] == QMC_ETOOBIG and \
                any(limit in d["message"] for limit in limits):
            clear += 1
        else:
            unclear += 1
        s.close()
    return kept, ok, clear, unclear


def sc_peers(tcp_addr, unix_addr, pid, per_peer):
    """1030 sockets from one TCP peer (127.0.0.2), then as many from one
    Unix-socket user (root): each gets exactly max-connections-per-peer, is
    told why for the rest (over TCP also when newer sockets take its place
    in the handshake), and 127.0.0.1 and another uid still get in."""
    pid, per_peer = int(pid), int(per_peer)
    raise_nofile(4096)
    base = vmrss_kb(pid)
    host, port = tcp_addr[4:].rsplit(":", 1)

    def greedy_tcp():
        s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        s.settimeout(20.0)
        s.bind((GREEDY_HOST, 0))
        s.connect((host, int(port)))
        return s

    kept, ok, clear, unclear = flood(greedy_tcp, 1030, ("-per-peer",))
    check("1030 sockets from %s: %d in (max-connections-per-peer %d), %d told "
          "'max-connections-per-peer' or 'max-preauth-connections-per-peer' in an ERROR, "
          "%d unclear" % (GREEDY_HOST, ok, per_peer, clear, unclear),
          ok == per_peer and clear + unclear == 1030 - per_peer and unclear == 0)
    serves_correctly(tcp_addr, "greedy TCP peer holding its limit")
    try:
        p = Peer(unix_addr)
        check("greedy TCP peer: a Unix-socket client gets in", p.ping())
        p.close()
    except (OSError, ValueError) as e:
        check("greedy TCP peer: a Unix-socket client gets in", False, repr(e))

    def greedy_unix():
        s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        s.settimeout(20.0)
        s.connect(unix_addr[5:])
        return s

    ukept, uok, uclear, uunclear = flood(greedy_unix, 2 * per_peer + 10)
    check("Unix sockets from uid %d: %d in, %d told why, %d unclear"
          % (os.getuid(), uok, uclear, uunclear),
          uok == per_peer and uunclear == 0 and uclear == per_peer + 10)
    # Another user is another peer: a child that drops to nobody connects.
    if os.getuid() == 0:
        r, w = os.pipe()
        child = os.fork()
        if child == 0:
            os.close(r)
            code = 1
            try:
                os.setgid(65534)
                os.setuid(65534)
                # Where nobody cannot even reach the socket's directory (a
                # chroot unpacked into a 0700 directory, as on a fresh
                # machine check), the file system says no before qmcd can
                # say anything: that is the machine, not the daemon.
                path = unix_addr[len("unix:"):]
                if not all(os.access(d, os.X_OK) for d in parents(path)):
                    code = 2
                else:
                    q = Peer(unix_addr, timeout=20.0)
                    code = 0 if q.ping() else 1
                    q.close()
            except BaseException as e:  # reported through the exit code
                sys.stderr.write("uid 65534 client: %r\n" % e)
                code = 1
            os.write(w, b"%d" % code)
            os._exit(0)
        os.close(w)
        said = os.read(r, 16)
        os.close(r)
        os.waitpid(child, 0)
        if said == b"2":
            print("skip: uid 65534 cannot reach %s here (a parent directory is closed)"
                  % unix_addr)
        else:
            check("uid %d holding its limit: uid 65534 on the same socket gets in"
                  % os.getuid(), said == b"0", repr(said))
    serves_correctly(tcp_addr, "both greedy peers holding their limits")
    st = stats_of(tcp_addr)
    want = (1030 - per_peer) + (per_peer + 10)
    got = st["refused_connections_per_peer"] + st["handshakes_evicted"]
    check("STATS refused_connections_per_peer + handshakes_evicted count every refusal by "
          "those limits (%d + %d, want %d)" % (st["refused_connections_per_peer"],
                                               st["handshakes_evicted"], want), got == want)
    rss_check(pid, base, 64, "1030 + %d greedy sockets" % (2 * per_peer + 10))
    for s in kept + ukept:
        s.close()


def settle_rss(pid, rounds=100, still=5):
    """Samples VmRSS every 0.1 s until it has not grown by 1 MiB for `still`
    samples in a row (at most `rounds`): returns the peak."""
    peak, calm, last = vmrss_kb(pid), 0, vmrss_kb(pid)
    for _ in range(rounds):
        time.sleep(0.1)
        now = vmrss_kb(pid)
        peak = max(peak, now)
        calm = calm + 1 if now - last < 1024 else 0
        last = max(last, now)
        if calm >= still:
            break
    return peak


def sc_noread(addr, pid, conns, limit_mb):
    """`conns` connections each ask for a 1M-point stream (16 dims, 128 MB)
    and never read: the output buffers they fill stay under
    out-buffer-total-bytes, and a reading client is still served."""
    pid, conns, limit_mb = int(pid), int(conns), int(limit_mb)
    raise_nofile(conns + 256)
    waits0 = stats_of(addr)["out_buffer_waits"]
    base = vmrss_kb(pid)
    greedy = []
    for _ in range(conns):
        p = Peer(addr)
        p.s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        p.send(p.points_frame(p.rid(), dims=16, count=1 << 20))
        greedy.append(p)
    peak = settle_rss(pid)
    print("# %d non-reading streams: VmRSS %d kB -> %d kB" % (conns, base, peak))
    check("%d streams never read: VmRSS %d kB -> peak %d kB, under +%d MiB"
          % (conns, base, peak, limit_mb), peak - base < limit_mb * 1024)
    serves_correctly(addr, "%d non-reading streams" % conns)
    # A reader's own big stream waits for memory (it needs a 512 KiB chunk,
    # more than its floor) while its small requests are still answered;
    # once the non-readers leave, it arrives whole.
    try:
        q = Peer(addr, timeout=20.0)
        big = q.rid()
        q.send(q.points_frame(big, kind="sobol", dims=2, count=1 << 15))
        ping = q.rid()
        q.send(q.ping_frame(ping))
        frames = []
        for _ in range(1000):
            f = q.recv()
            frames.append(f)
            if f is None or f[1] == ping:
                break
        check("%d non-reading streams: a reader's PING is answered while its big stream "
              "waits" % conns, frames and frames[-1] and frames[-1][0] == "PONG",
              repr([f[0] for f in frames if f][:5]))
        for p in greedy:
            p.close()
        greedy = []
        data = b"".join(f[2]["data"] for f in frames if f and f[0] == "POINTS_CHUNK")
        for _ in range(1000):
            f = q.recv()
            if f is None or f[0] != "POINTS_CHUNK":
                break
            data += f[2]["data"]
        got = struct.unpack("<%dd" % (len(data) // 8), data)
        want = [radical_inverse2(i) for i in range(1 << 15)]
        check("%d non-reading streams gone: the reader's 32768-point stream arrives whole "
              "(dimension 1 = radical inverse), then END" % conns,
              f and f[0] == "END" and list(got[0::2]) == want, repr(f and f[0]))
        q.close()
        waits = stats_of(addr)["out_buffer_waits"]
        check("STATS out_buffer_waits moved with the waiting streams (%d -> %d, the reader's "
              "among them)" % (waits0, waits), waits0 == 0 and waits >= 1)
    except (OSError, ValueError, PeerError) as e:
        check("%d non-reading streams: a reader's stream arrives" % conns, False, repr(e))
    for p in greedy:
        p.close()


def huge_job(method):
    """A job that never reaches its tolerance (tol_rel 1e-300, max_evals
    2^64 - 1, as in the issue): sampling blocks (rqmc) or a quadrature that
    runs none (cubature)."""
    if method == "cubature":
        spec = qmcpeer.cli_like_spec("genz-oscillatory", 6, "cubature")
        spec["max_memory"] = 16 << 20
    else:
        spec = qmcpeer.cli_like_spec("genz-oscillatory", 8, "rqmc", 4096, 16, 1)
    spec.update(tol_rel=1e-300, max_evals=(1 << 64) - 1)
    return spec


TINY = qmcpeer.cli_like_spec("poly", 1, "rqmc", 4096, 8, 3)  # x^5 over [0,1): 1/6


def tiny_result(p):
    """Runs the tiny job on p; returns its JOB_RESULT dict."""
    return qmcpeer.run_job(p, TINY)


def job_states(p, ids):
    states = []
    for jid in ids:
        rid = p.rid()
        p.send(frame(MSG["JOB_STATUS"], rid, struct.pack("<Q", jid)))
        for _ in range(100):
            t, r, d = p.recv()
            if r == rid:
                states.append(d.get("state") if t == "JOB_STATE" else t)
                break
    return states


def sc_starve(addr):
    """Eight endless jobs from one connection, both kinds in turn: another
    connection's tiny job finishes while all eight still run or wait, with
    the same bits as on an idle daemon and the true value within its bar."""
    idle = Peer(addr, timeout=60.0)
    alone = tiny_result(idle)
    idle.close()
    check("tiny job on an idle daemon: 1/6 within 6 standard errors (%r +- %r)"
          % (alone["estimate"], alone["error"]),
          abs(alone["estimate"] - 1 / 6) <= 6 * alone["error"] and alone["error"] > 0)
    for method in ("rqmc", "cubature"):
        g = Peer(addr, timeout=60.0)
        ids = []
        for _ in range(8):
            rid = g.rid()
            g.send(g.integrate_frame(rid, **huge_job(method)))
            t, r, d = g.recv()
            if t != "JOB_ACCEPTED":
                raise ValueError("huge %s job answered %s %r" % (method, t, d))
            ids.append(d["job_id"])
        # They hold the workers: wait (bounded) until two of them run.
        for _ in range(400):
            if job_states(g, ids).count("running") >= 2:
                break
            time.sleep(0.05)
        before = job_states(g, ids)
        q = Peer(addr, timeout=60.0)
        res = tiny_result(q)
        after = job_states(g, ids)
        check("%s: 8 endless jobs of one client hold the workers (%s)"
              % (method, ",".join(before)), before.count("running") >= 2)
        check("%s: another client's tiny job finished while all 8 still ran or waited "
              "(after: %s)" % (method, ",".join(after)),
              all(st in ("running", "queued") for st in after), repr(after))
        check("%s: the tiny job under contention has the same bits as alone" % method,
              qmcpeer.same(res["estimate"], alone["estimate"]) and
              qmcpeer.same(res["error"], alone["error"]),
              "%r vs %r" % (res["estimate"], alone["estimate"]))
        # A queued job cancelled is answered at once, not after the
        # connection's running jobs end.
        rid = g.rid()
        g.send(frame(MSG["JOB_CANCEL"], rid, struct.pack("<Q", ids[-1])))
        answer = None
        for _ in range(1000):
            t, r, d = g.recv()
            if t == "ERROR" and d["code"] == qmcpeer.ECANCELED:
                answer = d
                break
        still = job_states(g, ids[:-1])
        check("%s: a queued job cancelled is answered ECANCELED while the others still "
              "run or wait (%s)" % (method, ",".join(still)),
              answer is not None and all(st in ("running", "queued") for st in still))
        q.close()
        g.close()  # its jobs are cancelled (the connection is gone)
        serves_correctly(addr, "%s: after 8 endless jobs" % method)


def sc_quota(addr, jobs_per_conn, cancels_per_conn):
    """Past max-jobs-per-conn an INTEGRATE, and past max-cancels-per-conn a
    JOB_CANCEL, is refused with an ERROR naming the limit; the connection
    stays usable and the daemon serves others."""
    jobs_per_conn, cancels_per_conn = int(jobs_per_conn), int(cancels_per_conn)
    st0 = stats_of(addr)
    g = Peer(addr, timeout=30.0)
    ids, ids_rids = [], set()
    for _ in range(jobs_per_conn):
        rid = g.rid()
        g.send(g.integrate_frame(rid, **huge_job("rqmc")))
        t, r, d = g.recv()
        ids.append(d.get("job_id") if t == "JOB_ACCEPTED" else None)
        ids_rids.add(rid)
    rid = g.rid()
    g.send(g.integrate_frame(rid, **huge_job("rqmc")))
    t, r, d = g.recv()
    check("max-jobs-per-conn %d: the next INTEGRATE gets ERROR naming the limit"
          % jobs_per_conn, None not in ids and t == "ERROR" and r == rid and
          d["code"] == QMC_ETOOBIG and "max-jobs-per-conn" in d["message"], repr((t, d)))
    # Cancels: the bucket holds cancels_per_conn; the next is refused.
    # (A cancelled job's own ERROR ECANCELED, for its INTEGRATE's id, may
    # come between: each cancel's answer is the frame with its id.)
    answers = []
    for k in range(cancels_per_conn + 1):
        rid = g.rid()
        g.send(frame(MSG["JOB_CANCEL"], rid, struct.pack("<Q", ids[k % len(ids)])))
        for _ in range(100):
            t, r, d = g.recv()
            if r == rid or r not in ids_rids:
                break
        answers.append((t, r == rid, d))
    firsts = all(t == "JOB_STATE" and same for t, same, _ in answers[:-1])
    t, same, d = answers[-1]
    check("max-cancels-per-conn %d: %d cancels answered, the next gets ERROR naming the "
          "limit" % (cancels_per_conn, cancels_per_conn),
          firsts and t == "ERROR" and same and d["code"] == QMC_ETOOBIG and
          "max-cancels-per-conn" in d["message"], repr(answers[-2:]))
    # (The cancelled jobs' ERROR ECANCELED answers may come first.)
    rid = g.rid()
    g.send(g.ping_frame(rid))
    pong = False
    for _ in range(100):
        f = g.recv()
        if f is None or f[1] == rid:
            pong = f is not None and f[0] == "PONG"
            break
    check("quotas: the refused connection still answers PING", pong)
    st = stats_of(addr)
    check("STATS refused_jobs_per_conn and refused_cancels_per_conn count one refusal each "
          "(%d, %d)" % (st["refused_jobs_per_conn"] - st0["refused_jobs_per_conn"],
                        st["refused_cancels_per_conn"] - st0["refused_cancels_per_conn"]),
          st["refused_jobs_per_conn"] - st0["refused_jobs_per_conn"] == 1 and
          st["refused_cancels_per_conn"] - st0["refused_cancels_per_conn"] == 1 and
          st["refused_jobs"] == st0["refused_jobs"])
    serves_correctly(addr, "quotas refused")
    g.close()


def rss_shmem_kb(pid):
    with open("/proc/%d/status" % pid) as f:
        for line in f:
            if line.startswith("RssShmem:"):
                return int(line.split()[1])
    return -1


def punch_hole(fd, length):
    """fallocate(FALLOC_FL_PUNCH_HOLE | FALLOC_FL_KEEP_SIZE): 0 or -errno."""
    libc = ctypes.CDLL(None, use_errno=True)
    libc.fallocate.argtypes = [ctypes.c_int, ctypes.c_int, ctypes.c_long, ctypes.c_long]
    if libc.fallocate(fd, 3, 0, length) == 0:
        return 0
    return -ctypes.get_errno()


def sc_punch(addr, pid, ring_mb="16"):
    """After SHM_OK the client tries to give its ring's pages back to the
    kernel (fallocate PUNCH_HOLE, and MADV_REMOVE through a writable mapping
    it made before attaching), so that the daemon's writes would allocate
    them again, charged to the daemon: both must fail, and streaming the
    whole ring must leave the memfd's allocated blocks unchanged."""
    pid = int(pid)
    slots, slot_bytes = int(ring_mb), 1 << 20
    size = slots * slot_bytes
    p = Peer(addr, version=2, timeout=20.0)
    fd, ro = qmcpeer.make_ring(slots, slot_bytes)
    rw = mmap.mmap(fd, size, mmap.MAP_SHARED, mmap.PROT_READ | mmap.PROT_WRITE)
    t, r, d = p.attach(fd, slots, slot_bytes, ring=ro)
    check("punch: SHM_ATTACH of a %d MiB ring answered SHM_OK" % (size >> 20), t == "SHM_OK",
          repr((t, d)))
    shmem0 = rss_shmem_kb(pid)
    blocks0 = os.fstat(fd).st_blocks
    seals = fcntl.fcntl(fd, fcntl.F_GET_SEALS)
    rc = punch_hole(fd, size)
    try:
        rw.madvise(mmap.MADV_REMOVE)
        madv = 0
    except OSError as e:
        madv = -e.errno
    blocks1 = os.fstat(fd).st_blocks
    print("# seals after SHM_OK 0x%x; punch %d, MADV_REMOVE %d; blocks %d -> %d; daemon "
          "RssShmem %d kB -> %d kB" % (seals, rc, madv, blocks0, blocks1, shmem0,
                                      rss_shmem_kb(pid)))
    check("punch: fallocate(PUNCH_HOLE) on the attached ring is refused (%d)" % rc,
          rc == -errno.EPERM)
    check("punch: MADV_REMOVE through a writable mapping made before attaching is "
          "refused (%d)" % madv, madv == -errno.EPERM)
    # Stream twice the ring through it: every slot written, twice.
    data, end, chunks = p.points_shm(kind="sobol", dims=2, count=2 * size // 16)
    got = struct.unpack_from("<%dd" % 128, data)
    want = []
    for i in range(64):
        want += [radical_inverse2(i), sobol_index_dim2(i)]
    blocks2 = os.fstat(fd).st_blocks
    shmem1 = rss_shmem_kb(pid)
    print("# memfd blocks %d -> %d after %d chunks; daemon RssShmem %d kB -> %d kB"
          % (blocks0, blocks2, chunks, shmem0, shmem1))
    check("punch: the ring streamed %d chunks, points = closed form" % chunks,
          end is not None and list(got) == want)
    check("punch: the memfd's pages are the client's own, never reallocated by the "
          "daemon's writes (blocks %d -> %d -> %d)" % (blocks0, blocks1, blocks2),
          blocks1 == blocks0 and blocks2 == blocks0)
    p.close()
    os.close(fd)
    # A memfd sealed with F_SEAL_SEAL cannot get F_SEAL_FUTURE_WRITE from
    # the server: refused, with the reason.
    q = Peer(addr, version=2, timeout=20.0)
    fd, _ = qmcpeer.make_ring(2, 64 << 10)
    fcntl.fcntl(fd, fcntl.F_ADD_SEALS, fcntl.F_SEAL_SEAL)
    qmcpeer.refused(q, fd, 2, 64 << 10, "sealed with F_SEAL_SEAL", qmcpeer.QMC_EINVAL,
                    "F_SEAL_SEAL")
    os.close(fd)
    check("punch: the refused connection still answers PING", q.ping())
    q.close()
    serves_correctly(addr, "after the hole punching")


class TcpPeer(Peer):
    """A Peer whose TCP connection comes from source address `source`."""

    def __init__(self, addr, source, timeout=60.0):
        host, port = addr[4:].rsplit(":", 1)
        self.s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.s.settimeout(timeout)
        self.s.bind((source, 0))
        self.s.connect((host, int(port)))
        self.buf = bytearray()
        self.next_id = 100
        self.ring = None
        self.info = self.hello()


def sc_starve_peers(tcp_addr, conns):
    """One peer (127.0.0.2) opens `conns` connections, each with two endless
    jobs, enough to take every runner if it could: it holds all but
    `threads` of them, and a job from 127.0.0.1 still finishes while all of
    the greedy ones run or wait."""
    conns = int(conns)
    greedy, ids = [], []
    for _ in range(conns):
        g = TcpPeer(tcp_addr, GREEDY_HOST)
        mine = []
        for _ in range(2):
            rid = g.rid()
            g.send(g.integrate_frame(rid, **huge_job("rqmc")))
            t, r, d = g.recv()
            if t != "JOB_ACCEPTED":
                raise ValueError("huge job answered %s %r" % (t, d))
            mine.append(d["job_id"])
        greedy.append(g)
        ids.append(mine)

    def states():
        return [st for g, mine in zip(greedy, ids) for st in job_states(g, mine)]

    for _ in range(400):
        before = states()
        if before.count("running") >= 2:
            break
        time.sleep(0.05)
    q = TcpPeer(tcp_addr, "127.0.0.1")
    res = tiny_result(q)
    after = states()
    print("# %d connections from %s: %d jobs running, %d queued; a 127.0.0.1 job "
          "finished meanwhile" % (conns, GREEDY_HOST, after.count("running"),
                                  after.count("queued")))
    check("one peer with %d connections x 2 endless jobs: a job from another peer "
          "finished while all %d still ran or waited" % (conns, len(after)),
          all(st in ("running", "queued") for st in after) and
          res["error"] > 0 and abs(res["estimate"] - 1 / 6) <= 6 * res["error"],
          repr(after))
    q.close()
    for g in greedy:
        g.close()
    serves_correctly(tcp_addr, "after one peer's %d greedy connections" % conns)


def rss_parts(pid):
    """VmRSS's parts and the thread count, for a failure's message."""
    with open("/proc/%d/status" % pid) as f:
        return " ".join(line.split(":")[0] + "=" + line.split()[1] for line in f
                        if line.split(":")[0] in ("RssAnon", "RssFile", "RssShmem", "Threads"))


def hungry_job(max_memory):
    """A cubature job that fills max_memory with regions before it stops
    (tol_rel 1e-300: it refines until the region memory bound), on a
    Gaussian whose integral has a closed form."""
    spec = qmcpeer.cli_like_spec("genz-gaussian", 2, "cubature")
    spec.update(a=(5.0, 5.0), u=(0.5, 0.5), tol_rel=1e-300, max_evals=16000000,
                max_memory=max_memory)
    return spec


def hungry_exact():
    """prod over 2 axes of int_0^1 exp(-25 (x - 1/2)^2) dx (Genz 1984's
    Gaussian), by erf."""
    a, u = 5.0, 0.5
    axis = math.sqrt(math.pi) / (2 * a) * (math.erf(a * (1 - u)) + math.erf(a * u))
    return axis * axis


def sc_jobmem(tcp_addr, unix_addr, pid, total_mb, job_mb, slack_mb):
    """Memory-hungry jobs from four peers (127.0.0.1, .2, .3 and a Unix uid),
    two each, every one reserving job_mb under max-jobs-memory-total
    total_mb: no more run at once than fit, the others wait their turn and
    all are answered with the bits of an idle daemon and the closed form
    within the bar; VmRSS stays under +total + slack; a job that alone
    exceeds the total is refused with an ERROR naming the limit; STATS
    counts the waits and the refusal."""
    pid, total_mb, job_mb, slack_mb = int(pid), int(total_mb), int(job_mb), int(slack_mb)
    fit = total_mb // job_mb
    spec = hungry_job(job_mb << 20)
    idle = Peer(unix_addr, timeout=60.0)
    alone = qmcpeer.run_job(idle, spec)
    exact = hungry_exact()
    check("hungry job on an idle daemon: the closed form within its bar (%r, error %r, "
          "exact %r)" % (alone["estimate"], alone["error"], exact),
          abs(alone["estimate"] - exact) <= max(alone["error"], 1e-15))
    st0 = idle.stats()
    base = vmrss_kb(pid)
    base_parts = rss_parts(pid)
    peers = [Peer(unix_addr, timeout=60.0)] + [TcpPeer(tcp_addr, h) for h in
                                              ("127.0.0.1", GREEDY_HOST, "127.0.0.3")]
    jobs = []  # (peer, job id, request id)
    for _ in range(2):
        for p in peers:
            rid = p.rid()
            p.send(p.integrate_frame(rid, **spec))
            t, r, d = p.recv()
            if t != "JOB_ACCEPTED":
                raise ValueError("hungry job answered %s %r" % (t, d))
            jobs.append((p, d["job_id"], rid))
    # Poll states and the reservation until every job has left the queue:
    # never more than `fit` running, never more reserved than the total.
    answers = {}  # request id -> the JOB_RESULT dict, or None for an ERROR

    def state_of(p, jid):
        """JOB_STATUS, keeping any job's final answer that comes first."""
        rid = p.rid()
        p.send(frame(MSG["JOB_STATUS"], rid, struct.pack("<Q", jid)))
        for _ in range(100):
            t, r, d = p.recv()
            if r == rid:
                return d.get("state") if t == "JOB_STATE" else t
            if t in ("JOB_RESULT", "ERROR"):
                answers[r] = d if t == "JOB_RESULT" else None
        return None

    # A queued job cancelled while the others wait for memory is answered
    # at once (cancelled jobs reserve nothing and pass the stall).
    cp, cjid, crid = jobs.pop()
    rid = cp.rid()
    cp.send(frame(MSG["JOB_CANCEL"], rid, struct.pack("<Q", cjid)))
    cancelled = None
    for _ in range(100):
        t, r, d = cp.recv()
        if t in ("JOB_RESULT", "ERROR") and r != rid:
            answers[r] = d if t == "JOB_RESULT" else None
            if r == crid:
                cancelled = d
                break
    # The pool starts the first `fit` jobs on its worker threads, which a
    # loaded machine may not have scheduled yet: wait for that state (by
    # polls, not by a clock) before judging it.
    still = [state_of(p, jid) for p, jid, _ in jobs]
    for _ in range(500):
        if still.count("running") >= fit or any(v not in ("queued", "running") for v in still):
            break
        time.sleep(0.01)
        still = [state_of(p, jid) for p, jid, _ in jobs]
    # (Before any running one ended: the first `fit` still run, the rest
    # still wait.)
    check("a queued hungry job cancelled is answered ECANCELED while the first %d still "
          "run and the rest wait for memory (%s)" % (fit, ",".join(map(str, still))),
          cancelled is not None and cancelled.get("code") == qmcpeer.ECANCELED and
          still.count("running") == fit and still.count("queued") == len(jobs) - fit,
          repr(cancelled))
    most_running, most_reserved, peak, polls = 0, 0, base, 0
    for polls in range(1, 2000):
        states = [state_of(p, jid) for p, jid, _ in jobs]
        st = idle.stats()
        most_running = max(most_running, states.count("running"))
        most_reserved = max(most_reserved, st.get("job_memory_reserved_bytes", -1))
        peak = max(peak, vmrss_kb(pid))
        if "queued" not in states and "running" not in states:
            break
        time.sleep(0.02)
    results = []
    for p, jid, rid in jobs:
        for _ in range(100):
            if rid in answers:
                break
            t, r, d = p.recv()
            if t in ("JOB_RESULT", "ERROR"):
                answers[r] = d if t == "JOB_RESULT" else None
        results.append(answers.get(rid))
    st = idle.stats()
    print("# %d hungry jobs of %d MiB under a %d MiB total: at most %d running, %d bytes "
          "reserved at most, VmRSS %d kB -> peak %d kB (%d polls)"
          % (len(jobs), job_mb, total_mb, most_running, most_reserved, base, peak, polls))
    # (The states are read one job after another, so a scan can see a job
    # still running and its successor already started: the reservation,
    # read at once under the pool's lock, is the count of running jobs.)
    at_once = most_reserved // (job_mb << 20)
    check("%d hungry jobs: at most %d ran at once (reserved %d bytes = %d jobs at most)"
          % (len(jobs), fit, most_reserved, at_once),
          most_reserved % (job_mb << 20) == 0 and 1 <= at_once <= fit and most_running >= 1)
    check("%d hungry jobs: reserved memory stayed within %d MiB (saw %d bytes)"
          % (len(jobs), total_mb, most_reserved), 0 < most_reserved <= total_mb << 20)
    waits = st["job_memory_waits"] - st0["job_memory_waits"]
    check("%d hungry jobs: STATS job_memory_waits counts the jobs that waited (%d, at least "
          "%d)" % (len(jobs), waits, len(jobs) - fit), waits >= len(jobs) - fit)
    check("%d hungry jobs: VmRSS %d kB -> peak %d kB, under +%d MiB"
          % (len(jobs), base, peak, total_mb + slack_mb),
          peak - base < (total_mb + slack_mb) * 1024,
          "at the base %s; now %s" % (base_parts, rss_parts(pid)))
    check("%d hungry jobs from 4 peers: all answered with the same bits as on an idle daemon"
          % len(jobs), len(results) == len(jobs) and all(
              r is not None and qmcpeer.same(r["estimate"], alone["estimate"]) and
              qmcpeer.same(r["error"], alone["error"]) for r in results),
          repr([r and r["estimate"] for r in results]))
    check("after the hungry jobs nothing stays reserved", st["job_memory_reserved_bytes"] == 0,
          repr(st["job_memory_reserved_bytes"]))
    # ... and the memory went back to the kernel, not into the runners'
    # malloc arenas (which kept 24 MiB per runner that ever ran one).
    after = vmrss_kb(pid)
    check("after the hungry jobs VmRSS is back near its base (%d kB -> %d kB, within 16 MiB)"
          % (base, after), after - base < 16 * 1024)
    # One job alone over the total (a budget that could fill its
    # max_memory): refused at once, with the reason.
    big = hungry_job((total_mb + 1) << 20)
    big["max_evals"] = 10 ** 9
    rid = idle.rid()
    idle.send(idle.integrate_frame(rid, **big))
    t, r, d = idle.recv()
    st2 = idle.stats()
    check("a job over max-jobs-memory-total alone gets ERROR naming the limit",
          t == "ERROR" and r == rid and d["code"] == QMC_ETOOBIG and
          "max-jobs-memory-total" in d["message"], repr((t, d)))
    check("STATS refused_job_memory counts it (%d -> %d)"
          % (st["refused_job_memory"], st2["refused_job_memory"]),
          st2["refused_job_memory"] == st["refused_job_memory"] + 1)
    for p in peers:
        p.close()
    idle.close()
    serves_correctly(unix_addr, "after the hungry jobs")


SCENARIOS = dict(jobmem=sc_jobmem, peers=sc_peers, noread=sc_noread, starve=sc_starve, quota=sc_quota, punch=sc_punch,
                 starve_peers=sc_starve_peers)

if __name__ == "__main__":
    sys.exit(qmcpeer.main(sys.argv, SCENARIOS, "greedypeer.py"))
