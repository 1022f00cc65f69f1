#!/usr/bin/python3
"""modbus_isolation.py - hostile Modbus TCP clients for
tests/e2e/test_modbus_isolation.sh: silent sockets and read-only floods
that must not take the Modbus server from everyone else (issue 22, 4).

Every scenario prints one "ok NAME" or "FAIL NAME: why" line per check;
the exit status is the number of failures.  The daemon's counters come
from its STATS over the Unix socket (`qmc stats`, $QMC), so that reading
them takes no Modbus slot.  Frames are built from the spec here (MBAP:
transaction id, protocol id 0, length, unit id; then the PDU).

  silent   P4 UNIX N SRC        N silent sockets from loopback, then a
                                newcomer from SRC connects 12 times
  readers  P4 UNIX              FC03 from 4 loopback addresses x 256 units,
                                then a newcomer's FC17, FC43 and FC03
  conns    P4 P6 UNIX CAP MAX   the per-peer connection cap, peer by peer
                                (needs the addresses the test puts on lo)
  banks    P4 P6 UNIX SHARE MAX the per-peer bank share and the full table
                                (same)
  allow    P4 ALLOWED REFUSED   modbus-allow's IPv4-mapped entries

The addresses off 127.0.0.0/8 exist only inside the test's own network
namespace (RFC 5737 and RFC 3849 documentation ranges on its lo).
"""
import os
import select
import socket
import struct
import subprocess
import sys
import time

from modbus_peer import adu, connect, recv_adu

QMC = os.environ.get("QMC", "qmc")
failures = 0
# The defaults of a fresh bank (MODBUS.md section 3): sobol, 2 dims, the
# rest 0; and the result block's status 1, no request yet.
DEFAULT_HR = [1, 2] + [0] * 11


def check(name, cond, why=""):
    global failures
    if cond:
        print("ok", name)
    else:
        failures += 1
        print("FAIL %s: %s" % (name, why))


def stats(unix):
    out = subprocess.run([QMC, "stats", "--connect", "unix:" + unix], check=True,
                         stdout=subprocess.PIPE, text=True).stdout
    vals = {}
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == 2 and parts[1].isdigit():
            vals[parts[0]] = int(parts[1])
    return vals


def settle(unix, want):
    """Polls STATS (at most 10 s) until the server has accepted or refused
    `want` Modbus connections in all; returns the last STATS."""
    for _ in range(400):
        st = stats(unix)
        if (st.get("modbus_connections_accepted", 0) +
                st.get("modbus_connections_refused", 0)) >= want:
            return st
        time.sleep(0.025)
    return stats(unix)


def endpoint(src, p4, p6):
    return ("::1", p6) if ":" in src else ("127.0.0.1", p4)


def request(s, tid, unit, pdu):
    """One request, its answer's PDU; b"" when the server closed."""
    try:
        s.sendall(adu(tid, unit, pdu))
        rtid, runit, resp = recv_adu(s)
    except (EOFError, ConnectionResetError, BrokenPipeError):
        return b""
    if rtid != tid or runit != unit:
        raise ValueError("answer for %d/%d, want %d/%d" % (rtid, runit, tid, unit))
    return resp


def fc03(addr, count):
    return struct.pack(">BHH", 3, addr, count)


def fc06(addr, value):
    return struct.pack(">BHH", 6, addr, value)


FC17 = b"\x11"
FC43 = b"\x2b\x0e\x01\x00"


def regs(resp, fc, count):
    if len(resp) != 2 + 2 * count or resp[0] != fc or resp[1] != 2 * count:
        return None
    return list(struct.unpack(">%dH" % count, resp[2:]))


def served(src, p4, p6, unit=1):
    """Connects from src and reads the bank's holding registers: the
    registers, or None if the connection was closed unanswered."""
    host, port = endpoint(src, p4, p6)
    s = connect(host, port, src)
    try:
        return regs(request(s, 1, unit, fc03(0, 13)), 3, 13)
    finally:
        s.close()


def closed_set(socks, want, bound_s=10.0):
    """The sockets the server has closed (readable at EOF), waiting at most
    bound_s for `want` of them; the others were never readable (silent
    sockets get no data)."""
    closed = set()
    deadline = time.monotonic() + bound_s
    while len(closed) < want and time.monotonic() < deadline:
        live = [s for s in socks if s not in closed]
        r, _, _ = select.select(live, [], [], 0.2)
        for s in r:
            try:
                data = s.recv(1)
            except ConnectionResetError:
                data = b""
            if data:
                raise ValueError("a silent socket got data %r" % data)
            closed.add(s)
    return closed


