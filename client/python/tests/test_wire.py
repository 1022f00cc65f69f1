"""The codec against the protocol's own text: every test vector of
tests/vectors/proto/ decodes and re-encodes to the same bytes; every
truncation of one is refused; the payload bounds are section 6's table;
the code tables are the C headers' X-macros; damaged frames are refused
with the reason.  No daemon: pure bytes."""
import glob
import math
import os
import re
import struct
import unittest

import numpy as np

import support
from qmcd import wire, errors
from qmcd.errors import ProtocolError, FrameTooBig

ALL = frozenset(wire.NAMES)


def vectors():
    """name -> frame: tests/vectors/proto/*.hex by their names, and the
    version-6 message types' (v6/*.hex) as "v6/NAME".  v5/ holds older
    versions' frames of known types (test_known_abs_by_version)."""
    d = support.tree_file("tests", "vectors", "proto")
    out = {}
    for sub in ("", "v6"):
        for f in sorted(glob.glob(os.path.join(d, sub, "*.hex"))):
            with open(f) as h:
                out[os.path.join(sub, os.path.basename(f)[:-4])] = bytes.fromhex(h.read())
    return out


def split(frame):
    """(type, request id, payload); a type this package does not know (a
    newer version's) is returned unchecked, for the caller to skip."""
    if frame[5] not in wire.NAMES:
        rid, n = struct.unpack("<QI", frame[8:20])
        return frame[5], rid, frame[24:24 + n]
    t, rid, n = wire.parse_header(frame[:24], wire.MAX_PAYLOAD, ALL)
    return t, rid, frame[24:24 + n]


class Vectors(unittest.TestCase):
    def test_every_vector_round_trips(self):
        vs = vectors()
        self.assertGreaterEqual(len(vs), 25)
        seen = set()
        for name, frame in vs.items():
            t, rid, payload = split(frame)
            if t not in wire.LAYOUTS:
                continue  # a message of a newer version than this package speaks
            seen.add(t)
            with self.subTest(name):
                self.assertEqual(len(frame), 24 + len(payload))
                self.assertEqual(wire.NAMES[t].lower(), os.path.basename(name))
                d = wire.decode_payload(t, payload)
                self.assertEqual(wire.encode(t, rid, d), frame)
        self.assertTrue({wire.SESSION_PART, wire.SESSION_PART_SUMS} <= seen)

    def test_an_unknown_type_is_skipped(self):
        # A vector of a type newer than this package: split() hands it
        # back unchecked, and the loops above skip it.
        frame = wire.header(wire.PING, 1, 2) + b"\0\0"
        frame = frame[:5] + bytes([200]) + frame[6:]
        t, rid, payload = split(frame)
        self.assertEqual((t, rid, payload), (200, 1, b"\0\0"))
        self.assertNotIn(t, wire.LAYOUTS)

    def test_part_vectors_mean_what_the_text_says(self):
        vs = vectors()
        h = wire.decode_payload(wire.SESSION_PART, split(vs["v6/session_part"])[2])
        # Part 2 of 3 of 16 blocks: blocks 5 .. 9.
        self.assertEqual((h["session_id"], h["blocks"], h["first"], h["count"], h["part_k"],
                          h["part_p"], h["sampling"]["sampler"], h["sampling"]["reps"]),
                         (5, 16, 5, 5, 2, 3, "rqmc", 16))
        q = wire.decode_payload(wire.SESSION_PART_SUMS, split(vs["v6/session_part_sums"])[2])
        r = wire.part_records(q["records"])
        self.assertEqual((q["first"], q["n"], len(r)), (5, 1, 1))
        # f was 4, 2 and 1 at three of 4096 points, 0 elsewhere.
        self.assertEqual((int(r["count"][0]), int(r["nonfinite"][0]), r["f"][0].tolist(),
                          r["absf"][0].tolist(), r["top"][0][:4].tolist()),
                         (4096, 0, [7.0, 0.0], [7.0, 0.0], [4.0, 2.0, 1.0, 0.0]))
        self.assertEqual(r["mean_f"][0], 7.0 / 4096)

    def test_vectors_mean_what_the_text_says(self):
        vs = vectors()
        _, rid, p = split(vs["hello"])
        self.assertEqual(wire.decode_payload(wire.HELLO, p),
                         {"version_min": 1, "version_max": 1, "max_frame": 16 << 20,
                          "client": "qmc-client/1"})
        h = wire.decode_payload(wire.HELLO_OK, split(vs["hello_ok"])[2])
        self.assertEqual((h["version"], h["max_inflight"], h["max_points"], h["server"],
                          h["engine"], h["sobol_table_hash"]),
                         (1, 64, 2**32, "qmcd", "qmc 0.1", 0xD2213C5F4111BE68))
        c = wire.decode_payload(wire.POINTS_CHUNK, split(vs["points_chunk"])[2])
        self.assertEqual(struct.unpack("<4d", c["data"]), (0.0, 0.0, 0.5, 0.5))
        g = wire.decode_payload(wire.INTEGRATE, split(vs["integrate"])[2])
        self.assertEqual((g["method"], g["integrand"], g["a"], g["u"], g["difficulty"],
                          g["sampling"]["scramble"], g["sampling"]["reps"]),
                         ("rqmc", "genz-gaussian", (1.5, 2.0, 2.5), (0.5, 0.5, 0.5), None,
                          "owen", 16))
        r = wire.decode_payload(wire.JOB_RESULT, split(vs["job_result"])[2])
        self.assertEqual((r["job_id"], r["method_used"], r["error_kind"], r["reference_kind"],
                          r["evals"], r["detail"]),
                         (17, "rqmc", "stderr", "exact", 65536, "sobol owen, 16 x 4096 points"))
        e = wire.decode_payload(wire.ERROR, split(vs["error"])[2])
        self.assertEqual((e["code"], e["message"]), (errors.ECANCELED, "job 17 cancelled"))
        s = wire.decode_payload(wire.STATS_REPLY, split(vs["stats_reply"])[2])
        self.assertEqual(s["stats"], {"connections": 1, "jobs_running": 1, "points_sent": 2})

    def test_every_truncation_is_refused(self):
        for name, frame in vectors().items():
            t, rid, payload = split(frame)
            if t not in wire.LAYOUTS:
                continue
            for cut in range(len(payload)):
                with self.subTest(name=name, cut=cut), self.assertRaises(ProtocolError):
                    wire.decode_payload(t, payload[:cut])

    def test_a_byte_left_over_is_refused(self):
        for name, frame in vectors().items():
            t, rid, payload = split(frame)
            if t not in wire.LAYOUTS or t == wire.POINTS_CHUNK:
                continue
            with self.subTest(name), self.assertRaises(ProtocolError):
                wire.decode_payload(t, payload + b"\0")


