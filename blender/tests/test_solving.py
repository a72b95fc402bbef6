"""Tests of the Blender extension's solving in bpy, headless: the smooth-rotations energy and
its bending length against the Python API's Deformer, and the finishing steps that take the
live pose to its rest once the controls stop (again after an undo or redo).

Run with Blender's Python (bpy from PyPI):
    tools/blender/.venv/bin/python blender/tests/test_solving.py [-v] [Class.test_name]
The extension zip is found as common.py says. Skips (with the reason) when bpy or the zip is
missing.
"""

from __future__ import annotations

import os
import sys
import unittest
from unittest import mock

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import (  # noqa: E402  (sets BLENDER_USER_RESOURCES before bpy)
    SKIP, bpy, bsarap, draw_panel, expected_handles, ext, make_controls, np, pose_of,
    setUpModule, tube
)

if SKIP is None:
    from mathutils import Euler, Matrix, Vector


class SmoothRotations(unittest.TestCase):
    """The smooth-rotations energy and its bending length, from the object's settings to
    ``bsarap.Deformer``: the live pose is the direct Deformer's for the same handles, and it is
    not the spokes-and-rims pose."""

    @classmethod
    def setUpClass(cls):
        bpy.ops.wm.read_homefile(use_empty=True)
        cls.obj = tube()
        make_controls(cls.obj, ["bottom", "top"])
        # a bend: the top ring moved sideways and turned, the bottom held
        top = bpy.data.objects["top"]
        top.location = Vector(top.location) + Vector((1.2, 0.0, -0.6))
        top.rotation_euler = Euler((0.0, 0.7, 0.0))
        bpy.context.view_layer.update()

    def reference(self, **settings):
        """A fresh Deformer (the Python API, not the extension) solving the extension's handle
        targets for the controls' current motion."""
        obj = self.obj
        st = ext.solve.state(obj)
        ref = bsarap.Deformer(st.rest, ext.handles.triangles(obj.data), st.labels, **settings)
        return ref, ref.solve_targets(ext.solve.targets(st, ext.solve.control_deltas(obj)))

    def pose_with(self, energy, bending_length, *, fresh=False):
        """Switch the settings and run the live handler: one solve, from rest, of a solver
        rebuilt for them (``fresh``: dropped first, for settings that do not change), as the
        reference's."""
        obj = self.obj
        obj.bsarap.energy = energy
        obj.bsarap.bending_length = bending_length
        ext.solve.messages.pop(ext.solve.uid(obj), None)
        if fresh:
            ext.solve.forget(obj)
        ext.handlers.update_scene(bpy.context.scene)
        bpy.context.view_layer.update()  # the handler again: nothing moved, no second solve
        self.assertEqual(ext.solve.state(obj).solves, 1)
        return pose_of(obj)

    def test_bending_length_setting(self):
        s = self.obj.bsarap
        self.assertIn("smooth-rotations", [item.identifier for item in s.bl_rna.properties["energy"].enum_items])
        prop = s.bl_rna.properties["bending_length"]
        self.assertAlmostEqual(prop.default, bsarap.DEFAULT_BENDING_LENGTH, places=6)
        self.assertAlmostEqual(prop.default, 0.02, places=6)
        self.assertAlmostEqual(prop.soft_min, 0.005, places=6)
        self.assertAlmostEqual(prop.soft_max, 0.1, places=6)
        self.assertEqual(prop.hard_max, bsarap.MAX_BENDING_LENGTH)
        self.assertGreater(prop.hard_min, 0.0)  # the solver refuses 0
        # the panel's world value: the fraction times the rest diagonal in object space
        st = ext.solve.state(self.obj)
        diag = np.linalg.norm(np.ptp(st.rest, axis=0))
        self.assertAlmostEqual(ext.solve.rest_diagonal(self.obj), diag, places=9)
        self.assertAlmostEqual(diag, np.sqrt(1.0 + 1.0 + 16.0), places=5)  # the tube's box

    def test_panel_shows_bending_length(self):
        """The Solver panel's draw (with a recording layout: no window headless) offers the
        bending length only for smooth rotations, with its value in the mesh's units."""
        obj = self.obj

        def draw():
            return draw_panel(ext.panel.BSARAP_PT_settings, obj)

        energy, ell = obj.bsarap.energy, obj.bsarap.bending_length
        try:
            obj.bsarap.energy = "spokes-and-rims"
            self.assertNotIn("bending_length", draw().props)
            self.assertNotIn("coarse_energy", draw().props)
            obj.bsarap.energy = "smooth-rotations"
            obj.bsarap.bending_length = 0.03
            layout = draw()
            self.assertIn("bending_length", layout.props)
            self.assertIn("coarse_energy", layout.props)
            diag = np.linalg.norm(np.ptp(ext.solve.state(obj).rest, axis=0))
            world = f"{obj.bsarap.bending_length * diag:.4g}"
            self.assertTrue(any(world in t for t in layout.labels), (world, layout.labels))
        finally:
            obj.bsarap.energy, obj.bsarap.bending_length = energy, ell

    def test_smooth_rotations_pose(self):
        obj = self.obj
        sar = self.pose_with("spokes-and-rims", 0.02, fresh=True)
        _, want = self.reference()
        np.testing.assert_allclose(sar, want, atol=1e-5)

        sr = self.pose_with("smooth-rotations", 0.05)
        st = ext.solve.state(obj)
        self.assertIn("settings or groups changed", ext.solve.message(obj))
        self.assertEqual(st.deformer.energy, "smooth-rotations")
        ell = float(obj.bsarap.bending_length)  # 0.05 as Blender's float32 stores it
        self.assertAlmostEqual(st.deformer.bending_length, ell, places=12)
        ref, want = self.reference(energy="smooth-rotations", bending_length=ell)
        self.assertEqual(ref.energy, "smooth-rotations")
        np.testing.assert_allclose(sr, want, atol=1e-5)
        self.assertAlmostEqual(st.deformer.bending_length_world, ell * st.diagonal, places=9)
        # the handles are where the controls put them, whatever the energy
        for k in (0, 1):
            idx, at = expected_handles(obj, st, k)
            np.testing.assert_allclose(sr[idx], at, atol=1e-5)
        # a different pose than spokes and rims: the free vertices differ by a visible amount
        free = st.labels < 0
        gap = np.linalg.norm(sr[free] - sar[free], axis=1).max()
        self.assertGreater(gap, 1e-2 * st.diagonal, "smooth rotations gave the spokes-and-rims pose")

        # another bending length rebuilds the solver and moves the pose
        longer = self.pose_with("smooth-rotations", 0.1)
        st = ext.solve.state(obj)
        self.assertIn("settings or groups changed", ext.solve.message(obj))
        ell = float(obj.bsarap.bending_length)
        self.assertAlmostEqual(st.deformer.bending_length, ell, places=12)
        _, want = self.reference(energy="smooth-rotations", bending_length=ell)
        np.testing.assert_allclose(longer, want, atol=1e-5)
        self.assertGreater(np.abs(longer - sr).max(), 1e-2 * st.diagonal)

    def test_galerkin_coarse_energy_pose(self):
        """The coarse energy setting reaches the solver: the Galerkin pose is the direct
        Deformer's for it, and not the decimated one's; under spokes and rims the setting is
        left out (the Galerkin energy restricts smooth rotations only)."""
        obj = self.obj
        try:
            obj.bsarap.coarse_energy = "decimated"
            decimated = self.pose_with("smooth-rotations", 0.02, fresh=True)
            obj.bsarap.coarse_energy = "galerkin"
            galerkin = self.pose_with("smooth-rotations", 0.02, fresh=True)
            # every setting as the extension passes it (its float32 tolerance decides where
            # the solve stops)
            _, want = self.reference(**obj.bsarap.solver_settings())
            np.testing.assert_allclose(galerkin, want, atol=1e-5)
            st = ext.solve.state(obj)
            self.assertGreater(np.abs(galerkin - decimated).max(), 1e-3 * st.diagonal)
            self.assertEqual(obj.bsarap.solver_settings()["coarse_energy"], "galerkin")
            obj.bsarap.energy = "spokes-and-rims"
            self.assertEqual(obj.bsarap.solver_settings()["coarse_energy"], "decimated")
        finally:
            obj.bsarap.coarse_energy = "decimated"
            obj.bsarap.energy = "spokes-and-rims"


