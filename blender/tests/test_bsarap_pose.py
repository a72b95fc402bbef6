"""Tests of the Blender extension (blender/bsarap_pose) in bpy, headless.

Run with Blender's Python (bpy from PyPI):
    tools/blender/.venv/bin/python blender/tests/test_bsarap_pose.py [-v] [Class.test_name]
The extension zip comes from $BSARAP_BLENDER_ZIP or target/blender-extension/*.zip (made by
scripts/blender-extension.sh target/blender-extension); it is installed with
bpy.ops.extensions.package_install_files into a temporary user repository, as a user would.
Skips (with the reason) when bpy or the zip is missing.

`Creature.test_handler_time` measures the live handler on assets/creature.obj (30k vertices)
and prints the time per update (BENCHMARKS.md).
"""

from __future__ import annotations

import glob
import os
import statistics
import sys
import tempfile
import time
import types
import unittest
from unittest import mock

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
# A private user configuration: the extension is installed there, never into the real one.
os.environ.setdefault("BLENDER_USER_RESOURCES", tempfile.mkdtemp(prefix="bsarap-blender-"))

try:
    import bpy
    import numpy as np
    from mathutils import Euler, Matrix, Vector
except ImportError as e:  # no bpy here
    bpy = None
    SKIP = f"bpy is not importable ({e})"
else:
    SKIP = None


def find_zip():
    env = os.environ.get("BSARAP_BLENDER_ZIP")
    if env:
        return env if os.path.isfile(env) else None
    found = sorted(glob.glob(os.path.join(ROOT, "target", "blender-extension", "bsarap_pose-*.zip")))
    return found[-1] if found else None


ZIP = find_zip() if SKIP is None else None
if SKIP is None and ZIP is None:
    SKIP = "no extension zip (run scripts/blender-extension.sh target/blender-extension or set BSARAP_BLENDER_ZIP)"

MODULE = "bl_ext.user_default.bsarap_pose"
ext = None  # the installed package (bl_ext.user_default.bsarap_pose)
bsarap = None


def setUpModule():
    global ext, bsarap
    if SKIP:
        raise unittest.SkipTest(SKIP)
    bpy.ops.wm.read_homefile(use_empty=True)
    r = bpy.ops.extensions.package_install_files(filepath=ZIP, repo="user_default", enable_on_install=True)
    assert r == {"FINISHED"}, r
    import importlib

    ext = importlib.import_module(MODULE)
    import bsarap as b  # the wheel the extension installed

    bsarap = b
    assert hasattr(bpy.types.Object, "bsarap"), "the extension did not register"


def tube(name="tube", rings=24, around=16, radius=0.5, height=4.0):
    """An open tube along z (a manifold with boundary) with vertex groups bottom and top (the
    two end rings of each side at weight 1) and one vertex of ring 2 in top at 0.3."""
    verts, faces = [], []
    for r in range(rings):
        z = height * r / (rings - 1)
        for a in range(around):
            t = 2 * np.pi * a / around
            verts.append((radius * np.cos(t), radius * np.sin(t), z))
    for r in range(rings - 1):
        for a in range(around):
            i, j = r * around + a, r * around + (a + 1) % around
            faces.append((i, j, j + around, i + around))
    me = bpy.data.meshes.new(name)
    me.from_pydata(verts, [], faces)
    me.update()
    obj = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(obj)
    bottom = obj.vertex_groups.new(name="bottom")
    top = obj.vertex_groups.new(name="top")
    bottom.add(list(range(2 * around)), 1.0, "REPLACE")
    top.add(list(range((rings - 2) * around, rings * around)), 1.0, "REPLACE")
    top.add([2 * around], 0.3, "REPLACE")  # below the threshold: stays free
    activate(obj)
    obj.location = (1.0, 2.0, 0.5)  # the object's own transform must not matter
    bpy.context.view_layer.update()
    return obj


def activate(obj):
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj


