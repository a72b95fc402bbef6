#!/usr/bin/env python3
"""Reference run of libigl's ARAP (PyPI `libigl` 2.6) on the benchmark of `bsarap bench`.

Same mesh, same handle selection (.dmat or sphere .json, first sphere wins), same motion (the
first group on a circle of radius `--radius`·diag in the xy plane, frames 1..N of one turn),
same warm start (previous frame) and the same stopping rule (relative energy decrease below
`--tol`, capped at `--max-iters`). libigl's `arap_solve` is called with `max_iter = 1`, so one
call is one local-global iteration; it returns neither energy nor rotations, so the
spokes-and-rims energy E(U, R(U)) (rotations fitted to U) is computed here with numpy, outside
the timed region. Prints one JSON object:

    python3 bench/libigl_reference.py ../shared/meshes/armadillo.obj \\
        --handles bench/handles/armadillo.json --frames 20 --tol 1e-4
"""
import argparse
import json
import os
import time

import igl
import numpy as np
import scipy.sparse as sp


def load_selection(path, v):
    if path.endswith(".dmat"):
        with open(path) as f:
            tokens = f.read().split()
        cols, rows = int(tokens[0]), int(tokens[1])
        labels = np.array([int(round(float(t))) for t in tokens[2:2 + cols * rows]])
        return labels
    with open(path) as f:
        spheres = json.load(f)
    labels = np.full(len(v), -1, dtype=int)
    for s in spheres:
        inside = np.linalg.norm(v - np.asarray(s["center"]), axis=1) <= s["radius"]
        labels[inside & (labels < 0)] = s["group"]
    return labels


class Energy:
    """Spokes-and-rims ARAP energy E(U, R(U)) with libigl's cotangent entries."""

    def __init__(self, v, f):
        self.f = f
        self.c = igl.cotmatrix_entries(v, f)  # #F×3, column k: edge (k+1, k+2)
        self.i1 = f[:, [1, 2, 0]]
        self.i2 = f[:, [2, 0, 1]]
        self.e = v[self.i1] - v[self.i2]  # #F×3×3 rest edges
        nf = len(f)
        rows = f.reshape(-1)
        cols = np.repeat(np.arange(nf), 3)
        self.inc = sp.csr_matrix((np.ones(3 * nf), (rows, cols)), shape=(len(v), nf))

    def __call__(self, u):
        d = u[self.i1] - u[self.i2]
        cov = np.einsum("fk,fki,fkj->fij", self.c, self.e, d).reshape(-1, 9)
        s = (self.inc @ cov).reshape(-1, 3, 3)
        uu, _, vt = np.linalg.svd(s)
        r = np.einsum("nji,nkj->nik", vt, uu)  # V U^T
        bad = np.linalg.det(r) < 0
        if bad.any():
            uu[bad, :, 2] *= -1
            r[bad] = np.einsum("nji,nkj->nik", vt[bad], uu[bad])
        total = 0.0
        for corner in range(3):
            rc = r[self.f[:, corner]]
            re = np.einsum("fij,fkj->fki", rc, self.e)
            total += float((self.c * ((d - re) ** 2).sum(-1)).sum())
        return total


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("mesh")
    ap.add_argument("--handles", required=True)
    ap.add_argument("--frames", type=int, default=20)
    ap.add_argument("--tol", type=float, default=1e-4)
    ap.add_argument("--max-iters", type=int, default=100)
    ap.add_argument("--radius", type=float, default=0.1)
    a = ap.parse_args()

    v, f = igl.read_triangle_mesh(a.mesh)
    v = np.ascontiguousarray(v, dtype=np.float64)
    f = np.ascontiguousarray(f, dtype=np.int64)
    labels = load_selection(a.handles, v)
    b = np.nonzero(labels >= 0)[0].astype(np.int32)
    first = labels[b].min()
    moving = labels[b] == first
    diag = float(np.linalg.norm(v.max(0) - v.min(0)))
    radius = a.radius * diag

    t0 = time.perf_counter()
    data = igl.ARAPData()
    data.energy = igl.ARAP_ENERGY_TYPE_SPOKES_AND_RIMS
    data.max_iter = 1
    igl.arap_precomputation(v, f, 3, b, data)
    precompute_ms = (time.perf_counter() - t0) * 1e3
    energy = Energy(v, f)

    u = v.copy()
    iterations, solve_ms, energy_s = [], 0.0, 0.0
    frames_at_cap, last = 0, 0.0
    for k in range(1, a.frames + 1):
        theta = 2 * np.pi * k / a.frames
        t = np.array([radius * (np.cos(theta) - 1), radius * np.sin(theta), 0.0])
        bc = v[b].copy()
        bc[moving] += t
        u[b] = bc
        te = time.perf_counter()
        prev = energy(u)
        energy_s += time.perf_counter() - te
        it, converged = 0, False
        while it < a.max_iters:
            ts = time.perf_counter()
            u = igl.arap_solve(bc, data, u)
            solve_ms += (time.perf_counter() - ts) * 1e3
            it += 1
            te = time.perf_counter()
            e = energy(u)
            energy_s += time.perf_counter() - te
            if a.tol > 0 and (prev <= np.finfo(float).tiny or (prev - e) / prev < a.tol):
                converged = True
                prev = e
                break
            prev = e
        last = prev
        iterations.append(it)
        frames_at_cap += int(not converged)
    total = sum(iterations)
    out = {
        "tool": "libigl " + getattr(igl, "__version__", "2.6"),
        "mesh": a.mesh,
        "vertices": len(v),
        "faces": len(f),
        "frames": a.frames,
        "tolerance": a.tol,
        "max_iterations": a.max_iters,
        "radius": radius,
        "cpu_count": os.cpu_count(),
        "precompute_ms": precompute_ms,
        "ms_per_iteration": solve_ms / max(total, 1),
        "iterations_per_frame": total / a.frames,
        "seconds_per_frame": solve_ms / 1e3 / a.frames,
        "final_energy": last,
        "frames_at_cap": frames_at_cap,
        "iterations": iterations,
        "energy_seconds_untimed": energy_s,
    }
    print(json.dumps(out))


if __name__ == "__main__":
    main()
