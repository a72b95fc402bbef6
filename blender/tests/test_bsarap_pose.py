"""Tests of the Blender extension (blender/bsarap_pose) in bpy, headless: adding controls, the
live pose, baking, bad input, the package, unregistering. The solver's energies and the
finishing steps are in test_solving.py.

Run with Blender's Python (bpy from PyPI):
    tools/blender/.venv/bin/python blender/tests/test_bsarap_pose.py [-v] [Class.test_name]
The extension zip is found as common.py says. Skips (with the reason) when bpy or the zip is
missing.

`Creature.test_handler_time` measures the live handler on assets/creature.obj (30k vertices)
and prints the time per update (BENCHMARKS.md).
"""

from __future__ import annotations

import os
import statistics
import sys
import tempfile
import time
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import (  # noqa: E402  (sets BLENDER_USER_RESOURCES before bpy)
    MODULE, ROOT, SKIP, ZIP, activate, bpy, bsarap, evaluated_positions, expected_handles,
    ext, key_co, make_controls, np, pose_of, setUpModule, tube
)

if SKIP is None:
    from mathutils import Euler, Vector


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
        ext.solve.messages.pop(ext.solve.uid(obj), None)
        bpy.data.objects["top"].location.z += 0.1
        bpy.context.view_layer.update()
        st = ext.solve.state(obj)
        self.assertEqual(st.deformer.method, "arap")
        self.assertIn("settings or groups changed", ext.solve.message(obj))
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
        self.assertIn("topology changed", ext.solve.message(obj))
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

    def test_deforming_modifier(self):
        """A modifier that moves the vertices (here with a harmless one) blocks posing: the
        message names it, and says what kinds are fine."""
        for kind, label in (("ARMATURE", "Armature"), ("DISPLACE", r"Bumps \(Displace\)")):
            bpy.ops.wm.read_homefile(use_empty=True)
            obj = tube()
            obj.modifiers.new("Subdivision", "SUBSURF")
            obj.modifiers.new("Armature" if kind == "ARMATURE" else "Bumps", kind)
            bpy.ops.bsarap.add_group(group="top")
            self.assertReports(
                bpy.ops.bsarap.add_controls,
                rf"tube: modifiers that move the vertices \({label}\): .* apply, remove or disable them "
                r"\(disabled: in the viewport and render\) \(modifiers that keep the vertices in place are fine: Subdivision Surface, Multires, Mirror",
            )

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
        self.assertIn("'top' does not exist", ext.solve.message(obj))


def stand_in(obj, V, setup):
    """A mesh object with the faces of ``obj`` and the vertices ``V``, no shape keys, its
    modifiers made by ``setup``: what the evaluated posed mesh must be."""
    me = bpy.data.meshes.new("stand-in")
    me.from_pydata(V.tolist(), [], [tuple(p.vertices) for p in obj.data.polygons])
    ref = bpy.data.objects.new("stand-in", me)
    bpy.context.scene.collection.objects.link(ref)
    setup(ref)
    bpy.context.view_layer.update()
    return ref


def subdivided_and_mirrored(obj):
    obj.modifiers.new("Subdivision", "SUBSURF").levels = 1
    obj.modifiers.new("Mirror", "MIRROR").use_axis = (False, True, False)


