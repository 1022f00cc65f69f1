#!/usr/bin/python3
"""modbus_peer.py - Modbus TCP peers for tests/e2e/test_modbus.sh.

Every check compares with `qmc points` (run here through $QMC) or with the
Modbus spec itself, and prints one "ok NAME" or "FAIL NAME: why" line; the
exit status is the number of failures.

  modbus_peer.py pymodbus HOST PORT    python3-pymodbus: FC03/04/06/16/23,
                                       FC17, FC43/14 and exceptions 01..03
  modbus_peer.py dribble HOST PORT     a client dribbling one byte every
                                       100 ms while another is served
  modbus_peer.py many HOST PORT N      N connections at once, own banks
  modbus_peer.py refused HOST PORT SRC a client from SRC is closed at accept
  modbus_peer.py stall HOST PORT       a half-sent frame is closed by the
                                       partial-frame deadline
  modbus_peer.py raw HOST PORT         bad MBAP headers close the connection
  modbus_peer.py limits HOST PORT      against --modbus-max-sessions 2 and
                                       --modbus-max-connections 3
  modbus_peer.py nonreader HOST PORT   a client that never reads is closed
                                       after write-timeout-ms

Raw frames are built here from the spec (MBAP: transaction id, protocol
id 0, length, unit id; then the PDU), not from pymodbus.
"""
import os
import socket
import struct
import subprocess
import sys
import time

QMC = os.environ.get("QMC", "qmc")
failures = 0


def check(name, cond, why=""):
    global failures
    if cond:
        print("ok", name)
    else:
        failures += 1
        print("FAIL %s: %s" % (name, why))


def qmc_words(kind, dims, scramble, seed, index, fmt):
    """The registers of a point as `qmc points` computes it: f32 and u32
    as their 32-bit patterns split high word first, u16 as floor(x*2^16),
    i.e. the top half of the u32 fixed point."""
    qfmt = "f32" if fmt == 0 else "u32"
    out = subprocess.run(
        [QMC, "points", "--seq", kind, "--dims", str(dims), "--scramble", scramble,
         "--seed", str(seed), "--start", str(index), "--count", "1", "--format", qfmt],
        check=True, stdout=subprocess.PIPE).stdout
    vals = struct.unpack("<%dI" % dims, out)
    if fmt == 1:
        return [v >> 16 for v in vals]
    words = []
    for v in vals:
        words += [v >> 16, v & 0xFFFF]
    return words


# ---- raw Modbus TCP ---------------------------------------------------------

def adu(tid, unit, pdu):
    return struct.pack(">HHHB", tid, 0, len(pdu) + 1, unit) + pdu


def recv_exact(s, n):
    buf = b""
    while len(buf) < n:
        chunk = s.recv(n - len(buf))
        if not chunk:
            raise EOFError("closed after %d of %d bytes" % (len(buf), n))
        buf += chunk
    return buf


def recv_adu(s):
    head = recv_exact(s, 7)
    tid, proto, length, unit = struct.unpack(">HHHB", head)
    return tid, unit, recv_exact(s, length - 1)


def connect(host, port, src=None):
    fam = socket.AF_INET6 if ":" in host else socket.AF_INET
    s = socket.socket(fam, socket.SOCK_STREAM)
    s.settimeout(20)
    if src:
        s.bind((src, 0))
    s.connect((host, port))
    s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    return s


def read_input(s, tid, unit, addr, count):
    s.sendall(adu(tid, unit, struct.pack(">BHH", 4, addr, count)))
    rtid, runit, pdu = recv_adu(s)
    if rtid != tid or runit != unit or pdu[0] != 4 or pdu[1] != 2 * count:
        raise ValueError("bad answer %r" % pdu)
    return list(struct.unpack(">%dH" % count, pdu[2:]))


def write_single(s, tid, unit, addr, value):
    req = struct.pack(">BHH", 6, addr, value)
    s.sendall(adu(tid, unit, req))
    rtid, runit, pdu = recv_adu(s)
    if pdu != req:
        raise ValueError("write %d=%d answered %r" % (addr, value, pdu))


# ---- pymodbus ---------------------------------------------------------------

