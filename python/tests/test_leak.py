"""No leak across 1000 solver constructions (and solves): the resident set stays bounded."""
import gc

import numpy as np

import bsarap
from conftest import tube


def rss_kb():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    raise RuntimeError("no VmRSS in /proc/self/status")


def test_no_leak_over_1000_constructions():
    V, F, labels = tube(12, 10)
    b = np.nonzero(labels >= 0)[0]
    bc = V[b] + 0.1

    def round_trip():
        s = bsarap.Arap(V, F, b)
        s.solve(bc, V)
        d = bsarap.Deformer(V, F, labels, method="bsarap")
        d.solve({1: (0.1, 0.0, 0.0)})

    for _ in range(100):  # warm up allocator pools and rayon's threads
        round_trip()
    gc.collect()
    before = rss_kb()
    for _ in range(1000):
        round_trip()
    gc.collect()
    grown = rss_kb() - before
    # One construction holds ~100 kB; a leak of it would grow the RSS by ~100 MB.
    assert grown < 8 * 1024, f"RSS grew by {grown} kB over 1000 constructions"
