"""The per-object solver state: one warm-started ``bsarap.Deformer`` per posed object.

The pose of handle group ``k`` is the motion of its control Empty ``E_k`` since controls were
added, in the mesh object's space ``O``: ``D_k = (O^-1 E_k) (O^-1 E_k)_rest^-1``. The targets
are the group's rest vertices moved by it, ``t_i = D_k p_i``; ``Deformer.solve_targets`` gives
the pose, which goes into the shape key ``POSE_KEY`` (value 1) so the base mesh is never
overwritten. The state is kept under the object's ``session_uid`` (:func:`uid`) and built for
a key (:class:`StateKey`): its topology (counts and a checksum of the faces' connectivity), a
checksum of its rest coordinates, its handle groups, the settings and the modifiers that block
posing; a change of any of them rebuilds the solver (with a message) instead of failing, while
a rename keeps it: the object's, or a handle group's vertex group's, which the handle group
follows (:func:`.edits.follow_renamed_groups`). Apply Transform and Set Origin change the basis
and the object's matrix together: the controls' rest matrices follow
(:func:`.edits.follow_applied_transform`), so the pose stays. A build that failed is not tried
again until its key changes (or *Add Controls*): the depsgraph updates that follow get its
message at once. What is kept for an object no longer in any scene is dropped (:func:`prune`).

Each control Empty poses one object, and so does each mesh: the first object posed claims them,
and another that uses them is refused with a message (:func:`check_controls`; the claims
themselves are in :mod:`.claims`).

A mesh that is library data, linked or a library override, cannot take the pose key (Blender
keeps no shape key written to either): it is refused before anything is claimed or built
(:func:`mesh_refusal`).

The panel's message (:func:`message`) says what is wrong now: an error of the live update goes
once the object poses again (:func:`report_error`), and a refusal of another object's controls
or mesh is not shown once it no longer holds, even where no update runs (Live off, no control).

Objects in Edit Mode are left alone (their mesh data is stale until Edit Mode ends); on leaving
it the pose is solved again (:func:`editing`), since Blender writes the edit mesh's copy of the
shape keys back over it.

Once the controls have rested ``REST_DELAY`` seconds, :func:`finish_step` takes the pose the
rest of the way, as the editor does after a drag: the same targets solved again until a solve
converges, then settle steps (``bsarap-coarse`` with settle iterations); not while a bake runs.

The solver gets the mesh cleaned as the editor and the command line load one
(``bsarap.clean``): vertices at the same place welded, so that a mesh split at its UV seams or
sharp edges (Blender's glTF import, whose *Merge Vertices* is off by default) poses as one
surface instead of tearing open along them; degenerate and repeated triangles dropped. The
pose is written back on the mesh's own vertices (:meth:`SolverState.on_mesh`).
"""

from __future__ import annotations

import time
from typing import NamedTuple

import numpy as np

from . import claims, edits, handles, modifiers
from .handles import HandleError

#: The shape key the live pose goes into.
POSE_KEY = "BS-ARAP pose"
#: Custom properties of the mesh's shape keys (its ``Key``): the pose key was muted by a bake
#: (not by the user), and the Basis was made for the pose key (*Remove Controls* drops it).
BAKE_MUTED = "bsarap_bake_muted"
MADE_BASIS = "bsarap_made_basis"
#: Seconds the controls rest before :func:`finish_step` goes on (the editor's settle delay).
REST_DELAY = 0.15


