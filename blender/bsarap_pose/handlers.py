"""Live posing: after every depsgraph update and frame change, each object with controls (and
Live on) is solved again when one of its controls moved.

Once the controls stop, a timer (``finish_timer``) takes each pose the rest of the way
(``solve.finish_step``): solved until converged, then settled, as the editor does after a drag.

Re-entrancy: writing the pose shape key triggers another depsgraph update. ``_busy`` stops a
nested call, and ``solve.update`` skips objects whose controls have not moved since their last
solve, so the update that follows our own write solves nothing.

Objects in Edit Mode are skipped (``solve.editing``). While Blender renders (``render_init`` /
``render_pre`` to ``render_complete`` / ``render_cancel``) nothing is solved: handlers that change
data during a render can crash Blender, so an animation is baked before it is rendered. An error
is kept as the object's message (the panel shows it) and printed once, never a traceback per
update.

Undo and redo bring back an undo step's pose keys, maybe a pose that had not settled: each
solver's last motion is forgotten (``solve.undone``), so the update that follows solves the pose
again and the timer settles it; the panel never calls the undone pose at rest. The undone step's
vertex weights are read again (a paint undone in Object Mode).

Each update first drops what is kept for objects deleted since (``solve.prune``): when the objects
in the scenes changed, by their session uids (an object deleted and another added in one update
leave the counts as they were), and tends the claims (``claims.tend_claims``). A loaded file
starts the caches again; the claims of controls and meshes are saved in it (``claims.owner``,
``claims.mesh_owner``), so a file saved with a copy that shares its original's controls keeps
them with the original; a file saved before they were gets them on load, and the open file when
the extension is enabled (``claims.claim_unclaimed``).
"""

from __future__ import annotations

import bpy
import numpy as np
from bpy.app.handlers import persistent

from . import claims, solve
from .handles import HandleError

_busy = False
#: Set while a bake runs: it drives the frames and solves itself.
suspended = False
#: Set while Blender renders: no data may change then.
rendering = False


def posed_objects(scene):
    """The meshes with Live on and controls in the scene (a group without one is reported by
    the solve), not in Edit Mode. The mode of every mesh with handle groups is noted on the way
    (``solve.editing``), Live on or off: leaving a mode that edits weights reads them again."""
    for obj in scene.objects:
        if obj.type != "MESH" or not len(obj.bsarap.groups):
            continue
        try:
            if solve.editing(obj):
                continue
        except Exception as e:  # noqa: BLE001 - a bug: said, and the other objects go on
            report(obj, e)
            continue
        if obj.bsarap.live and any(claims.linked(g.control) for g in obj.bsarap.groups):
            yield obj


def alive_objects() -> set:
    """The session uids of the objects in the scenes (a deleted one is in none)."""
    return {o.session_uid for sc in bpy.data.scenes for o in sc.objects}


#: The objects (:func:`scene_objects`) at the last prune (``None``: prune at the next update).
_pruned_at = None


def _uids(collection) -> bytes:
    """The session uids of the objects of ``collection`` (``claims.object_uids``), as bytes."""
    return claims.object_uids(collection).tobytes()


def scene_objects() -> tuple:
    """The number of objects in ``bpy.data`` and the session uids of each scene's objects: a
    deletion changes it (the deleted object may stay in ``bpy.data``, held by a pointer such as
    a control's claim, but leaves its scenes), also with another object added in the same update
    (uids are never reused in a session)."""
    return len(bpy.data.objects), tuple(_uids(sc.objects) for sc in bpy.data.scenes)


def prune() -> None:
    """Drop what is kept for deleted objects (``solve.prune``), only when the objects in the
    scenes changed since the last prune: walking every scene's objects in Python on every update
    costs on a big scene. The claims of an object in no scene are ignored anyway
    (``claims.owner``, ``claims.mesh_owner``)."""
    global _pruned_at
    n = scene_objects()
    if n == _pruned_at:
        return
    if solve.tracked():
        solve.prune(alive_objects())
    claims.tend_claims()
    _pruned_at = scene_objects()  # dropping a claim may free a deleted object


