"""Tests of the Blender extension's robustness in bpy, headless: bakes with a frame step, the
point cache's path, deleted controls, Edit Mode, a bake stopped by an error or an undo, failed
builds, a singular object transform, an edited basis, faces reconnected with the counts kept,
non-uniform scale, rendering, renamed and deleted objects, and copies of a posed object.

Run with Blender's Python (bpy from PyPI):
    tools/blender/.venv/bin/python blender/tests/test_robustness.py [-v] [Class.test_name]
The extension zip is found as common.py says. Skips (with the reason) when bpy or the zip is
missing.
"""

from __future__ import annotations

import contextlib
import io
import os
import sys
import tempfile
import types
import unittest
from unittest import mock

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import (  # noqa: E402  (sets BLENDER_USER_RESOURCES before bpy)
    SKIP, activate, assert_pose_follows, bpy, bsarap, draw_group_rows, draw_panel, duplicate,
    evaluated_positions, expected_handles, ext, fake_modal_bake, key_co, link_rig, make_controls,
    np, pose_of, posed_tube, setUpModule, tube
)

if SKIP is None:
    import bmesh


def key_top(frames_x):
    """Key the top control's x offset at each ``(frame, x)``, linearly."""
    top = bpy.data.objects["top"]
    x0 = top.location.x
    for f, x in frames_x:
        top.location.x = x0 + x
        top.keyframe_insert("location", frame=f)
    from bpy_extras import anim_utils

    ad = top.animation_data
    for fc in anim_utils.action_get_channelbag_for_slot(ad.action, ad.action_slot).fcurves:
        for kp in fc.keyframe_points:
            kp.interpolation = "LINEAR"
    return top


class FrameStep(unittest.TestCase):
    """scene.frame_step 2: only every other frame is solved, and every frame plays (the frames
    in between blend their two baked neighbours), from shape keys or the point cache."""

    def setUp(self):
        self.obj = posed_tube()
        key_top([(1, 0.0), (9, 2.0)])
        sc = bpy.context.scene
        sc.frame_start, sc.frame_end, sc.frame_step = 1, 9, 2
        activate(self.obj)

    def test_shape_keys(self):
        obj, sc = self.obj, bpy.context.scene
        self.assertEqual(bpy.ops.bsarap.bake_shape_keys(), {"FINISHED"})
        keys = obj.data.shape_keys.key_blocks
        baked = {f: key_co(keys[f"BS-ARAP frame {f:04d}"]) for f in (1, 3, 5, 7, 9)}
        self.assertEqual(sum(kb.name.startswith("BS-ARAP frame") for kb in keys), 5)
        for f in range(1, 10):
            sc.frame_set(f)
            total = sum(kb.value for kb in keys if kb.name.startswith("BS-ARAP frame"))
            self.assertAlmostEqual(total, 1.0, places=5, msg=f"frame {f}")
            want = baked[f] if f % 2 else 0.5 * (baked[f - 1] + baked[f + 1])
            np.testing.assert_allclose(evaluated_positions(obj), want, atol=1e-5, err_msg=f"frame {f}")
        # baking again with step 1 replaces them all (their F-curves too)
        sc.frame_step = 1
        self.assertEqual(bpy.ops.bsarap.bake_shape_keys(), {"FINISHED"})
        self.assertEqual(sum(kb.name.startswith("BS-ARAP frame") for kb in keys), 9)
        fcurves = ext.bake._fcurves(obj.data.shape_keys)
        self.assertEqual(len(fcurves), 9)

    def test_point_cache(self):
        obj, sc = self.obj, bpy.context.scene
        path = os.path.join(tempfile.mkdtemp(), "tube.pc2")
        obj.bsarap.pc2_path = path
        self.assertEqual(bpy.ops.bsarap.bake_point_cache(), {"FINISHED"})
        start, rate, samples = ext.bake.read_pc2(path)
        self.assertEqual((start, rate, len(samples)), (1.0, 2.0, 5))
        for f in range(1, 10):
            sc.frame_set(f)
            k = (f - 1) // 2
            want = samples[k] if f % 2 else 0.5 * (samples[k] + samples[k + 1])
            np.testing.assert_allclose(evaluated_positions(obj), want, atol=1e-5, err_msg=f"frame {f}")


class PointCachePath(unittest.TestCase):
    def setUp(self):
        self.obj = posed_tube()
        bpy.context.scene.frame_start, bpy.context.scene.frame_end = 1, 2

    def test_unsaved_file_refused(self):
        """Blender's temporary folder goes when it quits: no cache there."""
        for p in ("", "//tube.pc2"):
            self.obj.bsarap.pc2_path = p
            with self.assertRaises(RuntimeError) as cm:
                bpy.ops.bsarap.bake_point_cache()
            self.assertIn("save the .blend file first", str(cm.exception))
            self.assertNotIn(ext.modifiers.CACHE_MODIFIER, self.obj.modifiers)
        self.assertFalse(ext.solve.state(self.obj).baking)

    def test_saved_file_relative_path(self):
        folder = tempfile.mkdtemp()
        bpy.ops.wm.save_as_mainfile(filepath=os.path.join(folder, "scene.blend"))
        obj = bpy.data.objects["tube"]
        activate(obj)
        self.assertEqual(bpy.ops.bsarap.bake_point_cache(), {"FINISHED"})
        mod = obj.modifiers[ext.modifiers.CACHE_MODIFIER]
        self.assertEqual(mod.filepath, "//tube.bsarap.pc2")
        self.assertTrue(os.path.isfile(os.path.join(folder, "tube.bsarap.pc2")))
        _, _, samples = ext.bake.read_pc2(bpy.path.abspath(mod.filepath))
        bpy.context.scene.frame_set(2)
        np.testing.assert_allclose(evaluated_positions(obj), samples[1], atol=1e-5)