class SolverState:
    """A built solver for one object and what it was built from: ``rest`` and ``labels`` on
    the mesh's vertices; ``cleaned``, the solver's positions and labels on the cleaned mesh;
    ``vertex_map`` taking a mesh vertex to its cleaned vertex (-1: in no triangle, at rest)."""

    def __init__(self, key, deformer, rest, labels, group_names, cleaned, vertex_map):
        self.key = key
        self.deformer = deformer
        self.rest = rest
        self.labels = labels
        self.group_names = group_names
        self.cleaned_rest, welded = cleaned
        self.vertex_map = vertex_map
        # nothing welded or dropped: the solver's pose is the mesh's as it is
        self.identity = len(vertex_map) == len(self.cleaned_rest) and bool(
            np.array_equal(vertex_map, np.arange(len(vertex_map)))
        )
        self.handle_vertices = np.asarray(deformer.handle_vertices)
        self.handle_labels = welded[self.handle_vertices]
        self.last_deltas = None  # the control motions of the last solve (re-entrancy guard)
        self.last_ms = None  # the last update's time in the handler: solve + shape key write
        self.solves = 0
        self.last_solve_ms = None  # of which in Deformer.solve_targets
        self.moved_at = None  # time.monotonic() of the last solve after a control moved
        self.converged = False  # the last solve met the tolerance
        self.finish_steps = 0  # finish_step's solves and settle steps since the last move
        # why finish_step has nothing left at the last motion: "rest", or short of it "cap"
        # (MAX_SETTLE_STEPS) or "error"; None while it has
        self.ended = None
        self.baking = False  # a bake solves the frames: no live solve, finish_step waits
        # the rest bounding-box diagonal: the unit of the fractions (bending length, smoothing)
        self.diagonal = diagonal(self.cleaned_rest)
        # the object's matrix at the build and at each update since
        # (edits.follow_applied_transform)
        self.matrix = None

    def on_mesh(self, U: np.ndarray) -> np.ndarray:
        """The solver's pose ``U`` (cleaned vertices) on the mesh's vertices: welded ones
        together, one in no triangle at rest."""
        if self.identity:
            return U
        kept = self.vertex_map >= 0
        out = np.array(self.rest, dtype=np.float64, copy=True)
        out[kept] = np.asarray(U)[self.vertex_map[kept]]
        return out


def cleaned_labels(labels: np.ndarray, vertex_map: np.ndarray, n: int) -> np.ndarray:
    """The handle group of each of the ``n`` cleaned vertices: the largest of the mesh
    vertices welded into it (-1, free, when none is in a group)."""
    out = np.full(n, -1, dtype=np.int64)
    kept = vertex_map >= 0
    np.maximum.at(out, vertex_map[kept], np.asarray(labels, dtype=np.int64)[kept])
    return out


def diagonal(rest: np.ndarray) -> float:
    """The bounding-box diagonal of positions ``(n, 3)``."""
    return float(np.linalg.norm(np.ptp(rest, axis=0))) if len(rest) else 0.0


# Each object's entries are kept under its session uid (:func:`uid`).
#: session uid -> SolverState
_states: dict = {}
#: session uid -> the last message about the object (the panel shows it; the live handler's
#: errors).
messages: dict = {}
#: session uid -> ((topology, rest fingerprint), rest diagonal) for the panel, where no built
#: solver has that rest mesh.
_diagonals: dict = {}
#: session uid -> (state key, HandleError) of the last failed build: not retried for that key.
_failures: dict = {}
#: session uid -> the message of the last refusal of another object's controls (it goes once
#: the controls are the object's own again).
_refused: dict = {}
#: session uid -> the last error the live update or a finishing step reported
#: (:func:`report_error`): it goes once the object poses again.
_errors: dict = {}
#: session uid -> the mode of a mesh with handle groups at the handler's last update
#: (:func:`editing`).
_modes: dict = {}
#: session uid -> how often the handle groups' weights were found changed on leaving a mode that
#: edits them (:func:`weights_edited`); in the key, so a change rebuilds.
_weights: dict = {}
#: The entries kept per object.
_PER_OBJECT = (_states, messages, _diagonals, _failures, _refused, _errors, _modes, _weights)


def uid(obj) -> int:
    """The key of ``obj``'s entries: ``ID.session_uid``, which stays with the object through
    renames and undo steps and is never reused within a session. It is not saved in the .blend
    (the entries are this session's caches; a loaded file starts them again)."""
    return obj.session_uid


def built(obj):
    """The object's built :class:`SolverState`, or ``None`` (never builds)."""
    return _states.get(uid(obj))


