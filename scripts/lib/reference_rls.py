#!/usr/bin/python3
"""A straightforward per-sample RLS with forgetting in numpy: the reference the C++ RLS is compared with
(scripts/benchmark). Prints nanoseconds per update for each parameter count given."""
import sys
import time

import numpy as np


def rls_ns_per_update(n, updates=60000, forgetting=0.998):
    rng = np.random.default_rng(1)
    rows = rng.standard_normal((1024, n))
    theta = np.ones(n)
    p = np.eye(n) * 100.0
    start = time.perf_counter()
    for k in range(updates):
        phi = rows[k & 1023]
        y = phi.sum()
        p_phi = p @ phi
        gain = p_phi / (forgetting + phi @ p_phi)
        theta = theta + gain * (y - phi @ theta)
        p = (p - np.outer(gain, p_phi)) / forgetting
    return (time.perf_counter() - start) / updates * 1e9


if __name__ == "__main__":
    for n in map(int, sys.argv[1:] or ["3", "4", "8"]):
        print("%d %.1f" % (n, rls_ns_per_update(n)))
