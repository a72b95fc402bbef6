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
outputs are new arrays that own the solver's buffers. Every error is a :class:`BsarapError` (a
``ValueError``) carrying the solver's message. Solves release the GIL: an object serves one
thread at a time (a call while another thread solves with it raises :class:`BsarapError`), and
Ctrl-C stops the calls of many solves or frames (:meth:`Deformer.solve_to_rest`, :func:`record`,
:func:`export_gltf`) between two of them; one solve runs to its end.

The modules: ``_common`` (defaults, array coercion, :class:`SolveStats`, :class:`AtRest`),
``_mesh``, ``_arap``, ``_deformer``, ``_animation``; ``_bsarap`` is the native half. Import
everything from ``bsarap`` itself.
"""

from __future__ import annotations

# Also importable from here as before the split into modules: the defaults and aliases of the
# stubs (DEFAULT_*, PathLike, Transform) and the coercions the tests check (_positions, ...).
from ._animation import Recording, Scene, Timeline, export_gltf, load_scene, record
from ._arap import Arap
from ._bsarap import BsarapError
from ._common import (
    AtRest,
    DEFAULT_BENDING_LENGTH,
    DEFAULT_MAX_ITERS,
    DEFAULT_MEMBRANE,
    DEFAULT_TOL,
    ENERGIES,
    MAX_BENDING_LENGTH,
    MAX_SETTLE_STEPS,
    METHODS,
    PathLike,
    SolveStats,
    _count,
    _indices,
    _positions,
)
from ._deformer import Deformer, Transform
from ._mesh import clean, load_mesh, load_selection, rotation, save_mesh

__all__ = [
    "BsarapError",
    "METHODS",
    "ENERGIES",
    "SolveStats",
    "AtRest",
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