class Bounds(unittest.TestCase):
    def test_section_6_table(self):
        text = read("protocol", "PROTOCOL.md")
        rows = re.findall(r"^\| `(\w+)` \| (\d+) \| ([CS]) \| (\d+)(?:-(\d+))? \|", text, re.M)
        seen = set()
        for name, code, sender, lo, hi in rows:
            if name not in wire.MSG:
                continue  # a newer version's message
            t = wire.MSG[name]
            seen.add(t)
            self.assertEqual(t, int(code), name)
            self.assertEqual(wire.BOUNDS[t], (int(lo), int(hi or lo)), name)
            self.assertEqual(t in wire.SERVER_SENT, sender == "S", name)
        self.assertEqual(seen, set(wire.LAYOUTS))


def read(*parts):
    with open(support.tree_file(*parts)) as f:
        return f.read()


def c_table(header, macro):
    """The rows of an X-macro table in include/qmc/HEADER, each the text
    between X( and its closing parenthesis (quotes respected)."""
    text = read("include", "qmc", header)
    body = re.search(r"#define %s\(X\)(.*?)\n\n" % macro, text, re.S).group(1)
    rows, i = [], 0
    while True:
        i = body.find("X(", i)
        if i < 0:
            return rows
        j, depth, quote = i + 2, 1, False
        while depth:
            c = body[j]
            if c == '"' and body[j - 1] != "\\":
                quote = not quote
            elif not quote and c in "()":
                depth += 1 if c == "(" else -1
            j += 1
        rows.append(body[i + 2:j - 1].replace("\\\n", " "))
        i = j


def quoted(row):
    return re.findall(r'"((?:[^"\\]|\\.)*)"', row)


