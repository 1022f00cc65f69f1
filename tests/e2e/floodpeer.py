#!/usr/bin/python3
"""floodpeer.py - e2e attacks of issue 22 on what clients share: clients
without the key flooding the handshake (finding 1), and one peer's jobs
filling max-jobs (finding 2).  For tests/e2e/test_isolation.sh.

    floodpeer.py preauth PORT UNIX_ADDR KEYFILE ROUNDS [SRC DST]
    floodpeer.py nets PORT PORT6 UNIX_ADDR PER_NET TOTAL
    floodpeer.py jobshare UNIX_ADDR TCP_ADDR CONNS JOBS SHARE

preauth: a forked attacker keeps 25 keyless connections open from each of
127.0.0.2..5 (the issue's 4 x 25 = max-connections 100), sending HELLO
and never answering the challenge, and re-opens every one the server
closes, for as long as the test runs (bounded: 90 s at most).  Meanwhile,
ROUNDS times, 0.2 s apart, a Unix-socket client and a key holder over TCP
(from SRC to DST, two addresses off loopback in the test's own network
namespace) must be served; a key holder on loopback (127.0.0.1) shares
loopback's budget with the attacker, and how often it is served is
printed, not promised.

nets: the pre-authentication budget is counted per network: all of
loopback is one, an IPv6 /64 is one, an IPv4 address off loopback is one
(the addresses exist only in the test's network namespace).

jobshare: one peer (this uid, over the Unix socket) opens CONNS
connections x JOBS endless jobs: it gets SHARE of them, the rest are
refused naming max-jobs-per-peer, and another peer's job (TCP 127.0.0.1,
and uid 65534 on the socket when it can reach it) is accepted and answered.

Prints "ok NAME" / "FAIL NAME: why" lines like qmcpeer.py.  Order and
state decide every check (which client was served, which connection got
which ERROR, STATS counters), never time.
"""
import os
import select
import socket
import struct
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import qmcpeer  # noqa: E402
from authpeer import handshake  # noqa: E402
from greedypeer import (TcpPeer, huge_job, parents, raise_nofile,  # noqa: E402
                        serves_correctly, tiny_result, TINY)
from qmcpeer import (MSG, QMC_ETOOBIG, Peer, PeerError, check, frame)  # noqa: E402

ATTACKERS = ["127.0.0.2", "127.0.0.3", "127.0.0.4", "127.0.0.5"]
PER_ATTACKER = 25  # the max-connections-per-peer; 4 x 25 = max-connections


def hello_frame(rid=1):
    return frame(MSG["HELLO"], rid, struct.pack("<HHI", 1, 3, 1 << 20) + qmcpeer.str16("flood"))


def source_socket(src, dst, port, timeout=20.0):
    """A TCP socket from address src to dst:port (either family)."""
    fam = socket.AF_INET6 if ":" in src else socket.AF_INET
    s = socket.socket(fam, socket.SOCK_STREAM)
    s.settimeout(timeout)
    s.bind((src, 0))
    s.connect((dst, int(port)))
    return s


def source_peer(src, dst, port, timeout=20.0):
    """A qmcpeer.Peer (no HELLO sent) on a socket from src."""
    p = Peer.__new__(Peer)
    p.s = source_socket(src, dst, port, timeout)
    p.buf, p.next_id, p.info, p.ring = bytearray(), 100, None, None
    return p


def stats(unix_addr):
    p = Peer(unix_addr, timeout=20.0)
    st = p.stats()
    p.close()
    return st


# ---- the attacker (a child process) --------------------------------------------

