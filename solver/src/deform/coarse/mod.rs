//! BS-ARAP on a coarse base: ARAP runs on a decimated copy of a smooth base surface and the
//! full-resolution details ride on it (our variant for speed; docs/DESIGN.md, "The coarse base").
//!
//! Per mesh, whatever the handles ([`CoarseBase`], built once and shared by every handle set):
//! 1–3. $B$ = the faired base of $M$ with no vertex held, $B_c$ its decimation, the embedding
//!    of each fine vertex as barycentric weights $w_{ik}$ on a coarse triangle $t_i$, and the
//!    details $D_i = p_i - \sum_k w_{ik} B_{c,k}$ ([`crate::deform::coarse::base`]).
//!
//! Per handle set ([`CoarseBsArap::with_base`]; milliseconds at a few thousand coarse vertices):
//! - **Handles on the coarse level**: coarse vertex $k$ joins group $g$ when at least half of
//!   the fine vertices it represents are in $g$; a group left with fewer than
//!   [`MIN_COARSE_GROUP`] coarse vertices takes those with the largest share of its vertices,
//!   then their neighbours nearest to its centroid. Each frame, group $g$'s coarse targets
//!   are $T_g(B_{c,k})$, $T_g$ the group's rigid motion as the caller gives it
//!   ([`CoarseBsArap::solve_groups`]; the editor, scenes, CLI and Python poses), or for bare
//!   per-vertex targets ([`CoarseBsArap::solve`]) the best rigid motion of its fine handles
//!   from rest to their targets ([`crate::linalg::rigid`]: the same motion for rigid targets,
//!   the rigid part otherwise); the fine handle vertices get their own targets exactly in
//!   step 4.
//! - ARAP on $B_c$ with those handles, factored; or, with the Galerkin coarse energy
//!   ([`BaseConfig::coarse_energy`], [`crate::deform::coarse::energy`]), the full mesh's
//!   energy restricted to the coarse space, its handles' terms added to the mesh's part.
//!
//! 4. Each frame: ARAP on $B_c$ (the coarse handles on their targets), or the Galerkin energy
//!    (the fine handles on theirs, exactly), gives $B_c'$ and $R_k$;
//!    $p'_i = \sum_k w_{ik} B'_{c,k} + \hat R_i (D_i + C_i)$ where $\hat R_i$ is the normalized
//!    blend of the corner rotations as quaternions (signs aligned) and $C_i$ the carried fine
//!    correction (step 5; zero without it). Handle vertices are set to their targets exactly,
//!    and the vertices of components without handles to their rest positions (the deformer
//!    then moves the following ones, [`crate::deform::riders`]).
//! 5. Optionally ([`BaseConfig::fine_iterations`]), a few ARAP iterations on $M$ (factored
//!    when first needed, [`CoarseBsArap::factor_fine`], or on a thread of its own,
//!    [`CoarseBsArap::factor_fine_in_background`]) with
//!    Anderson acceleration ([`Arap::refine`]) start from $p'$ and give the result $x$: a
//!    two-level scheme in which the coarse solve supplies the smooth part of the deformation
//!    and the fine iterations reduce what the coarse space and the detail transfer cannot
//!    represent. What they changed is kept in the detail frames,
//!    $C_i = \hat R_i^\top (x_i - \sum_k w_{ik} B'_{c,k}) - D_i$, and carried to the next
//!    frame, so that over an animation the fine iterations add up instead of starting again
//!    from the coarse pose every frame (BENCHMARKS.md measures both).
//!
//! 6. Optionally ([`BaseConfig::settle_iterations`], [`CoarseBsArap::settle`]), once the
//!    handles stop, more fine iterations refine the pose step by step, carried the same way,
//!    until the steps' lengths say the pose is within a hundredth of a percent of the diagonal
//!    of where they lead (`settle_rule.rs`): the pose approaches converged ARAP on $M$. With
//!    the Galerkin coarse energy the coarse solve first runs on until its own steps say the
//!    same (its minimum is $M$'s in the coarse space; a frame's stopping rule, a decrease of the
//!    energy, leaves the soft modes unfinished). A base faired on a level then settles on that
//!    level ([`crate::deform::coarse::level_settle`]: a ninth of the vertices at 692k, factored
//!    far sooner), then on $M$.
//!
//! Rest pose is exact (rest targets give $B_c' = B_c$, $R = I$ and clear $C$, so $p' = p$;
//! they skip the fine iterations) and a rigid motion of all handles moves the result rigidly.
//! An iteration costs what ARAP on $B_c$ costs; the prolongation is one pass over the fine
//! vertices per frame, each fine iteration one ARAP iteration on $M$.
//!
//! **Three meshes, one word each**: the *full mesh* $M$ (the user's), the *level* $M_\ell$
//! (the full mesh decimated to resolve the smoothing length, where a dense mesh's base is
//! faired and a stopped pose settles first) and the *coarse mesh* $B_c$ (a few thousand
//! vertices, where the per-frame ARAP runs). One file per step:
//!
//! | file | step |
//! |---|---|
//! | `base.rs` | 1–3: $B$, $B_c$, the embedding and the details, per mesh ([`CoarseBase`]) |
//! | `level.rs` | 1: fairing $B$ on the level of a dense mesh |
//! | `cache.rs` | the per-mesh part on disk |
//! | `groups.rs` | handle groups on the coarse mesh and their rigid targets |
//! | `prolong.rs` | 4: the coarse pose carried to the full mesh with its details |
//! | `full_mesh.rs` | 5–6: ARAP iterations on the full mesh (factored in the background) |
//! | `settle.rs` | 6: settling in phases, the coarse level's steps ([`CoarseBsArap::settle`]) |
//! | `level_settle.rs` | 6: settling on the level before the full mesh |
//! | `settle_rule.rs` | 6: when settling stops (the distance still to go, from the steps) |
//! | `mod.rs` | [`CoarseBsArap`]: the steps in order, per frame |
//! | `pipeline.rs` | 4: a frame's prolongation beside the next frame's coarse solve (the editor) |
//! | `energy.rs` | 4: the coarse level's energy, decimated ARAP or Galerkin, behind one interface |
//! | `galerkin/` | the full mesh's energy restricted to the coarse space (its mesh part, tests) |
//! | `fit.rs` | the pose of the coarse space nearest a given one (a measurement) |

