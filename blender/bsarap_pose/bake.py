"""Baking the controls' animation over the scene's frame range: into shape keys (one per frame,
keyed on at its frame and off at the neighbours) or into a PC2 point cache read by a Mesh Cache
modifier.

PC2 (little-endian; the format of the solver's ``animation::pointcache`` writer, which the
Python module does not expose, so it is written here): a 32-byte header ``"POINTCACHE2\\0"``,
``i32`` version 1, ``i32`` numPoints, ``f32`` startFrame, ``f32`` sampleRate (1: one sample per
frame), ``i32`` numSamples, then numSamples x numPoints x 3 ``f32``.
"""

from __future__ import annotations

import struct

import numpy as np

from . import handlers, solve

FRAME_KEY_PREFIX = "BS-ARAP frame "
PC2_MAGIC = b"POINTCACHE2\0"


def frame_key_name(frame: int) -> str:
    return f"{FRAME_KEY_PREFIX}{frame:04d}"


class Baker:
    """Solves the frames ``frames`` of ``obj`` one :meth:`step` at a time (for the modal
    operator), warm-starting each frame from the previous one."""

    def __init__(self, scene, obj, frames):
        self.scene, self.obj, self.frames = scene, obj, list(frames)
        self.st = solve.state(obj)
        self.st.baking = True  # until restore_frame: the live pose's finishing steps wait
        self.poses = []
        self.frame_before = scene.frame_current

    @property
    def done(self) -> bool:
        return len(self.poses) == len(self.frames)

    def step(self) -> None:
        f = self.frames[len(self.poses)]
        handlers.suspended = True
        try:
            self.scene.frame_set(f)
        finally:
            handlers.suspended = False
        self.poses.append(solve.solve(self.obj, self.st, solve.control_deltas(self.obj)))

    def restore_frame(self) -> None:
        """The frame the bake started at, without a live solve; ends the bake."""
        handlers.suspended = True
        try:
            self.scene.frame_set(self.frame_before)
        finally:
            handlers.suspended = False
            self.st.baking = False


def remove_frame_keys(obj) -> None:
    """Remove the keys of an earlier bake with their keyframes (an F-curve left without
    keyframes goes with them)."""
    keys = obj.data.shape_keys
    if keys is None:
        return
    for kb in [kb for kb in keys.key_blocks if kb.name.startswith(FRAME_KEY_PREFIX)]:
        try:
            f = int(kb.name[len(FRAME_KEY_PREFIX):])
        except ValueError:
            f = None
        if f is not None and keys.animation_data is not None:
            for frame in (f - 1, f, f + 1):
                try:
                    kb.keyframe_delete("value", frame=frame)
                except RuntimeError:  # no keyframe there
                    pass
        obj.shape_key_remove(kb)


def write_shape_keys(obj, frames, poses) -> None:
    """One shape key per frame, its value keyed 1 at its frame and 0 at the neighbours; the live
    pose key is muted (the bake replaces it)."""
    remove_frame_keys(obj)
    solve.ensure_pose_key(obj).mute = True
    for f, U in zip(frames, poses):
        kb = obj.shape_key_add(name=frame_key_name(f), from_mix=False)
        kb.points.foreach_set("co", np.ascontiguousarray(U, dtype=np.float32).ravel())
        for frame, value in ((f - 1, 0.0), (f, 1.0), (f + 1, 0.0)):
            kb.value = value
            kb.keyframe_insert("value", frame=frame)
    obj.data.update()


def write_pc2(path: str, poses, start_frame: float, sample_rate: float = 1.0) -> None:
    """Write ``poses`` (a sequence of ``(n, 3)``) as a PC2 file."""
    arr = np.ascontiguousarray(np.stack(poses), dtype="<f4")
    n_samples, n_points, _ = arr.shape
    header = PC2_MAGIC + struct.pack("<iiffi", 1, n_points, float(start_frame), float(sample_rate), n_samples)
    with open(path, "wb") as f:
        f.write(header)
        f.write(arr.tobytes())


def read_pc2(path: str):
    """``(start_frame, sample_rate, samples (s, n, 3))`` of a PC2 file."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:12] != PC2_MAGIC:
        raise ValueError(f"{path}: not a PC2 file")
    _version, n, start, rate, s = struct.unpack("<iiffi", data[12:32])
    arr = np.frombuffer(data, dtype="<f4", offset=32, count=s * n * 3).reshape(s, n, 3)
    return start, rate, arr


def add_cache_modifier(obj, path: str, start_frame: int):
    """The Mesh Cache modifier reading ``path``, first in the stack; the live pose key is
    muted (the cache overwrites the positions)."""
    mod = obj.modifiers.get(solve.CACHE_MODIFIER)
    if mod is None or mod.type != "MESH_CACHE":
        mod = obj.modifiers.new(solve.CACHE_MODIFIER, "MESH_CACHE")
    mod.cache_format = "PC2"
    mod.filepath = path
    mod.time_mode = "FRAME"
    mod.play_mode = "SCENE"
    # Blender's reader takes sample (scene frame - frame_start) in FRAME mode, whatever the
    # file's startFrame says (measured in bpy 5.0.1: with 0 here, frame 1 showed sample 1).
    mod.frame_start = float(start_frame)
    mod.frame_scale = 1.0
    mod.deform_mode = "OVERWRITE"
    mod.interpolation = "NONE"
    idx = list(obj.modifiers).index(mod)
    if idx != 0:
        obj.modifiers.move(idx, 0)
    if obj.data.shape_keys is not None:
        kb = obj.data.shape_keys.key_blocks.get(solve.POSE_KEY)
        if kb is not None:
            kb.mute = True
    return mod
