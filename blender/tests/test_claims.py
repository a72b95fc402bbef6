"""Tests of the Blender extension in bpy, headless, around what belongs to which object: the
claims of a file saved before they were stored, the point cache of a copy of a baked object,
the panel's messages once their cause is gone, the solver of a deleted object, a library
override's mesh, an object removed by a script, a mesh's claim saved as a pointer on it, and
vertex weights edited after the controls were added.

Run with Blender's Python (bpy from PyPI):
    tools/blender/.venv/bin/python blender/tests/test_claims.py [-v] [Class.test_name]
The extension zip is found as common.py says. Skips (with the reason) when bpy or the zip is
missing.
"""

from __future__ import annotations

import os
import shutil
import sys
import tempfile
import types
import unittest
from unittest import mock

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import (  # noqa: E402  (sets BLENDER_USER_RESOURCES before bpy)
    MODULE, SKIP, activate, assert_pose_follows, bpy, draw_panel, duplicate, ext, fake_modal_bake,
    link_rig, posed_tube, setUpModule
)

if SKIP is None:
    import bmesh


def save_and_open(name):
    """Save the file in a new folder as ``name`` and open it again; returns its path."""
    path = os.path.join(tempfile.mkdtemp(), name)
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    return path


def claims():
    """``{name: owner name}`` of every control and mesh with a claim."""
    out = {o.name: o.bsarap_owner.name for o in bpy.data.objects if o.bsarap_owner is not None}
    for sc in bpy.data.scenes:
        out.update({m.owner.data.name: m.owner.name for m in sc.bsarap_meshes if m.owner})
    return out


def clear_claims():
    """As in a file saved before the claims were stored."""
    for o in bpy.data.objects:
        o.bsarap_owner = None
    for sc in bpy.data.scenes:
        sc.bsarap_meshes.clear()


class OldFile(unittest.TestCase):
    """A file saved before the claims were stored in it (commit 7938d5f), simulated by clearing
    them before saving: its objects get them on load where one object alone uses the control or
    the mesh, so a copy made after loading is refused. Live is off, as after a bake: no update
    claims the controls before the copy is posed."""

    def old_file(self, *, copy=False):
        obj = posed_tube(top_x=0.5)
        obj.bsarap.live = False
        if copy:
            duplicate(obj)
        clear_claims()
        save_and_open("old.blend")
        return bpy.data.objects["tube"]

    def test_copy_after_loading_refused(self):
        obj = self.old_file()
        self.assertEqual(claims(), {"bottom": "tube", "top": "tube", "tube": "tube"})
        dup = duplicate(obj)
        activate(dup)
        with self.assertRaises(RuntimeError) as cm:
            bpy.ops.bsarap.pose()
        self.assertIn("the controls of 'bottom', 'top' pose 'tube'", str(cm.exception))
        activate(obj)
        self.assertEqual(bpy.ops.bsarap.pose(), {"FINISHED"})
        assert_pose_follows(obj)

    def test_linked_duplicate_after_loading_refused(self):
        obj = self.old_file()
        dup = duplicate(obj, linked=True)
        activate(dup)
        self.assertEqual(bpy.ops.bsarap.remove_controls(), {"FINISHED"})  # lets go of tube's
        with self.assertRaises(RuntimeError) as cm:
            bpy.ops.bsarap.add_controls()
        self.assertIn("shares its mesh with 'tube', which poses it (a linked duplicate, Alt+D", str(cm.exception))

    def test_saved_with_a_copy_not_claimed(self):
        """An original and its copy saved sharing the controls: which is the original is not in
        the file, so nothing is claimed on load; the first posed takes them, as before."""
        self.old_file(copy=True)
        self.assertEqual(claims(), {"tube": "tube", "tube.001": "tube.001"})  # each its own mesh
        dup = bpy.data.objects["tube.001"]
        self.assertIs(dup.bsarap.groups[1].control, bpy.data.objects["top"])
        activate(bpy.data.objects["tube"])
        self.assertEqual(bpy.ops.bsarap.pose(), {"FINISHED"})
        activate(dup)
        with self.assertRaises(RuntimeError):
            bpy.ops.bsarap.pose()

    def test_claimed_when_enabled(self):
        """The extension enabled with such a file open: claimed as on load."""
        obj = self.old_file()
        clear_claims()  # as opened with the extension disabled
        bpy.ops.preferences.addon_disable(module=MODULE)
        bpy.ops.preferences.addon_enable(module=MODULE)
        self.assertEqual(claims(), {"bottom": "tube", "top": "tube", "tube": "tube"})
        dup = duplicate(obj)
        activate(dup)
        with self.assertRaises(RuntimeError):
            bpy.ops.bsarap.pose()


