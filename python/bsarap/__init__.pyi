"""Type stubs of bsarap, the whole public API in one file (the documentation is in the modules
the package imports it from: _common, _mesh, _arap, _deformer, _animation)."""

import os
from typing import Any, Dict, Iterable, List, Mapping, Optional, Tuple, Union, overload, Literal

import numpy as np
import numpy.typing as npt

PathLike = Union[str, bytes, os.PathLike[str], os.PathLike[bytes]]
ArrayLike = npt.ArrayLike
F64 = npt.NDArray[np.float64]
I64 = npt.NDArray[np.int64]
Method = Literal["arap", "bsarap", "bsarap-faired", "bsarap-coarse"]
EnergyName = Literal["spokes-and-rims", "spokes", "smooth-rotations"]
CoarseEnergyName = Literal["decimated", "galerkin"]
ArapEnergyName = Literal["spokes-and-rims", "spokes"]
Transform = Union[
    ArrayLike,
    Tuple[ArrayLike, ArrayLike],
    Mapping[str, ArrayLike],
]

class BsarapError(ValueError):
    """An error of the solver (bad mesh, handles, settings or file), with its message."""

METHODS: Tuple[str, ...]
ENERGIES: Tuple[str, ...]
DEFAULT_TOL: float
DEFAULT_MAX_ITERS: int
DEFAULT_MEMBRANE: float
DEFAULT_BENDING_LENGTH: float
MAX_BENDING_LENGTH: float
MAX_SETTLE_STEPS: int

class SolveStats:
    """What one solve did (solver::SolveStats)."""

    iterations: int
    converged: bool
    done: bool
    initial_energy: float
    energy: float
    energies: F64
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

class AtRest:
    """What Deformer.solve_to_rest did (solver::AtRest)."""

    solves: int
    converged: bool
    settle_steps: int
    settled: bool
    iterations: int
    energy: float

@overload
def load_mesh(path: PathLike, *, with_report: Literal[False] = ...) -> Tuple[F64, I64]: ...
@overload
def load_mesh(path: PathLike, *, with_report: Literal[True]) -> Tuple[F64, I64, Dict[str, Any]]: ...
@overload
def load_mesh(
    path: PathLike, *, with_report: bool
) -> Union[Tuple[F64, I64], Tuple[F64, I64, Dict[str, Any]]]: ...
def clean(V: ArrayLike, F: ArrayLike) -> Tuple[F64, I64, Dict[str, Any]]: ...
def save_mesh(path: PathLike, V: ArrayLike, F: ArrayLike) -> None: ...
def load_selection(path: PathLike, V: ArrayLike, *, vertex_map: Optional[ArrayLike] = None) -> I64: ...
def rotation(axis: ArrayLike, degrees: float) -> F64: ...

class Arap:
    """libigl-shaped ARAP: Arap(V, F, b).solve(bc, U0) -> U.

    b: fixed vertex indices, integers or integral floats; no dim argument (igl's third). libigl's
    defaults are solve(bc, U0, max_iters=10, tol=0). stats is None from the start of a solve
    until it returns.
    """

    n_vertices: int
    stats: Optional[SolveStats]
    def __init__(
        self,
        V: ArrayLike,
        F: ArrayLike,
        b: ArrayLike,
        energy: ArapEnergyName = ...,
        *,
        max_iters: int = ...,
        tol: float = ...,
        anderson: int = ...,
    ) -> None: ...
    def solve(
        self,
        bc: ArrayLike,
        U0: Optional[ArrayLike] = ...,
        max_iters: Optional[int] = ...,
        tol: Optional[float] = ...,
    ) -> F64: ...
    def energy(self, U: ArrayLike) -> float: ...
    @property
    def positions(self) -> F64: ...
    @property
    def rotations(self) -> F64: ...
    @property
    def b(self) -> I64: ...
    def reset(self) -> None: ...