def message(obj):
    """The last message about ``obj`` (the panel shows it), or ``None``: also when it is a
    refusal of another object's controls or mesh that no longer holds (the original deleted,
    or its controls removed, while no update ran). Reads only (the panel calls it)."""
    k = uid(obj)
    msg = messages.get(k)
    if msg is not None and msg == _refused.get(k) and not claims.refused(obj):
        return None
    return msg


def report_error(obj, msg: str) -> None:
    """Keep ``msg``, an error of the live update or of a finishing step, as the message of
    ``obj``: it goes once ``obj`` poses again (:func:`clear_error`)."""
    k = uid(obj)
    messages[k] = _errors[k] = msg


def clear_error(obj) -> bool:
    """Drop the error :func:`report_error` kept for ``obj`` (it poses again), unless another
    message replaced it; returns whether there was one."""
    k = uid(obj)
    msg = _errors.pop(k, None)
    if msg is not None:
        _drop_message(k, msg)
    return msg is not None


def _drop_message(k, *kept) -> None:
    """Drop the message of the object under ``k`` if it is still one of ``kept`` (a message
    whose cause is gone), not one that replaced it since."""
    if k in messages and messages[k] in kept:
        del messages[k]


def rest_diagonal(obj) -> float:
    """The rest bounding-box diagonal of ``obj``'s mesh in object space (the solver's unit of
    length): the built solver's while its rest mesh is the mesh's, else measured once per rest
    mesh (the panel draws it often; the checksums cost about 2 ms per 100k vertices)."""
    k = uid(obj)
    st = _states.get(k)
    fp = (handles.topology_fingerprint(obj.data), handles.rest_fingerprint(obj.data))
    if st is not None and (st.key.topology, st.key.rest) == fp:
        return st.diagonal
    cached = _diagonals.get(k)
    if cached is None or cached[0] != fp:
        cached = (fp, diagonal(handles.rest_positions(obj.data)))
        _diagonals[k] = cached
    return cached[1]


def import_bsarap():
    try:
        import bsarap
    except ImportError as e:  # the wheel missing or built for another platform
        raise HandleError(f"the bsarap module cannot be imported ({e}); reinstall the extension") from None
    return bsarap


def check_object(obj) -> None:
    """Raise :class:`HandleError` for an object BS-ARAP cannot pose (see :mod:`.modifiers` for
    the modifiers that block it)."""
    if obj is None or obj.type != "MESH":
        raise HandleError("select a mesh object")
    check_mesh_writable(obj)
    why = modifiers.refusal(obj)
    if why:
        raise HandleError(why)
    if len(obj.data.polygons) == 0:
        raise HandleError(f"{obj.name}: the mesh has no faces")


def mesh_refusal(obj):
    """Why the pose key of ``obj`` cannot be written, or ``None``: its mesh is linked from a
    library (also under a library override of the object, whose mesh is not overridden), or is
    a library override itself. Blender keeps no shape key written to either (measured in bpy
    5.0.1: the override's pose key stays at rest); made local, the mesh takes it."""
    me = obj.data
    local = "make the mesh local (Object > Relations > Make Local > Selected Objects and Data)"
    if me.library is not None:
        if obj.override_library is not None:
            return (
                f"{obj.name}: a library override whose mesh is not overridden: the mesh is still "
                f"linked from {me.library.name}, where the pose key cannot be written (it would be "
                f"lost on save); {local}"
            )
        return (
            f"{obj.name}: the mesh is linked from a library ({me.library.name}) and its shape "
            "keys cannot be written; make it local first (Object > Relations > Make Local)"
        )
    if me.override_library is not None:
        ref = me.override_library.reference
        lib = ref.library.name if ref is not None and ref.library is not None else "a library"
        return (
            f"{obj.name}: the mesh is a library override (from {lib}), whose shape keys Blender "
            f"does not keep: the pose would not show, nor be saved; {local}"
        )
    return None


def check_mesh_writable(obj) -> None:
    """Raise :class:`HandleError` when the pose key of ``obj`` cannot be written
    (:func:`mesh_refusal`)."""
    why = mesh_refusal(obj)
    if why:
        raise HandleError(why)