class DeletedControl(unittest.TestCase):
    def test_deleted_control_is_missing_and_recreated(self):
        obj = posed_tube()
        top = bpy.data.objects["top"]
        activate(top)
        self.assertEqual(bpy.ops.object.delete(), {"FINISHED"})
        # still held by the handle group's pointer, in no scene: no longer posing
        self.assertIs(obj.bsarap.groups[1].control, top)
        bpy.data.objects["bottom"].location.x += 0.2
        bpy.context.view_layer.update()
        self.assertIn("'top' was deleted", ext.solve.message(obj))
        activate(obj)
        self.assertEqual(bpy.ops.bsarap.add_controls(), {"FINISHED"})
        new = obj.bsarap.groups[1].control
        self.assertEqual(new.name, "top")  # the orphan removed, its name free again
        self.assertIn(new.name, bpy.context.scene.objects)
        new.location.x += 0.5
        bpy.context.view_layer.update()
        assert_pose_follows(obj)


class EditMode(unittest.TestCase):
    def setUp(self):
        self.obj = posed_tube()

    def test_operators_refuse_edit_mode(self):
        bpy.ops.object.mode_set(mode="EDIT")
        for op in (bpy.ops.bsarap.add_controls, bpy.ops.bsarap.pose, bpy.ops.bsarap.bake_shape_keys):
            with self.assertRaises(RuntimeError) as cm:
                op()
            self.assertIn("leave Edit Mode first", str(cm.exception))
        self.assertTrue(bpy.ops.bsarap.add_group.poll())  # the list does not read the mesh
        self.assertIn("Edit Mode", " ".join(draw_panel(ext.panel.BSARAP_PT_pose, self.obj).labels))

    def test_frame_change_in_edit_mode(self):
        """Controls animated, frames changed in Edit Mode: nothing solved there; the pose of the
        current frame once Edit Mode ends."""
        obj, sc = self.obj, bpy.context.scene
        key_top([(1, 0.0), (10, 1.0)])
        sc.frame_set(1)
        st = ext.solve.state(obj)
        bpy.ops.object.mode_set(mode="EDIT")
        solves = st.solves
        sc.frame_set(10)
        bpy.context.view_layer.update()
        self.assertEqual(st.solves, solves)
        bpy.ops.object.mode_set(mode="OBJECT")
        bpy.context.view_layer.update()
        assert_pose_follows(obj)

    def test_pose_key_edited_is_solved_again(self):
        """Leaving Edit Mode writes the edit mesh's copy of the pose key back: solved again."""
        import bmesh

        obj = self.obj
        bpy.data.objects["top"].location.x += 0.5
        bpy.context.view_layer.update()
        bpy.ops.object.mode_set(mode="EDIT")
        bm = bmesh.from_edit_mesh(obj.data)
        layer = bm.verts.layers.shape[ext.solve.POSE_KEY]
        for v in bm.verts:
            v[layer] = v.co  # the pose key back at rest
        bmesh.update_edit_mesh(obj.data)
        bpy.ops.object.mode_set(mode="OBJECT")
        bpy.context.view_layer.update()
        assert_pose_follows(obj)


