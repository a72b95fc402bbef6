"""What the rest of the package shares: the settings' defaults and names, the array coercions
(no copy when the layout already fits) and :class:`SolveStats`."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any, Mapping, Tuple, Union

import numpy as np

from . import _bsarap
from ._bsarap import BsarapError

#: The method names of :class:`~bsarap.Deformer` (the CLI's ``--method``).
METHODS: Tuple[str, ...] = tuple(_bsarap.METHODS)
#: The ARAP energies (the CLI's ``--energy``), read from the native module.
ENERGIES: Tuple[str, ...] = tuple(_bsarap.ENERGIES)

#: The solver's defaults (``solver::deform::arap::DEFAULT_TOLERANCE`` / ``DEFAULT_MAX_ITERATIONS``).
DEFAULT_TOL = 1e-4
DEFAULT_MAX_ITERS = 100
#: The coarse level's default membrane share (``solver::BaseConfig::DEFAULT_MEMBRANE``, read from
#: the native module).
DEFAULT_MEMBRANE: float = _bsarap.DEFAULT_MEMBRANE
#: The default bending length of the ``"smooth-rotations"`` energy, a fraction of the rest
#: bounding-box diagonal (``solver::deform::arap::DEFAULT_BENDING_LENGTH``, read from the native
#: module); accepted up to ``MAX_BENDING_LENGTH``.
DEFAULT_BENDING_LENGTH: float = _bsarap.DEFAULT_BENDING_LENGTH
MAX_BENDING_LENGTH: float = _bsarap.MAX_BENDING_LENGTH
#: The most solves, and settle steps, of :meth:`~bsarap.Deformer.solve_to_rest` by default
#: (``solver::MAX_SETTLE_STEPS``, the editor's cap on settle steps; read from the native module).
MAX_SETTLE_STEPS: int = _bsarap.MAX_SETTLE_STEPS

PathLike = Union[str, bytes, "os.PathLike[str]", "os.PathLike[bytes]"]

#: The largest count or index the native layer takes (``i64``, as :func:`_indices` checks).
_MAX_INT = int(np.iinfo(np.int64).max)


def _path(p: Any, name: str = "path") -> str:
    """A file path as ``str``: ``str``, ``bytes`` (decoded as ``os.fsdecode`` does) or any
    ``os.PathLike``; anything else refused."""
    try:
        return os.fsdecode(os.fspath(p))
    except TypeError:
        kind = type(p).__name__
        raise BsarapError(f"{name} must be a str, bytes or os.PathLike (got {kind})") from None


def _real(a: Any, name: str) -> np.ndarray:
    """``a`` as a float64 array; complex values refused (numpy would drop their imaginary part
    with a warning only)."""
    try:
        complex_values = np.iscomplexobj(a)  # may raise too (a ragged list)
        if not complex_values:
            return np.asarray(a, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as e:
        raise BsarapError(f"{name} must be an array of numbers: {e}") from None
    raise BsarapError(f"{name} must hold real numbers; got complex values")


def _positions(a: Any, name: str) -> np.ndarray:
    """``a`` as a C-contiguous ``(n, 3)`` float64 array (no copy when it already is one)."""
    arr = np.ascontiguousarray(_real(a, name))
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise BsarapError(f"{name} must have shape (n, 3); got {arr.shape}")
    return arr


def _indices(a: Any, name: str, ndim: int) -> np.ndarray:
    """``a`` as a C-contiguous int64 array of ``ndim`` dimensions (integer dtypes only; a single
    number is not a 1-d array)."""
    arr = np.asarray(a)
    if ndim == 1 and arr.ndim == 0:
        raise BsarapError(f"{name} must be a 1-d array; got the single value {a!r}")
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


def _labels(a: Any, name: str) -> np.ndarray:
    """``a`` as a 1-d int64 array (:func:`_indices`), also from floats whose values are all
    finite integers (``igl.read_dmat`` returns float64); a fractional or non-finite value is
    refused, naming its index."""
    arr = np.asarray(a)
    if arr.dtype.kind == "f" and arr.size:
        flat = arr.reshape(-1)
        with np.errstate(invalid="ignore"):
            bad = ~np.isfinite(flat) | (flat != np.round(flat)) | (np.abs(flat) >= 2.0**63)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise BsarapError(
                f"{name} must hold integers; got {float(flat[i])!r} at index {i} (floats are "
                "taken when every value is a finite integer)"
            )
        arr = arr.astype(np.int64)
    return _indices(arr, name, 1)


def _items(x: Any, name: str, what: str) -> list:
    """The items of a sequence, 1-d array or other iterable ``x``, as a list; a number, ``None``
    or a string is refused (``what`` says what ``x`` should be)."""
    if not isinstance(x, (str, bytes)):
        try:
            return list(x)
        except TypeError:
            pass
    raise BsarapError(f"{name} must be {what} (got {x!r})")


def _number(x: Any, name: str) -> float:
    """A real number as a float (bools and non-numbers refused; the range is the solver's)."""
    if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)):
        raise BsarapError(f"{name} must be a number (got {x!r})")
    try:
        return float(x)
    except OverflowError:
        raise BsarapError(f"{name} is too large to be a float (got {x!r})") from None


def _flag(x: Any, name: str) -> bool:
    """A bool (numpy's too); anything else refused (``"no"`` is not false)."""
    if not isinstance(x, (bool, np.bool_)):
        raise BsarapError(f"{name} must be True or False (got {x!r})")
    return bool(x)


def _count(x: Any, name: str) -> int:
    """A non-negative int (bools and negative numbers refused)."""
    if isinstance(x, bool) or not isinstance(x, (int, np.integer)) or int(x) < 0:
        raise BsarapError(f"{name} must be a non-negative integer (got {x!r})")
    if int(x) > _MAX_INT:
        raise BsarapError(f"{name} is too large (got {x!r}; at most 2**63 - 1)")
    return int(x)


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


@dataclass(frozen=True)
class AtRest:
    """What :meth:`~bsarap.Deformer.solve_to_rest` did (``solver::AtRest``).

    ``solves`` warm-started solves ran until one ``converged``; then ``settle_steps`` settle
    steps (``bsarap-coarse`` with ``settle_iterations > 0``). ``settled``: nothing is left to
    settle. ``iterations`` counts every local-global iteration, fine ones included; ``energy``
    is the last solve's or step's.
    """

    solves: int
    converged: bool
    settle_steps: int
    settled: bool
    iterations: int
    energy: float

    @classmethod
    def _from(cls, d: Mapping[str, Any]) -> "AtRest":
        return cls(**d)
