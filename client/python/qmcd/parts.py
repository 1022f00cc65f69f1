"""qmcd.parts - a part session's answer (protocol version 6, PROTOCOL.md
section 6.22) and the `--part` file it makes: SESSION_PART, then the
part's block sums in SESSION_PART_SUMS frames in block order, gathered
here until SESSION_RESULT ends the request (client/lib/session_part.c's
rules: the blocks consecutive from the part's first, never past its
count, all of them before the result); PartResult holds them and writes
the file `qmc integrate --command PROGRAM --part K/P` writes
(docs/FILES.md, client/cli/partial.c), so `qmc merge` combines parts
from Python, the CLI and the daemon alike.

Must not: trust the server's counts for memory (the sums are kept as the
frames that came, never more than the part's count), accept sums out of
order, touch a socket, or print.  sessions.py routes the frames here.
"""
import hashlib
import os
import struct

import numpy as np

from . import wire

PART_MAGIC = "qmc-partial 2"
# The CLI's words for a declared smoothness (`--smoothness`).
CLI_SMOOTHNESS = {"analytic": "smooth", "continuous": "kinks", "discontinuous": "jumps",
                  "singular": "singular"}


class Gather:
    """The sums of one part session as they arrive.  file() and end()
    return None, or the reason the frame breaks the protocol."""

    def __init__(self, part_k=0, part_p=0):
        self.part_k, self.part_p = part_k, part_p
        self.head = None
        self.chunks = []   # numpy PART_RECORD arrays, in block order
        self.got = 0

    def file(self, mtype, msg, session_id):
        if mtype == wire.SESSION_PART:
            if self.head is not None or msg["session_id"] != session_id:
                return "SESSION_PART again, or for another session"
            # The decoder checked that first and count are part k of p's.
            if self.part_p and (msg["part_k"], msg["part_p"]) != (self.part_k, self.part_p):
                return "SESSION_PART for another part than the one opened"
            self.head = msg
            return None
        if self.head is None or msg["session_id"] != session_id:
            return "block sums before SESSION_PART, or for another session"
        if msg["first"] != self.head["first"] + self.got or \
                msg["n"] > self.head["count"] - self.got:
            return "block sums out of order, or past the part's blocks"
        self.chunks.append(wire.part_records(msg["records"]))
        self.got += msg["n"]
        return None

    def end(self):
        if self.part_p and self.head is None:
            return "the result of a part session without its block sums"
        if self.head is not None and self.got != self.head["count"]:
            return "the result after %d of the part's %d block sums" % (
                self.got, self.head["count"])
        return None

    def sums(self):
        if not self.chunks:
            return np.zeros(0, dtype=wire.PART_RECORD)
        return np.concatenate(self.chunks)


def hex_float(v):
    """v as C's printf("%a") writes it with glibc: the shortest hex
    mantissa, 0x1.8p+0, 0x0p+0, 0x0.0000000000001p-1022 (subnormals),
    inf, -nan.  Hex floats read back exactly (strtod)."""
    bits = struct.unpack("<Q", struct.pack("<d", v))[0]
    sign = "-" if bits >> 63 else ""
    exp, mant = bits >> 52 & 0x7FF, bits & ((1 << 52) - 1)
    if exp == 0x7FF:
        return sign + ("nan" if mant else "inf")
    if exp == 0 and mant == 0:
        return sign + "0x0p+0"
    lead, e = ("0", -1022) if exp == 0 else ("1", exp - 1023)
    digits = ("%013x" % mant).rstrip("0")
    return "%s0x%s%sp%+d" % (sign, lead, "." + digits if digits else "", e)


def _word(w):
    """An arg line's word as partial.c writes it: %, blanks and newlines
    as %XX, every other byte as it is."""
    out = []
    for b in w.encode("utf-8"):
        out.append("%%%02X" % b if b in b"% \n\r\t" else chr(b))
    return "".join(out).encode("latin-1")