class BakeStops(unittest.TestCase):
    """A bake that fails is never left running: live posing resumes, the timer and progress
    end, the frame is restored, and the status bar says why."""

    TIMER = types.SimpleNamespace(type="TIMER")

    def setUp(self):
        self.obj = posed_tube("m")
        key_top([(1, 0.0), (5, 1.0)])
        sc = bpy.context.scene
        sc.frame_start, sc.frame_end = 1, 5
        sc.frame_set(3)
        activate(self.obj)

    def assert_stopped(self, result, op, calls, pattern):
        self.assertEqual(result, {"CANCELLED"})
        self.assertEqual(calls, ["timer removed", "progress end"])
        self.assertEqual(len(op.reports), 1)
        self.assertEqual(op.reports[0][0], {"ERROR"})
        self.assertRegex(op.reports[0][1], pattern)
        self.assertFalse(ext.solve.built(bpy.data.objects["m"]).baking)

    def test_unexpected_error(self):
        Op = ext.operators.BSARAP_OT_bake_shape_keys
        op, ctx, calls = fake_modal_bake(self.obj, Op, range(1, 6))
        self.assertEqual(Op.modal(op, ctx, self.TIMER), {"RUNNING_MODAL"})
        with mock.patch.object(ext.solve, "solve", side_effect=ValueError("boom")):
            result = Op.modal(op, ctx, self.TIMER)
        self.assert_stopped(result, op, calls, r"unexpected error \(ValueError: boom\)")
        self.assertEqual(bpy.context.scene.frame_current, 3)
        # live posing goes on
        st = ext.solve.state(self.obj)
        solves = st.solves
        bpy.data.objects["top"].location.y += 0.3
        bpy.context.view_layer.update()
        self.assertEqual(st.solves, solves + 1)

    def test_a_second_bake_is_refused_and_a_cancelled_one_ends(self):
        """A second bake while one runs is refused (the first to end let live posing go on
        under the other); Blender ending the modal bake itself (its window closed) ends it."""
        Op = ext.operators.BSARAP_OT_bake_shape_keys
        op, ctx, calls = fake_modal_bake(self.obj, Op, range(1, 6))
        self.assertEqual(Op.modal(op, ctx, self.TIMER), {"RUNNING_MODAL"})
        with self.assertRaises(RuntimeError) as cm:
            bpy.ops.bsarap.bake_shape_keys()  # refused by its poll
        self.assertIn("a bake is under way", str(cm.exception))
        with self.assertRaises(ext.handles.HandleError) as cm:
            ext.bake.Baker(bpy.context.scene, self.obj, range(1, 3))  # and by the baker
        self.assertIn("a bake is under way", str(cm.exception))
        Op.cancel(op, ctx)
        self.assertEqual(calls, ["timer removed", "progress end"])
        self.assertFalse(ext.solve.built(bpy.data.objects["m"]).baking)
        self.assertEqual(bpy.context.scene.frame_current, 3)
        self.assertEqual(bpy.ops.bsarap.bake_shape_keys(), {"FINISHED"})

    def test_unexpected_error_in_one_go(self):
        self.obj.bsarap.pc2_path = os.path.join(tempfile.mkdtemp(), "m.pc2")
        with mock.patch.object(ext.solve, "solve", side_effect=ValueError("boom")):
            with self.assertRaises(RuntimeError) as cm:
                bpy.ops.bsarap.bake_point_cache()
        self.assertIn("unexpected error (ValueError: boom)", str(cm.exception))
        self.assertNotIn("Traceback", str(cm.exception))
        self.assertFalse(ext.solve.built(bpy.data.objects["m"]).baking)

    def test_undo_during_bake(self):
        bpy.ops.ed.undo_push(message="controls")
        self.obj.bsarap.tol = 1e-5
        bpy.ops.ed.undo_push(message="edit")
        Op = ext.operators.BSARAP_OT_bake_shape_keys
        op, ctx, calls = fake_modal_bake(self.obj, Op, range(1, 6))
        self.assertEqual(Op.modal(op, ctx, self.TIMER), {"RUNNING_MODAL"})
        bpy.ops.ed.undo()  # Ctrl+Z passes through the modal bake: its object and scene go
        result = Op.modal(op, ctx, self.TIMER)
        self.assert_stopped(result, op, calls, "changed while baking")
        # live posing goes on with the undone file's objects
        obj = bpy.data.objects["m"]
        bpy.data.objects["top"].location.y += 0.3
        bpy.context.view_layer.update()
        assert_pose_follows(obj)


class LiveAfterBake(unittest.TestCase):
    """A bake mutes the live pose key (its frames replace it). With Live turned on again, the
    panel says why posing shows nothing while the baked keys play, and once they are deleted
    the live pose shows again: the key stayed muted, and posing did nothing visible."""

    def test_live_posing_after_the_baked_keys_are_deleted(self):
        obj = posed_tube("relive", top_x=0.5)
        sc = bpy.context.scene
        sc.frame_start, sc.frame_end = 1, 3
        activate(obj)
        self.assertEqual(bpy.ops.bsarap.bake_shape_keys(), {"FINISHED"})
        kb = obj.data.shape_keys.key_blocks[ext.solve.POSE_KEY]
        self.assertTrue(kb.mute)
        obj.bsarap.live = True
        ext.handlers.update_scene(sc)
        text, icon = ext.solve.status(obj)
        self.assertIn("muted: the baked shape keys play", text)
        ext.bake.remove_frame_keys(obj)
        top = bpy.data.objects["top"]
        top.location.x += 0.3
        bpy.context.view_layer.update()
        ext.handlers.update_scene(sc)
        self.assertFalse(kb.mute, "the live pose key stayed muted")
        self.assertNotIn("muted", ext.solve.status(obj)[0])
        np.testing.assert_allclose(evaluated_positions(obj), pose_of(obj), atol=1e-5)
        assert_pose_follows(obj)
        # a key the user mutes stays muted, also through a bake and the deletion of its keys
        kb.mute = True
        top.location.x += 0.2
        bpy.context.view_layer.update()
        ext.handlers.update_scene(sc)
        self.assertTrue(kb.mute, "the user's mute was undone")
        self.assertEqual(bpy.ops.bsarap.bake_shape_keys(), {"FINISHED"})
        ext.bake.remove_frame_keys(obj)
        obj.bsarap.live = True
        top.location.x += 0.2
        bpy.context.view_layer.update()
        ext.handlers.update_scene(sc)
        self.assertTrue(kb.mute, "a bake took over the user's mute")


