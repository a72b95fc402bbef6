"""The operators, ``bpy.ops.bsarap.*``. Bad input ends in ``self.report({'ERROR'}, ...)`` (the
status bar; a RuntimeError with the message for scripts), never a traceback. Those that read the
mesh refuse Edit Mode (its data is stale there): their poll fails with a message."""

from __future__ import annotations

import os

import bpy
import numpy as np
from bpy.props import IntProperty, StringProperty
from mathutils import Matrix

from . import bake, claims, handles, solve
from .handles import HandleError


def _mesh_object(context):
    obj = context.object
    return obj if obj is not None and obj.type == "MESH" else None


class _MeshOperator:
    bl_options = {"REGISTER", "UNDO"}
    #: Whether the operator runs in Edit Mode (it does not read the mesh's data).
    in_edit_mode = False

    @classmethod
    def poll(cls, context):
        obj = _mesh_object(context)
        if obj is None:
            return False
        if obj.mode == "EDIT" and not cls.in_edit_mode:
            cls.poll_message_set("BS-ARAP works in Object Mode: leave Edit Mode first")
            return False
        # Pose Now or Add Controls mid-bake wrote a pose key and moved the bake's solver to
        # another start; the bake's panel lets clicks through.
        if solve.baking(obj):
            cls.poll_message_set(bake.under_way(obj))
            return False
        return True


class BSARAP_OT_add_group(_MeshOperator, bpy.types.Operator):
    """Use a vertex group (the active one by default) as a handle group"""

    bl_idname = "bsarap.add_group"
    bl_label = "Add Handle Group"
    in_edit_mode = True

    group: StringProperty(name="Vertex group", description="Empty: the active vertex group")

    def execute(self, context):
        obj = _mesh_object(context)
        name = self.group
        if not name:
            vg = obj.vertex_groups.active
            if vg is None:
                self.report({"ERROR"}, f"{obj.name}: the mesh has no vertex groups; create or paint one first")
                return {"CANCELLED"}
            name = vg.name
        if obj.vertex_groups.get(name) is None:
            self.report({"ERROR"}, f"{obj.name}: no vertex group '{name}'")
            return {"CANCELLED"}
        if any(g.name == name for g in obj.bsarap.groups):
            self.report({"WARNING"}, f"'{name}' is already a handle group")
            return {"CANCELLED"}
        item = obj.bsarap.groups.add()
        item.name = name
        obj.bsarap.active_group = len(obj.bsarap.groups) - 1
        return {"FINISHED"}


class BSARAP_OT_remove_group(_MeshOperator, bpy.types.Operator):
    """Stop using the selected handle group (its control Empty stays in the scene)"""

    bl_idname = "bsarap.remove_group"
    bl_label = "Remove Handle Group"
    in_edit_mode = True

    def execute(self, context):
        s = _mesh_object(context).bsarap
        if not 0 <= s.active_group < len(s.groups):
            self.report({"ERROR"}, "no handle group selected")
            return {"CANCELLED"}
        s.groups.remove(s.active_group)
        s.active_group = max(0, min(s.active_group, len(s.groups) - 1))
        return {"FINISHED"}


def _copied_control(obj, control):
    """Where a copy's own control goes: placed on ``obj`` as ``control`` is on the object that
    claimed it (so the copy keeps that pose); ``None`` when that object is gone or singular."""
    other = claims.owner(control)
    if other is None:
        return None
    try:
        return obj.matrix_world @ other.matrix_world.inverted() @ control.matrix_world
    except ValueError:  # a scale of 0: no inverse
        return None