def pose_of(obj):
    kb = obj.data.shape_keys.key_blocks[ext.solve.POSE_KEY]
    a = np.empty(len(kb.data) * 3, dtype=np.float32)
    kb.data.foreach_get("co", a)
    return a.reshape(-1, 3).astype(np.float64)


def key_co(kb):
    a = np.empty(len(kb.data) * 3, dtype=np.float32)
    kb.data.foreach_get("co", a)
    return a.reshape(-1, 3).astype(np.float64)


def evaluated_positions(obj):
    dg = bpy.context.evaluated_depsgraph_get()
    me = obj.evaluated_get(dg).to_mesh()
    a = np.empty(len(me.vertices) * 3, dtype=np.float32)
    me.vertices.foreach_get("co", a)
    obj.evaluated_get(dg).to_mesh_clear()
    return a.reshape(-1, 3).astype(np.float64)


def expected_handles(obj, st, group):
    """Where the rest vertices of handle group ``group`` must be: moved by the control's motion
    (mathutils, independent of the add-on's numpy code)."""
    g = obj.bsarap.groups[group]
    rest = Matrix([g.rest_matrix[4 * i : 4 * i + 4] for i in range(4)])
    delta = obj.matrix_world.inverted() @ g.control.matrix_world @ rest.inverted()
    idx = np.nonzero(st.labels == group)[0]
    return idx, np.array([(delta @ Vector(st.rest[i]))[:] for i in idx])


def make_controls(obj, groups):
    activate(obj)
    for g in groups:
        assert bpy.ops.bsarap.add_group(group=g) == {"FINISHED"}
    assert bpy.ops.bsarap.add_controls() == {"FINISHED"}


class RecordingLayout:
    """A panel layout that records the properties and labels drawn (no window headless)."""

    def __init__(self):
        self.props, self.labels = [], []

    def __getattr__(self, _name):  # row, column, template_list, operator: the same layout
        return lambda *_a, **_kw: self

    def prop(self, _data, name, **_kw):
        self.props.append(name)

    def label(self, text="", **_kw):
        self.labels.append(text)


def draw_panel(panel, obj) -> RecordingLayout:
    layout = RecordingLayout()
    panel.draw(types.SimpleNamespace(layout=layout), types.SimpleNamespace(object=obj))
    return layout