def attack(port, ctl, report, deadline_s=90.0):
    """Keeps PER_ATTACKER keyless connections from each ATTACKERS address
    open on 127.0.0.1:port, each having sent HELLO, and re-opens any the
    server closes, until ctl becomes readable or deadline_s passes.
    Writes "ready" on report once the server has answered (a challenge or
    an ERROR) as many connections as it keeps, then at the end the count
    of connections it re-opened."""
    raise_nofile(4096)
    socks = {}  # socket -> [source address, answered yet]
    answered, reopened, ready = 0, 0, False
    end = time.monotonic() + deadline_s

    def open_one(src):
        s = source_socket(src, "127.0.0.1", port)
        try:
            s.sendall(hello_frame())
        except OSError:
            pass  # closed at once: seen as EOF below
        s.setblocking(False)
        socks[s] = [src, False]

    for src in ATTACKERS:
        for _ in range(PER_ATTACKER):
            open_one(src)
    want = len(socks)
    while time.monotonic() < end:
        r, _, _ = select.select([ctl] + list(socks), [], [], 0.2)
        if ctl in r:
            break
        for s in r:
            if s is ctl:
                continue
            try:
                data = s.recv(65536)
            except BlockingIOError:
                continue
            except OSError:
                data = b""
            entry = socks[s]
            if not entry[1]:
                entry[1] = True
                answered += 1
            if data:
                continue  # a challenge it will never answer, or an ERROR before EOF
            src = entry[0]
            del socks[s]
            s.close()
            try:
                open_one(src)
                reopened += 1
            except OSError:
                pass
        if not ready and answered >= want:
            os.write(report, b"ready\n")
            ready = True
    for s in socks:
        s.close()
    os.write(report, b"reopened %d\n" % reopened)


def sc_preauth(port, unix_addr, keyfile, rounds, src=None, dst=None):
    rounds = int(rounds)
    key = open(keyfile, "rb").read()
    ctl_r, ctl_w = os.pipe()
    rep_r, rep_w = os.pipe()
    child = os.fork()
    if child == 0:
        os.close(ctl_w)
        os.close(rep_r)
        try:
            attack(int(port), ctl_r, rep_w)
        finally:
            os._exit(0)
    os.close(ctl_r)
    os.close(rep_w)
    rep = os.fdopen(rep_r)
    # Wait (bounded by the attacker's own deadline) until the server has
    # seen the whole first wave.
    first = rep.readline().strip()
    check("the attacker's %d keyless connections were all answered (the attack is on)"
          % (len(ATTACKERS) * PER_ATTACKER), first == "ready", repr(first))

    served = {"unix": 0, "remote": 0, "loopback": 0}
    why = {}

    def attempt(kind, fn):
        try:
            if fn():
                served[kind] += 1
                return
            why[kind] = "not served"
        except (OSError, ValueError, PeerError) as e:
            why[kind] = "%s: %s" % (type(e).__name__, e)

    def unix_client():
        p = Peer(unix_addr, timeout=20.0)
        ok = p.ping()
        p.close()
        return ok

    def key_holder(s, d):
        def run():
            p = source_peer(s, d, port)
            r = handshake(p, key)
            ok = r[0] == "ok" and p.ping()
            if r[0] != "ok":
                why_text = r[1].get("message") if isinstance(r[1], dict) else r
                p.close()
                raise ValueError("handshake: %s" % why_text)
            p.close()
            return ok
        return run

    t0 = time.monotonic()
    for _ in range(rounds):
        attempt("unix", unix_client)
        if src:
            attempt("remote", key_holder(src, dst))
        attempt("loopback", key_holder("127.0.0.1", "127.0.0.1"))
        time.sleep(0.2)  # pacing only: the rounds spread over the attack
    seconds = time.monotonic() - t0
    os.write(ctl_w, b"stop\n")
    last = rep.readline().strip()
    os.waitpid(child, 0)
    reopened = int(last.split()[1]) if last.startswith("reopened ") else -1
    print("# %d rounds in %.1f s against 4 x %d keyless connections (re-opened %d times): "
          "Unix client served %d, key holder from %s served %d, key holder on loopback "
          "served %d" % (rounds, seconds, PER_ATTACKER, reopened, served["unix"], src or "-",
                         served["remote"], served["loopback"]))
    check("a Unix-socket client is served every time under the flood (%d of %d)"
          % (served["unix"], rounds), served["unix"] == rounds, why.get("unix", ""))
    if src:
        check("a key holder over TCP from %s is served every time under the flood (%d of %d)"
              % (src, served["remote"], rounds), served["remote"] == rounds,
              why.get("remote", ""))
    # Loopback is the attacker's network too: its key holder competes for
    # loopback's share, and wins its race only often, not always.
    check("a key holder on loopback, sharing loopback's share with the flood, is served "
          "(%d of %d)" % (served["loopback"], rounds), served["loopback"] >= 1,
          why.get("loopback", ""))
    st = stats(unix_addr)
    check("the flood never reached max-connections (connections_rejected %d) and was "
          "turned away by its own share (handshakes_evicted %d)"
          % (st["connections_rejected"], st.get("handshakes_evicted", 0)),
          st["connections_rejected"] == 0 and st.get("handshakes_evicted", 0) > 0)
    serves_correctly(unix_addr, "after the keyless flood")


