"""Imports a Wavefront OBJ file into Blender and prints a JSON report of its faces.

Usage: python check_obj.py FILE.obj     (the Python of a venv with `bpy` installed)

The report (one JSON object on the last line of stdout, prefixed by "REPORT "):
- "blender": version string;
- "objects": one entry per imported mesh object, in the order Blender created them:
  - "name", "vertices", "faces", "uv_layers" (names), "materials" (slot names);
  - "corners": the corner count of each face, in Blender's face order (which is the file's:
    the importer adds faces as it reads the `f` lines);
  - "loops": each face's vertex indices (Blender's, 0-based, in its corner order).

Exit status: 0 on success, 2 when the file cannot be imported.
"""

import json
import sys

import bpy


def main():
    path = sys.argv[-1]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    try:
        bpy.ops.wm.obj_import(filepath=path)
    except RuntimeError as e:
        print(f"cannot import {path}: {e}", file=sys.stderr)
        sys.exit(2)
    objects = []
    for o in bpy.context.scene.objects:
        if o.type != "MESH":
            continue
        m = o.data
        objects.append(
            {
                "name": o.name,
                "vertices": len(m.vertices),
                "faces": len(m.polygons),
                "uv_layers": [uv.name for uv in m.uv_layers],
                "materials": [s.material.name if s.material else None for s in o.material_slots],
                "corners": [p.loop_total for p in m.polygons],
                "loops": [list(p.vertices) for p in m.polygons],
            }
        )
    report = {"blender": bpy.app.version_string, "objects": objects}
    print("REPORT " + json.dumps(report))


main()