class Tables(unittest.TestCase):
    def check_codes(self, header, macro, table):
        rows = c_table(header, macro)
        want = {}
        for r in rows:
            fields = [f.strip() for f in r.split(",")]
            want[quoted(r)[0]] = int(fields[1])
        self.assertEqual(want, table)

    def test_codes(self):
        self.check_codes("seq.h", "QMC_SEQ_KIND_MAP", wire.KINDS)
        self.check_codes("seq.h", "QMC_SCRAMBLE_MAP", wire.SCRAMBLES)
        self.check_codes("seq.h", "QMC_FORMAT_MAP", wire.FORMATS)
        self.check_codes("scene.h", "QMC_SCENE_STRATEGY_MAP", wire.STRATEGIES)
        self.check_codes("testfn.h", "QMC_DIFFICULTY_MAP", wire.DIFFICULTIES)
        self.check_codes("proto.h", "QMC_JOB_STATE_MAP", wire.JOB_STATES)
        self.check_codes("pixel.h", "QMC_PIXEL_SAMPLER_MAP", wire.PIXEL_SAMPLERS)

    def test_positional_codes(self):
        for header, macro, table in (("integrate.h", "QMC_METHOD_MAP", wire.METHODS),
                                     ("sampling.h", "QMC_SAMPLER_MAP", wire.SAMPLERS)):
            names = [quoted(r)[0] for r in c_table(header, macro)]
            self.assertEqual({n: i for i, n in enumerate(names)}, table, macro)

    def test_flags_and_errors(self):
        rows = c_table("result.h", "QMC_FLAG_MAP")
        want = [(int(r.split(",")[1]), quoted(r)[0], "".join(quoted(r)[1:])) for r in rows]
        self.assertEqual(want, list(wire.FLAGS))
        rows = c_table("error.h", "QMC_ERROR_MAP")
        want = [("QMC_" + r.split(",")[0].strip(), int(r.split(",")[1]), quoted(r)[0])
                for r in rows]
        self.assertEqual(want, list(errors.ERROR_MAP))


class PartDamage(unittest.TestCase):
    """SESSION_PART and SESSION_PART_SUMS are refused as the C decoder
    refuses them (protocol/messages_part.c): a range that is not part k of
    p, records that cannot be a block's."""

    def test_part_checks(self):
        vs = vectors()
        good = wire.decode_payload(wire.SESSION_PART, split(vs["v6/session_part"])[2])
        for change, why in (({"first": 6}, "are not part 2 of 3"),
                            ({"count": 4}, "are not part 2 of 3"),
                            ({"part_k": 4}, "part 4 of 3"),
                            ({"part_k": 0}, "part 0 of 3"),
                            ({"blocks": 0, "first": 0, "count": 0}, "of 0 blocks"),
                            ({"blocks": (1 << 20) + 1}, "blocks")):
            with self.subTest(change):
                payload = wire.LAYOUTS[wire.SESSION_PART].encode(good)
                bad = dict(good, **change)
                raw = bytearray(payload)
                struct.pack_into("<QQQQQII", raw, 0, bad["session_id"], bad["fingerprint"],
                                 bad["blocks"], bad["first"], bad["count"], bad["part_k"],
                                 bad["part_p"])
                with self.assertRaisesRegex(ProtocolError, why):
                    wire.decode_payload(wire.SESSION_PART, bytes(raw))
        # The empty part of a job of 2 blocks in 3 parts is a part.
        empty = dict(good, blocks=2, part_k=1, first=0, count=0)
        self.assertEqual(wire.decode_payload(
            wire.SESSION_PART, wire.LAYOUTS[wire.SESSION_PART].encode(empty))["count"], 0)

    def test_sums_checks(self):
        vs = vectors()
        payload = split(vs["v6/session_part_sums"])[2]
        rec = np.frombuffer(payload[24:], dtype=wire.PART_RECORD).copy()

        def frame(recs, first=5, n=None):
            n = len(recs) if n is None else n
            return struct.pack("<QQI4x", 5, first, n) + recs.tobytes()
        self.assertEqual(wire.decode_payload(wire.SESSION_PART_SUMS, frame(rec))["n"], 1)
        two = np.concatenate([rec, rec])
        self.assertEqual(wire.decode_payload(wire.SESSION_PART_SUMS, frame(two))["n"], 2)
        cases = []
        for field, k, v, why in (("count", None, 4097, "more than 4096 points"),
                                 ("nonfinite", None, 4097, "more non-finite"),
                                 ("top", 0, -1.0, "negative, NaN or not descending"),
                                 ("top", 1, float("nan"), "negative, NaN or not descending"),
                                 ("top", 3, 3.0, "negative, NaN or not descending")):
            r = rec.copy()
            if k is None:
                r[field][0] = v
            else:
                r[field][0][k] = v
            cases.append((frame(r), why))
        cases += [(frame(rec, n=0), "record bytes"), (frame(rec, n=2), "record bytes"),
                  (frame(rec, first=1 << 20), "from block 1048576"),
                  (frame(two, first=(1 << 20) - 1), "from block 1048575"),
                  (frame(rec)[:-1], "record bytes")]
        for raw, why in cases:
            with self.subTest(why):
                with self.assertRaisesRegex(ProtocolError, why):
                    wire.decode_payload(wire.SESSION_PART_SUMS, raw)
        # Any sum's bits are carried: an overflow to infinity, a NaN.
        r = rec.copy()
        r["f"][0] = [float("inf"), float("nan")]
        back = wire.decode_payload(wire.SESSION_PART_SUMS, frame(r))
        self.assertEqual(back["records"], r.tobytes())


