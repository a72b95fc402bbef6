"""Imports a glTF file into Blender and prints a JSON report of what Blender made of it.

Usage: python check_gltf.py FILE.glb|FILE.gltf     (the Python of a venv with `bpy` installed)

The report (one JSON object on the last line of stdout, prefixed by "REPORT "):
- "blender": version string; "fps": the scene's frames per second;
- "meshes": one entry per mesh object, sorted by name:
  - "name", "vertices", "faces", "uv_layers" (names);
  - "materials": [{"name", "image_texture": an Image Texture node has an image,
    "image_size": [w, h] of the first such image in pixels (0, 0 when none or unreadable),
    "images": how many Image Texture nodes have an image, "linked": the names of the node
    inputs (any node's: the Principled BSDF's, the glTF output group's Occlusion) that a link
    feeds, sorted, "normal_strength": the Normal Map node's strength (null when none)}];
  - "shape_keys": the number of shape keys besides the basis;
  - "action": name of the action animating the shape keys or the object (null when none);
  - "keyframes": frame numbers of the first animated channel's keys (shape-key channels first);
  - "samples": at frames `frame_start`, the middle and `frame_end` of that action, plus every
    key frame, the world-space bounding box of the *evaluated* mesh (modifiers, shape keys and
    the action applied): [{"frame", "min": [x, y, z], "max": [x, y, z]}];
  - "positions": the evaluated world-space vertex positions at each key frame (only with
    --positions): [[[x, y, z], ...], ...], one list per key frame;
  - "slider_range": [smallest slider_min, largest slider_max] of the shape keys besides the
    basis (Blender clamps a key's value to its slider range; null when there are none);
  - "key_values": at each key frame, the value of every shape key besides the basis as the
    action set it (the glTF morph weights as Blender plays them).
Blender's axes are Z-up; glTF's Y-up. The importer turns (x, y, z)_gltf into
(x, -z, y)_blender; "positions" and the bounding boxes are converted back to glTF axes so that
they compare with the file directly.

Exit status: 0 on success, 2 when the file cannot be imported.
"""

import json
import sys
from array import array

import bpy


def to_gltf_axes(v):
    """Blender Z-up (x, y, z) -> glTF Y-up (x, z, -y)."""
    return [v[0], v[2], -v[1]]


def channelbag_fcurves(anim_data):
    """The F-curves an AnimData's action drives: the legacy `action.fcurves` (Blender < 4.4) or
    the slotted action's channel bag for the assigned slot (Blender >= 4.4, only form in 5)."""
    if anim_data is None or anim_data.action is None:
        return None, []
    action = anim_data.action
    if hasattr(action, "layers") and len(action.layers) > 0:
        slot = getattr(anim_data, "action_slot", None)
        curves = []
        for layer in action.layers:
            for strip in layer.strips:
                bag = strip.channelbag(slot) if slot is not None else None
                if bag is not None:
                    curves.extend(bag.fcurves)
        return action, curves
    return action, list(getattr(action, "fcurves", []))


def material_report(mat):
    entry = {
        "name": mat.name if mat else None,
        "image_texture": False,
        "image_size": [0, 0],
        "images": 0,
        "linked": [],
        "normal_strength": None,
    }
    if mat is None or mat.node_tree is None:
        return entry
    linked = set()
    for node in mat.node_tree.nodes:
        if node.type == "TEX_IMAGE" and node.image is not None:
            entry["images"] += 1
            if not entry["image_texture"]:
                w, h = node.image.size
                entry["image_texture"] = True
                entry["image_size"] = [w, h]
        if node.type == "NORMAL_MAP":
            entry["normal_strength"] = float(node.inputs["Strength"].default_value)
        if node.type in ("BSDF_PRINCIPLED", "GROUP"):
            linked.update(i.name for i in node.inputs if i.is_linked)
    entry["linked"] = sorted(linked)
    return entry


