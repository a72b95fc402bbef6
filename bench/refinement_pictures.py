"""The refinement study's picture (BENCHMARKS.md, "One pose at every resolution"): one pose of
a mesh at its own resolution and subdivided, for each energy, side by side, rendered in one
Blender Workbench image with one orthographic camera.

    tools/blender/.venv/bin/python bench/refinement_pictures.py POSES_DIR STEM OUT.png \
        [--energies spokes-rims,sr0.02] [--factor 16] [--scale 0.03]

POSES_DIR holds `refinement --write-poses` OBJs, STEM_ENERGY_x1.obj, STEM_ENERGY_xFACTOR.obj and
STEM_rest.obj
(the finer mesh's first vertices are the coarse mesh's, subdivision keeps them first). Rows:
the energies; columns: ×1, ×FACTOR, and ×1 coloured by each vertex's distance to the same
vertex of the ×FACTOR pose (gray 0 to dark red at `--scale`, a fraction of the diagonal of STEM_rest.obj's box, as the
example's distances). Driven by bench/refinement_pictures.sh.
"""

from __future__ import annotations

import argparse
import os

import bpy
import numpy as np

LABELS = {"spokes-rims": "spokes and rims"}


def label(energy: str) -> str:
    if energy.startswith("sr"):
        return f"smooth rotations\nℓ = {energy[2:]}·diag"
    return LABELS.get(energy, energy)


def read_obj(path: str):
    """Positions ``(n, 3)`` and triangles ``(m, 3)`` of an OBJ of `v` and `f i j k` lines."""
    v, f = [], []
    with open(path) as fh:
        for line in fh:
            if line.startswith("v "):
                v.append([float(x) for x in line.split()[1:4]])
            elif line.startswith("f "):
                f.append([int(x.split("/")[0]) - 1 for x in line.split()[1:4]])
    return np.array(v), np.array(f, dtype=np.int64)


def add_mesh(name, V, F, offset, colors=None, gray=0.8):
    """A mesh object at ``offset`` (Blender's z up: the file's y up, its z towards -y)."""
    P = np.stack([V[:, 0], -V[:, 2], V[:, 1]], axis=1) + offset
    me = bpy.data.meshes.new(name)
    me.vertices.add(len(P))
    me.vertices.foreach_set("co", P.astype(np.float32).ravel())
    me.loops.add(F.size)
    me.loops.foreach_set("vertex_index", F.astype(np.int32).ravel())
    me.polygons.add(len(F))
    me.polygons.foreach_set("loop_start", np.arange(0, F.size, 3, dtype=np.int32))
    me.update()
    me.validate()
    if colors is None:
        colors = np.tile([gray, gray, gray], (len(P), 1))
    attr = me.color_attributes.new("heat", "FLOAT_COLOR", "POINT")
    rgba = np.concatenate([colors, np.ones((len(P), 1))], axis=1)
    attr.data.foreach_set("color", rgba.astype(np.float32).ravel())
    me.color_attributes.active_color = attr
    obj = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def add_text(body, location, size):
    cu = bpy.data.curves.new(body[:20], "FONT")
    cu.body = body
    cu.size = size
    cu.align_x = "CENTER"
    obj = bpy.data.objects.new(body[:20], cu)
    obj.location = location
    obj.rotation_euler = (np.pi / 2, 0.0, 0.0)  # facing the camera (-y)
    bpy.context.scene.collection.objects.link(obj)
    # Workbench colours by attribute: the text as a mesh with a dark one
    bpy.context.view_layer.update()
    me = bpy.data.meshes.new_from_object(obj.evaluated_get(bpy.context.evaluated_depsgraph_get()))
    attr = me.color_attributes.new("heat", "FLOAT_COLOR", "POINT")
    attr.data.foreach_set("color", np.tile([0.05, 0.05, 0.05, 1.0], len(me.vertices)).astype(np.float32))
    mobj = bpy.data.objects.new(body[:20], me)
    mobj.matrix_world = obj.matrix_world
    bpy.context.scene.collection.objects.unlink(obj)
    bpy.context.scene.collection.objects.link(mobj)


