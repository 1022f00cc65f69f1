"""qmcd.wire - the qmcd wire protocol as pure data: frame headers, every
message's payload layout, the code tables, limits.  protocol/PROTOCOL.md
is the normative text; this is a second implementation of it, written
from that text (the reference codec is the C one in protocol/).

Each message layout is written once, as a list of fields, and the same
list both decodes and encodes it (PROTOCOL.md section 9 does the same in
C), so the two directions cannot drift apart.  Decoding checks what the
bytes can show, as section 2 asks: every field's bounds, codes known,
reserved bytes zero, booleans 0 or 1, text well-formed UTF-8 without NUL,
flag bits defined in the negotiated version, nothing left over.

Must not: touch a socket, a file or the clock, or keep state between
calls (a decode is a pure function of its bytes and the version).
"""
import math
import struct

from .errors import ProtocolError, FrameTooBig
# Part sessions' block sums (section 6.22): their record and checks.
from .wire_part import (SAMPLING_BLOCK, SAMPLING_MAX_BLOCKS, SAMPLING_TOP,  # noqa: F401
                        PART_RECORD, PART_SUMS_BYTES, PART_MAX_SUMS, part_range, part_records,
                        check_session_part, check_part_sums)

# ---- frames (section 2) ----------------------------------------------------

MAGIC = b"QMCD"
FRAME_VERSION = 1
HEADER = struct.Struct("<4sBBHQII")  # magic, version, type, flags, id, len, reserved
HEADER_BYTES = HEADER.size  # 24

VERSION_MIN = 1
VERSION_MAX = 6          # the newest version this package speaks
VERSION_SHM = 2          # SHM_ATTACH, POINTS_SHM_CHUNK, SHM_RELEASE
VERSION_AUTH = 3         # AUTH_*; result flag bits 12-16
VERSION_PIXELS = 4       # PIXELS; scramble fast-owen
VERSION_SESSIONS = 5     # SESSION_OPEN .. SESSION_CLOSE (section 6.21)
VERSION_KNOWN_ABS = 6    # JOB_RESULT's known integral of |f| (section 6.10)
VERSION_PARTS = 6        # part sessions: SESSION_PART, SESSION_PART_SUMS (section 6.22)

# ---- limits (section 8) ----------------------------------------------------

MAX_PAYLOAD = 16 << 20
CHUNK_BYTES = 1 << 20
MAX_NAME = 64
MAX_MESSAGE = 1024
MAX_PING = 256
MAX_LIST = 1024
MAX_STATS = 256
JOB_NAME_MAX = 31
SCENE_MAX = 65536
MIN_MAX_FRAME = 65536
SHM_MIN_SLOTS, SHM_MAX_SLOTS = 2, 64
SHM_MIN_SLOT_BYTES, SHM_MAX_SLOT_BYTES = 64 << 10, 4 << 20
SHM_SLOT_ALIGN = 4096
AUTH_NONCE_BYTES = AUTH_MAC_BYTES = 32
SESSION_TOKEN_BYTES = 32
SESSION_NAME_MAX = 31
SESSION_MAX_VALUES = CHUNK_BYTES // 8   # values in one inline SESSION_VALUES

# ---- code tables (section 5) -----------------------------------------------
# name -> code.  A unit test checks each against its X-macro table in
# include/qmc/ when the tree is there.

KINDS = {"sobol": 1, "halton": 2, "hammersley": 3, "random": 4, "stratified": 5, "lhs": 6}
SCRAMBLES = {"none": 0, "shift": 1, "owen": 2, "faure": 3, "fast-owen": 4}
FORMATS = {"f64": 1, "f32": 2, "u32": 3}
FORMAT_BYTES = {"f64": 8, "f32": 4, "u32": 4}
METHODS = {name: i for i, name in enumerate((
    "auto", "mc", "stratified", "lhs", "qmc", "rqmc", "midpoint", "trapezoid", "simpson",
    "gauss-legendre", "gauss-kronrod", "cubature", "clenshaw-curtis"))}
SAMPLERS = {name: i for i, name in enumerate(("mc", "stratified", "lhs", "qmc", "rqmc"))}
STRATEGIES = {"uniform": 1, "brdf": 2, "light": 3, "mis-balance": 4, "mis-power": 5,
              "mis-max": 6}
DIFFICULTIES = {"testpack": 0, "fixed": 1}
JOB_STATES = {"queued": 1, "running": 2, "done": 3, "cancelled": 4, "failed": 5,
              "unknown": 6}
ERROR_KINDS = {"none": 0, "stderr": 1, "estimate": 2}
REFERENCE_KINDS = {"none": 0, "exact": 1, "reference": 2}
PIXEL_SAMPLERS = {"zsobol": 1, "padded-sobol": 2, "sobol": 3}
TRANSPORTS = {"inline": 0, "shm": 1}
SMOOTHNESS = {"analytic": 0, "continuous": 1, "discontinuous": 2, "singular": 3}
# QMC_SESSION_END_MAP (include/qmc/session.h), numbered from 0.
SESSION_ENDS = {"running": 0, "converged": 1, "complete": 2, "budget": 3, "cannot_tell": 4,
                "failed": 5}