def evaluated_positions(obj, depsgraph):
    """The evaluated mesh's vertices in world space and glTF axes: Blender's object matrix
    (f32) applied to its vertex coordinates (f32) in Python's doubles, as Blender holds them;
    mathutils' `matrix_world @ co` would round the sum to f32, half a unit at five million."""
    ev = obj.evaluated_get(depsgraph)
    mesh = ev.to_mesh()
    m = [[float(ev.matrix_world[i][j]) for j in range(4)] for i in range(3)]
    co = array("f", bytes(12 * len(mesh.vertices)))
    mesh.vertices.foreach_get("co", co)
    pts = []
    for k in range(0, len(co), 3):
        x, y, z = co[k], co[k + 1], co[k + 2]
        pts.append(to_gltf_axes([r[0] * x + r[1] * y + r[2] * z + r[3] for r in m]))
    ev.to_mesh_clear()
    return pts


def bbox(pts):
    if not pts:
        return [0.0] * 3, [0.0] * 3
    return [min(p[k] for p in pts) for k in range(3)], [max(p[k] for p in pts) for k in range(3)]


def set_frame(scene, frame):
    whole = int(frame // 1)
    scene.frame_set(whole, subframe=frame - whole)


def import_or_exit(path):
    """Imports the glTF file `path` into an empty scene with Blender's own importer and
    returns the scene; exits with status 2 (the message on stderr) when the import fails."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    try:
        result = bpy.ops.import_scene.gltf(filepath=path)
    except RuntimeError as e:
        print(f"{path}: import failed: {e}", file=sys.stderr)
        sys.exit(2)
    if "FINISHED" not in result:
        print(f"{path}: import returned {result}", file=sys.stderr)
        sys.exit(2)
    return bpy.context.scene


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    want_positions = "--positions" in sys.argv
    if not args:
        print("usage: check_gltf.py FILE.glb|FILE.gltf [--positions]", file=sys.stderr)
        sys.exit(2)
    path = args[-1]
    scene = import_or_exit(path)
    meshes = []
    for obj in sorted((o for o in scene.objects if o.type == "MESH"), key=lambda o: o.name):
        data = obj.data
        keys = data.shape_keys
        shape_keys = max(len(keys.key_blocks) - 1, 0) if keys else 0
        action, curves = channelbag_fcurves(keys.animation_data if keys else None)
        if action is None:
            action, curves = channelbag_fcurves(obj.animation_data)
        keyframes = [k.co[0] for k in curves[0].keyframe_points] if curves else []
        entry = {
            "name": obj.name,
            "vertices": len(data.vertices),
            "faces": len(data.polygons),
            "uv_layers": [uv.name for uv in data.uv_layers],
            "materials": [material_report(m) for m in data.materials],
            "shape_keys": shape_keys,
            "action": action.name if action else None,
            "keyframes": keyframes,
            "samples": [],
            "slider_range": None,
            "key_values": [],
        }
        blocks = list(keys.key_blocks)[1:] if keys else []
        if blocks:
            entry["slider_range"] = [
                min(b.slider_min for b in blocks),
                max(b.slider_max for b in blocks),
            ]
        frames = []
        if action is not None:
            start, end = action.frame_range
            frames = [start, 0.5 * (start + end), end]
        frames += keyframes
        positions = []
        for i, f in enumerate(frames):
            set_frame(scene, f)
            pts = evaluated_positions(obj, bpy.context.evaluated_depsgraph_get())
            lo, hi = bbox(pts)
            entry["samples"].append({"frame": f, "min": lo, "max": hi})
            if i >= len(frames) - len(keyframes):
                entry["key_values"].append([b.value for b in blocks])
                if want_positions:
                    positions.append(pts)
        if want_positions:
            entry["positions"] = positions
        meshes.append(entry)
    report = {"blender": bpy.app.version_string, "fps": scene.render.fps, "meshes": meshes}
    sys.stdout.flush()
    print("REPORT " + json.dumps(report))


if __name__ == "__main__":
    main()
