"""Every error path raises bsarap.BsarapError (a ValueError) with the solver's message; none
crashes the interpreter."""
import numpy as np
import pytest

import bsarap
from bsarap import BsarapError
from conftest import tube


def test_error_type():
    assert issubclass(BsarapError, ValueError)


def test_load_errors(tmp_path):
    with pytest.raises(BsarapError, match="cannot open"):
        bsarap.load_mesh(tmp_path / "missing.obj")
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nf 1 2 7\n")
    with pytest.raises(BsarapError, match="bad.obj"):
        bsarap.load_mesh(bad)
    (tmp_path / "x.xyz").write_text("1 2 3\n")
    with pytest.raises(BsarapError, match="xyz"):
        bsarap.load_mesh(tmp_path / "x.xyz")
    with pytest.raises(BsarapError, match="directory"):
        bsarap.load_mesh(tmp_path)
    empty = tmp_path / "empty.off"
    empty.write_text("")
    with pytest.raises(BsarapError, match="empty"):
        bsarap.load_mesh(empty)


def test_array_errors():
    V, F, labels = tube()
    b = np.nonzero(labels >= 0)[0]
    cases = [
        (lambda: bsarap.clean(V[:, :2], F), "shape"),
        (lambda: bsarap.clean(V, F[:, :2]), "shape"),
        (lambda: bsarap.clean(V, F.astype(float)), "integers"),
        (lambda: bsarap.clean(np.where(np.arange(len(V))[:, None] == 3, np.nan, V), F), "non-finite"),
        (lambda: bsarap.clean(V, F + len(V)), "refers to vertex"),
        (lambda: bsarap.clean(V, -F), "refers to vertex"),
        (lambda: bsarap.clean(V, np.zeros((0, 3), dtype=np.int64)), "no usable triangle"),
        (lambda: bsarap.clean([["a", "b", "c"]], F), "numbers"),
        (lambda: bsarap.Arap(V, F, []), "b is empty"),
        (lambda: bsarap.Arap(V, F, [0, 0]), "twice"),
        (lambda: bsarap.Arap(V, F, [len(V)]), "not a vertex index"),
        (lambda: bsarap.Arap(V, F, [-1]), "not a vertex index"),
        (lambda: bsarap.Arap(V, F, [[0, 1], [2, 3]]), "1-d"),
        (lambda: bsarap.Arap(V, F, [0.5]), "integers"),
        (lambda: bsarap.Arap(V, F, b, energy="elements"), "energy"),
        (lambda: bsarap.Arap(V, F, b, tol=-1), "tol"),
        (lambda: bsarap.Arap(V, F, b, tol=float("nan")), "tol"),
        (lambda: bsarap.Arap(V, F, b, max_iters=0), "max_iters"),
        (lambda: bsarap.Arap(V, F, b, max_iters=-3), "max_iters"),
        (lambda: bsarap.Arap(V, F, b, anderson=65), "anderson"),
        (lambda: bsarap.Arap(V, np.array([[0, 0, 1]]), [0]), "repeats a vertex"),
        (lambda: bsarap.Arap(np.zeros((3, 3)), np.array([[0, 1, 2]]), [0]), "degenerate"),
    ]
    for call, match in cases:
        with pytest.raises(BsarapError, match=match):
            call()


def test_solve_errors():
    V, F, labels = tube()
    b = np.nonzero(labels >= 0)[0]
    s = bsarap.Arap(V, F, b)
    with pytest.raises(BsarapError, match="rows but b has"):
        s.solve(V[b[:-1]])
    with pytest.raises(BsarapError, match="non-finite"):
        s.solve(np.full((len(b), 3), np.inf))
    with pytest.raises(BsarapError, match="U0 has"):
        s.solve(V[b], V[:-1])
    with pytest.raises(BsarapError, match="non-finite"):
        s.solve(V[b], np.full_like(V, np.nan))
    # Finite, but beyond what the f32 views and the export hold: refused, the limit named.
    with pytest.raises(BsarapError, match=r"out-of-range coordinate \(2e30; the limit is ±1e30\)"):
        s.solve(V[b] + 2e30)
    with pytest.raises(BsarapError, match="out-of-range"):
        bsarap.Arap(V * 1e31, F, b)
    with pytest.raises(BsarapError, match="max_iters"):
        s.solve(V[b], max_iters=0)
    with pytest.raises(BsarapError, match="U has"):
        s.energy(V[:3])