# ---- the attacks, at the defaults ---------------------------------

def run_silent(p4, unix, n, src):
    """N sockets that never send, from 127.0.0.2..5 (all loopback: one
    peer), then 12 connections from a newcomer at src: each must be
    served.  Before the per-peer cap, N = modbus-max-connections silent
    sockets refused the newcomer 12 times of 12."""
    socks = [connect("127.0.0.1", p4, "127.0.0.%d" % (2 + k % 4)) for k in range(n)]
    st = settle(unix, n)
    got = [served(src, p4, 0) for _ in range(12)]
    ok = sum(1 for g in got if g == DEFAULT_HR)
    check("silent: newcomer %s served %d of 12 times beside %d silent loopback sockets"
          % (src, ok, n), ok == 12, repr(got[:2]))
    print("# silent: open %d, refused %d, refused per peer %d" % (
        st.get("modbus_connections_open", -1), st.get("modbus_connections_refused", -1),
        st.get("modbus_refused_connections_per_peer", -1)))
    for s in socks:
        s.close()


def run_readers(p4, unix):
    """Plain FC03 reads from 4 addresses x 256 unit ids: each answered
    with a fresh bank's registers, and none creates a bank, so a newcomer's
    FC17, FC43 and FC03 are answered (before: exception 06, every bank in
    use)."""
    bad = 0
    for a in range(4):
        s = connect("127.0.0.1", p4, "127.0.0.%d" % (2 + a))
        for unit in range(256):
            if regs(request(s, unit, unit, fc03(0, 13)), 3, 13) != DEFAULT_HR:
                bad += 1
        s.close()
    check("readers: 1024 FC03 of fresh banks answered with the defaults", bad == 0,
          "%d wrong" % bad)
    st = stats(unix)
    check("readers: no bank was made by a read", st.get("modbus_sessions") == 0,
          "modbus_sessions %r" % st.get("modbus_sessions"))
    s = connect("127.0.0.1", p4, "127.0.0.6")
    r17 = request(s, 1, 1, FC17)
    r43 = request(s, 2, 1, FC43)
    r03 = request(s, 3, 1, fc03(0, 13))
    s.close()
    check("readers: a newcomer's FC17 is answered", r17[:1] == b"\x11" and b"qmcd" in r17,
          repr(r17))
    check("readers: a newcomer's FC43 is answered", r43[:2] == b"\x2b\x0e" and b"qmcd" in r43,
          repr(r43))
    check("readers: a newcomer's FC03 is answered", regs(r03, 3, 13) == DEFAULT_HR, repr(r03))


# ---- the per-peer connection cap, peer by peer ---------------------------------

def open_silent(sources, p4, p6):
    return [connect(*endpoint(src, p4, p6), src) for src in sources]


