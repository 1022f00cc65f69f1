#!/usr/bin/python3
"""modbus_device.py - measuring devices for tests/e2e/test_modbus_integrate.sh.

A device integrates a function it "measures", f(x) = prod_j (pi/2) sin(pi x_j),
whose integral over the unit cube is exactly 1, through qmcd's Modbus
integration block (protocol/MODBUS.md section 9), with python3-pymodbus
(Debian's 3.0.0rc1: client methods take slave=, readwrite_registers unit=):
it writes the setup and a start number, then reads each point and its
request number, evaluates f there and writes the number and f as float32,
until the status says the session is over.  Every check prints one
"ok NAME" or "FAIL NAME: why" line; the exit status is the number of
failures.  The register map is written here from MODBUS.md.

  modbus_device.py run HOST PORT SOCK    three devices (rqmc over FC23,
                                         auto over FC04 + FC16 in CDAB
                                         order, mc with u16 points), each
                                         against the closed form; stale and
                                         retried writes; STATS while a
                                         session runs and after
  modbus_device.py bytes HOST PORT       prints "bytes N": what a fixed
                                         rqmc session of 2 dims holds
  modbus_device.py memory HOST PORT SOCK B  against a daemon whose
                                         modbus-integration-memory is 3B/2
                                         and -total 10B (a peer's share:
                                         5B/2): the third session and a
                                         large one are refused, a closed
                                         one makes room
  modbus_device.py rtu TTY SOCK          a device on a serial line (unit 5,
                                         19200 8N1): auto on 1 dim, counted
                                         in STATS while it runs
  modbus_device.py hold HOST PORT SOCK   starts a session, sees it in STATS,
                                         and leaves it
"""
import math
import os
import struct
import subprocess
import sys

from pymodbus.client import ModbusSerialClient, ModbusTcpClient

QMC = os.environ.get("QMC", "qmc")
failures = 0

SETUP, VALUE, BLOCK = 300, 320, 400
# status block offsets (MODBUS.md section 9)
ST, START, REQ, POINT, EVALS, FLAGS = 0, 1, 2, 4, 68, 72
EST32, BAR32, EST64, BAR64, NONFIN, ERR, METHOD, BYTES = 74, 76, 78, 82, 86, 90, 91, 92
WAITING, CONVERGED, COMPLETE, NO_MEMORY = 1, 2, 3, 8
FLAG_ROUNDOFF = 1 << 6


def check(name, cond, why=""):
    global failures
    if cond:
        print("ok", name)
    else:
        failures += 1
        print("FAIL %s: %s" % (name, why))


def f(x):
    p = 1.0
    for t in x:
        p *= math.pi / 2 * math.sin(math.pi * t)
    return p


def words32(bits, low_first):
    hi, lo = bits >> 16, bits & 0xFFFF
    return [lo, hi] if low_first else [hi, lo]


def f32_words(v, low_first):
    return words32(struct.unpack(">I", struct.pack(">f", v))[0], low_first)


def f32_of(w, low_first):
    hi, lo = (w[1], w[0]) if low_first else (w[0], w[1])
    return struct.unpack(">f", struct.pack(">I", hi << 16 | lo))[0]


def f64_of(w, low_first):
    w = list(reversed(w)) if low_first else list(w)
    return struct.unpack(">d", struct.pack(">4H", *w))[0]


def u32(w):
    return w[0] << 16 | w[1]


def u64(w):
    return w[0] << 48 | w[1] << 32 | w[2] << 16 | w[3]


def setup_regs(method, dims, smooth, seed, n, reps, tol_rel, budget, start, low_first):
    return ([method, dims, smooth, seed >> 16, seed & 0xFFFF, n >> 16, n & 0xFFFF, reps] +
            f32_words(0.0, low_first) + f32_words(tol_rel, low_first) +
            [budget >> 16, budget & 0xFFFF, 950, start])


def stats(sock):
    out = subprocess.run([QMC, "stats", "--connect", "unix:" + sock], check=True,
                         stdout=subprocess.PIPE, text=True).stdout
    vals = {}
    for line in out.splitlines():
        parts = line.split()
        if len(parts) >= 2 and parts[1].isdigit():
            vals[parts[0]] = int(parts[1])
    return vals


