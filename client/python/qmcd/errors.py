"""qmcd.errors - the exceptions the client raises, each carrying a code.

Codes are those of the wire protocol (protocol/PROTOCOL.md section 7): a
QMC_E* code of include/qmc/error.h, or a negated Linux errno.  Every
exception has .code (int, < 0), .name ("QMC_EDIMS", "ETIMEDOUT") and
.message (one line for people, the daemon's own words when it sent them).

Must not: import anything of the package (the codec and the client both
raise these), or swallow the daemon's message.
"""
import errno as _errno

QMC_EINVAL = -1001
QMC_ENOMEM = -1002
QMC_EKIND = -1003
QMC_ESCRAMBLE = -1004
QMC_EDIMS = -1005
QMC_ERANGE = -1006
QMC_ECOUNT = -1007
QMC_EFORMAT = -1008
QMC_EAGAIN = -1009
QMC_EPROTO = -1010
QMC_ETOOBIG = -1011
QMC_ENOTSUP = -1012
QMC_EDOMAIN = -1013
QMC_EBUDGET = -1014
QMC_ECANCELED = -1015
QMC_EAUTH = -1016

# QMC_ERROR_MAP of include/qmc/error.h: name, code, meaning.  A unit test
# reads the header and checks this table against it.
ERROR_MAP = (
    ("QMC_EINVAL", QMC_EINVAL, "invalid argument"),
    ("QMC_ENOMEM", QMC_ENOMEM, "out of memory"),
    ("QMC_EKIND", QMC_EKIND, "unknown sequence kind"),
    ("QMC_ESCRAMBLE", QMC_ESCRAMBLE, "scramble not supported by this sequence kind"),
    ("QMC_EDIMS", QMC_EDIMS, "dimension count outside the kind's range"),
    ("QMC_ERANGE", QMC_ERANGE, "index past the end of the sequence"),
    ("QMC_ECOUNT", QMC_ECOUNT, "point count not valid for this kind"),
    ("QMC_EFORMAT", QMC_EFORMAT, "unknown output format"),
    ("QMC_EAGAIN", QMC_EAGAIN, "incomplete input"),
    ("QMC_EPROTO", QMC_EPROTO, "malformed input"),
    ("QMC_ETOOBIG", QMC_ETOOBIG, "request exceeds a configured limit"),
    ("QMC_ENOTSUP", QMC_ENOTSUP, "operation not supported"),
    ("QMC_EDOMAIN", QMC_EDOMAIN, "value outside the function's domain"),
    ("QMC_EBUDGET", QMC_EBUDGET, "evaluation budget exceeded"),
    ("QMC_ECANCELED", QMC_ECANCELED, "stopped by the caller's interrupt hook"),
    ("QMC_EAUTH", QMC_EAUTH, "authentication failed"),
)
_BY_CODE = {code: (name, text) for name, code, text in ERROR_MAP}

ECANCELED = -_errno.ECANCELED
ETIMEDOUT = -_errno.ETIMEDOUT
ECONNRESET = -_errno.ECONNRESET
ENOENT = -_errno.ENOENT


def error_name(code):
    """The symbolic name of a code: "QMC_EDIMS", "ECANCELED", or "E?123"."""
    if code in _BY_CODE:
        return _BY_CODE[code][0]
    return _errno.errorcode.get(-code, "E?%d" % -code) if code < 0 else "E?%d" % code


def strerror(code):
    """A short meaning of a code, as qmc_strerror() gives it."""
    if code in _BY_CODE:
        return _BY_CODE[code][1]
    import os
    return os.strerror(-code) if code < 0 else "unknown error %d" % code


class QmcdError(Exception):
    """Anything that went wrong talking to qmcd; .code, .name, .message."""

    def __init__(self, code, message=None):
        self.code = int(code)
        self.name = error_name(self.code)
        self.message = message if message else strerror(self.code)
        Exception.__init__(self, self.message)

    def __str__(self):
        return "%s (%s)" % (self.message, self.name)


class ServerError(QmcdError):
    """The daemon answered ERROR: .code and .message are its own.
    .request_id is the request it ended (0: the whole connection, which
    the daemon then closes)."""

    def __init__(self, code, message, request_id=0):
        QmcdError.__init__(self, code, message)
        self.request_id = request_id


class ProtocolError(QmcdError):
    """The peer broke the protocol: garbage, a truncated or malformed
    frame, a message out of place.  The connection is closed."""

    def __init__(self, message, code=QMC_EPROTO):
        QmcdError.__init__(self, code, message)


class FrameTooBig(ProtocolError):
    """A frame header announced more payload than we accept."""

    def __init__(self, message):
        ProtocolError.__init__(self, message, QMC_ETOOBIG)


class ConnectionLost(QmcdError, ConnectionError):
    """The connection closed or broke (EOF, reset) before the answer."""

    def __init__(self, message, code=ECONNRESET):
        QmcdError.__init__(self, code, message)


class Timeout(QmcdError, TimeoutError):
    """No byte, or no whole frame, arrived within the client's timeout."""

    def __init__(self, message):
        QmcdError.__init__(self, ETIMEDOUT, message)


class AuthError(QmcdError):
    """Authentication failed or could not be done (PROTOCOL.md 4.1)."""

    def __init__(self, message):
        QmcdError.__init__(self, QMC_EAUTH, message)