class Errors(unittest.TestCase):
    def setUp(self):
        self.obj = posed_tube()

    def test_failed_build_not_retried(self):
        """A build that failed fails again at once for the same input (no 0.7 s per update on
        30k vertices); a changed input or Add Controls tries again."""
        obj = self.obj
        obj.vertex_groups["top"].remove(list(range(len(obj.data.vertices))))
        obj.bsarap.tol = 1e-5  # a new key: rebuilt, and failing
        bottom = bpy.data.objects["bottom"]
        with mock.patch.object(ext.solve, "build", wraps=ext.solve.build) as build:
            for _ in range(4):
                bottom.location.x += 0.05
                bpy.context.view_layer.update()
            self.assertEqual(build.call_count, 1)
            self.assertIn("'top' has no vertex", ext.solve.message(obj))
            obj.bsarap.tol = 1e-3  # another new key (1e-4 is the built solver's: no build)
            bottom.location.x += 0.05
            bpy.context.view_layer.update()
            self.assertEqual(build.call_count, 2)
            activate(obj)
            with self.assertRaises(RuntimeError):
                bpy.ops.bsarap.add_controls()
            self.assertEqual(build.call_count, 3)

    def test_failed_build_renamed(self):
        """The stored error of a failed build is said with the object's current name."""
        obj = self.obj
        obj.vertex_groups["top"].remove(list(range(len(obj.data.vertices))))
        obj.bsarap.tol = 1e-5
        bpy.context.view_layer.update()
        self.assertTrue(ext.solve.message(obj).startswith("tube: "))
        obj.name = "renamed"
        activate(obj)
        with mock.patch.object(ext.solve, "build", wraps=ext.solve.build) as build:
            with self.assertRaises(RuntimeError) as cm:
                bpy.ops.bsarap.pose()
            self.assertEqual(build.call_count, 0)  # not built again
        self.assertIn("renamed: vertex group 'top' has no vertex", str(cm.exception))
        self.assertNotIn("tube", str(cm.exception))

    def test_linked_library_mesh(self):
        """A mesh linked from a library cannot take the pose key: refused with a message, not
        an unexpected error on every update."""
        path = os.path.join(tempfile.mkdtemp(), "lib.blend")
        bpy.ops.wm.save_as_mainfile(filepath=path)
        obj = link_rig(path)[0].make_local()  # the object local, its mesh still linked
        self.assertIsNotNone(obj.data.library)
        activate(obj)
        with self.assertRaises(RuntimeError) as cm:
            bpy.ops.bsarap.pose()
        self.assertIn("tube: the mesh is linked from a library (lib.blend)", str(cm.exception))
        self.assertIn("make it local", str(cm.exception))

    def test_singular_object_matrix(self):
        obj, sc = self.obj, bpy.context.scene
        bpy.data.objects["top"].location.x += 0.3
        obj.scale = (1.0, 1.0, 0.0)
        bpy.context.view_layer.update()
        ext.handlers.update_scene(sc)  # must not raise
        self.assertIn("singular (a scale of 0 on an axis)", ext.solve.message(obj))
        with self.assertRaises(ext.handles.HandleError):
            ext.solve.control_deltas(obj)
        obj.scale = (1.0, 1.0, 1.0)
        bpy.context.view_layer.update()
        assert_pose_follows(obj)

    def test_unexpected_error_reported_once(self):
        obj, sc = self.obj, bpy.context.scene
        out = io.StringIO()
        with mock.patch.object(ext.solve, "update", side_effect=ValueError("boom")):
            with contextlib.redirect_stdout(out):
                for _ in range(3):
                    ext.handlers.update_scene(sc)
        self.assertEqual(ext.solve.message(obj), "tube: unexpected error (ValueError: boom)")
        self.assertEqual(out.getvalue().count("boom"), 1)
        st = ext.solve.state(obj)
        st.converged = False
        st.moved_at = 0.0
        with mock.patch.object(ext.solve, "finish_step", side_effect=KeyError("k")):
            ext.handlers.finish_timer()  # must not raise
        self.assertIn("unexpected error (KeyError", ext.solve.message(obj))

    def test_basis_edit_rebuilds(self):
        obj = self.obj
        st = ext.solve.state(obj)
        basis = obj.data.shape_keys.reference_key
        co = key_co(basis)
        co[:, 0] *= 1.5
        basis.points.foreach_set("co", co.astype(np.float32).ravel())
        obj.data.update()
        bpy.data.objects["top"].location.x += 0.3
        bpy.context.view_layer.update()
        new = ext.solve.state(obj)
        self.assertIsNot(new, st)
        np.testing.assert_allclose(new.rest, co, atol=1e-6)
        self.assertIn("rest mesh (basis) changed", ext.solve.message(obj))

    def test_non_uniform_scale_warned(self):
        obj = self.obj
        self.assertIsNone(ext.solve.scale_warning(obj))
        obj.scale = (2.0, 2.0, 2.0)
        bpy.context.view_layer.update()
        self.assertIsNone(ext.solve.scale_warning(obj))
        obj.scale = (1.0, 1.0, 3.0)
        bpy.context.view_layer.update()
        labels = draw_panel(ext.panel.BSARAP_PT_pose, obj).labels
        self.assertTrue(any("apply scale first" in t for t in labels), labels)


