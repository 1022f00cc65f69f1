#!/usr/bin/python3
"""pixelpeer.py - PIXELS (protocol version 4, PROTOCOL.md section 6.20)
spoken raw with qmcpeer.py's independent codec, for test_pixels_cli.sh:
requests the CLI would refuse before sending them reach the daemon here.

    pixelpeer.py errors ADDR QMC REFERENCE   bad tiles get one-line ERRORs
                                             (the CLI's own line, where it
                                             has one) while another
                                             connection's tile streams; the
                                             stream then arrives whole
    pixelpeer.py version ADDR                a version-3 connection gets
                                             QMC_ENOTSUP, and stays usable
    pixelpeer.py ring ADDR REFERENCE         the tile through the shared-
                                             memory ring, chunk by slot
    pixelpeer.py hold ADDR MARKER GONE       starts the big tile, reads one
                                             chunk, creates MARKER, reads
                                             nothing more until GONE exists
                                             (the daemon was stopped and has
                                             exited): it must have cut the
                                             connection, no END

REFERENCE holds `qmc pixels --sampler padded-sobol --resolution 512,512
--spp 64 --tile 0,0,128,128 --dims 4 --format u32`, computed in-process.
"""
import os
import struct
import time
import subprocess
import sys

import qmcpeer as q
from qmcpeer import MSG, PIXEL_SAMPLER, FORMAT, Peer, PeerError, check, frame

QMC_EKIND, QMC_EDIMS, QMC_ERANGE, QMC_ECOUNT = -1003, -1005, -1006, -1007
REF = dict(sampler="padded-sobol", width=512, height=512, spp=64, tile=(0, 0, 128, 128),
           dims=4, fmt="u32")
REF_BYTES = 128 * 128 * 64 * 4 * 4


def pixels_frame(rid, sampler="zsobol", width=64, height=32, spp=16, seed=0, frame_=0, dims=2,
                 tile=(0, 0, 4, 4), samples=None, fmt="f32", transport=0, code=None):
    """A PIXELS frame laid out as PROTOCOL.md section 6.20 says."""
    start, count = samples if samples is not None else (0, spp)
    p = struct.pack("<BBBBIIIIIQIIIIQQ",
                    PIXEL_SAMPLER[sampler] if code is None else code, FORMAT[fmt][0],
                    transport, 0, width, height, seed, frame_, dims, spp,
                    tile[0], tile[1], tile[2], tile[3], start, count)
    assert len(p) == 64
    return frame(MSG["PIXELS"], rid, p)


def cli_args(sampler="zsobol", width=64, height=32, spp=16, seed=0, frame_=0, dims=2,
             tile=(0, 0, 4, 4), samples=None, fmt="f32", **_):
    a = ["pixels", "--sampler", sampler, "--resolution", "%d,%d" % (width, height),
         "--spp", str(spp), "--seed", str(seed), "--frame", str(frame_), "--dims", str(dims),
         "--tile", "%d,%d,%d,%d" % tile, "--format", fmt]
    if samples is not None:
        a += ["--samples", "%d:%d" % samples]
    return a


def read_stream(p, rid, want_samples, row_bytes, release=True, start=0):
    """A PIXELS answer inline (POINTS_CHUNK) or through p's ring, from
    sample `start` on (the chunks before it already read): returns (data,
    END dict, chunk frames).  Checks order and END's totals."""
    data, expect, chunks = bytearray(), start, 0
    for _ in range(1 << 20):
        t, r, d = p.recv()
        if r != rid:
            raise ValueError("answer for request %d, expected %d" % (r, rid))
        if t == "ERROR":
            raise PeerError(d)
        if t == "END":
            if d["points"] != want_samples or d["bytes"] != (len(data) + start * row_bytes) or \
                    len(data) != (want_samples - start) * row_bytes:
                raise ValueError("END %r after %d bytes, %d samples wanted" %
                                 (d, len(data), want_samples))
            if p.ring and p.ring[4] and release:
                p.release()
            return bytes(data), d, chunks
        if d["first"] != expect:
            raise ValueError("%s first %d, expected %d" % (t, d["first"], expect))
        if t == "POINTS_CHUNK":
            blob = d["data"]
        elif t == "POINTS_SHM_CHUNK" and p.ring:
            ring, slots, slot_bytes = p.ring[0], p.ring[1], p.ring[2]
            if d["slot"] != p.ring[3] or d["data_len"] > slot_bytes or p.ring[4] >= slots:
                raise ValueError("slot %d with %d held; expected %d" %
                                 (d["slot"], p.ring[4], p.ring[3]))
            p.ring[3] = (d["slot"] + 1) % slots
            p.ring[4] += 1
            blob = ring[d["slot"] * slot_bytes:d["slot"] * slot_bytes + d["data_len"]]
        else:
            raise ValueError("%s in a PIXELS stream" % t)
        if len(blob) != d["points"] * row_bytes:
            raise ValueError("a chunk of %d samples in %d bytes" % (d["points"], len(blob)))
        data += blob
        expect += d["points"]
        chunks += 1
        if p.ring and release and not p.has_frame():
            p.release()
    raise ValueError("too many chunks")


