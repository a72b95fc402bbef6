"""Which object poses a control Empty, and which poses a mesh: the claims.

Each control Empty poses one object: the first to use it claims it (``solve.check_controls``). A
copy of a posed object (Shift+D, ``Object.copy``) points to the same Empties; it is refused with
a message until *Add Controls* gives it its own, so one Empty never drives two meshes. The first
object posed claims its mesh too: a linked duplicate (Alt+D, or Link Object Data) shares the
mesh, so its pose key, and is refused (:func:`mesh_sharer`) until it is made single-user. The
claims are saved in the file (``Object.bsarap_owner`` on the control; the mesh's as its owner in
each of the owner's scenes, ``Scene.bsarap_meshes``, since Blender leaves a mesh's pointer to a
removed object, and a scene's to a removed mesh, dangling), so a reload, an undo or the
extension enabled again keep them; Blender remaps a control's when a mesh and its controls are
duplicated together (measured in bpy 5.0.1), so the copy owns the copies. An owner in no scene
(deleted), or no longer using the control or the mesh, is no owner (:func:`tend_claims` drops
the claims of the deleted). A file saved before the claims were stored gets them on load
(:func:`claim_unclaimed`), where one object alone uses the control or the mesh; one saved with a
mesh's claim on the mesh has it moved into the scene (:func:`adopt_mesh_pointers`).
"""

from __future__ import annotations

import bpy
import numpy as np


def object_uids(collection) -> np.ndarray:
    """The session uids of the objects of ``collection`` (read in C with ``foreach_get``, no
    Python object per object): a 32-bit RNA int, read into as many."""
    a = np.empty(len(collection), dtype=np.int32)
    collection.foreach_get("session_uid", a)
    return a


def tend_claims() -> None:
    """Clear the claims held by objects in no scene (deleted), of controls, meshes and point
    cache files: a claim is a pointer, which would keep a deleted object, and its mesh, in the
    file. Undo brings them back with it. A mesh's claim is then put in each scene its owner is
    in (:func:`claim_mesh`), so deleting one of them keeps it; and a mesh appended from a file
    that kept its claim on the mesh has it moved (:func:`adopt_mesh_pointers`). Which objects
    are in which scene is read once (``users_scene`` walks every scene's objects per call)."""
    members = {sc.session_uid: set(object_uids(sc.objects).tolist()) for sc in bpy.data.scenes}
    alive = set().union(*members.values())

    def live(o) -> bool:
        return o is not None and o.session_uid in alive

    for c in bpy.data.objects:
        if c.library is None and c.bsarap_owner is not None and not live(c.bsarap_owner):
            c.bsarap_owner = None
    local = [sc for sc in bpy.data.scenes if sc.library is None]
    owners, claimed = {}, {}
    for sc in local:
        claims = sc.bsarap_meshes
        for k in reversed(range(len(claims))):
            o = claims[k].owner
            if live(o):
                owners[o.session_uid] = o
            else:
                claims.remove(k)
        claimed[sc.session_uid] = {m.owner.session_uid for m in claims}
        for k in reversed(range(len(sc.bsarap_caches))):  # the point cache files' (operators.claim_cache)
            o = sc.bsarap_caches[k].owner
            if o is not None and not live(o):
                sc.bsarap_caches.remove(k)
    for u, o in owners.items():
        for sc in local:
            if u in members[sc.session_uid] and u not in claimed[sc.session_uid]:
                sc.bsarap_meshes.add().owner = o
    adopt_mesh_pointers()


def linked(control) -> bool:
    """Whether a control Empty is in a scene: one deleted in the viewport stays in
    ``bpy.data`` while the handle group's pointer holds it, but in no scene."""
    return control is not None and len(control.users_scene) > 0


def owner(control):
    """The object that claimed ``control`` (its saved ``bsarap_owner``), or ``None``: also when
    that object is in no scene (deleted) or none of its handle groups uses the control."""
    o = control.bsarap_owner
    if o is None or not linked(o) or not any(g.control == control for g in o.bsarap.groups):
        return None
    return o


def mesh_owner(mesh):
    """The object that claimed ``mesh`` (in a scene's ``bsarap_meshes``), or ``None``: also when
    that object is in no scene or has another mesh since. A claim is of the owner's mesh, the
    one it writes its pose key to; were two claimants given one mesh (a script's
    ``Object.data`` swap), the first claim in the scenes' order keeps it."""
    for sc in bpy.data.scenes:
        for m in sc.bsarap_meshes:
            o = m.owner
            if o is not None and o.data == mesh and linked(o):
                return o
    return None


def claim_mesh(obj) -> None:
    """Record that ``obj`` poses its mesh, in each scene of ``obj`` that is not library data and
    has no claim of it yet (none if there is no such scene: then nothing is claimed)."""
    for sc in obj.users_scene:
        if sc.library is None and not any(m.owner == obj for m in sc.bsarap_meshes):
            sc.bsarap_meshes.add().owner = obj


def mesh_sharer(obj):
    """The other object that claimed the mesh ``obj`` shares with it (a linked duplicate,
    Alt+D: one pose key for both), or ``None``. The first object posed claims it."""
    o = mesh_owner(obj.data)
    return None if o is None or o == obj else o