pub mod base;
pub mod cache;
pub mod energy;
pub mod fit;
pub mod full_mesh;
pub mod galerkin;
pub mod groups;
pub mod level;
pub mod level_settle;
mod pipeline;
pub mod prolong;
mod settle;
pub mod settle_rule;

use crate::deform::arap::{Arap, ArapConfig, Energy, GlobalStep, RotationStep, SolveStats};
use crate::deform::coarse::base::{CoarseBase, Phases};
use crate::deform::coarse::energy::CoarseSolver;
use crate::deform::coarse::full_mesh::FineLevel;
use crate::deform::coarse::galerkin::{GalerkinCoarse, HandleRule, galerkin_mesh};
pub use crate::deform::coarse::groups::MIN_COARSE_GROUP;
use crate::deform::coarse::groups::{CoarseGroups, coarse_rig};
use crate::deform::coarse::level_settle::LevelSolver;
use crate::deform::coarse::prolong::{
    Prolongation, at, prolong, quaternion_of, rotate, triangle_frames,
};
use crate::deform::coarse::settle_rule::SettleRule;
use crate::deform::config::{BaseConfig, CoarseEnergy};
use crate::deform::constraints::Constraints;
use crate::deform::handles::Handles;
use crate::deform::quality::distances;
use crate::error::{SolveError, check_targets};
use crate::geometry::embedding::{blend, from_stored};
use crate::geometry::mesh::{Mesh, sub};
use crate::linalg::rigid::Motion;
use glam::DQuat;
use rayon::prelude::*;
use std::sync::Arc;

