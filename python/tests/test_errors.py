"""Every error path raises bsarap.BsarapError (a ValueError) with the solver's message; none
crashes the interpreter."""
import warnings

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
    with pytest.raises(BsarapError, match="axis needs 3 numbers, got 2"):
        bsarap.rotation([1, 0], 30)
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


def test_audit_findings():
    """Bad input found by an audit: each once crashed, hung, poisoned the solver or was taken
    silently."""
    V, F, labels = tube()
    tl = bsarap.Timeline.from_json('{"duration": 1, "fps": 2}')
    # frame_times asked for 2**36 frames aborted the interpreter on the allocation.
    with pytest.raises(BsarapError, match="at most 100000"):
        tl.frame_times(2**36)
    assert len(tl.frame_times(100000)) == 100000
    # A translation beyond the solver's range was solved, and its pose poisoned every later solve.
    d = bsarap.Deformer(V, F, labels, method="arap")
    with pytest.raises(BsarapError, match="group 1's move 1e200 .* coordinate limit"):
        d.solve({1: (1e200, 0, 0)})
    with pytest.raises(BsarapError, match="group 1's move 1e31 .* coordinate limit"):
        d.targets({1: (1e31, 0, 0)})
    assert np.isfinite(d.solve({1: (0.3, 0, 0)})).all()
    # Pinning a component that has handles did nothing, silently.
    with pytest.raises(BsarapError, match="has handles"):
        bsarap.Deformer(V, F, labels, pinned_components=[0])
    # Strings and other non-numbers were taken by float(); "no" was True.
    with pytest.raises(BsarapError, match="tol must be a number"):
        bsarap.Deformer(V, F, labels, method="arap", tol="1e-3")
    with pytest.raises(BsarapError, match="membrane must be a number"):
        bsarap.Deformer(V, F, labels, membrane="0.1")
    with pytest.raises(BsarapError, match="tol must be a number"):
        bsarap.Arap(V, F, np.nonzero(labels >= 0)[0], tol="1e-3")
    # A very long or very short axis overflowed or underflowed to a non-rotation.
    for axis in ([1e160, 0, 0], [1e308, 1e308, 0], [1e-170, 0, 0]):
        R = bsarap.rotation(axis, 90)
        assert np.allclose(R @ R.T, np.eye(3)) and np.isclose(np.linalg.det(R), 1.0), axis
        assert np.isclose(np.trace(R), 1.0), axis  # 90°: 1 + 2 cos 90°
    assert np.allclose(bsarap.rotation([1e-170, 0, 0], 90) @ [0, 1, 0], [0, 0, 1])
    # A keyframe turning about a zero axis was taken as no turn.
    bad = ('{"duration": 1, "fps": 4, "paths": [{"group": 1, "path": {"type": "keyframed", '
           '"interpolation": "linear", "keys": [{"time": 0}, {"time": 1, "rotation": '
           '{"axis": [0, 0, 0], "degrees": 90}}]}}]}')
    with pytest.raises(BsarapError, match="zero axis"):
        bsarap.Timeline.from_json(bad)


