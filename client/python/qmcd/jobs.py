"""qmcd.jobs - integration jobs on the daemon: the INTEGRATE request built
from `qmc integrate`'s options with the CLI's defaults (so the same
options send the same bytes), the Job handle (progress, wait, cancel)
and the JobResult with its flags, their meanings and the JSON `qmc
integrate --json` prints.

Must not: read or write the socket except through the Client's frame loop,
or print.  A result's numbers are the daemon's, never recomputed here;
only the report's derived fields (the actual error against the exact
value, relative errors) are computed, as the CLI computes them.
"""
import math
import time

from . import wire
from .errors import ProtocolError, ServerError, Timeout

FLAG_KEYS = {bit: key for bit, key, _ in wire.FLAGS}
FLAG_MEANINGS = {key: text for _, key, text in wire.FLAGS}
_U32 = 2**32 - 1
_U64 = 2**64 - 1


class JobRequest:
    """An INTEGRATE request's fields, and what the report needs of the
    request: the label, the method asked for, the confidence."""

    def __init__(self, fields, label, method, confidence):
        self.fields, self.label, self.method, self.confidence = fields, label, method, confidence


def _u(name, v, lo, hi):
    if isinstance(v, bool) or int(v) != v or not lo <= int(v) <= hi:
        raise ValueError("%s: want an integer in %d..%d, not %r" % (name, lo, hi, v))
    return int(v)


def job_request(integrand=None, dims=None, *, scene=None, scene_label="scene", method="auto",
                a=None, u=None, difficulty=None, control=None, strategy=None, beta=2.0,
                samples=(1, 1), n=None, reps=None, seq=None, scramble=None, shuffle=False,
                split_net=False, seed=0, tol_abs=0.0, tol_rel=0.0, max_evals=100000000,
                max_memory=64 << 20, confidence=0.95, progress_ms=0):
    """The INTEGRATE request `qmc integrate` sends for the same options
    (client/cli/cmd_integrate.c, job_options.c): its defaults, its checks,
    its words.  integrand: a test function name (with dims), or scene: a
    scene's text (docs/SCENES.md), labelled scene_label in the report."""
    if integrand is None and scene is None:
        raise ValueError("integrate: name an integrand or give a scene")
    if integrand is not None and scene is not None:
        raise ValueError("integrate: give either an integrand or a scene, not both")
    if strategy is not None and scene is None:
        raise ValueError("strategy chooses how a scene is sampled; there is no scene")
    if integrand is not None and dims is None:
        raise ValueError("integrate: dims is required with an integrand")
    if scene is not None and (dims is not None or a is not None or u is not None or
                              difficulty is not None or control is not None):
        raise ValueError("a scene fixes the integrand: dims, a, u, difficulty and control do "
                         "not apply")
    if method not in wire.METHODS:
        raise ValueError("method: unknown method '%s' (%s)" % (method, ", ".join(wire.METHODS)))
    if difficulty is not None and difficulty not in wire.DIFFICULTIES:
        raise ValueError("difficulty: unknown preset '%s' (testpack, fixed)" % difficulty)
    if strategy is not None and strategy not in wire.STRATEGIES:
        raise ValueError("strategy: unknown strategy '%s' (%s)"
                         % (strategy, ", ".join(wire.STRATEGIES)))
    if seq is not None and seq not in wire.KINDS:
        raise ValueError("seq: unknown sequence kind '%s'" % seq)
    if scramble is not None and scramble not in wire.SCRAMBLES:
        raise ValueError("scramble: unknown scramble '%s' (%s)"
                         % (scramble, ", ".join(wire.SCRAMBLES)))
    if not 0 < confidence < 1:
        raise ValueError("confidence: must lie strictly between 0 and 1")
    for name, tol in (("tol_abs", tol_abs), ("tol_rel", tol_rel)):
        if tol and not tol > 0:
            raise ValueError("%s: must be a positive number" % name)
    if split_net and method != "rqmc":
        raise ValueError("split_net is for rqmc (auto decides by itself), not %s" % method)
    sampler = method if method in wire.SAMPLERS else "mc"
    if method in ("mc", "stratified", "lhs") and (seq is not None or scramble is not None):
        raise ValueError("seq and scramble are for qmc and rqmc; %s draws its own points"
                         % method)
    b, l = samples
    b, l = _u("samples (brdf)", b, 1, 64), _u("samples (light)", l, 1, 64)
    dims = 0 if dims is None else _u("dims", dims, 1, _U32)
    if n is not None:
        n = _u("n", n, 1, _U64)
    # The sampling spec: qmc_sampling_spec_init for the sampler, then what
    # was given (cli_integrate_defaults).
    spec = {"sampler": sampler, "seq": seq or "sobol",
            "scramble": scramble or ("owen" if sampler == "rqmc" and method == "rqmc"
                                     else "none"),
            "seq_flags": wire.SEQ_SHUFFLE if shuffle else 0, "seed": _u("seed", seed, 0, _U64),
            "n": 4096 if n is None else n, "confidence": float(confidence),
            "reps": (16 if method == "rqmc" else 1) if reps is None
            else _u("reps", reps, 1, 1 << 20),
            "split_net": bool(split_net)}
    if method == "stratified" and n is None:
        # The largest k^D not above the default n, as qmc_integrate does.
        f_dims = dims if scene is None else (
            2 * (b + l) if (strategy or "mis-power").startswith("mis-") else 2)
        best, k = 1, 2
        while True:
            q = 1
            for _ in range(f_dims):
                q *= k
                if q > spec["n"]:
                    break
            if q > spec["n"]:
                break
            best, k = q, k + 1
        spec["n"] = best
    if n is not None and n > _U32:
        raise ValueError("n: %d is too many points per axis" % n)
    scene_text = b""
    if scene is not None:
        scene_text = scene.encode("utf-8") if isinstance(scene, str) else bytes(scene)
    fields = {
        "method": method, "strategy": strategy or "mis-power", "difficulty": difficulty,
        "n_given": n is not None, "dims": dims,
        "samples_brdf": b if scene is not None else 1,
        "samples_light": l if scene is not None else 1,
        "n_axis": 0 if n is None else n, "progress_ms": _u("progress_ms", progress_ms, 0, _U32),
        "max_evals": _u("max_evals", max_evals, 1, _U64),
        "max_memory": _u("max_memory", max_memory, 4096, 1 << 40),
        "beta": float(beta) if scene is not None else 2.0, "tol_abs": float(tol_abs),
        "tol_rel": float(tol_rel), "sampling": spec, "integrand": integrand or "",
        "control": control or "", "a": tuple(a) if a is not None else (),
        "u": tuple(u) if u is not None else (), "scene": scene_text}
    # Let the codec refuse what it would refuse on the wire, before sending.
    wire.LAYOUTS[wire.INTEGRATE].encode(fields)
    label = integrand if scene is None else scene_label
    return JobRequest(fields, label, method, float(confidence))