def run_pymodbus(host, port):
    from pymodbus.client import ModbusTcpClient
    from pymodbus.mei_message import ReadDeviceInformationRequest
    from pymodbus.other_message import ReportSlaveIdRequest
    c = ModbusTcpClient(host, port=port, timeout=10)
    check("pymodbus connect", c.connect())
    unit = 17
    cases = [("sobol", 1, "none", 0, 0, 0, 0, 5),
             ("sobol", 5, "owen", 1, 77, 0, 0, 1000),
             ("sobol", 8, "shift", 2, 4242, 2, 1, 123456),
             ("halton", 3, "faure", 3, 9, 1, 0, 31),
             ("halton", 32, "owen", 1, 0xDEADBEEF, 0, 1, 4294967295),
             ("sobol", 7, "fast-owen", 4, 2024, 0, 0, 65535),
             ("random", 4, "none", 0, 5, 2, 0, 99)]
    req = 0
    for kind, dims, scr, scr_code, seed, fmt, order, index in cases:
        req += 1
        kcode = {"sobol": 1, "halton": 2, "random": 3}[kind]
        regs = [kcode, dims, scr_code, seed >> 16, seed & 0xFFFF, fmt,
                (index >> 48) & 0xFFFF, (index >> 32) & 0xFFFF, (index >> 16) & 0xFFFF,
                index & 0xFFFF, req, 0, order]
        # FC16 sets up and triggers in one write; FC04 reads the block.
        w = c.write_registers(0, regs, slave=unit)
        name = "pymodbus %s d%d %s fmt%d order%d" % (kind, dims, scr, fmt, order)
        check(name + " FC16", not w.isError(), str(w))
        want = qmc_words(kind, dims, scr, seed, index, fmt)
        if order == 1 and fmt != 1:
            want = [want[i ^ 1] for i in range(len(want))]
        n = 6 + len(want)
        r = c.read_input_registers(0, n, slave=unit)
        got = r.registers if not r.isError() else None
        head = [req, 0, (index >> 48) & 0xFFFF, (index >> 32) & 0xFFFF,
                (index >> 16) & 0xFFFF, index & 0xFFFF]
        check(name + " FC04 == qmc points", got == head + want, "%r vs %r" % (got, head + want))
        h = c.read_holding_registers(100, n, slave=unit)
        check(name + " FC03 100.. == FC04 0..", not h.isError() and h.registers == got)
    # FC23: next index and a new request number, answer in the same reply.
    # (pymodbus 3.0.0rc1: the client's methods take slave=, the request
    # classes behind readwrite_registers and execute take unit=.)
    rw = c.readwrite_registers(read_address=100, read_count=8, write_address=9,
                               write_registers=[7, 50], unit=unit)
    want = qmc_words("random", 4, "none", 5, 7, 2)
    check("pymodbus FC23 writes then reads", not rw.isError() and
          rw.registers == [50, 0, 0, 0, 0, 7] + want[:2], str(getattr(rw, "registers", rw)))
    # FC06 auto-advance: request numbers 51, 52 give points 7 and 8.
    c.write_register(11, 1, slave=unit)
    c.write_register(10, 51, slave=unit)
    c.write_register(10, 51, slave=unit)      # a retry: no skip
    a = c.read_input_registers(5, 1, slave=unit).registers[0]
    c.write_register(10, 52, slave=unit)
    b = c.read_input_registers(5, 1, slave=unit).registers[0]
    nxt = c.read_holding_registers(9, 1, slave=unit).registers[0]
    check("pymodbus FC06 auto-advance and idempotent retry", (a, b, nxt) == (7, 8, 9),
          "%r" % ((a, b, nxt),))
    # Exceptions: 02 for unmapped or read-only, 03 for bad values.
    def exc(resp):
        return getattr(resp, "exception_code", None)
    check("pymodbus exception 03 dims 33", exc(c.write_register(1, 33, slave=unit)) == 3)
    check("pymodbus exception 03 kind 9", exc(c.write_register(0, 9, slave=unit)) == 3)
    check("pymodbus exception 02 write result", exc(c.write_register(100, 1, slave=unit)) == 2)
    check("pymodbus exception 02 unmapped", exc(c.read_holding_registers(50, 1, slave=unit)) == 2)
    check("pymodbus exception 03 past the block",
          exc(c.read_input_registers(60, 20, slave=unit)) == 3)
    check("pymodbus exception 01 coils", exc(c.read_coils(0, 1, slave=unit)) == 1)
    # FC17 and FC43/14.
    rid = c.execute(ReportSlaveIdRequest(unit=unit))
    ident = getattr(rid, "identifier", b"")
    check("pymodbus FC17 report server id",
          ident.startswith(b"\x51") and b"qmcd " in ident and b" sobol:" in ident, repr(ident))
    di = c.execute(ReadDeviceInformationRequest(read_code=1, object_id=0, unit=unit))
    info = getattr(di, "information", {})
    check("pymodbus FC43/14 device identification",
          info.get(0) == b"qmcd" and info.get(1) == b"qmcd-modbus" and 2 in info, repr(info))
    # Counters: requests grow, exceptions were counted.
    ctr = c.read_input_registers(200, 24, slave=unit).registers
    vals = [ctr[4 * i] << 48 | ctr[4 * i + 1] << 32 | ctr[4 * i + 2] << 16 | ctr[4 * i + 3]
            for i in range(6)]
    check("pymodbus counters: requests and exceptions", vals[1] >= 30 and vals[2] >= 6,
          repr(vals))
    c.close()