class CopyPointCache(unittest.TestCase):
    """A copy of a baked object (Shift+D) has its Point cache path: once it has its own
    controls, baking it must not overwrite the original's cache file."""

    def setUp(self):
        self.obj = posed_tube(top_x=0.5)
        self.folder = tempfile.mkdtemp()
        bpy.ops.wm.save_as_mainfile(filepath=os.path.join(self.folder, "scene.blend"))
        sc = bpy.context.scene
        sc.frame_start, sc.frame_end = 1, 3

    def bake_copy(self, setting):
        """Bake the original with Point cache ``setting``, copy it, give the copy its own
        controls and move one; returns the copy and the original's cache (path, bytes)."""
        obj = self.obj
        obj.bsarap.pc2_path = setting
        activate(obj)
        self.assertEqual(bpy.ops.bsarap.bake_point_cache(), {"FINISHED"})
        path = bpy.path.abspath(obj.modifiers[ext.modifiers.CACHE_MODIFIER].filepath)
        with open(path, "rb") as f:
            data = f.read()
        dup = duplicate(obj)
        self.assertEqual(dup.bsarap.pc2_path, setting)
        activate(dup)
        self.assertEqual(bpy.ops.bsarap.add_controls(), {"FINISHED"})
        dup.bsarap.groups[1].control.location.z -= 0.5
        bpy.context.view_layer.update()
        return dup, path, data

    def assert_intact(self, path, data):
        with open(path, "rb") as f:
            self.assertEqual(f.read(), data, "the original's bake was overwritten")
        mod = self.obj.modifiers[ext.modifiers.CACHE_MODIFIER]
        self.assertEqual(os.path.realpath(bpy.path.abspath(mod.filepath)), os.path.realpath(path))

    def assert_copy_refused(self, setting):
        """The copy's bake into the original's cache (Point cache ``setting``) is refused,
        nothing written; given a path of its own, it bakes there."""
        dup, path, data = self.bake_copy(setting)
        solves = ext.solve.state(dup).solves
        with self.assertRaises(RuntimeError) as cm:
            bpy.ops.bsarap.bake_point_cache()
        msg = str(cm.exception)
        self.assertIn(f"tube.001: the point cache {path} holds the bake of 'tube'", msg)
        self.assertIn("set another Point cache path for tube.001", msg)
        self.assertNotIn("copy of", msg)
        self.assert_intact(path, data)
        self.assertEqual(ext.solve.state(dup).solves, solves, "refused only after solving")
        dup.bsarap.pc2_path = "//copy.pc2"
        self.assertEqual(bpy.ops.bsarap.bake_point_cache(), {"FINISHED"})
        self.assertEqual(dup.modifiers[ext.modifiers.CACHE_MODIFIER].filepath, "//copy.pc2")
        self.assert_intact(path, data)

    def test_absolute_path_refused(self):
        self.assert_copy_refused(os.path.join(self.folder, "anim.pc2"))

    def test_relative_path_refused(self):
        self.assert_copy_refused("//anim.pc2")

    def test_default_paths_differ(self):
        """No path set: each bakes next to the .blend under its own name."""
        dup, path, data = self.bake_copy("")
        self.assertEqual(bpy.ops.bsarap.bake_point_cache(), {"FINISHED"})
        mod = dup.modifiers[ext.modifiers.CACHE_MODIFIER]
        self.assertEqual(mod.filepath, "//tube_001.bsarap.pc2")
        self.assert_intact(path, data)

    def test_same_default_name_refused(self):
        """Two names that make the same file name ("tube.001" and "tube_001"): refused too."""
        dup, path, data = self.bake_copy("")
        dup.name = "tube_001"
        self.assertEqual(bpy.ops.bsarap.bake_point_cache(), {"FINISHED"})
        dup_path = os.path.join(self.folder, "tube_001.bsarap.pc2")
        with open(dup_path, "rb") as f:
            dup_data = f.read()
        other = duplicate(dup)
        other.name = "tube.001"
        activate(other)
        self.assertEqual(bpy.ops.bsarap.add_controls(), {"FINISHED"})
        with self.assertRaises(RuntimeError) as cm:
            bpy.ops.bsarap.bake_point_cache()
        self.assertIn("holds the bake of 'tube_001'", str(cm.exception))
        with open(dup_path, "rb") as f:
            self.assertEqual(f.read(), dup_data)
        self.assert_intact(path, data)


    def bake_modal(self, obj, change=None):
        """Bake to point cache ``obj`` as the modal operator does, ``change()`` called after
        its first frame; returns the result and the reports."""
        Op = ext.operators.BSARAP_OT_bake_point_cache
        op, ctx, _calls = fake_modal_bake(obj, Op, range(1, 4))
        timer = types.SimpleNamespace(type="TIMER")
        self.assertEqual(Op.modal(op, ctx, timer), {"RUNNING_MODAL"})
        if change is not None:
            change()
        result = {"RUNNING_MODAL"}
        while result == {"RUNNING_MODAL"}:
            result = Op.modal(op, ctx, timer)
        return result, op.reports

    def assert_original_rebaked(self, modal):
        """The original baked again once a copy (which reads its cache) exists: it writes."""
        dup, path, data = self.bake_copy("//anim.pc2")
        self.obj.bsarap.groups[1].control.location.z += 0.5
        bpy.context.view_layer.update()
        activate(self.obj)
        if modal:
            self.assertEqual(self.bake_modal(self.obj)[0], {"FINISHED"})
        else:
            self.assertEqual(bpy.ops.bsarap.bake_point_cache(), {"FINISHED"})
        with open(path, "rb") as f:
            self.assertNotEqual(f.read(), data, "the original's bake not written")

    def test_original_rebaked_after_a_copy(self):
        self.assert_original_rebaked(modal=False)

    def test_original_rebaked_after_a_copy_modal(self):
        self.assert_original_rebaked(modal=True)

    def test_deleted_original_does_not_block(self):
        """The original deleted (kept in bpy.data by its controls' claims): the copy bakes."""
        dup, path, data = self.bake_copy("//anim.pc2")
        activate(self.obj)
        self.assertEqual(bpy.ops.object.delete(), {"FINISHED"})
        activate(dup)
        self.assertEqual(bpy.ops.bsarap.bake_point_cache(), {"FINISHED"})
        with open(path, "rb") as f:
            self.assertNotEqual(f.read(), data)
        self.assertEqual(ext.operators.cache_claims(path)[0].owner, dup)

    def test_path_changed_while_baking(self):
        """Checked again before writing: the copy's Point cache set to the original's file
        while it bakes: refused, nothing written."""
        dup, path, data = self.bake_copy("//anim.pc2")
        dup.bsarap.pc2_path = "//copy.pc2"
        result, reports = self.bake_modal(dup, lambda: setattr(dup.bsarap, "pc2_path", "//anim.pc2"))
        self.assertEqual(result, {"CANCELLED"})
        self.assertIn("holds the bake of 'tube'", reports[-1][1])
        self.assert_intact(path, data)
        self.assertFalse(os.path.exists(os.path.join(self.folder, "copy.pc2")))

    def test_claim_taken_while_baking(self):
        """Another object's bake claims the file while this one bakes: refused before writing."""
        dup, path, data = self.bake_copy("//anim.pc2")
        path_b = os.path.join(self.folder, "b.pc2")
        dup.bsarap.pc2_path = path_b
        claim = lambda: ext.operators.claim_cache(bpy.context.scene, path_b, self.obj)  # noqa: E731
        with open(path_b, "wb") as f:
            f.write(b"other")
        self.obj.modifiers[ext.modifiers.CACHE_MODIFIER].filepath = path_b
        result, reports = self.bake_modal(dup, claim)
        self.assertEqual(result, {"CANCELLED"})
        self.assertIn("holds the bake of 'tube'", reports[-1][1])
        with open(path_b, "rb") as f:
            self.assertEqual(f.read(), b"other")

    def test_unclaimed_file(self):
        """A file no bake claimed (an older file's bake, or the user's cache): refused while
        another object reads it, also to one that reads it too (a Shift+D copy reads its
        original's file, and which baked it is not known); allowed to the one reader."""
        dup, path, data = self.bake_copy("//anim.pc2")
        bpy.context.scene.bsarap_caches.clear()
        for o, other in ((dup, "tube"), (self.obj, "tube.001")):
            activate(o)
            with self.assertRaises(RuntimeError) as cm:
                bpy.ops.bsarap.bake_point_cache()
            msg = str(cm.exception)
            self.assertIn(f"the point cache {path} is read by '{other}' (its modifier 'BS-ARAP cache')", msg)
            self.assertIn(f"was not baked from {o.name}", msg)
            self.assert_intact(path, data)
        dup.modifiers.remove(dup.modifiers[ext.modifiers.CACHE_MODIFIER])
        activate(self.obj)
        self.assertEqual(bpy.ops.bsarap.bake_point_cache(), {"FINISHED"})

    def test_moved_project(self):
        """The claim is kept relative to the .blend, as the modifier's path: in a copy of the
        project's folder the copy's bake is still refused, the copied file intact."""
        dup, path, data = self.bake_copy("//anim.pc2")
        self.assertEqual([c.path for c in ext.operators.cache_claims(path)], ["//anim.pc2"])
        bpy.ops.wm.save_mainfile()
        moved = os.path.join(tempfile.mkdtemp(), "moved")
        shutil.copytree(self.folder, moved)
        bpy.ops.wm.open_mainfile(filepath=os.path.join(moved, "scene.blend"))
        activate(bpy.data.objects["tube.001"])
        with self.assertRaises(RuntimeError) as cm:
            bpy.ops.bsarap.bake_point_cache()
        self.assertIn("holds the bake of 'tube'", str(cm.exception))
        with open(os.path.join(moved, "anim.pc2"), "rb") as f:
            self.assertEqual(f.read(), data)

    def test_scene_full_copy(self):
        """A scene copied whole copies the claims, each to its scene's object: neither bakes
        into the shared file."""
        self.bake_copy("//anim.pc2")  # the original baked
        activate(bpy.data.objects["tube.001"])
        self.assertEqual(bpy.ops.object.delete(), {"FINISHED"})
        path = bpy.path.abspath("//anim.pc2")
        with open(path, "rb") as f:
            data = f.read()
        self.assertEqual(bpy.ops.scene.new(type="FULL_COPY"), {"FINISHED"})
        owners = sorted(c.owner.name for c in ext.operators.cache_claims(path))
        self.assertEqual(len(owners), 2, owners)
        for sc in bpy.data.scenes:
            bpy.context.window.scene = sc
            obj = next(o for o in sc.objects if o.name.startswith("tube"))
            activate(obj)
            with self.assertRaises(RuntimeError) as cm:
                bpy.ops.bsarap.bake_point_cache()
            self.assertIn("holds the bake of", str(cm.exception))
        with open(path, "rb") as f:
            self.assertEqual(f.read(), data)

    def test_deleted_owner_claim_dropped(self):
        """A claim of a deleted object goes at the next update (a pointer would keep the object
        and its mesh in the file)."""
        self.bake_copy("//anim.pc2")
        path = bpy.path.abspath("//anim.pc2")
        activate(self.obj)
        self.assertEqual(bpy.ops.object.delete(), {"FINISHED"})
        bpy.context.view_layer.update()
        self.assertEqual(ext.operators.cache_claims(path), [])