class Modifiers(unittest.TestCase):
    """The pose is a shape key, evaluated before the modifier stack: modifiers that keep the
    vertices in place act on the posed mesh; those that move them block posing."""

    def setUp(self):
        bpy.ops.wm.read_homefile(use_empty=True)

    def bend(self, obj):
        top = bpy.data.objects["top"]
        top.location = Vector(top.location) + Vector((0.8, 0.0, -0.3))
        top.rotation_euler = Euler((0.0, 0.5, 0.0))
        bpy.context.view_layer.update()

    def test_subdivision_and_mirror(self):
        obj = tube()
        subdivided_and_mirrored(obj)
        make_controls(obj, ["bottom", "top"])
        self.bend(obj)
        st = ext.solve.state(obj)
        U = pose_of(obj)
        for k in (0, 1):  # the shape key holds the pose
            idx, want = expected_handles(obj, st, k)
            np.testing.assert_allclose(U[idx], want, atol=1e-5)
        # the evaluated mesh is the posed surface, subdivided and mirrored
        ev = evaluated_positions(obj)
        self.assertGreater(len(ev), 4 * len(U))
        np.testing.assert_allclose(ev, evaluated_positions(stand_in(obj, U, subdivided_and_mirrored)), atol=1e-5)
        self.assertGreater(ev[:, 0].max(), st.rest[:, 0].max() + 0.3)  # bent, not at rest

    def test_type_lists(self):
        """The harmless types are Blender's own names, and none of them deforms."""
        types = {i.identifier for i in bpy.types.Modifier.bl_rna.properties["type"].enum_items}
        keeps = ext.modifiers.KEEPS_VERTICES
        self.assertLessEqual(keeps, types)
        deforming = {
            "ARMATURE", "CAST", "CURVE", "DISPLACE", "HOOK", "LAPLACIANDEFORM", "LATTICE",
            "MESH_DEFORM", "SHRINKWRAP", "SIMPLE_DEFORM", "SMOOTH", "CORRECTIVE_SMOOTH",
            "LAPLACIANSMOOTH", "SURFACE_DEFORM", "WARP", "WAVE", "CLOTH", "SOFT_BODY",
            "MESH_CACHE", "MESH_SEQUENCE_CACHE", "NODES", "EXPLODE", "OCEAN", "DYNAMIC_PAINT",
            "PARTICLE_INSTANCE", "FLUID", "VOLUME_TO_MESH",
        }
        self.assertLessEqual(deforming, types)
        self.assertFalse(keeps & deforming)

    def test_added_after_controls(self):
        """A deforming modifier added to a posed mesh stops the live pose with the message;
        disabled again, the same solver goes on and the message goes."""
        obj = tube()
        make_controls(obj, ["bottom", "top"])
        st = ext.solve.state(obj)
        solves = st.solves
        disp = obj.modifiers.new("Displace", "DISPLACE")
        self.bend(obj)
        self.assertEqual(st.solves, solves)
        self.assertRegex(ext.solve.message(obj), r"modifiers that move the vertices \(Displace\)")
        # a mesh with shape keys cannot have a modifier applied: not offered
        self.assertIn("; remove or disable them (disabled: in the viewport and render)", ext.solve.message(obj))
        disp.show_viewport = disp.show_render = False
        bpy.context.view_layer.update()
        self.assertIs(ext.solve.state(obj), st)
        self.assertEqual(st.solves, solves + 1)
        self.assertIsNone(ext.solve.message(obj))
        idx, want = expected_handles(obj, st, 1)
        np.testing.assert_allclose(pose_of(obj)[idx], want, atol=1e-5)

    def test_disabled_cache_modifier(self):
        """A disabled BS-ARAP cache modifier is no cache: an enabled modifier before it does
        not block (it keeps the vertices in place)."""
        obj = tube()
        obj.modifiers.new("Subdivision", "SUBSURF")
        cache = obj.modifiers.new(ext.modifiers.CACHE_MODIFIER, "MESH_CACHE")
        self.assertIn("must stay first", ext.modifiers.refusal(obj))
        cache.show_viewport = cache.show_render = False
        self.assertIsNone(ext.modifiers.refusal(obj))
        make_controls(obj, ["bottom", "top"])
        self.bend(obj)
        self.assertIsNone(ext.solve.message(obj))

    def test_geometry_nodes(self):
        """Smooth by Angle (Shade Auto Smooth, a Geometry Nodes group that only shades) is fine;
        a group that moves the vertices (Set Position) blocks."""
        obj = tube()
        self.assertEqual(bpy.ops.object.shade_auto_smooth(), {"FINISHED"})
        self.assertEqual([m.type for m in obj.modifiers], ["NODES"])
        make_controls(obj, ["bottom", "top"])
        self.bend(obj)
        idx, want = expected_handles(obj, ext.solve.state(obj), 1)
        np.testing.assert_allclose(evaluated_positions(obj)[idx], want, atol=1e-5)
        tree = bpy.data.node_groups.new("Move", "GeometryNodeTree")
        for t in ("NodeGroupInput", "GeometryNodeSetPosition", "NodeGroupOutput"):
            tree.nodes.new(t)
        obj.modifiers.new("Move", "NODES").node_group = tree
        activate(obj)
        with self.assertRaises(RuntimeError) as cm:
            bpy.ops.bsarap.pose()
        self.assertIn("modifiers that move the vertices (Move (Geometry Nodes))", str(cm.exception))

    def test_bake_with_subdivision(self):
        """Both bakes with a Subdivision Surface: the shape keys and the point cache (first in the
        stack, the Subdivision after it) play subdivided; a modifier moved before the cache
        blocks."""
        obj = tube()
        obj.modifiers.new("Subdivision", "SUBSURF").levels = 1

        def subdivided(o):
            o.modifiers.new("Subdivision", "SUBSURF").levels = 1

        make_controls(obj, ["bottom", "top"])
        scene = bpy.context.scene
        scene.frame_start, scene.frame_end = 1, 3
        top = bpy.data.objects["top"]
        top.keyframe_insert("location", frame=1)
        top.location.x += 1.0
        top.keyframe_insert("location", frame=3)
        activate(obj)
        self.assertEqual(bpy.ops.bsarap.bake_shape_keys(), {"FINISHED"})
        scene.frame_set(3)
        U = key_co(obj.data.shape_keys.key_blocks["BS-ARAP frame 0003"])
        np.testing.assert_allclose(evaluated_positions(obj), evaluated_positions(stand_in(obj, U, subdivided)), atol=1e-5)
        obj.bsarap.pc2_path = os.path.join(tempfile.mkdtemp(), "tube.pc2")
        activate(obj)
        self.assertEqual(bpy.ops.bsarap.bake_point_cache(), {"FINISHED"})
        self.assertEqual([m.name for m in obj.modifiers], ["BS-ARAP cache", "Subdivision"])
        _, _, samples = ext.bake.read_pc2(obj.bsarap.pc2_path)
        scene.frame_set(2)
        np.testing.assert_allclose(
            evaluated_positions(obj), evaluated_positions(stand_in(obj, samples[1], subdivided)), atol=1e-5
        )
        obj.modifiers.move(1, 0)
        activate(obj)
        with self.assertRaises(RuntimeError) as cm:
            bpy.ops.bsarap.pose()
        self.assertIn("modifiers before the BS-ARAP cache modifier (Subdivision (Subdivision Surface))", str(cm.exception))
        self.assertIn("must stay first", str(cm.exception))


