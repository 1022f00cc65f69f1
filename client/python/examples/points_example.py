#!/usr/bin/python3
"""points_example.py - Sobol points from qmcd as a numpy array, and the
same points through scipy's engine interface.

    QMC_ENDPOINT=unix:/run/qmcd/qmcd.sock python3 points_example.py

Estimates the integral of prod_j (1 + (x_j - 1/2) / 5) over [0,1)^8 (which
is 1) with 2^16 Owen-scrambled Sobol points, 8 times with 8 seeds, and
prints the mean and the spread of the 8 estimates.
"""
import numpy as np

import qmcd

with qmcd.connect() as client:               # $QMC_ENDPOINT, $QMC_AUTH_KEY_FILE
    estimates = []
    for seed in range(8):
        x = client.points("sobol", dims=8, count=2**16, scramble="owen", seed=seed)
        estimates.append(np.prod(1 + (x - 0.5) / 5, axis=1).mean())
    est = np.array(estimates)
    print("points     %s of %s, from %s" % (x.shape, x.dtype, client.server))
    print("estimate   %.12f +- %.1e (8 scrambles; exact 1)"
          % (est.mean(), est.std(ddof=1) / np.sqrt(len(est))))

    # scipy.stats.qmc's interface: the same points scipy's Sobol gives.
    engine = qmcd.Sobol(d=2, scramble=False, client=client)
    print("engine     first 4 points %s" % engine.random_base2(2).tolist())