class StaleMessages(unittest.TestCase):
    """The panel's message says what is wrong now: an error goes once its cause is gone."""

    def setUp(self):
        self.obj = posed_tube(top_x=0.5)

    def panel_message(self, obj):
        msg = ext.solve.message(obj)
        labels = draw_panel(ext.panel.BSARAP_PT_pose, obj).labels
        if msg is not None:
            self.assertIn(msg, labels)
        return msg

    def test_live_error_goes_once_fixed(self):
        obj = self.obj
        obj.scale = (1.0, 1.0, 0.0)
        bpy.context.view_layer.update()
        self.assertIn("singular (a scale of 0", self.panel_message(obj))
        obj.scale = (1.0, 1.0, 1.0)
        bpy.context.view_layer.update()
        self.assertIsNone(self.panel_message(obj))
        assert_pose_follows(obj)

    def test_live_error_goes_with_pose_now(self):
        """Live turned off after the error, the cause fixed: Pose Now poses, the error goes."""
        obj = self.obj
        obj.scale = (1.0, 1.0, 0.0)
        bpy.context.view_layer.update()
        self.assertIn("singular", ext.solve.message(obj))
        obj.bsarap.live = False
        obj.scale = (1.0, 1.0, 1.0)
        bpy.context.view_layer.update()
        activate(obj)
        self.assertEqual(bpy.ops.bsarap.pose(), {"FINISHED"})
        self.assertIsNone(self.panel_message(obj))

    def test_first_build_error_goes(self):
        """A build that failed with no solver built before (a file just opened): fixed, the
        solver is built and its error goes."""
        obj = self.obj
        mod = obj.modifiers.new("Displace", "DISPLACE")
        ext.solve.forget()  # as after opening the file
        bpy.data.objects["top"].location.y += 0.1
        bpy.context.view_layer.update()
        self.assertIn("modifiers that move the vertices (Displace)", self.panel_message(obj))
        self.assertIsNone(ext.solve.built(obj))
        obj.modifiers.remove(mod)
        bpy.data.objects["top"].location.y += 0.1
        bpy.context.view_layer.update()
        self.assertIsNotNone(ext.solve.built(obj))
        self.assertIsNone(self.panel_message(obj))
        assert_pose_follows(obj)

    def test_finishing_error_kept_until_a_move(self):
        """A finishing step's error stays while the controls rest (the update that follows has
        nothing to solve), and goes with the next solve."""
        obj, sc = self.obj, bpy.context.scene
        st = ext.solve.state(obj)
        st.converged, st.moved_at, st.ended = False, 0.0, None
        with mock.patch.object(ext.solve, "finish_step", side_effect=KeyError("k")):
            ext.handlers.finish_timer()
        self.assertIn("unexpected error (KeyError", ext.solve.message(obj))
        ext.handlers.update_scene(sc)  # the controls rest: no solve
        self.assertIn("unexpected error (KeyError", self.panel_message(obj))
        bpy.data.objects["top"].location.y += 0.1
        bpy.context.view_layer.update()
        self.assertIsNone(self.panel_message(obj))

    def test_check_error_in_timer_goes(self):
        """A check that fails in a finishing step (a scale of 0 while settling) is the live
        update's to clear: the scale fixed, the message goes and settling resumes."""
        obj, timer = self.obj, ext.handlers.finish_timer
        st = ext.solve.state(obj)
        st.converged, st.moved_at, st.ended = False, 0.0, None
        obj.scale = (1.0, 1.0, 0.0)
        bpy.context.view_layer.update()  # the live update reports it too
        with self.assertRaises(ext.handles.HandleError):
            ext.solve.finish_step(obj)  # the step's check fails
        ext.solve.clear_error(obj)  # what follows is the timer's own report
        self.assertIsNone(ext.solve.message(obj))
        timer()
        self.assertIn("singular (a scale of 0", ext.solve.message(obj))
        self.assertIsNone(st.ended, "a failed check does not end the pose")
        if bpy.app.timers.is_registered(timer):
            bpy.app.timers.unregister(timer)  # as the timer ends when nothing is due
        obj.scale = (1.0, 1.0, 1.0)
        bpy.context.view_layer.update()
        self.assertIsNone(self.panel_message(obj))
        self.assertNotIn("Stopped", ext.solve.status(obj)[0])
        self.assertTrue(bpy.app.timers.is_registered(timer))
        steps = st.finish_steps
        st.moved_at = 0.0
        self.assertEqual(timer(), 0.0)
        self.assertEqual(st.finish_steps, steps + 1)

    def test_refusal_goes_without_an_update(self):
        """A copy refused: once the original's controls are removed, or the original deleted
        with the copy's Live off, no update runs for the copy, and its refusal is not shown."""
        for how in ("remove controls", "delete"):
            with self.subTest(how=how):
                obj = self.obj = posed_tube(top_x=0.5)
                dup = duplicate(obj)
                self.assertIn("pose 'tube'", self.panel_message(dup))
                activate(obj)
                if how == "delete":
                    dup.bsarap.live = False
                    self.assertEqual(bpy.ops.object.delete(), {"FINISHED"})
                else:
                    self.assertEqual(bpy.ops.bsarap.remove_controls(), {"FINISHED"})
                bpy.context.view_layer.update()
                self.assertIsNone(self.panel_message(dup))

    def test_library_mesh_made_local(self):
        """A linked mesh refused, then made local: Pose Now poses it (not the stored failure),
        and the refusal goes."""
        path = os.path.join(tempfile.mkdtemp(), "lib.blend")
        bpy.ops.wm.save_as_mainfile(filepath=path)
        obj = link_rig(path)[0].make_local()  # the object local, its mesh still linked
        activate(obj)
        bpy.context.view_layer.update()
        self.assertIn("the mesh is linked from a library", ext.solve.message(obj))
        with self.assertRaises(RuntimeError):
            bpy.ops.bsarap.pose()
        obj.data = obj.data.make_local()
        self.assertIsNone(obj.data.library)
        self.assertEqual(bpy.ops.bsarap.pose(), {"FINISHED"})
        self.assertIsNone(self.panel_message(obj))
        assert_pose_follows(obj)