class Controls(unittest.TestCase):
    def setUp(self):
        bpy.ops.wm.read_homefile(use_empty=True)

    def test_remove_controls(self):
        obj = tube()
        make_controls(obj, ["bottom", "top"])
        rest = np.array([v.co for v in obj.data.vertices])
        self.assertEqual(bpy.ops.bsarap.remove_controls(), {"FINISHED"})
        self.assertNotIn("top", bpy.data.objects)
        self.assertNotIn("bottom", bpy.data.objects)
        # the Basis that Add Controls made goes too: with a shape key, no modifier can be applied
        self.assertIsNone(obj.data.shape_keys)
        np.testing.assert_allclose(np.array([v.co for v in obj.data.vertices]), rest, atol=1e-6)
        # a Basis the mesh had before stays
        obj.shape_key_add(name="Basis", from_mix=False)
        self.assertEqual(bpy.ops.bsarap.add_controls(), {"FINISHED"})  # the groups are kept
        self.assertEqual(bpy.ops.bsarap.remove_controls(), {"FINISHED"})
        self.assertEqual([kb.name for kb in obj.data.shape_keys.key_blocks], ["Basis"])
        bpy.context.view_layer.update()
        # no controls: the live handler leaves the object alone (no solver, no message)
        self.assertIsNone(ext.solve.built(obj))
        self.assertIsNone(ext.solve.message(obj))

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


class Unregister(unittest.TestCase):
    def test_zz_unregister(self):
        bpy.ops.wm.read_homefile(use_empty=True)
        handlers = ext.handlers
        bpy.ops.preferences.addon_disable(module=MODULE)
        self.assertFalse(hasattr(bpy.types.Object, "bsarap"))
        self.assertFalse(hasattr(bpy.types.Object, "bsarap_owner"))
        self.assertFalse(hasattr(bpy.types.Scene, "bsarap_meshes"))
        self.assertNotIn(handlers.on_depsgraph_update, bpy.app.handlers.depsgraph_update_post)
        self.assertNotIn(handlers.on_frame_change, bpy.app.handlers.frame_change_post)
        self.assertNotIn(handlers.on_render_start, bpy.app.handlers.render_init)
        self.assertNotIn(handlers.on_render_end, bpy.app.handlers.render_complete)
        self.assertFalse(bpy.app.timers.is_registered(handlers.finish_timer))
        self.assertFalse(hasattr(bpy.types, "BSARAP_PT_pose"))
        with self.assertRaises((AttributeError, RuntimeError)):
            bpy.ops.bsarap.add_controls()


def load_tests(loader, standard, _pattern):
    # Unregister last, whatever the order of the classes' names.
    suite = unittest.TestSuite()
    for cls in (Package, Tube, BadInput, Modifiers, Controls, Creature, Unregister):
        suite.addTests(loader.loadTestsFromTestCase(cls))
    return suite


if __name__ == "__main__":
    if SKIP:
        print(f"skipped: {SKIP}")
        sys.exit(0)
    unittest.main()