def block(c, unit, count=96):
    r = c.read_input_registers(BLOCK, count, slave=unit)
    if r.isError():
        raise RuntimeError("FC04 400: %r" % r)
    return r.registers


def coord(w, fmt, low_first):
    """A coordinate from its registers: (value, registers used)."""
    if fmt == 1:
        return w[0] / 65536.0, 1
    if fmt == 2:
        hi, lo = (w[1], w[0]) if low_first else (w[0], w[1])
        return (hi << 16 | lo) / 4294967296.0, 2
    return f32_of(w[:2], low_first), 2


class Device:
    """One device on one unit: its word order and point format are
    registers 12 and 5 of its bank."""

    def __init__(self, c, unit, dims, fmt=0, low_first=0, fc23=False):
        self.c, self.unit, self.dims, self.fmt = c, unit, dims, fmt
        self.low, self.fc23 = low_first, fc23
        self.head = POINT + (1 if fmt == 1 else 2) * dims
        w = c.write_registers(5, [fmt], slave=unit)
        w2 = c.write_registers(12, [low_first], slave=unit)
        if w.isError() or w2.isError():
            raise RuntimeError("setting format and word order: %r %r" % (w, w2))

    def start(self, regs):
        return self.c.write_registers(SETUP, regs, slave=self.unit)

    def point(self, regs):
        x, i = [], POINT
        for _ in range(self.dims):
            v, used = coord(regs[i:i + 2], self.fmt, self.low)
            x.append(v)
            i += used
        return x

    def value_regs(self, req, v):
        return [req >> 16, req & 0xFFFF] + f32_words(v, self.low)

    def run(self, limit, on_point=None):
        """Measures until the session is over (or limit points); returns
        (points written, request numbers increasing)."""
        regs = block(self.c, self.unit, self.head)
        done, last, increasing = 0, 0, True
        while regs[ST] == WAITING and done < limit:
            req = u32(regs[REQ:REQ + 2])
            increasing = increasing and req > last
            last = req
            w = self.value_regs(req, f(self.point(regs)))
            if self.fc23:
                rw = self.c.readwrite_registers(read_address=BLOCK, read_count=self.head,
                                                write_address=VALUE, write_registers=w,
                                                unit=self.unit)
                if rw.isError():
                    raise RuntimeError("FC23 value for request %d: %r" % (req, rw))
                regs = rw.registers
            else:
                a = self.c.write_registers(VALUE, w, slave=self.unit)
                if a.isError():
                    raise RuntimeError("FC16 value for request %d: %r" % (req, a))
                regs = block(self.c, self.unit, self.head)
            done += 1
            if on_point:
                on_point(done, req, w)
        return done, increasing


def closed_form(name, b, low, status):
    """The estimate against the integral 1: within the bar (or, a rule's bar
    flagged roundoff, within what float32 values resolve)."""
    est, bar = f64_of(b[EST64:EST64 + 4], low), f64_of(b[BAR64:BAR64 + 4], low)
    flags = u32(b[FLAGS:FLAGS + 2])
    check(name + " status", b[ST] == status, "status %d" % b[ST])
    lim = max(bar, 2.0 ** -22) if flags & FLAG_ROUNDOFF else bar
    check(name + " |estimate - 1| <= bar", abs(est - 1.0) <= lim,
          "estimate %.17g bar %.3g flags %#x" % (est, bar, flags))
    e32 = f32_of(b[EST32:EST32 + 2], low)
    check(name + " float32 estimate is the float64's", e32 == struct.unpack(
        ">f", struct.pack(">f", est))[0], "%r vs %r" % (e32, est))
    print("# %s: estimate %.12g bar %.3g evals %d flags %#x method %d" %
          (name, est, bar, u64(b[EVALS:EVALS + 4]), flags, b[METHOD]))
    return est, bar