class Seams(unittest.TestCase):
    """A mesh split at a seam (vertices at the same place, as Blender's glTF import leaves
    them at UV seams) poses as one surface: the solver gets it welded, and the pose key holds
    the seam's copies together. Posed unwelded, the seam opened."""

    def test_a_split_seam_stays_closed(self):
        bpy.ops.wm.read_homefile(use_empty=True)
        rings, around, radius, height = 16, 12, 0.5, 3.0
        # around + 1 columns: the last repeats the first exactly (a UV seam)
        angle = [2 * np.pi * (a % around) / around for a in range(around + 1)]
        verts = [
            (radius * np.cos(t), radius * np.sin(t), height * r / (rings - 1))
            for r in range(rings) for t in angle
        ]
        cols = around + 1
        faces = [
            (r * cols + a, r * cols + a + 1, (r + 1) * cols + a + 1, (r + 1) * cols + a)
            for r in range(rings - 1) for a in range(around)
        ]
        me = bpy.data.meshes.new("seamed")
        me.from_pydata(verts, [], faces)
        me.update()
        obj = bpy.data.objects.new("seamed", me)
        bpy.context.scene.collection.objects.link(obj)
        obj.vertex_groups.new(name="bottom").add(list(range(2 * cols)), 1.0, "REPLACE")
        top = list(range((rings - 2) * cols, rings * cols))
        obj.vertex_groups.new(name="top").add(top, 1.0, "REPLACE")
        make_controls(obj, ["bottom", "top"])
        control = bpy.data.objects["top"]
        control.location = Vector(control.location) + Vector((1.0, 0.3, -0.4))
        control.rotation_euler = Euler((0.4, 0.6, 0.0))
        bpy.context.view_layer.update()
        ext.handlers.update_scene(bpy.context.scene)
        pose = pose_of(obj)
        st = ext.solve.state(obj)
        first = pose[[r * cols for r in range(rings)]]
        last = pose[[r * cols + around for r in range(rings)]]
        gap = np.linalg.norm(first - last, axis=1).max()
        self.assertLess(gap, 1e-6 * st.diagonal, "the seam opened")
        self.assertEqual(len(st.cleaned_rest), rings * around, "the seam was not welded")
        moved = np.linalg.norm(pose - st.rest, axis=1).max()
        self.assertGreater(moved, 0.1 * st.diagonal, "nothing was posed")