# ---- hostile and crowded clients --------------------------------------------

def run_dribble(host, port):
    """One byte every 100 ms from one client; between its bytes another
    client completes two requests each.  The order is the assertion: 22
    answers arrive while the first client's frame is still incomplete, and
    its frame is answered once complete."""
    slow = connect(host, port)
    fast = connect(host, port)
    frame = adu(0x1234, 3, struct.pack(">BHH", 4, 200, 4))
    served = 0
    for i, byte in enumerate(frame[:-1]):
        slow.sendall(bytes([byte]))
        time.sleep(0.1)
        for _ in range(2):
            read_input(fast, 100 + served, 4, 0, 6)
            served += 1
    check("dribble: the prompt client got %d answers during one unfinished frame" % served,
          served == 2 * (len(frame) - 1))
    slow.sendall(frame[-1:])
    tid, unit, pdu = recv_adu(slow)
    check("dribble: the dribbled frame is answered once complete",
          tid == 0x1234 and unit == 3 and pdu[:2] == b"\x04\x08", repr(pdu))
    slow.close()
    fast.close()


def run_many(host, port, n):
    socks = [connect(host, port) for _ in range(n)]
    # Each connection its own unit id, so its own bank: write, then read.
    for k, s in enumerate(socks):
        write_single(s, k, 1 + k, 10, 1000 + k)
    ok = all(read_input(s, k, 1 + k, 0, 1) == [1000 + k] for k, s in enumerate(socks))
    check("many: %d connections at once, each answered from its own bank" % n, ok)
    ctr = read_input(socks[0], 9999, 1, 200, 24)
    open_now = ctr[20] << 48 | ctr[21] << 32 | ctr[22] << 16 | ctr[23]
    check("many: the open-connections counter sees them all", open_now >= n, str(open_now))
    for s in socks:
        s.close()


def counter(host, port, i):
    s = connect(host, port)
    c = read_input(s, 1, 1, 200 + 4 * i, 4)
    s.close()
    return c[0] << 48 | c[1] << 32 | c[2] << 16 | c[3]


def run_refused(host, port, src):
    before = counter(host, port, 4)
    s = connect(host, port, src)
    try:
        s.sendall(adu(1, 1, struct.pack(">BHH", 4, 0, 1)))
        data = s.recv(100)
    except (ConnectionResetError, BrokenPipeError):
        data = b""
    check("refused: a client from %s outside modbus-allow is closed unanswered" % src,
          data == b"", repr(data))
    s.close()
    # The refusal is counted (the counter read itself comes from an
    # allowed address).
    after = counter(host, port, 4)
    check("refused: counted", after == before + 1, "%d -> %d" % (before, after))


