"""qmcd.auth - the client's half of the version-3 handshake (PROTOCOL.md
section 4.1, docs/SECURITY.md): reading a key file by the daemon's and
the CLI's rules, and the two HMAC-SHA256 proofs.

Mc = HMAC-SHA256(key, T("qmcd-auth-v1 C>S")), Ms likewise with "S>C",
where T(label) is the 16 label bytes, u16 version_min, u16 version_max
(the HELLO's), u16 version (the AUTH_CHALLENGE's), u16 0, Ns, Nc.

Must not: send anything (client.py does), keep the key anywhere but the
client that loaded it, or follow a key file that is not a regular file
(opening a FIFO would wait for a writer).
"""
import hashlib
import hmac
import os
import stat
import struct

from .errors import AuthError, QmcdError

KEY_MIN_BYTES = 16
KEY_MAX_BYTES = 1024
LABEL_CLIENT = b"qmcd-auth-v1 C>S"
LABEL_SERVER = b"qmcd-auth-v1 S>C"


def _kind(mode):
    for test, what in ((stat.S_ISFIFO, "a FIFO"), (stat.S_ISDIR, "a directory"),
                       (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
                       (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return what
    return "of an unknown type"


def check_key(key, what="auth key"):
    """Raises AuthError unless key (bytes) is 16 to 1024 bytes."""
    if not KEY_MIN_BYTES <= len(key) <= KEY_MAX_BYTES:
        raise AuthError("%s holds %d bytes; a key is %d to %d"
                        % (what, len(key), KEY_MIN_BYTES, KEY_MAX_BYTES))
    return bytes(key)


def load_key(path):
    """The key in file `path`, by the rules the daemon and `qmc` apply: a
    regular file, not readable or writable by group or others, 16 to 1024
    bytes.  AuthError names what is wrong; an OSError's reason becomes a
    QmcdError with its -errno."""
    path = os.fspath(path)
    shown = os.fsdecode(path)
    try:
        st = os.stat(path)
        if not stat.S_ISREG(st.st_mode):
            raise AuthError("auth key %s: is %s, not a regular file" % (shown, _kind(st.st_mode)))
        # Non-blocking, so a name swapped for a FIFO since the stat cannot
        # make us wait; the fstat below refuses it.
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC | os.O_NOCTTY)
    except OSError as e:
        raise QmcdError(-e.errno, "auth key %s: cannot open: %s" % (shown, e.strerror)) from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise AuthError("auth key %s: is %s, not a regular file" % (shown, _kind(st.st_mode)))
        if st.st_mode & 0o077:
            raise AuthError("auth key %s is readable or writable by group or others "
                            "(chmod 600 it)" % shown)
        if st.st_size < KEY_MIN_BYTES:
            raise AuthError("auth key %s is shorter than 16 bytes (make one with "
                            "head -c 32 /dev/urandom)" % shown)
        if st.st_size > KEY_MAX_BYTES:
            raise AuthError("auth key %s is longer than 1024 bytes: not a key file" % shown)
        chunks, got = [], 0
        while got <= KEY_MAX_BYTES:
            b = os.read(fd, KEY_MAX_BYTES + 1 - got)
            if not b:
                break
            chunks.append(b)
            got += len(b)
    except OSError as e:
        raise QmcdError(-e.errno, "auth key %s: %s" % (shown, e.strerror)) from None
    finally:
        os.close(fd)
    return check_key(b"".join(chunks), "auth key %s" % shown)


def transcript(label, version_min, version_max, version, server_nonce, client_nonce):
    """T(label): the 88 bytes both proofs are MACs of."""
    return (label + struct.pack("<HHHH", version_min, version_max, version, 0) +
            bytes(server_nonce) + bytes(client_nonce))


def proof(key, label, version_min, version_max, version, server_nonce, client_nonce):
    return hmac.new(key, transcript(label, version_min, version_max, version, server_nonce,
                                    client_nonce), hashlib.sha256).digest()


def same(a, b):
    """Constant-time comparison of two proofs."""
    return hmac.compare_digest(bytes(a), bytes(b))
