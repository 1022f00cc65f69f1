"""Hostile and broken servers: each fake server here answers the client
with garbage, a truncated or oversized frame, silence, a drip, a frame out
of place or a lie about the ring, and the client must raise a clear
exception (which one, and its code) - never hang: every read is bounded
by the client's timeout, set short here.  The servers are threads on Unix
sockets (and one loopback TCP port 0) in a scratch directory."""
import os
import socket
import struct
import threading
import time
import unittest

import support
import qmcd
from qmcd import wire, errors
from qmcd.errors import (ProtocolError, FrameTooBig, Timeout, ConnectionLost, ServerError,
                         AuthError)

T = 0.4  # the client's timeout in these tests, seconds


def hdr(mtype, rid, plen):
    return wire.header(mtype, rid, plen)


def hello_ok(rid, version=4, max_points=1 << 20, server="fake", max_frame=1 << 20):
    return wire.encode(wire.HELLO_OK, rid, {
        "version": version, "max_frame": max_frame, "max_inflight": 8, "max_points": max_points,
        "sobol_table_hash": qmcd.JOE_KUO_TABLE_HASH, "server": server, "engine": "none"})


def read_frame(s):
    """One frame from the client: (type, rid, payload), or None at EOF."""
    h = b""
    while len(h) < 24:
        b = s.recv(24 - len(h))
        if not b:
            return None
        h += b
    _, _, t, _, rid, n, _ = wire.HEADER.unpack(h)
    p = b""
    while len(p) < n:
        b = s.recv(n - len(p))
        if not b:
            return None
        p += b
    return t, rid, p


class Fake:
    """A server thread running script(sock) for each of up to `conns`
    connections; .unix (or .tcp) is its endpoint; .done is set when the
    scripts have run; .seen collects what a script records."""

    def __init__(self, script, tcp=False, conns=1):
        self.script, self.seen, self.errors = script, [], []
        if tcp:
            self.ls = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            self.ls.bind(("127.0.0.1", 0))
            self.endpoint = "tcp:127.0.0.1:%d" % self.ls.getsockname()[1]
        else:
            path = os.path.join(support.scratch(), "fake.sock")
            self.ls = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            self.ls.bind(path)
            self.endpoint = "unix:" + path
        self.ls.listen(4)
        self.ls.settimeout(10)
        self.conns = conns
        self.done = threading.Event()
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    def run(self):
        try:
            for _ in range(self.conns):
                s, _ = self.ls.accept()
                s.settimeout(10)
                try:
                    self.script(self, s)
                except OSError:
                    pass  # the client hung up on us: what many tests expect
                finally:
                    self.stop.wait(5 * T)  # keep it open until the client has given up
                    s.close()
        except Exception as e:  # pragma: no cover - shows up as a test failure
            self.errors.append(e)
        finally:
            self.done.set()
            self.ls.close()

    def close(self):
        self.stop.set()
        self.thread.join(10)


def handshake(fake, s, **kw):
    t, rid, p = read_frame(s)
    fake.seen.append((t, p))
    s.sendall(hello_ok(rid, **kw))


class HostileTest(unittest.TestCase):
    def fake(self, script, **kw):
        f = Fake(script, **kw)
        self.addCleanup(f.close)
        return f

    def connect(self, fake, **kw):
        t0 = time.monotonic()
        try:
            return qmcd.connect(fake.endpoint, timeout=T, **kw)
        finally:
            self.elapsed = time.monotonic() - t0

    def fails(self, exc, fake, regex=None, after=None, **kw):
        """Connects (then runs after(client)) and expects exc."""
        with self.assertRaises(exc) as cm:
            c = self.connect(fake, **kw)
            try:
                after(c)
            finally:
                c.close()
        if regex:
            self.assertRegex(str(cm.exception), regex)
        return cm.exception


