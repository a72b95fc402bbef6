//! What the UI and a solver thread say to each other: the method settings, the slot a thread
//! serves, the [`PoseSolver`] it runs, the [`SolverCommand`]s in and the [`SolvedFrame`]s and
//! [`SolverStatus`] out.

use std::sync::Arc;
use std::time::Instant;

use solver::geometry::normals::VertexFaces;
use solver::{ComponentInfo, FrameStats, GroupTransform, Handles, LooseParts, Mesh};

use crate::editor::shape::Shape;

/// Method settings shown in the UI; sent whole to the solver thread, which rebuilds its pose
/// solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MethodSettings {
    /// The local-global iteration of every solve: energy (and the bending length of smooth
    /// rotations), the stopping rule (the tolerance below which a frame counts as converged,
    /// the iteration cap of one frame), the acceleration (plain or Anderson). Checked by
    /// [`solver::ArapConfig::validate`] wherever it comes from (a scene, the panel).
    pub arap: solver::ArapConfig,
    /// Which BS-ARAP variant the BS-ARAP slot runs.
    pub bs_variant: solver::Method,
    /// Base-surface settings of the BS-ARAP variants (smoothing, coarse vertex count, fine
    /// iterations).
    pub base: solver::BaseConfig,
    /// What the left viewport of the side-by-side view runs (ARAP by default).
    pub compare_variant: solver::Method,
}

/// Anderson window when the method panel's acceleration is on (Peng et al. 2018 use 5-6;
/// BENCHMARKS.md measures 5).
pub const ANDERSON_WINDOW: usize = 5;

impl Default for MethodSettings {
    fn default() -> Self {
        MethodSettings {
            // Smooth rotations (ℓ = 0.02 of the diagonal): one pose at every resolution, so the
            // coarse pose while dragging and the settled pose agree (docs/DESIGN.md, "Smooth
            // rotations"). Fewer iterations than the solver's default cap: a frame of a drag
            // should stay short.
            arap: solver::ArapConfig {
                energy: solver::Energy::SmoothRotations,
                max_iterations: 30,
                ..solver::ArapConfig::default()
            },
            // The paper's base is slow to precompute and collapses under small handles on the
            // default creature (see main's scenes); the coarse faired base is interactive.
            bs_variant: solver::Method::BsArapCoarse,
            // Once the handles stop, the coarse variant's pose is refined on the full mesh in
            // steps of 5 Anderson-accelerated ARAP iterations until they stop lowering the energy.
            // Its coarse level minimizes the full mesh's energy restricted to it (the Galerkin
            // coarse energy), so that the pose while dragging aims where settling ends
            // (docs/DESIGN.md, "The coarse energy").
            base: solver::BaseConfig {
                settle_iterations: 5,
                coarse_energy: solver::CoarseEnergy::Galerkin,
                ..solver::BaseConfig::default()
            },
            compare_variant: solver::Method::Arap,
        }
    }
}

impl MethodSettings {
    /// The solver's configuration for these settings (the editor's threads, its recording, and
    /// the scenes it saves use the same).
    pub fn arap_config(&self) -> solver::ArapConfig {
        self.arap
    }

    /// The base settings the solvers, recordings and saved scenes use: [`MethodSettings::base`],
    /// with the decimated coarse energy under an energy the Galerkin one does not restrict
    /// (the method panel shows this and keeps the choice for smooth rotations).
    pub fn base_config(&self) -> solver::BaseConfig {
        let mut base = self.base;
        if self.arap.energy != solver::Energy::SmoothRotations {
            base.coarse_energy = solver::CoarseEnergy::Decimated;
        }
        base
    }

    /// The method `slot` runs.
    pub fn method(&self, slot: Slot) -> solver::Method {
        match slot {
            Slot::Compare => self.compare_variant,
            Slot::Main => self.bs_variant,
        }
    }