/// Coarse-base BS-ARAP precomputed for one mesh and one handle set: what the handles fix
/// (the base, the factored coarse ARAP, the handle groups, the full-mesh and level solvers,
/// the iteration counts) and, in its `SolveState`, what each solve changes.
#[derive(Debug)]
pub struct CoarseBsArap {
    /// The mesh's handle-independent part: $B_c$, the embedding, the details.
    base: Arc<CoarseBase>,
    /// The coarse level's solver ([`BaseConfig::coarse_energy`]); its positions are the coarse
    /// pose of the last successful solve.
    coarse: CoarseSolver,
    fine_handles: Vec<u32>,
    /// Fine vertices of components without handles, with their rest positions.
    pinned: Vec<(u32, [f64; 3])>,
    groups: CoarseGroups,
    /// ARAP on the full mesh (when fine or settle iterations are asked for), factored when
    /// first needed.
    fine: Option<FineLevel>,
    fine_iterations: usize,
    /// ARAP on the fairing level (step 6), when settle iterations are asked for and the base
    /// was faired on a level.
    level: Option<LevelSolver>,
    settle_iterations: usize,
    /// The full mesh's bounding-box diagonal, the settle rule's unit.
    diagonal: f64,
    phases: Vec<(&'static str, f64)>,
    state: SolveState,
}

/// What a solve changes: the pose, rotations and carried corrections of the last successful
/// solve, the scratch the next one writes into, and what [`CoarseBsArap::settle`] needs to
/// know about it.
///
/// Invariants between solves: `result`, `quaternions` and the coarse ARAP's positions are
/// those of one successful solve (the rest pose before any, `result` then empty); `next` and
/// `next_quaternions` hold nothing that is read. A solve writes its pose and rotations into
/// the scratch, swaps them in ([`SolveState::swap_next`]) and, if the pose is not finite or
/// the fine iterations fail, swaps them back and puts the coarse pose back to `coarse_before`
/// ([`SolveState::roll_back`]), so that after an error the pose, the base and the rotations
/// all stay those of the last successful solve.
#[derive(Debug)]
struct SolveState {
    /// The result of the last successful solve, `#V×3`; empty before the first (the rest
    /// pose is then the mesh's own, [`CoarseBsArap::positions`], not a copy).
    result: Vec<[f64; 3]>,
    /// Scratch for the next result, `#V×3` once a solve has run.
    next: Vec<[f64; 3]>,
    /// $R_k$ of the last successful solve as unit quaternions; `next_quaternions` is the
    /// solve in progress, swapped in with the result.
    quaternions: Vec<DQuat>,
    next_quaternions: Vec<DQuat>,
    /// $\sum_k w_{ik} B'_{c,k}$ of the last solve, computed when first asked for
    /// ([`CoarseBsArap::deformed_base`]): the frames need no copy of it.
    deformed_base: std::sync::OnceLock<Vec<[f64; 3]>>,
    /// Per fine vertex, what the last fine iterations added to its detail, in the detail's
    /// frame (zero without fine iterations): carried to the next solve.
    correction: Vec<[f64; 3]>,
    /// Whether `correction` holds anything but zeros (else the prolongation skips it).
    corrected: bool,
    /// Per-solve scratch: each group's motion and the coarse handles' targets (a few thousand
    /// vertices; reused, not allocated per frame).
    motions: Vec<Motion>,
    coarse_targets: Vec<[f64; 3]>,
    /// The coarse pose to go back to if the prolongation or the fine iterations fail: that of
    /// the last successful solve, whose pose is `result` (also while a frame is pending).
    coarse_before: Vec<[f64; 3]>,
    /// A frame whose coarse solve has run and whose prolongation has not
    /// ([`CoarseBsArap::begin_groups`]); its coarse pose is the coarse solver's.
    pending: Option<Pending>,
    /// Scratch: the pending frame's coarse pose while the next frame's coarse solve moves on
    /// (`pipeline.rs`).
    coarse_pose: Vec<[f64; 3]>,
    /// The targets of the last solve, and whether [`CoarseBsArap::settle`] may refine its
    /// result (its coarse solve converged and it is not the rest pose).
    last_targets: Vec<[f64; 3]>,
    settle_ready: bool,
    /// Whether the last solve's pose has settled on the coarse level, on the level, and on
    /// the full mesh (step 6).
    coarse_settled: bool,
    level_settled: bool,
    full_settled: bool,
    /// The coarse energy of the last solve (what a settle step reports).
    last_energy: f64,
    /// The current settle phase's steps ([`settle_rule`]).
    settling: SettleRule,
}

impl SolveState {
    /// The state before any solve, of a full mesh of `n` vertices: the rest pose (no result
    /// yet) and identity rotations at the `n_coarse` coarse vertices.
    fn new(n: usize, n_coarse: usize) -> SolveState {
        SolveState {
            result: Vec::new(),
            next: Vec::new(),
            quaternions: vec![DQuat::IDENTITY; n_coarse],
            next_quaternions: vec![DQuat::IDENTITY; n_coarse],
            deformed_base: std::sync::OnceLock::new(),
            correction: vec![[0.0; 3]; n],
            corrected: false,
            motions: Vec::new(),
            coarse_targets: Vec::new(),
            coarse_before: Vec::new(),
            pending: None,
            coarse_pose: Vec::new(),
            last_targets: Vec::new(),
            settle_ready: false,
            coarse_settled: true,
            level_settled: false,
            full_settled: false,
            last_energy: 0.0,
            settling: SettleRule::default(),
        }
    }

