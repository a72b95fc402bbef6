"""The extension's data on each object (``Object.bsarap``): the handle groups with their
controls (Empties) and the solver settings, the CLI's flags; on each control, the object it
poses (``Object.bsarap_owner``); on each scene, the objects that pose their meshes
(``Scene.bsarap_meshes``) and the point cache files its bakes wrote (``Scene.bsarap_caches``)."""

from __future__ import annotations

import bpy
from bpy.props import (
    BoolProperty,
    CollectionProperty,
    EnumProperty,
    FloatProperty,
    FloatVectorProperty,
    IntProperty,
    PointerProperty,
    StringProperty,
)

try:  # The solver's own defaults; the add-on still registers without the wheel.
    from bsarap import DEFAULT_BENDING_LENGTH, DEFAULT_MEMBRANE, MAX_BENDING_LENGTH
except ImportError:  # pragma: no cover - reported by the operators
    DEFAULT_BENDING_LENGTH, DEFAULT_MEMBRANE, MAX_BENDING_LENGTH = 0.02, 0.0, 1.0

#: The methods of ``bsarap.Deformer`` (the CLI's ``--method``), the editor's default first.
METHOD_ITEMS = [
    ("bsarap-coarse", "Coarse BS-ARAP", "BS-ARAP on a coarse base with details carried (the editor's default)"),
    ("bsarap", "BS-ARAP", "The paper's BS-ARAP on the full mesh"),
    ("bsarap-faired", "Faired BS-ARAP", "BS-ARAP on a faired base surface"),
    ("arap", "ARAP", "Plain as-rigid-as-possible deformation"),
]
ENERGY_ITEMS = [
    ("spokes-and-rims", "Spokes and rims", "ARAP energy over each vertex's spokes and rims"),
    ("spokes", "Spokes", "ARAP energy over each vertex's spokes only"),
    (
        "smooth-rotations",
        "Smooth rotations",
        "Spokes and rims with the rotations smoothed over the bending length (SR-ARAP): "
        "the pose does not move with the mesh's resolution",
    ),
]
#: The coarse variant's coarse energies (``bsarap.Deformer(coarse_energy=...)``).
COARSE_ENERGY_ITEMS = [
    ("decimated", "Decimated", "ARAP on the decimated base"),
    (
        "galerkin",
        "Galerkin",
        "The full mesh's energy restricted to the coarse level: nearer the full mesh's pose "
        "(smooth rotations only; the editor's default there)",
    ),
]

#: The path option that lets a file path be relative to the .blend ("//"), where Blender has it.
_BLEND_RELATIVE = (
    {"PATH_SUPPORTS_BLEND_RELATIVE"}
    if "is_path_supports_blend_relative" in bpy.types.Property.bl_rna.properties
    else set()
)

IDENTITY = (1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0)


def _empty_only(_self, obj):
    return obj.type == "EMPTY"


class BSARAP_HandleGroup(bpy.types.PropertyGroup):
    """One handle group: a vertex group of the mesh, posed by its control Empty."""

    # `name` (the vertex group's name) is PropertyGroup's own.
    control: PointerProperty(name="Control", type=bpy.types.Object, poll=_empty_only)
    # The control's matrix relative to the mesh object when controls were added (row-major):
    # the pose is the control's motion from there.
    rest_matrix: FloatVectorProperty(size=16, default=IDENTITY, options={"HIDDEN"})
    # The vertex group's index when last seen (-1: never): a rename is followed by it
    # (``edits.follow_renamed_groups``).
    vertex_group: IntProperty(default=-1, options={"HIDDEN"})


class BSARAP_CacheClaim(bpy.types.PropertyGroup):
    """A point cache file that a bake wrote (``Scene.bsarap_caches``): in the scene, which
    Shift+D does not copy, so a copy of the baked object, which has its Point cache path, is
    told apart from the object whose bake the file is."""

    path: StringProperty(name="Path", description="The file's absolute, normalized path", options={"HIDDEN"})
    owner: PointerProperty(name="Owner", type=bpy.types.Object, description="The object baked into it")


class BSARAP_MeshClaim(bpy.types.PropertyGroup):
    """An object that poses its mesh (``Scene.bsarap_meshes``): in the scene, which Shift+D does
    not copy, so a linked duplicate (Alt+D), which shares the mesh, is told apart from the object
    that posed it. A pointer to the object alone: Blender clears a scene's or an object's pointer
    to an object it removes, but not a pointer to an object on a mesh, nor one to a mesh on a
    scene (measured in bpy 5.0.1: the removal skips the ID types that cannot use the removed one,
    whatever an add-on stores on them), and such a pointer would read freed memory."""

    owner: PointerProperty(name="Owner", type=bpy.types.Object, description="The object that poses its mesh")