class BSARAP_OT_add_controls(_MeshOperator, bpy.types.Operator):
    """Create one Empty per handle group at its centroid (named after the group, no parent); moving,
    rotating or keying them poses the mesh. A control deleted from the scene is re-created; a copy
    of a posed object gets its own, placed as the original's"""

    bl_idname = "bsarap.add_controls"
    bl_label = "Add Controls"

    def execute(self, context):
        obj = _mesh_object(context)
        try:
            if len(obj.vertex_groups) == 0:
                raise HandleError(f"{obj.name}: the mesh has no vertex groups; create or paint one first")
            solve.check_mesh_writable(obj)  # library data: before any claim
            other = claims.mesh_sharer(obj)
            if other is not None:
                # a linked duplicate: its own controls would fight over the shared pose key
                raise HandleError(claims.shared_mesh_message(obj, other))
            foreign = claims.foreign_groups(obj)
            solve.forget(obj)  # an explicit rebuild: the rest mesh may have been edited
            st = solve.state(obj)
        except HandleError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        foreign = dict(foreign)
        n = len(st.group_names)
        cent = handles.centroids(st.rest, st.labels, n)
        size = 0.05 * float(np.linalg.norm(st.rest.max(axis=0) - st.rest.min(axis=0)))
        coll = obj.users_collection[0] if obj.users_collection else context.scene.collection
        O = obj.matrix_world.copy()
        made, recreated, copied = 0, [], []
        for k, g in enumerate(obj.bsarap.groups):
            place = None
            if g.name in foreign:
                # another object's (this is a copy of it): that one keeps it
                place = _copied_control(obj, g.control)
                copied.append(g.name)
                g.control = None
            elif claims.linked(g.control):
                continue
            elif g.control is not None:
                # deleted in the viewport: in no scene, kept only by this pointer
                recreated.append(g.name)
                old, g.control = g.control, None
                if old.users == 0:
                    bpy.data.objects.remove(old)
            e = bpy.data.objects.new(g.name, None)
            e.empty_display_type = "SPHERE"
            e.empty_display_size = max(size, 1e-3)
            coll.objects.link(e)
            g.control = e
            e.bsarap_owner = obj  # its claim, saved in the file
            if place is not None:
                # the original's motion since its rest (the copied rest_matrix): the same pose
                e.matrix_world = place
            else:
                e.matrix_world = O @ Matrix.Translation(cent[k])
                # The control's rest, relative to the object: O^-1 E = the centroid's translation.
                g.rest_matrix = [x for row in Matrix.Translation(cent[k]) for x in row]
            made += 1
        solve.ensure_pose_key(obj)
        try:
            solve.update(obj, force=True)
        except HandleError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        again = f" (re-created, deleted from the scene: {', '.join(recreated)})" if recreated else ""
        if copied:
            again += f" (its own for {', '.join(copied)}, whose controls posed another object; the pose kept)"
        self.report(
            {"INFO"}, f"{obj.name}: {made} control(s) added{again}, {n} handle group(s), {st.deformer.method}"
        )
        warning = solve.scale_warning(obj)
        if warning:
            self.report({"WARNING"}, warning)
        return {"FINISHED"}


class BSARAP_OT_pose(_MeshOperator, bpy.types.Operator):
    """Solve the pose for the controls' current positions now"""

    bl_idname = "bsarap.pose"
    bl_label = "Pose Now"

    def execute(self, context):
        obj = _mesh_object(context)
        try:
            solve.update(obj, force=True)
        except HandleError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        st = solve.state(obj)
        stats = st.deformer.stats
        if stats is not None:
            self.report({"INFO"}, f"{obj.name}: {stats.iterations} iterations, {st.last_ms:.1f} ms")
        return {"FINISHED"}


