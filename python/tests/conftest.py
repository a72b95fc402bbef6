"""Shared fixtures: the paper's meshes (../shared/meshes beside the repository, skipped with a
note when absent), a small procedural tube, and the repository's own assets."""
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


@pytest.fixture
def small():
    return tube()


@pytest.fixture
def repo():
    return REPO