def non_manifold_edges(tri: np.ndarray) -> int:
    """The number of edges shared by more than two triangles."""
    e = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    e.sort(axis=1)
    _, counts = np.unique(e, axis=0, return_counts=True)
    return int((counts > 2).sum())


class StateKey(NamedTuple):
    """What a solver is built from: a change of any field rebuilds it. Not the object's name
    (the entries are under its session uid: a rename keeps the solver), nor the modifiers that
    keep the vertices in place (they act after the pose)."""

    #: the element counts and the connectivity's checksum (``handles.topology_fingerprint``)
    topology: tuple
    #: the basis edited (its vertices moved): the rest shape changed
    rest: int
    groups: tuple
    #: a handle group's vertex group deleted: rebuild (and say so); a rename is followed first
    #: (:func:`.edits.follow_renamed_groups`)
    groups_exist: tuple
    settings: tuple
    #: the modifiers that block posing (added after the controls: refused until they go)
    blocking: tuple
    #: the handle groups' vertex weights found changed (:func:`weights_edited`)
    weights: int


def state_key(obj) -> StateKey:
    s = obj.bsarap
    return StateKey(
        topology=handles.topology_fingerprint(obj.data),
        rest=handles.rest_fingerprint(obj.data),
        groups=tuple(g.name for g in s.groups),
        groups_exist=tuple(obj.vertex_groups.get(g.name) is not None for g in s.groups),
        settings=tuple(sorted(s.solver_settings().items())),
        blocking=tuple(tuple(labels) for labels in modifiers.blocking(obj)),
        weights=_weights.get(uid(obj), 0),
    )


def build(obj) -> SolverState:
    """Build the solver of ``obj`` from its mesh, vertex groups and settings."""
    bsarap = import_bsarap()
    check_object(obj)
    names = [g.name for g in obj.bsarap.groups]
    labels = handles.labels(obj, names)
    rest = handles.rest_positions(obj.data)
    try:
        V, tri, report = bsarap.clean(rest, handles.triangles(obj.data))
    except bsarap.BsarapError as e:
        raise HandleError(f"{obj.name}: {e}") from None
    vertex_map = np.asarray(report["vertex_map"], dtype=np.int64)
    bad = non_manifold_edges(tri)
    if bad:
        raise HandleError(f"{obj.name}: the mesh is not manifold ({bad} edges with more than two faces)")
    try:
        welded = cleaned_labels(labels, vertex_map, len(V))
        d = bsarap.Deformer(V, tri, welded, **obj.bsarap.solver_settings())
    except bsarap.BsarapError as e:
        raise HandleError(f"{obj.name}: {e}") from None
    return SolverState(state_key(obj), d, rest, labels, names, (V, welded), vertex_map)