class BSARAP_OT_remove_controls(_MeshOperator, bpy.types.Operator):
    """Delete the control Empties and the pose shape key; the mesh is back at rest. A copy lets go
    of the controls it shares with its original without deleting them"""

    bl_idname = "bsarap.remove_controls"
    bl_label = "Remove Controls"

    def execute(self, context):
        obj = _mesh_object(context)
        foreign = dict(claims.foreign_groups(obj))
        # a linked duplicate's pose key is its original's too
        shared = claims.mesh_sharer(obj) is not None
        for g in obj.bsarap.groups:
            if g.control is not None:
                if g.name not in foreign:
                    bpy.data.objects.remove(g.control)
                g.control = None
        keys = obj.data.shape_keys
        if not shared and keys is not None and keys.key_blocks.get(solve.POSE_KEY) is not None:
            obj.shape_key_remove(keys.key_blocks[solve.POSE_KEY])
            keys.pop(solve.BAKE_MUTED, None)  # of the key just removed
            _drop_lone_basis(obj)
        solve.forget(obj)
        claims.release_mesh(obj)
        if foreign:
            self.report({"INFO"}, f"{obj.name}: let go of another object's controls ({', '.join(foreign)}), kept")
        return {"FINISHED"}


def _drop_lone_basis(obj) -> None:
    """Removes the shape keys when only the Basis the pose key needed is left (made for it,
    ``solve.MADE_BASIS``): with any shape key Blender refuses to apply a modifier. The basis's
    coordinates go into the mesh first, so nothing moves. A Basis of the user's stays."""
    keys = obj.data.shape_keys
    if keys is None or len(keys.key_blocks) != 1 or not keys.get(solve.MADE_BASIS):
        return
    basis = keys.key_blocks[0]
    co = np.empty(len(basis.data) * 3, dtype=np.float32)
    basis.data.foreach_get("co", co)
    obj.shape_key_clear()
    obj.data.vertices.foreach_set("co", co)
    obj.data.update()


class _BakeOperator(_MeshOperator):
    """Shared by both bakes: ``execute`` bakes in one loop (scripts, background mode);
    ``invoke`` bakes one frame per timer event with the progress indicator, Esc cancels."""

    frame_start: IntProperty(name="Start", description="0 with End 0: the scene's range", default=0)
    frame_end: IntProperty(name="End", default=0)

    def frames(self, scene):
        if self.frame_start == 0 and self.frame_end == 0:
            return range(scene.frame_start, scene.frame_end + 1, max(1, scene.frame_step))
        return range(self.frame_start, self.frame_end + 1)

    def start(self, context):
        obj = _mesh_object(context)
        frames = self.frames(context.scene)
        if len(frames) == 0:
            raise HandleError("the frame range is empty")
        solve.check_controls(obj)  # what is wrong with the object first (the Baker checks again)
        self.check_output(obj)
        return bake.Baker(context.scene, obj, frames)

    def check_output(self, obj) -> None:
        """Raise :class:`HandleError` when the bake could not be written (before solving)."""

    def finish(self, context, baker) -> str:
        raise NotImplementedError

    def execute(self, context):
        wm = context.window_manager
        try:
            baker = self.start(context)
            wm.progress_begin(0, len(baker.frames))
            try:
                while not baker.done:
                    baker.step()
                    wm.progress_update(len(baker.poses))
            finally:
                wm.progress_end()
                baker.restore_frame()
            msg = self.finish(context, baker)
        except Exception as e:  # noqa: BLE001 - a message, not a traceback
            self.report({"ERROR"}, _bake_error(e))
            return {"CANCELLED"}
        self.report({"INFO"}, msg)
        return {"FINISHED"}

    def invoke(self, context, _event):
        if context.window is None:
            return self.execute(context)
        try:
            self._baker = self.start(context)
        except Exception as e:  # noqa: BLE001 - a message, not a traceback
            self.report({"ERROR"}, _bake_error(e))
            return {"CANCELLED"}
        wm = context.window_manager
        wm.progress_begin(0, len(self._baker.frames))
        self._timer = wm.event_timer_add(0.0, window=context.window)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _stop(self, context):
        """End the modal bake: the timer, the progress indicator and the bake's state (each
        even when another fails)."""
        wm = context.window_manager
        try:
            wm.event_timer_remove(self._timer)
        finally:
            try:
                wm.progress_end()
            finally:
                self._baker.restore_frame()

    def cancel(self, context):
        """Blender ends the modal bake itself (its window closed, a file loaded): the bake's
        state ends too, else live posing stayed stopped and the next bake refused."""
        baker = getattr(self, "_baker", None)
        if baker is not None and baker.st.baking:
            self._stop(context)

    def modal(self, context, event):
        if event.type == "ESC":
            self._stop(context)
            self.report({"WARNING"}, f"bake cancelled after {len(self._baker.poses)} frame(s); nothing written")
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        try:
            self._baker.step()
            context.window_manager.progress_update(len(self._baker.poses))
            if not self._baker.done:
                return {"RUNNING_MODAL"}
            self._stop(context)
            msg = self.finish(context, self._baker)
        except Exception as e:  # noqa: BLE001 - a message, not a traceback; never left baking
            if self._baker.st.baking:
                self._stop(context)
            self.report({"ERROR"}, _bake_error(e))
            return {"CANCELLED"}
        self.report({"INFO"}, msg)
        return {"FINISHED"}