def shared_mesh_message(obj, other) -> str:
    """What is said of ``obj``, whose mesh ``other`` poses (:func:`mesh_sharer`). Which way the
    mesh came to be shared is not recorded; where ``obj`` claimed a mesh too, both were posed
    before they were given one mesh (Link Object Data, a script's ``Object.data``), and a
    linked duplicate would not be the cause."""
    if any(m.owner == obj for sc in bpy.data.scenes for m in sc.bsarap_meshes):
        how = "both were posed, then given one mesh: Link Object Data or a script"
    else:
        how = "a linked duplicate, Alt+D, or Link Object Data"
    return (
        f"{obj.name}: shares its mesh with '{other.name}', which poses it ({how}): both would "
        "write the same pose key; for a pose of its own make the mesh single-user (Object > "
        "Relations > Make Single User > Object & Data), then Add Controls"
    )


def release_mesh(obj) -> None:
    """Let go of the claims of ``obj`` on meshes (Remove Controls)."""
    for sc in bpy.data.scenes:
        if sc.library is None:
            for k in reversed(range(len(sc.bsarap_meshes))):
                if sc.bsarap_meshes[k].owner == obj:
                    sc.bsarap_meshes.remove(k)


def foreign_groups(obj) -> list:
    """``[(group name, owner)]``: the handle groups of ``obj`` whose control another object
    claimed (``obj`` is a copy of it: Shift+D and ``Object.copy`` copy the pointers to the
    controls; duplicated with its controls, it points to the copies)."""
    out = []
    for g in obj.bsarap.groups:
        if linked(g.control) and g.control.bsarap_owner != obj:
            o = owner(g.control)
            if o is not None:
                out.append((g.name, o))
    return out


def foreign_message(obj, foreign) -> str:
    """What the panel says of an object whose controls ``foreign`` pose another one."""
    names = ", ".join(f"'{n}'" for n, _ in foreign)
    other = foreign[0][1]
    who = f"'{other.name}'"
    return (
        f"{obj.name}: the controls of {names} pose {who}, not this object (a copy, Shift+D, "
        f"shares its original's controls); Add Controls gives {obj.name} its own"
    )


def claim_free_controls(obj) -> None:
    """Claim the controls of ``obj`` that no object claimed yet, and its mesh when no other
    object (in a scene, with that mesh) claimed it."""
    controls = [g.control for g in obj.bsarap.groups if linked(g.control)]
    me = obj.data
    if controls and mesh_owner(me) is None and me.library is None:
        claim_mesh(obj)
    for c in controls:
        if c.bsarap_owner != obj and owner(c) is None and c.library is None:
            c.bsarap_owner = obj


def refused(obj) -> bool:
    """Whether another object claimed the mesh or some controls of ``obj`` (reads only)."""
    return mesh_sharer(obj) is not None or bool(foreign_groups(obj))


def claim_unclaimed() -> None:
    """Claims for a file saved before they were stored in it: each control that the handle
    groups of one mesh object alone (in the scenes) use, and each mesh that one object with
    controls alone uses, is claimed by that object, so a copy made after loading is refused. A
    control or mesh that two objects use (a file saved with a copy) is left to the first posed.
    Mesh claims saved as pointers on the meshes are adopted first (:func:`adopt_mesh_pointers`)."""
    adopt_mesh_pointers()
    users, mesh_users = {}, {}
    objects = {o.session_uid: o for sc in bpy.data.scenes for o in sc.objects if o.type == "MESH"}
    for o in objects.values():
        controls = {c.session_uid: c for c in (g.control for g in o.bsarap.groups) if linked(c)}
        if not controls:
            continue
        for c in controls.values():
            users.setdefault(c.session_uid, (c, []))[1].append(o)
        mesh_users.setdefault(o.data.session_uid, (o.data, []))[1].append(o)
    for c, used_by in users.values():
        if len(used_by) == 1 and c.library is None and owner(c) is None:
            c.bsarap_owner = used_by[0]
    for me, used_by in mesh_users.values():
        if len(used_by) == 1 and me.library is None and mesh_owner(me) is None:
            claim_mesh(used_by[0])


def adopt_mesh_pointers() -> None:
    """Move the mesh claims of a file saved when they were a pointer on the mesh
    (``Mesh.bsarap_owner``, before ``Scene.bsarap_meshes``) into the scene, and delete the
    pointer: Blender leaves it dangling when its object is removed by a script, and frees
    through it when the mesh goes. Run when a file is loaded (or the extension enabled in it),
    while the pointer is as read from the file, and when the scenes' objects changed (an
    append: :func:`tend_claims`)."""
    for me in bpy.data.meshes:
        if me.library is None:
            for o in _pop_mesh_pointers(me):
                if isinstance(o, bpy.types.Object) and linked(o) and o.data == me and mesh_owner(me) is None:
                    claim_mesh(o)


def _pop_mesh_pointers(me) -> list:
    """The values of ``me``'s legacy ``bsarap_owner``, deleted: Blender 5 keeps an add-on's
    properties apart from the user's (``bl_system_properties_get``), and a file saved by 4.x
    opened in 5 has the pointer in both."""
    stores = [me]
    if hasattr(me, "bl_system_properties_get"):
        stores.append(me.bl_system_properties_get())
    found = []
    for props in stores:
        if props is not None and "bsarap_owner" in props:
            found.append(props["bsarap_owner"])
            del props["bsarap_owner"]
    return found