class Tube(unittest.TestCase):
    """One scene for the ordered steps: controls, live pose, topology change, bakes."""

    @classmethod
    def setUpClass(cls):
        bpy.ops.wm.read_homefile(use_empty=True)
        cls.obj = tube()
        cls.ref = None

    def test_1_add_controls(self):
        obj = self.obj
        make_controls(obj, ["bottom", "top"])
        st = ext.solve.state(obj)
        self.assertEqual(st.deformer.method, "bsarap-coarse")
        # weight 0.3 is not in the group; 64 handle vertices
        self.assertEqual(int((st.labels == 1).sum()), 32)
        self.assertEqual(int((st.labels >= 0).sum()), 64)
        for k, name in enumerate(["bottom", "top"]):
            e = bpy.data.objects[name]
            self.assertEqual(e.type, "EMPTY")
            self.assertIsNone(e.parent)
            self.assertIs(obj.bsarap.groups[k].control, e)
            cent = obj.matrix_world @ Vector(st.rest[st.labels == k].mean(axis=0))
            self.assertLess((e.matrix_world.translation - cent).length, 1e-6)
        keys = obj.data.shape_keys.key_blocks
        self.assertEqual([kb.name for kb in keys], ["Basis", "BS-ARAP pose"])
        self.assertEqual(keys["BS-ARAP pose"].value, 1.0)
        # at rest the pose is the rest mesh
        np.testing.assert_allclose(pose_of(obj), st.rest, atol=1e-5)

    def test_2_live_pose(self):
        obj = self.obj
        st = ext.solve.state(obj)
        basis = key_co(obj.data.shape_keys.key_blocks["Basis"])
        # The reference: a fresh Deformer solving the same targets in the same order.
        ref = bsarap.Deformer(st.rest, ext.handles.triangles(obj.data), st.labels)
        top = bpy.data.objects["top"]
        ref.solve_targets(ext.solve.targets(st, ext.solve.control_deltas(obj)))
        for loc, rot in (((0.6, 0.0, -0.2), (0.0, 0.0, 0.0)), ((0.8, -0.3, -0.4), (0.5, 0.2, -0.3))):
            solves = st.solves
            top.location = Vector(top.location) + Vector(loc)
            top.rotation_euler = Euler(rot)
            bpy.context.view_layer.update()  # fires depsgraph_update_post: the live handler
            self.assertEqual(st.solves, solves + 1, "one solve per control move")
            U = pose_of(obj)
            for k in (0, 1):
                idx, want = expected_handles(obj, st, k)
                np.testing.assert_allclose(U[idx], want, atol=1e-5)
            want = ref.solve_targets(ext.solve.targets(st, ext.solve.control_deltas(obj)))
            np.testing.assert_allclose(U, want, atol=1e-5)
            self.assertGreater(np.abs(U - st.rest).max(), 0.1)
            # writing the shape key updated the depsgraph again: no second solve
            bpy.context.view_layer.update()
            self.assertEqual(st.solves, solves + 1)
        np.testing.assert_array_equal(key_co(obj.data.shape_keys.key_blocks["Basis"]), basis)
        # the evaluated mesh is the pose (shape key at value 1)
        np.testing.assert_allclose(evaluated_positions(obj), pose_of(obj), atol=1e-5)

    def test_3_settings_and_topology_change(self):
        obj = self.obj
        obj.bsarap.method = "arap"
        ext.solve.messages.pop(obj.name, None)
        bpy.data.objects["top"].location.z += 0.1
        bpy.context.view_layer.update()
        st = ext.solve.state(obj)
        self.assertEqual(st.deformer.method, "arap")
        self.assertIn("settings or groups changed", ext.solve.messages[obj.name])
        obj.bsarap.method = "bsarap-coarse"
        # a topology edit: subdivide one face ring with bmesh
        import bmesh

        n0 = len(obj.data.vertices)
        bm = bmesh.new()
        bm.from_mesh(obj.data)
        bm.edges.ensure_lookup_table()
        ring = [e for e in bm.edges if all(abs(v.co.z - 2.0) < 0.2 for v in e.verts)]
        bmesh.ops.subdivide_edges(bm, edges=ring, cuts=1, use_grid_fill=True)
        bm.to_mesh(obj.data)
        bm.free()
        obj.data.update()
        bpy.data.objects["top"].location.z += 0.1
        bpy.context.view_layer.update()  # must not raise
        st = ext.solve.state(obj)
        self.assertGreater(len(obj.data.vertices), n0)
        self.assertEqual(len(st.rest), len(obj.data.vertices))
        self.assertIn("topology changed", ext.solve.messages[obj.name])
        idx, want = expected_handles(obj, st, 1)
        np.testing.assert_allclose(pose_of(obj)[idx], want, atol=1e-5)

    def test_4_bake_shape_keys(self):
        obj, scene = self.obj, bpy.context.scene
        top = bpy.data.objects["top"]
        scene.frame_start, scene.frame_end = 1, 12
        top.keyframe_insert("location", frame=1)
        top.keyframe_insert("rotation_euler", frame=1)
        top.location = Vector(top.location) + Vector((-1.0, 0.5, -0.5))
        top.rotation_euler = Euler((-0.4, 0.3, 0.6))
        top.keyframe_insert("location", frame=12)
        top.keyframe_insert("rotation_euler", frame=12)
        # playing the keyed controls: frame_change_post poses the mesh live
        st = ext.solve.state(obj)
        for f in (6, 1):
            solves = st.solves
            scene.frame_set(f)
            self.assertEqual(st.solves, solves + 1)
            idx, want = expected_handles(obj, st, 1)
            np.testing.assert_allclose(pose_of(obj)[idx], want, atol=1e-5)
        activate(obj)
        self.assertEqual(bpy.ops.bsarap.bake_shape_keys(), {"FINISHED"})
        keys = obj.data.shape_keys.key_blocks
        names = [f"BS-ARAP frame {f:04d}" for f in range(1, 13)]
        self.assertEqual([kb.name for kb in keys if kb.name.startswith("BS-ARAP frame")], names)
        self.assertTrue(keys["BS-ARAP pose"].mute)
        self.assertFalse(obj.bsarap.live)
        baked = {}
        for f in (1, 5, 12):
            scene.frame_set(f)
            kb = keys[f"BS-ARAP frame {f:04d}"]
            self.assertEqual(kb.value, 1.0)
            self.assertEqual(sum(k.value for k in keys if k.name.startswith("BS-ARAP frame")), 1.0)
            U = key_co(kb)
            baked[f] = U
            for k in (0, 1):
                idx, want = expected_handles(obj, st, k)
                np.testing.assert_allclose(U[idx], want, atol=1e-5)
            np.testing.assert_allclose(evaluated_positions(obj), U, atol=1e-5)
        self.assertGreater(np.abs(baked[12] - baked[1]).max(), 0.5)
        type(self).baked = baked
        # baking again replaces the keys (no duplicates)
        self.assertEqual(bpy.ops.bsarap.bake_shape_keys(), {"FINISHED"})
        self.assertEqual(sum(kb.name.startswith("BS-ARAP frame") for kb in keys), 12)
        # and their F-curves: one per key, none left behind by the first bake
        from bpy_extras import anim_utils

        ad = obj.data.shape_keys.animation_data
        bag = anim_utils.action_get_channelbag_for_slot(ad.action, ad.action_slot)
        paths = sorted(fc.data_path for fc in bag.fcurves)
        self.assertEqual(paths, sorted(f'key_blocks["{n}"].value' for n in names))

    def test_5_bake_point_cache(self):
        obj, scene = self.obj, bpy.context.scene
        path = os.path.join(tempfile.mkdtemp(), "tube.pc2")
        obj.bsarap.pc2_path = path
        activate(obj)
        self.assertEqual(bpy.ops.bsarap.bake_point_cache(), {"FINISHED"})
        start, rate, frames = ext.bake.read_pc2(path)
        self.assertEqual((start, rate, frames.shape), (1.0, 1.0, (12, len(obj.data.vertices), 3)))
        self.assertEqual(os.path.getsize(path), 32 + 12 * len(obj.data.vertices) * 12)
        mod = obj.modifiers[0]
        self.assertEqual((mod.name, mod.type, mod.filepath), ("BS-ARAP cache", "MESH_CACHE", path))
        st = ext.solve.state(obj)
        for f in (1, 7, 12):
            scene.frame_set(f)
            idx, want = expected_handles(obj, st, 1)
            np.testing.assert_allclose(frames[f - 1][idx], want, atol=1e-5)
            # the same frames as the shape-key bake, up to the solver's tolerance
            if f in self.baked:
                diag = np.linalg.norm(np.ptp(st.rest, axis=0))
                self.assertLess(np.abs(frames[f - 1] - self.baked[f]).max(), 1e-2 * diag)
            np.testing.assert_allclose(evaluated_positions(obj), frames[f - 1], atol=1e-5)