def heat(t):
    """The ×1 columns' gray (0) through orange (0.5) to dark red (1), ``t`` clipped to [0, 1]."""
    t = np.clip(t, 0.0, 1.0)[:, None]
    gray, orange, red = np.array([0.8, 0.8, 0.8]), np.array([1.0, 0.45, 0.05]), np.array([0.45, 0.0, 0.0])
    lo = gray + (orange - gray) * np.clip(2 * t, 0, 1)
    return np.where(t < 0.5, lo, orange + (red - orange) * np.clip(2 * t - 1, 0, 1))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("poses")
    ap.add_argument("stem")
    ap.add_argument("out")
    ap.add_argument("--energies", default="spokes-rims,sr0.02")
    ap.add_argument("--factor", type=int, default=16)
    ap.add_argument("--scale", type=float, default=0.03)
    ap.add_argument("--width", type=int, default=1000)
    a = ap.parse_args()
    energies = a.energies.split(",")

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    rows = []
    for e in energies:
        coarse = read_obj(os.path.join(a.poses, f"{a.stem}_{e}_x1.obj"))
        fine = read_obj(os.path.join(a.poses, f"{a.stem}_{e}_x{a.factor}.obj"))
        rows.append((e, coarse, fine))
    rest = read_obj(os.path.join(a.poses, f"{a.stem}_rest.obj"))[0]
    lo, hi = rest.min(axis=0), rest.max(axis=0)
    diag = float(np.linalg.norm(hi - lo))
    for _, (V, _), (W, _) in rows:  # the poses' common box
        lo, hi = np.minimum(lo, np.minimum(V.min(0), W.min(0))), np.maximum(hi, np.maximum(V.max(0), W.max(0)))
    w, h = (hi[0] - lo[0]) * 1.15, (hi[1] - lo[1]) * 1.2  # a cell: x across, y up
    centre = (lo + hi) / 2
    cols = 3
    margin = 0.75 * w  # the row labels' column
    for r, (e, (V, F), (W, G)) in enumerate(rows):
        y = -(r - (len(rows) - 1) / 2) * h
        n = len(V)
        d = np.linalg.norm(V - W[:n], axis=1) / diag
        for c, (name, P, T, colors) in enumerate(
            (
                ("x1", V, F, None),
                (f"x{a.factor}", W, G, None),
                ("diff", V, F, heat(d / a.scale)),
            )
        ):
            x = (c - (cols - 1) / 2) * w
            off = np.array([x, 0.0, y]) - np.array([centre[0], -centre[2], centre[1]])
            add_mesh(f"{e}_{name}", P, T, off, colors)
        print(f"{e}: {n} / {len(W)} vertices; |x1 - x{a.factor}| mean {100 * d.mean():.3f} % max {100 * d.max():.3f} % of diag")
        add_text(label(e), (-(cols / 2) * w - margin / 2, 0.0, y), 0.065 * h)
    size = 0.065 * h
    top = (len(rows) / 2) * h
    heads = (
        f"×1 ({len(rows[0][1][0])} vertices)",
        f"×{a.factor} ({len(rows[0][2][0])} vertices)",
        f"×1 coloured by |×1 − ×{a.factor}|\n0 to {100 * a.scale:g} % of diag",
    )
    for c, text in enumerate(heads):
        add_text(text, ((c - (cols - 1) / 2) * w, 0.0, top + 0.06 * h), size)

    cam = bpy.data.cameras.new("camera")
    cam.type = "ORTHO"
    full_w, full_h = cols * w + margin, len(rows) * h + 0.2 * h
    cam.ortho_scale = max(full_w, full_h)
    cobj = bpy.data.objects.new("camera", cam)
    cobj.location = (-margin / 2, -10.0 * diag, 0.1 * h)
    cobj.rotation_euler = (np.pi / 2, 0.0, 0.0)
    cam.clip_end = 100.0 * diag
    scene.collection.objects.link(cobj)
    scene.camera = cobj
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.display.shading.light = "STUDIO"
    scene.display.shading.color_type = "VERTEX"
    scene.display.shading.show_cavity = False
    scene.render.resolution_x = a.width
    scene.render.resolution_y = int(round(a.width * full_h / full_w))
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGB"
    scene.render.image_settings.compression = 100
    scene.render.film_transparent = False
    scene.world = bpy.data.worlds.new("world")
    scene.world.color = (1.0, 1.0, 1.0)
    scene.view_settings.view_transform = "Standard"  # white stays white (not AgX's gray)
    scene.render.filepath = os.path.abspath(a.out)
    bpy.ops.render.render(write_still=True)
    print(a.out)


if __name__ == "__main__":
    main()