def run_devices(host, port, sock):
    c = ModbusTcpClient(host, port=port)
    check("connect", c.connect())

    # 1. rqmc over FC23, 2 dims, 8 x 256 points, tolerance 1e-3.
    d = Device(c, 1, 2, fc23=True)
    w = d.start(setup_regs(3, 2, 0, 12345, 256, 8, 1e-3, 1000000, 1, 0))
    check("rqmc setup and start in one FC16", not w.isError(), str(w))
    b = block(c, 1)
    check("rqmc waiting, start 1", b[ST] == WAITING and b[START] == 1, str(b[:4]))
    seen = {}

    def midway(done, req, wv):
        if done != 100:
            return
        s = stats(sock)
        nb = u64(block(c, 1)[BYTES:BYTES + 4])
        check("STATS while running: one integration, its bytes",
              s.get("modbus_integrations") == 1 and s.get("modbus_integration_bytes") == nb
              and nb > 0, "%r, block says %d" % (s, nb))
        stale = d.value_regs(req - 1, 0.5)
        r = c.write_registers(VALUE, stale, slave=1)
        check("stale request number: exception 03", getattr(r, "exception_code", None) == 3,
              str(r))
        r = c.write_registers(VALUE, wv, slave=1)
        check("the last value again: acknowledged", not r.isError(), str(r))
        r = c.write_registers(VALUE, wv[:2], slave=1)
        check("a value without its number's pair: exception 03",
              getattr(r, "exception_code", None) == 3, str(r))
        b2 = block(c, 1)
        check("nothing moved", u64(b2[EVALS:EVALS + 4]) == 100, str(b2[:8]))
        seen["mid"] = True

    n, inc = d.run(1000000, midway)
    check("rqmc request numbers increase", inc)
    check("rqmc checked midway", seen.get("mid"))
    b = block(c, 1)
    check("rqmc evaluations == values written", u64(b[EVALS:EVALS + 4]) == n,
          "%d vs %d" % (u64(b[EVALS:EVALS + 4]), n))
    closed_form("rqmc FC23", b, 0, CONVERGED)
    s = stats(sock)
    check("STATS once over: none open, no bytes",
          s.get("modbus_integrations") == 0 and s.get("modbus_integration_bytes") == 0, str(s))

    # 2. auto, declared analytic, 2 dims, low word first, FC04 + FC16.
    d = Device(c, 2, 2, low_first=1)
    w = d.start(setup_regs(4, 2, 0, 0, 0, 0, 1e-5, 1000000, 9, 1))
    check("auto start", not w.isError(), str(w))
    n, inc = d.run(1000000)
    b = block(c, 2)
    check("auto request numbers increase", inc)
    closed_form("auto CDAB FC16", b, 1, CONVERGED)

    # 3. mc, 3 dims, 2000 points, u16 coordinates: complete, not converged.
    d = Device(c, 3, 3, fmt=1)
    w = d.start(setup_regs(1, 3, 1, 99, 2000, 0, 0.0, 1000000, 1, 0))
    check("mc start", not w.isError(), str(w))
    n, inc = d.run(1000000)
    b = block(c, 3)
    check("mc 2000 values", n == 2000, str(n))
    closed_form("mc u16", b, 0, COMPLETE)
    # After the end a value is refused; the setup reads back.
    r = c.write_registers(VALUE, d.value_regs(999999, 0.5), slave=3)
    check("a value after the end: exception 03", getattr(r, "exception_code", None) == 3)
    r = c.read_holding_registers(SETUP, 16, slave=3)
    check("setup reads back", not r.isError() and r.registers[:3] == [1, 3, 1], str(r))
    c.close()


def fixed_rqmc(start):
    return setup_regs(3, 2, 0, 1, 1024, 8, 0.0, 1000000, start, 0)


def print_bytes(host, port):
    c = ModbusTcpClient(host, port=port)
    c.connect()
    d = Device(c, 77, 2)
    d.start(fixed_rqmc(1))
    b = block(c, 77)
    check("a fixed rqmc session runs", b[ST] == WAITING, str(b[:4]))
    print("bytes %d" % u64(b[BYTES:BYTES + 4]))
    d.start(fixed_rqmc(0))
    c.close()