class Handshake(HostileTest):
    def test_garbage(self):
        f = self.fake(lambda f, s: s.sendall(b"HTTP/1.1 400 Bad Request\r\n\r\n"))
        e = self.fails(ProtocolError, f, "does not speak the qmcd protocol.*bad magic")
        self.assertEqual(e.code, errors.QMC_EPROTO)
        self.assertEqual(e.name, "QMC_EPROTO")

    def test_garbage_after_a_valid_prefix_is_refused_without_waiting(self):
        # "QMCD" then a wrong frame version: refused on that byte, long
        # before a whole header (or the timeout) would come.
        def script(f, s):
            s.sendall(b"QMCD\x07")
            f.stop.wait(10)
        # Waiting for the rest of the header would end in Timeout instead.
        self.fails(ProtocolError, self.fake(script), "frame version 7")

    def test_silence_times_out(self):
        f = self.fake(lambda f, s: read_frame(s))
        e = self.fails(Timeout, f, "no answer from the daemon within")
        self.assertEqual(e.code, errors.ETIMEDOUT)
        self.assertIsInstance(e, TimeoutError)

    def test_truncated_header_then_silence(self):
        def script(f, s):
            read_frame(s)
            s.sendall(hello_ok(1)[:10])
        self.fails(Timeout, self.fake(script))

    def test_truncated_payload_then_close(self):
        def script(f, s):
            read_frame(s)
            s.sendall(hello_ok(1)[:40])
            s.shutdown(socket.SHUT_WR)
        e = self.fails(ConnectionLost, self.fake(script), "closed the connection")
        self.assertIsInstance(e, ConnectionError)

    def test_oversized_frame_is_refused_from_its_header(self):
        def script(f, s):
            read_frame(s)
            s.sendall(hdr(wire.HELLO_OK, 1, 1 << 30))  # and never the 1 GiB
        e = self.fails(FrameTooBig, self.fake(script), "1073741824 payload bytes")
        self.assertEqual(e.code, errors.QMC_ETOOBIG)

    def test_frame_outside_its_type_bounds(self):
        def script(f, s):
            read_frame(s)
            s.sendall(hdr(wire.HELLO_OK, 1, 5) + bytes(5))
        self.fails(ProtocolError, self.fake(script), "outside 36..164")

    def test_a_client_message_from_the_server(self):
        def script(f, s):
            read_frame(s)
            s.sendall(wire.encode(wire.HELLO, 1, {"version_min": 1, "version_max": 4,
                                                  "max_frame": 65536, "client": "x"}))
        self.fails(ProtocolError, self.fake(script), "not a message this side receives")

    def test_malformed_hello_ok(self):
        def script(f, s):
            read_frame(s)
            frame = bytearray(hello_ok(1))
            frame[24 + 2] = 1  # a reserved byte
            s.sendall(frame)
        self.fails(ProtocolError, self.fake(script), "reserved bytes")

    def test_version_we_do_not_speak(self):
        self.fails(ProtocolError, self.fake(lambda f, s: handshake(f, s, version=9)),
                   "chose protocol version 9")

    def test_refused_handshake_carries_the_code_and_message(self):
        def script(f, s):
            t, rid, _ = read_frame(s)
            s.sendall(wire.encode(wire.ERROR, rid, {"code": errors.QMC_ENOTSUP,
                                                    "message": "no common version"}))
        e = self.fails(ServerError, self.fake(script), "refused the handshake: no common")
        self.assertEqual(e.code, errors.QMC_ENOTSUP)

    def test_hello_says_what_we_speak(self):
        f = self.fake(handshake)
        self.connect(f).close()
        f.close()
        (t, p), = f.seen
        h = wire.decode_payload(wire.HELLO, p)
        self.assertEqual((t, h["version_min"], h["version_max"]), (wire.HELLO, 1, wire.VERSION_MAX))
        self.assertGreaterEqual(h["max_frame"], wire.MIN_MAX_FRAME)


def serving(answer):
    """A script: handshake, then answer(fake, sock, type, rid, payload) for
    each request until the client hangs up."""
    def script(f, s):
        handshake(f, s)
        while True:
            fr = read_frame(s)
            if fr is None:
                return
            f.seen.append(fr[0])
            if answer(f, s, *fr) is False:
                return
    return script


def pong(data, rid):
    return wire.encode(wire.PONG, rid, {"data": data})