class Deformer:
    """Every method of the bsarap CLI: Deformer(V, F, handles, method).solve({group: transform}).

    handles: per-vertex labels, -1 free, 0 <= k < #V + 1024 group k (integers or integral
    floats), or a selection file. stats and at_rest are None from the start of a solve until it
    returns.
    """

    stats: Optional[SolveStats]
    at_rest: Optional[AtRest]
    def __init__(
        self,
        V: ArrayLike,
        F: ArrayLike,
        handles: Union[ArrayLike, PathLike],
        method: Method = ...,
        *,
        energy: EnergyName = ...,
        bending_length: float = ...,
        tol: float = ...,
        max_iters: int = ...,
        anderson: int = ...,
        smoothing: float = ...,
        coarse_vertices: Optional[int] = ...,
        fine_iterations: int = ...,
        settle_iterations: int = ...,
        membrane: float = ...,
        coarse_energy: CoarseEnergyName = ...,
        pinned_components: Iterable[int] = ...,
        vertex_map: Optional[ArrayLike] = ...,
    ) -> None: ...
    def solve(self, group_transforms: Mapping[int, Transform]) -> F64:
        """Rotations must be orthonormal within 1e-6 (R.T @ R entrywise) with determinant +1."""
    def solve_targets(self, targets: ArrayLike) -> F64: ...
    def targets(self, group_transforms: Mapping[int, Transform]) -> F64: ...
    def settle(self) -> Optional[F64]: ...
    def solve_to_rest(
        self, group_transforms: Mapping[int, Transform], max_steps: int = ...
    ) -> F64: ...
    @property
    def settle_pending(self) -> bool: ...
    def set_stopping(self, tol: float, max_iters: int) -> None: ...
    def reset(self) -> None: ...
    @property
    def positions(self) -> F64: ...
    @property
    def base(self) -> Optional[F64]: ...
    @property
    def details(self) -> Optional[F64]: ...
    @property
    def rest(self) -> F64: ...
    @property
    def labels(self) -> I64: ...
    @property
    def handle_vertices(self) -> I64: ...
    @property
    def groups(self) -> List[int]: ...
    @property
    def method(self) -> str: ...
    @property
    def energy(self) -> str: ...
    @property
    def bending_length(self) -> float: ...
    @property
    def bending_length_world(self) -> float: ...
    @property
    def notice(self) -> Optional[str]: ...

class Timeline:
    """Handle paths over time, from a scene file or JSON."""

    def __init__(self, native: Any) -> None: ...
    @classmethod
    def from_json(cls, text: str) -> Timeline: ...
    @classmethod
    def from_scene(cls, path: PathLike) -> Timeline: ...
    @property
    def duration(self) -> float: ...
    @property
    def fps(self) -> float: ...
    @property
    def looping(self) -> bool: ...
    @property
    def groups(self) -> List[int]: ...
    def default_frame_count(self) -> int: ...
    def frame_times(self, n: int) -> F64: ...
    def transforms_at(self, t: float) -> Dict[int, Tuple[F64, F64]]: ...
    def to_json(self) -> str: ...

class Scene:
    """A scene file with its mesh loaded and its handles resolved."""

    def __init__(self, native: Any) -> None: ...
    @property
    def V(self) -> F64: ...
    @property
    def F(self) -> I64: ...
    @property
    def labels(self) -> I64: ...
    @property
    def method(self) -> str: ...
    @property
    def mesh_path(self) -> str: ...
    @property
    def notices(self) -> List[str]: ...
    @property
    def settings(self) -> Dict[str, Any]: ...
    @property
    def timeline(self) -> Timeline: ...
    def deformer(self, *, settle_iterations: int = 0) -> Deformer: ...

def load_scene(path: PathLike) -> Scene: ...

class Recording:
    """Solved frames of a timeline."""

    def __init__(self, native: Any) -> None: ...
    @property
    def times(self) -> F64: ...
    @property
    def frames(self) -> F64: ...
    @property
    def stats(self) -> List[Dict[str, Any]]: ...
    @property
    def total_iterations(self) -> int: ...
    def __len__(self) -> int: ...

def record(deformer: Deformer, timeline: Timeline, n_frames: Optional[int] = ...) -> Recording: ...
def export_gltf(
    path: PathLike,
    recording: Recording,
    *,
    quantized: bool = ...,
    normals: bool = ...,
    every: int = ...,
) -> int: ...