    /// What the pose solver of `slot` is built from: the slot's method, the ARAP configuration
    /// and the part of the base configuration the method reads (`solver::DeformerOptions::base`:
    /// none for ARAP and the paper's BS-ARAP, the smoothing for the faired variant; the rest
    /// at its default). The other slot's method and settings its method does not read are not
    /// part of it, so changing them does not rebuild this slot's solver (the solver thread
    /// keeps it, see `worker::Active::serves`): the coarse level's settings side by side with
    /// ARAP, e.g.
    pub fn slot_part(
        &self,
        slot: Slot,
    ) -> (solver::Method, solver::ArapConfig, solver::BaseConfig) {
        let method = self.method(slot);
        let (all, default) = (self.base_config(), solver::BaseConfig::default());
        let base = match BaseRead::of(method) {
            BaseRead::Nothing => default,
            BaseRead::Smoothing => solver::BaseConfig { smoothing: all.smoothing, ..default },
            BaseRead::All => all,
        };
        (method, self.arap_config(), base)
    }

    /// What a saved scene holds of these settings (`editor::document::to_scene`): the method,
    /// the ARAP and the base configurations, but not settling or the side-by-side method,
    /// which are the editor's own.
    pub fn saved_part(&self) -> (solver::Method, solver::ArapConfig, solver::BaseConfig) {
        let base = solver::BaseConfig { settle_iterations: 0, ..self.base_config() };
        (self.bs_variant, self.arap_config(), base)
    }

    /// These settings with `part` (what a scene holds, [`MethodSettings::saved_part`]) in
    /// place of theirs: the editor's own, settling and the side-by-side method, stay.
    pub fn with_saved_part(
        self,
        (method, arap, base): (solver::Method, solver::ArapConfig, solver::BaseConfig),
    ) -> MethodSettings {
        let base = solver::BaseConfig { settle_iterations: self.base.settle_iterations, ..base };
        MethodSettings { arap, bs_variant: method, base, compare_variant: self.compare_variant }
    }

    /// A length given as a fraction of the rest bounding-box diagonal (the bending length), in
    /// world units for a mesh of diagonal `diagonal`.
    pub fn world_length(fraction: f64, diagonal: f64) -> f64 {
        fraction * diagonal
    }

    /// The energy the editor's quality measurement converges to: these settings' energy and
    /// bending length.
    pub fn reference_energy(&self) -> solver::deform::quality::ReferenceEnergy {
        solver::deform::quality::ReferenceEnergy {
            energy: self.arap.energy,
            bending_length: self.arap.bending_length,
        }
    }
}

/// Which of the base settings a method reads (`solver::DeformerOptions::base`), least first:
/// what a slot's solver is built from ([`MethodSettings::slot_part`]) and what the method
/// panel shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum BaseRead {
    /// ARAP and the paper's BS-ARAP.
    Nothing,
    /// The faired variant.
    Smoothing,
    /// The coarse variant: every one.
    All,
}

impl BaseRead {
    pub fn of(method: solver::Method) -> BaseRead {
        match method {
            solver::Method::Arap | solver::Method::BsArap => BaseRead::Nothing,
            solver::Method::BsArapFaired => BaseRead::Smoothing,
            solver::Method::BsArapCoarse => BaseRead::All,
        }
    }
}

/// Which solver slot a thread serves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Slot {
    /// The left viewport of the side-by-side view: runs [`MethodSettings::compare_variant`]
    /// (ARAP by default).
    Compare,
    /// The main viewport (the right one side by side): runs [`MethodSettings::bs_variant`].
    Main,
}

impl Slot {
    /// How the status bar names the slot (by the method it runs by default).
    pub fn label(self) -> &'static str {
        match self {
            Slot::Compare => "ARAP",
            Slot::Main => "BS-ARAP",
        }
    }
}