def test_python_values_at_the_edges(tmp_path):
    """Values Python allows and the native layer cannot take: bytes paths are paths, complex
    arrays, ints past 64 bits and floats past float's range get a BsarapError (each was a
    TypeError, a ComplexWarning with the imaginary part dropped, or an OverflowError)."""
    V, F, labels = tube()
    # bytes paths are accepted wherever str paths are (os.fsdecode).
    out = tmp_path / "tube.off"
    bsarap.save_mesh(bytes(out), V, F)
    V2, F2 = bsarap.load_mesh(bytes(out))
    assert V2.shape == V.shape and F2.shape == F.shape
    np.savetxt(tmp_path / "labels.dmat", labels, fmt="%d", header=f"1 {len(labels)}", comments="")
    assert (bsarap.load_selection(bytes(tmp_path / "labels.dmat"), V) == labels).all()
    bsarap.Deformer(V, F, bytes(tmp_path / "labels.dmat"), method="arap")
    with pytest.raises(BsarapError, match="missing.json"):
        bsarap.load_scene(bytes(tmp_path / "missing.json"))
    with pytest.raises(BsarapError, match="path must be a str, bytes or os.PathLike"):
        bsarap.load_mesh(3)
    d = bsarap.Deformer(V, F, labels, method="arap")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no ComplexWarning: refused before numpy casts
        for call in (
            lambda: bsarap.clean(V.astype(complex), F),
            lambda: bsarap.Deformer(V + 0j, F, labels),
            lambda: bsarap.Arap(V.tolist()[:-1] + [[0, 0, 1j]], F, [0]),
            lambda: d.solve({1: (0, 0, 1 + 0j)}),
            lambda: d.solve({1: ((0, 0, 0), np.eye(3, dtype=complex))}),
        ):
            with pytest.raises(BsarapError, match="real numbers; got complex"):
                call()
    for call, match in [
        (lambda: bsarap.Deformer(V, F, labels, max_iters=2**70), "max_iters is too large"),
        (lambda: bsarap.Deformer(V, F, labels, coarse_vertices=2**64), "coarse_vertices is too"),
        (lambda: bsarap.Deformer(V, F, labels, tol=10**400), "tol is too large to be a float"),
        (lambda: d.solve({1: (0, 0, 10**400)}), "translation must be an array of numbers"),
        (lambda: bsarap.clean(V.tolist()[:-1] + [[0, 0, 10**400]], F), "V must be an array of"),
        (lambda: bsarap.clean(V.tolist()[:-1] + [[0, 0]], F), "V must be an array of numbers"),
        (lambda: d.solve({1: ((0, 0, 0), [[1, 0, 0], [0, 1], [0, 0, 1]])}), "rotation must be an"),
        (lambda: bsarap.Arap(V, F, [0], anderson=2**63), "anderson is too large"),
        (lambda: d.solve({2**70: (0, 0, 0)}), "group ids is too large"),
        (lambda: d.solve_to_rest({1: (0, 0, 0)}, max_steps=2**80), "max_steps is too large"),
        (lambda: bsarap.rotation([1, 0, 0], 10**400), "degrees is too large"),
        (lambda: bsarap.Timeline.from_json('{"duration": 1, "fps": 2}').frame_times(2**70), "n is"),
    ]:
        with pytest.raises(BsarapError, match=match):
            call()
    # The edge itself is taken: a cap of 2**63 - 1 steps is no cap.
    d.solve_to_rest({1: (0.1, 0, 0)}, max_steps=2**63 - 1)
    assert d.at_rest.converged


def test_settle_after_record_ends(tmp_path):
    """After record, settle() refines the last frame and settle_pending ends (it stayed true
    while settle() did nothing: an endless loop)."""
    V, F, labels = tube()
    d = bsarap.Deformer(V, F, labels, settle_iterations=5)
    tl = bsarap.Timeline.from_json(
        '{"duration": 1, "fps": 4, "paths": [{"group": 1, "path": {"type": "keyframed", '
        '"interpolation": "linear", "keys": [{"time": 0, "translation": [0, 0, 0]}, '
        '{"time": 1, "translation": [0.3, 0, 0]}]}}]}'
    )
    rec = bsarap.record(d, tl)
    steps = 0
    while d.settle_pending and steps < 1000:
        d.settle()
        steps += 1
    assert not d.settle_pending and steps < 1000, steps
    assert np.abs(d.positions - rec.frames[-1]).max() < 0.05


def test_record_refused_up_front_keeps_the_deformer():
    """A timeline record() refuses before solving (a group the deformer lacks) leaves the
    deformer as it was: its pose, and the settling it had pending, which settle() carries out
    (it said "nothing was solved yet" while settle_pending stayed true)."""
    V, F, labels = tube()
    d = bsarap.Deformer(V, F, labels, settle_iterations=5)
    posed = d.solve({1: (0, 0, 0.3)})
    assert d.settle_pending
    tl = bsarap.Timeline.from_json(
        '{"duration": 1, "fps": 2, "paths": [{"group": 7, "path": {"type": "static"}}]}')
    with pytest.raises(BsarapError, match="group"):
        bsarap.record(d, tl, 2)
    np.testing.assert_array_equal(d.positions, posed)
    steps = 0
    while d.settle_pending and steps < 1000:
        d.settle()
        steps += 1
    assert steps > 0 and not d.settle_pending, steps


def test_unreferenced_vertex_every_method():
    """A vertex that no triangle uses (an uncleaned mesh) is a loose point for every method:
    bsarap-coarse refused the mesh ("pivot N is not positive")."""
    V, F, labels = tube()
    V1 = np.r_[V, [[0.0, 0.0, 2.0]]]
    L1 = np.r_[labels, -1]
    for method in bsarap.METHODS:
        for pinned in ([], [1]):
            d = bsarap.Deformer(V1, F, L1, method=method, pinned_components=pinned)
            U = d.solve({1: (0.3, 0, 0)})
            assert np.isfinite(U).all(), method
            if pinned:
                assert np.array_equal(U[-1], V1[-1]), method