def ask(p, **kw):
    """One PIXELS request; returns the ERROR dict, or None if it streamed."""
    rid = p.rid()
    p.send(pixels_frame(rid, **kw))
    try:
        start, count = kw.get("samples") or (0, kw.get("spp", 16))
        w, h = kw.get("tile", (0, 0, 4, 4))[2:]
        read_stream(p, rid, w * h * count, kw.get("dims", 2) * FORMAT[kw.get("fmt", "f32")][1])
        return None
    except PeerError as e:
        return {"code": e.code, "message": e.message}


def sc_errors(addr, qmc, ref_file):
    ref = open(ref_file, "rb").read()
    check("the reference tile has its size", len(ref) == REF_BYTES, "%d bytes" % len(ref))
    # A: the big tile starts; read its first chunk, then let it wait.
    a = Peer(addr, version=4, timeout=60)
    rid_a = a.rid()
    a.send(pixels_frame(rid_a, sampler=REF["sampler"], width=512, height=512, spp=64, dims=4,
                        tile=REF["tile"], fmt="u32"))
    t, r, first = a.recv()
    check("the big tile's first chunk", t == "POINTS_CHUNK" and r == rid_a and
          first["first"] == 0, "%s %r" % (t, r))
    # B: bad requests on another connection, each one ERROR of one line.
    b = Peer(addr, version=4, timeout=30)
    same_as_cli = [
        ("a tile outside the image", dict(tile=(60, 0, 8, 8)), QMC_ERANGE),
        ("a tile below the image", dict(tile=(0, 32, 1, 1)), QMC_ERANGE),
        ("an empty tile", dict(tile=(0, 0, 0, 4)), q.QMC_EINVAL),
        ("no samples", dict(samples=(3, 0)), q.QMC_EINVAL),
        ("a sample past spp", dict(samples=(8, 9)), QMC_ERANGE),
        ("dims 0", dict(dims=0), QMC_EDIMS),
        ("spp 0", dict(spp=0, samples=(0, 1)), QMC_ECOUNT),
        ("spp 24 for zsobol", dict(spp=24), QMC_ECOUNT),
        ("resolution 0", dict(width=0), q.QMC_EINVAL),
        ("sobol past 21201 dims", dict(sampler="sobol", dims=21202), QMC_EDIMS),
        ("padded-sobol past spp", dict(sampler="padded-sobol", spp=5, samples=(4, 2)),
         QMC_ERANGE),
    ]
    for name, kw, code in same_as_cli:
        e = ask(b, **kw)
        cli = subprocess.run([qmc] + cli_args(**kw), capture_output=True, text=True)
        line = cli.stderr.strip()
        check("%s: ERROR %d, the CLI's line" % (name, code),
              e is not None and e["code"] == code and "\n" not in e["message"] and
              cli.returncode == 2 and line == "qmc: " + e["message"],
              "%r vs CLI %r" % (e, line))
    # Refusals only the daemon makes: its limits and the transport.
    big = dict(width=65536, height=65536, spp=1, tile=(0, 0, 65536, 65536))
    e = ask(b, **big)
    check("a tile of 2^32 samples: ETOOBIG naming max-points",
          e is not None and e["code"] == q.QMC_ETOOBIG and "max-points" in e["message"], repr(e))
    e = ask(b, dims=300000, tile=(0, 0, 1, 1), samples=(0, 1))
    check("a sample larger than a chunk: ETOOBIG",
          e is not None and e["code"] == q.QMC_ETOOBIG and "one sample is" in e["message"],
          repr(e))
    e = ask(b, transport=1)
    want = q.QMC_EINVAL if addr.startswith("unix:") else q.QMC_ENOTSUP
    check("transport 1 without a ring: ERROR %d" % want,
          e is not None and e["code"] == want and "PIXELS transport 1" in e["message"], repr(e))
    # An unknown sampler code is malformed: ERROR and the connection closes
    # (PROTOCOL.md section 2) - on a connection of its own.
    m = Peer(addr, version=4, timeout=30)
    m.send(pixels_frame(m.rid(), code=9))
    errs = q.expect_closed(m, "sampler 9")
    check("sampler code 9: one ERROR EPROTO, then closed",
          len(errs) == 1 and errs[0]["code"] == q.QMC_EPROTO, repr(errs))
    m.close()
    # B is still served, and right: a good tile equals the CLI's bytes.
    good = dict(sampler="zsobol", width=300, height=200, spp=32, seed=9, dims=3,
                tile=(250, 150, 50, 50), samples=(5, 20), fmt="f64")
    rid = b.rid()
    b.send(pixels_frame(rid, **good))
    data, end, _ = read_stream(b, rid, 50 * 50 * 20, 3 * 8)
    cli = subprocess.run([qmc] + cli_args(**good), capture_output=True)
    check("after the refusals, B's good tile equals the CLI's bytes",
          cli.returncode == 0 and data == cli.stdout, "%d vs %d bytes" % (len(data),
                                                                          len(cli.stdout)))
    check("B answers PING", b.ping())
    # An id in flight reused: the ERROR ends both (PROTOCOL.md section 3).
    # The tile is the big one: it cannot be over before the PING arrives.
    rid = b.rid()
    b.send(pixels_frame(rid, sampler=REF["sampler"], width=512, height=512, spp=64, dims=4,
                        tile=REF["tile"], fmt="u32") + b.ping_frame(rid))
    seen = []
    for _ in range(1000):
        t, r, d = b.recv()
        seen.append(t)
        if t == "ERROR":
            break
    check("an id reused while its tile streams: ERROR EINVAL ends it",
          seen[-1] == "ERROR" and d["code"] == q.QMC_EINVAL and r == rid and "END" not in seen,
          repr(seen[-3:]))
    check("then the connection is usable", b.ping())
    b.close()
    # A client that hangs up in the middle of a tile: the daemon lets go.
    h = Peer(addr, version=4, timeout=30)
    h.send(pixels_frame(h.rid(), sampler=REF["sampler"], width=512, height=512, spp=64,
                        dims=4, tile=REF["tile"], fmt="u32"))
    t, r, d = h.recv()
    h.close()
    s = Peer(addr, version=4, timeout=30)
    check("after a client hung up mid-tile, another is served", ask(s, tile=(1, 1, 3, 3)) is None)
    s.close()
    # A's tile resumes and arrives whole, the same bytes as in-process.
    data, end, chunks = read_stream(a, rid_a, 128 * 128 * 64, 16, start=first["points"])
    data = first["data"] + data
    check("the big tile, streamed meanwhile, equals the in-process one (%d chunks)" %
          (chunks + 1), data == ref, "%d vs %d bytes" % (len(data), len(ref)))
    a.close()


