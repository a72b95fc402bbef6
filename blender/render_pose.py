"""Render the README's picture of the extension at work (headless, Workbench):
    tools/blender/.venv/bin/python blender/render_pose.py EXTENSION.zip OUT.png

Installs the extension zip into a temporary user repository, imports assets/creature.obj with
its handle spheres as vertex groups, adds controls, lifts the snout's Empty and the front right
foot's, and renders the creature at rest (grey, left) and posed by the live handler (blue).
"""

import os
import sys
import tempfile

os.environ.setdefault("BLENDER_USER_RESOURCES", tempfile.mkdtemp(prefix="bsarap-blender-"))

import bpy  # noqa: E402
import numpy as np  # noqa: E402
from mathutils import Euler, Vector  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main(zip_path, out):
    bpy.ops.wm.read_homefile(use_empty=True)
    assert bpy.ops.extensions.package_install_files(
        filepath=os.path.abspath(zip_path), repo="user_default", enable_on_install=True
    ) == {"FINISHED"}
    import bsarap

    bpy.ops.wm.obj_import(filepath=os.path.join(ROOT, "assets", "creature.obj"), forward_axis="NEGATIVE_Z", up_axis="Y")
    obj = bpy.context.selected_objects[0]
    me = obj.data
    V = np.array([v.co[:] for v in me.vertices])
    labels = bsarap.load_selection(os.path.join(ROOT, "assets", "creature.handles.json"), V)
    names = ["front right foot", "front left foot", "back right foot", "back left foot", "tail tip", "snout"]
    for k, name in enumerate(names):
        obj.vertex_groups.new(name=name).add([int(i) for i in np.nonzero(labels == k)[0]], 1.0, "REPLACE")
    bpy.context.view_layer.objects.active = obj
    for name in names:
        bpy.ops.bsarap.add_group(group=name)
    bpy.ops.bsarap.add_controls()

    # the rest copy, left of the posed one
    rest = obj.copy()
    rest.data = me.copy()
    rest.data.shape_keys.key_blocks["BS-ARAP pose"].mute = True
    rest.bsarap.live = False
    rest.location = Vector((-4.0, 0.0, 0.0))
    bpy.context.scene.collection.objects.link(rest)

    snout, foot = bpy.data.objects["snout"], bpy.data.objects["front right foot"]
    snout.location += Vector((0.1, 0.0, 0.55))
    snout.rotation_euler = Euler((0.0, -0.6, 0.0))
    foot.location += Vector((0.45, 0.0, 0.6))
    bpy.context.view_layer.update()  # the live handler poses the mesh

    obj.color = (0.35, 0.55, 0.9, 1.0)
    rest.color = (0.7, 0.7, 0.7, 1.0)
    scene = bpy.context.scene
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.display.shading.color_type = "OBJECT"
    scene.display.shading.light = "STUDIO"
    scene.render.resolution_x, scene.render.resolution_y = 960, 400
    scene.render.film_transparent = False
    cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    scene.collection.objects.link(cam)
    scene.camera = cam
    cam.location = (-2.0, -9.0, 2.5)
    target = Vector((-2.0, 0.0, 0.0))
    cam.rotation_euler = (target - cam.location).to_track_quat("-Z", "Y").to_euler()
    cam.data.lens = 34
    scene.render.image_settings.compression = 100
    scene.render.filepath = os.path.abspath(out)
    bpy.ops.render.render(write_still=True)
    print(out)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