    /// Exchanges the result and the rotations with their scratch buffers.
    fn swap_next(&mut self) {
        std::mem::swap(&mut self.result, &mut self.next);
        std::mem::swap(&mut self.quaternions, &mut self.next_quaternions);
    }

    /// Undoes a failed solve whose pose and rotations were swapped in: they go back to the
    /// scratch, the coarse pose of `coarse` back to the last successful solve's, and nothing is
    /// left to settle.
    fn roll_back(&mut self, coarse: &mut CoarseSolver) {
        self.swap_next();
        coarse.set_positions(&self.coarse_before);
        self.settle_ready = false;
    }

    /// The coarse solver's rotations as the next pose's quaternions.
    fn take_rotations(&mut self, coarse: &CoarseSolver) {
        for (q, r) in self.next_quaternions.iter_mut().zip(coarse.rotations()) {
            *q = quaternion_of(r);
        }
    }

    /// Keeps what settling needs to know of a successful solve at `targets` with `stats`
    /// (`galerkin`: its coarse energy is the Galerkin one).
    fn solved(&mut self, targets: &[[f64; 3]], stats: &SolveStats, galerkin: bool) {
        self.last_targets.clear();
        self.last_targets.extend_from_slice(targets);
        // Only a coarse energy whose minimum is the full mesh's in the coarse space is worth
        // settling on (the decimated ARAP's lies tenths of a percent away).
        self.coarse_settled = !galerkin;
        self.level_settled = false;
        self.full_settled = false;
        self.settling.reset();
        self.settle_ready = stats.converged && stats.iterations > 0;
        self.last_energy = stats.energy();
    }

    /// Forgets the carried corrections.
    fn clear_correction(&mut self) {
        self.correction.fill([0.0; 3]);
        self.corrected = false;
    }

    /// Keeps what the fine or level iterations changed of `result` in the detail frames of
    /// the coarse pose `coarse` (with `quaternions`) on `base`, for the next solve's
    /// prolongation.
    fn carry(&mut self, coarse: &[[f64; 3]], base: &CoarseBase) {
        let frames = triangle_frames(coarse, &self.quaternions, base.coarse_mesh.triangles());
        self.correction
            .par_iter_mut()
            .zip(self.result.par_iter().zip(base.faces.par_iter()))
            .zip(base.weights.par_iter().zip(base.details.par_iter()))
            .for_each(|((c, (x, &f)), (w, d))| {
                let frame = &frames[f as usize];
                let (b, q) = at(&frame.corners(), &frame.quaternions, &from_stored(w[0], w[1]));
                let conj = [-q[0], -q[1], -q[2], q[3]];
                *c = sub(rotate(conj, sub(*x, b)), *d);
            });
        self.corrected = true;
    }

    /// What [`CoarseBsArap::reset`] forgets: the rotations and corrections the next solve would
    /// start from, and the last solve's targets (nothing to settle). The result stays until
    /// the next solve replaces it.
    fn restart(&mut self) {
        self.pending = None;
        self.deformed_base = std::sync::OnceLock::new();
        self.quaternions.fill(DQuat::IDENTITY);
        self.clear_correction();
        self.last_targets.clear();
        self.settle_ready = false;
    }
}

/// A frame whose coarse solve has run and whose prolongation waits: its statistics and its fine
/// targets.
#[derive(Debug)]
struct Pending {
    stats: SolveStats,
    targets: Vec<[f64; 3]>,
}

/// Puts the handle vertices `handles` on their `targets` and the pinned vertices (of
/// components without handles) at their rest positions, in the pose `x`.
fn hold(x: &mut [[f64; 3]], handles: &[u32], targets: &[[f64; 3]], pinned: &[(u32, [f64; 3])]) {
    for (&v, t) in handles.iter().zip(targets) {
        x[v as usize] = *t;
    }
    for &(v, p) in pinned {
        x[v as usize] = p;
    }
}

/// The vertices a prolonged pose puts on given positions: the handles on their targets, the
/// vertices of components without handles at rest.
#[derive(Clone, Copy)]
struct Held<'a> {
    handles: &'a [u32],
    targets: &'a [[f64; 3]],
    pinned: &'a [(u32, [f64; 3])],
}