class PanelUnits(unittest.TestCase):
    """The Solver panel's bending length in the mesh's units."""

    def test_bending_length_follows_the_rest_mesh(self):
        """The world-unit bending length of an object never posed follows its base mesh scaled
        in place (same topology), and so does a posed one's with Live off (no rebuild yet)."""
        bpy.ops.wm.read_homefile(use_empty=True)
        never = tube("never")
        posed = tube("posed")
        make_controls(posed, ["bottom", "top"])
        posed.bsarap.live = False
        for obj in (never, posed):
            obj.bsarap.energy = "smooth-rotations"
            obj.bsarap.bending_length = 0.05
            before = ext.solve.rest_diagonal(obj)
            obj.data.transform(Matrix.Scale(2.0, 4), shape_keys=True)  # the basis too
            obj.data.update()
            self.assertAlmostEqual(ext.solve.rest_diagonal(obj), 2.0 * before, places=5)
            labels = draw_panel(ext.panel.BSARAP_PT_settings, obj).labels
            world = f"{0.05 * 2.0 * before:.4g}"
            self.assertTrue(any(world in t for t in labels), (world, labels))


    def test_empty_mesh(self):
        """A mesh with no vertices (``meshes.new``: not even a position attribute): the panel
        says 0 units, and Add Controls that it has no faces."""
        bpy.ops.wm.read_homefile(use_empty=True)
        obj = bpy.data.objects.new("empty", bpy.data.meshes.new("empty"))
        bpy.context.scene.collection.objects.link(obj)
        obj.vertex_groups.new(name="g")
        obj.bsarap.groups.add().name = "g"
        obj.bsarap.energy = "smooth-rotations"
        labels = draw_panel(ext.panel.BSARAP_PT_settings, obj).labels
        self.assertTrue(any("= 0 units" in t for t in labels), labels)
        for o in bpy.context.view_layer.objects:
            o.select_set(False)
        obj.select_set(True)
        bpy.context.view_layer.objects.active = obj
        with self.assertRaises(RuntimeError) as cm:
            bpy.ops.bsarap.add_controls()
        self.assertIn("no faces", str(cm.exception))