SEQ_SHUFFLE = 1  # sequence flag bit 0

# Result flags (QMC_FLAG_MAP in include/qmc/result.h): bit, key, meaning.
FLAGS = (
    (0, "nonfinite", "non-finite integrand values (estimate invalid)"),
    (1, "heavy_tail", "heavy tails: the variance may be infinite"),
    (2, "not_pow2", "N is not a power of two: the net property is lost"),
    (3, "dims_past_good", "dimensions past the sequence's known-good range"),
    (4, "not_converged", "the tolerance was not reached"),
    (5, "budget", "the evaluation budget ran out"),
    (6, "roundoff", "roundoff error limits the attainable accuracy"),
    (7, "max_subdiv", "the maximum number of subdivisions was reached"),
    (8, "memory_bound", "the region memory bound was reached"),
    (9, "few_reps", "too few randomizations for a reliable interval"),
    (10, "error_unreliable", "the error estimate is not trustworthy"),
    (11, "zero_pdf", "the sampling pdf vanishes where the integrand does not"),
    (12, "few_nonzero", "too few nonzero values: the bar cannot see mass the points missed"),
    (13, "zero_spread", "samples or replicates agree exactly: a spread of 0 is not exactness"),
    (14, "tail_untested",
     "too few nonzero values to test for heavy tails: infinite variance not ruled out"),
    (15, "unresolved",
     "the rule does not resolve the integrand: its nodes missed mass, or its bar is "
     "a tenth of the estimate or more"),
    (16, "mis_undersampled", "a sampling technique owns mass it almost never sampled"),
)


def result_flags_defined(version):
    """The result flag bits a version defines (section 5)."""
    return 0x0000FFF if version < VERSION_AUTH else 0x001FFFF


# ---- message types (section 6) ---------------------------------------------

HELLO, HELLO_OK, PING, PONG, POINTS, POINTS_CHUNK, END = 1, 2, 3, 4, 5, 6, 7
INTEGRATE, JOB_ACCEPTED, JOB_PROGRESS, JOB_RESULT = 8, 9, 10, 11
JOB_STATUS, JOB_STATE, JOB_CANCEL, STATS, STATS_REPLY, ERROR = 12, 13, 14, 15, 16, 17
SHM_ATTACH, SHM_OK, POINTS_SHM_CHUNK, SHM_RELEASE = 18, 19, 20, 21
AUTH_CHALLENGE, AUTH_RESPONSE, AUTH_OK, PIXELS = 22, 23, 24, 25
SESSION_OPEN, SESSION_OPENED, SESSION_BATCH, SESSION_VALUES = 26, 27, 28, 29
SESSION_REPORT, SESSION_RESULT, SESSION_RESUME, SESSION_CLOSE = 30, 31, 32, 33
SESSION_PART, SESSION_PART_SUMS = 34, 35
MSG = {"HELLO": HELLO, "HELLO_OK": HELLO_OK, "PING": PING, "PONG": PONG, "POINTS": POINTS,
       "POINTS_CHUNK": POINTS_CHUNK, "END": END, "INTEGRATE": INTEGRATE,
       "JOB_ACCEPTED": JOB_ACCEPTED, "JOB_PROGRESS": JOB_PROGRESS, "JOB_RESULT": JOB_RESULT,
       "JOB_STATUS": JOB_STATUS, "JOB_STATE": JOB_STATE, "JOB_CANCEL": JOB_CANCEL,
       "STATS": STATS, "STATS_REPLY": STATS_REPLY, "ERROR": ERROR, "SHM_ATTACH": SHM_ATTACH,
       "SHM_OK": SHM_OK, "POINTS_SHM_CHUNK": POINTS_SHM_CHUNK, "SHM_RELEASE": SHM_RELEASE,
       "AUTH_CHALLENGE": AUTH_CHALLENGE, "AUTH_RESPONSE": AUTH_RESPONSE, "AUTH_OK": AUTH_OK,
       "PIXELS": PIXELS, "SESSION_OPEN": SESSION_OPEN, "SESSION_OPENED": SESSION_OPENED,
       "SESSION_BATCH": SESSION_BATCH, "SESSION_VALUES": SESSION_VALUES,
       "SESSION_REPORT": SESSION_REPORT, "SESSION_RESULT": SESSION_RESULT,
       "SESSION_RESUME": SESSION_RESUME, "SESSION_CLOSE": SESSION_CLOSE,
       "SESSION_PART": SESSION_PART, "SESSION_PART_SUMS": SESSION_PART_SUMS}
NAMES = {code: name for name, code in MSG.items()}
# What a server sends; a client receiving anything else has met a peer
# that breaks the protocol.
SERVER_SENT = frozenset((HELLO_OK, PONG, POINTS_CHUNK, END, JOB_ACCEPTED, JOB_PROGRESS,
                         JOB_RESULT, JOB_STATE, STATS_REPLY, ERROR, SHM_OK, POINTS_SHM_CHUNK,
                         AUTH_CHALLENGE, AUTH_OK, SESSION_OPENED, SESSION_BATCH,
                         SESSION_REPORT, SESSION_RESULT, SESSION_PART, SESSION_PART_SUMS))