# ---- per network -------------------------------------------------------------------

def first_frame(p, timeout=20.0):
    """The next frame on p, or None at EOF / reset."""
    p.s.settimeout(timeout)
    try:
        return p.recv()
    except (ConnectionResetError, socket.timeout, ValueError):
        return None


def readable(p):
    """True when p has something to read now (a frame, or EOF)."""
    if p.has_frame():
        return True
    r, _, _ = select.select([p.s], [], [], 0)
    return bool(r)


def sc_nets(port, port6, unix_addr, per_net, total):
    """Silent connections from several networks: each network holds at
    most per_net of them, a newcomer past that evicts its own network's
    oldest; past `total` the oldest handshake of the busiest networks
    gives its place up."""
    per_net, total = int(per_net), int(total)

    def evicted():
        return stats(unix_addr).get("handshakes_evicted", 0)

    def fill(src, n):
        if src.startswith("127.") or src == "::1":
            dst, prt = ("::1", port6) if src == "::1" else ("127.0.0.1", port)
        else:
            dst, prt = ("2001:db8:0:1::1", port6) if ":" in src else ("192.0.2.1", port)
        return [source_peer(src, dst, prt) for _ in range(n)]

    def settled(want):
        """Polls STATS (bounded) until want handshakes are held."""
        for _ in range(500):
            if stats(unix_addr).get("handshakes_open", -1) == want:
                return True
            time.sleep(0.02)
        return False

    def evicted_for(f, limit, net):
        return (f is not None and f[0] == "ERROR" and f[2]["code"] == QMC_ETOOBIG and
                limit in f[2]["message"] and net in f[2]["message"])

    e0 = evicted()
    n = per_net
    # Loopback is one network: 127.0.0.2 and ::1 share one share.
    lo = fill("127.0.0.2", n)
    check("loopback: %d silent handshakes held (STATS handshakes_open)" % n, settled(n))
    extra = fill("::1", 1)
    f = first_frame(lo[0])
    check("one more from ::1 evicts loopback's oldest (127.0.0.2's first): ERROR naming "
          "max-preauth-connections-per-peer and loopback",
          evicted_for(f, "max-preauth-connections-per-peer (%d)" % n, "loopback") and
          settled(n) and not any(readable(p) for p in lo[1:] + extra), repr(f))
    # An IPv6 /64 is one network.
    v6 = fill("2001:db8:0:2::1", n)
    settled(2 * n)
    same64 = fill("2001:db8:0:2::2", 1)
    f = first_frame(v6[0])
    check("2001:db8:0:2::2 evicts 2001:db8:0:2::1's oldest (one /64, one share)",
          evicted_for(f, "max-preauth-connections-per-peer", "2001:db8:0:2::/64") and
          settled(2 * n), repr(f))
    # An IPv4 address off loopback is one network; another is another.
    v4 = fill("192.0.2.3", n)
    settled(3 * n)
    other = fill("192.0.2.4", 1)
    check("192.0.2.4 evicts nobody while 192.0.2.3 holds its share (%d held)" % (3 * n + 1),
          settled(3 * n + 1) and evicted() == e0 + 2 and
          not any(readable(p) for p in lo[1:] + extra + v6[1:] + same64 + v4 + other))
    # Loopback, the /64 and 192.0.2.3 hold n each, 192.0.2.4 one: that is
    # `total`.  A newcomer from a fresh /64 takes the place of the oldest
    # handshake of the busiest networks: loopback's oldest left (lo[1]).
    check("the server holds max-preauth-connections (%d) handshakes" % total,
          3 * n + 1 == total)
    fresh = fill("2001:db8:0:3::1", 1)
    f = first_frame(lo[1])
    check("past max-preauth-connections a newcomer from a fresh /64 evicts the oldest "
          "handshake of the busiest networks (loopback's): ERROR naming "
          "max-preauth-connections", evicted_for(f, "max-preauth-connections (%d)" % total,
                                                 "loopback") and settled(total) and
          not any(readable(p) for p in lo[2:] + extra + v6[1:] + same64 + v4 + other + fresh),
          repr(f))
    check("STATS handshakes_evicted counts each eviction (%d)" % (evicted() - e0),
          evicted() - e0 == 3)
    for p in lo + extra + v6 + same64 + v4 + other + fresh:
        p.close()