class Finishing(unittest.TestCase):
    """Once the controls rest, the timer's steps take the live pose to what it is at rest:
    solved again until a solve converges, then settled (``bsarap-coarse``'s settle
    iterations), the pose of the same loop run on a Deformer directly. (Timers do not run in
    background mode: the test calls the timer's function as Blender would.)"""

    @classmethod
    def setUpClass(cls):
        bpy.ops.wm.read_homefile(use_empty=True)
        cls.obj = tube()
        cls.obj.bsarap.max_iters = 3  # the live solve stops short of converged
        make_controls(cls.obj, ["bottom", "top"])

    def test_1_rest_pose(self):
        obj = self.obj
        st = ext.solve.state(obj)
        self.assertEqual(obj.bsarap.solver_settings()["settle_iterations"], 5)
        top = bpy.data.objects["top"]
        top.location = Vector(top.location) + Vector((1.0, 0.0, -0.5))
        top.rotation_euler = Euler((0.0, 0.6, 0.0))
        before = st.solves
        bpy.context.view_layer.update()  # the live handler: one solve, and the timer
        self.assertEqual(st.solves, before + 1)
        self.assertFalse(st.converged)
        self.assertTrue(bpy.app.timers.is_registered(ext.handlers.finish_timer))
        live = pose_of(obj)
        # The controls have not rested yet: the timer waits.
        self.assertGreater(ext.handlers.finish_timer(), 0.0)
        self.assertEqual(st.solves, before + 1)
        self.assertEqual(ext.solve.status(obj)[0], "Live: settles once the controls rest")

        # The reference: the same settings on a Deformer, solved until converged and settled
        # (from rest: the extension's solver started elsewhere; measured 1.2e-7 apart, float32
        # rounding of the shape key).
        ref = bsarap.Deformer(
            st.rest, ext.handles.triangles(obj.data), st.labels, **obj.bsarap.solver_settings()
        )
        tg = ext.solve.targets(st, ext.solve.control_deltas(obj))
        for _ in range(5000):
            ref.solve_targets(tg)
            if ref.stats.converged:
                break
        settles = 0
        while ref.settle_pending:
            ref.settle()
            settles += 1
        self.assertGreater(settles, 0)

        st.moved_at -= 1.0  # rested
        calls = 0
        while ext.handlers.finish_timer() is not None:
            calls += 1
            self.assertLess(calls, 5000)
            self.assertEqual(ext.solve.status(obj)[0], f"Settling: {st.finish_steps} steps")
        solves = st.solves - before
        self.assertGreater(solves, 1, "solved again until converged")
        self.assertTrue(st.converged and st.ended == "rest")
        self.assertGreater(st.finish_steps, solves - 1, "then settled")
        self.assertFalse(st.deformer.settle_pending)
        U = pose_of(obj)
        far = np.abs(live - ref.positions).max()
        near = np.abs(U - ref.positions).max()
        self.assertGreater(far, 0.05, "the live solve stopped short")
        self.assertLess(near, 1e-4, f"finished {near:.2e} from the reference, live {far:.2e}")
        # The update that the last write triggers solves nothing; nothing is left to do.
        bpy.context.view_layer.update()
        self.assertEqual(st.solves, before + solves)
        self.assertIsNone(ext.solve.finish_step(obj))
        status = f"At rest ({st.finish_steps} steps after the last move)"
        self.assertEqual(ext.solve.status(obj), (status, "CHECKMARK"))
        self.assertIn(status, draw_panel(ext.panel.BSARAP_PT_pose, obj).labels)
        obj.bsarap.live = False
        self.assertEqual(ext.solve.status(obj)[0], status, "at rest whatever Live says")
        obj.bsarap.live = True

    def test_2_a_move_restarts_the_wait(self):
        obj = self.obj
        st = ext.solve.state(obj)
        top = bpy.data.objects["top"]
        top.location.x += 0.2
        bpy.context.view_layer.update()  # solved by the live handler
        self.assertIsNone(st.ended)
        self.assertEqual(st.finish_steps, 0)
        self.assertGreater(ext.handlers.finish_timer(), 0.0)
        st.moved_at -= 1.0
        solves = st.solves
        self.assertEqual(ext.handlers.finish_timer(), 0.0)  # one step
        self.assertEqual(st.finish_steps, 1)
        # Controls that moved since the last solve are the live handler's: no step on stale
        # targets.
        kept, st.last_deltas = st.last_deltas, st.last_deltas.copy()
        st.last_deltas[1, 0, 3] += 0.1
        self.assertIsNone(ext.solve.finish_step(obj))
        self.assertEqual(st.finish_steps, 1)
        self.assertLessEqual(st.solves, solves + 1)
        st.last_deltas = kept
        # The cap: no step past it, and the panel says the pose stopped short.
        st.finish_steps = bsarap.MAX_SETTLE_STEPS
        self.assertIsNone(ext.solve.finish_step(obj))
        self.assertEqual(st.ended, "cap")
        self.assertIn("the cap", ext.solve.status(obj)[0])
        # A failed solve stops the steps, said in the message and the status.
        st.finish_steps, st.ended, st.converged = 0, None, False
        with mock.patch.object(ext.solve, "solve", side_effect=ext.handles.HandleError("tube: refused")):
            self.assertIsNone(ext.handlers.finish_timer())
        self.assertEqual(ext.solve.message(obj), "tube: refused")
        self.assertEqual(ext.solve.status(obj), ("Stopped settling: see the message", "ERROR"))
        self.assertIsNone(ext.solve.finish_step(obj))

    def test_3_off_without_settle_iterations(self):
        """Settle iterations 0: the steps only solve until converged."""
        obj = self.obj
        obj.bsarap.settle_iterations = 0  # a rebuilt solver (the settings changed)
        top = bpy.data.objects["top"]
        top.location.x -= 0.3
        bpy.context.view_layer.update()
        st = ext.solve.state(obj)
        st.moved_at -= 1.0
        while ext.handlers.finish_timer() is not None:
            pass
        self.assertTrue(st.converged and st.ended == "rest")
        self.assertFalse(st.deformer.settle_pending)
        self.assertEqual(st.finish_steps, st.solves - 1)

    def test_4_no_steps_while_baking(self):
        """A bake solves its frames itself: no live solve or finishing step until it ends."""
        obj = self.obj
        scene = bpy.context.scene
        baker = ext.bake.Baker(scene, obj, [scene.frame_current])
        st = baker.st
        baker.step()  # a solve at the current controls, as a live one would be
        st.converged, st.ended, st.moved_at = False, None, 0.0
        solves = st.solves
        self.assertEqual(ext.solve.finish_step(obj), ext.solve.REST_DELAY)
        self.assertEqual(st.solves, solves)
        self.assertTrue(ext.solve.status(obj)[0].startswith("Baking"))
        # A control moved meanwhile is not solved live either (the bake's warm starts stay its own).
        top = bpy.data.objects["top"]
        y = top.location.y
        top.location.y = y + 0.1
        bpy.context.view_layer.update()
        self.assertEqual(st.solves, solves)
        top.location.y = y
        bpy.context.view_layer.update()
        baker.restore_frame()
        self.assertEqual(ext.solve.finish_step(obj), 0.0)
        self.assertEqual(st.solves, solves + 1)