class Package(unittest.TestCase):
    def test_manifest_valid(self):
        """Blender's own extension validator (the `blender_ext validate` of extensions.blender.org
        uploads; stricter than installing) accepts the zip."""
        import subprocess

        cli = os.path.join(bpy.utils.system_resource("SCRIPTS"), "addons_core", "bl_pkg", "cli", "blender_ext.py")
        r = subprocess.run([sys.executable, cli, "validate", ZIP], capture_output=True, text=True)
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)


class BadInput(unittest.TestCase):
    """Each bad input ends in an operator error report (a RuntimeError for scripts) with a
    message, not a Python traceback."""

    def setUp(self):
        bpy.ops.wm.read_homefile(use_empty=True)

    def assertReports(self, op, pattern):
        with self.assertRaises(RuntimeError) as cm:
            op()
        msg = str(cm.exception)
        self.assertRegex(msg, pattern)
        self.assertNotIn("Traceback", msg)

    def test_no_vertex_groups(self):
        obj = tube()
        for vg in list(obj.vertex_groups):
            obj.vertex_groups.remove(vg)
        self.assertReports(bpy.ops.bsarap.add_group, "no vertex groups")
        self.assertReports(bpy.ops.bsarap.add_controls, "no vertex groups")

    def test_empty_group(self):
        obj = tube()
        obj.vertex_groups.new(name="nothing")
        bpy.ops.bsarap.add_group(group="top")
        bpy.ops.bsarap.add_group(group="nothing")
        self.assertReports(bpy.ops.bsarap.add_controls, "'nothing' has no vertex with weight above 0.5")

    def test_no_handle_groups(self):
        tube()
        self.assertReports(bpy.ops.bsarap.add_controls, "no handle groups")

    def test_non_manifold(self):
        me = bpy.data.meshes.new("fan")
        # three triangles on one edge
        me.from_pydata([(0, 0, 0), (1, 0, 0), (0.5, 1, 0), (0.5, -1, 0), (0.5, 0, 1)], [], [(0, 1, 2), (1, 0, 3), (0, 1, 4)])
        obj = bpy.data.objects.new("fan", me)
        bpy.context.scene.collection.objects.link(obj)
        obj.vertex_groups.new(name="a").add([2], 1.0, "REPLACE")
        activate(obj)
        bpy.ops.bsarap.add_group(group="a")
        self.assertReports(bpy.ops.bsarap.add_controls, "not manifold")

    def test_modifier_before(self):
        obj = tube()
        obj.modifiers.new("Subdivision", "SUBSURF")
        bpy.ops.bsarap.add_group(group="top")
        self.assertReports(bpy.ops.bsarap.add_controls, r"modifiers before BS-ARAP \(Subdivision\)")

    def test_bake_without_controls(self):
        tube()
        bpy.ops.bsarap.add_group(group="top")
        self.assertReports(bpy.ops.bsarap.bake_shape_keys, "has no control")

    def test_live_error_is_a_message(self):
        obj = tube()
        make_controls(obj, ["bottom", "top"])
        obj.vertex_groups.remove(obj.vertex_groups["top"])
        bpy.data.objects["bottom"].location.x += 0.2
        bpy.context.view_layer.update()  # the handler must not raise
        self.assertIn("'top' does not exist", ext.solve.messages[obj.name])