class BSARAP_OT_bake_shape_keys(_BakeOperator, bpy.types.Operator):
    """Solve every frame of the scene's range into its own shape key, keyed on at its frame"""

    bl_idname = "bsarap.bake_shape_keys"
    bl_label = "Bake to Shape Keys"

    def finish(self, context, baker):
        bake.write_shape_keys(baker.obj, baker.frames, baker.poses)
        baker.obj.bsarap.live = False
        return f"{baker.obj.name}: {len(baker.frames)} frames baked to shape keys (Live turned off)"


def _bake_error(e: Exception) -> str:
    """The status bar's message for a bake that failed with ``e``."""
    if isinstance(e, (HandleError, OSError)):
        return str(e)
    if isinstance(e, ReferenceError):  # an undo removed what the bake held
        return "the object or its scene changed while baking (undo?); bake stopped, nothing written"
    return f"bake stopped by an unexpected error ({type(e).__name__}: {e}); nothing written"


def pc2_path(obj) -> str:
    """The absolute path of the object's point cache: its *Point cache* setting, else next to
    the .blend. Raises :class:`HandleError` when that needs a saved .blend and there is none
    (Blender's temporary folder is deleted when it quits)."""
    p = obj.bsarap.pc2_path
    if not bpy.data.filepath and (not p or p.startswith("//")):
        raise HandleError(
            f"{obj.name}: save the .blend file first (the point cache goes next to it), "
            "or set the Point cache path to an absolute one"
        )
    if p:
        return bpy.path.abspath(p)
    return os.path.join(os.path.dirname(bpy.data.filepath), f"{bpy.path.clean_name(obj.name)}.bsarap.pc2")


def _same_file(path: str) -> str:
    """``path`` made comparable with another path to the same file."""
    return os.path.normcase(os.path.realpath(path))


def _claimed_file(claim) -> str:
    """The file a claim names, comparable (:func:`_same_file`): kept as the modifier keeps its
    path (``//``-relative once the .blend is saved), so a moved project keeps its claims."""
    return _same_file(bpy.path.abspath(claim.path, library=claim.id_data.library))


def cache_claims(path: str) -> list:
    """The claims of the point cache file ``path`` (``Scene.bsarap_caches``, in every scene):
    each names the object whose bake wrote the file. Scene data, which Shift+D does not copy."""
    want = _same_file(path)
    return [c for sc in bpy.data.scenes for c in sc.bsarap_caches if c.path and _claimed_file(c) == want]


def claim_cache(scene, path: str, obj) -> None:
    """Record that ``obj``'s bake wrote the file ``path`` (the file's claims before go)."""
    want = _same_file(path)
    for sc in bpy.data.scenes:
        for i in reversed(range(len(sc.bsarap_caches))):
            c = sc.bsarap_caches[i]
            if not c.path or _claimed_file(c) == want:
                sc.bsarap_caches.remove(i)
    claim = scene.bsarap_caches.add()
    claim.path, claim.owner = stored_path(path), obj