def state(obj, *, rebuild=True) -> SolverState:
    """The object's solver, built or rebuilt when its key changed (a message says why). Back at
    the built solver's key after a failed build (a blocking modifier removed again), the
    failure's message goes."""
    k = uid(obj)
    renamed = edits.follow_renamed_groups(obj)
    key = state_key(obj)
    st = _states.get(k)
    if renamed and st is not None:
        # the solver's groups are the same vertex groups under new names: kept
        names = dict(renamed)
        same = st.key._replace(
            groups=tuple(names.get(n, n) for n in st.key.groups), groups_exist=key.groups_exist
        )
        if same == key:
            st.key, st.group_names = key, list(key.groups)
            _drop_failure(k, obj)
        said = ", ".join(f"'{a}' to '{b}'" for a, b in renamed)
        messages[k] = f"{obj.name}: vertex group renamed ({said}): its handle group follows"
    if st is not None and st.key == key:
        _drop_failure(k, obj)
        edits.note_vertex_groups(obj)
        return st
    if not rebuild:
        raise HandleError(f"{obj.name}: the solver is not built")
    failed = _failures.get(k)
    if failed is not None and failed[0] == key:
        # the same input failed already: say so without building again (by its current name)
        raise _renamed(failed, obj.name)
    try:
        new = build(obj)
    except HandleError as e:
        _failures[k] = (key, e, obj.name)
        # a deleted vertex group fails the build: noted now, a group added later at its
        # index is not taken for it renamed (edits.follow_renamed_groups)
        edits.note_vertex_groups(obj)
        raise
    _failures.pop(k, None)
    edits.note_vertex_groups(obj)
    new.matrix = np.array(obj.matrix_world, dtype=np.float64)
    # a setting changed while a bake solves the frames with the old solver: the new one waits
    # for the bake too (its end clears the object's current state, bake.Baker.restore_frame)
    new.baking = st is not None and st.baking
    followed = st is not None and edits.follow_applied_transform(obj, st, new)
    if obj.bsarap.rest_basis != str(key.rest):
        obj.bsarap.rest_basis = str(key.rest)
    if st is not None:
        if st.key.topology != key.topology:
            change = _topology_change(st.key, key)
            messages[k] = f"{obj.name}: the topology changed ({change}); solver rebuilt"
        elif followed:
            messages[k] = (
                f"{obj.name}: the object's transform went into its mesh (Apply or Set Origin); "
                "the controls' rests followed, the pose is kept"
            )
        elif st.key.rest != key.rest:
            messages[k] = f"{obj.name}: the rest mesh (basis) changed; solver rebuilt"
        elif st.key.weights != key.weights:
            messages[k] = f"{obj.name}: the handle groups' vertex weights changed; solver rebuilt"
        else:
            messages[k] = f"{obj.name}: settings or groups changed; solver rebuilt"
    _states[k] = new
    return new


def _drop_failure(k, obj) -> None:
    """Back at the built solver's key: a failed build's message goes."""
    failed = _failures.pop(k, None)
    if failed is not None:
        _drop_message(k, str(failed[1]), str(_renamed(failed, obj.name)))


def _topology_change(old: StateKey, new: StateKey) -> str:
    """How the topology changed between two keys, for the rebuild's message: the vertex counts,
    or, where the counts stayed, that the faces were reconnected (Rotate Edge, faces sorted)."""
    if old.topology[:4] != new.topology[:4]:
        return f"{old.topology[0]} -> {new.topology[0]} vertices"
    return f"faces reconnected, {new.topology[0]} vertices"


def _renamed(failed, name) -> HandleError:
    """The stored error of a failed build (``(key, error, name then)``), said of the object's
    current ``name`` (it may have been renamed since)."""
    e, old = failed[1], failed[2]
    msg = str(e)
    if old == name or not msg.startswith(f"{old}:"):
        return e
    return HandleError(name + msg[len(old) :])


def baking(obj) -> bool:
    """Whether a bake is solving ``obj``'s frames (its solver is not built for the question)."""
    st = _states.get(uid(obj))
    return st is not None and st.baking


def bake_ended(k) -> None:
    """The bake of the object under session uid ``k`` ended: its solver, also one rebuilt while
    the bake ran (a setting changed, an undo), poses live again."""
    st = _states.get(k)
    if st is not None:
        st.baking = False


def forget(obj=None) -> None:
    """Drop the solver and the messages of one object (or everything)."""
    if obj is None:
        for d in _PER_OBJECT:
            d.clear()
    else:
        k = uid(obj)
        for d in _PER_OBJECT:
            d.pop(k, None)


def tracked() -> bool:
    """Whether anything is kept (else :func:`prune` has nothing to do)."""
    return any(_PER_OBJECT)


def prune(alive) -> None:
    """Drop what is kept for objects not in ``alive`` (the session uids of the objects in the
    scenes: the others were deleted): a deleted object's solver (a dense mesh's factorization)
    is freed at the next update."""
    for d in _PER_OBJECT:
        for k in [k for k in d if k not in alive]:
            del d[k]


def check_controls(obj) -> None:
    """Claim the free controls of ``obj``; raise :class:`HandleError` when another object
    claimed some (one Empty never drives two meshes), or when its mesh is library data (nothing
    is claimed then). Once they are its own again (its original deleted), the refusal's message
    goes."""
    check_mesh_writable(obj)
    k = uid(obj)
    other = claims.mesh_sharer(obj)
    foreign = claims.foreign_groups(obj) if other is None else None
    if other is not None or foreign:
        msg = _refused[k] = claims.shared_mesh_message(obj, other) if other is not None else claims.foreign_message(obj, foreign)
        raise HandleError(msg)
    refused = _refused.pop(k, None)
    if refused is not None:
        _drop_message(k, refused)
    claims.claim_free_controls(obj)


