"""qmcd - a Python client for the qmcd daemon: low-discrepancy points and
renderers' pixel samples as numpy arrays, scipy.stats.qmc-style engines
served by the daemon, and integration jobs with honest error bars.

    import qmcd
    c = qmcd.connect()                        # $QMC_ENDPOINT, $QMC_AUTH_KEY_FILE
    x = c.points("sobol", dims=8, count=4096, scramble="owen", seed=7)
    tile = c.pixels("zsobol", (1920, 1080), spp=16, dims=8, tile=(0, 0, 64, 64))
    r = c.run("genz-gaussian", 5, method="rqmc")   # r.estimate, r.error, r.flags
    s = c.integrate(lambda x: (x**2).sum(axis=1), 3, method="rqmc")  # your own f
    p = c.integrate(f, 3, method="rqmc", n=65536, part=(1, 4))  # p.write("part1")
    eng = qmcd.Sobol(8, scramble=False, client=c)  # scipy's engine, on the daemon

Pure Python (the standard library and numpy); the wire protocol is
protocol/PROTOCOL.md of the qmcd tree.  Errors are qmcd.QmcdError
subclasses carrying the daemon's code and message.
"""
from .client import Client, connect, JOE_KUO_TABLE_HASH
from .streams import tile_piece
from .engines import (QMCEngine, Sobol, Halton, Hammersley, LatinHypercube, Stratified,
                      Random)
from .errors import (QmcdError, ServerError, ProtocolError, FrameTooBig, ConnectionLost,
                     Timeout, AuthError, error_name, strerror)
from .jobs import Job, JobResult, JobProgress, FLAG_MEANINGS
from .sessions import Session, SessionBatch, SessionReport, SessionResult
from .parts import PartResult

__version__ = "0.1.0"

__all__ = ["Client", "connect", "tile_piece", "JOE_KUO_TABLE_HASH", "QMCEngine", "Sobol",
           "Halton", "Hammersley", "LatinHypercube", "Stratified", "Random", "QmcdError",
           "ServerError", "ProtocolError", "FrameTooBig", "ConnectionLost", "Timeout",
           "AuthError", "error_name", "strerror", "Job", "JobResult", "JobProgress",
           "FLAG_MEANINGS", "Session", "SessionBatch", "SessionReport", "SessionResult",
           "PartResult"]