def test_deformer_errors():
    V, F, labels = tube()
    cases = [
        (lambda: bsarap.Deformer(V, F, labels, method="lbs"), "method must be one of"),
        (lambda: bsarap.Deformer(V, F, labels[:-1]), "labels but the mesh has"),
        (lambda: bsarap.Deformer(V, F, np.full(len(V), -1)), "empty"),
        (lambda: bsarap.Deformer(V, F, np.full(len(V), -7)), "invalid"),
        (lambda: bsarap.Deformer(V, F, labels, smoothing=0), "smoothing"),
        (lambda: bsarap.Deformer(V, F, labels, coarse_vertices=3), "coarse_vertices"),
        (lambda: bsarap.Deformer(V, F, labels, fine_iterations=10**6), "fine_iterations"),
        (lambda: bsarap.Deformer(V, F, labels, settle_iterations=10**6), "settle_iterations"),
        (lambda: bsarap.Deformer(V, F, labels, membrane=-0.1), r"membrane must be in \[0, 1\]"),
        (lambda: bsarap.Deformer(V, F, labels, membrane=1.5), r"membrane must be in \[0, 1\]"),
        (lambda: bsarap.Deformer(V, F, labels, membrane=float("nan")), r"membrane .*NaN"),
        (lambda: bsarap.Deformer(V, F, labels, pinned_components=[4]), "components"),
        (lambda: bsarap.Deformer(V, F, "missing.dmat"), "missing.dmat"),
        (lambda: bsarap.Deformer(V, F, "handles.txt"), "txt"),
    ]
    for call, match in cases:
        with pytest.raises(BsarapError, match=match):
            call()
    d = bsarap.Deformer(V, F, labels, method="arap")
    with pytest.raises(BsarapError, match="nothing was solved"):
        d.settle()
    for transforms, match in [
        ({5: (0, 0, 0)}, "group 5 does not exist"),
        ({-1: (0, 0, 0)}, "non-negative"),
        ({1: (0, 0)}, "3 components"),
        ({1: (0, 0, np.nan)}, "not finite"),
        ({1: ((0, 0, 0), np.eye(2))}, "3x3"),
        ({1: ((0, 0, 0), 2 * np.eye(3))}, "proper"),
        ({1: ((0, 0, 0), -np.eye(3))}, "proper"),
        ({1: {"move": (0, 0, 0)}}, "unknown keys"),
        ([(1, (0, 0, 0))], "dict"),
    ]:
        with pytest.raises(BsarapError, match=match):
            d.solve(transforms)
    with pytest.raises(BsarapError, match="targets were given"):
        d.solve_targets(np.zeros((2, 3)))
    with pytest.raises(BsarapError, match="axis"):
        bsarap.rotation([0, 0, 0], 10)
    with pytest.raises(BsarapError, match="max_iters"):
        d.set_stopping(1e-4, 0)


def test_animation_errors(tmp_path):
    V, F, labels = tube()
    with pytest.raises(BsarapError, match="missing.json"):
        bsarap.load_scene(tmp_path / "missing.json")
    (tmp_path / "s.json").write_text('{"mesh": "x.obj"}')
    with pytest.raises(BsarapError, match="version"):
        bsarap.load_scene(tmp_path / "s.json")
    bsarap.save_mesh(tmp_path / "tube.off", V, F)
    (tmp_path / "m.json").write_text(
        '{"version": 1, "mesh": "tube.off", "handles": {"labels": %s}, "timeline": {"duration": 1, '
        '"fps": 2}, "base": {"membrane": 1.5}}' % labels.tolist())
    with pytest.raises(BsarapError, match="membrane must be in"):
        bsarap.load_scene(tmp_path / "m.json")
    with pytest.raises(BsarapError):
        bsarap.Timeline.from_json('{"duration": -1, "fps": 10}')
    with pytest.raises(BsarapError):
        bsarap.Timeline.from_json("not json")
    tl = bsarap.Timeline.from_json('{"duration": 1, "fps": 2, "paths": [{"group": 9, "path": {"type": "static"}}]}')
    d = bsarap.Deformer(V, F, labels, method="arap")
    with pytest.raises(BsarapError, match="group 9"):
        bsarap.record(d, tl)
    with pytest.raises(BsarapError, match="n_frames"):
        bsarap.record(d, tl, n_frames=0)
    with pytest.raises(BsarapError, match="Deformer"):
        bsarap.record("d", tl)
    ok = bsarap.Timeline.from_json('{"duration": 1, "fps": 2}')
    rec = bsarap.record(d, ok)
    with pytest.raises(BsarapError, match="every"):
        bsarap.export_gltf(tmp_path / "a.glb", rec, every=0)
    with pytest.raises(BsarapError, match="glb"):
        bsarap.export_gltf(tmp_path / "a.fbx", rec)
    with pytest.raises(BsarapError, match="Recording"):
        bsarap.export_gltf(tmp_path / "a.glb", None)
    with pytest.raises(BsarapError, match="unsupported output"):
        bsarap.save_mesh(tmp_path / "a.stl", V, F)
