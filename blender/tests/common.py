"""What the Blender extension's tests share: bpy imported with a private user configuration,
the extension zip found and installed as a user would, a test mesh and small helpers.

The extension zip comes from $BSARAP_BLENDER_ZIP or target/blender-extension/*.zip (made by
scripts/blender-extension.sh target/blender-extension); it is installed with
bpy.ops.extensions.package_install_files into a temporary user repository. `SKIP` says why the
tests cannot run (no bpy, no zip), or is None.
"""

from __future__ import annotations

import glob
import os
import tempfile
import types

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
# A private user configuration: the extension is installed there, never into the real one.
os.environ.setdefault("BLENDER_USER_RESOURCES", tempfile.mkdtemp(prefix="bsarap-blender-"))

try:
    import bpy
    import numpy as np
    from mathutils import Matrix, Vector
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
_installed = {}  # "ext": the installed package, "bsarap": the wheel it installed


class _Installed:
    """Stands for a module that exists once :func:`install` ran (a test file imports it before
    that): attribute access goes to the module."""

    def __init__(self, key):
        self._key = key

    def __getattr__(self, name):
        return getattr(_installed[self._key], name)


#: The installed extension's package (bl_ext.user_default.bsarap_pose) and its `bsarap` wheel.
ext = _Installed("ext")
bsarap = _Installed("bsarap")


def install():
    """Installs and enables the extension in an empty scene (once a process); returns the
    extension's package and the `bsarap` module it installed. Raises SkipTest with `SKIP`."""
    import unittest

    if SKIP:
        raise unittest.SkipTest(SKIP)
    bpy.ops.wm.read_homefile(use_empty=True)
    if not _installed:
        r = bpy.ops.extensions.package_install_files(filepath=ZIP, repo="user_default", enable_on_install=True)
        assert r == {"FINISHED"}, r
        import importlib

        _installed["ext"] = importlib.import_module(MODULE)
        import bsarap as b

        _installed["bsarap"] = b
    assert hasattr(bpy.types.Object, "bsarap"), "the extension did not register"
    return _installed["ext"], _installed["bsarap"]


def setUpModule():
    """unittest's module set-up for the test files that import it."""
    install()


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


def posed_tube(name="tube", top_x=0.0):
    """A fresh scene with the test tube and its two controls added, the top one moved ``top_x``
    along x."""
    bpy.ops.wm.read_homefile(use_empty=True)
    obj = tube(name)
    make_controls(obj, ["bottom", "top"])
    if top_x:
        bpy.data.objects["top"].location.x += top_x
        bpy.context.view_layer.update()
    return obj


def duplicate(obj, *, linked=False):
    """Shift+D (Alt+D with ``linked``) of ``obj`` alone, moved aside."""
    activate(obj)
    assert bpy.ops.object.duplicate(linked=linked) == {"FINISHED"}
    dup = bpy.context.view_layer.objects.active
    assert dup != obj
    dup.location.x += 3.0
    bpy.context.view_layer.update()
    return dup


def assert_pose_follows(obj):
    """The live pose's handle vertices are where the controls put them."""
    st = ext.solve.state(obj)
    for k in (0, 1):
        idx, want = expected_handles(obj, st, k)
        np.testing.assert_allclose(pose_of(obj)[idx], want, atol=1e-5)


def link_rig(path):
    """The tube and its controls linked from the .blend ``path`` into a new empty scene."""
    bpy.ops.wm.read_homefile(use_empty=True)
    with bpy.data.libraries.load(path, link=True) as (_src, dst):
        dst.objects = ["tube", "bottom", "top"]
    for o in dst.objects:
        bpy.context.scene.collection.objects.link(o)
    return dst.objects


def fake_modal_bake(obj, op_class, frames):
    """The modal bake operator's state without a window: ``(op, context, calls)``, the window
    manager's calls recorded."""
    calls = []
    wm = types.SimpleNamespace(
        event_timer_remove=lambda _t: calls.append("timer removed"),
        progress_end=lambda: calls.append("progress end"),
        progress_update=lambda _n: None,
    )
    op = types.SimpleNamespace(reports=[])
    op.report = lambda level, msg: op.reports.append((level, msg))
    op._baker = ext.bake.Baker(bpy.context.scene, obj, frames)
    op._timer = object()
    op._stop = lambda ctx: op_class._stop(op, ctx)
    op.finish = lambda ctx, b: op_class.finish(op, ctx, b)
    return op, types.SimpleNamespace(window_manager=wm), calls


class RecordingLayout:
    """A panel layout that records the properties and labels drawn (no window headless)."""

    def __init__(self):
        self.props, self.labels, self.icons = [], [], []

    def __getattr__(self, _name):  # row, column, template_list, operator: the same layout
        return lambda *_a, **_kw: self

    def prop(self, _data, name, **_kw):
        self.props.append(name)

    def label(self, text="", icon="NONE", **_kw):
        self.labels.append(text)
        self.icons.append(icon)


def draw_panel(panel, obj) -> RecordingLayout:
    layout = RecordingLayout()
    panel.draw(types.SimpleNamespace(layout=layout), types.SimpleNamespace(object=obj))
    return layout


def draw_group_rows(obj) -> RecordingLayout:
    """The handle-group list's rows of ``obj`` (``BSARAP_UL_groups.draw_item``), recorded."""
    layout = RecordingLayout()
    ctx = types.SimpleNamespace(object=obj)
    for i, item in enumerate(obj.bsarap.groups):
        ext.panel.BSARAP_UL_groups.draw_item(None, ctx, layout, obj.bsarap, item, 0, None, "", i)
    return layout