#: The modes that edit vertex weights: the handle groups are read again on leaving one.
WEIGHT_MODES = ("EDIT", "WEIGHT_PAINT")


def editing(obj) -> bool:
    """Whether ``obj`` is in Edit Mode (the live update leaves it alone); the depsgraph handler
    asks it of every mesh with handle groups. The first call after Edit Mode ended forgets the
    last solve's motion, so the next update solves the pose again: leaving Edit Mode wrote the
    edit mesh's copy of the pose key back over it. After Edit Mode or Weight Paint the handle
    groups are read again (:func:`weights_edited`)."""
    k = uid(obj)
    before, mode = _modes.get(k), obj.mode
    _modes[k] = mode
    if mode == "EDIT":
        return True
    st = built(obj)
    if before == "EDIT" and st is not None:
        st.last_deltas = None
    if before in WEIGHT_MODES and mode != before:
        weights_edited(obj)
    return False


def undone(objects) -> None:
    """Blender's undo or redo brought back an undo step's data, the pose keys as they were then:
    maybe a pose short of rest (the finishing steps push no undo step), while each solver still
    holds where its pose ended since, "rest" perhaps, for controls back where they were. Forget
    every solver's last motion, as on leaving Edit Mode (:func:`editing`): the panel claims no
    state of the undone pose, and the next update (the undo's own) solves it again, and the
    finishing steps settle it. The step's vertex weights may be others than the solver's (a
    paint undone in Object Mode): those of ``objects`` with a solver, built or failed, are read
    again (:func:`weights_edited`; a pass over the vertices in Python per posed object)."""
    for st in _states.values():
        st.last_deltas = None
    for obj in objects:
        k = uid(obj)
        if (k in _states or k in _failures) and obj.mode not in WEIGHT_MODES:
            weights_edited(obj)


def weights_edited(obj) -> None:
    """Read the handle groups' vertex weights again (after a mode that edits them): when the
    labels differ from the built solver's, or no longer make handle groups, or the last build
    failed, the key changes, so the next update builds again and a fixed failure's message goes
    (a group with no vertex above the threshold, painted since). Reading the weights costs a
    pass over the vertices in Python; the build only follows a change."""
    k = uid(obj)
    st, failed = _states.get(k), _failures.get(k)
    if failed is not None and failed[0] == state_key(obj):
        changed = True
    elif st is not None:
        try:
            changed = not np.array_equal(handles.labels(obj, st.group_names), st.labels)
        except HandleError:
            changed = True  # the build says why
    else:
        changed = False
    if changed:
        _weights[k] = _weights.get(k, 0) + 1


def scale_warning(obj):
    """A warning when ``obj`` has a non-uniform scale (the pose is solved in object space, so a
    control's world motion is distorted in it), else ``None``."""
    sc = [abs(x) for x in obj.matrix_world.to_scale()]
    if min(sc) > 0 and max(sc) <= min(sc) * (1 + 1e-4):
        return None
    s = ", ".join(f"{x:.3g}" for x in sc)
    return f"{obj.name}: non-uniform scale ({s}) distorts the pose; apply scale first (Ctrl+A, Scale)"


def _object_matrix_inverse(obj) -> np.ndarray:
    M = np.array(obj.matrix_world, dtype=np.float64)
    try:
        inv = np.linalg.inv(M)
    except np.linalg.LinAlgError:
        inv = None
    if inv is None or not np.isfinite(inv).all():
        raise HandleError(
            f"{obj.name}: the object's transform is singular (a scale of 0 on an axis); "
            "give it a non-zero scale to pose it"
        )
    return inv