class Reconnected(unittest.TestCase):
    """An edit of the faces that keeps the element counts (Rotate Edge on a triangle mesh, faces
    sorted) rebuilds the solver, which else went on solving on the old connectivity: the
    topology's fingerprint checks the connectivity, not only the counts."""

    def setUp(self):
        bpy.ops.wm.read_homefile(use_empty=True)
        self.obj = tube()
        self.edit(lambda bm: bmesh.ops.triangulate(bm, faces=bm.faces[:]))
        make_controls(self.obj, ["bottom", "top"])

    def edit(self, change):
        """``change(bm)`` on the mesh through bmesh (its shape keys and vertex groups kept)."""
        me = self.obj.data
        bm = bmesh.new()
        bm.from_mesh(me)
        change(bm)
        bm.to_mesh(me)
        bm.free()
        me.update()

    def assert_rebuilt(self, change):
        """``change`` keeps the counts, yet the next update rebuilds the solver, says so, and
        poses with the mesh's triangles now: the pose of a Deformer built from them."""
        obj = self.obj
        counts = ext.handles.topology_fingerprint(obj.data)[:4]
        triangles = ext.handles.triangles(obj.data)
        st = ext.solve.state(obj)
        self.edit(change)
        self.assertEqual(ext.handles.topology_fingerprint(obj.data)[:4], counts)
        self.assertFalse(np.array_equal(ext.handles.triangles(obj.data), triangles))
        bpy.data.objects["top"].location.x += 0.4
        bpy.context.view_layer.update()  # the live update
        new = ext.solve.state(obj)
        self.assertIsNot(new, st, "solved on the old connectivity")
        self.assertIn("topology changed (faces reconnected", ext.solve.message(obj))
        ref = bsarap.Deformer(
            new.rest, ext.handles.triangles(obj.data), new.labels, **obj.bsarap.solver_settings()
        )
        want = ref.solve_targets(ext.solve.targets(new, ext.solve.control_deltas(obj)))
        np.testing.assert_allclose(pose_of(obj), want, atol=1e-5)
        assert_pose_follows(obj)

    def test_rotate_edge(self):
        def rotate(bm):
            # an edge between two triangles halfway up the tube, turned to the other diagonal
            edge = next(
                e for e in bm.edges
                if len(e.link_faces) == 2 and all(abs(v.co.z - 2.0) < 0.5 for v in e.verts)
                and abs(e.verts[0].co.z - e.verts[1].co.z) > 1e-3
            )
            self.assertEqual(len(bmesh.ops.rotate_edges(bm, edges=[edge])["edges"]), 1)

        self.assert_rebuilt(rotate)

    def test_faces_sorted(self):
        self.assert_rebuilt(lambda bm: bm.faces.sort(key=lambda f: -f.index))

    def test_faces_split_another_way(self):
        """The same corners cut into faces another way (a quad and a triangle, or a triangle and
        a quad): the counts and each corner's vertex stay, the closing edges change."""
        verts = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0), (3, 0, 0), (2, 1, 0)]
        meshes = []
        for faces in ([(0, 1, 2, 3), (4, 5, 6)], [(0, 1, 2), (3, 4, 5, 6)]):
            me = bpy.data.meshes.new("split")
            me.from_pydata(verts, [], faces)
            me.update()
            meshes.append(me)
        a, b = (ext.handles.topology_fingerprint(me) for me in meshes)
        self.assertEqual(a[:4], b[:4])
        self.assertNotEqual(a, b)

    def test_fingerprint_without_the_internal_attributes(self):
        """Where Blender has no internal connectivity attributes, the same numbers are read
        through the mesh's loops and edges: the same fingerprint."""
        me = self.obj.data
        plain = types.SimpleNamespace(
            attributes={}, vertices=me.vertices, edges=me.edges, loops=me.loops,
            polygons=me.polygons,
        )
        fingerprint = ext.handles.topology_fingerprint
        self.assertEqual(fingerprint(plain), fingerprint(me))


class SessionKeys(unittest.TestCase):
    """The solver states are kept under the object's session uid: a rename keeps its solver, a
    deleted object's goes at the next update."""

    def setUp(self):
        self.obj = posed_tube()

    def test_rename_keeps_the_solver(self):
        obj = self.obj
        st = ext.solve.state(obj)
        solves = st.solves
        obj.name = "renamed"
        bpy.data.objects["top"].location.x += 0.3
        bpy.context.view_layer.update()
        self.assertIs(ext.solve.state(obj), st)  # the same Deformer: no rebuild
        self.assertEqual(st.solves, solves + 1)
        self.assertEqual(list(ext.solve._states.values()), [st])  # nothing under the old key
        self.assertFalse([m for m in ext.solve.messages.values() if "rebuilt" in m])
        assert_pose_follows(obj)
        # a new object given the old name starts from nothing
        other = tube("tube")
        self.assertEqual(other.name, "tube")
        self.assertIsNone(ext.solve.built(other))

    def test_deleted_object_dropped(self):
        obj = self.obj
        obj.vertex_groups["top"].remove(list(range(len(obj.data.vertices))))
        obj.bsarap.tol = 1e-5  # a failed build kept, with its message
        bpy.context.view_layer.update()
        self.assertEqual(len(ext.solve._states), 1)
        self.assertEqual(len(ext.solve._failures), 1)
        self.assertEqual(len(ext.solve.messages), 1)
        activate(obj)
        self.assertEqual(bpy.ops.object.delete(), {"FINISHED"})
        bpy.context.view_layer.update()
        self.assertEqual(ext.solve._states, {})
        self.assertEqual(ext.solve._failures, {})
        self.assertEqual(ext.solve.messages, {})
        top = bpy.data.objects["top"]
        self.assertIsNone(ext.claims.owner(top))  # its controls are free again
        self.assertIsNone(top.bsarap_owner)  # the claim no longer holds the deleted object
        self.assertEqual(obj.users, 0)


