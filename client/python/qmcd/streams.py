"""qmcd.streams - points and pixel tiles: the POINTS and PIXELS requests
and the stream of chunks that answers both, as a part of Client.

Each chunk is checked (it starts where the last ended, holds whole points,
does not run past the request; a ring chunk names the slot that comes next
and fits in it; END counts what came) and lands once in the caller's
array: read from the socket straight into it, or copied from the ring
slot, which then goes back to the daemon at once.  A request for more
points than the server's max_points is sent as several; a tile, as pieces
whose outputs lie end to end (tile_piece).

Must not: hold more than one chunk, leave a stream half read (an error
closes the connection), or send PIXELS or fast-owen to a server whose
version lacks them.
"""
import struct

import numpy as np

from . import wire
from .errors import ProtocolError, QmcdError, ServerError, QMC_EINVAL

DTYPES = {"f64": np.dtype("<f8"), "f32": np.dtype("<f4"), "u32": np.dtype("<u4")}
FINITE_KINDS = ("hammersley", "stratified", "lhs")
_CHUNK_PREFIX = struct.Struct("<QII")
AUTO_SLOT_BYTES = wire.CHUNK_BYTES  # a request of more than this attaches a ring


def format_of(dtype):
    """The wire format for a dtype given as "f64"/"f32"/"u32" or a numpy
    dtype (float64, float32, uint32)."""
    if isinstance(dtype, str) and dtype in DTYPES:
        return dtype
    try:
        dt = np.dtype(dtype)
    except TypeError:
        dt = None
    for name, d in DTYPES.items():
        if dt is not None and dt.kind == d.kind and dt.itemsize == d.itemsize:
            return name
    raise ValueError("dtype %r: want f64, f32 or u32 (numpy float64, float32, uint32)"
                     % (dtype,))


def _result_dtype(fmt):
    # The wire is little-endian, numpy's native order on the machines qmcd
    # runs on; elsewhere the array is little-endian all the same.
    return DTYPES[fmt]