class BSARAP_ObjectSettings(bpy.types.PropertyGroup):
    groups: CollectionProperty(type=BSARAP_HandleGroup)
    active_group: IntProperty(default=0)
    # The checksum of the basis (``handles.rest_fingerprint``) the groups' rest matrices are
    # recorded against: an undo step brings back both (see ``edits.follow_applied_transform``).
    rest_basis: StringProperty(default="", options={"HIDDEN"})
    # How many vertex groups the object had when the handle groups' indices were noted.
    vertex_groups: IntProperty(default=-1, options={"HIDDEN"})
    live: BoolProperty(
        name="Live",
        description="Solve whenever a control moves or the frame changes",
        default=True,
    )
    method: EnumProperty(name="Method", items=METHOD_ITEMS, default="bsarap-coarse")
    energy: EnumProperty(name="Energy", items=ENERGY_ITEMS, default="spokes-and-rims")
    bending_length: FloatProperty(
        name="Bending length",
        description="Smooth rotations: the length over which the rotations are smoothed, a fraction "
        "of the rest bounding-box diagonal (longer resists bending more)",
        default=DEFAULT_BENDING_LENGTH, min=1e-4, max=MAX_BENDING_LENGTH,
        soft_min=0.005, soft_max=0.1, step=0.1, precision=3,
    )
    tol: FloatProperty(
        name="Tolerance",
        description="Relative energy decrease at which a solve stops (0: run Max iterations)",
        default=1e-4, min=0.0, precision=6,
    )
    max_iters: IntProperty(name="Max iterations", default=100, min=1, max=100000)
    anderson: IntProperty(name="Anderson window", description="0: off", default=0, min=0, max=64)
    smoothing: FloatProperty(
        name="Smoothing", description="Faired base's smoothing length, fraction of the diagonal",
        default=0.01, min=0.0, precision=4,
    )
    coarse_vertices: IntProperty(
        name="Coarse vertices", description="Vertices of the coarse base (0: min(3000, 30 % of the mesh))",
        default=0, min=0,
    )
    fine_iterations: IntProperty(
        name="Fine iterations", description="ARAP iterations on the full mesh after each coarse solve",
        default=0, min=0,
    )
    settle_iterations: IntProperty(
        name="Settle iterations",
        description="Once the controls stop: ARAP iterations on the full mesh per settle step, "
        "until the pose is the full mesh's (0: off; the editor's default is 5)",
        default=5, min=0, max=1000,
    )
    membrane: FloatProperty(
        name="Membrane", description="The coarse level's membrane share",
        default=DEFAULT_MEMBRANE, min=0.0, max=1.0,
    )
    coarse_energy: EnumProperty(
        name="Coarse energy", items=COARSE_ENERGY_ITEMS, default="decimated",
        description="What the coarse level minimizes (Galerkin: with smooth rotations only)",
    )
    pc2_path: StringProperty(
        name="Point cache", description="Where Bake to point cache writes (empty: next to the .blend)",
        subtype="FILE_PATH", default="",
        # "//" (relative to the .blend): a Blender that knows the option warns without it
        options=_BLEND_RELATIVE,
    )

    def solver_settings(self) -> dict:
        """The keyword arguments of ``bsarap.Deformer`` (besides V, F, handles)."""
        return {
            "method": self.method,
            "energy": self.energy,
            "bending_length": float(self.bending_length),
            "tol": float(self.tol),
            "max_iters": int(self.max_iters),
            "anderson": int(self.anderson),
            "smoothing": float(self.smoothing),
            "coarse_vertices": int(self.coarse_vertices) or None,
            "fine_iterations": int(self.fine_iterations),
            "settle_iterations": int(self.settle_iterations),
            "membrane": float(self.membrane),
            # the Galerkin energy restricts smooth rotations only
            "coarse_energy": self.coarse_energy if self.energy == "smooth-rotations" else "decimated",
        }


classes = (BSARAP_HandleGroup, BSARAP_CacheClaim, BSARAP_MeshClaim, BSARAP_ObjectSettings)


def register():
    for c in classes:
        bpy.utils.register_class(c)
    bpy.types.Object.bsarap = PointerProperty(type=BSARAP_ObjectSettings)
    # The claims, saved in the file (see claims.py): a control Empty's the mesh object it poses,
    # and, in each of its scenes, an object's that poses its mesh (a linked duplicate shares it).
    bpy.types.Object.bsarap_owner = PointerProperty(
        name="BS-ARAP owner", type=bpy.types.Object, description="The mesh object this control poses"
    )
    bpy.types.Scene.bsarap_meshes = CollectionProperty(type=BSARAP_MeshClaim)
    # The point cache files the bakes wrote, each with its object (see operators.pc2_target).
    bpy.types.Scene.bsarap_caches = CollectionProperty(type=BSARAP_CacheClaim)


def unregister():
    del bpy.types.Scene.bsarap_caches
    del bpy.types.Scene.bsarap_meshes
    del bpy.types.Object.bsarap_owner
    del bpy.types.Object.bsarap
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
