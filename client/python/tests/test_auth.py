"""The handshake against the daemon itself (qmcd --auth-key): the right
key passes over TCP and over a Unix socket that asks for it, a wrong key
and no key are refused with the daemon's code, a key offered to a TCP
daemon that asks for none is refused by us; key files follow the CLI's
rules (a FIFO is refused at once, never waited on); QMC_ENDPOINT and
QMC_AUTH_KEY_FILE are read as `qmc` reads them.  Also the proofs against
tests/vectors/auth_vectors.h (made by a separate script)."""
import os
import re
import unittest

import support
import qmcd
from qmcd import auth, errors


def key_file(directory, key, mode=0o600, name="key"):
    path = os.path.join(directory, name)
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, mode)
    with open(fd, "wb") as f:
        f.write(key)
    os.chmod(path, mode)
    return path


def setUpModule():
    global d, keyed, key, key_path
    d = support.scratch()
    key = os.urandom(32)
    key_path = key_file(d, key)
    # Many wrong proofs come from this address: no lockout for the test.
    keyed = support.daemon("keyed", "--auth-key", key_path, "--auth-unix", "1",
                           "--auth-max-failures", "1000000")


class Daemon(unittest.TestCase):
    def test_right_key(self):
        for ep in (keyed.tcp, keyed.unix):
            for k in (key_path, key):
                with self.subTest(ep=ep, key=type(k).__name__), qmcd.connect(ep, auth_key=k) as c:
                    self.assertTrue(c.authenticated)
                    self.assertEqual(c.version, qmcd.wire.VERSION_MAX)
                    self.assertGreaterEqual(c.ping(), 0)
                    self.assertEqual(c.points("sobol", 2, 4).tolist(),
                                     [[0, 0], [0.5, 0.5], [0.25, 0.75], [0.75, 0.25]])

    def test_wrong_key(self):
        for ep in (keyed.tcp, keyed.unix):
            with self.subTest(ep), self.assertRaises(qmcd.ServerError) as cm:
                qmcd.connect(ep, auth_key=os.urandom(32))
            self.assertEqual(cm.exception.code, errors.QMC_EAUTH)
            self.assertIn("refused the handshake", cm.exception.message)
        with qmcd.connect(keyed.tcp, auth_key=key) as c:
            self.assertGreaterEqual(c.stats()["auth_failures"], 2)

    def test_no_key(self):
        with self.assertRaises(qmcd.AuthError) as cm:
            qmcd.connect(keyed.tcp, auth_key="")
        self.assertEqual(cm.exception.code, errors.QMC_EAUTH)
        self.assertIn("requires authentication", str(cm.exception))

    def test_key_for_a_daemon_without_one(self):
        plain = support.daemon("plain")
        with self.assertRaisesRegex(qmcd.AuthError, "did not ask for authentication"):
            qmcd.connect(plain.tcp, auth_key=key)
        with qmcd.connect(plain.unix, auth_key=key) as c:  # the socket vouches for it
            self.assertFalse(c.authenticated)

    def test_environment(self):
        old = {k: os.environ.get(k) for k in ("QMC_ENDPOINT", "QMC_AUTH_KEY_FILE")}
        try:
            os.environ["QMC_ENDPOINT"] = keyed.tcp
            os.environ["QMC_AUTH_KEY_FILE"] = key_path
            with qmcd.connect() as c:
                self.assertTrue(c.authenticated)
                self.assertEqual(c.endpoint, keyed.tcp)
            del os.environ["QMC_ENDPOINT"]
            with self.assertRaisesRegex(qmcd.QmcdError, "set QMC_ENDPOINT"):
                qmcd.connect()
        finally:
            for k, v in old.items():
                if v is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = v


class KeyFiles(unittest.TestCase):
    def test_rules(self):
        sd = support.scratch()
        cases = [(key_file(sd, b"x" * 32, 0o644, "open"), "readable or writable by group"),
                 (key_file(sd, b"x" * 15, 0o600, "short"), "shorter than 16 bytes"),
                 (key_file(sd, b"x" * 1025, 0o600, "long"), "longer than 1024 bytes"),
                 (sd, "is a directory")]
        fifo = os.path.join(sd, "fifo")
        os.mkfifo(fifo, 0o600)
        cases.append((fifo, "is a FIFO, not a regular file"))
        for path, why in cases:
            with self.subTest(why), self.assertRaisesRegex(qmcd.AuthError, why):
                qmcd.connect(keyed.tcp, auth_key=path)
        with self.assertRaises(qmcd.QmcdError) as cm:
            qmcd.connect(keyed.tcp, auth_key=os.path.join(sd, "missing"))
        self.assertEqual(cm.exception.name, "ENOENT")
        with self.assertRaisesRegex(qmcd.AuthError, "holds 3 bytes"):
            qmcd.connect(keyed.tcp, auth_key=b"abc")


class Vectors(unittest.TestCase):
    def test_proofs(self):
        with open(support.tree_file("tests", "vectors", "auth_vectors.h")) as f:
            text = f.read()
        entries = re.findall(r"\{(\d+), \{([^}]*)\},\s*(\d+), (\d+), (\d+),\s*\{([^}]*)\},\s*"
                             r"\{([^}]*)\},\s*\{([^}]*)\},\s*\{([^}]*)\},\s*\{([^}]*)\}\}", text)
        self.assertGreaterEqual(len(entries), 4)

        def b(s):
            return bytes(int(x, 16) for x in s.split(",") if x.strip())
        for n, k, vmin, vmax, v, ns, nc, mc, ms, tc in entries:
            k = b(k)[:int(n)]
            vmin, vmax, v = int(vmin), int(vmax), int(v)
            self.assertEqual(auth.transcript(auth.LABEL_CLIENT, vmin, vmax, v, b(ns), b(nc)),
                             b(tc))
            self.assertEqual(auth.proof(k, auth.LABEL_CLIENT, vmin, vmax, v, b(ns), b(nc)), b(mc))
            self.assertEqual(auth.proof(k, auth.LABEL_SERVER, vmin, vmax, v, b(ns), b(nc)), b(ms))


if __name__ == "__main__":
    unittest.main()