def run_raw(host, port):
    for name, data in [("protocol id 1", struct.pack(">HHHBBHH", 1, 1, 6, 1, 4, 0, 1)),
                       ("length 1", struct.pack(">HHHB", 1, 0, 1, 1) + b"\x04\x00\x00\x00\x01"),
                       ("length 255", struct.pack(">HHHB", 1, 0, 255, 1) + b"\x04" * 254)]:
        s = connect(host, port)
        s.sendall(data)
        try:
            got = s.recv(100)
        except ConnectionResetError:
            got = b""
        check("raw: MBAP %s closes the connection unanswered" % name, got == b"", repr(got))
        s.close()
    # Pipelined requests in one segment are answered in order.
    s = connect(host, port)
    s.sendall(b"".join(adu(t, 9, struct.pack(">BHH", 4, 0, 1)) for t in range(5)))
    tids = [recv_adu(s)[0] for _ in range(5)]
    check("raw: pipelined requests answered in order", tids == list(range(5)), repr(tids))
    s.close()


def run_limits(host, port):
    socks = [connect(host, port) for _ in range(3)]
    # Two banks (units 1 and 2) fit; a third client gets exception 06 and
    # the first two keep their state.
    write_single(socks[0], 1, 1, 10, 11)
    write_single(socks[1], 2, 2, 10, 22)
    socks[2].sendall(adu(3, 3, struct.pack(">BHH", 6, 10, 33)))
    tid, unit, pdu = recv_adu(socks[2])
    check("limits: a third bank is refused with exception 06", pdu == b"\x86\x06", repr(pdu))
    check("limits: the two banks keep their state",
          read_input(socks[2], 4, 1, 0, 1) == [11] and read_input(socks[0], 5, 2, 0, 1) == [22])
    # A fourth connection is closed at accept, unanswered.
    extra = connect(host, port)
    try:
        extra.sendall(adu(6, 1, struct.pack(">BHH", 4, 0, 1)))
        got = extra.recv(100)
    except (ConnectionResetError, BrokenPipeError):
        got = b""
    check("limits: a connection past modbus-max-connections is closed", got == b"", repr(got))
    extra.close()
    ctr = read_input(socks[0], 7, 1, 200, 24)
    vals = [ctr[4 * i] << 48 | ctr[4 * i + 1] << 32 | ctr[4 * i + 2] << 16 | ctr[4 * i + 3]
            for i in range(6)]
    check("limits: counters (exceptions 1, accepted 3, refused 1, open 3)",
          vals[2] == 1 and vals[3] == 3 and vals[4] == 1 and vals[5] == 3, repr(vals))
    for s in socks:
        s.close()


def run_nonreader(host, port):
    """Requests, and never a reply read: once the replies fill the buffers
    the server stops reading and, after write-timeout-ms, closes."""
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    s.connect((host, port))
    s.settimeout(0.5)
    frame = b"".join(adu(t, 1, struct.pack(">BHH", 4, 0, 60)) for t in range(64))
    sent = 0
    try:
        while sent < 50000000:
            s.sendall(frame)
            sent += len(frame)
    except socket.timeout:
        pass                      # both directions are full now
    except (ConnectionResetError, BrokenPipeError):
        pass
    s.settimeout(20)
    closed = False
    try:
        while True:
            if not s.recv(65536):
                closed = True
                break
    except (ConnectionResetError, BrokenPipeError):
        closed = True
    except socket.timeout:
        pass
    check("nonreader: a client that takes no replies is closed (after %d bytes sent)" % sent,
          closed)
    s.close()


def main():
    mode, host, port = sys.argv[1], sys.argv[2], int(sys.argv[3])
    if mode == "pymodbus":
        run_pymodbus(host, port)
    elif mode == "dribble":
        run_dribble(host, port)
    elif mode == "many":
        run_many(host, port, int(sys.argv[4]))
    elif mode == "refused":
        run_refused(host, port, sys.argv[4])
    elif mode == "raw":
        run_raw(host, port)
    elif mode == "limits":
        run_limits(host, port)
    elif mode == "nonreader":
        run_nonreader(host, port)
    elif mode == "stall":
        # Half a frame, then silence: the partial-frame deadline closes it
        # (whenever it comes: the assertion is the close, not its time).
        s = connect(host, port)
        s.sendall(adu(1, 1, struct.pack(">BHH", 4, 0, 1))[:5])
        s.settimeout(60)  # well past the deadline: this only bounds a hang
        try:
            got = s.recv(100)
        except ConnectionResetError:
            got = b""
        check("stall: a half-sent frame is closed by the deadline, unanswered", got == b"",
              repr(got))
    else:
        print("FAIL unknown mode", mode)
        return 1
    return min(failures, 100)


if __name__ == "__main__":
    sys.exit(main())