def sc_version(addr):
    p = Peer(addr, version=3)
    check("HELLO 1..3 chooses version 3", p.info["version"] == 3, repr(p.info))
    e = ask(p)
    check("PIXELS on a version-3 connection: ERROR ENOTSUP naming version 4",
          e is not None and e["code"] == q.QMC_ENOTSUP and "version 4" in e["message"], repr(e))
    check("the version-3 connection goes on", p.ping())
    p.close()
    p = Peer(addr, version=4)
    check("HELLO 1..4 chooses version 4", p.info["version"] == 4, repr(p.info))
    check("PIXELS on a version-4 connection streams", ask(p) is None)
    p.close()


def sc_ring(addr, ref_file):
    ref = open(ref_file, "rb").read()
    p = Peer(addr, version=4, timeout=60)
    fd, m = q.make_ring(4, 256 << 10, name="pixelpeer-ring")
    t, r, d = p.attach(fd, 4, 256 << 10, ring=m)
    os.close(fd)
    check("a ring of 4 x 256 KiB attached", t == "SHM_OK", repr((t, d)))
    rid = p.rid()
    p.send(pixels_frame(rid, sampler=REF["sampler"], width=512, height=512, spp=64, dims=4,
                        tile=REF["tile"], fmt="u32", transport=1))
    data, end, chunks = read_stream(p, rid, 128 * 128 * 64, 16)
    check("the tile through the ring equals the in-process one (%d slots filled)" % chunks,
          data == ref and chunks == REF_BYTES // (256 << 10), "%d bytes" % len(data))
    # Inline on the same connection, and a sample larger than a slot.
    e = ask(p, dims=70000, tile=(0, 0, 1, 1), samples=(0, 1), transport=1, fmt="f32")
    check("a sample larger than a slot: ETOOBIG",
          e is not None and e["code"] == q.QMC_ETOOBIG and "ring slot" in e["message"], repr(e))
    check("an inline tile on the ringed connection", ask(p, tile=(3, 3, 10, 10)) is None)
    p.close()


def sc_hold(addr, marker, gone):
    p = Peer(addr, version=4, timeout=60)
    rid = p.rid()
    p.send(pixels_frame(rid, sampler=REF["sampler"], width=512, height=512, spp=64, dims=4,
                        tile=REF["tile"], fmt="u32"))
    t, r, d = p.recv()
    check("hold: the big tile started", t == "POINTS_CHUNK" and r == rid, t)
    open(marker, "w").close()
    # Read nothing until the daemon has exited: the stream waits for room
    # meanwhile, so only the shutdown deadline can end it.  Then drain
    # what the socket holds.
    for _ in range(1200):
        if os.path.exists(gone):
            break
        time.sleep(0.05)
    check("hold: the daemon exited while the tile waited", os.path.exists(gone))
    seen, cut = set(), False
    try:
        for _ in range(1 << 16):
            f = p.recv()
            if f is None:
                cut = True
                break
            seen.add(f[0])
    except (ConnectionResetError, BrokenPipeError):
        cut = True
    except ValueError as e:  # cut in the middle of a chunk frame
        cut = "EOF inside a frame" in str(e)
    check("hold: stopped mid-tile, the connection is cut without END",
          cut and "END" not in seen, repr((cut, seen)))


SCENARIOS = dict(errors=sc_errors, version=sc_version, ring=sc_ring, hold=sc_hold)

if __name__ == "__main__":
    sys.exit(q.main(sys.argv, SCENARIOS, "pixelpeer.py"))
