#!/usr/bin/env python3
"""Time bsarap.Arap against libigl's ARAP (igl.arap_precomputation / igl.arap_solve, PyPI
libigl 2.6.3) per iteration, on the same mesh, handles, motion and starting guesses.

For each MESH SEL pair: the handle selection (a libigl .dmat, or a sphere .json as in
bench/handles/, first sphere wins) gives b; the first group moves on the circle of `bsarap
bench` (radius 0.1·diag in the xy plane), at frames k/(N+1) of one turn for k = 1..N (never
back at rest, which bsarap returns without iterating), the other groups stay. Every frame runs
exactly --iters spokes-and-rims iterations in both solvers (bsarap: tol=0, counted from its
stats; libigl: data.max_iter), each warm-started from its own previous frame; only the solve
calls are timed. --repeat rounds (from rest each time) give each solver's median round, so that a
moment of load on a shared machine does not decide the ratio.
Prints one line per mesh and the per-iteration ratio (libigl / bsarap), then a JSON list:

    python python/bench.py ../shared/meshes/decimated-knight.off \\
        ../shared/meshes/decimated-knight-selection.dmat
"""
import argparse
import json
import os
import time

import numpy as np

import bsarap


def labels_of(path, V):
    """Per-vertex group labels from a .dmat or a sphere .json (first sphere wins)."""
    if str(path).endswith(".json"):
        with open(path) as f:
            spheres = json.load(f)
        labels = np.full(len(V), -1, dtype=np.int64)
        for s in spheres:
            inside = np.linalg.norm(V - np.asarray(s["center"]), axis=1) <= s["radius"]
            labels[inside & (labels < 0)] = s["group"]
        return labels
    return bsarap.load_selection(path, V)


def bench(mesh, sel, frames, iters, radius, repeat):
    import igl

    V, F = bsarap.load_mesh(mesh)
    labels = labels_of(sel, V)
    b = np.nonzero(labels >= 0)[0]
    moving = labels[b] == labels[b].min()
    diag = float(np.linalg.norm(V.max(0) - V.min(0)))
    r = radius * diag

    t0 = time.perf_counter()
    ours = bsarap.Arap(V, F, b, max_iters=iters, tol=0)
    ours_pre = time.perf_counter() - t0
    t0 = time.perf_counter()
    data = igl.ARAPData()
    data.energy = igl.ARAP_ENERGY_TYPE_SPOKES_AND_RIMS
    data.max_iter = iters
    igl.arap_precomputation(V, F, 3, b.astype(np.int32), data)
    igl_pre = time.perf_counter() - t0

    ms_ours, ms_igl = [], []
    n = frames * iters
    for _ in range(repeat):  # rounds from rest; each solver's median round is reported
        U_ours, U_igl = V.copy(), V.copy()
        t_ours = t_igl = 0.0
        n_ours = 0
        for k in range(1, frames + 1):
            theta = 2 * np.pi * k / (frames + 1)
            bc = V[b].copy()
            bc[moving] += [r * (np.cos(theta) - 1), r * np.sin(theta), 0.0]
            t0 = time.perf_counter()
            U_ours = ours.solve(bc, U_ours)
            t_ours += time.perf_counter() - t0
            n_ours += ours.stats.iterations
            t0 = time.perf_counter()
            U_igl = igl.arap_solve(bc, data, U_igl)
            t_igl += time.perf_counter() - t0
        assert n_ours == n, f"bsarap ran {n_ours} iterations, libigl {n}"
        ms_ours.append(t_ours * 1e3 / n)
        ms_igl.append(t_igl * 1e3 / n)
    m_ours, m_igl = float(np.median(ms_ours)), float(np.median(ms_igl))
    return {
        "mesh": os.path.basename(str(mesh)),
        "vertices": len(V),
        "faces": len(F),
        "handles": len(b),
        "frames": frames,
        "iterations_per_frame": iters,
        "bsarap_precompute_ms": ours_pre * 1e3,
        "libigl_precompute_ms": igl_pre * 1e3,
        "repeat": repeat,
        "bsarap_ms_per_iteration": m_ours,
        "libigl_ms_per_iteration": m_igl,
        "ratio": m_igl / m_ours,
        "bsarap_ms_per_iteration_rounds": ms_ours,
        "libigl_ms_per_iteration_rounds": ms_igl,
        # Unconverged iterates (--iters per frame), so only a sanity figure.
        "last_frame_distance_over_diag": float(np.linalg.norm(U_ours - U_igl, axis=1).max() / diag),
        "cpu_count": os.cpu_count(),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("pairs", nargs="+", metavar="MESH SEL", help="mesh and handle selection, repeated")
    ap.add_argument("--frames", type=int, default=10)
    ap.add_argument("--iters", type=int, default=10, help="iterations per frame in both solvers")
    ap.add_argument("--radius", type=float, default=0.1, help="circle radius, fraction of the diagonal")
    ap.add_argument("--repeat", type=int, default=3, help="rounds; the median round of each solver is reported")
    a = ap.parse_args()
    if len(a.pairs) % 2:
        ap.error("give MESH SEL pairs")
    rows = []
    print(f"{'mesh':<24} {'#V':>7} {'bsarap ms/it':>13} {'libigl ms/it':>13} {'ratio':>7}")
    for mesh, sel in zip(a.pairs[::2], a.pairs[1::2]):
        row = bench(mesh, sel, a.frames, a.iters, a.radius, a.repeat)
        rows.append(row)
        print(f"{row['mesh']:<24} {row['vertices']:>7} {row['bsarap_ms_per_iteration']:>13.3f} "
              f"{row['libigl_ms_per_iteration']:>13.3f} {row['ratio']:>6.1f}x", flush=True)
    print(json.dumps(rows))


if __name__ == "__main__":
    main()
