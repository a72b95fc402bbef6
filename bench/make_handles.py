#!/usr/bin/env python3
"""Writes the sphere-selection handle sets bench/handles/*.json for the paper's meshes.

Each region is a sphere of radius `r`·diag around an extreme vertex of the mesh (an ear tip, a
hand, the lowest point of a foot), found from the geometry so the choice is reproducible:
    python3 bench/make_handles.py   # from the repository root; reads ../shared/meshes
Group 0 is the one the benchmark moves on a circle; the others stay at rest. The knight and
decimated-max use libigl's own .dmat selections from ../shared/meshes instead.

`*-b.json` are held-out sets for armadillo, Cheburashka and the bunny: other regions, other
sizes and another moving group, on which no default was tuned (the defaults are checked on
them, BENCHMARKS.md "Defaults on held-out handle sets"). `*-c.json` are held out the same way
from the comparison of base smoothing lengths (BENCHMARKS.md, "One pose at every resolution").
"""
import json
import sys

import numpy as np

MESHES = "../shared/meshes/"


def read(path):
    import igl

    v, f = igl.read_triangle_mesh(path)
    return np.asarray(v, dtype=float)


def extreme(v, direction, mask=None):
    d = np.asarray(direction, dtype=float)
    s = v @ d
    if mask is not None:
        s = np.where(mask, s, -np.inf)
    return v[int(np.argmax(s))]


def spheres(v, regions, r):
    diag = float(np.linalg.norm(v.max(0) - v.min(0)))
    out = []
    for g, (name, c) in enumerate(regions):
        n = int((np.linalg.norm(v - c, axis=1) <= r * diag).sum())
        print(f"  group {g} {name}: {n} vertices", file=sys.stderr)
        out.append({"group": g, "center": [float(x) for x in c],
                    "radius": r * diag})
    return out