def control_deltas(obj, *, checked=False) -> np.ndarray:
    """``(G, 4, 4)``: each handle group's motion in the object's space (see the module doc);
    ``checked``: :func:`check_controls` passed already."""
    if not checked:
        check_controls(obj)
    inv = _object_matrix_inverse(obj)
    out = []
    for g in obj.bsarap.groups:
        e = g.control
        if e is None:
            raise HandleError(f"{obj.name}: handle group '{g.name}' has no control; use Add controls")
        if not claims.linked(e):
            raise HandleError(
                f"{obj.name}: the control of handle group '{g.name}' was deleted; Add Controls re-creates it"
            )
        rest = np.array(g.rest_matrix, dtype=np.float64).reshape(4, 4)
        now = inv @ np.array(e.matrix_world, dtype=np.float64)
        out.append(now @ np.linalg.inv(rest))
    return np.array(out)


def targets(st: SolverState, deltas: np.ndarray) -> np.ndarray:
    """The handle vertices' targets ``(H, 3)`` (``Deformer.handle_vertices`` order)."""
    D = deltas[st.handle_labels]
    p = st.cleaned_rest[st.handle_vertices]
    return np.einsum("nij,nj->ni", D[:, :3, :3], p) + D[:, :3, 3]


def solve(obj, st: SolverState, deltas: np.ndarray) -> np.ndarray:
    bsarap = import_bsarap()
    tg = targets(st, deltas)
    t0 = time.perf_counter()
    try:
        U = st.deformer.solve_targets(tg)
    except bsarap.BsarapError as e:
        raise HandleError(f"{obj.name}: {e}") from None
    st.last_solve_ms = (time.perf_counter() - t0) * 1e3
    st.last_deltas = deltas
    st.solves += 1
    st.converged = st.deformer.stats.converged
    return st.on_mesh(U)


def ensure_pose_key(obj):
    """The object's pose shape key (created with a Basis when missing), value 1."""
    if obj.data.shape_keys is None:
        obj.shape_key_add(name="Basis", from_mix=False)
        obj.data.shape_keys[MADE_BASIS] = True
    kb = obj.data.shape_keys.key_blocks.get(POSE_KEY)
    if kb is None:
        kb = obj.shape_key_add(name=POSE_KEY, from_mix=False)
        kb.value = 1.0
    return kb


def baked_output(obj):
    """What a bake left driving the mesh in place of the live pose, which it muted: its frame
    shape keys or its Mesh Cache modifier, named for a message; ``None`` when neither is left."""
    from . import bake  # it imports this module

    keys = obj.data.shape_keys
    if keys is not None and any(kb.name.startswith(bake.FRAME_KEY_PREFIX) for kb in keys.key_blocks):
        return "the baked shape keys"
    mod = obj.modifiers.get(modifiers.CACHE_MODIFIER)
    if mod is not None and mod.type == "MESH_CACHE":
        return "the point cache's Mesh Cache modifier"
    return None


def mute_for_bake(obj) -> None:
    """Mutes the pose key for a bake's output, which replaces it (:func:`write_pose` unmutes
    it once that output is gone). A key the user muted before stays the user's."""
    kb = ensure_pose_key(obj)
    if not kb.mute:
        kb.mute = True
        obj.data.shape_keys[BAKE_MUTED] = True


def pose_muted_by_bake(obj):
    """What plays in place of the live pose while a bake's output mutes it (``None``: the
    live pose shows, or the user muted it)."""
    keys = obj.data.shape_keys
    kb = keys.key_blocks.get(POSE_KEY) if keys is not None else None
    muted = kb is not None and kb.mute and bool(keys.get(BAKE_MUTED))
    return baked_output(obj) if muted else None


def write_pose(obj, U: np.ndarray) -> None:
    kb = ensure_pose_key(obj)
    # A bake muted the key; once its output is gone, the live pose shows again (it stayed
    # muted: posing did nothing visible, with Live on). A key the user muted stays muted.
    keys = obj.data.shape_keys
    if keys.get(BAKE_MUTED) and (not kb.mute or baked_output(obj) is None):
        # unmuted by the user meanwhile, or the output gone: the mark has done its part
        kb.mute = False
        del keys[BAKE_MUTED]
    # ShapeKey.points (Blender 4.1+): the raw array; `data` goes point by point, 50x slower
    # (757k points: 2 ms against 108 ms).
    kb.points.foreach_set("co", np.ascontiguousarray(U, dtype=np.float32).ravel())
    obj.data.update()


