"""Every method of the ``bsarap`` CLI: :class:`Deformer`, posed by per-group rigid transforms."""

from __future__ import annotations

import os
from typing import Any, Iterable, Mapping, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

from . import _bsarap
from ._bsarap import BsarapError
from ._common import (
    DEFAULT_BENDING_LENGTH,
    DEFAULT_MAX_ITERS,
    DEFAULT_MEMBRANE,
    DEFAULT_TOL,
    MAX_SETTLE_STEPS,
    AtRest,
    SolveStats,
    _count,
    _indices,
    _items,
    _labels,
    _number,
    _positions,
    _real,
)
from ._mesh import load_selection


Transform = Union[npt.ArrayLike, Tuple[npt.ArrayLike, npt.ArrayLike], Mapping[str, npt.ArrayLike]]


def _transforms(group_transforms: Mapping[int, Transform]):
    """``{group: transform}`` as ``[(group, translation, rotation)]`` for the native layer."""
    if not isinstance(group_transforms, Mapping):
        raise BsarapError("group_transforms must be a dict {group: transform}")
    out = []
    for g, t in group_transforms.items():
        g = _count(g, "group ids")
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
        translation = _real(translation, f"group {g}: the translation")
        rot = _real(rot, f"group {g}: the rotation")
        if translation.shape != (3,):
            raise BsarapError(f"group {g}: the translation must have 3 components; got {translation.shape}")
        if rot.shape != (3, 3):
            raise BsarapError(f"group {g}: the rotation must be a 3x3 matrix; got {rot.shape}")
        out.append((g, translation.tolist(), rot.tolist()))
    return out


def _pinned(pinned_components: Any) -> list:
    """``pinned_components`` as a list of component indices (a sequence or 1-d array)."""
    items = _items(pinned_components, "pinned_components", "a sequence of component indices")
    return [_count(c, "pinned_components") for c in items]