def main():
    sets = {}
    v = read(MESHES + "armadillo.obj")  # y up, facing +z
    lowy = v[:, 1] < np.quantile(v[:, 1], 0.05)
    sets["armadillo"] = (v, [
        ("right hand", extreme(v, [1, 0, 0])),
        ("left hand", extreme(v, [-1, 0, 0])),
        ("left foot", extreme(v, [-0.3, -1, 0], lowy & (v[:, 0] < 0))),
        ("right foot", extreme(v, [0.3, -1, 0], lowy & (v[:, 0] > 0))),
        ("head", extreme(v, [0, 1, 0])),
    ], 0.04)
    v = read(MESHES + "cheburashka.off")  # y up, ears along ±x
    mid = v[:, 0].mean()
    sets["cheburashka"] = (v, [
        ("right ear", extreme(v, [1, 0, 0])),
        ("left ear", extreme(v, [-1, 0, 0])),
        ("left foot", extreme(v, [0, -1, 0], v[:, 0] < mid)),
        ("right foot", extreme(v, [0, -1, 0], v[:, 0] > mid)),
    ], 0.04)
    v = read(MESHES + "bunny.off")  # y up, ears up and back
    tip = extreme(v, [0, 1, 0])
    far = np.linalg.norm(v - tip, axis=1) > 0.15 * np.linalg.norm(v.max(0) - v.min(0))
    lowy = v[:, 1] < np.quantile(v[:, 1], 0.03)
    sets["bunny"] = (v, [
        ("ear", tip),
        ("other ear", extreme(v, [0, 1, -1], far & (v[:, 1] > np.quantile(v[:, 1], 0.8)))),
        ("front feet", extreme(v, [1, -0.2, 0], lowy)),
        ("hind feet", extreme(v, [-1, -0.2, 0], lowy)),
    ], 0.04)
    v = read(MESHES + "dragon.obj")  # y up, base at y = 0
    lowy = v[:, 1] < np.quantile(v[:, 1], 0.03)
    sets["dragon"] = (v, [
        ("head", extreme(v, [0, 1, 0])),
        ("left wing", extreme(v, [-1, 0, 0])),
        ("right wing", extreme(v, [1, 0, 0])),
        ("front foot", extreme(v, [0, -0.2, -1], lowy)),
        ("tail", extreme(v, [0, -0.2, 1], lowy)),
    ], 0.03)
    # Held-out sets (`-b`): different regions, radii and moving group.
    v = read(MESHES + "armadillo.obj")
    lowy = v[:, 1] < np.quantile(v[:, 1], 0.05)
    sets["armadillo-b"] = (v, [
        ("head", extreme(v, [0, 1, 0.3])),
        ("right foot", extreme(v, [0.3, -1, 0], lowy & (v[:, 0] > 0))),
        ("left foot", extreme(v, [-0.3, -1, 0], lowy & (v[:, 0] < 0))),
        ("tail end", extreme(v, [0, -0.3, -1])),
    ], 0.05)
    v = read(MESHES + "cheburashka.off")
    mid = v[:, 0].mean()
    sets["cheburashka-b"] = (v, [
        ("left foot", extreme(v, [0, -1, 0], v[:, 0] < mid)),
        ("right foot", extreme(v, [0, -1, 0], v[:, 0] > mid)),
        ("top of the head", extreme(v, [0, 1, 0])),
    ], 0.05)
    v = read(MESHES + "bunny.off")
    lowy = v[:, 1] < np.quantile(v[:, 1], 0.03)
    sets["bunny-b"] = (v, [
        ("front feet", extreme(v, [1, -0.2, 0], lowy)),
        ("tail", extreme(v, [-1, 0, 0])),
        ("nose", extreme(v, [1, 0.3, 0])),
    ], 0.03)
    # Held-out sets (`-c`), written for the base smoothing of smooth rotations (BENCHMARKS.md,
    # "One pose at every resolution") after it was compared on the others: another moving
    # group and radius again, and a set for the dragon.
    v = read(MESHES + "armadillo.obj")
    lowy = v[:, 1] < np.quantile(v[:, 1], 0.05)
    sets["armadillo-c"] = (v, [
        ("left hand", extreme(v, [-1, 0, 0])),
        ("right foot", extreme(v, [0.3, -1, 0], lowy & (v[:, 0] > 0))),
        ("left foot", extreme(v, [-0.3, -1, 0], lowy & (v[:, 0] < 0))),
    ], 0.035)
    v = read(MESHES + "cheburashka.off")
    mid = v[:, 0].mean()
    sets["cheburashka-c"] = (v, [
        ("left ear", extreme(v, [-1, 0, 0])),
        ("left foot", extreme(v, [0, -1, 0], v[:, 0] < mid)),
        ("right foot", extreme(v, [0, -1, 0], v[:, 0] > mid)),
    ], 0.035)
    v = read(MESHES + "bunny.off")
    tip = extreme(v, [0, 1, 0])
    far = np.linalg.norm(v - tip, axis=1) > 0.15 * np.linalg.norm(v.max(0) - v.min(0))
    lowy = v[:, 1] < np.quantile(v[:, 1], 0.03)
    sets["bunny-c"] = (v, [
        ("other ear", extreme(v, [0, 1, -1], far & (v[:, 1] > np.quantile(v[:, 1], 0.8)))),
        ("front feet", extreme(v, [1, -0.2, 0], lowy)),
        ("hind feet", extreme(v, [-1, -0.2, 0], lowy)),
    ], 0.035)
    v = read(MESHES + "dragon.obj")
    lowy = v[:, 1] < np.quantile(v[:, 1], 0.03)
    sets["dragon-c"] = (v, [
        ("tail", extreme(v, [0, -0.2, 1], lowy)),
        ("head", extreme(v, [0, 1, 0])),
        ("front foot", extreme(v, [0, -0.2, -1], lowy)),
    ], 0.04)
    for name, (v, regions, r) in sets.items():
        print(name, file=sys.stderr)
        with open(f"bench/handles/{name}.json", "w") as f:
            json.dump(spheres(v, regions, r), f)
            f.write("\n")


if __name__ == "__main__":
    main()