class JobProgress:
    """A job's state as JOB_STATE or JOB_PROGRESS tells it."""

    def __init__(self, state, evals, seconds):
        self.state, self.evals, self.seconds = state, evals, seconds

    def __repr__(self):
        return "JobProgress(state=%r, evals=%d, seconds=%g)" % (self.state, self.evals,
                                                                 self.seconds)


class Job:
    """An integration job running on the daemon (Client.submit)."""

    def __init__(self, client, request_id, job_id, request):
        self.client = client
        self.request_id = request_id
        self.id = job_id
        self.request = request
        self.finished = False
        self.last_progress = None   # the newest JOB_PROGRESS (progress_ms > 0)
        self._result = None
        self._error = None

    def __repr__(self):
        return "<qmcd.Job %d %s>" % (self.id, "finished" if self.finished else "running")

    # Frames for our INTEGRATE request, from the client's frame loop.
    def _file(self, mtype, msg):
        if self.finished:
            return False
        if mtype == wire.JOB_PROGRESS:
            if msg["job_id"] != self.id:
                raise self.client._break(ProtocolError(
                    "protocol error: JOB_PROGRESS for job %d on the request of job %d"
                    % (msg["job_id"], self.id)))
            self.last_progress = JobProgress("running", msg["evals"], msg["seconds"])
            return True
        if mtype == wire.JOB_RESULT:
            if msg["job_id"] != self.id:
                raise self.client._break(ProtocolError(
                    "protocol error: JOB_RESULT for job %d on the request of job %d"
                    % (msg["job_id"], self.id)))
            self._result = JobResult(msg, self.request)
            self.finished = True
            return True
        if mtype == wire.ERROR:
            self._error = ServerError(msg["code"], msg["message"], self.request_id)
            self.finished = True
            return True
        return False

    def progress(self):
        """JOB_STATUS: the job's state (queued, running, done, cancelled,
        failed, unknown), evaluations so far and seconds."""
        c = self.client
        with c._lock:
            rid = c._send(wire.JOB_STATUS, {"job_id": self.id})
            msg = c._answer(rid, wire.JOB_STATE)
            if msg["job_id"] != self.id:
                raise c._break(ProtocolError("protocol error: JOB_STATE for job %d, not %d"
                                             % (msg["job_id"], self.id)))
            return JobProgress(msg["state"], msg["evals"], msg["seconds"])

    def cancel(self):
        """JOB_CANCEL; returns the state JOB_STATE gave: cancelled (wait()
        then raises ServerError ECANCELED), done or failed (it finished
        first), unknown."""
        c = self.client
        with c._lock:
            rid = c._send(wire.JOB_CANCEL, {"job_id": self.id})
            return c._answer(rid, wire.JOB_STATE)["state"]

    def wait(self, timeout=None):
        """The JobResult, once it arrives: at most timeout seconds (None:
        as long as the job runs; a quiet daemon is asked JOB_STATUS every
        client timeout, so a dead one is noticed).  Raises ServerError when
        the job failed or was cancelled, Timeout when timeout passed (the
        job and the connection go on)."""
        c = self.client
        until = None if timeout is None else time.monotonic() + timeout
        with c._lock:
            while not self.finished:
                if c._conn.closed:
                    from .errors import ConnectionLost
                    raise ConnectionLost("the connection is closed; job %d is lost" % self.id)
                left = None if until is None else until - time.monotonic()
                quiet = c.timeout if left is None else (
                    left if c.timeout is None else min(left, c.timeout))
                if not c._conn.readable(quiet):
                    if until is not None and time.monotonic() >= until:
                        raise Timeout("job %d: no result within %g s" % (self.id, timeout))
                    self.progress()  # alive?  A dead daemon fails this.
                    continue
                mtype, rid, msg = c._frame()
                c._other(mtype, rid, msg)
        if self._error is not None:
            raise self._error
        return self._result

    @property
    def result(self):
        """The JobResult if it has arrived (else None); see wait()."""
        return self._result