class Deformer:
    """Every deformation method of the ``bsarap`` CLI behind one interface.

    ``Deformer(V, F, handles, method="bsarap-coarse", **settings)`` precomputes (may take
    seconds on large meshes); ``solve({group: transform})`` poses the handle groups as the
    CLI's ``--move`` / ``--rotate`` do and returns the deformed positions.

    Args:
        V, F: the mesh (``(#V, 3)``, ``(#F, 3)``; see :func:`load_mesh` / :func:`clean`).
        handles: per-vertex labels ``(#V,)``: -1 free, ``0 <= k < #V + 1024`` group k (the
            solver refuses larger ids); integers, or floats whose values are all integers (as
            ``igl.read_dmat`` returns them). Or the path of a ``.dmat`` / sphere ``.json``
            selection (read with :func:`load_selection`).
        vertex_map: with a selection file, the cleaning's map of the mesh file ``V`` was read
            from (``report["vertex_map"]`` of :func:`load_mesh`): a ``.dmat`` written for the
            file's vertices is read through it, as :func:`load_selection` does.
        method: ``"arap"``, ``"bsarap"`` (the paper), ``"bsarap-faired"`` or
            ``"bsarap-coarse"`` (default, the editor's).

    Settings (keywords; the CLI's flags). Unlike the CLI, which refuses a flag the method does
    not read, a setting another method reads is accepted and has no effect (a caller can pass
    one set of settings to every method): ``smoothing`` is read by ``bsarap-faired`` and
    ``bsarap-coarse``; ``coarse_vertices``, ``fine_iterations``, ``settle_iterations``,
    ``membrane`` and ``coarse_energy`` by ``bsarap-coarse`` only.
        energy: ``"spokes-and-rims"`` (default), ``"spokes"`` or ``"smooth-rotations"``
            (SR-ARAP: spokes plus a rotation-smoothness term whose minimum does not move with
            the mesh's resolution).
        bending_length: the bending length of ``"smooth-rotations"``, a fraction of the rest
            bounding-box diagonal in (0, ``MAX_BENDING_LENGTH``] (default
            ``DEFAULT_BENDING_LENGTH``; :attr:`bending_length_world` gives it in world units).
            Checked whatever the energy, used by smooth rotations only.
        tol: relative energy decrease at which a solve stops (default 1e-4; 0: run max_iters).
        max_iters: iteration cap (default 100).
        anderson: Anderson acceleration window, 0 (default) to 64.
        smoothing: smoothing length of the faired base, fraction of the diagonal (default 0.01;
            ``bsarap-faired``, ``bsarap-coarse``).
        coarse_vertices: vertices of the coarse base (default min(3000, 30 % of the mesh);
            ``bsarap-coarse``).
        fine_iterations: ARAP iterations on the full mesh after each coarse solve (default 0).
        settle_iterations: ARAP iterations per :meth:`settle` step (coarse; default 0: off).
        membrane: the coarse level's membrane share, in [0, 1]: the part of its ARAP energy in
            cells of single triangles, which resist no bending (``bsarap-coarse`` with the
            spokes-and-rims energy; default ``DEFAULT_MEMBRANE``, 0: vertex cells alone).
        coarse_energy: what ``bsarap-coarse`` minimizes on its coarse level: ``"decimated"``
            (default: ARAP on the decimated base) or ``"galerkin"`` (the full mesh's energy
            restricted to the coarse level, nearer the full mesh's minimum; needs
            ``energy="smooth-rotations"``).
        pinned_components: the indices of components without handles kept at rest instead of
            following (a sequence or 1-d array; default none).

    ``positions``, ``base`` (the deformed base surface B') and ``details`` (D = M - B at rest)
    are readable after each solve; ``base``/``details`` are ``None`` for ARAP. ``stats`` (the
    last solve's :class:`SolveStats`) and ``at_rest`` (the last :meth:`solve_to_rest`'s
    :class:`AtRest`) are set to ``None`` as each solve starts: after a solve that raised
    (``BsarapError``, ``KeyboardInterrupt``) they are ``None``, never an older solve's.

    Solves release the GIL, and a deformer serves one thread at a time: any call on it while
    another thread solves with it raises :class:`BsarapError` ("busy"); give each thread its
    own deformer, or wait for the solve to return.
    """

    def __init__(
        self,
        V: Any,
        F: Any,
        handles: Any,
        method: str = "bsarap-coarse",
        *,
        energy: str = "spokes-and-rims",
        bending_length: float = DEFAULT_BENDING_LENGTH,
        tol: float = DEFAULT_TOL,
        max_iters: int = DEFAULT_MAX_ITERS,
        anderson: int = 0,
        smoothing: float = 0.01,
        coarse_vertices: Optional[int] = None,
        fine_iterations: int = 0,
        settle_iterations: int = 0,
        membrane: float = DEFAULT_MEMBRANE,
        coarse_energy: str = "decimated",
        pinned_components: Iterable[int] = (),
        vertex_map: Any = None,
    ) -> None:
        V = _positions(V, "V")
        if isinstance(handles, (str, bytes, os.PathLike)):
            labels = load_selection(handles, V, vertex_map=vertex_map)
        elif vertex_map is not None:
            raise BsarapError(
                "vertex_map reads a selection file through a cleaning; labels given as an "
                "array are already one per vertex of V"
            )
        else:
            labels = _labels(handles, "handles")
        self._native = _bsarap.NativeDeformer(
            V, _indices(F, "F", 2), labels, str(method), str(energy), _number(tol, "tol"),
            _count(max_iters, "max_iters"), _count(anderson, "anderson"), _number(smoothing, "smoothing"),
            None if coarse_vertices is None else _count(coarse_vertices, "coarse_vertices"),
            _count(fine_iterations, "fine_iterations"), _count(settle_iterations, "settle_iterations"),
            _number(membrane, "membrane"), _pinned(pinned_components),
            _number(bending_length, "bending_length"), str(coarse_energy),
        )
        self.stats: Optional[SolveStats] = None
        self.at_rest: Optional[AtRest] = None

    @classmethod
    def _wrap(cls, native: Any) -> "Deformer":
        d = cls.__new__(cls)
        d._native = native
        d.stats = None
        d.at_rest = None
        return d

    def solve(self, group_transforms: Mapping[int, Transform]) -> np.ndarray:
        """Pose the handle groups and solve, warm-started from the last result.

        ``group_transforms`` maps a group id to its rigid motion, one of:
        a translation ``(dx, dy, dz)``; a pair ``(translation, R)`` with ``R`` a 3x3 rotation;
        or ``{"translate": (dx, dy, dz), "rotate": R}``. The rotation turns the group about its
        rest centroid, then the translation moves it (the CLI's ``--rotate`` then ``--move``;
        :func:`rotation` builds ``R`` from an axis and degrees). ``R`` must be orthonormal within
        1e-6 (every entry of ``R.T @ R`` within 1e-6 of the identity's) with determinant +1; a
        rotation further off is refused, the deviation named. Groups not listed stay at rest.
        Returns the positions ``(#V, 3)``; statistics in ``self.stats``, which is ``None`` (as is
        ``self.at_rest``) from the start of the call until it returns.
        """
        self.stats = self.at_rest = None
        U, stats = self._native.solve(_transforms(group_transforms))
        self.stats = SolveStats._from(stats)
        return U

    def solve_targets(self, targets: Any) -> np.ndarray:
        """Solve for handle positions given directly, ``(#H, 3)`` in the order of
        :attr:`handle_vertices`. Statistics in ``self.stats``, ``None`` (as is ``self.at_rest``)
        from the start of the call until it returns."""
        self.stats = self.at_rest = None
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
        editor does after a drag: the last step's ``stats.converged`` is true, and nothing is
        pending after it until the next solve."""
        r = self._native.settle()
        if r is None:
            return None
        U, stats = r
        self.stats = SolveStats._from(stats)
        return U

    def solve_to_rest(
        self, group_transforms: Mapping[int, Transform], max_steps: int = MAX_SETTLE_STEPS
    ) -> np.ndarray:
        """The pose at rest at ``group_transforms`` (as in :meth:`solve`): solves again,
        warm-started, until one converges, then :meth:`settle` steps until one says converged;
        at most ``max_steps`` of each (at least one solve). Returns the positions ``(#V, 3)``;
        what it did in ``self.at_rest`` (:class:`AtRest`), ``self.stats`` is cleared. With
        ``settle_iterations=5`` (the editor's) this is the pose the editor shows once the
        handles stop, as ``bsarap deform SCENE`` writes it.

        Ctrl-C (``KeyboardInterrupt``) stops it between two steps; a step (one solve or settle
        step) runs to its end. The deformer is then as after the last step that ran: its
        :attr:`positions`, its targets and :attr:`settle_pending`, from which :meth:`settle`,
        :meth:`solve` or another ``solve_to_rest`` carry on; ``stats`` and ``at_rest`` are
        ``None`` (from the start of the call, after any error too)."""
        self.stats = self.at_rest = None
        U, at_rest = self._native.solve_to_rest(
            _transforms(group_transforms), _count(max_steps, "max_steps")
        )
        self.at_rest = AtRest._from(at_rest)
        return U

    @property
    def settle_pending(self) -> bool:
        """Whether :meth:`settle` has work after the last solve."""
        return self._native.settle_pending

    def set_stopping(self, tol: float, max_iters: int) -> None:
        """Change the stopping rule without precomputing again."""
        self._native.set_stopping(_number(tol, "tol"), _count(max_iters, "max_iters"))

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
    def energy(self) -> str:
        """The energy's name (``"spokes-and-rims"``, ``"spokes"`` or ``"smooth-rotations"``)."""
        return self._native.energy

    @property
    def bending_length(self) -> float:
        """The bending length of ``"smooth-rotations"``, a fraction of the rest bounding-box
        diagonal."""
        return self._native.bending_length

    @property
    def bending_length_world(self) -> float:
        """:attr:`bending_length` in world units (times the rest bounding-box diagonal)."""
        return self._native.bending_length_world

    @property
    def notice(self) -> Optional[str]:
        """A sentence about the loose parts (components without handles), if any."""
        return self._native.notice