class UndoSettling(unittest.TestCase):
    """Undo and redo bring back an undo step's pose key: pushed right after a move, it holds a
    pose short of rest (the finishing steps push no undo step), while the solver settled since
    for the same controls. The panel does not call that pose at rest: it is solved again and
    settled. (The undo's own depsgraph update solves; the test calls the timer as Blender
    would.)"""

    def settle(self, obj):
        """The finishing steps run to the end at once (the controls rested long enough); the
        settled pose."""
        st = ext.solve.state(obj)
        st.moved_at -= 1.0
        calls = 0
        while ext.handlers.finish_timer() is not None:
            calls += 1
            self.assertLess(calls, 5000)
        self.assertEqual(st.ended, "rest")
        self.assertTrue(ext.solve.status(obj)[0].startswith("At rest"))
        return pose_of(obj)

    def assert_settles_again(self, what, unsettled, settled):
        """After ``what`` (an undo or a redo) to a step holding the pose ``unsettled``: not said
        to be at rest until the finishing steps took the pose back to ``settled``."""
        obj = bpy.data.objects["tube"]  # the undo step's object
        bpy.context.view_layer.update()
        status = ext.solve.status(obj)
        self.assertFalse(
            status is not None and status[0].startswith("At rest"),
            f"after {what}: '{status[0] if status else None}' with the step's pose short of rest",
        )
        self.assertEqual(status, ("Live: settles once the controls rest", "TIME"), what)
        self.assertGreater(np.abs(pose_of(obj) - unsettled).max(), 0.0, f"{what}: not solved again")
        again = self.settle(obj)
        np.testing.assert_allclose(again, settled, atol=1e-4, err_msg=what)

    def test_undo_and_redo_to_an_unsettled_pose(self):
        bpy.ops.wm.read_homefile(use_empty=True)
        obj = tube()
        obj.bsarap.max_iters = 3  # the live solve stops short of converged
        make_controls(obj, ["bottom", "top"])
        top = bpy.data.objects["top"]
        top.location = Vector(top.location) + Vector((1.0, 0.0, -0.5))
        bpy.context.view_layer.update()  # the live solve
        self.assertFalse(ext.solve.state(obj).converged)
        unsettled = pose_of(obj)
        # two steps pushed before the pose settled (a move, then a change the pose ignores)
        bpy.ops.ed.undo_push(message="moved")
        obj.bsarap.live = True
        bpy.ops.ed.undo_push(message="unrelated")
        settled = self.settle(obj)
        self.assertGreater(np.abs(settled - unsettled).max(), 0.05, "the live solve was at rest")

        bpy.ops.ed.undo()  # to "moved": the controls where they are, the pose key short of rest
        self.assert_settles_again("undo", unsettled, settled)
        bpy.ops.ed.redo()  # to "unrelated": the same again
        self.assert_settles_again("redo", unsettled, settled)


if __name__ == "__main__":
    if SKIP:
        print(f"skipped: {SKIP}")
        sys.exit(0)
    unittest.main()