class DeletedAndAdded(unittest.TestCase):
    """The solvers are kept under the object's session uid, which Blender never reuses in a
    session: a new object never gets a deleted one's solver, even deleted and added in one
    depsgraph update, with its name and mesh; and the deleted one's is dropped then too."""

    def test_in_one_update(self):
        obj = posed_tube(top_x=0.5)
        old, st = obj.session_uid, ext.solve.state(obj)
        mesh = obj.data
        bpy.data.objects.remove(obj)  # the object counts stay as they were: one out, one in
        new = bpy.data.objects.new("tube", mesh)  # its vertex groups are the mesh's
        bpy.context.scene.collection.objects.link(new)
        for g in ("bottom", "top"):
            new.bsarap.groups.add().name = g
        new.bsarap.method = "arap"
        bpy.context.view_layer.update()
        self.assertNotEqual(new.session_uid, old)
        self.assertNotIn(old, ext.solve._states)  # the deleted object's solver is freed
        self.assertEqual(ext.solve.messages, {})
        self.assertIsNone(ext.solve.built(new))
        activate(new)
        self.assertEqual(bpy.ops.bsarap.add_controls(), {"FINISHED"})
        self.assertIsNot(ext.solve.built(new), st)  # its own, for its own settings
        self.assertEqual(ext.solve.state(new).deformer.method, "arap")
        self.assertEqual(list(ext.solve._states), [new.session_uid])
        new.bsarap.groups[1].control.location.z -= 0.4
        bpy.context.view_layer.update()
        assert_pose_follows(new)


