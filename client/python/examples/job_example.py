#!/usr/bin/python3
"""job_example.py - an integration job on qmcd: submit, watch, collect.

    QMC_ENDPOINT=unix:/run/qmcd/qmcd.sock python3 job_example.py

Integrates a 5-dimensional Genz Gaussian with randomized QMC and prints
the estimate, its error bar, the interval and every flag with its meaning;
then the same result as the JSON line `qmc integrate --json` prints.
"""
import qmcd

with qmcd.connect() as client:
    job = client.submit("genz-gaussian", 5, method="rqmc", n=4096)
    print("job        %d submitted" % job.id)   # job.progress(), job.cancel() meanwhile
    r = job.wait()
    print("estimate   %.17g" % r.estimate)
    print("stderr     %.3g (%s), %g%% interval [%.17g, %.17g]"
          % (r.error, r.error_kind, 100 * r.confidence, r.interval[0], r.interval[1]))
    print("exact      %.17g" % r.exact)
    print("work       n %d, evals %d" % (r.n, r.evals))
    for key, meaning in r.meanings().items():
        print("flag       %s: %s" % (key, meaning))
    if not r.flags:
        print("flags      none")
    print(r.json())

    # A job that cannot be trusted says so: x^-1/2 has infinite variance.
    bad = client.run("inv-sqrt", 1, method="mc", n=100000)
    print("inv-sqrt   flags: %s" % ", ".join(bad.flags))