def memory(host, port, sock, one):
    c = ModbusTcpClient(host, port=port)
    check("connect", c.connect())
    devs = {u: Device(c, u, 2) for u in (1, 2, 3, 4)}
    for u in (1, 2):
        devs[u].start(fixed_rqmc(1))
        b = block(c, u)
        check("unit %d starts within the peer's share" % u, b[ST] == WAITING, str(b[:4]))
    devs[3].start(fixed_rqmc(1))
    b = block(c, 3)
    check("unit 3: past the peer's share (5B/2), NO_MEMORY with the bytes it needs",
          b[ST] == NO_MEMORY and u64(b[BYTES:BYTES + 4]) == one, str(b))
    # adaptive rqmc needs far more than the bank's cap
    devs[4].start(setup_regs(3, 2, 0, 1, 0, 8, 1e-3, 1000000, 1, 0))
    b = block(c, 4)
    check("unit 4: past modbus-integration-memory (3B/2), NO_MEMORY",
          b[ST] == NO_MEMORY and u64(b[BYTES:BYTES + 4]) > one * 3 // 2, str(b[:4]))
    s = stats(sock)
    check("STATS: 2 open, 2B held, 2 refused",
          s.get("modbus_integrations") == 2 and s.get("modbus_integration_bytes") == 2 * one
          and s.get("modbus_refused_integrations") == 2, str(s))
    # Unit 1 walks a few points, then closes: room for unit 3.
    devs[1].run(10)
    devs[1].start(fixed_rqmc(0))
    check("unit 1 closed", block(c, 1)[ST] == 0)
    devs[3].start(fixed_rqmc(2))
    b = block(c, 3)
    check("unit 3 starts once unit 1 closed", b[ST] == WAITING, str(b[:4]))
    n, _ = devs[3].run(100000)
    check("unit 3 integrates to the end", n == 8192 and block(c, 3)[ST] == COMPLETE, str(n))
    s = stats(sock)
    check("STATS: unit 2 alone holds B",
          s.get("modbus_integrations") == 1 and s.get("modbus_integration_bytes") == one, str(s))
    c.close()


def rtu(tty, sock):
    # 8N1: pyserial 3.5 cannot set parity on a pty (tcsetattr: EINVAL).
    c = ModbusSerialClient(port=tty, baudrate=19200, bytesize=8, parity="N", stopbits=1,
                           timeout=2)
    check("rtu connect", c.connect())
    d = Device(c, 5, 1, fc23=False)
    w = d.start(setup_regs(4, 1, 0, 0, 0, 0, 1e-6, 1000000, 1, 0))
    check("rtu start", not w.isError(), str(w))
    seen = {}

    def first(done, req, wv):
        if done == 1:
            nb = u64(block(c, 5)[BYTES:BYTES + 4])
            s = stats(sock)
            seen["stats"] = (s.get("modbus_integrations") == 1 and
                             s.get("modbus_integration_bytes") == nb > 0, s, nb)

    n, inc = d.run(100000, first)
    check("rtu: STATS counts the line's session", seen.get("stats", (False,))[0],
          str(seen.get("stats")))
    check("rtu request numbers increase", inc and n > 0, str(n))
    closed_form("rtu auto d=1", block(c, 5), 0, CONVERGED)
    s = stats(sock)
    check("rtu: STATS once over",
          s.get("modbus_integrations") == 0 and s.get("modbus_integration_bytes") == 0, str(s))
    c.close()


def hold(host, port, sock):
    c = ModbusTcpClient(host, port=port)
    c.connect()
    d = Device(c, 9, 2)
    d.start(fixed_rqmc(1))
    nb = u64(block(c, 9)[BYTES:BYTES + 4])
    s = stats(sock)
    check("a session held: counted in STATS",
          s.get("modbus_integrations") == 1 and s.get("modbus_integration_bytes") == nb > 0,
          "%r, block says %d" % (s, nb))
    c.close()


def main():
    what = sys.argv[1]
    try:
        if what == "run":
            run_devices(sys.argv[2], int(sys.argv[3]), sys.argv[4])
        elif what == "bytes":
            print_bytes(sys.argv[2], int(sys.argv[3]))
        elif what == "memory":
            memory(sys.argv[2], int(sys.argv[3]), sys.argv[4], int(sys.argv[5]))
        elif what == "rtu":
            rtu(sys.argv[2], sys.argv[3])
        elif what == "hold":
            hold(sys.argv[2], int(sys.argv[3]), sys.argv[4])
        else:
            check("scenario " + what, False, "unknown")
    except Exception as e:  # a dead daemon or a refused connection
        check(what + " ran", False, repr(e))
    sys.exit(min(failures, 100))


if __name__ == "__main__":
    main()
