"""Edits of a posed object that keep its pose: a handle group's vertex group renamed (the
handle group follows it by its index) and the object's transform put into its mesh (Apply
Transform, Set Origin: the controls' rest matrices follow). :func:`.solve.state` calls them
before and after a build."""

from __future__ import annotations

import numpy as np


def note_vertex_groups(obj) -> None:
    """Note each handle group's vertex group index and the number of vertex groups, for
    :func:`follow_renamed_groups` (written only when they changed: a write is an update)."""
    s = obj.bsarap
    for g in s.groups:
        vg = obj.vertex_groups.get(g.name)
        if vg is not None and g.vertex_group != vg.index:
            g.vertex_group = vg.index
    if s.vertex_groups != len(obj.vertex_groups):
        s.vertex_groups = len(obj.vertex_groups)


def follow_renamed_groups(obj) -> list:
    """A vertex group renamed in Blender (nothing tells of it) leaves its handle group naming a
    group that is gone. Where there are as many vertex groups as when they were last noted
    (:func:`note_vertex_groups`; a deletion shifts the indices) and the one at the handle group's
    noted index is named by no handle group, it is that vertex group renamed: the handle group
    takes its name. Returns the ``(old, new)`` names followed."""
    s = obj.bsarap
    vgs = obj.vertex_groups
    if s.vertex_groups != len(vgs):
        return []
    names = {g.name for g in s.groups}
    out = []
    for g in s.groups:
        if vgs.get(g.name) is not None or not 0 <= g.vertex_group < len(vgs):
            continue
        new = vgs[g.vertex_group].name
        if new in names:
            continue
        out.append((g.name, new))
        names.add(new)
        g.name = new
    return out


def follow_applied_transform(obj, old, new) -> bool:
    """Apply Transform (Ctrl+A) and Set Origin move the mesh's vertices by an affine map ``A``
    (``p' = A p``) and the object the other way (``O' = O A^-1``): nothing moves in the world,
    but the object's space, in which the controls' rest matrices are recorded, changed under
    them, and the pose would jump (targets at ``A D A p`` for a scale). Where the object's matrix
    since the last update (``old.matrix``) and the new basis agree on one such ``A =
    O'^-1 O``, every vertex of the old basis mapped by it onto the new one within float32
    rounding, the rest matrices are mapped too (``R' = A R``) and the pose stays. An edit of the
    basis alone, the object where it was, keeps them (``A = I``); so do rests recorded against
    another basis than ``old``'s (an undo step brought back its own: ``rest_basis``). Returns
    whether they were mapped. With Live off the object's matrix is known from the last Pose
    Now: moved since and then applied, the rests stay as they were."""
    s = obj.bsarap
    stale = s.rest_basis != str(old.key.rest)
    if old.matrix is None or old.key.topology != new.key.topology or stale:
        return False
    try:
        A = np.linalg.inv(new.matrix) @ old.matrix
    except np.linalg.LinAlgError:
        return False
    if not np.isfinite(A).all() or np.allclose(A, np.eye(4), rtol=0.0, atol=1e-9):
        return False
    mapped = old.rest @ A[:3, :3].T + A[:3, 3]
    scale = max(float(np.abs(new.rest).max(initial=0.0)), float(np.abs(mapped).max(initial=0.0)), 1e-12)
    if float(np.abs(mapped - new.rest).max(initial=0.0)) > 1e-5 * scale:
        return False
    for g in s.groups:
        R = np.array(g.rest_matrix, dtype=np.float64).reshape(4, 4)
        g.rest_matrix = [float(x) for x in (A @ R).ravel()]
    return True