def update(obj, *, force=False) -> bool:
    """Solve ``obj`` for its controls' current motion and write the pose; skipped (False) when
    the controls have not moved since the last solve, which also stops the update that writing
    the shape key triggers from solving again; and while a bake solves the frames. Once it
    gets past the checks (posed, or its pose up to date), the error reported before goes: then
    also True while the pose has not ended, so that the finishing steps a failed check stopped
    resume (the caller starts the finish timer on True)."""
    t0 = time.perf_counter()
    check_controls(obj)  # before building: no solver for a copy that cannot use the controls
    st = state(obj)
    st.matrix = np.array(obj.matrix_world, dtype=np.float64)
    if st.baking and not force:
        return False
    deltas = control_deltas(obj, checked=True)
    if not force and st.last_deltas is not None and np.array_equal(deltas, st.last_deltas):
        if st.ended == "error":  # a failed solve or settle step holds until the controls move
            return False
        return clear_error(obj) and st.ended is None
    U = solve(obj, st, deltas)
    write_pose(obj, U)
    st.last_ms = (time.perf_counter() - t0) * 1e3
    st.moved_at = time.monotonic()
    st.finish_steps = 0
    st.ended = None
    clear_error(obj)
    return True


def finish_step(obj):
    """One step of the pose toward what it is at rest, for controls that have stopped: the last
    solve again at the same targets while it had not converged, else one settle step while one
    is pending; written into the pose key. Returns ``None`` when there is nothing to do (no
    solve yet, the controls moved since it, which the live handler solves, or the pose at rest),
    else the seconds until the next step is due (0 after a step). At most
    ``bsarap.MAX_SETTLE_STEPS`` steps per motion, as the editor."""
    st = built(obj)
    if st is None or st.last_deltas is None or st.ended or st.key != state_key(obj):
        return None
    deltas = control_deltas(obj)
    if not np.array_equal(deltas, st.last_deltas):
        return None
    if st.baking:
        return REST_DELAY
    wait = REST_DELAY - (time.monotonic() - (st.moved_at or 0.0))
    if wait > 0:
        return wait
    bsarap = import_bsarap()
    if st.finish_steps >= bsarap.MAX_SETTLE_STEPS:
        st.ended = "cap"
        return None
    if not st.converged:
        try:
            U = solve(obj, st, deltas)
        except HandleError:
            st.ended = "error"
            raise
    else:
        try:
            U = st.deformer.settle() if st.deformer.settle_pending else None
        except bsarap.BsarapError as e:
            st.ended = "error"
            raise HandleError(f"{obj.name}: {e}") from None
        if U is None:
            st.ended = "rest"
            return None
        U = st.on_mesh(U)
    st.finish_steps += 1
    write_pose(obj, U)
    return 0.0


def status(obj):
    """Where the pose of ``obj`` stands, for the panel (the editor's status bar says the same of
    its pose): ``(text, icon)``, or ``None`` before its first solve."""
    st = built(obj)
    if st is None or st.last_deltas is None:
        return None
    if st.baking:
        return "Baking: the bake solves the frames", "TIME"
    what = pose_muted_by_bake(obj) if obj.bsarap.live else None
    if what is not None:
        return f"The live pose is muted: {what} play instead (delete them to pose live)", "ERROR"
    if st.ended == "cap":
        return f"Stopped after {st.finish_steps} steps (the cap), short of rest", "ERROR"
    if st.ended == "error":
        return "Stopped settling: see the message", "ERROR"
    if st.ended == "rest":
        return f"At rest ({st.finish_steps} steps after the last move)", "CHECKMARK"
    if not obj.bsarap.live:
        return "Posed once (Live off: no settling)", "INFO"
    if st.finish_steps:
        return f"Settling: {st.finish_steps} steps", "TIME"
    return "Live: settles once the controls rest", "TIME"
