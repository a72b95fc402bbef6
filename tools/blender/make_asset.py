"""Authors the asset-pipeline test asset in Blender, by script, and exports it.

Usage: python make_asset.py OUT_DIR      (the Python of a venv with `bpy` installed)

The asset: a UV-sphere "head" whose material samples a generated 64x64 image texture
(Image Texture -> Principled BSDF base colour), and two small UV-sphere "eyes", separate
objects (loose parts) sharing a second, untextured material. Three connected components in all.

Writes into OUT_DIR:
- head.glb                     (glTF binary, texture embedded as PNG)
- head.obj, head.mtl, skin.png (OBJ with materials; path mode "copy" puts the texture beside)
- source/skin.png              (the generated texture as authored)
and prints one line "REPORT {json}" describing what was written (objects, vertex and face counts).

Nothing is downloaded: the geometry and the texture pixels are generated here.
"""

import json
import os
import sys

import bpy


def clear_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)


def checker_image(name, size):
    """A size x size RGBA checkerboard (8 squares a side) with a red-to-green ramp: a texture
    whose look shows a wrong UV mapping at once."""
    img = bpy.data.images.new(name, width=size, height=size, alpha=True)
    pixels = [0.0] * (size * size * 4)
    for y in range(size):
        for x in range(size):
            on = ((x * 8 // size) + (y * 8 // size)) % 2 == 0
            base = 0.9 if on else 0.2
            i = 4 * (y * size + x)
            pixels[i] = base * x / (size - 1)
            pixels[i + 1] = base * y / (size - 1)
            pixels[i + 2] = base
            pixels[i + 3] = 1.0
    img.pixels.foreach_set(pixels)
    return img


def new_material(name):
    """A material with its node tree (Blender 5 gives one; older versions need use_nodes)."""
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True
    return mat


def textured_material(name, image):
    mat = new_material(name)
    nodes = mat.node_tree.nodes
    bsdf = next(n for n in nodes if n.type == "BSDF_PRINCIPLED")
    tex = nodes.new("ShaderNodeTexImage")
    tex.image = image
    mat.node_tree.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
    return mat


def plain_material(name, rgba):
    mat = new_material(name)
    bsdf = next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    bsdf.inputs["Base Color"].default_value = rgba
    mat.diffuse_color = rgba
    return mat


def sphere(name, radius, location, segments, rings, material):
    bpy.ops.mesh.primitive_uv_sphere_add(
        segments=segments, ring_count=rings, radius=radius, location=location
    )
    obj = bpy.context.active_object
    obj.name = name
    obj.data.name = name
    obj.data.materials.append(material)
    return obj


def main():
    if len(sys.argv) < 2:
        print("usage: make_asset.py OUT_DIR", file=sys.stderr)
        sys.exit(2)
    out = os.path.abspath(sys.argv[-1])
    os.makedirs(out, exist_ok=True)
    clear_scene()

    image = checker_image("skin", 64)
    # Save the generated pixels as a PNG in a source folder: the glTF exporter embeds it and
    # the OBJ exporter ("copy" path mode) copies it beside head.mtl.
    src = os.path.join(out, "source")
    os.makedirs(src, exist_ok=True)
    image.filepath_raw = os.path.join(src, "skin.png")
    image.file_format = "PNG"
    image.save()

    skin = textured_material("skin", image)
    eye = plain_material("eye", (0.05, 0.05, 0.3, 1.0))
    head = sphere("head", 1.0, (0.0, 0.0, 0.0), 24, 12, skin)
    eyes = [
        sphere("eye_left", 0.15, (-0.35, -0.9, 0.3), 12, 6, eye),
        sphere("eye_right", 0.15, (0.35, -0.9, 0.3), 12, 6, eye),
    ]
    objects = [head] + eyes

    glb = os.path.join(out, "head.glb")
    bpy.ops.export_scene.gltf(filepath=glb, export_format="GLB", export_image_format="AUTO")
    obj_path = os.path.join(out, "head.obj")
    bpy.ops.wm.obj_export(
        filepath=obj_path,
        export_materials=True,
        export_uv=True,
        export_normals=True,
        export_triangulated_mesh=False,
        path_mode="COPY",
    )
    report = {
        "blender": bpy.app.version_string,
        "files": sorted(f for f in os.listdir(out) if f != "source"),
        "objects": [
            {
                "name": o.name,
                "vertices": len(o.data.vertices),
                "faces": len(o.data.polygons),
                "material": o.data.materials[0].name,
            }
            for o in objects
        ],
    }
    print("REPORT " + json.dumps(report))


if __name__ == "__main__":
    main()