class Copies(unittest.TestCase):
    """A copy of a posed object points to its controls: it is refused with a message (one Empty
    never drives two meshes) until Add Controls gives it its own, placed as the original's."""

    def setUp(self):
        self.obj = posed_tube(top_x=0.5)

    def assert_copy_refused(self, dup, original, *, follows=True):
        """Pose Now on the copy ``dup`` is refused naming ``original``; moving a control then
        poses the original (with ``follows``)."""
        activate(dup)
        with self.assertRaises(RuntimeError) as cm:
            bpy.ops.bsarap.pose()
        self.assertIn(f"pose '{original.name}'", str(cm.exception))
        if follows:
            bpy.data.objects["top"].location.y += 0.3
            bpy.context.view_layer.update()
            assert_pose_follows(original)

    def test_copy_refused_until_own_controls(self):
        obj = self.obj
        dup = duplicate(self.obj)
        self.assertIs(dup.bsarap.groups[1].control, obj.bsarap.groups[1].control)
        frozen = pose_of(dup)
        top = bpy.data.objects["top"]
        top.location.y += 0.4
        bpy.context.view_layer.update()
        assert_pose_follows(obj)  # the original follows its controls
        np.testing.assert_array_equal(pose_of(dup), frozen)  # the copy does not
        self.assertIsNone(ext.solve.built(dup))  # no solver built for it
        msg = ext.solve.message(dup)
        self.assertIn("the controls of 'bottom', 'top' pose 'tube'", msg)
        self.assertIn("Add Controls gives tube.001 its own", msg)
        self.assertEqual(draw_group_rows(dup).icons, ["GROUP_VERTEX", "ERROR"] * 2)
        self.assertEqual(draw_group_rows(obj).icons, ["GROUP_VERTEX", "EMPTY_AXIS"] * 2)
        self.assertIn(msg, draw_panel(ext.panel.BSARAP_PT_pose, dup).labels)
        activate(dup)
        for op in (bpy.ops.bsarap.pose, bpy.ops.bsarap.bake_shape_keys):
            with self.assertRaises(RuntimeError) as cm:
                op()
            self.assertIn("Add Controls gives tube.001 its own", str(cm.exception))
        # its own controls, placed on it as the original's are on the original: the same pose
        self.assertEqual(bpy.ops.bsarap.add_controls(), {"FINISHED"})
        for g, h in zip(dup.bsarap.groups, obj.bsarap.groups):
            self.assertIsNot(g.control, h.control)
            self.assertIn(g.control.name, ("bottom.001", "top.001"))
        np.testing.assert_allclose(ext.solve.control_deltas(dup), ext.solve.control_deltas(obj), atol=1e-6)
        st = ext.solve.state(dup)
        idx, want = expected_handles(dup, st, 1)
        np.testing.assert_allclose(pose_of(dup)[idx], want, atol=1e-5)
        np.testing.assert_allclose(pose_of(dup)[idx], pose_of(obj)[idx], atol=1e-5)
        self.assertEqual(draw_group_rows(dup).icons, ["GROUP_VERTEX", "EMPTY_AXIS"] * 2)
        # each drives its own mesh
        before = pose_of(obj)
        dup.bsarap.groups[1].control.location.z -= 0.5
        bpy.context.view_layer.update()
        np.testing.assert_array_equal(pose_of(obj), before)
        idx, want = expected_handles(dup, st, 1)
        np.testing.assert_allclose(pose_of(dup)[idx], want, atol=1e-5)

    def test_original_deleted(self):
        """The original deleted: its controls are free, the copy takes them (the message goes)."""
        obj = self.obj
        dup = duplicate(self.obj)
        self.assertIn("pose 'tube'", ext.solve.message(dup))
        activate(obj)
        self.assertEqual(bpy.ops.object.delete(), {"FINISHED"})
        bpy.context.view_layer.update()
        bpy.data.objects["top"].location.y += 0.3
        bpy.context.view_layer.update()
        self.assertIsNone(ext.solve.message(dup))
        idx, want = expected_handles(dup, ext.solve.state(dup), 1)
        np.testing.assert_allclose(pose_of(dup)[idx], want, atol=1e-5)

    def test_object_copy(self):
        """``Object.copy`` from a script: the same."""
        obj = self.obj
        dup = obj.copy()
        dup.data = obj.data.copy()
        bpy.context.scene.collection.objects.link(dup)
        bpy.data.objects["bottom"].location.x -= 0.2
        bpy.context.view_layer.update()
        assert_pose_follows(obj)
        self.assertIn("pose 'tube'", ext.solve.message(dup))

    def test_remove_controls_of_a_copy(self):
        """Remove Controls on the copy lets go of the original's controls without deleting them."""
        obj = self.obj
        dup = duplicate(self.obj)
        activate(dup)
        self.assertEqual(bpy.ops.bsarap.remove_controls(), {"FINISHED"})
        self.assertIn("top", bpy.context.scene.objects)
        self.assertIs(obj.bsarap.groups[1].control, bpy.data.objects["top"])
        self.assertIsNone(dup.bsarap.groups[1].control)
        bpy.data.objects["top"].location.y += 0.3
        bpy.context.view_layer.update()
        assert_pose_follows(obj)

    def test_linked_duplicate(self):
        """Alt+D shares the mesh, so its pose key: it shows the original's pose, and Add Controls
        is refused (two sets of controls would fight over the key); Remove Controls keeps it."""
        obj = self.obj
        dup = duplicate(self.obj, linked=True)
        self.assertIs(dup.data, obj.data)
        msg = ext.solve.message(dup)
        self.assertIn("shares its mesh with 'tube', which poses it (a linked duplicate, Alt+D", msg)
        self.assertIn("Make Single User", msg)
        activate(dup)
        with self.assertRaises(RuntimeError) as cm:
            bpy.ops.bsarap.add_controls()
        self.assertIn("a linked duplicate", str(cm.exception))
        self.assertEqual(bpy.ops.bsarap.remove_controls(), {"FINISHED"})
        self.assertIn(ext.solve.POSE_KEY, obj.data.shape_keys.key_blocks)
        bpy.data.objects["top"].location.y += 0.3
        bpy.context.view_layer.update()
        assert_pose_follows(obj)

    def assert_refused_shared(self, obj, dup):
        """``dup`` shares the mesh of ``obj``, which poses it: its pose key is the original's,
        live updates and Add Controls refuse it, and the original keeps posing."""
        self.assertIs(dup.data, obj.data)
        activate(dup)
        with self.assertRaises(RuntimeError) as cm:
            bpy.ops.bsarap.add_controls()
        self.assertIn("shares its mesh with 'tube', which poses it (a linked duplicate, Alt+D", str(cm.exception))
        self.assertIn("Make Single User", str(cm.exception))
        with self.assertRaises(RuntimeError) as cm:
            bpy.ops.bsarap.pose()
        self.assertIn("a linked duplicate", str(cm.exception))
        for o in bpy.context.scene.objects:
            if o.type == "EMPTY" and o not in (g.control for g in obj.bsarap.groups):
                o.location.z -= 0.5  # the duplicate's own controls, if any: they pose nothing
        bpy.data.objects["top"].location.y += 0.3
        bpy.context.view_layer.update()
        assert_pose_follows(obj)
        self.assertIsNone(ext.solve.message(obj))

    def test_linked_duplicate_with_its_controls(self):
        """Alt+D of the mesh with its Empties: the duplicate points to its own new Empties, but
        shares the pose key: refused."""
        obj = self.obj
        for name in ("bottom", "top"):
            bpy.data.objects[name].select_set(True)
        self.assertEqual(bpy.ops.object.duplicate(linked=True), {"FINISHED"})
        dup = bpy.data.objects["tube.001"]
        self.assertEqual([g.control.name for g in dup.bsarap.groups], ["bottom.001", "top.001"])
        bpy.data.objects["top.001"].location.z -= 0.5
        bpy.context.view_layer.update()
        self.assertIn("shares its mesh with 'tube'", ext.solve.message(dup))
        self.assertIsNone(ext.solve.built(dup))
        self.assert_refused_shared(obj, dup)

    def test_linked_duplicate_controls_removed(self):
        """Alt+D, Remove Controls on the duplicate (it lets go of the original's), then Add
        Controls: refused, the mesh is still the original's."""
        dup = duplicate(self.obj, linked=True)
        activate(dup)
        self.assertEqual(bpy.ops.bsarap.remove_controls(), {"FINISHED"})
        self.assert_refused_shared(self.obj, dup)

    def test_linked_duplicate_before_controls(self):
        """Alt+D before any controls, then Add Controls on both: the first posed keeps the mesh;
        made single-user, the duplicate poses on its own."""
        bpy.ops.wm.read_homefile(use_empty=True)
        obj = tube()
        for g in ("bottom", "top"):
            self.assertEqual(bpy.ops.bsarap.add_group(group=g), {"FINISHED"})
        self.assertEqual(bpy.ops.object.duplicate(linked=True), {"FINISHED"})
        dup = bpy.context.view_layer.objects.active
        dup.location.x += 3.0
        activate(obj)
        self.assertEqual(bpy.ops.bsarap.add_controls(), {"FINISHED"})
        self.assert_refused_shared(obj, dup)
        # made single-user (Object & Data): its own mesh, its own controls
        activate(dup)
        self.assertEqual(bpy.ops.object.make_single_user(object=True, obdata=True), {"FINISHED"})
        self.assertIsNot(dup.data, obj.data)
        self.assertEqual(bpy.ops.bsarap.add_controls(), {"FINISHED"})
        self.assertIsNone(ext.solve.message(dup))
        assert_pose_follows(dup)

    def test_two_posed_objects_given_one_mesh(self):
        """Two posed objects given one mesh (Link Object Data): the first claim keeps it, and
        the other is told that both were posed, not that it is a linked duplicate."""
        obj = self.obj
        pipe = tube("pipe")
        make_controls(pipe, ["bottom", "top"])
        activate(obj)
        pipe.select_set(True)
        self.assertEqual(bpy.ops.object.make_links_data(type="OBDATA"), {"FINISHED"})
        bpy.context.view_layer.update()
        self.assertIs(pipe.data, obj.data)
        msg = ext.solve.message(pipe)
        self.assertIn("shares its mesh with 'tube', which poses it (both were posed", msg)
        self.assertNotIn("Alt+D", msg)
        self.assertIsNone(ext.solve.message(obj))
        bpy.data.objects["top"].location.y += 0.3
        bpy.context.view_layer.update()
        assert_pose_follows(obj)

    def test_duplicated_with_its_controls(self):
        """Shift+D of the mesh with its Empties: Blender points the copy to the copied Empties,
        which it claims: both pose, each with its own."""
        obj = self.obj
        for name in ("bottom", "top"):
            bpy.data.objects[name].select_set(True)
        self.assertEqual(bpy.ops.object.duplicate(), {"FINISHED"})
        dup = bpy.data.objects["tube.001"]
        self.assertEqual([g.control.name for g in dup.bsarap.groups], ["bottom.001", "top.001"])
        bpy.data.objects["top.001"].location.z -= 0.5
        bpy.context.view_layer.update()
        self.assertIsNone(ext.solve.message(dup))
        idx, want = expected_handles(dup, ext.solve.state(dup), 1)
        np.testing.assert_allclose(pose_of(dup)[idx], want, atol=1e-5)
        assert_pose_follows(obj)

    def test_saved_with_a_copy(self):
        """A file saved with an original and its copy sharing the controls: once reopened, the
        original keeps them (the claims are saved in the file), whichever is solved first, its
        name sorting after the copy's."""
        duplicate(self.obj)
        self.obj.name = "z-tube"  # loaded, "tube.001" comes first in bpy.data.objects
        path = os.path.join(tempfile.mkdtemp(), "copies.blend")
        bpy.ops.wm.save_as_mainfile(filepath=path)
        bpy.ops.wm.open_mainfile(filepath=path)
        obj, dup = bpy.data.objects["z-tube"], bpy.data.objects["tube.001"]
        self.assertEqual([o.name for o in bpy.data.objects if o.type == "MESH"], ["tube.001", "z-tube"])
        self.assert_copy_refused(dup, obj)

    def test_claims_kept_through_undo(self):
        """The original deleted, the copy takes its controls, Ctrl+Z: the original is back and
        keeps them (the claims are undone with the file's data)."""
        dup = duplicate(self.obj)
        bpy.ops.ed.undo_push(message="copied")
        activate(self.obj)
        self.assertEqual(bpy.ops.object.delete(), {"FINISHED"})
        bpy.context.view_layer.update()
        bpy.data.objects["top"].location.y += 0.3
        bpy.context.view_layer.update()
        self.assertIsNone(ext.solve.message(dup))  # the copy poses with them now
        bpy.ops.ed.undo_push(message="deleted")
        bpy.ops.ed.undo()
        obj, dup = bpy.data.objects["tube"], bpy.data.objects["tube.001"]
        self.assert_copy_refused(dup, obj)

    def test_claims_kept_through_reenabling(self):
        """The extension disabled and enabled again: the copy, solved first, is still refused."""
        dup = duplicate(self.obj)
        self.obj.bsarap.live = False  # no update solves the original before the copy
        module = "bl_ext.user_default.bsarap_pose"
        bpy.ops.preferences.addon_disable(module=module)
        bpy.ops.preferences.addon_enable(module=module)
        self.assert_copy_refused(dup, self.obj, follows=False)