/// What a solver thread runs: a deformation method for one mesh and handle set, with its
/// precomputation done (factorization happens in the [`PoseSolverFactory`]). The editor's
/// own implementation wraps `solver::Deformer` (see `editor::pose_solvers`); tests plug in
/// trivial ones.
pub trait PoseSolver: Send {
    /// Solves for the group motions `poses` (`(group, transform)`: rotation about the group's
    /// rest centroid, then translation; groups not listed at rest), handed on as they are
    /// (`solver::Deformer::solve_groups`), warm started from the pose it holds; the result is
    /// [`PoseSolver::positions`].
    fn solve(&mut self, poses: &[(usize, GroupTransform)]) -> Result<FrameStats, String>;
    /// The first half of [`PoseSolver::solve`] where the solver splits a frame
    /// (`solver::Deformer::begin_groups`): [`PoseSolver::positions`] stays the last frame's
    /// until [`PoseSolver::finish_beside`]. The default solves the whole frame.
    fn begin(&mut self, poses: &[(usize, GroupTransform)]) -> Result<FrameStats, String> {
        self.solve(poses)
    }
    /// The second half: `publish` gets the begun frame's pose as soon as it is there, and
    /// `next` begins beside it ([`PoseSolver::begin`]; its statistics returned). The default
    /// publishes the current pose, then begins `next`.
    fn finish_beside(
        &mut self,
        next: Option<&[(usize, GroupTransform)]>,
        publish: &mut (dyn FnMut(&[[f64; 3]]) + Send),
    ) -> Result<Option<FrameStats>, String> {
        publish(self.positions());
        next.map(|poses| self.begin(poses)).transpose()
    }
    /// The pose it holds (`#V×3`): the rest pose until the first solve, then the last solve's
    /// or settle step's result. The thread makes each frame's shape from it without copying
    /// it (36 MB a frame at 1.5M vertices).
    fn positions(&self) -> &[[f64; 3]];
    /// The deformed base surface B' (BS-ARAP only), `#V×3`.
    fn deformed_base(&self) -> Option<Vec<[f64; 3]>> {
        None
    }
    /// Per-vertex detail magnitude |D_i| (BS-ARAP only), `#V`. Constant for a pose solver: the
    /// thread asks once per scene.
    fn detail_magnitudes(&self) -> Option<Vec<f64>> {
        None
    }
    /// The mesh's connected components as this pose solver treats them (which have handles,
    /// the loose parts' modes and what the following ones ride on); empty when it does not say
    /// (the default).
    fn components(&self) -> Vec<ComponentInfo> {
        Vec::new()
    }
    /// Whether [`PoseSolver::settle`] has work after the last solve (the default: never).
    fn settle_pending(&self) -> bool {
        false
    }
    /// Whether [`PoseSolver::settle`] can run now without a long wait: starts what it needs
    /// (a factorization) in the background when it is not started yet, so that the thread
    /// stays free for new poses meanwhile; the thread asks again while it waits (the default:
    /// always ready).
    fn settle_ready(&mut self) -> bool {
        true
    }
    /// Refines the last solve's converged pose, whose handles have stopped at the group
    /// motions `poses`, by a step (the result in [`PoseSolver::positions`]); the thread calls
    /// it until the stats say converged. `None`: nothing to refine (the default).
    fn settle(&mut self, _poses: &[(usize, GroupTransform)]) -> Result<Option<FrameStats>, String> {
        Ok(None)
    }
    /// Changes the loose parts' modes (no refactorization), the current pose with them in
    /// [`PoseSolver::positions`]; `mesh` and `handles` are the scene's. The default does
    /// nothing (a pose solver that does not move loose parts).
    fn set_loose_parts(
        &mut self,
        _mesh: &Mesh,
        _handles: &Handles,
        _parts: &LooseParts,
    ) -> Result<(), String> {
        Ok(())
    }
}

/// Builds a pose solver for a slot, a mesh, a handle set and the loose parts' modes (the slow
/// part: factorization). The last argument says whether the build is moot (a newer scene was
/// sent, or the thread is shutting down): a factory may stop where it can and return an
/// error, which the thread then drops unseen.
pub type PoseSolverFactory = Arc<
    dyn Fn(
            Slot,
            &Mesh,
            &Handles,
            &MethodSettings,
            &LooseParts,
            &dyn Fn() -> bool,
        ) -> Result<Box<dyn PoseSolver>, String>
        + Send
        + Sync,
>;

