"""The review's findings: statistics never stale after a failed solve, non-sequences refused
with a BsarapError, the label limit documented, integral float labels taken, the libigl drop-in
(defaults, no dim argument), the rotation tolerance named, and the stub's types."""
import ast
import inspect
from pathlib import Path

import numpy as np
import pytest

import bsarap
from bsarap import BsarapError
from conftest import REPO, tube

PKG = Path(bsarap.__file__).parent


class _Interrupting:
    """A native half whose `solve*` finishes, then raises KeyboardInterrupt (Ctrl-C seen as the
    call returns: the pose changed, the statistics never arrive)."""

    def __init__(self, native):
        self._native = native

    def __getattr__(self, name):
        method = getattr(self._native, name)

        def call(*args):
            method(*args)
            raise KeyboardInterrupt

        return call


def test_stats_cleared_when_a_solve_fails():
    V, F, labels = tube()
    d = bsarap.Deformer(V, F, labels, method="arap")
    d.solve_to_rest({1: (0, 0, 0.5)})
    assert d.at_rest is not None
    # A refused solve leaves no statistics of an older one (nor solve_to_rest's at_rest).
    with pytest.raises(BsarapError):
        d.solve({1: ((0, 0, 0), 2 * np.eye(3))})
    assert d.stats is None and d.at_rest is None
    d.solve({1: (0, 0, 0.5)})
    with pytest.raises(BsarapError):
        d.solve_targets(np.zeros((2, 3)))
    assert d.stats is None
    d.solve_to_rest({1: (0, 0, 0.5)})
    with pytest.raises(BsarapError):
        d.solve_to_rest({7: (0, 0, 0.5)})
    assert d.stats is None and d.at_rest is None
    # Ctrl-C seen after the pose changed: no statistics of the solve before.
    native = d._native
    for solve in [lambda: d.solve({1: (0, 0, 1.0)}), lambda: d.solve_targets(V[labels >= 0])]:
        d._native = native
        d.solve({1: (0, 0, 0.5)})
        d._native = _Interrupting(native)
        with pytest.raises(KeyboardInterrupt):
            solve()
        assert d.stats is None
    d._native = native

    b = np.nonzero(labels >= 0)[0]
    s = bsarap.Arap(V, F, b)
    s.solve(V[b])
    with pytest.raises(BsarapError, match="rows but b has"):
        s.solve(V[b[:-1]])
    assert s.stats is None
    s.solve(V[b])
    native, s._native = s._native, _Interrupting(s._native)
    try:
        with pytest.raises(KeyboardInterrupt):
            s.solve(V[b] + 0.1)
        assert s.stats is None
    finally:
        s._native = native


def test_non_sequences_refused_naming_the_argument():
    V, F, labels = tube()
    for pinned in [5, None, "0"]:
        with pytest.raises(BsarapError, match="pinned_components must be a sequence"):
            bsarap.Deformer(V, F, labels, pinned_components=pinned)
    assert bsarap.Deformer(V, F, labels, pinned_components=np.array([], dtype=int)).groups == [0, 1]
    for axis in [5, None, np.float64(1.0)]:
        with pytest.raises(BsarapError, match="axis must be a sequence of 3 numbers"):
            bsarap.rotation(axis, 30)
    np.testing.assert_allclose(bsarap.rotation(np.array([0.0, 0.0, 2.0]), 90), bsarap.rotation([0, 0, 1], 90))


def test_label_limit_documented():
    V, F, labels = tube()
    with pytest.raises(BsarapError, match="invalid"):
        bsarap.Deformer(V, F, np.where(labels == 1, len(V) + 1024, labels))
    bsarap.Deformer(V, F, np.where(labels == 1, len(V) + 1023, labels))
    assert "0 <= k < #V + 1024" in inspect.getdoc(bsarap.Deformer)
    stub = ast.parse((PKG / "__init__.pyi").read_text())
    deformer = next(n for n in stub.body if isinstance(n, ast.ClassDef) and n.name == "Deformer")
    assert "#V + 1024" in ast.get_docstring(deformer)


def test_integral_float_labels_taken():
    V, F, labels = tube()
    d = bsarap.Deformer(V, F, labels.astype(np.float64)[:, None], method="arap")
    assert d.labels.dtype == np.int64 and np.array_equal(d.labels, labels)
    b = np.nonzero(labels >= 0)[0]
    s = bsarap.Arap(V, F, b.astype(np.float64))
    assert s.b.dtype == np.int64 and np.array_equal(s.b, b)
    for bad, value in [(0.5, r"0\.5"), (np.nan, "nan"), (np.inf, "inf"), (2.0**63, "9.2")]:
        with pytest.raises(BsarapError, match=f"handles must hold integers; got {value}.* at index 3"):
            bsarap.Deformer(V, F, np.where(np.arange(len(V)) == 3, bad, labels))
        with pytest.raises(BsarapError, match=f"b must hold integers; got {value}"):
            bsarap.Arap(V, F, np.append(b.astype(np.float64), bad))


def test_libigl_drop_in():
    V, F, labels = tube()
    b = np.nonzero(labels >= 0)[0]
    for dim in [3, np.int64(3), np.array(3)]:
        with pytest.raises(BsarapError, match="b must be a 1-d array.*no dim argument"):
            bsarap.Arap(V, F, dim)
        with pytest.raises(BsarapError, match="energy must be a str.*no dim argument"):
            bsarap.Arap(V, F, dim, b)
    with pytest.raises(BsarapError, match="handles must be a 1-d array"):
        bsarap.Deformer(V, F, 3)
    line = next(x for x in (REPO / "README.md").read_text().splitlines() if "igl.arap_solve(bc" in x)
    assert "max_iters=10, tol=0" in line
    s = bsarap.Arap(V, F, b)
    s.solve(V[b] + [0, 0, 0.5], V, max_iters=10, tol=0)
    assert s.stats.iterations == 10


def test_rotation_tolerance_named():
    V, F, labels = tube()
    d = bsarap.Deformer(V, F, labels, method="arap")
    with pytest.raises(BsarapError, match=r"orthonormal within 1e-6.*: an entry of RᵀR is 3\.0e0 from"):
        d.solve({1: ((0, 0, 0), 2 * np.eye(3))})
    with pytest.raises(BsarapError, match=r"determinant is -1\.000"):
        d.solve({1: ((0, 0, 0), -np.eye(3))})
    with pytest.raises(BsarapError, match="non-finite entry"):
        d.solve({1: ((0, 0, 0), np.full((3, 3), np.nan))})
    d.solve({1: ((0, 0, 0), np.eye(3) + 4e-7 * np.eye(3)[::-1])})
    assert "1e-6" in inspect.getdoc(bsarap.Deformer.solve)
    stub = (PKG / "__init__.pyi").read_text()
    assert "within 1e-6" in stub


def test_stub_types():
    stub = ast.parse((PKG / "__init__.pyi").read_text())
    assert "Sequence[float]" not in ast.unparse(stub)
    functions = [n for n in stub.body if isinstance(n, ast.FunctionDef)]
    rotation = next(n for n in functions if n.name == "rotation")
    assert ast.unparse(rotation.args.args[0].annotation) == "ArrayLike"
    transform = next(n for n in stub.body if isinstance(n, ast.Assign) and n.targets[0].id == "Transform")
    assert ast.unparse(transform.value).startswith("Union[ArrayLike,")
    load_mesh = [ast.unparse(n.args.kwonlyargs[0].annotation) for n in functions if n.name == "load_mesh"]
    assert load_mesh == ["Literal[False]", "Literal[True]", "bool"]