CLIENT_SENT = frozenset(NAMES) - SERVER_SENT


def type_name(t):
    return NAMES.get(t, "type %d" % t)


# ---- fields ------------------------------------------------------------------
# A layout is a tuple of fields; a field is (kind, name, arg).  Fixed-width
# kinds go through struct; the rest are read one by one.

_FIXED = {"u8": "B", "u16": "H", "u32": "I", "u64": "Q", "i32": "i", "f64": "d",
          "fin": "d", "bool": "B", "code": "B", "flags": "I", "rflags": "I"}


class _Reader:
    """A bounded cursor over one payload: every short read is malformed."""
    __slots__ = ("b", "off", "what")

    def __init__(self, b, what):
        self.b, self.off, self.what = b, 0, what

    def take(self, n):
        end = self.off + n
        if end > len(self.b):
            raise ProtocolError("malformed %s: %d bytes short" % (self.what, end - len(self.b)))
        v = self.b[self.off:end]
        self.off = end
        return v


def _utf8(raw):
    try:
        bytes(raw).decode("utf-8")
        return True
    except UnicodeDecodeError:
        return False


def _bad(what, why):
    return ProtocolError("malformed %s: %s" % (what, why))


def _text(raw, what, field):
    if b"\0" in raw:
        raise _bad(what, "%s holds a NUL byte" % field)
    try:
        return bytes(raw).decode("utf-8")
    except UnicodeDecodeError:
        raise _bad(what, "%s is not valid UTF-8" % field) from None


