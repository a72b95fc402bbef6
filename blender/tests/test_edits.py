"""Tests of the Blender extension in bpy, headless: edits of a posed object that must keep its
pose, its transform applied to its mesh (Apply, Set Origin) and undone, a handle group's vertex
group renamed, a solver setting changed while a bake runs.

Run with Blender's Python (bpy from PyPI):
    tools/blender/.venv/bin/python blender/tests/test_edits.py [-v] [Class.test_name]
The extension zip is found as common.py says. Skips (with the reason) when bpy or the zip is
missing.
"""

from __future__ import annotations

import os
import sys
import types
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import (  # noqa: E402  (sets BLENDER_USER_RESOURCES before bpy)
    SKIP, activate, assert_pose_follows, bpy, ext, fake_modal_bake, key_co, np, pose_of, posed_tube,
    setUpModule
)


def world_pose(obj):
    """The live pose's vertices in world space."""
    M = np.array(obj.matrix_world, dtype=np.float64)
    return pose_of(obj) @ M[:3, :3].T + M[:3, 3]


def rests(obj):
    return [tuple(g.rest_matrix) for g in obj.bsarap.groups]


class AppliedTransform(unittest.TestCase):
    """The object's transform put into its mesh (Ctrl+A, Set Origin) moves nothing in the world:
    the controls' rests follow, so the pose stays where it was."""

    def setUp(self):
        self.obj = posed_tube(top_x=0.8)
        obj = self.obj
        # converged solves: the pose rebuilt from scratch is the same minimum
        obj.bsarap.method, obj.bsarap.tol, obj.bsarap.max_iters = "arap", 1e-9, 3000
        obj.rotation_euler = (0.3, 0.0, 0.2)
        obj.scale = (2.0, 2.0, 2.0)
        bpy.context.view_layer.update()
        self.handles = np.nonzero(ext.solve.state(obj).labels >= 0)[0]
        self.before = world_pose(obj)
        self.diag = ext.solve.state(obj).diagonal * 2.0

    def assert_pose_kept(self):
        obj = self.obj
        after = world_pose(obj)
        # the handles are where they were (the controls did not move), the rest of the mesh
        # solved again to about the same pose
        np.testing.assert_allclose(after[self.handles], self.before[self.handles], atol=1e-4 * self.diag)
        self.assertLess(np.abs(after - self.before).max(), 1e-3 * self.diag)
        assert_pose_follows(obj)

    def apply(self, **what):
        activate(self.obj)
        self.assertEqual(bpy.ops.object.transform_apply(**what), {"FINISHED"})
        bpy.context.view_layer.update()

    def test_apply_scale(self):
        self.apply(location=False, rotation=False, scale=True)
        self.assertEqual(tuple(self.obj.scale), (1.0, 1.0, 1.0))
        self.assert_pose_kept()
        self.assertIn("Apply or Set Origin", ext.solve.message(self.obj))

    def test_apply_all(self):
        self.apply(location=True, rotation=True, scale=True)
        self.assert_pose_kept()

    def test_set_origin(self):
        activate(self.obj)
        self.assertEqual(bpy.ops.object.origin_set(type="ORIGIN_GEOMETRY", center="BOUNDS"), {"FINISHED"})
        bpy.context.view_layer.update()
        self.assertGreater(np.linalg.norm(self.obj.location - bpy.context.scene.cursor.location), 0.5)
        self.assert_pose_kept()

    def test_undo_and_redo(self):
        """Undo brings back the rests recorded against the basis it brings back: they are not
        mapped again. Redo brings back the applied basis with the rests of before, mapped then."""
        obj = self.obj
        bpy.ops.ed.undo_push(message="posed")
        self.apply(location=False, rotation=False, scale=True)
        bpy.ops.ed.undo_push(message="applied")
        bpy.ops.ed.undo()
        bpy.context.view_layer.update()
        obj = self.obj = bpy.data.objects["tube"]
        self.assertEqual(tuple(obj.scale), (2.0, 2.0, 2.0))
        self.assert_pose_kept()
        bpy.ops.ed.redo()
        bpy.context.view_layer.update()
        obj = self.obj = bpy.data.objects["tube"]
        self.assertEqual(tuple(obj.scale), (1.0, 1.0, 1.0))
        self.assert_pose_kept()

    def test_basis_edit_keeps_the_rests(self):
        """The basis scaled in place, the object where it was: a shape edit, not a transform
        applied; the rests stay."""
        obj = self.obj
        kept = rests(obj)
        basis = obj.data.shape_keys.reference_key
        co = key_co(basis) * 1.5
        basis.points.foreach_set("co", co.astype(np.float32).ravel())
        obj.data.update()
        bpy.context.view_layer.update()
        self.assertIn("rest mesh (basis) changed", ext.solve.message(obj))
        self.assertEqual(rests(obj), kept)