class Render(unittest.TestCase):
    def test_live_suspended_while_rendering(self):
        """Blender: handlers that change data during a render can crash it. From render_init /
        render_pre to render_complete / render_cancel nothing is solved."""
        obj, sc = posed_tube(), bpy.context.scene
        h = ext.handlers
        for name, fn in (
            ("render_init", h.on_render_start),
            ("render_pre", h.on_render_start),
            ("render_complete", h.on_render_end),
            ("render_cancel", h.on_render_end),
        ):
            self.assertIn(fn, getattr(bpy.app.handlers, name))
        # a real render (Workbench, 16 px): the flag is up during it, down after
        cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
        sc.collection.objects.link(cam)
        sc.camera, cam.location = cam, (0.0, -10.0, 2.0)
        sc.render.engine = "BLENDER_WORKBENCH"
        sc.render.resolution_x = sc.render.resolution_y = 16
        seen = []

        def record(_scene, *_):
            seen.append(h.rendering)

        bpy.app.handlers.render_post.append(record)
        try:
            bpy.ops.render.render()
        finally:
            bpy.app.handlers.render_post.remove(record)
        self.assertEqual(seen, [True])
        self.assertFalse(h.rendering)
        # while the flag is up, a moved control is not solved; once down, it is
        st = ext.solve.state(obj)
        solves = st.solves
        h.on_render_start(sc)
        bpy.data.objects["top"].location.x += 0.3
        bpy.context.view_layer.update()
        self.assertEqual(st.solves, solves)
        h.on_render_end(sc)
        h.update_scene(sc)  # the next depsgraph update
        self.assertEqual(st.solves, solves + 1)
        assert_pose_follows(obj)
        # A render that ends without render_complete or render_cancel (its movie output failed
        # to start) held posing off for the session: another file poses again.
        h.on_render_start(sc)
        h.on_load()
        self.assertFalse(h.rendering)

    def test_operators_wait_for_a_bake(self):
        """Pose Now and Add Controls during a bake wrote a pose key and moved the bake's
        solver; they are refused while it runs."""
        obj = posed_tube()
        activate(obj)
        st = ext.solve.state(obj)
        self.assertTrue(bpy.ops.bsarap.pose.poll())
        st.baking = True
        try:
            self.assertFalse(bpy.ops.bsarap.pose.poll())
            self.assertFalse(bpy.ops.bsarap.add_controls.poll())
        finally:
            st.baking = False
        self.assertTrue(bpy.ops.bsarap.pose.poll())


if __name__ == "__main__":
    if SKIP:
        print(f"skipped: {SKIP}")
        sys.exit(0)
    unittest.main()