class Requests(HostileTest):
    def test_error_keeps_the_connection(self):
        def answer(f, s, t, rid, p):
            if t == wire.POINTS:
                s.sendall(wire.encode(wire.ERROR, rid, {"code": errors.QMC_EDIMS,
                                                        "message": "sobol: dims 0"}))
            elif t == wire.PING:
                s.sendall(pong(wire.decode_payload(wire.PING, p)["data"], rid))
        c = self.connect(self.fake(serving(answer)))
        with self.assertRaises(ServerError) as cm:
            c.points("sobol", 2, 4)
        self.assertEqual((cm.exception.code, cm.exception.message, cm.exception.name),
                         (errors.QMC_EDIMS, "sobol: dims 0", "QMC_EDIMS"))
        self.assertGreaterEqual(c.ping(), 0.0)  # still usable
        c.close()

    def test_pong_that_does_not_echo(self):
        def answer(f, s, t, rid, p):
            s.sendall(pong(b"nope", rid))
        self.fails(ProtocolError, self.fake(serving(answer)), "does not echo",
                   after=lambda c: c.ping())

    def test_answer_for_a_request_not_in_flight(self):
        def answer(f, s, t, rid, p):
            s.sendall(pong(b"x", rid + 100))
        self.fails(ProtocolError, self.fake(serving(answer)), "request 102, which is not in "
                   "flight", after=lambda c: c.ping())

    def test_connection_error(self):
        def answer(f, s, t, rid, p):
            s.sendall(wire.encode(wire.ERROR, 0, {"code": errors.ETIMEDOUT,
                                                  "message": "idle for too long"}))
        e = self.fails(ServerError, self.fake(serving(answer)), "closed the connection: idle",
                       after=lambda c: c.ping())
        self.assertEqual((e.code, e.request_id), (errors.ETIMEDOUT, 0))

    def test_drip_feed_hits_the_frame_deadline(self):
        # One byte at a time, each within the timeout, the frame never
        # whole in time: the deadline is per frame, not per byte.
        def answer(f, s, t, rid, p):
            for b in pong(wire.decode_payload(wire.PING, p)["data"], rid):
                if f.stop.wait(T / 4):
                    return False
                s.sendall(bytes([b]))
        self.fails(Timeout, self.fake(serving(answer)), after=lambda c: c.ping())

    def chunk(self, rid, first, points, data):
        return wire.encode(wire.POINTS_CHUNK, rid, {"first": first, "points": points,
                                                    "data_len": len(data), "data": data})

    def stream(self, frames):
        def answer(f, s, t, rid, p):
            if t == wire.POINTS:
                s.sendall(b"".join(fr(rid) for fr in frames))
        return self.fake(serving(answer))

    def test_chunks_checked(self):
        two = struct.pack("<4d", 0, 0, 0.5, 0.5)
        end = lambda n, b: lambda rid: wire.encode(wire.END, rid, {"points": n, "bytes": b})  # noqa
        ok = [lambda rid: self.chunk(rid, 0, 2, two), end(2, 32)]
        c = self.connect(self.stream(ok))
        self.assertEqual(c.points("sobol", 2, 2).tolist(), [[0, 0], [0.5, 0.5]])
        c.close()
        cases = [
            ([lambda rid: self.chunk(rid, 1, 2, two), end(2, 32)], "at index 1; expected index 0"),
            ([lambda rid: self.chunk(rid, 0, 4, two), end(4, 32)], "chunk of 4 points"),
            ([lambda rid: self.chunk(rid, 0, 1, two[:16]), end(2, 32)], "END says 2 points"),
            ([lambda rid: self.chunk(rid, 0, 2, two), end(3, 48)], "END says 3"),
            ([lambda rid: self.chunk(rid, 0, 2, two), lambda rid: pong(b"", rid)],
             "PONG in a points stream"),
            ([lambda rid: hdr(wire.POINTS_CHUNK, rid, 44) + struct.pack("<QII", 0, 2, 32) +
              two[:28]], "data_len 32, payload 44"),
        ]
        for frames, why in cases:
            with self.subTest(why):
                self.fails(ProtocolError, self.stream(frames), why,
                           after=lambda c: c.points("sobol", 2, 2))

    def test_stream_cut_short(self):
        two = struct.pack("<4d", 0, 0, 0.5, 0.5)
        frames = [lambda rid: self.chunk(rid, 0, 2, two)[:30]]
        self.fails(Timeout, self.stream(frames), after=lambda c: c.points("sobol", 2, 2))