def run_conns(p4, p6, unix, cap, most):
    """With modbus-max-connections-per-peer CAP and modbus-max-connections
    MOST (3 * CAP + 1): loopback is one peer (127.0.0.2, .3 and ::1 share a
    cap), an IPv6 /64 is one peer, an IPv4 address off loopback is one
    peer; a newcomer from another peer is served while one holds its cap,
    and the server-wide cap still holds."""
    accepted = 0
    loop = open_silent(["127.0.0.2"] * 4 + ["127.0.0.3"] * 3 + ["::1"] * 3, p4, p6)
    st = settle(unix, 10)
    closed = closed_set(loop, 10 - cap)
    check("conns: 10 silent sockets from 127.0.0.2, .3 and ::1: %d closed at accept (want %d)"
          % (len(closed), 10 - cap), len(closed) == 10 - cap and
          st.get("modbus_refused_connections_per_peer") == 10 - cap,
          "open %r, refused per peer %r" % (st.get("modbus_connections_open"),
                                           st.get("modbus_refused_connections_per_peer")))
    kept = [s for s in loop if s not in closed]
    answers = [regs(request(s, 9, 1, fc03(0, 13)), 3, 13) for s in kept]
    check("conns: the %d loopback sockets let in are served" % len(kept),
          len(kept) == cap and all(a == DEFAULT_HR for a in answers), repr(answers))
    accepted += 10
    got = [served(src, p4, p6) for src in ["192.0.2.1", "2001:db8:0:1::1"] * 6]
    accepted += 12
    check("conns: newcomers from 192.0.2.1 and 2001:db8:0:1::1 served 12 of 12 while "
          "loopback holds its cap", all(g == DEFAULT_HR for g in got), repr(got))
    # An IPv6 /64 is one peer: ::1 and ::2 of 2001:db8:0:2::/64 share a cap.
    net = open_silent(["2001:db8:0:2::1"] * (cap // 2) +
                      ["2001:db8:0:2::2"] * (cap - cap // 2), p4, p6)
    extra = open_silent(["2001:db8:0:2::3"], p4, p6)
    accepted += cap + 1
    settle(unix, accepted)
    check("conns: a third address of a /64 holding its cap is closed at accept",
          len(closed_set(extra, 1)) == 1)
    check("conns: another /64 (2001:db8:0:3::1) is served",
          served("2001:db8:0:3::1", p4, p6) == DEFAULT_HR)
    accepted += 1
    # IPv4 off loopback: per address.
    v4 = open_silent(["192.0.2.2"] * cap, p4, p6)
    extra = open_silent(["192.0.2.2"], p4, p6)
    accepted += cap + 1
    settle(unix, accepted)
    check("conns: 192.0.2.2's connection past its cap is closed at accept",
          len(closed_set(extra, 1)) == 1)
    check("conns: 192.0.2.3 is served", served("192.0.2.3", p4, p6) == DEFAULT_HR)
    accepted += 1
    # With 192.0.2.4 in the last slot, three peers at their caps and one
    # more fill modbus-max-connections: the server-wide cap still closes a
    # fifth peer's connection, and counts it apart.
    last = open_silent(["192.0.2.4"], p4, p6)
    extra = open_silent(["192.0.2.5"], p4, p6)
    accepted += 2
    st = settle(unix, accepted)
    check("conns: with %d open (3 peers x %d, and one), a fifth peer meets "
          "modbus-max-connections" % (most, cap), len(closed_set(extra, 1)) == 1 and
          st.get("modbus_connections_open") == most, repr(st.get("modbus_connections_open")))
    want_pp = (10 - cap) + 2
    check("conns: STATS modbus_refused_connections_per_peer %r == %d"
          % (st.get("modbus_refused_connections_per_peer"), want_pp),
          st.get("modbus_refused_connections_per_peer") == want_pp)
    check("conns: STATS modbus_connections_refused %r == %d (per peer + 1 server-wide)"
          % (st.get("modbus_connections_refused"), want_pp + 1),
          st.get("modbus_connections_refused") == want_pp + 1)
    for s in loop + net + v4 + last:
        s.close()


# ---- banks: reads take none, writes take a share ---------------------------

def write(src, p4, p6, unit, addr, value):
    """FC06 from src: the answer PDU (the echo, or an exception)."""
    host, port = endpoint(src, p4, p6)
    s = connect(host, port, src)
    try:
        return request(s, 1, unit, fc06(addr, value))
    finally:
        s.close()


def ask(src, p4, p6, unit, pdu):
    host, port = endpoint(src, p4, p6)
    s = connect(host, port, src)
    try:
        return request(s, 1, unit, pdu)
    finally:
        s.close()


def run_banks(p4, p6, unix, share, most):
    """With modbus-max-sessions-per-peer SHARE and modbus-max-sessions MOST
    (2 * SHARE + 2)."""
    # A write refused with an exception stores nothing: no bank either.
    r = write("192.0.2.1", p4, p6, 1, 1, 33)
    check("banks: a refused write (dims 33) is exception 03", r == b"\x86\x03", repr(r))
    check("banks: ... and leaves no bank", stats(unix).get("modbus_sessions") == 0)
    # Loopback is one peer: three addresses, one share.
    srcs = ["127.0.0.2", "127.0.0.3", "::1", "127.0.0.4"][:share + 1]
    for k, src in enumerate(srcs[:share]):
        r = write(src, p4, p6, 7, 10, 100 + k)
        check("banks: loopback bank %d (%s, unit 7) is made by a write" % (k + 1, src),
              r == fc06(10, 100 + k), repr(r))
    r = write(srcs[share], p4, p6, 7, 10, 999)
    check("banks: a write past loopback's share of %d is exception 06" % share,
          r == b"\x86\x06", repr(r))
    st = stats(unix)
    check("banks: STATS modbus_sessions %r == %d, modbus_refused_sessions_per_peer %r == 1"
          % (st.get("modbus_sessions"), share, st.get("modbus_refused_sessions_per_peer")),
          st.get("modbus_sessions") == share and
          st.get("modbus_refused_sessions_per_peer") == 1)
    # The refused client still reads (the default bank), FC17 and FC43.
    r03 = ask(srcs[share], p4, p6, 7, fc03(0, 13))
    r17 = ask(srcs[share], p4, p6, 7, FC17)
    r43 = ask(srcs[share], p4, p6, 7, FC43)
    check("banks: ... which still gets FC03 (defaults), FC17 and FC43",
          regs(r03, 3, 13) == DEFAULT_HR and r17[:1] == b"\x11" and r43[:2] == b"\x2b\x0e",
          "%r %r %r" % (r03, r17, r43))
    # A newcomer from another peer writes and reads back its own state.
    r = write("192.0.2.1", p4, p6, 7, 10, 4242)
    got = ask("192.0.2.1", p4, p6, 7, struct.pack(">BHH", 4, 0, 1))
    check("banks: newcomer 192.0.2.1 gets a bank while loopback holds its share",
          r == fc06(10, 4242) and regs(got, 4, 1) == [4242], "%r %r" % (r, got))
    # Fill the table: 192.0.2.1's share, then 2001:db8:0:1::/64's.
    for unit in range(8, 8 + share - 1):
        write("192.0.2.1", p4, p6, unit, 10, unit)
    left = most - 2 * share
    for unit in range(1, 1 + left):
        r = write("2001:db8:0:1::1", p4, p6, unit, 10, unit)
    st = stats(unix)
    check("banks: the table is full (%r of %d)" % (st.get("modbus_sessions"), most),
          st.get("modbus_sessions") == most)
    r = write("2001:db8:0:3::1", p4, p6, 1, 10, 1)
    check("banks: a write from a peer with no bank, the table full, is exception 06",
          r == b"\x86\x06", repr(r))
    r03 = ask("2001:db8:0:3::1", p4, p6, 1, fc03(0, 13))
    r17 = ask("2001:db8:0:3::1", p4, p6, 1, FC17)
    check("banks: ... and still gets FC03 and FC17",
          regs(r03, 3, 13) == DEFAULT_HR and r17[:1] == b"\x11", "%r %r" % (r03, r17))
    # Every bank written keeps its state.
    kept = [regs(ask(src, p4, p6, 7, struct.pack(">BHH", 4, 0, 1)), 4, 1)
            for src in srcs[:share]]
    check("banks: the loopback banks keep their writes", kept ==
          [[100 + k] for k in range(share)], repr(kept))
    st = stats(unix)
    check("banks: STATS modbus_refused_sessions %r == 1 (the full table)"
          % st.get("modbus_refused_sessions"), st.get("modbus_refused_sessions") == 1)


# ---- modbus-allow with IPv4-mapped entries ------------------------------------

def run_allow(p4, allowed, refused):
    for src in allowed.split(","):
        check("allow: %s (an IPv4-mapped entry) is let in" % src,
              served(src, p4, 0) == DEFAULT_HR)
    for src in refused.split(","):
        check("allow: %s is closed at accept" % src, served(src, p4, 0) is None)


def main():
    mode = sys.argv[1]
    a = sys.argv[2:]
    if mode == "silent":
        run_silent(int(a[0]), a[1], int(a[2]), a[3])
    elif mode == "readers":
        run_readers(int(a[0]), a[1])
    elif mode == "conns":
        run_conns(int(a[0]), int(a[1]), a[2], int(a[3]), int(a[4]))
    elif mode == "banks":
        run_banks(int(a[0]), int(a[1]), a[2], int(a[3]), int(a[4]))
    elif mode == "allow":
        run_allow(int(a[0]), a[1], a[2])
    else:
        print("FAIL unknown mode", mode)
        return 1
    return min(failures, 100)


if __name__ == "__main__":
    sys.exit(main())
