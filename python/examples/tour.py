# %% [markdown]
# # A tour of `bsarap` from Python
#
# Notebook-style (`# %%` cells: run it as a script, or open it in VS Code / Jupytext as a
# notebook). From the repository root, after `pip install ./python`:
#
#     python python/examples/tour.py
#
# It uses the repository's default asset (`assets/creature.obj`, 30k vertices, six handle
# groups), compares the methods on one pose, animates a scene and writes glTF into
# `tour-output/`.

# %%
import time
from pathlib import Path

import numpy as np

import bsarap

ROOT = Path(__file__).resolve().parents[2]
OUT = Path("tour-output")
OUT.mkdir(exist_ok=True)

V, F, report = bsarap.load_mesh(ROOT / "assets" / "creature.obj", with_report=True)
print(f"{len(V)} vertices, {len(F)} triangles; cleaning: {report['notices'] or 'nothing to do'}")

# %% [markdown]
# ## Handles
# A selection file gives one label per vertex (-1 free, k: group k). Handles can also be
# picked in numpy: here, every vertex within 3 % of the diagonal of the highest point.

# %%
labels = bsarap.load_selection(ROOT / "assets" / "creature.dmat", V)
diag = np.linalg.norm(V.max(0) - V.min(0))
top = V[np.argmax(V[:, 1])]
picked = np.linalg.norm(V - top, axis=1) < 0.03 * diag
print("groups:", {int(g): int((labels == g).sum()) for g in np.unique(labels) if g >= 0},
      f"| picked {picked.sum()} vertices around the top")

# %% [markdown]
# ## libigl-shaped ARAP
# `b` are the fixed vertices, `bc` their positions: `igl.arap_solve(bc, data, U)` becomes
# `bsarap.Arap(V, F, b).solve(bc, U)`.

# %%
b = np.nonzero(labels >= 0)[0]
bc = V[b].copy()
bc[labels[b] == 0] += [0.0, 0.15 * diag, 0.0]
arap = bsarap.Arap(V, F, b, tol=1e-4, max_iters=200)
t = time.perf_counter()
U = arap.solve(bc, V)
s = arap.stats
print(f"ARAP: {s.iterations} iterations in {1e3 * (time.perf_counter() - t):.0f} ms "
      f"({s.ms_per_iteration:.2f} ms each), energy {s.initial_energy:.4g} -> {s.energy:.4g}")
print("energy per iteration (first five):", np.round(s.energies[:5], 6))

# %% [markdown]
# ## Every method of the CLI
# Handle groups move rigidly: `{group: translation}` or `{group: (translation, rotation)}`,
# the rotation about the group's rest centroid (the CLI's `--move` / `--rotate`).

# %%
pose = {0: ([0.0, 0.15 * diag, 0.0], bsarap.rotation([0, 0, 1], 30))}
results = {}
for method in bsarap.METHODS:
    t = time.perf_counter()
    d = bsarap.Deformer(V, F, labels, method=method)
    pre = time.perf_counter() - t
    t = time.perf_counter()
    results[method] = d.solve(pose)
    print(f"{method:>14}: precompute {1e3 * pre:6.0f} ms, solve {1e3 * (time.perf_counter() - t):6.0f} ms, "
          f"{d.stats.iterations:3d} iterations" + ("" if d.base is None else
          f", details up to {np.linalg.norm(d.details, axis=1).max() / diag:.3f} of the diagonal"))
    bsarap.save_mesh(OUT / f"creature-{method}.obj", results[method], F)
for method, U in results.items():
    dist = np.linalg.norm(U - results["arap"], axis=1) / diag
    print(f"{method:>14}: distance to ARAP, max {dist.max():.4f}, mean {dist.mean():.4f} of the diagonal")

# %% [markdown]
# ## Anderson acceleration and settling
# `anderson=5` accelerates the local-global loop; the coarse BS-ARAP with
# `settle_iterations` refines the pose on the full mesh once the handles stop, as the editor
# does after a drag.

# %%
fast = bsarap.Deformer(V, F, labels, method="arap", anderson=5)
fast.solve(pose)
print("ARAP + Anderson:", fast.stats.iterations, "iterations")
coarse = bsarap.Deformer(V, F, labels, method="bsarap-coarse", settle_iterations=10)
coarse.solve_to_rest(pose)  # solve until converged, then settle until done
steps = coarse.at_rest.settle_steps
dist = np.linalg.norm(coarse.positions - results["arap"], axis=1) / diag
print(f"coarse BS-ARAP after {steps} settle steps: mean distance to ARAP {dist.mean():.4f}")

# %% [markdown]
# ## Animation: a scene, a recording, glTF
# A scene file holds the mesh, handles, timeline and method; `record` solves every frame
# (warm-started), `export_gltf` writes morph targets on the asset's own layout.

# %%
scene = bsarap.load_scene(ROOT / "assets" / "creature-circle.json")
timeline = scene.timeline
deformer = scene.deformer()
t = time.perf_counter()
rec = bsarap.record(deformer, timeline, n_frames=16)
print(f"{len(rec)} frames of {scene.method} in {time.perf_counter() - t:.1f} s, "
      f"{rec.total_iterations / len(rec):.1f} iterations per frame")
size = bsarap.export_gltf(OUT / "creature-circle.glb", rec)
print(f"wrote {OUT / 'creature-circle.glb'} ({size / 1e6:.1f} MB)")