def ring_server(lie):
    """A script that takes the client's ring and then answers POINTS with
    lie(ring_mmap, rid) frames."""
    import mmap

    def script(f, s):
        handshake(f, s)
        data, fds, _, _ = socket.recv_fds(s, 1 << 16, 4)
        f.seen.append(len(fds))
        t, rid, n = wire.parse_header(data[:24], 1 << 20, wire.CLIENT_SENT)
        req = wire.decode_payload(t, data[24:24 + n])
        m = mmap.mmap(fds[0], req["slots"] * req["slot_bytes"])
        os.close(fds[0])
        s.sendall(wire.encode(wire.SHM_OK, rid, req))
        while True:
            fr = read_frame(s)
            if fr is None:
                return
            if fr[0] == wire.POINTS:
                s.sendall(lie(m, fr[1], wire.decode_payload(wire.POINTS, fr[2])))
    return script


class Ring(HostileTest):
    def shm_chunk(self, rid, first, points, data_len, slot):
        return wire.encode(wire.POINTS_SHM_CHUNK, rid, {"first": first, "points": points,
                                                        "data_len": data_len, "slot": slot})

    def test_ring_chunks(self):
        n = (1 << 16) + 1  # more than 1 MiB of f64 pairs, so the ring is attached

        def honest(m, rid, req):
            assert req["transport"] == "shm"
            m[:16] = struct.pack("<2d", 0.25, 0.75)
            return (self.shm_chunk(rid, 0, 1, 16, 0) +
                    wire.encode(wire.ERROR, rid, {"code": errors.QMC_ERANGE, "message": "x"}))
        f = self.fake(ring_server(honest))
        c = self.connect(f)
        with self.assertRaises(ServerError):
            c.points("sobol", 2, n)
        self.assertEqual(f.seen[-1], 1)  # one descriptor came with SHM_ATTACH
        c.close()
        for lie, why in ((lambda m, rid, req: self.shm_chunk(rid, 0, 1, 16, 3), "slot 3"),
                         (lambda m, rid, req: self.shm_chunk(rid, 0, 1 << 17, 2 << 20, 0),
                          "at most 1048576 bytes"),
                         (lambda m, rid, req: self.shm_chunk(rid, 5, 1, 16, 0), "index 5")):
            with self.subTest(why):
                self.fails(ProtocolError, self.fake(ring_server(lie)), why,
                           after=lambda c: c.points("sobol", 2, n))


class Auth(HostileTest):
    def key_file(self, key=b"k" * 32):
        path = os.path.join(support.scratch(), "key")
        with open(os.open(path, os.O_WRONLY | os.O_CREAT, 0o600), "wb") as f:
            f.write(key)
        return path

    def test_key_but_no_challenge_over_tcp(self):
        f = self.fake(handshake, tcp=True)
        self.fails(AuthError, f, "did not ask for authentication", auth_key=self.key_file())

    def test_key_but_no_challenge_over_unix_is_fine(self):
        c = self.connect(self.fake(handshake), auth_key=self.key_file())
        self.assertFalse(c.authenticated)
        c.close()

    def challenger(self, ok_mac):
        def script(f, s):
            t, rid, p = read_frame(s)
            s.sendall(wire.encode(wire.AUTH_CHALLENGE, rid, {"version": 4,
                                                             "nonce": bytes(range(32))}))
            t, rid, p = read_frame(s)
            f.seen.append(wire.decode_payload(wire.AUTH_RESPONSE, p))
            s.sendall(wire.encode(wire.AUTH_OK, rid, {"mac": ok_mac(f.seen[-1])}))
            s.sendall(hello_ok(rid))
        return script

    def test_server_proof_checked(self):
        from qmcd import auth
        key = b"k" * 32
        vmax = wire.VERSION_MAX
        right = lambda r: auth.proof(key, auth.LABEL_SERVER, 1, vmax, 4,  # noqa
                                     bytes(range(32)), r["nonce"])
        f = self.fake(self.challenger(right), tcp=True)
        c = self.connect(f, auth_key=self.key_file(key))
        self.assertTrue(c.authenticated)
        c.close()
        r = f.seen[-1]
        self.assertTrue(auth.same(r["mac"], auth.proof(key, auth.LABEL_CLIENT, 1, vmax, 4,
                                                       bytes(range(32)), r["nonce"])))
        f = self.fake(self.challenger(lambda r: bytes(32)), tcp=True)
        e = self.fails(AuthError, f, "could not prove it holds our key",
                       auth_key=self.key_file(key))
        self.assertEqual(e.code, errors.QMC_EAUTH)

    def test_challenge_without_a_key(self):
        self.fails(AuthError, self.fake(self.challenger(lambda r: bytes(32))),
                   "requires authentication")


if __name__ == "__main__":
    unittest.main()
