"""bsarap: ARAP and BS-ARAP mesh deformation from numpy.

A thin binding over the Rust ``solver`` crate of the BS-ARAP editor (all numerics live there):

- :func:`load_mesh`, :func:`clean`, :func:`save_mesh`, :func:`load_selection` for meshes and
  handle selections;
- :class:`Arap`, shaped like libigl's ARAP (``arap_precomputation`` + ``arap_solve``): fixed
  vertex indices ``b``, their positions ``bc``;
- :class:`Deformer`, every method of the ``bsarap`` CLI (``arap``, ``bsarap``,
  ``bsarap-faired``, ``bsarap-coarse``; Anderson acceleration, fine and settle iterations)
  posed by per-group rigid transforms;
- :func:`load_scene`, :class:`Timeline`, :func:`record`, :func:`export_gltf` for animation.

Arrays: positions are ``(n, 3)`` float64, triangles ``(m, 3)`` integer. Inputs of another
dtype or layout are converted (no copy when they already are C-contiguous float64 / int64);
outputs are new arrays that own the solver's buffers. Solves release the GIL. Every error is a
:class:`BsarapError` (a ``ValueError``) carrying the solver's message.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _bsarap
from ._bsarap import BsarapError

__all__ = [
    "BsarapError",
    "METHODS",
    "ENERGIES",
    "SolveStats",
    "load_mesh",
    "clean",
    "save_mesh",
    "load_selection",
    "rotation",
    "Arap",
    "Deformer",
    "Scene",
    "Timeline",
    "Recording",
    "load_scene",
    "record",
    "export_gltf",
]

#: The method names of :class:`Deformer` (the CLI's ``--method``).
METHODS: Tuple[str, ...] = tuple(_bsarap.METHODS)
#: The ARAP energies (the CLI's ``--energy``).
ENERGIES: Tuple[str, ...] = ("spokes-and-rims", "spokes")

#: The solver's defaults (``solver::deform::arap::DEFAULT_TOLERANCE`` / ``DEFAULT_MAX_ITERATIONS``).
DEFAULT_TOL = 1e-4
DEFAULT_MAX_ITERS = 100

PathLike = Union[str, "os.PathLike[str]"]


def _positions(a: Any, name: str) -> np.ndarray:
    """``a`` as a C-contiguous ``(n, 3)`` float64 array (no copy when it already is one)."""
    try:
        arr = np.ascontiguousarray(a, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise BsarapError(f"{name} must be an (n, 3) array of numbers: {e}") from None
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise BsarapError(f"{name} must have shape (n, 3); got {arr.shape}")
    return arr


def _indices(a: Any, name: str, ndim: int) -> np.ndarray:
    """``a`` as a C-contiguous int64 array of ``ndim`` dimensions (integer dtypes only)."""
    arr = np.asarray(a)
    if arr.size == 0 and arr.dtype.kind == "f":
        arr = arr.astype(np.int64)
    if arr.dtype.kind not in "iu":
        raise BsarapError(f"{name} must hold integers; got dtype {arr.dtype}")
    if arr.dtype.kind == "u" and arr.size and int(arr.max()) > np.iinfo(np.int64).max:
        raise BsarapError(f"{name}: index out of range")
    arr = np.ascontiguousarray(arr, dtype=np.int64)
    if ndim == 2 and (arr.ndim != 2 or arr.shape[1] != 3):
        raise BsarapError(f"{name} must have shape (m, 3); got {arr.shape}")
    if ndim == 1:
        if arr.ndim == 2 and 1 in arr.shape:
            arr = arr.reshape(-1)
        if arr.ndim != 1:
            raise BsarapError(f"{name} must be a 1-d array; got shape {arr.shape}")
    return arr


@dataclass(frozen=True)
class SolveStats:
    """What one solve did (``solver::SolveStats``).

    ``energies[k]`` is the ARAP energy after iteration ``k + 1`` with rotations fitted to the
    pose (never increasing); ``initial_energy`` that of the starting guess. Times are
    milliseconds of the local steps, right-hand sides, back-substitutions and the final
    energy evaluation. For ``bsarap-coarse``, ``iterations`` counts the coarse iterations and
    ``fine_*`` the ARAP iterations on the full mesh after them.
    """

    iterations: int
    converged: bool
    done: bool
    initial_energy: float
    energy: float
    energies: np.ndarray = field(repr=False)
    local_ms: float
    rhs_ms: float
    solve_ms: float
    energy_ms: float
    total_ms: float
    ms_per_iteration: float
    rejected_steps: int
    fine_iterations: int
    fine_ms: float
    fine_energy: float
    fine_unconverged: bool

    @classmethod
    def _from(cls, d: Mapping[str, Any]) -> "SolveStats":
        return cls(**d)


def load_mesh(path: PathLike, *, with_report: bool = False):
    """Load and clean a mesh file.

    Reads every format the ``bsarap`` CLI reads (OBJ, OFF, PLY, STL, glTF ``.glb``/``.gltf``),
    then cleans it as the CLI does (welds duplicated vertices, drops degenerate, duplicated and
    unreferenced elements; the vertex order is the file's when nothing is removed).

    Returns ``(V, F)``: ``V`` ``(#V, 3)`` float64, ``F`` ``(#F, 3)`` int64; with
    ``with_report=True``, ``(V, F, report)`` where ``report`` is the dict of :func:`clean` plus
    the reader's notices. Raises :class:`BsarapError` naming the file and line.
    """
    v, f, report = _bsarap.load_mesh(os.fspath(path))
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
    _bsarap.save_mesh(os.fspath(path), _positions(V, "V"), _indices(F, "F", 2))


def load_selection(path: PathLike, V: Any) -> np.ndarray:
    """Read a handle selection for a mesh with rest positions ``V``.

    ``path``: a libigl ``.dmat`` (one value per vertex: -1 free, k >= 0 group k) or a JSON list
    of spheres ``[{"group": 0, "center": [x, y, z], "radius": r}]``. Returns the per-vertex
    labels, int64. ``np.nonzero(labels >= 0)[0]`` is libigl's ``b``.
    """
    return _bsarap.load_selection(os.fspath(path), _positions(V, "V"))


def rotation(axis: Sequence[float], degrees: float) -> np.ndarray:
    """The 3x3 rotation by ``degrees`` about ``axis`` (as the CLI's ``--rotate G:ax,ay,az,deg``)."""
    return np.array(_bsarap.rotation([float(c) for c in axis], float(degrees)))


class Arap:
    """ARAP deformation shaped like libigl's (``igl.arap_precomputation`` / ``igl.arap_solve``).

    ``Arap(V, F, b)`` precomputes (cotangent weights, one sparse Cholesky factorization of the
    free block); ``solve(bc, U0)`` runs local-global iterations to the stopping rule and
    returns ``U``. Code written for libigl changes in one line::

        # data = igl.ARAPData(); data.max_iter = 100
        # igl.arap_precomputation(V, F, 3, b, data); U = igl.arap_solve(bc, data, U0)
        solver = bsarap.Arap(V, F, b); U = solver.solve(bc, U0, max_iters=100, tol=0)

    Args:
        V: ``(#V, 3)`` rest positions.
        F: ``(#F, 3)`` triangles (no repeated vertex in a triangle; see :func:`clean`).
        b: ``(#b,)`` fixed vertex indices, distinct, at least one.
        energy: ``"spokes-and-rims"`` (default; libigl's default for surfaces) or ``"spokes"``.
        max_iters: iteration cap of a solve (default 100).
        tol: stop when an iteration lowers the energy by less than ``tol`` of itself (default
            1e-4); ``0`` runs exactly ``max_iters`` iterations, as libigl does.
        anderson: Anderson acceleration window (0, the default: plain local-global).

    Components of the mesh without a fixed vertex are held at rest (their block would be
    singular). ``stats`` holds the last solve's :class:`SolveStats`.
    """

    def __init__(
        self,
        V: Any,
        F: Any,
        b: Any,
        energy: str = "spokes-and-rims",
        *,
        max_iters: int = DEFAULT_MAX_ITERS,
        tol: float = DEFAULT_TOL,
        anderson: int = 0,
    ) -> None:
        V = _positions(V, "V")
        self._native = _bsarap.NativeArap(
            V, _indices(F, "F", 2), _indices(b, "b", 1), str(energy), _count(max_iters, "max_iters"),
            float(tol), _count(anderson, "anderson"),
        )
        self.n_vertices = V.shape[0]
        self.stats: Optional[SolveStats] = None

    def solve(
        self,
        bc: Any,
        U0: Any = None,
        max_iters: Optional[int] = None,
        tol: Optional[float] = None,
    ) -> np.ndarray:
        """Solve for the fixed positions ``bc``; returns ``U`` ``(#V, 3)``.

        Args:
            bc: ``(#b, 3)`` positions of the fixed vertices, rows in the order of ``b``.
            U0: ``(#V, 3)`` starting guess (libigl's ``U``), used as given with the fixed
                vertices moved onto ``bc``; ``None``: the solver's own warm start (the last
                result; before any solve or after :meth:`reset`, its start from rest).
            max_iters, tol: this solve's stopping rule (default: the constructor's).

        The per-iteration energies and phase times are in ``self.stats``.
        """
        u0 = None if U0 is None else _positions(U0, "U0")
        U, stats = self._native.solve(
            _positions(bc, "bc"),
            u0,
            None if max_iters is None else _count(max_iters, "max_iters"),
            None if tol is None else float(tol),
        )
        self.stats = SolveStats._from(stats)
        return U

    def energy(self, U: Any) -> float:
        """The ARAP energy of pose ``U`` with rotations fitted to it, min_R E(U, R)."""
        return self._native.energy(_positions(U, "U"))

    @property
    def positions(self) -> np.ndarray:
        """The current pose (the last result), ``(#V, 3)``."""
        return self._native.positions

    @property
    def rotations(self) -> np.ndarray:
        """The per-vertex rotations of the last local step, ``(#V, 3, 3)``."""
        return self._native.rotations

    @property
    def b(self) -> np.ndarray:
        """The fixed vertex indices, in the order given."""
        return self._native.b

    def reset(self) -> None:
        """Restart the next solve without ``U0`` from the rest pose."""
        self._native.reset()


def _count(x: Any, name: str) -> int:
    """A non-negative int (bools and negative numbers refused)."""
    if isinstance(x, bool) or not isinstance(x, (int, np.integer)) or int(x) < 0:
        raise BsarapError(f"{name} must be a non-negative integer (got {x!r})")
    return int(x)


Transform = Union[Sequence[float], Tuple[Sequence[float], Any], Mapping[str, Any]]


def _transforms(group_transforms: Mapping[int, Transform]):
    """``{group: transform}`` as ``[(group, translation, rotation)]`` for the native layer."""
    if not isinstance(group_transforms, Mapping):
        raise BsarapError("group_transforms must be a dict {group: transform}")
    out = []
    for g, t in group_transforms.items():
        if isinstance(g, bool) or not isinstance(g, (int, np.integer)) or int(g) < 0:
            raise BsarapError(f"group ids must be non-negative integers (got {g!r})")
        translation, rot = np.zeros(3), np.eye(3)
        if isinstance(t, Mapping):
            unknown = set(t) - {"translate", "rotate"}
            if unknown:
                raise BsarapError(f"group {g}: unknown keys {sorted(unknown)} (use translate, rotate)")
            translation = t.get("translate", translation)
            rot = t.get("rotate", rot)
        elif isinstance(t, tuple) and len(t) == 2:
            translation, rot = t
        else:
            translation = t
        translation = np.asarray(translation, dtype=np.float64)
        rot = np.asarray(rot, dtype=np.float64)
        if translation.shape != (3,):
            raise BsarapError(f"group {g}: the translation must have 3 components; got {translation.shape}")
        if rot.shape != (3, 3):
            raise BsarapError(f"group {g}: the rotation must be a 3x3 matrix; got {rot.shape}")
        out.append((int(g), translation.tolist(), rot.tolist()))
    return out


class Deformer:
    """Every deformation method of the ``bsarap`` CLI behind one interface.

    ``Deformer(V, F, handles, method="bsarap-coarse", **settings)`` precomputes (may take
    seconds on large meshes); ``solve({group: transform})`` poses the handle groups as the
    CLI's ``--move`` / ``--rotate`` do and returns the deformed positions.

    Args:
        V, F: the mesh (``(#V, 3)``, ``(#F, 3)``; see :func:`load_mesh` / :func:`clean`).
        handles: per-vertex labels ``(#V,)`` (-1 free, k >= 0 group k), or the path of a
            ``.dmat`` / sphere ``.json`` selection (read with :func:`load_selection`).
        method: ``"arap"``, ``"bsarap"`` (the paper), ``"bsarap-faired"`` or
            ``"bsarap-coarse"`` (default, the editor's).

    Settings (keywords; the CLI's flags):
        energy: ``"spokes-and-rims"`` (default) or ``"spokes"``.
        tol: relative energy decrease at which a solve stops (default 1e-4; 0: run max_iters).
        max_iters: iteration cap (default 100).
        anderson: Anderson acceleration window, 0 (default) to 64.
        smoothing: smoothing length of the faired base, fraction of the diagonal (default 0.01).
        coarse_vertices: vertices of the coarse base (default min(3000, 30 % of the mesh)).
        fine_iterations: ARAP iterations on the full mesh after each coarse solve (default 0).
        settle_iterations: ARAP iterations per :meth:`settle` step (coarse; default 0: off).
        pinned_components: components without handles kept at rest instead of following.

    ``positions``, ``base`` (the deformed base surface B') and ``details`` (D = M - B at rest)
    are readable after each solve; ``base``/``details`` are ``None`` for ARAP.
    """

    def __init__(
        self,
        V: Any,
        F: Any,
        handles: Any,
        method: str = "bsarap-coarse",
        *,
        energy: str = "spokes-and-rims",
        tol: float = DEFAULT_TOL,
        max_iters: int = DEFAULT_MAX_ITERS,
        anderson: int = 0,
        smoothing: float = 0.01,
        coarse_vertices: Optional[int] = None,
        fine_iterations: int = 0,
        settle_iterations: int = 0,
        pinned_components: Sequence[int] = (),
    ) -> None:
        V = _positions(V, "V")
        if isinstance(handles, (str, os.PathLike)):
            labels = load_selection(handles, V)
        else:
            labels = _indices(handles, "handles", 1)
        self._native = _bsarap.NativeDeformer(
            V, _indices(F, "F", 2), labels, str(method), str(energy), float(tol),
            _count(max_iters, "max_iters"), _count(anderson, "anderson"), float(smoothing),
            None if coarse_vertices is None else _count(coarse_vertices, "coarse_vertices"),
            _count(fine_iterations, "fine_iterations"), _count(settle_iterations, "settle_iterations"),
            [_count(c, "pinned_components") for c in pinned_components],
        )
        self.stats: Optional[SolveStats] = None

    @classmethod
    def _wrap(cls, native: Any) -> "Deformer":
        d = cls.__new__(cls)
        d._native = native
        d.stats = None
        return d

    def solve(self, group_transforms: Mapping[int, Transform]) -> np.ndarray:
        """Pose the handle groups and solve, warm-started from the last result.

        ``group_transforms`` maps a group id to its rigid motion, one of:
        a translation ``(dx, dy, dz)``; a pair ``(translation, R)`` with ``R`` a 3x3 rotation;
        or ``{"translate": (dx, dy, dz), "rotate": R}``. The rotation turns the group about its
        rest centroid, then the translation moves it (the CLI's ``--rotate`` then ``--move``;
        :func:`rotation` builds ``R`` from an axis and degrees). Groups not listed stay at rest.
        Returns the positions ``(#V, 3)``; statistics in ``self.stats``.
        """
        U, stats = self._native.solve(_transforms(group_transforms))
        self.stats = SolveStats._from(stats)
        return U

    def solve_targets(self, targets: Any) -> np.ndarray:
        """Solve for handle positions given directly, ``(#H, 3)`` in the order of
        :attr:`handle_vertices`."""
        U, stats = self._native.solve_targets(_positions(targets, "targets"))
        self.stats = SolveStats._from(stats)
        return U

    def targets(self, group_transforms: Mapping[int, Transform]) -> np.ndarray:
        """The handle positions ``(#H, 3)`` that :meth:`solve` would use."""
        return self._native.targets(_transforms(group_transforms))

    def settle(self) -> Optional[np.ndarray]:
        """Refine the last pose at the same targets (``bsarap-coarse`` with
        ``settle_iterations > 0``, after a solve whose coarse iterations converged; solve
        again at the same targets until ``stats.converged``): the new positions, or ``None``
        when there is nothing to refine. Call while :attr:`settle_pending` is true, as the
        editor does after a drag."""
        r = self._native.settle()
        if r is None:
            return None
        U, stats = r
        self.stats = SolveStats._from(stats)
        return U

    @property
    def settle_pending(self) -> bool:
        """Whether :meth:`settle` has work after the last solve."""
        return self._native.settle_pending

    def set_stopping(self, tol: float, max_iters: int) -> None:
        """Change the stopping rule without precomputing again."""
        self._native.set_stopping(float(tol), _count(max_iters, "max_iters"))

    def reset(self) -> None:
        """Restart the next solve from rest."""
        self._native.reset()

    @property
    def positions(self) -> np.ndarray:
        """The deformed positions of the last solve (rest before any), ``(#V, 3)``."""
        return self._native.positions

    @property
    def base(self) -> Optional[np.ndarray]:
        """The deformed base surface B' of the last solve, ``(#V, 3)``; ``None`` for ARAP."""
        return self._native.base

    @property
    def details(self) -> Optional[np.ndarray]:
        """The details D = M - B at rest, ``(#V, 3)``; ``None`` for ARAP."""
        return self._native.details

    @property
    def rest(self) -> np.ndarray:
        """The rest positions, ``(#V, 3)``."""
        return self._native.rest

    @property
    def labels(self) -> np.ndarray:
        """Per-vertex handle labels (-1 free, k group k)."""
        return self._native.labels

    @property
    def handle_vertices(self) -> np.ndarray:
        """The handle vertices, ascending (the row order of :meth:`targets`)."""
        return self._native.handle_vertices

    @property
    def groups(self) -> list:
        """The ids of the non-empty handle groups."""
        return self._native.groups

    @property
    def method(self) -> str:
        """The method's name."""
        return self._native.method

    @property
    def notice(self) -> Optional[str]:
        """A sentence about the loose parts (components without handles), if any."""
        return self._native.notice


class Timeline:
    """Handle paths over time (static, circular, keyframed), from a scene file.

    Get one from :attr:`Scene.timeline` or :meth:`Timeline.from_json` (the JSON of a scene's
    ``"timeline"`` field; format in ``solver/src/animation/scene.rs``).
    """

    def __init__(self, native: Any) -> None:
        self._native = native

    @classmethod
    def from_json(cls, text: str) -> "Timeline":
        """Parse and validate the JSON of a scene's ``"timeline"`` field."""
        return cls(_bsarap.timeline_from_json(str(text)))

    @classmethod
    def from_scene(cls, path: PathLike) -> "Timeline":
        """The timeline of the scene file at ``path``."""
        return load_scene(path).timeline

    @property
    def duration(self) -> float:
        """Seconds."""
        return self._native.duration

    @property
    def fps(self) -> float:
        """Frames per second."""
        return self._native.fps

    @property
    def looping(self) -> bool:
        """Whether playback wraps around after ``duration``."""
        return self._native.looping

    @property
    def groups(self) -> list:
        """The handle groups that have a path."""
        return self._native.groups

    def default_frame_count(self) -> int:
        """Frames of a default recording: round(duration * fps) + 1."""
        return self._native.default_frame_count()

    def frame_times(self, n: int) -> np.ndarray:
        """``n`` evenly spaced times over [0, duration], both ends included."""
        return self._native.frame_times(_count(n, "n"))

    def transforms_at(self, t: float) -> dict:
        """``{group: (translation, R)}`` of every path at time ``t``, ready for
        :meth:`Deformer.solve`."""
        return {g: (np.array(tr), np.array(r)) for g, tr, r in self._native.transforms_at(float(t))}

    def to_json(self) -> str:
        """The timeline as the JSON of a scene's ``"timeline"`` field."""
        return self._native.to_json()


class Scene:
    """A scene file (``bsarap`` editor / ``bsarap export``): mesh, handles, timeline, method
    and settings, the mesh loaded and cleaned. Use :func:`load_scene`."""

    def __init__(self, native: Any) -> None:
        self._native = native

    @property
    def V(self) -> np.ndarray:
        """Rest positions of the cleaned mesh, ``(#V, 3)``."""
        return self._native.vertices

    @property
    def F(self) -> np.ndarray:
        """Triangles of the cleaned mesh, ``(#F, 3)``."""
        return self._native.faces

    @property
    def labels(self) -> np.ndarray:
        """Per-vertex handle labels (-1 free, k group k)."""
        return self._native.labels

    @property
    def method(self) -> str:
        """The scene's method name."""
        return self._native.method

    @property
    def mesh_path(self) -> str:
        """The mesh file, resolved against the scene's folder."""
        return str(self._native.mesh_path)

    @property
    def settings(self) -> dict:
        """energy, tol, max_iters, anderson, smoothing, coarse_vertices, fine_iterations."""
        return self._native.settings

    @property
    def timeline(self) -> Timeline:
        """The scene's timeline."""
        return Timeline(self._native.timeline)

    def deformer(self) -> Deformer:
        """A :class:`Deformer` with the scene's mesh, handles, method, settings and loose
        parts; its recordings export the whole asset (file layout, materials, textures)."""
        return Deformer._wrap(self._native.deformer())


def load_scene(path: PathLike) -> Scene:
    """Read a scene file (JSON, versioned), load and clean its mesh, resolve its handles."""
    return Scene(_bsarap.load_scene(os.fspath(path)))


class Recording:
    """Solved frames of a timeline (:func:`record`)."""

    def __init__(self, native: Any) -> None:
        self._native = native

    @property
    def times(self) -> np.ndarray:
        """Seconds of each frame, ``(#frames,)``."""
        return self._native.times

    @property
    def frames(self) -> np.ndarray:
        """The poses, ``(#frames, #V, 3)``."""
        return self._native.frames

    @property
    def stats(self) -> list:
        """One dict per frame: iterations, converged, done, energy, ms, ms_per_iteration,
        fine_iterations, fine_energy."""
        return self._native.stats

    @property
    def total_iterations(self) -> int:
        """Iterations over all frames."""
        return self._native.total_iterations

    def __len__(self) -> int:
        return len(self._native.times)


def record(deformer: Deformer, timeline: Timeline, n_frames: Optional[int] = None) -> Recording:
    """Solve ``n_frames`` frames of ``timeline`` (default round(duration*fps)+1) with
    ``deformer``: reset first, each frame warm-started from the previous one, to the
    deformer's stopping rule; the same frames as the editor's Record and ``bsarap export``."""
    if not isinstance(deformer, Deformer) or not isinstance(timeline, Timeline):
        raise BsarapError("record(deformer, timeline): expected a Deformer and a Timeline")
    n = None if n_frames is None else _count(n_frames, "n_frames")
    return Recording(_bsarap.record(deformer._native, timeline._native, n))


def export_gltf(
    path: PathLike,
    recording: Recording,
    *,
    quantized: bool = True,
    normals: bool = True,
    every: int = 1,
) -> int:
    """Write ``recording`` as glTF 2.0 (``.glb`` or ``.gltf`` by extension): one morph target
    per frame under a looping animation, atomically; returns the bytes written.

    A recording of a scene's deformer is written on the whole asset (the file's own vertices,
    UVs, normals, materials, textures), as ``bsarap export``; otherwise on the bare mesh.
    ``quantized``: 16-bit morph targets (``KHR_mesh_quantization``), else float32;
    ``normals``: include normal deltas; ``every``: keep every k-th frame (and the last).
    """
    if not isinstance(recording, Recording):
        raise BsarapError("export_gltf: recording must be a Recording")
    return _bsarap.export_gltf(os.fspath(path), recording._native, bool(quantized), bool(normals),
                               _count(every, "every"))
