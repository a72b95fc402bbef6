"""Animation: scenes (:func:`load_scene`, :class:`Scene`), :class:`Timeline`, :func:`record`
and :func:`export_gltf`."""

from __future__ import annotations

from typing import Any, Optional

import numpy as np

from . import _bsarap
from ._bsarap import BsarapError
from ._common import PathLike, _count, _flag, _number, _path
from ._deformer import Deformer


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
        return {g: (np.array(tr), np.array(r)) for g, tr, r in self._native.transforms_at(_number(t, "t"))}

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
    def notices(self) -> list:
        """The loader's notices (sentences): what cleaning changed, what the reader left out,
        each file the scene names outside its own folder (a downloaded scene can name any of
        your files; look before exporting it)."""
        return self._native.notices

    @property
    def settings(self) -> dict:
        """energy, bending_length, tol, max_iters, anderson, smoothing, coarse_vertices,
        fine_iterations, membrane, coarse_energy (the keywords of :class:`Deformer`)."""
        return self._native.settings

    @property
    def timeline(self) -> Timeline:
        """The scene's timeline."""
        return Timeline(self._native.timeline)

    def deformer(self, *, settle_iterations: int = 0) -> Deformer:
        """A :class:`Deformer` with the scene's mesh, handles, method, settings and loose
        parts; its recordings export the whole asset (file layout, materials, textures).
        ``settle_iterations`` (not a scene's: the editor sets it) is :class:`Deformer`'s; the
        editor and ``bsarap deform SCENE`` settle with 5."""
        return Deformer._wrap(self._native.deformer(_count(settle_iterations, "settle_iterations")))


def load_scene(path: PathLike) -> Scene:
    """Read a scene file (JSON, versioned), load and clean its mesh, resolve its handles."""
    return Scene(_bsarap.load_scene(_path(path)))


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
    deformer's stopping rule; the same frames as the editor's Record and ``bsarap export``.

    Ctrl-C (``KeyboardInterrupt``) stops it between two frames (a frame's solve runs to its
    end): no recording is returned, and ``deformer`` is left at the last frame solved (at rest
    if none), from which :meth:`Deformer.settle` refines and solves carry on."""
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
    UVs, normals, materials, textures), as ``bsarap export``: a Z-up scene stands upright (a
    node rotation), and the scene's own files are not written over (an error); otherwise on the
    bare mesh.
    ``quantized``: 16-bit morph targets (``KHR_mesh_quantization``), else float32;
    ``normals``: include normal deltas; ``every``: keep every k-th frame (and the last).
    Ctrl-C (``KeyboardInterrupt``) stops it between two frames, before anything is written.
    """
    if not isinstance(recording, Recording):
        raise BsarapError("export_gltf: recording must be a Recording")
    return _bsarap.export_gltf(_path(path), recording._native, _flag(quantized, "quantized"), _flag(normals, "normals"),
                               _count(every, "every"))