class PartResult:
    """A part of a fixed-n sampling job computed through a part session:
    fingerprint, blocks (the whole job's), first and count (the part's
    blocks), part_k and part_p, sampling (the job's spec as run), sums (a
    numpy array of wire.PART_RECORD, one per block from first), seconds
    (wall time, f's evaluations included, as the CLI counts it), report
    (the session's last SessionReport) and args (the `qmc integrate`
    words this part stands for).  write() makes its `--part` file."""

    def __init__(self, gather, args, seconds, report=None):
        h = gather.head
        self.fingerprint, self.blocks = h["fingerprint"], h["blocks"]
        self.first, self.count = h["first"], h["count"]
        self.part_k, self.part_p = h["part_k"], h["part_p"]
        self.sampling = h["sampling"]
        self.sums = gather.sums()
        self.args = list(args)
        self.seconds = seconds
        self.report = report

    def __repr__(self):
        return "<qmcd.PartResult %d/%d: blocks %d..%d of %d>" % (
            self.part_k, self.part_p, self.first, self.first + self.count, self.blocks)

    def data(self, args=None):
        """The `--part` file's bytes (docs/FILES.md, version 2).  args: the
        words of the `qmc integrate` command this part stands for, in
        order, without --part (default self.args); `qmc merge` reads the
        job from them, and the CLI writes its own words there, so give
        the words of the command whose file this one should equal."""
        words = self.args if args is None else list(args)
        if len(words) > 128:
            raise ValueError("a part file holds at most 128 args, not %d" % len(words))
        if not (0 <= self.seconds <= 1e12):
            raise ValueError("seconds %r: want 0 .. 1e12" % self.seconds)
        out = [("%s\nfingerprint %016x\nblocks %d\nseconds %.6f\n"
                % (PART_MAGIC, self.fingerprint, self.blocks, self.seconds)).encode()]
        for w in words:
            out.append(b"arg " + _word(str(w)) + b"\n")
        s = self.sums
        for i in range(self.count):
            r = s[i]
            vals = [r["f"][0], r["f"][1], r["absf"][0], r["absf"][1], r["g"][0], r["g"][1],
                    r["mean_f"], r["mean_g"], r["m2_f"], r["m2_g"], r["c_fg"]]
            top = r["top"]
            n = len(top)
            while n > 0 and top[n - 1] == 0.0:
                n -= 1
            line = "sums %d %d %d %s %d%s\n" % (
                self.first + i, r["count"], r["nonfinite"],
                " ".join(hex_float(float(v)) for v in vals), n,
                "".join(" " + hex_float(float(t)) for t in top[:n]))
            out.append(line.encode())
        body = b"".join(out)
        digest = hashlib.sha256(body).hexdigest()
        return body + ("digest sha256 %s\nend\n" % digest).encode()

    def write(self, file, args=None):
        """Writes the `--part` file to a path or a binary file object."""
        raw = self.data(args)
        if hasattr(file, "write"):
            file.write(raw)
            return
        with open(os.fspath(file), "wb") as f:
            f.write(raw)


def cli_args(dims, method, smoothness, name, exact, options):
    """The `qmc integrate` words for a session's options, as a user would
    type them (only what differs from the CLI's defaults)."""
    words = ["--command", name, "--dims", str(dims), "--smoothness",
             CLI_SMOOTHNESS[smoothness], "--method", method]
    defaults = {"seed": 0, "max_evals": 100000000, "max_memory": 64 << 20,
                "confidence": 0.95, "tol_abs": 0.0, "tol_rel": 0.0}
    for key in ("n", "reps", "seq", "scramble", "shuffle", "split_net", "seed", "tol_abs",
                "tol_rel", "max_evals", "max_memory", "confidence"):
        v = options.get(key)
        if v is None or v is False or (key in defaults and v == defaults[key]):
            continue
        flag = "--" + key.replace("_", "-")
        if v is True:
            words.append(flag)
        else:
            words += [flag, repr(float(v)) if isinstance(v, float) else str(v)]
    if exact is not None:
        words += ["--exact", repr(float(exact))]
    return words