def update_scene(scene) -> None:
    global _busy
    if _busy or suspended or rendering:
        return
    _busy = True
    finishing = False  # whether a pose has finishing steps to take (solve.update)
    try:
        prune()
        for obj in posed_objects(scene):
            try:
                finishing |= solve.update(obj)
            except Exception as e:  # noqa: BLE001 - a message, not a traceback per update
                report(obj, e)
    finally:
        _busy = False
    if finishing and not bpy.app.timers.is_registered(finish_timer):
        bpy.app.timers.register(finish_timer, first_interval=solve.REST_DELAY)


def report(obj, e: Exception) -> None:
    """Keep ``e`` as the object's message (the panel shows it) and print it, once; an exception
    other than :class:`HandleError` (a bug) is named as unexpected."""
    msg = str(e) if isinstance(e, HandleError) else f"{obj.name}: unexpected error ({type(e).__name__}: {e})"
    if solve.message(obj) != msg:  # say it once, not on every update
        solve.report_error(obj, msg)
        print(f"BS-ARAP: {msg}")


def finish_timer():
    """``bpy.app.timers``: one ``solve.finish_step`` for each posed object whose controls
    rest; runs again when the next step is due, and ends when no pose has anything left (the
    next solve registers it again)."""
    global _busy
    if _busy or suspended or rendering:
        return solve.REST_DELAY
    _busy = True
    due = []
    try:
        for obj in posed_objects(bpy.context.scene):
            try:
                due.append(solve.finish_step(obj))
            except HandleError as e:
                # a failed check (a singular transform, a deleted control): the live update
                # clears it once the object poses (a failed solve or settle step ends in
                # finish_step itself)
                report(obj, e)
            except Exception as e:  # noqa: BLE001 - a message, not a traceback per step
                st = solve.built(obj)
                if st is not None:  # a bug: it would fail again at each step
                    st.ended = "error"
                report(obj, e)
    finally:
        _busy = False
    if not due or any(d is None or d == 0.0 for d in due):
        redraw_sidebars()  # a step ran, failed or ended: the panel's status changed
    due = [d for d in due if d is not None]
    return min(due) if due else None


def redraw_sidebars() -> None:
    """Redraw the 3D viewports (their sidebars show the status): the sidebar redraws on
    events only, and a timer's step is not one."""
    for window in bpy.context.window_manager.windows:
        for area in window.screen.areas:
            if area.type == "VIEW_3D":
                area.tag_redraw()


@persistent
def on_depsgraph_update(scene, _depsgraph=None):
    update_scene(scene)


@persistent
def on_frame_change(scene, _depsgraph=None):
    update_scene(scene)


@persistent
def on_load(_filepath=None, _unused=None):
    """Another file: its objects are not those the cached solvers were built for (the claims
    are in the file; one saved before they were gets them now)."""
    global _pruned_at, rendering
    _pruned_at = None
    # A render whose output failed to start ends without render_complete or render_cancel:
    # another file at least poses again.
    rendering = False
    solve.forget()
    claims.claim_unclaimed()


@persistent
def on_undo(_scene=None, _unused=None):
    """Undo or redo: the pose keys are the undo step's, perhaps short of the rest the solvers
    reached since (``solve.undone``); the depsgraph update that follows solves them again."""
    solve.undone(o for o in bpy.data.objects if o.type == "MESH" and len(o.bsarap.groups))


@persistent
def on_render_start(_scene=None, _unused=None):
    global rendering
    rendering = True


@persistent
def on_render_end(_scene=None, _unused=None):
    global rendering
    rendering = False


_handlers = (
    ("depsgraph_update_post", on_depsgraph_update),
    ("frame_change_post", on_frame_change),
    ("load_post", on_load),
    ("undo_post", on_undo),
    ("redo_post", on_undo),
    ("render_init", on_render_start),
    ("render_pre", on_render_start),
    ("render_complete", on_render_end),
    ("render_cancel", on_render_end),
)


def register():
    for name, fn in _handlers:
        getattr(bpy.app.handlers, name).append(fn)
    # Enabled in an open file (not at startup, where bpy.data is not readable yet and on_load
    # follows): its unclaimed controls are claimed as on load.
    if isinstance(bpy.data, bpy.types.BlendData):
        claims.claim_unclaimed()


def unregister():
    global rendering
    if bpy.app.timers.is_registered(finish_timer):
        bpy.app.timers.unregister(finish_timer)
    for name, fn in _handlers:
        lst = getattr(bpy.app.handlers, name)
        while fn in lst:
            lst.remove(fn)
    rendering = False
    solve.forget()
