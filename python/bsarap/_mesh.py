"""Meshes and selections: :func:`load_mesh`, :func:`clean`, :func:`save_mesh`,
:func:`load_selection`, and :func:`rotation` for the handles' transforms."""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from . import _bsarap
from ._common import PathLike, _indices, _items, _number, _path, _positions


def load_mesh(path: PathLike, *, with_report: bool = False):
    """Load and clean a mesh file.

    Reads every format the ``bsarap`` CLI reads (OBJ, OFF, PLY, STL, glTF ``.glb``/``.gltf``),
    then cleans it as the CLI does (welds duplicated vertices, drops degenerate, duplicated and
    unreferenced elements; the vertex order is the file's when nothing is removed).

    Returns ``(V, F)``: ``V`` ``(#V, 3)`` float64, ``F`` ``(#F, 3)`` int64; with
    ``with_report=True``, ``(V, F, report)`` where ``report`` is the dict of :func:`clean` plus
    the reader's notices. Raises :class:`BsarapError` naming the file and line.
    """
    v, f, report = _bsarap.load_mesh(_path(path))
    return (v, f, report) if with_report else (v, f)


def clean(V: Any, F: Any):
    """Clean raw arrays as the loader does: ``(V, F, report)``.

    ``report`` holds the counts (``vertices_in/out``, ``faces_in/out``, ``vertices_welded``,
    ``unreferenced_removed``, ``degenerate_faces_removed``, ``duplicate_faces_removed``,
    ``components``, ``boundary_edges``, ``non_manifold_edges``), ``changed``, ``vertex_map``
    (int64, input vertex -> output vertex, -1 when removed) and ``notices`` (sentences).
    """
    return _bsarap.clean(_positions(V, "V"), _indices(F, "F", 2))


def save_mesh(path: PathLike, V: Any, F: Any) -> None:
    """Write ``V``, ``F`` as ``.obj``, ``.off`` or ``.ply`` (by extension), atomically."""
    _bsarap.save_mesh(_path(path), _positions(V, "V"), _indices(F, "F", 2))


def load_selection(path: PathLike, V: Any, *, vertex_map: Any = None) -> np.ndarray:
    """Read a handle selection for a mesh with rest positions ``V``.

    ``path``: a libigl ``.dmat`` (one value per vertex: -1 free, k >= 0 group k) or a JSON list
    of spheres ``[{"group": 0, "center": [x, y, z], "radius": r}]``. Returns the per-vertex
    labels, int64. ``np.nonzero(labels >= 0)[0]`` is libigl's ``b``. ``vertex_map``: the
    cleaning's map of a mesh read with :func:`load_mesh` (``report["vertex_map"]``): a
    ``.dmat`` written for the file's vertices (before welding and removal) is carried to ``V``
    through it, as ``bsarap deform MESH --handles SEL`` does.
    """
    m = None if vertex_map is None else _indices(vertex_map, "vertex_map", 1)
    return _bsarap.load_selection(_path(path), _positions(V, "V"), m)


def rotation(axis: npt.ArrayLike, degrees: float) -> np.ndarray:
    """The 3x3 rotation by ``degrees`` about ``axis`` (3 numbers, a sequence or array; as the
    CLI's ``--rotate G:ax,ay,az,deg``)."""
    axis = [_number(c, "axis") for c in _items(axis, "axis", "a sequence of 3 numbers")]
    return np.array(_bsarap.rotation(axis, _number(degrees, "degrees")))