/// Step 4 into `state`: the coarse pose `coarse` (its rotations already in
/// `state.next_quaternions`) prolonged on `base` into the scratch, `held` put on their
/// positions, and swapped in as the result (the pose before in `state.next`). `at_rest`: the
/// coarse solve ran no iteration (rest targets). Returns a vertex whose point is not finite,
/// if any: the caller then rolls back ([`SolveState::roll_back`]).
fn prolong_state(
    state: &mut SolveState,
    base: &CoarseBase,
    coarse: &[[f64; 3]],
    held: Held<'_>,
    at_rest: bool,
) -> Option<usize> {
    // Rest targets give the rest pose exactly, without iterating: nothing to settle, and no
    // correction may carry over (the rest pose itself is copied below).
    if at_rest && state.corrected {
        state.clear_correction();
    }
    state.deformed_base = std::sync::OnceLock::new();
    // B'_c is finite (checked by ARAP) but the prolonged p' can still overflow: write into the
    // scratch, swap it in, and have the caller swap it back unless p' is finite (the previous
    // pose stays). The prolongation checks what it writes; only when that finds a point that
    // is not finite is the held pose searched (a handle may have replaced the point).
    if state.next.len() != base.rest.len() {
        // Zeroed pages from the system (no pass to fill them), first written by the parallel
        // prolongation.
        state.next = vec![[0.0; 3]; base.rest.len()];
    }
    let finite = prolong(
        Prolongation {
            coarse,
            quaternions: &state.next_quaternions,
            triangles: base.coarse_mesh.triangles(),
            faces: &base.faces,
            weights: &base.weights,
            details: &base.details,
            corrections: if state.corrected { &state.correction } else { &[] },
        },
        &mut state.next,
    );
    if at_rest && held.handles.iter().zip(held.targets).all(|(&v, t)| *t == base.rest[v as usize]) {
        // Rest targets: M exactly (the prolongation B + D may differ in the last bit).
        state.next.copy_from_slice(&base.rest);
    }
    hold(&mut state.next, held.handles, held.targets, held.pinned);
    let bad = if finite {
        None
    } else {
        state.next.par_iter().position_any(|p| !p.iter().all(|c| c.is_finite()))
    };
    state.swap_next();
    bad
}

impl CoarseBsArap {
    /// Builds the mesh's [`CoarseBase`] and then the solver for `handles` on it.
    pub fn new(
        mesh: &Mesh,
        handles: &Handles,
        config: &ArapConfig,
        coarse: &BaseConfig,
    ) -> Result<CoarseBsArap, SolveError> {
        let base = Arc::new(CoarseBase::new(mesh, coarse)?);
        CoarseBsArap::with_base(base, mesh, handles, config, coarse)
    }