def _num(v):
    return "%.17g" % v if math.isfinite(v) else "null"


def _div(a, b):
    """a / b in IEEE arithmetic (inf or NaN where Python would raise)."""
    if b == 0:
        if a == 0 or math.isnan(a):
            return math.nan
        return math.copysign(math.inf, a) * math.copysign(1.0, b)
    return a / b


def _json_str(s):
    out = ['"']
    for ch in s:
        o = ord(ch)
        if ch in '"\\':
            out.append("\\" + ch)
        elif o < 0x20:
            out.append("\\u%04x" % o)
        else:
            out.append(ch)
    out.append('"')
    return "".join(out)


def _client_text(s, limit):
    """What libqmcclient hands the CLI: control bytes as spaces
    (qmc__client_copy_str), at most limit - 1 bytes (the report's
    buffers)."""
    b = bytes(0x20 if c < 0x20 or c == 0x7F else c for c in s.encode("utf-8"))
    return b[:limit - 1].decode("utf-8", errors="replace")


class JobResult:
    """An integration result: the daemon's JOB_RESULT and what the report
    derives from it.

    estimate; error and error_kind ("stderr": a standard error, "estimate":
    a rule's own error estimate, "none": no bar at all); stderr and
    error_estimate (each None unless that is the kind); interval (ci_low,
    ci_high) at `confidence`, None without a bar; flags (keys, bit order)
    and flag_bits; meanings() (key -> what it means, docs/FLAGS.md); n,
    evals, dims, nonfinite; method (asked) and method_used; detail and
    auto_reason; reference and reference_kind ("exact", "reference" or
    "none") and exact (None unless exact); abs_integral (the integrator's
    estimate of the integral of |f|) and known_abs (that integral in
    closed form, as the daemon knows it; None when unknown, or when a
    daemon of protocol version 5 or older did not say: known_abs_told);
    cv_used, cv_beta,
    cv_variance_ratio; seconds (the daemon's compute time); sampling (the
    spec that ran, a dict); job_id.  json() is `qmc integrate --json`.
    """

    def __init__(self, msg, request):
        self.raw = msg
        self.request = request
        self.job_id = msg["job_id"]
        self.method = request.method
        self.method_used = msg["method_used"]
        self.estimate = msg["estimate"]
        self.error_kind = msg["error_kind"]
        self.error = None if self.error_kind == "none" else msg["error"]
        self.stderr = msg["error"] if self.error_kind == "stderr" else None
        self.error_estimate = msg["error"] if self.error_kind == "estimate" else None
        self.interval = None if self.error_kind == "none" else (msg["ci_low"], msg["ci_high"])
        self.confidence = request.confidence
        self.flag_bits = msg["flags"]
        self.flags = tuple(wire.flag_names(msg["flags"]))
        self.n, self.evals, self.dims = msg["n"], msg["evals"], msg["dims"]
        self.nonfinite = msg["nonfinite"]
        self.cv_used = msg["cv_used"]
        self.cv_beta, self.cv_variance_ratio = msg["cv_beta"], msg["cv_variance_ratio"]
        self.seconds = msg["seconds"]
        self.reference_kind = msg["reference_kind"]
        self.reference = None if self.reference_kind == "none" else msg["reference"]
        self.exact = self.reference if self.reference_kind == "exact" else None
        self.abs_integral = msg["abs_integral"]
        # Protocol version 6: the daemon says what the integrand knows.
        self.known_abs_told = "has_known_abs" in msg
        self.known_abs = msg["known_abs"] if msg.get("has_known_abs") else None
        self.detail = msg["detail"]
        self.auto_reason = msg["auto_reason"]
        self.sampling = msg["sampling"]

    def meanings(self):
        """key -> meaning of each flag raised (docs/FLAGS.md)."""
        return {k: FLAG_MEANINGS.get(k, "an undefined flag bit") for k in self.flags}

    @property
    def reliable(self):
        """False when a flag says the estimate or its bar cannot be trusted
        as printed (any flag at all: each one qualifies the number)."""
        return not self.flags

    def __repr__(self):
        bar = "" if self.error is None else " +- %.3g (%s)" % (self.error, self.error_kind)
        return "<qmcd.JobResult %s: %.17g%s, flags %s>" % (
            self.method_used, self.estimate, bar, ",".join(self.flags) or "none")

    def json(self):
        """The one line `qmc integrate --json` prints for this job (without
        its newline), byte for byte (client/cli/integrate_output.c)."""
        has_ref = self.reference is not None
        ref = self.reference if has_ref else math.nan
        est = self.estimate
        err = est - ref
        absint = self.known_abs if self.known_abs is not None else (
            self.abs_integral if self.abs_integral > 0 else math.nan)
        kind = self.error_kind
        raw = self.raw
        parts = ['"integrand":' + _json_str(self.request.label),
                 '"method":' + _json_str(self.method),
                 '"method_used":' + _json_str(self.method_used),
                 '"detail":' + _json_str(_client_text(self.detail, 160))]
        reason = _client_text(self.auto_reason, 512)
        if reason:
            parts.append('"auto_reason":' + _json_str(reason))
        parts += [
            '"estimate":' + _num(est),
            '"stderr":' + _num(raw["error"] if kind == "stderr" else math.nan),
            '"error_estimate":' + _num(raw["error"] if kind == "estimate" else math.nan),
            '"ci_low":' + _num(math.nan if kind == "none" else raw["ci_low"]),
            '"ci_high":' + _num(math.nan if kind == "none" else raw["ci_high"]),
            '"confidence":' + _num(self.confidence if kind == "stderr" else math.nan),
            '"exact":' + _num(ref if self.reference_kind == "exact" else math.nan)]
        if has_ref and self.reference_kind != "exact":
            parts.append('"reference":' + _num(ref))
        parts += ['"abs_error":' + _num(abs(err)),
                  '"rel_error":' + _num(_div(abs(err), abs(ref))),
                  '"abs_integral":' + _num(absint),
                  '"error_vs_abs_integral":' + _num(_div(abs(err), absint)),
                  '"n":%d' % self.n, '"evals":%d' % self.evals, '"dims":%d' % self.dims,
                  '"nonfinite":%d' % self.nonfinite]
        if self.cv_used:
            parts += ['"cv_beta":' + _num(self.cv_beta),
                      '"cv_variance_ratio":' + _num(self.cv_variance_ratio)]
        parts += ['"seconds":' + _num(self.seconds),
                  '"flags":[' + ",".join('"%s"' % k for k in self.flags) + "]"]
        return "{" + ",".join(parts) + "}"