/// What a solver thread rebuilds its pose solver for ([`SolverCommand::SetScene`]).
#[derive(Clone)]
pub struct NewScene {
    pub scene_generation: u64,
    pub mesh: Arc<Mesh>,
    /// Each vertex's triangles in `mesh`, for the frames' normals (built once per mesh, by
    /// the loader).
    pub vertex_faces: Arc<VertexFaces>,
    pub handles: Option<Handles>,
    pub settings: MethodSettings,
    /// Follow or pin per component without handles.
    pub loose_parts: LooseParts,
    pub poses: Vec<GroupTransform>,
    /// The pose generation `poses` belong to.
    pub pose_generation: u64,
}

/// The closed set of messages the UI sends to a solver thread.
pub enum SolverCommand {
    /// A new mesh and/or handle set / method settings: rebuild the pose solver, unless what it
    /// is built from is unchanged for this slot (then the scene's generation and poses are
    /// taken and the current pose published again). Boxed: the other messages are small.
    SetScene(Box<NewScene>),
    /// What [`super::SolverHandle::send`] sends for a [`Self::SetScene`]: the scene of this
    /// generation waits in the handle's one slot, which a newer scene takes over (a method
    /// slider dragged while a solver is built queued a copy of the handle set a frame, and
    /// was given up only once the build ended).
    SceneWaiting(u64),
    /// New modes of the loose parts (no refactorization); the frame that shows them carries
    /// `pose_generation`.
    SetLooseParts {
        pose_generation: u64,
        loose_parts: LooseParts,
    },
    /// New group poses (no refactorization).
    SetPoses {
        pose_generation: u64,
        poses: Vec<GroupTransform>,
    },
    /// Publish the current pose again (the deformed base was asked for while the thread was
    /// idle; see [`super::SolverHandle::show_base`]).
    Republish,
    /// Test hook: make the worker panic, to exercise the recovery path.
    InjectPanic,
    Shutdown,
}

/// The newest solved frame.
#[derive(Debug, Clone)]
pub struct SolvedFrame {
    pub scene_generation: u64,
    pub pose_generation: u64,
    /// This frame's number, unique among every solver thread's frames: settling publishes new
    /// positions for the same generations, and a republished pose can differ in what it
    /// carries (normals), so the viewport keys its drawn shape on this.
    pub sequence: u64,
    pub positions: Arc<Vec<[f32; 3]>>,
    /// Vertex normals of `positions` (computed here, not on the UI thread), or none when the
    /// viewport computes them on the GPU ([`super::SolverHandle::normals_on_gpu`]).
    pub normals: Arc<Vec<[f32; 3]>>,
    /// The deformed base surface, while [`super::SolverHandle::show_base`] is on (BS-ARAP only).
    pub deformed_base: Option<Shape>,
    pub detail_magnitudes: Option<Arc<Vec<f32>>>,
    /// [`PoseSolver::components`] as of this frame (shared by the frames until the scene or
    /// the loose parts change).
    pub components: Arc<Vec<ComponentInfo>>,
    pub stats: FrameStats,
    /// Solved frames per second over the last frames while solving.
    pub fps: f64,
}

/// What the solver thread is doing, for the status bar.
#[derive(Debug, Clone, PartialEq)]
pub enum SolverState {
    /// No scene yet, or no handles.
    Idle,
    /// Building the pose solver (factorization, base surface) since the given instant.
    Factorizing {
        since: Instant,
    },
    Solving,
    /// The handles have stopped and the pose is being refined on the full mesh
    /// ([`PoseSolver::settle`]).
    Settling,
    Converged,
    Failed(String),
    /// The worker panicked with this message and restarted.
    Panicked(String),
}

#[derive(Debug, Clone)]
pub struct SolverStatus {
    pub state: SolverState,
    /// While settling is due but waits for the pose solver to prepare it (a finer level's
    /// factorization, [`PoseSolver::settle_ready`]), since when; `None` otherwise.
    pub settle_waiting_since: Option<Instant>,
    /// How many times the worker panicked and restarted.
    pub panics: usize,
}
