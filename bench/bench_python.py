#!/usr/bin/python3
"""bench_python.py - the Python client's side of bench/bench_python.sh:
one measurement of one mode against a running qmcd, printed as the
"RESULT key=value ..." line qmc-load prints, so the script reads both
alike.

    bench_python.py ENDPOINT bulk-fresh|bulk-out|bulk-chunks DIMS COUNT REPEAT
    bench_python.py ENDPOINT ping|points1 REQUESTS

bulk-out: client.points(out=) into one array, allocated and faulted in
before the clock and reused (what qmc-load --bulk --shm --into does with
qmc_client_points); bulk-fresh: client.points() into a new numpy array
each time (its page faults in the time); bulk-chunks:
client.points_chunks(), each chunk a view of the ring touched once (what
qmc-load --bulk --shm does).  REPEAT streams, the median.  ping, points1: REQUESTS round trips one
after another (a PING; a POINTS of 1 point of 8-dimensional Sobol, f64),
the median and 99th percentile latency.  A benchmark only: it asserts
nothing and prints one line.
"""
import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "client",
                                "python"))
import numpy as np  # noqa: E402

import qmcd  # noqa: E402


def bulk(client, mode, dims, count, repeat):
    out = None
    if mode == "bulk-out":
        out = np.empty((count, dims))
        out[:] = 0  # faulted in before the clock, as a reused array is
    client.points("sobol", dims, 1 << 16)  # the ring attached before the clock too
    sink = 0
    times = []
    for _ in range(repeat):
        x = None
        t0 = time.perf_counter()
        if mode == "bulk-chunks":
            for _, a in client.points_chunks("sobol", dims, count):
                sink ^= int(a[len(a) // 2, 0] * 2.0**32)
        else:
            x = client.points("sobol", dims, count, out=out)
            sink ^= int(x[count // 2, 0] * 2.0**32)
        times.append(time.perf_counter() - t0)
    secs = sorted(times)[len(times) // 2]
    nbytes = count * dims * 8
    print("RESULT mode=%s points=%d bytes=%d seconds=%.4f mbps=%.1f sink=%d"
          % (mode, count, nbytes, secs, nbytes / secs / 1e6, sink & 1))


def latency(client, mode, n):
    call = client.ping if mode == "ping" else (lambda: client.points("sobol", 8, 1))
    for _ in range(min(n, 200)):  # warm up: imports, first allocations
        call()
    lat = np.empty(n)
    t0 = time.perf_counter()
    for i in range(n):
        t = time.perf_counter()
        call()
        lat[i] = time.perf_counter() - t
    secs = time.perf_counter() - t0
    print("RESULT mode=%s requests=%d seconds=%.4f rate=%.1f p50_us=%.2f p99_us=%.2f"
          % (mode, n, secs, n / secs, 1e6 * np.percentile(lat, 50),
             1e6 * np.percentile(lat, 99)))


def main():
    endpoint, mode = sys.argv[1], sys.argv[2]
    with qmcd.connect(endpoint, timeout=60) as client:
        if mode.startswith("bulk"):
            bulk(client, mode, int(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5]))
        else:
            latency(client, mode, int(sys.argv[3]))


if __name__ == "__main__":
    main()