class Controls(unittest.TestCase):
    def setUp(self):
        bpy.ops.wm.read_homefile(use_empty=True)

    def test_remove_controls(self):
        obj = tube()
        make_controls(obj, ["bottom", "top"])
        self.assertEqual(bpy.ops.bsarap.remove_controls(), {"FINISHED"})
        self.assertNotIn("top", bpy.data.objects)
        self.assertNotIn("bottom", bpy.data.objects)
        self.assertNotIn("BS-ARAP pose", obj.data.shape_keys.key_blocks)
        bpy.context.view_layer.update()
        # no controls: the live handler leaves the object alone (no solver, no message)
        self.assertNotIn(obj.name, ext.solve._states)
        self.assertNotIn(obj.name, ext.solve.messages)

    def test_invoke_bake_without_window(self):
        """The panel's button invokes the bake (modal, Esc cancels, in a window); with no window
        (background) it bakes in one go."""
        obj = tube()
        make_controls(obj, ["bottom", "top"])
        scene = bpy.context.scene
        scene.frame_start, scene.frame_end = 1, 3
        self.assertEqual(bpy.ops.bsarap.bake_shape_keys("INVOKE_DEFAULT"), {"FINISHED"})
        self.assertEqual(sum(kb.name.startswith("BS-ARAP frame") for kb in obj.data.shape_keys.key_blocks), 3)