    /// The solver for `handles` on a [`CoarseBase`] built for `mesh` (the handle-dependent
    /// part, module doc: coarse handle groups, their factorization). Refused with
    /// [`SolveError::StaleBase`] when `base` does not fit `mesh` and `coarse`.
    /// The ARAP on the full mesh that fine and settle iterations need is factored when they
    /// first run, not here.
    pub fn with_base(
        base: Arc<CoarseBase>,
        mesh: &Mesh,
        handles: &Handles,
        config: &ArapConfig,
        coarse: &BaseConfig,
    ) -> Result<CoarseBsArap, SolveError> {
        if handles.n_vertices() != mesh.n_vertices() {
            return Err(SolveError::HandleCount {
                got: handles.n_vertices(),
                expected: mesh.n_vertices(),
            });
        }
        if !base.fits(mesh, coarse) {
            return Err(SolveError::StaleBase);
        }
        let mut clock = Phases::default();
        let constraints = Constraints::new(mesh, handles);
        let groups = CoarseGroups::new(&base, handles, mesh.positions());
        clock.lap("coarse handles");
        let coarse_mesh = &base.coarse_mesh;
        let full_diagonal = mesh.bbox_diagonal();
        let solver = match coarse.coarse_energy {
            CoarseEnergy::Decimated => {
                let coarse_handles = Handles::from_options(groups.labels.clone())?
                    .with_rig(coarse_rig(&base, handles));
                let coarse_config = ArapConfig {
                    membrane: coarse.membrane,
                    ..config.same_bending_length(full_diagonal, coarse_mesh)
                };
                let arap = Arap::with_constraints(
                    coarse_mesh,
                    Constraints::new(coarse_mesh, &coarse_handles),
                    &coarse_config,
                    base.floor,
                    Some(&base.rest_kept),
                    RotationStep::Auto,
                    GlobalStep::Factor,
                )
                .map_err(|e| match e {
                    SolveError::DegenerateFace { face } => SolveError::DegenerateBase { face },
                    other => other,
                })?;
                CoarseSolver::Decimated(Box::new(arap))
            }
            CoarseEnergy::Galerkin => {
                if config.energy != Energy::SmoothRotations {
                    return Err(SolveError::GalerkinEnergy);
                }
                let gathered = galerkin_mesh(&base, mesh)?;
                clock.lap("Galerkin mesh part");
                let rule = HandleRule::Exact;
                let energy = GalerkinCoarse::new(
                    mesh,
                    &base,
                    &gathered,
                    handles,
                    &constraints,
                    config.bending_length,
                    rule,
                )?;
                CoarseSolver::galerkin(energy, config)
            }
        };
        clock.lap("coarse factorization");
        let pinned = constraints
            .pinned_vertices
            .iter()
            .map(|&v| (v, mesh.positions()[v as usize]))
            .collect();
        let fine = (coarse.fine_iterations > 0 || coarse.settle_iterations > 0)
            .then(|| FineLevel::full_mesh(mesh, constraints, config, Arc::clone(&base)));
        let fine_handles = handles.handle_vertices();
        let level = match (&base.level, coarse.settle_iterations) {
            (Some(l), 1..) => {
                let level_config = config.same_bending_length(full_diagonal, &l.mesh);
                Some(LevelSolver::new(mesh, l, handles, fine_handles, &level_config)?)
            }
            _ => None,
        };
        clock.lap("settling's inputs");
        Ok(CoarseBsArap {
            fine,
            fine_iterations: coarse.fine_iterations,
            level,
            settle_iterations: coarse.settle_iterations,
            diagonal: full_diagonal,
            phases: clock.phases,
            pinned,
            state: SolveState::new(mesh.n_vertices(), coarse_mesh.n_vertices()),
            fine_handles: fine_handles.to_vec(),
            groups,
            base,
            coarse: solver,
        })
    }

    pub fn solve(&mut self, targets: &[[f64; 3]]) -> Result<SolveStats, SolveError> {
        self.solve_with(targets, None)
    }

    /// [`CoarseBsArap::solve`] for `targets` made by the group motions `motions` (one per
    /// group id, [`crate::deform::pose::GroupRest::motions`]): the coarse handles follow the
    /// motions as given instead of a rigid fit to the fine targets (module doc, step 3).
    pub fn solve_groups(
        &mut self,
        targets: &[[f64; 3]],
        motions: &[Motion],
    ) -> Result<SolveStats, SolveError> {
        self.check_motions(motions)?;
        self.solve_with(targets, Some(motions))
    }

    /// One motion per group, else [`SolveError::GroupCount`].
    fn check_motions(&self, motions: &[Motion]) -> Result<(), SolveError> {
        if motions.len() != self.groups.n_groups() {
            return Err(SolveError::GroupCount {
                got: motions.len(),
                expected: self.groups.n_groups(),
            });
        }
        Ok(())
    }

    fn solve_with(
        &mut self,
        targets: &[[f64; 3]],
        motions: Option<&[Motion]>,
    ) -> Result<SolveStats, SolveError> {
        self.finish_pending()?;
        let mut stats = self.coarse_half(targets, motions)?;
        self.prolong_result(targets, stats.iterations == 0)?;
        if self.fine_iterations > 0 {
            match self.run_fine(targets, self.fine_iterations) {
                Ok((st, _)) => {
                    stats.fine_iterations = st.iterations;
                    stats.fine_energy = st.energy();
                    stats.fine_ms = st.total_ms();
                    stats.fine_unconverged = !self.fine_converged(&st);
                }
                Err(e) => {
                    // The previous pose, base and frames stay, as for a failed coarse solve.
                    self.state.roll_back(&mut self.coarse);
                    return Err(e);
                }
            }
        }
        self.state.solved(targets, &stats, self.coarse.is_galerkin());
        Ok(stats)
    }

    /// Step 4's coarse solve at `targets` (and `motions`): the coarse handles' targets, then
    /// the coarse solve from its last pose under its stopping rule, that pose kept to go back
    /// to. The result is not touched.
    fn coarse_half(
        &mut self,
        targets: &[[f64; 3]],
        motions: Option<&[Motion]>,
    ) -> Result<SolveStats, SolveError> {
        // Only some targets reach the coarse ARAP (which checks them); all are copied to p'.
        check_targets(targets, self.fine_handles.len())?;
        let state = &mut self.state;
        self.groups.targets(targets, motions, &mut state.motions, &mut state.coarse_targets);
        state.coarse_before.clear();
        state.coarse_before.extend_from_slice(self.coarse.positions());
        self.coarse.solve(targets, &state.coarse_targets, &state.coarse_before)
    }

