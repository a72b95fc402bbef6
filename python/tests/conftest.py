"""Shared fixtures: the paper's meshes (../shared/meshes beside the repository, skipped with a
note when absent), a small procedural tube, a subdivided sphere big enough for long solves, and
the repository's own assets."""
import os
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
MESHES = Path(os.environ.get("BSARAP_MESHES", REPO.parent / "shared" / "meshes"))

#: The paper's meshes with libigl's handle selections.
PAPER = {
    "knight": ("decimated-knight.off", "decimated-knight-selection.dmat"),
    "decimated-max": ("decimated-max.obj", "decimated-max-selection.dmat"),
}


def paper_mesh(name):
    """(mesh path, selection path) of a paper mesh, or a skip naming what is missing."""
    mesh, sel = PAPER[name]
    paths = MESHES / mesh, MESHES / sel
    missing = [str(p) for p in paths if not p.exists()]
    if missing:
        pytest.skip(f"skipped: the paper's meshes are not here ({', '.join(missing)})")
    return paths


def tube(nu=12, nv=10, radius=1.0, height=4.0):
    """A closed-ring open cylinder: (V, F, labels) with the bottom ring group 0 and the top
    ring group 1."""
    theta = 2 * np.pi * np.arange(nu) / nu
    z = np.linspace(0.0, height, nv)
    V = np.array([[radius * np.cos(t), radius * np.sin(t), h] for h in z for t in theta])
    F = []
    for j in range(nv - 1):
        for i in range(nu):
            a, b = j * nu + i, j * nu + (i + 1) % nu
            c, d = a + nu, b + nu
            F += [[a, b, d], [a, d, c]]
    labels = np.full(len(V), -1, dtype=np.int64)
    labels[:nu] = 0
    labels[-nu:] = 1
    return V, np.array(F, dtype=np.int64), labels


def sphere(level):
    """A unit icosphere subdivided `level` times (10·4^level + 2 vertices): (V, F, labels) with
    the cap z < -0.8 group 0 and the cap z > 0.8 group 1."""
    t = (1 + 5 ** 0.5) / 2
    V = [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t],
         [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]]
    F = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
         [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
         [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]]
    V = [np.array(v, dtype=float) / np.linalg.norm(v) for v in V]
    for _ in range(level):
        midpoints, finer = {}, []

        def midpoint(a, b):
            key = (min(a, b), max(a, b))
            if key not in midpoints:
                p = V[a] + V[b]
                V.append(p / np.linalg.norm(p))
                midpoints[key] = len(V) - 1
            return midpoints[key]

        for a, b, c in F:
            ab, bc, ca = midpoint(a, b), midpoint(b, c), midpoint(c, a)
            finer += [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
        F = finer
    V = np.array(V)
    labels = np.full(len(V), -1, dtype=np.int64)
    labels[V[:, 2] < -0.8] = 0
    labels[V[:, 2] > 0.8] = 1
    return V, np.array(F, dtype=np.int64), labels


@pytest.fixture
def small():
    return tube()


@pytest.fixture
def repo():
    return REPO
