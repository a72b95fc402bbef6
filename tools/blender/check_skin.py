"""Imports a skinned glTF (bones baked by `bsarap export --bones`) into Blender and prints a
JSON report of the armature, its action and the evaluated mesh at every key.

Usage: python check_skin.py FILE.glb|FILE.gltf     (the Python of a venv with `bpy` installed)

The report (one JSON object on the last line of stdout, prefixed by "REPORT "):
- "blender": version string; "fps": the scene's frames per second;
- "armatures": [{"name", "bones": bone count, "action": the armature's action (null when
  none), "keyframes": the sorted distinct key frames of all its channels}];
- "meshes": [{"name", "vertices", "faces", "armature_modifier": the mesh is deformed by an
  Armature modifier, "groups": vertex-group count, "positions": the evaluated world-space
  vertex positions at each key frame of the first armature, in glTF axes}].
Blender is Z-up; the importer turns (x, y, z)_gltf into (x, -z, y)_blender, converted back here.

Exit status: 0 on success, 2 when the file cannot be imported.
"""

import json
import sys

import bpy

from check_gltf import channelbag_fcurves, evaluated_positions, import_or_exit, set_frame


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    if not args:
        print("usage: check_skin.py FILE.glb|FILE.gltf", file=sys.stderr)
        sys.exit(2)
    path = args[-1]
    scene = import_or_exit(path)
    armatures = []
    frames = []
    for obj in sorted((o for o in scene.objects if o.type == "ARMATURE"), key=lambda o: o.name):
        action, curves = channelbag_fcurves(obj.animation_data)
        keys = sorted({round(k.co[0], 6) for c in curves for k in c.keyframe_points})
        if not frames:
            frames = keys
        armatures.append(
            {
                "name": obj.name,
                "bones": len(obj.data.bones),
                "action": action.name if action else None,
                "keyframes": keys,
            }
        )
    meshes = []
    for obj in sorted((o for o in scene.objects if o.type == "MESH"), key=lambda o: o.name):
        positions = []
        for f in frames:
            set_frame(scene, f)
            positions.append(evaluated_positions(obj, bpy.context.evaluated_depsgraph_get()))
        meshes.append(
            {
                "name": obj.name,
                "vertices": len(obj.data.vertices),
                "faces": len(obj.data.polygons),
                "armature_modifier": any(m.type == "ARMATURE" for m in obj.modifiers),
                "groups": len(obj.vertex_groups),
                "positions": positions,
            }
        )
    report = {
        "blender": bpy.app.version_string,
        "fps": scene.render.fps,
        "armatures": armatures,
        "meshes": meshes,
    }
    sys.stdout.flush()
    print("REPORT " + json.dumps(report))


if __name__ == "__main__":
    main()