    /// The pending frame's prolongation, if a frame is pending ([`CoarseBsArap::begin_groups`]).
    fn finish_pending(&mut self) -> Result<(), SolveError> {
        let Some(p) = self.state.pending.take() else { return Ok(()) };
        self.prolong_result(&p.targets, p.stats.iterations == 0)?;
        self.state.solved(&p.targets, &p.stats, self.coarse.is_galerkin());
        Ok(())
    }

    /// The coarse pose prolonged into the result, the handles held; `at_rest`: the coarse
    /// solve ran no iteration (rest targets). On error (a pose that is not finite) the pose,
    /// rotations and coarse pose of the last successful solve stay; otherwise the pose before
    /// is in `state.next`.
    fn prolong_result(&mut self, targets: &[[f64; 3]], at_rest: bool) -> Result<(), SolveError> {
        self.state.take_rotations(&self.coarse);
        let held = Held { handles: &self.fine_handles, targets, pinned: &self.pinned };
        let bad =
            prolong_state(&mut self.state, &self.base, self.coarse.positions(), held, at_rest);
        if let Some(vertex) = bad {
            self.state.roll_back(&mut self.coarse);
            return Err(SolveError::NonFiniteResult { vertex });
        }
        Ok(())
    }

    /// `n` fine iterations ([`Arap::refine`]) from the current result, which they replace; what
    /// they changed is kept in the detail frames for the next solve (zero again when the result
    /// is the rest pose); with how far they moved the vertices on average, over the diagonal.
    /// On error the result is unchanged.
    fn run_fine(
        &mut self,
        targets: &[[f64; 3]],
        n: usize,
    ) -> Result<(SolveStats, f64), SolveError> {
        self.factor_fine()?;
        let Some(fine) = self.fine.as_mut().and_then(FineLevel::arap_mut) else {
            return Ok((SolveStats { converged: true, ..SolveStats::default() }, 0.0));
        };
        let st = fine.refine(&self.state.result, targets, n)?;
        let moved = distances(&self.state.result, fine.positions(), self.diagonal).mean;
        self.state.result.copy_from_slice(fine.positions());
        self.state.carry(self.coarse.positions(), &self.base);
        Ok((st, moved))
    }

    /// Factors the ARAP on the full mesh if it is pending, or waits for the thread factoring it
    /// ([`CoarseBsArap::factor_fine_in_background`]); its phase is added to
    /// [`CoarseBsArap::precompute_phases`]. Nothing without fine or settle iterations or when
    /// done already; the error of a failed factorization every time.
    pub fn factor_fine(&mut self) -> Result<(), SolveError> {
        if let Some(ms) = self.fine.as_mut().map(FineLevel::factor).transpose()?.flatten() {
            self.phases.push(("fine factorization", ms));
        }
        Ok(())
    }

    /// Starts factoring what settling needs next (the level's ARAP until it has settled, then
    /// the full mesh's) on a thread of its own if it is pending
    /// ([`crate::deform::coarse::full_mesh`]: one at a time in the process); a caller that must
    /// stay responsive, such as the editor's solver thread, settles only once this says true.
    /// True when the next settle step can run without waiting for a factorization (done,
    /// failed, none asked for, or a step on the coarse level, which needs none while the
    /// factorization goes on): the next [`CoarseBsArap::settle`] takes the result, or reports
    /// the failure, or resumes a panic of that thread.
    pub fn factor_fine_in_background(&mut self) -> bool {
        let ready = if !self.state.level_settled
            && let Some(level) = self.level.as_mut().filter(|l| !l.has_failed())
        {
            level.factor_in_background()
        } else {
            self.fine.as_mut().is_none_or(FineLevel::factor_in_background)
        };
        // Settling on the coarse level needs no factorization but its own.
        ready || !self.state.coarse_settled
    }

    /// Whether the ARAP on the full mesh is factored (fine and settle iterations run at once).
    pub fn fine_ready(&self) -> bool {
        self.fine.as_ref().is_some_and(FineLevel::is_ready)
    }

