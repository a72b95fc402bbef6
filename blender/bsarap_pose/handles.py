"""Vertex groups as handle groups: per-vertex labels, rest positions and centroids.

A vertex belongs to a handle group when its weight in the vertex group is above
``WEIGHT_THRESHOLD`` (so weight painting at full strength selects it). Label ``k`` is the
``k``-th handle group of the object's list, ``-1`` a free vertex: the ``handles`` argument of
``bsarap.Deformer``.
"""

from __future__ import annotations

import zlib

import numpy as np

#: A vertex is in a handle group when its weight is above this.
WEIGHT_THRESHOLD = 0.5


class HandleError(Exception):
    """Bad handle input, with a message for the status bar."""


def _rest_co(mesh) -> np.ndarray:
    """The rest coordinates as Blender stores them, ``(3n,)`` float32: the reference (basis)
    shape key when the mesh has shape keys, else the vertices."""
    co = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    keys = mesh.shape_keys
    if keys is not None and keys.reference_key is not None:
        keys.reference_key.points.foreach_get("co", co)
    elif len(co):  # the position attribute: the same floats, read 20x faster than "co"
        mesh.attributes["position"].data.foreach_get("vector", co)
    return co


def rest_positions(mesh) -> np.ndarray:
    """The rest positions ``(n, 3)`` float64: the reference (basis) shape key when the mesh has
    shape keys, else the vertices. Never the posed shape."""
    return _rest_co(mesh).reshape(-1, 3).astype(np.float64)


def rest_fingerprint(mesh) -> int:
    """A checksum of the rest coordinates (CRC-32 of their bytes): changes when the basis is
    edited (about 1 ms per 100k vertices, cheap enough for every update)."""
    return zlib.crc32(_rest_co(mesh))


def triangles(mesh) -> np.ndarray:
    """The mesh's triangles ``(m, 3)`` int64 (Blender's loop triangulation of its faces)."""
    mesh.calc_loop_triangles()
    m = len(mesh.loop_triangles)
    tri = np.empty(m * 3, dtype=np.int32)
    mesh.loop_triangles.foreach_get("vertices", tri)
    return tri.reshape(m, 3).astype(np.int64)


#: The mesh's connectivity, as ``(attribute, collection, property, width)``: each face corner's
#: vertex and edge and each edge's two vertices. Blender (4.0+) keeps them as the internal
#: attributes named here, read raw in about 0.05 ms per 100k vertices; the same numbers through
#: ``loops`` and ``edges`` (the fallback) go item by item, about 30 ms.
_CONNECTIVITY = (
    (".corner_vert", "loops", "vertex_index", 1),
    (".corner_edge", "loops", "edge_index", 1),
    (".edge_verts", "edges", "vertices", 2),
)


def _int_array(mesh, attribute, collection, prop, width) -> np.ndarray:
    """The int32 array ``(len(collection) * width,)`` of the mesh's internal attribute
    ``attribute``, or, where it is missing (another Blender version, a mesh with no such
    element), of ``prop`` read through ``collection``: the same numbers."""
    items = getattr(mesh, collection)
    out = np.empty(len(items) * width, dtype=np.int32)
    attr = mesh.attributes.get(attribute)
    if attr is not None and len(attr.data) * width == len(out):
        attr.data.foreach_get("value", out)
    elif len(out):
        items.foreach_get(prop, out)
    return out


def topology_fingerprint(mesh) -> tuple:
    """The element counts and a checksum of the connectivity (CRC-32 of each face corner's vertex
    and edge, in face order, and of each edge's vertices): it changes with an edit of the faces
    that keeps the counts too (Rotate Edge, faces sorted, a face's corners split between faces
    another way, which changes the edge that closes a face). About 1.3 ms per 100k vertices of
    quads, 2 ms of triangles (mostly the checksum), cheap enough for every update and panel
    draw."""
    crc = 0
    for spec in _CONNECTIVITY:
        crc = zlib.crc32(_int_array(mesh, *spec), crc)
    return (len(mesh.vertices), len(mesh.edges), len(mesh.loops), len(mesh.polygons), crc)


def labels(obj, group_names) -> np.ndarray:
    """Per-vertex labels from the object's vertex groups ``group_names`` (in order).

    Raises :class:`HandleError` for an unknown group, a group with no vertex above the
    threshold, or a vertex in two handle groups.
    """
    if not group_names:
        raise HandleError(f"{obj.name}: no handle groups; add vertex groups to the BS-ARAP list first")
    index_of = {}
    for k, name in enumerate(group_names):
        vg = obj.vertex_groups.get(name)
        if vg is None:
            raise HandleError(f"{obj.name}: vertex group '{name}' does not exist")
        if vg.index in index_of:
            raise HandleError(f"{obj.name}: vertex group '{name}' is listed twice")
        index_of[vg.index] = k
    mesh = obj.data
    out = np.full(len(mesh.vertices), -1, dtype=np.int64)
    overlap = None
    for v in mesh.vertices:
        for g in v.groups:
            k = index_of.get(g.group)
            if k is None or g.weight <= WEIGHT_THRESHOLD:
                continue
            if out[v.index] >= 0 and out[v.index] != k:
                overlap = (v.index, group_names[out[v.index]], group_names[k])
            out[v.index] = k
    if overlap is not None:
        i, a, b = overlap
        raise HandleError(f"{obj.name}: vertex {i} is in two handle groups ('{a}' and '{b}')")
    counts = np.bincount(out[out >= 0], minlength=len(group_names))
    for k, name in enumerate(group_names):
        if counts[k] == 0:
            raise HandleError(
                f"{obj.name}: vertex group '{name}' has no vertex with weight above {WEIGHT_THRESHOLD}"
            )
    return out


def centroids(rest: np.ndarray, lab: np.ndarray, n_groups: int) -> np.ndarray:
    """The rest centroid ``(n_groups, 3)`` of each handle group, in object space."""
    out = np.zeros((n_groups, 3))
    for k in range(n_groups):
        out[k] = rest[lab == k].mean(axis=0)
    return out