class Layout:
    """One message's payload: decode(bytes) -> dict, encode(dict) -> bytes.
    Built once from its field list; consecutive fixed-width fields are one
    struct, so a small frame costs one unpack."""

    def __init__(self, name, fields, check=None):
        self.name = name
        self.check = check
        self.steps = []          # ("fixed", Struct, fields) or (kind, name, arg)
        run = []

        def flush():
            if run:
                fmt = "<" + "".join(_FIXED[k] if k != "zero" else "%ds" % a
                                    for k, _, a in run)
                self.steps.append(("fixed", struct.Struct(fmt), tuple(run)))
                run.clear()
        for f in fields:
            kind = f[0]
            if kind in _FIXED or kind == "zero":
                run.append(f)
            else:
                flush()
                self.steps.append(f)
        flush()
        # Fixed size, for a layout nested in another (the sampling spec).
        self.size = sum(st[1].size for st in self.steps if st[0] == "fixed")

    # -- decoding --
    def decode(self, payload, version=VERSION_MAX):
        r = _Reader(payload, self.name)
        d = {}
        for step in self.steps:
            kind = step[0]
            if kind == "fixed":
                st, fields = step[1], step[2]
                values = st.unpack(r.take(st.size))
                for (k, name, arg), v in zip(fields, values):
                    if k == "zero":
                        if v.count(0) != len(v):
                            raise _bad(self.name, "reserved bytes are not zero")
                    elif k == "bool":
                        if v > 1:
                            raise _bad(self.name, "%s is %d, not 0 or 1" % (name, v))
                        d[name] = bool(v)
                    elif k == "code":
                        if v not in arg[1]:
                            raise _bad(self.name, "unknown %s code %d" % (name, v))
                        d[name] = arg[1][v]
                    elif k == "fin":
                        if not math.isfinite(v):
                            raise _bad(self.name, "%s is not finite" % name)
                        d[name] = v
                    elif k == "flags":
                        if v & ~arg:
                            raise _bad(self.name, "%s has undefined bits %#x" % (name, v & ~arg))
                        d[name] = v
                    elif k == "rflags":
                        bad = v & ~result_flags_defined(version)
                        if bad:
                            raise _bad(self.name, "result flags %#x: bits %#x are undefined "
                                       "in version %d" % (v, bad, version))
                        d[name] = v
                    else:
                        d[name] = v
            elif kind == "str16" or kind == "str32":
                name, (maxlen, text) = step[1], step[2]
                n = struct.unpack("<H" if kind == "str16" else "<I",
                                  r.take(2 if kind == "str16" else 4))[0]
                if n > maxlen:
                    raise _bad(self.name, "%s is %d bytes, more than %d" % (name, n, maxlen))
                raw = r.take(n)
                d[name] = _text(raw, self.name, name) if text else bytes(raw)
            elif kind == "f64s":
                name = step[1]
                n = struct.unpack("<I", r.take(4))[0]
                if n > MAX_LIST:
                    raise _bad(self.name, "%s holds %d values, more than %d" % (name, n, MAX_LIST))
                vals = struct.unpack("<%dd" % n, r.take(8 * n))
                if not all(math.isfinite(x) for x in vals):
                    raise _bad(self.name, "%s holds a value that is not finite" % name)
                d[name] = vals
            elif kind == "bytes":
                d[step[1]] = bytes(r.take(step[2]))
            elif kind == "data":
                # The rest of the payload, exactly data_len bytes of it.
                left = len(payload) - r.off
                if left != d[step[2]]:
                    raise _bad(self.name, "data_len %d but %d data bytes" % (d[step[2]], left))
                d[step[1]] = r.take(left)
            elif kind == "stats":
                d[step[1]] = _decode_stats(r, self.name)
            elif kind == "tail":
                # Whatever is left: the message's check says how much that
                # must be (a session piece's data is inline only).
                d[step[1]] = r.take(len(payload) - r.off)
            elif kind == "records":
                # The rest of the payload: exactly d[count] records.
                size, count, _ = step[2]
                left = len(payload) - r.off
                if left != d[count] * size:
                    raise _bad(self.name, "%s %d but %d record bytes" % (count, d[count], left))
                d[step[1]] = bytes(r.take(left))
            elif kind == "sub":
                d[step[1]] = step[2].decode(r.take(step[2].size), version)
            elif kind == "since":
                # Fields a later version appended: absent before it.
                if version >= step[1]:
                    d.update(step[2].decode(r.take(step[2].size), version))
            else:  # pragma: no cover - a layout typo
                raise AssertionError(kind)
        if r.off != len(payload):
            raise _bad(self.name, "%d bytes left over" % (len(payload) - r.off))
        if self.check:
            why = self.check(d)
            if why:
                raise _bad(self.name, why)
        return d

    # -- encoding --
    def encode(self, d, version=VERSION_MAX):
        """Bytes of the payload for dict d; ValueError for a field the
        decoder would refuse (so nothing malformed is ever sent)."""
        if self.check:
            why = self.check(d)
            if why:
                raise ValueError("%s: %s" % (self.name, why))
        out = []
        for step in self.steps:
            kind = step[0]
            if kind == "fixed":
                st, fields = step[1], step[2]
                vals = []
                for k, name, arg in fields:
                    if k == "zero":
                        vals.append(bytes(arg))
                        continue
                    v = d[name]
                    if k == "code":
                        if v not in arg[0]:
                            raise ValueError("%s: unknown %s %r (want one of %s)"
                                             % (self.name, name, v, ", ".join(
                                                 str(x) for x in arg[0] if x is not None)))
                        v = arg[0][v]
                    elif k == "bool":
                        v = 1 if v else 0
                    elif k == "fin":
                        v = float(v)
                        if not math.isfinite(v):
                            raise ValueError("%s: %s must be finite" % (self.name, name))
                    elif k == "flags" and v & ~arg:
                        raise ValueError("%s: %s has undefined bits" % (self.name, name))
                    elif k == "rflags" and v & ~result_flags_defined(version):
                        raise ValueError("%s: result flags undefined in version %d"
                                         % (self.name, version))
                    vals.append(v)
                try:
                    out.append(st.pack(*vals))
                except struct.error as e:
                    raise ValueError("%s: %s" % (self.name, e)) from None
            elif kind == "str16" or kind == "str32":
                name, (maxlen, text) = step[1], step[2]
                v = d[name]
                raw = v.encode("utf-8") if isinstance(v, str) else bytes(v)
                if len(raw) > maxlen:
                    raise ValueError("%s: %s is %d bytes, more than %d"
                                     % (self.name, name, len(raw), maxlen))
                if text and (b"\0" in raw or not _utf8(raw)):
                    raise ValueError("%s: %s must be UTF-8 text without NUL" % (self.name, name))
                out.append(struct.pack("<H" if kind == "str16" else "<I", len(raw)))
                out.append(raw)
            elif kind == "f64s":
                vals = [float(x) for x in d[step[1]]]
                if len(vals) > MAX_LIST or not all(math.isfinite(x) for x in vals):
                    raise ValueError("%s: %s: at most %d finite values"
                                     % (self.name, step[1], MAX_LIST))
                out.append(struct.pack("<I%dd" % len(vals), len(vals), *vals))
            elif kind == "bytes":
                v = bytes(d[step[1]])
                if len(v) != step[2]:
                    raise ValueError("%s: %s must be %d bytes" % (self.name, step[1], step[2]))
                out.append(v)
            elif kind == "data" or kind == "tail" or kind == "records":
                out.append(bytes(d.get(step[1], b"")))
            elif kind == "stats":
                out.append(_encode_stats(d[step[1]], self.name))
            elif kind == "sub":
                out.append(step[2].encode(d[step[1]], version))
            elif kind == "since" and version >= step[1]:
                out.append(step[2].encode(d, version))
        return b"".join(out)


def _decode_stats(r, what):
    count = struct.unpack("<I", r.take(4))[0]
    if count > MAX_STATS:
        raise _bad(what, "%d entries, more than %d" % (count, MAX_STATS))
    if count * 10 > len(r.b) - r.off:
        raise _bad(what, "%d entries cannot fit in the payload" % count)
    out = {}
    for _ in range(count):
        n = struct.unpack("<H", r.take(2))[0]
        if n > MAX_NAME:
            raise _bad(what, "a stat name of %d bytes" % n)
        name = _text(r.take(n), what, "a stat name")
        out[name] = struct.unpack("<Q", r.take(8))[0]
    return out


