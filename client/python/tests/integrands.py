"""integrands.py - numpy functions that compute what libqmc's built-in
integrands compute (core/genz.c, core/testfn_1d.c), operation for
operation: the same IEEE operations in the same order, libm's exp and pow
through Python's math.  test_sessions.py integrates them through the
Python client, and cmdprog.py serves them to `qmc integrate --command`,
so three paths evaluate one function.

FUNCS names the ones cmdprog.py serves: each is (dims, f).  Must not:
print, or depend on anything but numpy and math.
"""
import math

import numpy as np


def exps(s):
    return np.array([math.exp(v) for v in s])


# Genz's families and poly as core/genz.c and core/testfn_1d.c compute
# them, for the parameters a and u (or the coefficients c).
def gaussian(a, u):
    w = [x * x for x in a]

    def f(x):
        s = np.zeros(len(x))
        for j in range(x.shape[1]):
            t = x[:, j] - u[j]
            s = s + (w[j] * t) * t
        return exps(-s)
    return f


def continuous(a, u):
    def f(x):
        s = np.zeros(len(x))
        for j in range(x.shape[1]):
            s = s + a[j] * np.abs(x[:, j] - u[j])
        return exps(-s)
    return f


def corner(a):
    def f(x):
        s = np.ones(len(x))
        for j in range(x.shape[1]):
            s = s + a[j] * x[:, j]
        c0 = -(x.shape[1] + 1.0)
        return np.array([math.pow(v, c0) for v in s])
    return f


def discontinuous(a, u):
    def f(x):
        s = np.zeros(len(x))
        for j in range(x.shape[1]):
            s = s + a[j] * x[:, j]
        out = exps(s)
        out[(x[:, 0] > u[0]) | (x[:, 1] > u[1])] = 0.0
        return out
    return f


def poly(c):
    def f(x):
        p = np.zeros(len(x))
        for cj in reversed(c):
            p = p * x[:, 0] + cj
        return p
    return f


A3, U3 = [1.5, 2.0, 2.5], [0.5, 0.3, 0.7]


def inv_sqrt(x):
    """x^-1/2 (testfn inv-sqrt): +inf at 0, an integrable singularity."""
    return 1.0 / np.sqrt(x[:, 0])


def with_nonfinite(x):
    """2 x_1 with a NaN and an infinity in every thousand values."""
    v = x[:, 0] * 2.0
    v[::1000] = np.nan
    v[1::1000] = np.inf
    return v


FUNCS = {
    "gaussian": (3, gaussian(A3, U3)),
    "discontinuous": (3, discontinuous(A3, U3)),
    "poly": (1, poly([1.0, -2.0, 3.0, 0.5])),
    "inv-sqrt": (1, inv_sqrt),
    "nonfinite": (2, with_nonfinite),
}
