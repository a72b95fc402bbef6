"""Live posing: after every depsgraph update and frame change, each object with controls (and
Live on) is solved again when one of its controls moved.

Re-entrancy: writing the pose shape key triggers another depsgraph update. ``_busy`` stops a
nested call, and ``solve.update`` skips objects whose controls have not moved since their last
solve, so the update that follows our own write solves nothing.
"""

from __future__ import annotations

import bpy
from bpy.app.handlers import persistent

from . import solve
from .handles import HandleError

_busy = False
#: Set while a bake runs: it drives the frames and solves itself.
suspended = False


def posed_objects(scene):
    """The meshes with Live on and controls (a group without one is reported by the solve)."""
    for obj in scene.objects:
        if obj.type == "MESH" and obj.bsarap.live and any(g.control is not None for g in obj.bsarap.groups):
            yield obj


def update_scene(scene) -> None:
    global _busy
    if _busy or suspended:
        return
    _busy = True
    try:
        for obj in posed_objects(scene):
            try:
                solve.update(obj)
            except HandleError as e:
                msg = str(e)
                if solve.messages.get(obj.name) != msg:  # say it once, not on every update
                    solve.messages[obj.name] = msg
                    print(f"BS-ARAP: {msg}")
    finally:
        _busy = False


@persistent
def on_depsgraph_update(scene, _depsgraph=None):
    update_scene(scene)


@persistent
def on_frame_change(scene, _depsgraph=None):
    update_scene(scene)


@persistent
def on_load(_filepath=None, _unused=None):
    """Another file: its objects are not those the cached solvers were built for."""
    solve.forget()


_handlers = (
    ("depsgraph_update_post", on_depsgraph_update),
    ("frame_change_post", on_frame_change),
    ("load_post", on_load),
)


def register():
    for name, fn in _handlers:
        getattr(bpy.app.handlers, name).append(fn)


def unregister():
    for name, fn in _handlers:
        lst = getattr(bpy.app.handlers, name)
        while fn in lst:
            lst.remove(fn)
    solve.forget()