def library_file():
    """A saved library with the posed tube and its controls; returns its path."""
    posed_tube(top_x=0.5)
    path = os.path.join(tempfile.mkdtemp(), "lib.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    return path


class LibraryOverride(unittest.TestCase):
    """A library override of the tube: its mesh, linked or overridden, cannot take the pose key
    (Blender keeps neither's shape keys): refused with a message that says so, before anything
    is claimed; made local, it poses."""

    @classmethod
    def setUpClass(cls):
        cls.lib = library_file()

    def assert_refused(self, obj, text):
        """Pose Now, Add Controls, the bakes and the live update refuse ``obj`` with ``text``;
        nothing built."""
        activate(obj)
        ops = (bpy.ops.bsarap.pose, bpy.ops.bsarap.add_controls, bpy.ops.bsarap.bake_shape_keys,
               bpy.ops.bsarap.bake_point_cache)
        for op in ops:
            with self.assertRaises(RuntimeError) as cm:
                op()
            self.assertIn(text, str(cm.exception))
        ext.handlers.update_scene(bpy.context.scene)  # the live update
        self.assertIn(text, ext.solve.message(obj))
        self.assertIsNone(ext.solve.built(obj))

    def test_mesh_not_overridden(self):
        """The object overridden, its mesh still linked; the library's tube, which posed it,
        also in the scene: refused as an override, not as a copy."""
        linked = link_rig(self.lib)
        obj = linked[0].override_create(remap_local_usages=False)
        bpy.context.scene.collection.objects.link(obj)
        self.assertIsNotNone(obj.data.library)
        self.assertIsNotNone(obj.override_library)
        self.assert_refused(
            obj, "tube: a library override whose mesh is not overridden: the mesh is still linked from lib.blend"
        )
        self.assertIn("make the mesh local", ext.solve.message(obj))

    def test_mesh_overridden(self):
        """The object and its mesh overridden: Blender keeps no pose key written to it (it stayed
        at rest): refused; made local, it poses."""
        rig = [o.override_create(remap_local_usages=True) for o in link_rig(self.lib)]
        obj = rig[0]
        obj.data.override_create(remap_local_usages=True)
        self.assertIsNone(obj.data.library)
        self.assertIsNotNone(obj.data.override_library)
        self.assert_refused(obj, "tube: the mesh is a library override (from lib.blend)")
        activate(obj)
        self.assertEqual(bpy.ops.object.make_local(type="SELECT_OBDATA"), {"FINISHED"})
        obj = bpy.context.view_layer.objects.active
        self.assertIsNone(obj.data.override_library)
        self.assertEqual(bpy.ops.bsarap.pose(), {"FINISHED"})
        self.assertIsNone(ext.solve.message(obj))
        rig[2].location.x += 0.3
        bpy.context.view_layer.update()
        assert_pose_follows(obj)



class WeightEdits(unittest.TestCase):
    """Vertex weights painted (Weight Paint) or assigned (Edit Mode) are read again when the
    mode ends: the solver is rebuilt when the handle groups changed, and a build that failed on
    them is tried again, its message gone once fixed."""

    def setUp(self):
        self.obj = posed_tube(top_x=0.5)
        self.top = self.obj.vertex_groups["top"]
        self.ring = list(range(20 * 16, 21 * 16))  # the ring below the top group's two

    def edit(self, mode, weights):
        """Enter ``mode``, set the top group's weights ``{vertex: weight}`` (in Edit Mode on the
        edit mesh, as assigning does), go back to Object Mode."""
        activate(self.obj)
        bpy.ops.object.mode_set(mode=mode)
        if mode == "EDIT":
            bm = bmesh.from_edit_mesh(self.obj.data)
            layer = bm.verts.layers.deform.verify()
            bm.verts.ensure_lookup_table()
            for w, idx in weights.items():
                for i in idx:
                    bm.verts[i][layer][self.top.index] = w
            bmesh.update_edit_mesh(self.obj.data)
        else:
            for w, idx in weights.items():
                self.top.add(idx, w, "REPLACE")
        bpy.context.view_layer.update()  # an update in the mode
        bpy.ops.object.mode_set(mode="OBJECT")
        bpy.context.view_layer.update()

    def test_painted_group_rebuilds(self):
        before = ext.solve.state(self.obj)
        self.edit("WEIGHT_PAINT", {1.0: self.ring})
        st = ext.solve.built(self.obj)
        self.assertIsNot(st, before)
        self.assertTrue((st.labels[self.ring] == 1).all())
        self.assertIn("vertex weights changed", ext.solve.message(self.obj))
        assert_pose_follows(self.obj)

    def test_unchanged_weights_keep_the_solver(self):
        before = ext.solve.state(self.obj)
        self.edit("EDIT", {})
        self.assertIs(ext.solve.built(self.obj), before)

    def test_live_off(self):
        """Painted with Live off (no live update poses it): Pose Now builds from the new
        weights."""
        self.obj.bsarap.live = False
        before = ext.solve.state(self.obj)
        self.edit("WEIGHT_PAINT", {1.0: self.ring})
        activate(self.obj)
        self.assertEqual(bpy.ops.bsarap.pose(), {"FINISHED"})
        self.assertIsNot(ext.solve.built(self.obj), before)
        self.assertTrue((ext.solve.built(self.obj).labels[self.ring] == 1).all())

    def test_undone_paint_read_again(self):
        """Painted, back in Object Mode, then Ctrl+Z past the paint: the undo step's weights."""
        bpy.ops.ed.undo_push(message="posed")
        self.edit("WEIGHT_PAINT", {1.0: self.ring})
        self.assertTrue((ext.solve.built(self.obj).labels[self.ring] == 1).all())
        bpy.ops.ed.undo_push(message="painted")
        bpy.ops.ed.undo()
        bpy.context.view_layer.update()
        obj = bpy.data.objects["tube"]
        self.assertTrue((ext.solve.built(obj).labels[self.ring] == -1).all())
        assert_pose_follows(obj)

    def test_failed_build_tried_again(self):
        top = [v.index for v in self.obj.data.vertices if any(g.group == self.top.index for g in v.groups)]
        self.edit("WEIGHT_PAINT", {0.3: top})
        self.assertIn("'top' has no vertex with weight above 0.5", ext.solve.message(self.obj))
        self.edit("EDIT", {1.0: top[:-1]})  # back as it was (the one vertex at 0.3 stays)
        self.assertIn("vertex weights changed; solver rebuilt", ext.solve.message(self.obj))
        bpy.data.objects["top"].location.x += 0.2
        bpy.context.view_layer.update()
        assert_pose_follows(self.obj)


class RemovedByScript(unittest.TestCase):
    """``bpy.data.objects.remove`` (a script's, not the viewport's Delete) frees the object at
    once; Blender clears the pointers to it that other objects and scenes hold, not a mesh's.
    A mesh's claim is in the scene, so nothing points to freed memory and the updates go on."""

    def test_posed_copy_removed(self):
        obj = posed_tube(top_x=0.5)
        dup = duplicate(obj)
        activate(dup)
        self.assertEqual(bpy.ops.bsarap.add_controls(), {"FINISHED"})  # its own controls
        mesh = dup.data
        self.assertEqual(ext.claims.mesh_owner(mesh), dup)
        bpy.data.objects.remove(dup)
        bpy.context.view_layer.update()
        ext.handlers.update_scene(bpy.context.scene)  # read freed memory with the pointer
        self.assertIsNone(ext.claims.mesh_owner(mesh))
        self.assertNotIn(mesh.name, claims())
        self.assertEqual(claims()["tube"], "tube")
        self.assertEqual(mesh.users, 0)  # no claim keeps the removed object's mesh
        bpy.data.objects["top"].location.x += 0.2
        bpy.context.view_layer.update()
        assert_pose_follows(obj)
        self.assertIsNone(ext.solve.message(obj))

    def test_mesh_reused(self):
        """The mesh of a removed posed object given to a new one (which takes the freed memory:
        the pointer on the mesh named it as the owner): no claim until it is posed."""
        obj = posed_tube(top_x=0.5)
        mesh = obj.data
        bpy.data.objects.remove(obj)
        new = bpy.data.objects.new("other", mesh)
        bpy.context.scene.collection.objects.link(new)
        bpy.context.view_layer.update()
        self.assertIsNone(ext.claims.mesh_owner(mesh))
        self.assertEqual([m.owner for m in bpy.context.scene.bsarap_meshes], [])


class ClaimScenes(unittest.TestCase):
    """A mesh's claim is the owner object alone, in each scene the owner is in: no pointer to
    the mesh, which Blender leaves dangling on a scene without user properties (Scene > New)
    when the mesh is removed, and no claim lost with one of the owner's scenes."""

    def test_mesh_removed_in_a_new_scene(self):
        obj = posed_tube(top_x=0.5)
        first, new = bpy.context.scene, bpy.data.scenes.new("New")  # New: no user properties
        for o in first.collection.objects:
            new.collection.objects.link(o)
        bpy.context.window.scene = new
        bpy.data.scenes.remove(first)
        bpy.context.view_layer.update()
        self.assertEqual([m.owner for m in new.bsarap_meshes], [obj])
        bpy.data.meshes.remove(obj.data)  # the object goes with it
        for i in range(3):  # new meshes may take the freed memory
            bpy.data.meshes.new(f"n{i}")
        ext.handlers.update_scene(new)
        self.assertEqual([m.owner for m in new.bsarap_meshes], [])

    def test_claim_kept_in_the_owners_other_scene(self):
        """The rig linked into a second scene, a linked duplicate with its controls removed,
        Live off: deleting the scene that held the claim keeps it, so the duplicate is still
        refused the shared mesh."""
        obj = posed_tube(top_x=0.5)
        obj.bsarap.live = False
        first = bpy.context.scene
        second = bpy.data.scenes.new("Second")
        for o in first.collection.objects:
            second.collection.objects.link(o)
        dup = duplicate(obj, linked=True)
        activate(dup)
        self.assertEqual(bpy.ops.bsarap.remove_controls(), {"FINISHED"})
        bpy.context.view_layer.update()  # the scenes' objects changed: the claims follow
        self.assertEqual([m.owner for m in second.bsarap_meshes], [obj])
        name = obj.name
        bpy.context.window.scene = second
        bpy.data.scenes.remove(first)
        obj, dup = bpy.data.objects[name], bpy.data.objects[dup.name]
        self.assertEqual(ext.claims.mesh_owner(obj.data), obj)
        self.assertIs(ext.claims.mesh_sharer(dup), obj)


class MeshPointerClaims(unittest.TestCase):
    """A file saved when a mesh's claim was a pointer on the mesh (``Mesh.bsarap_owner``): the
    claim moves into the scene on load and the pointer goes."""

    def saved_with_pointers(self, *, linked_copy=False, user_property=False):
        """The posed tube saved with its mesh's claim as a pointer on the mesh, the add-on's
        property (or with ``user_property`` the user's, as a 4.x file opened in Blender 5 has
        it too), and opened again; with ``linked_copy`` an Alt+D copy saved too, so that the
        pointer alone says which poses the mesh (on load neither would be claimed)."""
        obj = posed_tube(top_x=0.5)
        obj.bsarap.live = False
        dup = duplicate(obj, linked=True).name if linked_copy else None
        bpy.context.scene.bsarap_meshes.clear()
        if user_property:
            obj.data["bsarap_owner"] = obj
        else:
            bpy.types.Mesh.bsarap_owner = bpy.props.PointerProperty(type=bpy.types.Object)
            try:
                obj.data.bsarap_owner = obj
            finally:
                del bpy.types.Mesh.bsarap_owner  # its value stays in the mesh, as in such a file
        path = save_and_open("pointers.blend")
        return bpy.data.objects["tube"], dup and bpy.data.objects[dup], path

    def stored(self, mesh):
        """Whether a ``bsarap_owner`` is left on ``mesh``, as the add-on's or as the user's
        (Blender 5 keeps them apart; a 4.x file opened in 5 has it in both)."""
        stores = [mesh]
        if hasattr(mesh, "bl_system_properties_get"):
            stores.append(mesh.bl_system_properties_get())
        return any(props is not None and "bsarap_owner" in props for props in stores)

    def test_adopted(self):
        obj, dup, _ = self.saved_with_pointers(linked_copy=True)
        self.assertFalse(self.stored(obj.data))
        self.assertEqual(ext.claims.mesh_owner(obj.data), obj)
        self.assertIs(ext.claims.mesh_sharer(dup), obj)

    def test_user_property_too(self):
        """The pointer among the user's properties: it goes too (it would keep a deleted owner
        in the file)."""
        obj, dup, _ = self.saved_with_pointers(linked_copy=True, user_property=True)
        self.assertFalse(self.stored(obj.data))
        self.assertIs(ext.claims.mesh_sharer(dup), obj)

    def test_appended(self):
        """Appended into another file (no load handler runs): the next update adopts it."""
        _, dup, path = self.saved_with_pointers(linked_copy=True)
        names = ["tube", dup.name, "bottom", "top"]
        bpy.ops.wm.read_homefile(use_empty=True)
        with bpy.data.libraries.load(path, link=False) as (_src, dst):
            dst.objects = list(names)
        for o in dst.objects:
            bpy.context.scene.collection.objects.link(o)
        bpy.context.view_layer.update()
        obj, dup = bpy.data.objects["tube"], bpy.data.objects[names[1]]
        self.assertFalse(self.stored(obj.data))
        self.assertIs(ext.claims.mesh_sharer(dup), obj)

    def test_claim_holds_no_mesh_pointer(self):
        """A claim is its owner alone: a pointer to the mesh on a scene is one Blender can leave
        dangling (see ClaimScenes)."""
        props = {p.identifier for p in ext.props.BSARAP_MeshClaim.bl_rna.properties}
        self.assertEqual(props - {"rna_type", "name"}, {"owner"})


if __name__ == "__main__":
    if SKIP:
        print(f"skipped: {SKIP}")
        sys.exit(0)
    unittest.main()
