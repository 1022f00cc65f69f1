#!/usr/bin/python3
"""integrate_example.py - your own function, integrated by qmcd: the
daemon picks the points and keeps the estimate, the error bar and the
stopping rule; this script only evaluates f where it is asked to.

    QMC_ENDPOINT=unix:/run/qmcd/qmcd.sock python3 integrate_example.py

f(x) = prod_j 3 x_j^2 over [0,1)^4 (integral 1), by randomized QMC until
the 95% interval is within 1e-5 of the estimate, relative (a line for
each doubling of the points); then the same with `auto`, which, told that
f is smooth, picks a rule for it.
"""
import numpy as np

import qmcd


def f(x):
    """x: an (n, 4) array of points; returns the n values."""
    return np.prod(3.0 * x * x, axis=1)


def progress(rep):
    """Called after each batch with the daemon's running report."""
    if rep.estimate is not None and rep.evals & (rep.evals - 1) == 0:
        print("so far     %d values: %.10f" % (rep.evals, rep.estimate))


with qmcd.connect() as client:
    r = client.integrate(f, 4, method="rqmc", tol_rel=1e-5, exact=1.0, name="prod 3x^2",
                         on_report=progress)
    print("estimate   %.15f +- %.2e (%s), %d evaluations" % (r.estimate, r.error,
                                                              r.error_kind, r.evals))
    print("abs error  %.2e (exact 1)" % abs(r.estimate - 1.0))
    print("ended      %s; flags: %s" % (r.report.end, ", ".join(r.flags) or "none"))
    a = client.integrate(f, 4, method="auto", tol_rel=1e-10, smoothness="analytic")
    print("auto       %s: %.15f, %d evaluations" % (a.method_used, a.estimate, a.evals))
