"""libigl's ARAP shape: :class:`Arap` (fixed indices ``b``, their positions ``bc``)."""

from __future__ import annotations

from typing import Any, Optional

import numpy as np

from . import _bsarap
from ._bsarap import BsarapError
from ._common import (
    DEFAULT_MAX_ITERS,
    DEFAULT_TOL,
    SolveStats,
    _count,
    _indices,
    _labels,
    _number,
    _positions,
)

#: What a literal port of ``igl.arap_precomputation(V, F, dim, b, data)`` is told.
_NO_DIM = (
    "Arap takes no dim argument: igl's arap_precomputation(V, F, dim, b, data) is Arap(V, F, b)"
)


class Arap:
    """ARAP deformation shaped like libigl's (``igl.arap_precomputation`` / ``igl.arap_solve``).

    ``Arap(V, F, b)`` precomputes (cotangent weights, one sparse Cholesky factorization of the
    free block); ``solve(bc, U0)`` runs local-global iterations to the stopping rule and
    returns ``U``. Code written for libigl changes in one line::

        # data = igl.ARAPData(); data.max_iter = 100
        # igl.arap_precomputation(V, F, 3, b, data); U = igl.arap_solve(bc, data, U0)
        solver = bsarap.Arap(V, F, b); U = solver.solve(bc, U0, max_iters=100, tol=0)

    libigl's defaults differ from this class's: ``data.max_iter`` is 10 and libigl has no
    tolerance, so ``solve(bc, U0, max_iters=10, tol=0)`` runs the iterations of a default
    ``igl.ARAPData``.

    Args:
        V: ``(#V, 3)`` rest positions.
        F: ``(#F, 3)`` triangles (no repeated vertex in a triangle; see :func:`clean`).
        b: ``(#b,)`` fixed vertex indices, distinct, at least one: integers, or floats whose values
            are all integers (as ``igl.read_dmat`` returns them). There is no ``dim`` argument
            (libigl's third): ``Arap(V, F, 3, b)`` is refused.
        energy: ``"spokes-and-rims"`` (default; libigl's default for surfaces) or ``"spokes"``.
        max_iters: iteration cap of a solve (default 100).
        tol: stop when an iteration lowers the energy by less than ``tol`` of itself (default
            1e-4); ``0`` runs exactly ``max_iters`` iterations, as libigl does.
        anderson: Anderson acceleration window (0, the default: plain local-global).

    Components of the mesh without a fixed vertex are held at rest (their block would be
    singular). ``stats`` holds the last solve's :class:`SolveStats`; it is set to ``None`` as
    each solve starts, so after a solve that raised (``BsarapError``, ``KeyboardInterrupt``) it is
    ``None``, never an older solve's.
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
        if not isinstance(energy, str):
            kind = type(energy).__name__
            raise BsarapError(f"energy must be a str (got a {kind}); {_NO_DIM}")
        if isinstance(b, (int, float, np.generic)) or (isinstance(b, np.ndarray) and b.ndim == 0):
            raise BsarapError(f"b must be a 1-d array of vertex indices (got {b!r}); {_NO_DIM}")
        V = _positions(V, "V")
        self._native = _bsarap.NativeArap(
            V, _indices(F, "F", 2), _labels(b, "b"), energy, _count(max_iters, "max_iters"),
            _number(tol, "tol"), _count(anderson, "anderson"),
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

        The per-iteration energies and phase times are in ``self.stats``, which is ``None`` from
        the start of the call until it returns.
        """
        self.stats = None
        u0 = None if U0 is None else _positions(U0, "U0")
        U, stats = self._native.solve(
            _positions(bc, "bc"),
            u0,
            None if max_iters is None else _count(max_iters, "max_iters"),
            None if tol is None else _number(tol, "tol"),
        )
        self.stats = SolveStats._from(stats)
        return U

    def energy(self, U: Any) -> float:
        """The ARAP energy of pose ``U`` with rotations fitted to it, min_R E(U, R). ``U``
        becomes the pose: :attr:`positions` and the next solve's start without ``U0``."""
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