class RenamedGroup(unittest.TestCase):
    """A handle group's vertex group renamed: the handle group follows it, with its solver."""

    def setUp(self):
        self.obj = posed_tube(top_x=0.5)

    def move_top(self):
        bpy.data.objects["top"].location.x += 0.3
        bpy.context.view_layer.update()

    def test_rename_followed(self):
        obj = self.obj
        st = ext.solve.state(obj)
        obj.vertex_groups["top"].name = "head"
        self.move_top()
        self.assertEqual([g.name for g in obj.bsarap.groups], ["bottom", "head"])
        self.assertIs(ext.solve.state(obj), st)  # the same vertices: not built again
        self.assertIn("'top' to 'head'", ext.solve.message(obj))
        assert_pose_follows(obj)

    def test_rename_with_live_off(self):
        obj = self.obj
        obj.bsarap.live = False
        obj.vertex_groups["bottom"].name = "feet"
        self.move_top()
        self.assertEqual(obj.bsarap.groups[0].name, "bottom")  # nothing read it yet
        activate(obj)
        self.assertEqual(bpy.ops.bsarap.pose(), {"FINISHED"})
        self.assertEqual(obj.bsarap.groups[0].name, "feet")
        assert_pose_follows(obj)

    def test_deleted_group_not_taken_for_a_rename(self):
        """A vertex group added after the controls shifts into the deleted one's index: the
        count tells a deletion from a rename."""
        obj = self.obj
        obj.vertex_groups.new(name="extra")
        self.move_top()  # noted: three vertex groups
        obj.vertex_groups.remove(obj.vertex_groups["top"])
        self.move_top()
        self.assertEqual(obj.vertex_groups[1].name, "extra")
        self.assertEqual(obj.bsarap.groups[1].name, "top")
        self.assertIn("'top' does not exist", ext.solve.message(obj))
        # another added since: as many groups as before the delete, still not a rename
        obj.vertex_groups.new(name="later")
        self.move_top()
        self.assertEqual(obj.bsarap.groups[1].name, "top")
        self.assertIn("'top' does not exist", ext.solve.message(obj))

    def test_name_taken_by_another_handle_group_not_followed(self):
        obj = self.obj
        obj.vertex_groups.new(name="spare")
        self.move_top()
        # top renamed, then bottom given top's old name: "top" exists, "bottom" does not
        obj.vertex_groups["top"].name = "head"
        obj.vertex_groups["bottom"].name = "top"
        self.move_top()
        self.assertEqual([g.name for g in obj.bsarap.groups], ["bottom", "top"])
        self.assertIn("'bottom' does not exist", ext.solve.message(obj))


class SettingChangedWhileBaking(unittest.TestCase):
    """A solver setting changed while a bake runs rebuilds the live solver, which waits for the
    bake as the old one did: no live solve writes the pose key between the bake's frames."""

    def test_rebuilt_solver_waits(self):
        obj = posed_tube(top_x=0.5)
        Op = ext.operators.BSARAP_OT_bake_shape_keys
        op, ctx, _calls = fake_modal_bake(obj, Op, range(1, 4))
        timer = types.SimpleNamespace(type="TIMER")
        self.assertEqual(Op.modal(op, ctx, timer), {"RUNNING_MODAL"})
        obj.bsarap.max_iters = 50
        bpy.data.objects["top"].location.x += 0.3
        bpy.context.view_layer.update()
        st = ext.solve.built(obj)
        self.assertIsNot(st, op._baker.st)  # rebuilt for the new setting
        self.assertTrue(ext.solve.baking(obj))
        self.assertEqual(st.solves, 0)  # no live solve mid-bake
        result = {"RUNNING_MODAL"}
        while result == {"RUNNING_MODAL"}:
            result = Op.modal(op, ctx, timer)
        self.assertEqual(result, {"FINISHED"})
        self.assertFalse(ext.solve.baking(obj))


if __name__ == "__main__":
    if SKIP:
        print(f"SKIPPED: {SKIP}")
        sys.exit(0)
    unittest.main()