def _encode_stats(stats, what):
    items = list(stats.items())
    if len(items) > MAX_STATS:
        raise ValueError("%s: more than %d entries" % (what, MAX_STATS))
    out = [struct.pack("<I", len(items))]
    for name, value in items:
        raw = name.encode()
        if len(raw) > MAX_NAME:
            raise ValueError("%s: stat name too long" % what)
        out.append(struct.pack("<H", len(raw)) + raw + struct.pack("<Q", value))
    return b"".join(out)


def _code(table):
    """A code field's argument: (name -> code, code -> name)."""
    return (table, {v: k for k, v in table.items()})


_KIND_OR_NONE = dict(KINDS, none=0)
_DIFFICULTY = dict(DIFFICULTIES)
_DIFFICULTY[None] = 255

# The sampling spec of INTEGRATE and JOB_RESULT (section 6.7), 40 bytes;
# a nested dict in both.
SAMPLING = Layout("sampling spec", (
    ("code", "sampler", _code(SAMPLERS)), ("code", "seq", _code(_KIND_OR_NONE)),
    ("code", "scramble", _code(SCRAMBLES)), ("zero", None, 1),
    ("flags", "seq_flags", SEQ_SHUFFLE), ("u64", "seed", None), ("u64", "n", None),
    ("f64", "confidence", None), ("u32", "reps", None), ("bool", "split_net", None),
    ("zero", None, 3)))


