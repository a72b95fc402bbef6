"""The modifier stack of a posed mesh: which modifiers may stay on it and which block posing.

The pose goes into a shape key, and Blender evaluates shape keys before the modifier stack, so
every modifier acts on the posed mesh. One that keeps the vertices where they are (it adds,
refines, removes, mirrors or shades geometry: ``KEEPS_VERTICES``) shows the posed surface
subdivided, mirrored, bevelled... One that moves them (a deform modifier, physics, a Mesh Cache,
a Geometry Nodes group, which may do anything) moves the handles off their controls, which are
placed on the base mesh in object space: it blocks posing. A type not in the list blocks too,
so a modifier Blender adds later is refused until it is known to be harmless.

A Geometry Nodes group made only of shading and field nodes (``bpy.ops.object.shade_auto_smooth``'s
"Smooth by Angle", which Blender 4.1+ adds for auto smooth) keeps the vertices: it is allowed.

The Mesh Cache modifier a point-cache bake adds (``CACHE_MODIFIER``) overwrites the positions with
the baked ones, and reads the base mesh's vertex count: measured in bpy 5.0.1, a Subdivision
Surface before it makes it do nothing ("Vertex count mismatch"). It must stay first: any enabled
modifier before it blocks; those after it follow the rule above.
"""

from __future__ import annotations

#: The name of the Mesh Cache modifier Bake to point cache adds.
CACHE_MODIFIER = "BS-ARAP cache"

#: Modifier types (``bpy.types.Modifier.type``, bpy 5.0.1) that leave the posed vertices in
#: place: they act on the pose as they would on the rest mesh.
KEEPS_VERTICES = frozenset(
    {
        # Generate: new geometry around or from the posed surface
        "ARRAY", "BEVEL", "BOOLEAN", "BUILD", "DECIMATE", "EDGE_SPLIT", "MASK", "MIRROR",
        "MULTIRES", "REMESH", "SCREW", "SKIN", "SOLIDIFY", "SUBSURF", "TRIANGULATE", "WELD",
        "WIREFRAME",
        # Edit: normals, UVs, weights; Data Transfer moves no positions (its data types are
        # weights, colours, normals, UVs, seams, creases, bevel weights, sharpness)
        "DATA_TRANSFER", "NORMAL_EDIT", "WEIGHTED_NORMAL", "UV_PROJECT", "UV_WARP",
        "VERTEX_WEIGHT_EDIT", "VERTEX_WEIGHT_MIX", "VERTEX_WEIGHT_PROXIMITY",
        # Physics that only read the mesh (a collider, particles emitted from it, a force
        # field's surface)
        "COLLISION", "PARTICLE_SYSTEM", "SURFACE",
    }
)

#: What the refusal says is fine (by kind; the list above is the rule).
FINE = (
    "modifiers that keep the vertices in place are fine: Subdivision Surface, Multires, "
    "Mirror, Array, Solidify, Bevel, Triangulate, Decimate, Weld, normals, UVs, vertex weights, "
    "Smooth by Angle"
)

#: Geometry Nodes nodes that pass the geometry on with its positions unchanged.
_NODES_KEEPING = frozenset(
    {
        "NodeGroupInput", "NodeGroupOutput", "NodeFrame", "NodeReroute",
        "GeometryNodeSetShadeSmooth", "GeometryNodeSetMaterial", "GeometryNodeSetMaterialIndex",
    }
)
#: Field nodes: they compute values from the geometry, never a geometry.
_FIELD_PREFIXES = ("FunctionNode", "GeometryNodeInput", "ShaderNode")


def shading_only(tree, _seen=None) -> bool:
    """Whether a Geometry Nodes tree (and the groups inside it) only shades: its nodes are
    group inputs and outputs, Set Shade Smooth or Set Material, and field nodes, so its output
    is its input geometry with the same positions (Smooth by Angle)."""
    if tree is None:
        return True
    seen = set() if _seen is None else _seen
    if tree.name_full in seen:
        return True
    seen.add(tree.name_full)
    for n in tree.nodes:
        kind = n.bl_idname
        if kind == "GeometryNodeGroup":
            if not shading_only(n.node_tree, seen):
                return False
        elif kind not in _NODES_KEEPING and not kind.startswith(_FIELD_PREFIXES):
            return False
    return True


def keeps_vertices(m) -> bool:
    """Whether modifier ``m`` leaves the posed vertices where they are."""
    if m.type == "NODES":
        return shading_only(m.node_group)
    return m.type in KEEPS_VERTICES


def is_cache(m) -> bool:
    return m.name == CACHE_MODIFIER and m.type == "MESH_CACHE"


def enabled(m) -> bool:
    return m.show_viewport or m.show_render


def label(m) -> str:
    """The modifier's name, with its kind unless the name is the kind's: "Bend (Lattice)",
    "Displace"."""
    kind = m.bl_rna.properties["type"].enum_items[m.type].name
    same = m.name.replace(" ", "").lower() == kind.replace(" ", "").lower()
    return m.name if same else f"{m.name} ({kind})"


def blocking(obj):
    """``(before_cache, moving)``: the labels of the enabled modifiers before our (enabled) Mesh
    Cache modifier, and of those after it (all when there is none) that move the vertices."""
    mods = list(obj.modifiers)
    # a disabled cache modifier reads nothing: it is not the cache
    cache = next((i for i, m in enumerate(mods) if is_cache(m) and enabled(m)), None)
    before = [label(m) for m in mods[: cache or 0] if enabled(m)]
    after = mods if cache is None else mods[cache + 1 :]
    moving = [label(m) for m in after if enabled(m) and not keeps_vertices(m)]
    return before, moving


def refusal(obj):
    """Why the modifiers of ``obj`` block posing, or ``None`` when they do not."""
    before, moving = blocking(obj)
    if before:
        return (
            f"{obj.name}: modifiers before the {CACHE_MODIFIER} modifier ({', '.join(before)}): "
            "the point cache holds the base mesh's vertices, so it must stay first in the stack; "
            "move it to the top"
        )
    if moving:
        # Blender applies no modifier to a mesh with shape keys (a posed mesh has them)
        verbs = "apply, remove or disable" if obj.data.shape_keys is None else "remove or disable"
        return (
            f"{obj.name}: modifiers that move the vertices ({', '.join(moving)}): the pose is "
            f"solved on the base mesh and they would move it off the controls; {verbs} them "
            f"(disabled: in the viewport and render) ({FINE})"
        )
    return None