def header(mtype, rid, plen, version=1, flags=0, reserved=0, magic=b"QMCD"):
    return struct.pack("<4sBBHQII", magic, version, mtype, flags, rid, plen, reserved)


class Damage(unittest.TestCase):
    def test_header_checks_in_order(self):
        ok = header(wire.PONG, 1, 2)
        self.assertEqual(wire.parse_header(ok, 1 << 20), (wire.PONG, 1, 2))
        for bad, why in ((header(wire.PONG, 1, 2, magic=b"QMCE"), "magic"),
                         (header(wire.PONG, 1, 2, version=2), "frame version"),
                         (header(99, 1, 2), "unknown message type"),
                         (header(wire.PONG, 1, 2, flags=1), "reserved"),
                         (header(wire.PONG, 1, 2, reserved=1), "reserved")):
            with self.assertRaisesRegex(ProtocolError, why):
                wire.parse_header(bad, 1 << 20)
        # Too big is decided from the header alone, before the type's bounds.
        with self.assertRaises(FrameTooBig) as cm:
            wire.parse_header(header(wire.PONG, 1, 1 << 30), 1 << 20)
        self.assertEqual(cm.exception.code, errors.QMC_ETOOBIG)
        with self.assertRaisesRegex(ProtocolError, "outside 2..258"):
            wire.parse_header(header(wire.PONG, 1, 300), 1 << 20)
        with self.assertRaisesRegex(ProtocolError, "not a message this side receives"):
            wire.parse_header(header(wire.HELLO, 1, 20), 1 << 20)

    def test_garbage_is_refused_at_its_first_byte(self):
        self.assertIsNone(wire.check_header_prefix(b"QMCD\x01\x04", 6))
        self.assertRegex(wire.check_header_prefix(b"H", 1), "magic")
        self.assertRegex(wire.check_header_prefix(b"QMCD\x01\x00", 6), "type 0")

    def test_fields(self):
        vs = vectors()
        _, _, ok = split(vs["hello_ok"])
        cases = [
            (wire.HELLO_OK, ok[:2] + b"\x01" + ok[3:], "reserved"),
            (wire.HELLO_OK, b"\0\0" + ok[2:], "version is 0"),
            (wire.HELLO_OK, ok[:-7] + b"\xff" + ok[-6:], "UTF-8"),
            (wire.HELLO_OK, ok[:-7] + b"\x00" + ok[-6:], "NUL"),
            (wire.ERROR, struct.pack("<iH", 5, 0), "not negative"),
            (wire.JOB_STATE, struct.pack("<QB7xQd", 1, 9, 0, 0.0), "unknown state code 9"),
            (wire.SHM_OK, struct.pack("<II8x", 1, 65536), "ring of 1 slots"),
            (wire.POINTS_SHM_CHUNK, struct.pack("<QIII4x", 0, 3, 30, 0), "3 points in 30"),
            (wire.POINTS_SHM_CHUNK, struct.pack("<QIII4x", 0, 1, 8, 64), "slot 64"),
            (wire.POINTS_CHUNK, struct.pack("<QII", 0, 1, 8) + bytes(4), "data_len 8 but 4"),
            (wire.AUTH_CHALLENGE, struct.pack("<H2x", 2) + bytes(32), "version 2"),
        ]
        for mtype, payload, why in cases:
            with self.subTest(why), self.assertRaisesRegex(ProtocolError, why):
                wire.decode_payload(mtype, payload)

    def test_result_flags_by_version(self):
        _, _, p = split(vectors()["job_result"])
        p = p[:-16]  # the frame of versions before 6: no known integral of |f|
        with_bit_12 = p[:16] + struct.pack("<I", 1 << 12) + p[20:]
        self.assertEqual(wire.decode_payload(wire.JOB_RESULT, with_bit_12, 3)["flags"], 1 << 12)
        with self.assertRaisesRegex(ProtocolError, "undefined in version 2"):
            wire.decode_payload(wire.JOB_RESULT, with_bit_12, 2)
        with_bit_17 = p[:16] + struct.pack("<I", 1 << 17) + p[20:]
        with self.assertRaisesRegex(ProtocolError, "undefined in version 4"):
            wire.decode_payload(wire.JOB_RESULT, with_bit_17, 4)

    def test_known_abs_by_version(self):
        """Version 6 appends the known integral of |f| to JOB_RESULT and
        SESSION_RESULT (section 6.10); a version-5 peer gets the frame it
        always got (tests/vectors/proto/v5, the vectors from before)."""
        d = support.tree_file("tests", "vectors", "proto", "v5")
        for name, mtype, has, value in (("job_result", wire.JOB_RESULT, True, 0.3126145),
                                        ("session_result", wire.SESSION_RESULT, False, 0.0)):
            with open(os.path.join(d, name + ".hex")) as f:
                old = bytes.fromhex(f.read())
            frame = vectors()[name]
            _, rid, p = split(frame)
            r = wire.decode_payload(mtype, p)
            self.assertEqual((r["has_known_abs"], r["known_abs"]), (has, value))
            self.assertEqual(p[-16:], bytes([has]) + bytes(7) + struct.pack("<d", value))
            self.assertEqual(wire.encode(mtype, rid, r, 5), old)
            r5 = wire.decode_payload(mtype, split(old)[2], 5)
            self.assertNotIn("has_known_abs", r5)
            self.assertEqual(wire.encode(mtype, rid, r5, 5), old)
            with self.assertRaisesRegex(ProtocolError, "16 bytes left over"):
                wire.decode_payload(mtype, p, 5)
            with self.assertRaisesRegex(ProtocolError, "16 bytes short"):
                wire.decode_payload(mtype, split(old)[2], 6)
        _, _, p = split(vectors()["job_result"])
        head = p[:-16]
        for tail, why in ((bytes([2]) + bytes(15), "has_known_abs is 2"),
                          (bytes([1, 0, 1]) + bytes(13), "reserved"),
                          (b"\1" + bytes(7) + struct.pack("<d", math.nan), "known integral"),
                          (b"\1" + bytes(7) + struct.pack("<d", -1.0), "known integral"),
                          (b"\0" + bytes(7) + struct.pack("<d", 0.5), "unknown integral"),
                          (b"\0" + bytes(7) + struct.pack("<d", -0.0), "unknown integral")):
            with self.subTest(why), self.assertRaisesRegex(ProtocolError, why):
                wire.decode_payload(wire.JOB_RESULT, head + tail)
        r = wire.decode_payload(wire.JOB_RESULT, p)
        for change in ({"known_abs": math.inf}, {"has_known_abs": False}):
            with self.subTest(change), self.assertRaises(ValueError):
                wire.encode(wire.JOB_RESULT, 4, dict(r, **change))

    def test_encoder_refuses_what_the_decoder_would(self):
        base = {"kind": "sobol", "scramble": "none", "format": "f64", "transport": "inline",
                "dims": 2, "flags": 0, "seed": 0, "set_size": 0, "start": 0, "count": 2}
        self.assertEqual(wire.encode(wire.POINTS, 3, base), vectors()["points"])
        for change in ({"kind": "sobel"}, {"flags": 2}, {"count": -1}, {"dims": 2**32}):
            with self.subTest(change), self.assertRaises(ValueError):
                wire.encode(wire.POINTS, 3, dict(base, **change))
        with self.assertRaises(ValueError):
            wire.encode(wire.PING, 1, {"data": bytes(257)})
        with self.assertRaises(ValueError):
            wire.encode(wire.HELLO, 1, {"version_min": 2, "version_max": 1, "max_frame": 65536,
                                        "client": "x"})
        i = wire.decode_payload(wire.INTEGRATE, split(vectors()["integrate"])[2])
        for change in ({"tol_rel": math.inf}, {"integrand": "x" * 32}, {"a": [math.nan]},
                       {"integrand": "a\0b"}):
            with self.subTest(change), self.assertRaises(ValueError):
                wire.encode(wire.INTEGRATE, 4, dict(i, **change))


if __name__ == "__main__":
    unittest.main()
