"""Baking the controls' animation over the scene's frame range: into shape keys (one per frame,
keyed on at its frame and off at the neighbouring baked frames, linearly in between) or into a
PC2 point cache read by a Mesh Cache modifier. With a frame step (``scene.frame_step``) only
every step-th frame is solved; the frames in between blend the two nearest baked ones.

PC2 (little-endian; the format of the solver's ``animation::pointcache`` writer, which the
Python module does not expose, so it is written here): a 32-byte header ``"POINTCACHE2\\0"``,
``i32`` version 1, ``i32`` numPoints, ``f32`` startFrame, ``f32`` sampleRate (1: one sample per
frame), ``i32`` numSamples, then numSamples x numPoints x 3 ``f32``.
"""

from __future__ import annotations

import struct

import numpy as np

from . import handlers, modifiers, solve
from .handles import HandleError

FRAME_KEY_PREFIX = "BS-ARAP frame "
PC2_MAGIC = b"POINTCACHE2\0"


def frame_key_name(frame: int) -> str:
    return f"{FRAME_KEY_PREFIX}{frame:04d}"


def under_way(obj) -> str:
    """What refuses another bake, or an operator, while ``obj`` is being baked."""
    return f"{obj.name}: a bake is under way; wait for it to end (Esc stops it)"


class Baker:
    """Solves the frames ``frames`` of ``obj`` one :meth:`step` at a time (for the modal
    operator), warm-starting each frame from the previous one."""

    def __init__(self, scene, obj, frames):
        self.scene, self.obj, self.frames = scene, obj, list(frames)
        self.name = obj.name
        self.uid = solve.uid(obj)  # an undo replaces obj's Python object, not its session uid
        solve.check_controls(obj)  # a copy's controls pose its original: no bake
        self.st = solve.state(obj)
        if self.st.baking:
            # Two at once: the first to end restored the frame and let live posing go on
            # while the other still solved.
            raise HandleError(under_way(obj))
        self.st.baking = True  # until restore_frame: the live pose's finishing steps wait
        self.poses = []
        self.frame_before = scene.frame_current

    @property
    def done(self) -> bool:
        return len(self.poses) == len(self.frames)

    @property
    def step_frames(self) -> int:
        """Frames between two baked frames (the scene's frame step)."""
        return self.frames[1] - self.frames[0] if len(self.frames) > 1 else 1

    def check(self) -> None:
        """Raise :class:`HandleError` when the bake cannot go on: its object or scene is gone
        (an undo while it ran) or the object is in Edit Mode."""
        try:
            self.scene.frame_current
            mode = self.obj.mode
        except ReferenceError:
            raise HandleError(
                f"{self.name}: the object or its scene changed while baking (undo?); bake stopped, nothing written"
            ) from None
        if mode == "EDIT":
            raise HandleError(f"{self.name}: in Edit Mode; bake stopped, nothing written")

    def step(self) -> None:
        self.check()
        f = self.frames[len(self.poses)]
        handlers.suspended = True
        try:
            self.scene.frame_set(f)
        finally:
            handlers.suspended = False
        self.poses.append(solve.solve(self.obj, self.st, solve.control_deltas(self.obj)))

    def restore_frame(self) -> None:
        """The frame the bake started at, without a live solve; ends the bake (also when the
        scene is gone)."""
        handlers.suspended = True
        try:
            self.scene.frame_set(self.frame_before)
        except ReferenceError:  # the scene went with an undo: nothing to restore
            pass
        finally:
            handlers.suspended = False
            self.st.baking = False
            solve.bake_ended(self.uid)


def _fcurves(keys):
    """The F-curves animating the shape keys ``keys`` (a ``Key``), or ``None``: the action's
    channelbag for its slot (Blender 4.4+), else the action's own list."""
    ad = keys.animation_data
    if ad is None or ad.action is None:
        return None
    try:
        from bpy_extras.anim_utils import action_get_channelbag_for_slot
    except ImportError:  # Blender before 4.4: one F-curve list per action
        return ad.action.fcurves
    bag = action_get_channelbag_for_slot(ad.action, ad.action_slot)
    return None if bag is None else bag.fcurves


def _value_path(kb) -> str:
    return f'key_blocks["{kb.name}"].value'


def remove_frame_keys(obj) -> None:
    """Remove the keys of an earlier bake with their F-curves (whatever its frame step)."""
    keys = obj.data.shape_keys
    if keys is None:
        return
    for kb in [kb for kb in keys.key_blocks if kb.name.startswith(FRAME_KEY_PREFIX)]:
        fcurves = _fcurves(keys)
        fc = fcurves.find(_value_path(kb)) if fcurves is not None else None
        if fc is not None:
            fcurves.remove(fc)
        obj.shape_key_remove(kb)


def write_shape_keys(obj, frames, poses) -> None:
    """One shape key per frame, its value keyed 1 at its frame and 0 at the neighbouring baked
    frames (``frames`` evenly spaced), linear in between: a frame between two baked ones (a
    frame step above 1) blends them. The live pose key is muted (the bake replaces it)."""
    remove_frame_keys(obj)
    solve.mute_for_bake(obj)
    step = frames[1] - frames[0] if len(frames) > 1 else 1
    for f, U in zip(frames, poses):
        kb = obj.shape_key_add(name=frame_key_name(f), from_mix=False)
        kb.points.foreach_set("co", np.ascontiguousarray(U, dtype=np.float32).ravel())
        for frame, value in ((f - step, 0.0), (f, 1.0), (f + step, 0.0)):
            kb.value = value
            kb.keyframe_insert("value", frame=frame)
        fcurves = _fcurves(obj.data.shape_keys)
        fc = fcurves.find(_value_path(kb)) if fcurves is not None else None
        if fc is not None:
            for kp in fc.keyframe_points:
                kp.interpolation = "LINEAR"
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


def add_cache_modifier(obj, path: str, start_frame: int, step: int = 1):
    """The Mesh Cache modifier reading ``path`` (one sample per ``step`` frames from
    ``start_frame``; linear in between), first in the stack; the live pose key is muted (the
    cache overwrites the positions)."""
    mod = obj.modifiers.get(modifiers.CACHE_MODIFIER)
    if mod is None or mod.type != "MESH_CACHE":
        mod = obj.modifiers.new(modifiers.CACHE_MODIFIER, "MESH_CACHE")
    mod.cache_format = "PC2"
    mod.filepath = path
    mod.time_mode = "FRAME"
    mod.play_mode = "SCENE"
    # Blender's reader takes sample scene frame * frame_scale - frame_start in FRAME mode,
    # whatever the file's startFrame and sampleRate say (MOD_meshcache.cc; measured in bpy
    # 5.0.1: with 0 here, frame 1 showed sample 1).
    mod.frame_scale = 1.0 / step
    mod.frame_start = float(start_frame) / step
    mod.deform_mode = "OVERWRITE"
    mod.interpolation = "LINEAR"
    idx = list(obj.modifiers).index(mod)
    if idx != 0:
        obj.modifiers.move(idx, 0)
    if obj.data.shape_keys is not None and solve.POSE_KEY in obj.data.shape_keys.key_blocks:
        solve.mute_for_bake(obj)
    return mod
