"""Time the extension in bpy (headless) on assets/creature.obj:
    tools/blender/.venv/bin/python blender/bench.py [--cuts N] [--frames F] [--steps S]

Installs the extension zip as the tests do ($BSARAP_BLENDER_ZIP or target/blender-extension),
imports the creature with its six handle spheres as vertex groups (optionally subdivided first,
``--cuts 4``: each triangle into 25, about 757k vertices), adds controls, then
- the live handler: S steps of a drag of the snout's Empty, each a depsgraph update (the
  handler's solve and shape-key write, ``SolverState.last_ms``), median / min / max;
- Bake to shape keys over F frames (the Empty keyed from rest to a lifted, turned pose), wall
  time of the operator.
"""

import argparse
import os
import statistics
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "tests"))
import common as t  # noqa: E402  (sets BLENDER_USER_RESOURCES before bpy)

import bpy  # noqa: E402
import numpy as np  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--cuts", type=int, default=0)
    ap.add_argument("--frames", type=int, default=60)
    ap.add_argument("--steps", type=int, default=40)
    args = ap.parse_args()
    if t.SKIP:
        sys.exit(f"cannot run: {t.SKIP}")
    ext, bsarap = t.install()
    bpy.ops.wm.obj_import(filepath=os.path.join(t.ROOT, "assets", "creature.obj"), forward_axis="NEGATIVE_Z", up_axis="Y")
    obj = bpy.context.selected_objects[0]
    if args.cuts:
        import bmesh

        bm = bmesh.new()
        bm.from_mesh(obj.data)
        bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=args.cuts, use_grid_fill=True)
        bmesh.ops.triangulate(bm, faces=bm.faces[:])
        bm.to_mesh(obj.data)
        bm.free()
    V = ext.handles.rest_positions(obj.data)
    labels = bsarap.load_selection(os.path.join(t.ROOT, "assets", "creature.handles.json"), V)
    groups = []
    for k in range(int(labels.max()) + 1):
        vg = obj.vertex_groups.new(name=f"handle{k}")
        vg.add([int(i) for i in np.nonzero(labels == k)[0]], 1.0, "REPLACE")
        groups.append(vg.name)
    t0 = time.perf_counter()
    t.make_controls(obj, groups)
    build_s = time.perf_counter() - t0
    st = ext.solve.state(obj)
    e = obj.bsarap.groups[5].control  # the snout
    times, solve_ms = [], []
    for _ in range(args.steps):
        e.location.z += 0.01
        e.rotation_euler.y -= 0.01
        bpy.context.view_layer.update()
        times.append(st.last_ms)
        solve_ms.append(st.last_solve_ms)
    med = statistics.median(times)
    print(
        f"{len(V)} vertices, {st.deformer.method}: Add controls (build + first solve) {build_s:.1f} s; "
        f"live handler {med:.1f} ms per update median ({min(times):.1f} min, {max(times):.1f} max) "
        f"over {args.steps} steps = {1e3 / med:.1f} updates/s; of which the solve "
        f"(Deformer.solve_targets) {statistics.median(solve_ms):.1f} ms"
    )
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, args.frames
    e.keyframe_insert("location", frame=1)
    e.keyframe_insert("rotation_euler", frame=1)
    e.location.z += 0.4
    e.rotation_euler.z += 0.5
    e.keyframe_insert("location", frame=args.frames)
    e.keyframe_insert("rotation_euler", frame=args.frames)
    scene.frame_set(1)
    t.activate(obj)
    t0 = time.perf_counter()
    assert bpy.ops.bsarap.bake_shape_keys() == {"FINISHED"}
    bake_s = time.perf_counter() - t0
    print(f"Bake to shape keys, {args.frames} frames: {bake_s:.1f} s ({1e3 * bake_s / args.frames:.0f} ms a frame)")


if __name__ == "__main__":
    main()