def _reader(o, want: str):
    """The Mesh Cache modifier of ``o`` that reads the file ``want`` (:func:`_same_file`), or
    ``None``."""
    for m in o.modifiers:
        if m.type == "MESH_CACHE" and m.filepath:
            if _same_file(bpy.path.abspath(m.filepath, library=o.library)) == want:
                return m
    return None


def cache_readers(obj, path: str) -> list:
    """``[(object, modifier)]``: the Mesh Cache modifiers that read the file ``path``, of the
    objects in a scene other than ``obj`` (a deleted object, kept in ``bpy.data``, reads
    nothing)."""
    want = _same_file(path)
    found = ((o, _reader(o, want)) for o in bpy.data.objects if o != obj and claims.linked(o))
    return [(o, m) for o, m in found if m is not None]


def _path_taken(obj, path: str):
    """Why ``obj`` may not bake into ``path``, or ``None``. A file is taken when a bake of
    another object, in a scene and still reading it, claimed it (:func:`claim_cache`; a scene
    copied whole copies its claims, so two objects may claim one file: neither bakes into it).
    A file no bake of ``obj`` claimed (one baked before claims were kept, or the user's own
    cache) is taken when another object in a scene reads it, also when ``obj`` reads it too: a
    Shift+D copy reads its original's file, and which of them baked it is not known."""
    want = _same_file(path)
    owners = [c.owner for c in cache_claims(path) if c.owner is not None]
    others = [o for o in owners if o != obj and claims.linked(o) and _reader(o, want) is not None]
    if others:
        return f"holds the bake of '{others[0].name}'"
    if obj in owners:
        return None
    readers = cache_readers(obj, path)
    if readers:
        other, mod = readers[0]
        return f"is read by '{other.name}' (its modifier '{mod.name}') and was not baked from {obj.name}"
    return None


def pc2_target(obj) -> str:
    """Where Bake to point cache writes for ``obj`` (:func:`pc2_path`). Raises
    :class:`HandleError` when that file is another object's (:func:`_path_taken`): baking
    would overwrite it."""
    path = pc2_path(obj)
    taken = _path_taken(obj, path)
    if taken:
        raise HandleError(
            f"{obj.name}: the point cache {path} {taken}: baking {obj.name} would overwrite it; "
            f"set another Point cache path for {obj.name}"
        )
    return path


def stored_path(path: str) -> str:
    """``path`` as the modifier keeps it: relative to the .blend (``//...``) once it is saved,
    so the file and its cache move together."""
    if not bpy.data.filepath:
        return path
    try:
        return bpy.path.relpath(path)
    except ValueError:  # another drive (Windows): no relative path
        return path


class BSARAP_OT_bake_point_cache(_BakeOperator, bpy.types.Operator):
    """Solve every frame of the scene's range into a PC2 point cache read by a Mesh Cache modifier"""

    bl_idname = "bsarap.bake_point_cache"
    bl_label = "Bake to Point Cache"

    def check_output(self, obj):
        pc2_target(obj)

    def finish(self, context, baker):
        path = pc2_target(baker.obj)  # again: the paths may have changed while it baked
        bake.write_pc2(path, baker.poses, baker.frames[0], baker.step_frames)
        bake.add_cache_modifier(baker.obj, stored_path(path), baker.frames[0], baker.step_frames)
        claim_cache(baker.scene, path, baker.obj)
        baker.obj.bsarap.live = False
        return f"{baker.obj.name}: {len(baker.frames)} frames written to {path} (Live turned off)"


classes = (
    BSARAP_OT_add_group,
    BSARAP_OT_remove_group,
    BSARAP_OT_add_controls,
    BSARAP_OT_pose,
    BSARAP_OT_remove_controls,
    BSARAP_OT_bake_shape_keys,
    BSARAP_OT_bake_point_cache,
)


def register():
    for c in classes:
        bpy.utils.register_class(c)


def unregister():
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