# ---- jobs per peer ------------------------------------------------------------------

def sc_jobshare(unix_addr, tcp_addr, conns, jobs, share):
    conns, jobs, share = int(conns), int(jobs), int(share)
    st0 = stats(unix_addr)
    greedy, accepted, refused, other = [], 0, 0, []
    for _ in range(conns):
        g = Peer(unix_addr, timeout=60.0)
        for _ in range(jobs):
            rid = g.rid()
            g.send(g.integrate_frame(rid, **huge_job("rqmc")))
            t, r, d = g.recv()
            if t == "JOB_ACCEPTED":
                accepted += 1
            elif t == "ERROR" and d["code"] == QMC_ETOOBIG and \
                    "max-jobs-per-peer" in d["message"]:
                refused += 1
            else:
                other.append((t, d.get("message")))
        greedy.append(g)
    print("# uid %d: %d connections x %d endless jobs: %d accepted, %d refused "
          "(max-jobs-per-peer), %d other answers" % (os.getuid(), conns, jobs, accepted,
                                                      refused, len(other)))
    check("one peer's %d x %d endless jobs: %d accepted (its share), %d refused naming "
          "max-jobs-per-peer" % (conns, jobs, share, conns * jobs - share),
          accepted == share and refused == conns * jobs - share and not other,
          "accepted %d, refused %d, other %r" % (accepted, refused, other[:2]))
    # Another peer: 127.0.0.1 over TCP.
    try:
        q = TcpPeer(tcp_addr, "127.0.0.1")
        res = tiny_result(q)
        q.close()
        check("while one peer floods, a job from 127.0.0.1 is accepted and answered "
              "(1/6 within 6 standard errors: %r +- %r)" % (res["estimate"], res["error"]),
              res["error"] > 0 and abs(res["estimate"] - 1 / 6) <= 6 * res["error"])
    except (OSError, ValueError, PeerError) as e:
        check("while one peer floods, a job from 127.0.0.1 is accepted", False,
              "%s: %s" % (type(e).__name__, e))
    # Another uid on the same socket (as root: a child dropped to nobody).
    if os.getuid() == 0:
        r, w = os.pipe()
        child = os.fork()
        if child == 0:
            os.close(r)
            code = b"1"
            try:
                os.setgid(65534)
                os.setuid(65534)
                path = unix_addr[len("unix:"):]
                if not all(os.access(d, os.X_OK) for d in parents(path)):
                    code = b"2"
                else:
                    c = Peer(unix_addr, timeout=60.0)
                    rid = c.rid()
                    c.send(c.integrate_frame(rid, **TINY))
                    t, rr, d = c.recv()
                    code = b"0" if t == "JOB_ACCEPTED" else b"1 " + repr((t, d)).encode()
                    c.close()
            except BaseException as e:  # reported through the pipe
                code = b"1 " + repr(e).encode()
            os.write(w, code)
            os._exit(0)
        os.close(w)
        said = os.read(r, 512)
        os.close(r)
        os.waitpid(child, 0)
        if said == b"2":
            print("skip: uid 65534 cannot reach %s here" % unix_addr)
        else:
            check("while uid %d floods, uid 65534's job on the same socket is accepted"
                  % os.getuid(), said == b"0", repr(said))
    # The flooding peer's connections still answer.
    check("the flooding peer's connections still answer PING", all(g.ping() for g in greedy))
    st = stats(unix_addr)
    check("STATS refused_jobs_per_peer counts the refusals (%d), refused_jobs none (%d)"
          % (st.get("refused_jobs_per_peer", 0) - st0.get("refused_jobs_per_peer", 0),
             st["refused_jobs"] - st0["refused_jobs"]),
          st.get("refused_jobs_per_peer", 0) - st0.get("refused_jobs_per_peer", 0) ==
          conns * jobs - share and st["refused_jobs"] == st0["refused_jobs"])
    for g in greedy:
        g.close()


SCENARIOS = dict(preauth=sc_preauth, nets=sc_nets, jobshare=sc_jobshare)

if __name__ == "__main__":
    sys.exit(qmcpeer.main(sys.argv, SCENARIOS, "floodpeer.py"))