    /// Whether fine iterations no longer lower the energy by the tolerance per iteration (then
    /// running them again at the same targets would change nothing). Without a tolerance
    /// (other stopping rules) or with a non-finite energy there is nothing to wait for: true.
    fn fine_converged(&self, st: &SolveStats) -> bool {
        let tol = self.coarse.config().tolerance;
        let (e0, e1) = (st.initial_energy, st.energy());
        let per_iteration = (e0 - e1) / (e0 * st.iterations.max(1) as f64);
        tol <= 0.0 || e0 <= f64::MIN_POSITIVE || per_iteration.is_nan() || per_iteration < tol
    }

    /// The result of the last solve, `#V×3` (the rest pose before any).
    pub fn positions(&self) -> &[[f64; 3]] {
        if self.state.result.is_empty() { &self.base.rest } else { &self.state.result }
    }

    /// The base at rest as seen by the fine vertices (their points on $B_c$), `#V×3`.
    pub fn base(&self) -> &[[f64; 3]] {
        &self.base.base_on_coarse
    }

    /// The mesh's handle-independent part, shared with other handle sets of the mesh.
    pub fn coarse_base(&self) -> &Arc<CoarseBase> {
        &self.base
    }

    /// The deformed base at the fine vertices, `#V×3` (computed on the first call after a
    /// solve: the prolongation itself does not need it).
    pub fn deformed_base(&self) -> &[[f64; 3]] {
        self.state.deformed_base.get_or_init(|| {
            let bc = self.published_coarse();
            (0..self.base.faces.len())
                .into_par_iter()
                .map(|i| {
                    let (t, w) = self.base.embedding(i);
                    blend(bc, &t, &w)
                })
                .collect()
        })
    }

    /// The coarse pose of the result ([`CoarseBsArap::positions`]): the coarse solver's, or
    /// while a frame is pending the one it started from.
    fn published_coarse(&self) -> &[[f64; 3]] {
        if self.state.pending.is_some() {
            &self.state.coarse_before
        } else {
            self.coarse.positions()
        }
    }

    /// Details $D_i$, `#V×3`.
    pub fn details(&self) -> &[[f64; 3]] {
        &self.base.details
    }

    /// The inputs of the last solve's prolongation (step 4 of the module doc).
    pub fn prolongation(&self) -> Prolongation<'_> {
        Prolongation {
            coarse: self.published_coarse(),
            quaternions: &self.state.quaternions,
            triangles: self.base.coarse_mesh.triangles(),
            faces: &self.base.faces,
            weights: &self.base.weights,
            details: &self.base.details,
            corrections: &self.state.correction,
        }
    }

    /// The fine vertices the last solve put on given positions after the prolongation: the
    /// handles on their targets, then the vertices of components without handles at rest.
    pub fn fixed_vertices(&self) -> impl Iterator<Item = (u32, [f64; 3])> + '_ {
        self.fine_handles
            .iter()
            .copied()
            .zip(self.state.last_targets.iter().copied())
            .chain(self.pinned.iter().copied())
    }

    /// Milliseconds of each precomputation phase for this handle set (coarse handles, coarse
    /// factorization, and the fine factorization once fine or settle iterations ran); the
    /// mesh's own phases are [`CoarseBase::precompute_phases`].
    pub fn precompute_phases(&self) -> &[(&'static str, f64)] {
        &self.phases
    }

    /// Vertices of the coarse base.
    pub fn coarse_vertices(&self) -> usize {
        self.coarse.positions().len()
    }

    /// The ARAP solver on the coarse base ([`CoarseEnergy::Decimated`]; `None` for the
    /// Galerkin energy, which is not an ARAP on a mesh).
    pub fn base_arap(&self) -> Option<&Arap> {
        self.coarse.arap()
    }

    /// Mutable access to the ARAP solver on the coarse base (starting guesses); `None` for
    /// the Galerkin energy.
    pub fn base_arap_mut(&mut self) -> Option<&mut Arap> {
        self.coarse.arap_mut()
    }

    /// Changes the coarse solve's stopping rule without refactoring.
    pub fn set_stopping(&mut self, tolerance: f64, max_iterations: usize) {
        self.coarse.set_stopping(tolerance, max_iterations);
    }

    /// Restarts the next solve from rest.
    pub fn reset(&mut self) {
        self.coarse.reset();
        self.state.restart();
        if let Some(fine) = self.fine.as_mut().and_then(FineLevel::arap_mut) {
            fine.reset();
        }
    }
}

#[cfg(test)]
mod tests;