def _whole_points(d, cap):
    p, n = d["points"], d["data_len"]
    if not (n <= cap and p != 0 and n % 4 == 0 and n % p == 0 and n // p >= 4):
        return "%d points in %d data bytes" % (p, n)
    return None


def _check_hello(d):
    if d["version_min"] == 0 or d["version_min"] > d["version_max"]:
        return "versions %d..%d" % (d["version_min"], d["version_max"])


def _check_shm(d):
    if not (SHM_MIN_SLOTS <= d["slots"] <= SHM_MAX_SLOTS and
            SHM_MIN_SLOT_BYTES <= d["slot_bytes"] <= SHM_MAX_SLOT_BYTES and
            d["slot_bytes"] % SHM_SLOT_ALIGN == 0):
        return "a ring of %d slots of %d bytes" % (d["slots"], d["slot_bytes"])


def _check_shm_chunk(d):
    return _whole_points(d, SHM_MAX_SLOT_BYTES) or (
        "slot %d" % d["slot"] if d["slot"] >= SHM_MAX_SLOTS else None)


def _check_release(d):
    if not 1 <= d["slots"] <= SHM_MAX_SLOTS:
        return "release of %d slots" % d["slots"]


def _check_nonzero(field, what):
    return lambda d: None if d[field] else "%s is 0" % what


def _check_challenge(d):
    if d["version"] < VERSION_AUTH:
        return "a challenge for version %d" % d["version"]


_INTEGRATE = (
    ("code", "method", _code(METHODS)), ("code", "strategy", _code(STRATEGIES)),
    ("code", "difficulty", _code(_DIFFICULTY)), ("bool", "n_given", None),
    ("u32", "dims", None), ("u32", "samples_brdf", None), ("u32", "samples_light", None),
    ("u32", "n_axis", None), ("u32", "progress_ms", None), ("u64", "max_evals", None),
    ("u64", "max_memory", None), ("fin", "beta", None), ("fin", "tol_abs", None),
    ("fin", "tol_rel", None), ("sub", "sampling", SAMPLING), ("str16", "integrand", (JOB_NAME_MAX, True)),
    ("str16", "control", (JOB_NAME_MAX, True)), ("f64s", "a", None), ("f64s", "u", None),
    ("str32", "scene", (SCENE_MAX, True)))

def _check_known_abs(d):
    v = d["known_abs"]
    if d["has_known_abs"]:
        if not (math.isfinite(v) and v >= 0):
            return "a known integral of |f| of %r" % v
    elif v != 0 or math.copysign(1.0, v) < 0:
        return "an unknown integral of |f| with the value %r" % v


# Version 6's tail of JOB_RESULT and SESSION_RESULT (section 6.10): the
# integral of |f| the integrand knows in closed form.  Its fields join the
# result's dict; at version 5 or older they are absent from it.
KNOWN_ABS = Layout("known integral of |f|", (
    ("bool", "has_known_abs", None), ("zero", None, 7), ("f64", "known_abs", None)),
    _check_known_abs)

_JOB_RESULT = (
    ("u64", "job_id", None), ("code", "method_used", _code(METHODS)),
    ("code", "error_kind", _code(ERROR_KINDS)),
    ("code", "reference_kind", _code(REFERENCE_KINDS)), ("bool", "cv_used", None),
    ("u32", "dims", None), ("rflags", "flags", None), ("zero", None, 4),
    ("u64", "n", None), ("u64", "evals", None), ("u64", "nonfinite", None),
    ("f64", "estimate", None), ("f64", "error", None), ("f64", "ci_low", None),
    ("f64", "ci_high", None), ("f64", "abs_integral", None), ("f64", "cv_beta", None),
    ("f64", "cv_variance_ratio", None), ("f64", "seconds", None),
    ("f64", "reference", None), ("sub", "sampling", SAMPLING), ("str16", "detail", (MAX_MESSAGE, True)),
    ("str16", "auto_reason", (MAX_MESSAGE, True)),
    ("since", VERSION_KNOWN_ABS, KNOWN_ABS))


def _check_integrate(d):
    # The sampling spec's confidence is a finite double in INTEGRATE.
    if not math.isfinite(d["sampling"]["confidence"]):
        return "confidence is not finite"


def _check_error(d):
    if d["code"] >= 0:
        return "error code %d is not negative" % d["code"]


LAYOUTS = {
    HELLO: Layout("HELLO", (
        ("u16", "version_min", None), ("u16", "version_max", None),
        ("u32", "max_frame", None), ("str16", "client", (MAX_NAME, True))), _check_hello),
    HELLO_OK: Layout("HELLO_OK", (
        ("u16", "version", None), ("zero", None, 2), ("u32", "max_frame", None),
        ("u32", "max_inflight", None), ("zero", None, 4), ("u64", "max_points", None),
        ("u64", "sobol_table_hash", None), ("str16", "server", (MAX_NAME, True)),
        ("str16", "engine", (MAX_NAME, True))), _check_nonzero("version", "version")),
    PING: Layout("PING", (("str16", "data", (MAX_PING, False)),)),
    PONG: Layout("PONG", (("str16", "data", (MAX_PING, False)),)),
    POINTS: Layout("POINTS", (
        ("code", "kind", _code(KINDS)), ("code", "scramble", _code(SCRAMBLES)),
        ("code", "format", _code(FORMATS)), ("code", "transport", _code(TRANSPORTS)),
        ("u32", "dims", None), ("flags", "flags", SEQ_SHUFFLE), ("zero", None, 4),
        ("u64", "seed", None), ("u64", "set_size", None), ("u64", "start", None),
        ("u64", "count", None))),
    POINTS_CHUNK: Layout("POINTS_CHUNK", (
        ("u64", "first", None), ("u32", "points", None), ("u32", "data_len", None),
        ("data", "data", "data_len")), lambda d: _whole_points(d, CHUNK_BYTES)),
    END: Layout("END", (("u64", "points", None), ("u64", "bytes", None))),
    INTEGRATE: Layout("INTEGRATE", _INTEGRATE, _check_integrate),
    JOB_ACCEPTED: Layout("JOB_ACCEPTED", (("u64", "job_id", None),)),
    JOB_PROGRESS: Layout("JOB_PROGRESS", (
        ("u64", "job_id", None), ("u64", "evals", None), ("f64", "seconds", None))),
    JOB_RESULT: Layout("JOB_RESULT", _JOB_RESULT),
    JOB_STATUS: Layout("JOB_STATUS", (("u64", "job_id", None),)),
    JOB_STATE: Layout("JOB_STATE", (
        ("u64", "job_id", None), ("code", "state", _code(JOB_STATES)), ("zero", None, 7),
        ("u64", "evals", None), ("f64", "seconds", None))),
    JOB_CANCEL: Layout("JOB_CANCEL", (("u64", "job_id", None),)),
    STATS: Layout("STATS", ()),
    STATS_REPLY: Layout("STATS_REPLY", (("stats", "stats", None),)),
    ERROR: Layout("ERROR", (
        ("i32", "code", None), ("str16", "message", (MAX_MESSAGE, True))), _check_error),
    SHM_ATTACH: Layout("SHM_ATTACH", (
        ("u32", "slots", None), ("u32", "slot_bytes", None), ("zero", None, 8)), _check_shm),
    SHM_OK: Layout("SHM_OK", (
        ("u32", "slots", None), ("u32", "slot_bytes", None), ("zero", None, 8)), _check_shm),
    POINTS_SHM_CHUNK: Layout("POINTS_SHM_CHUNK", (
        ("u64", "first", None), ("u32", "points", None), ("u32", "data_len", None),
        ("u32", "slot", None), ("zero", None, 4)), _check_shm_chunk),
    SHM_RELEASE: Layout("SHM_RELEASE", (("u32", "slots", None),), _check_release),
    AUTH_CHALLENGE: Layout("AUTH_CHALLENGE", (
        ("u16", "version", None), ("zero", None, 2), ("bytes", "nonce", AUTH_NONCE_BYTES)),
        _check_challenge),
    AUTH_RESPONSE: Layout("AUTH_RESPONSE", (
        ("bytes", "nonce", AUTH_NONCE_BYTES), ("bytes", "mac", AUTH_MAC_BYTES))),
    AUTH_OK: Layout("AUTH_OK", (("bytes", "mac", AUTH_MAC_BYTES),)),
    PIXELS: Layout("PIXELS", (
        ("code", "sampler", _code(PIXEL_SAMPLERS)), ("code", "format", _code(FORMATS)),
        ("code", "transport", _code(TRANSPORTS)), ("zero", None, 1), ("u32", "width", None),
        ("u32", "height", None), ("u32", "seed", None), ("u32", "frame", None),
        ("u32", "dims", None), ("u64", "spp", None), ("u32", "x", None), ("u32", "y", None),
        ("u32", "tile_width", None), ("u32", "tile_height", None),
        ("u64", "sample_start", None), ("u64", "sample_count", None))),
}


def _check_session_batch(d):
    nbytes = d["points"] * d["dims"] * 8
    ring = d["transport"] == "shm"
    if d["points"] == 0 or d["dims"] == 0 or d["first"] > d["count"] or \
            d["points"] > d["count"] - d["first"] or nbytes != d["data_len"]:
        return "a piece of %d points of %d dims at %d of %d in %d bytes" % (
            d["points"], d["dims"], d["first"], d["count"], d["data_len"])
    if ring and (d["slot"] >= SHM_MAX_SLOTS or nbytes + 8 * d["points"] > SHM_MAX_SLOT_BYTES
                 or len(d.get("data", b""))):
        return "a ring piece in slot %d of %d bytes" % (d["slot"], nbytes)
    if not ring and (d["slot"] != 0 or nbytes > CHUNK_BYTES or
                     len(d.get("data", b"")) != nbytes):
        return "an inline piece of %d bytes, slot %d, %d data bytes" % (
            nbytes, d["slot"], len(d.get("data", b"")))


def _check_session_values(d):
    ring = d["transport"] == "shm"
    n = d["count"]
    if n == 0:
        return "count is 0"
    if ring and (d["slot"] >= SHM_MAX_SLOTS or d["data_len"] != 0 or
                 n > SHM_MAX_SLOT_BYTES // 8 or len(d.get("data", b""))):
        return "ring values: slot %d, data_len %d" % (d["slot"], d["data_len"])
    if not ring and (d["slot"] != 0 or n > SESSION_MAX_VALUES or d["data_len"] != 8 * n or
                     len(d.get("data", b"")) != 8 * n):
        return "%d inline values in %d bytes" % (n, d["data_len"])


def _check_session_report(d):
    if d["err"] > 0 or (d["end"] == "failed") != (d["err"] != 0):
        return "end %s with err %d" % (d["end"], d["err"])


LAYOUTS.update({
    SESSION_OPEN: Layout("SESSION_OPEN", (
        ("code", "method", _code(METHODS)), ("code", "smoothness", _code(SMOOTHNESS)),
        ("code", "transport", _code(TRANSPORTS)), ("bool", "n_given", None),
        ("u32", "dims", None), ("u32", "n_axis", None), ("bool", "has_exact", None),
        ("zero", None, 3), ("u32", "part_k", None), ("u32", "part_p", None),
        ("u64", "max_evals", None), ("u64", "max_memory", None), ("u64", "max_batch", None),
        ("fin", "tol_abs", None), ("fin", "tol_rel", None), ("fin", "exact", None),
        ("sub", "sampling", SAMPLING), ("str16", "name", (SESSION_NAME_MAX, True))),
        _check_integrate),
    SESSION_OPENED: Layout("SESSION_OPENED", (
        ("u64", "session_id", None), ("bytes", "token", SESSION_TOKEN_BYTES),
        ("u32", "dims", None), ("zero", None, 4), ("u64", "max_batch", None),
        ("u64", "memory_bytes", None), ("u64", "park_ms", None))),
    SESSION_BATCH: Layout("SESSION_BATCH", (
        ("u64", "seq", None), ("u64", "count", None), ("u64", "first", None),
        ("u32", "points", None), ("u32", "dims", None), ("code", "transport", _code(TRANSPORTS)),
        ("zero", None, 3), ("u32", "slot", None), ("u32", "data_len", None),
        ("tail", "data", None)), _check_session_batch),
    SESSION_VALUES: Layout("SESSION_VALUES", (
        ("u64", "session_id", None), ("u64", "seq", None), ("u64", "first", None),
        ("u32", "count", None), ("code", "transport", _code(TRANSPORTS)), ("zero", None, 3),
        ("u32", "slot", None), ("u32", "data_len", None), ("tail", "data", None)),
        _check_session_values),
    SESSION_REPORT: Layout("SESSION_REPORT", (
        ("u64", "session_id", None), ("u64", "batches", None), ("u64", "evals", None),
        ("u64", "nonfinite", None), ("code", "end", _code(SESSION_ENDS)),
        ("bool", "has_estimate", None), ("code", "error_kind", _code(ERROR_KINDS)),
        ("zero", None, 1), ("rflags", "flags", None), ("i32", "err", None),
        ("u32", "dims", None), ("u64", "res_n", None), ("u64", "res_evals", None),
        ("u64", "res_nonfinite", None), ("f64", "estimate", None), ("f64", "error", None),
        ("f64", "ci_low", None), ("f64", "ci_high", None), ("f64", "abs_integral", None)),
        _check_session_report),
    SESSION_RESULT: Layout("SESSION_RESULT", _JOB_RESULT),
    SESSION_RESUME: Layout("SESSION_RESUME", (
        ("u64", "session_id", None), ("bytes", "token", SESSION_TOKEN_BYTES),
        ("code", "transport", _code(TRANSPORTS)), ("zero", None, 7))),
    SESSION_CLOSE: Layout("SESSION_CLOSE", (
        ("u64", "session_id", None), ("bytes", "token", SESSION_TOKEN_BYTES))),
})


LAYOUTS.update({
    SESSION_PART: Layout("SESSION_PART", (
        ("u64", "session_id", None), ("u64", "fingerprint", None), ("u64", "blocks", None),
        ("u64", "first", None), ("u64", "count", None), ("u32", "part_k", None),
        ("u32", "part_p", None), ("sub", "sampling", SAMPLING)), check_session_part),
    SESSION_PART_SUMS: Layout("SESSION_PART_SUMS", (
        ("u64", "session_id", None), ("u64", "first", None), ("u32", "n", None),
        ("zero", None, 4), ("records", "records", (PART_SUMS_BYTES, "n", PART_MAX_SUMS))),
        check_part_sums),
})


def _bounds(layout):
    """(min, max) payload bytes of a layout, from its fields: section 6's table."""
    lo = hi = 0
    for step in layout.steps:
        kind = step[0]
        if kind == "fixed":
            lo += step[1].size
            hi += step[1].size
        elif kind in ("str16", "str32"):
            pre = 2 if kind == "str16" else 4
            lo += pre
            hi += pre + step[2][0]
        elif kind == "f64s":
            lo += 4
            hi += 4 + 8 * MAX_LIST
        elif kind == "bytes":
            lo += step[2]
            hi += step[2]
        elif kind == "data":
            lo += 4
            hi += CHUNK_BYTES
        elif kind == "tail":
            hi += CHUNK_BYTES
        elif kind == "records":
            lo += step[2][0]
            hi += step[2][0] * step[2][2]
        elif kind == "stats":
            lo += 4
            hi += 4 + MAX_STATS * (10 + MAX_NAME)
        elif kind == "sub":
            lo += step[2].size
            hi += step[2].size
        elif kind == "since":
            hi += step[2].size  # the bounds span every version
    return lo, hi


BOUNDS = {t: _bounds(lay) for t, lay in LAYOUTS.items()}


# ---- whole frames --------------------------------------------------------------

def header(mtype, request_id, payload_len):
    return HEADER.pack(MAGIC, FRAME_VERSION, mtype, 0, request_id, payload_len, 0)


def encode(mtype, request_id, fields=None, version=VERSION_MAX):
    """One whole frame: header and payload."""
    payload = LAYOUTS[mtype].encode(fields or {}, version)
    return header(mtype, request_id, len(payload)) + payload


def decode_payload(mtype, payload, version=VERSION_MAX):
    return LAYOUTS[mtype].decode(payload, version)


def check_header_prefix(buf, n):
    """Checks the first n bytes of a header as they arrive (section 2, step
    1: garbage is refused before a whole header is buffered).  Returns None,
    or the reason the bytes cannot begin a frame."""
    for i in range(n):
        c = buf[i]
        if i < 4:
            if c != MAGIC[i]:
                return "bad magic (byte %d is %#04x): not a qmcd peer" % (i, c)
        elif i == 4:
            if c != FRAME_VERSION:
                return "frame version %d, not %d" % (c, FRAME_VERSION)
        elif i == 5:
            if c not in NAMES:
                return "unknown message type %d" % c
        elif i in (6, 7) or i >= 20:
            if c != 0:
                return "reserved header byte %d is %#04x, not 0" % (i, c)
    return None


def parse_header(buf, max_payload, allowed=SERVER_SENT):
    """(type, request_id, payload_len) of a whole 24-byte header, checked in
    the order of section 2: fields, size against max_payload (FrameTooBig),
    then the type's own bounds.  `allowed` is the set of types this side
    may receive (the other direction is a protocol violation)."""
    magic, version, mtype, flags, rid, plen, reserved = HEADER.unpack(buf)
    if magic != MAGIC or version != FRAME_VERSION or mtype not in NAMES or flags or reserved:
        raise ProtocolError("malformed frame: " + check_header_prefix(buf, HEADER_BYTES))
    if plen > max_payload:
        raise FrameTooBig("a %s frame announces %d payload bytes; we accept at most %d"
                          % (type_name(mtype), plen, max_payload))
    if mtype not in allowed:
        raise ProtocolError("protocol error: %s is not a message this side receives"
                            % type_name(mtype))
    lo, hi = BOUNDS[mtype]
    if not lo <= plen <= hi:
        raise ProtocolError("malformed %s: payload of %d bytes, outside %d..%d"
                            % (type_name(mtype), plen, lo, hi))
    return mtype, rid, plen


def flag_names(flags):
    """The keys of the bits set in a result's flags, in bit order."""
    names = [key for bit, key, _ in FLAGS if flags >> bit & 1]
    names += ["bit%d" % b for b in range(len(FLAGS), 32) if flags >> b & 1]
    return names