class Creature(unittest.TestCase):
    """assets/creature.obj (30k vertices) with its handle spheres as vertex groups."""

    @classmethod
    def setUpClass(cls):
        bpy.ops.wm.read_homefile(use_empty=True)
        path = os.path.join(ROOT, "assets", "creature.obj")
        bpy.ops.wm.obj_import(filepath=path, forward_axis="NEGATIVE_Z", up_axis="Y")
        obj = bpy.context.selected_objects[0]
        V = ext.handles.rest_positions(obj.data)
        labels = bsarap.load_selection(os.path.join(ROOT, "assets", "creature.handles.json"), V)
        cls.groups = []
        for k in range(int(labels.max()) + 1):
            vg = obj.vertex_groups.new(name=f"handle{k}")
            vg.add([int(i) for i in np.nonzero(labels == k)[0]], 1.0, "REPLACE")
            cls.groups.append(vg.name)
        cls.obj = obj
        make_controls(obj, cls.groups)

    def test_handler_time(self):
        obj = self.obj
        st = ext.solve.state(obj)
        e = obj.bsarap.groups[len(self.groups) - 1].control
        scene = bpy.context.scene
        times = []
        # a drag: 40 small steps, each a depsgraph update that runs the live handler
        for i in range(40):
            e.location.x += 0.01
            e.rotation_euler.z += 0.01
            bpy.context.view_layer.update()
            t0 = time.perf_counter()
            ext.handlers.update_scene(scene)  # already solved by the update: must skip
            skip_ms = (time.perf_counter() - t0) * 1e3
            times.append(st.last_ms)
        med = statistics.median(times)
        print(
            f"\ncreature: {len(st.rest)} vertices, {len(self.groups)} groups, {st.deformer.method}: "
            f"live handler {med:.1f} ms per update median ({min(times):.1f} min, {max(times):.1f} max) "
            f"= {1e3 / med:.0f} updates/s; an update with nothing moved {skip_ms:.2f} ms",
            file=sys.stderr,
        )
        self.assertEqual(st.solves, 41)  # add_controls' solve + one per step
        idx, want = expected_handles(obj, st, len(self.groups) - 1)
        np.testing.assert_allclose(pose_of(obj)[idx], want, atol=1e-5)


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
        ext.solve.messages.pop(obj.name, None)
        if fresh:
            ext.solve.forget(obj.name)
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
        self.assertIn("settings or groups changed", ext.solve.messages[obj.name])
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
        self.assertIn("settings or groups changed", ext.solve.messages[obj.name])
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
        self.assertEqual(ext.solve.messages[obj.name], "tube: refused")
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


class Unregister(unittest.TestCase):
    def test_zz_unregister(self):
        bpy.ops.wm.read_homefile(use_empty=True)
        handlers = ext.handlers
        bpy.ops.preferences.addon_disable(module=MODULE)
        self.assertFalse(hasattr(bpy.types.Object, "bsarap"))
        self.assertNotIn(handlers.on_depsgraph_update, bpy.app.handlers.depsgraph_update_post)
        self.assertNotIn(handlers.on_frame_change, bpy.app.handlers.frame_change_post)
        self.assertFalse(bpy.app.timers.is_registered(handlers.finish_timer))
        self.assertFalse(hasattr(bpy.types, "BSARAP_PT_pose"))
        with self.assertRaises((AttributeError, RuntimeError)):
            bpy.ops.bsarap.add_controls()


def load_tests(loader, standard, _pattern):
    # Unregister last, whatever the order of the classes' names.
    suite = unittest.TestSuite()
    for cls in (Package, Tube, BadInput, Controls, SmoothRotations, Finishing, Creature, Unregister):
        suite.addTests(loader.loadTestsFromTestCase(cls))
    return suite


if __name__ == "__main__":
    if SKIP:
        print(f"skipped: {SKIP}")
        sys.exit(0)
    unittest.main()