class Streams:
    """Client's points and pixels (a mixin: Client has the connection)."""

    # -- streams of points (POINTS and PIXELS answers) --
    def _stream(self, mtype, fields, count, row_bytes, first0, dest=None):
        """A generator: sends one POINTS or PIXELS request for `count` points
        of row_bytes bytes, the first at index first0, and yields (done,
        points, view) for each chunk as it arrives, done being the points
        before it.  With dest (a byte memoryview of count * row_bytes) the
        chunk is already in place there and view is None; else view holds
        its bytes (a ring slot, or a buffer reused for the next chunk),
        valid until the generator is resumed.  Returns after END; raises
        the daemon's ERROR as ServerError."""
        if count * row_bytes > AUTO_SLOT_BYTES:
            self._shm_auto()
        ring = self._ring
        # While a session's batch pins ring slots, streams go inline (as
        # libqmcclient's do): releases are oldest first.
        shm = ring is not None and not ring.pinned and row_bytes <= ring.slot_bytes
        fields["transport"] = "shm" if shm else "inline"
        rid = self._send(mtype, fields)
        got = 0
        conn = self._conn
        scratch = None
        while True:
            if ring is not None and ring.held and not ring.pinned:
                self._release()
            ftype, frid, plen, deadline = conn.read_header()
            if frid != rid:
                payload = conn.read_payload(plen, deadline)
                try:
                    msg = wire.decode_payload(ftype, payload, self.version)
                except ProtocolError as e:
                    raise self._break(e)
                self._other(ftype, frid, msg)
                continue
            if ftype == wire.POINTS_CHUNK and not shm:
                first, points, data_len = _CHUNK_PREFIX.unpack(conn.read_payload(16, deadline))
                if data_len != plen - 16 or data_len > wire.CHUNK_BYTES or points == 0 or \
                        data_len % 4 or data_len % points or data_len // points < 4:
                    raise self._break(ProtocolError(
                        "malformed POINTS_CHUNK: %d points, data_len %d, payload %d"
                        % (points, data_len, plen)))
                self._check_chunk(first, points, data_len, first0 + got, count - got,
                                  row_bytes)
                if dest is not None:
                    conn.read_into(dest[got * row_bytes:got * row_bytes + data_len], deadline)
                    view = None
                else:
                    if scratch is None:
                        scratch = memoryview(bytearray(wire.CHUNK_BYTES))
                    view = scratch[:data_len]
                    conn.read_into(view, deadline)
                yield got, points, view
                got += points
                continue
            payload = conn.read_payload(plen, deadline)
            try:
                msg = wire.decode_payload(ftype, payload, self.version)
            except ProtocolError as e:
                raise self._break(e)
            if ftype == wire.POINTS_SHM_CHUNK and shm:
                if msg["slot"] != ring.next or msg["data_len"] > ring.slot_bytes or \
                        ring.held >= ring.slots:
                    raise self._break(ProtocolError(
                        "protocol error: a chunk of %d bytes in ring slot %d; expected slot "
                        "%d, at most %d bytes, with %d of %d slots held"
                        % (msg["data_len"], msg["slot"], ring.next, ring.slot_bytes,
                           ring.held, ring.slots)))
                ring.next = (ring.next + 1) % ring.slots
                ring.held += 1  # given back before we next wait (_release)
                n, points = msg["data_len"], msg["points"]
                self._check_chunk(msg["first"], points, n, first0 + got, count - got,
                                  row_bytes)
                view = ring.slot(msg["slot"], n)
                if dest is not None:
                    dest[got * row_bytes:got * row_bytes + n] = view
                    view = None
                    # Copied out: the slot can go back at once, so the
                    # daemon refills it while we copy the next one.
                    if not ring.pinned:
                        held, ring.held = ring.held, 0
                        self._send(wire.SHM_RELEASE, {"slots": held}, rid=0)
                yield got, points, view
                got += points
            elif ftype == wire.END:
                if msg["points"] != got or got != count or msg["bytes"] != got * row_bytes:
                    raise self._break(ProtocolError(
                        "protocol error: END says %d points in %d bytes; %d of %d points in "
                        "%d bytes arrived" % (msg["points"], msg["bytes"], got, count,
                                              got * row_bytes)))
                if ring is not None and ring.held:
                    self._release()
                return
            elif ftype == wire.ERROR:
                if ring is not None and ring.held:
                    self._release()
                raise ServerError(msg["code"], msg["message"], rid)
            else:
                raise self._break(ProtocolError(
                    "protocol error: %s in a points stream (%s transport)"
                    % (wire.type_name(ftype), "shm" if shm else "inline")))

    def _fill(self, mtype, fields, count, row_bytes, first0, dest):
        for _ in self._stream(mtype, fields, count, row_bytes, first0, dest):
            pass

    def _check_chunk(self, first, points, data_len, want_first, left, row_bytes):
        if first != want_first or points > left or data_len != points * row_bytes:
            raise self._break(ProtocolError(
                "protocol error: chunk of %d points (%d bytes) at index %d; expected index "
                "%d, %d bytes a point, at most %d points"
                % (points, data_len, first, want_first, row_bytes, left)))

    # -- points --
    def _points_request(self, kind, dims, count, start, scramble, seed, dtype, shuffle,
                        set_size):
        fmt = format_of(dtype)
        if kind not in wire.KINDS:
            raise ValueError("kind %r: want one of %s" % (kind, ", ".join(wire.KINDS)))
        if scramble not in wire.SCRAMBLES:
            raise ValueError("scramble %r: want one of %s"
                             % (scramble, ", ".join(wire.SCRAMBLES)))
        dims, count, start = int(dims), int(count), int(start)
        if dims < 1 or count < 0 or start < 0:
            raise ValueError("points: dims >= 1, count >= 0 and start >= 0, not %d, %d, %d"
                             % (dims, count, start))
        if kind in FINITE_KINDS:
            set_size = start + count if set_size is None else int(set_size)
        elif set_size is not None:
            raise ValueError("set_size: %s is an infinite sequence and takes no set size" % kind)
        else:
            set_size = 0
        if scramble == "fast-owen":
            self._need(wire.VERSION_PIXELS, "scramble fast-owen")
        fields = {"kind": kind, "scramble": scramble, "format": fmt, "dims": dims,
                  "flags": wire.SEQ_SHUFFLE if shuffle else 0, "seed": int(seed) % 2**64,
                  "set_size": set_size}
        return fmt, fields, dims, count, start, dims * wire.FORMAT_BYTES[fmt]

    def points(self, kind, dims, count, start=0, scramble="none", seed=0, dtype="f64",
               shuffle=False, set_size=None, out=None):
        """Points [start, start + count) of a sequence as a (count, dims)
        numpy array: what `qmc points` gives for the same options, value
        for value.

        kind: sobol, halton, hammersley, random, stratified, lhs.
        scramble: none, shift, owen, faure, fast-owen (which the kind takes).
        dtype: "f64" (float64), "f32" (float32: floor(x 2^24) / 2^24) or
        "u32" (uint32: floor(x 2^32)).  set_size: the finite kinds'
        (hammersley, stratified, lhs) set, default start + count, as the
        CLI has it.  out: an array of that shape and dtype, C-contiguous,
        to fill instead of a new one.  Each value is written once: from
        the socket, or from the shared-memory ring, straight into the array.
        """
        fmt, fields, dims, count, start, row = self._points_request(
            kind, dims, count, start, scramble, seed, dtype, shuffle, set_size)
        arr = self._out(out, (count, dims), fmt)
        if count == 0:
            return arr
        flat = memoryview(arr).cast("B")
        with self._lock:
            per = self.max_points or count
            done = 0
            while done < count:
                n = min(per, count - done)
                fields["start"], fields["count"] = start + done, n
                self._fill(wire.POINTS, fields, n, row, start + done,
                           flat[done * row:(done + n) * row])
                done += n
        return arr

    def points_chunks(self, kind, dims, count, start=0, scramble="none", seed=0, dtype="f64",
                      shuffle=False, set_size=None):
        """The points of points(...), chunk by chunk as they arrive, without
        copying them: yields (index, array) with array a read-only (n, dims)
        view of the chunk's n points from index on - in the shared-memory
        ring over a Unix socket.  Each view is valid only until the next
        step (its slot then goes back to the daemon): copy what you keep.
        Until the iteration ends the client takes no other request; leaving
        it early closes the connection (the stream cannot be stopped)."""
        fmt, fields, dims, count, start, row = self._points_request(
            kind, dims, count, start, scramble, seed, dtype, shuffle, set_size)
        dt = _result_dtype(fmt)
        with self._lock:
            if self._streaming:
                raise QmcdError(QMC_EINVAL, "points_chunks: another stream is open on this "
                                "client")
            self._streaming = True
            finished = False
            try:
                per = self.max_points or count
                done = 0
                while done < count:
                    n = min(per, count - done)
                    fields["start"], fields["count"] = start + done, n
                    for got, pts, view in self._stream(wire.POINTS, fields, n, row,
                                                       start + done):
                        yield start + done + got, \
                            np.frombuffer(view, dtype=dt).reshape(pts, dims)
                    done += n
                finished = True
            finally:
                self._streaming = False
                if not finished and not self.closed:
                    # Left mid-stream: the rest is on its way and cannot be
                    # stopped, so the connection goes (as libqmcclient does).
                    self.close()

    @staticmethod
    def _out(out, shape, fmt):
        dt = _result_dtype(fmt)
        if out is None:
            return np.empty(shape, dtype=dt)
        if out.shape != tuple(shape) or out.dtype != dt or not out.flags.c_contiguous or \
                not out.flags.writeable:
            raise ValueError("out: want a writable C-contiguous %s array of shape %s, not %s %s"
                             % (dt, tuple(shape), out.dtype, out.shape))
        return out

    # -- pixel tiles --
    def pixels(self, sampler, resolution, spp, dims, tile=None, samples=None, seed=0, frame=0,
               dtype="f32", out=None):
        """A tile of a pixel sampler (protocol version 4) as an array of shape
        (tile height, tile width, sample count, dims): what `qmc pixels`
        writes for the same options, value for value.

        sampler: zsobol, padded-sobol, sobol.  resolution: (width, height)
        of the whole image.  tile: (x, y, width, height), default the whole
        image.  samples: (start, count) of each pixel's samples, default
        (0, spp).  seed: pbrt-v4's int seed (a negative int is taken as
        its 32 bits).  dtype: "f32" (default), "f64" or "u32".
        """
        fmt = format_of(dtype)
        if sampler not in wire.PIXEL_SAMPLERS:
            raise ValueError("sampler %r: want one of %s"
                             % (sampler, ", ".join(wire.PIXEL_SAMPLERS)))
        width, height = (int(v) for v in resolution)
        x, y, tw, th = (int(v) for v in (tile if tile is not None else (0, 0, width, height)))
        s0, sn = (int(v) for v in (samples if samples is not None else (0, spp)))
        seed = int(seed)
        if not -2**31 <= seed < 2**32:
            raise ValueError("seed %d: pbrt-v4's int seed, -2^31 .. 2^32 - 1" % seed)
        arr = self._out(out, (th, tw, sn, int(dims)), fmt)
        total = tw * th * sn
        row = int(dims) * wire.FORMAT_BYTES[fmt]
        flat = memoryview(arr).cast("B")
        fields = {"sampler": sampler, "format": fmt, "width": width, "height": height,
                  "seed": seed % 2**32, "frame": int(frame), "dims": int(dims), "spp": int(spp)}
        with self._lock:
            self._need(wire.VERSION_PIXELS, "pixels")
            if total == 0:
                # An empty tile: the daemon says what is wrong with it.
                fields.update(x=x, y=y, tile_width=tw, tile_height=th, sample_start=s0,
                              sample_count=sn)
                self._fill(wire.PIXELS, fields, 0, row, 0, flat[:0])
                return arr
            per = self.max_points or total
            done = 0
            while done < total:
                px, py, pw, ph, ps0, psn = tile_piece((x, y, tw, th, s0, sn), done, per)
                n = pw * ph * psn
                f = dict(fields, x=px, y=py, tile_width=pw, tile_height=ph, sample_start=ps0,
                         sample_count=psn)
                self._fill(wire.PIXELS, f, n, row, 0, flat[done * row:(done + n) * row])
                done += n
        return arr


def tile_piece(tile, done, max_samples):
    """The piece of tile (x, y, w, h, sample_start, sample_count) whose
    output starts at sample `done` of the tile's output and holds at most
    max_samples: whole rows where a row fits, else whole pixels of one
    row, else part of one pixel's samples (core/pixel_piece.c's rule, so
    the pieces laid end to end are the tile's output)."""
    x, y, w, h, s0, n = tile
    pixel, s = divmod(done, n)
    row, col = divmod(pixel, w)
    px, py, pw, ph, ps0, psn = x + col, y + row, 1, 1, s0 + s, n - s
    if s == 0 and col == 0 and n <= max_samples // w:
        pw, ph = w, min(max_samples // (w * n), h - row)
    elif s == 0 and n <= max_samples:
        pw = min(max_samples // n, w - col)
    elif psn > max_samples:
        psn = max_samples
    return px, py, pw, ph, ps0, psn
