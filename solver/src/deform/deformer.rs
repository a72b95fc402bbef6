//! One interface over the deformation methods, for the CLI and the editor's solver threads,
//! with the loose parts (components without handles) following or pinned
//! ([`crate::deform::riders`]).

use crate::deform::arap::{Arap, ArapConfig, SolveStats};
use crate::deform::bs_arap::{BaseKind, BsArap};
use crate::deform::coarse::CoarseBsArap;
use crate::deform::coarse::base::CoarseBase;
use crate::deform::coarse::cache as coarse_cache;
use crate::deform::coarse::galerkin::galerkin_mesh;
use crate::deform::config::BaseConfig;
use crate::deform::handles::Handles;
use crate::deform::pose::{GroupRest, GroupTransform};
use crate::deform::riders::{LooseParts, Riders};
use crate::error::SolveError;
use crate::geometry::mesh::Mesh;
use crate::linalg::rigid::Motion;
use crate::pool::in_pool;
use std::ops::ControlFlow;
use std::sync::Arc;

/// The most settle steps at one pose, and the most solves [`Deformer::solve_to_rest`] runs
/// before them: a method whose steps never say converged stops here (the editor, the CLI and
/// Python share it).
pub const MAX_SETTLE_STEPS: usize = 2000;

/// What [`Deformer::solve_to_rest`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct AtRest {
    /// Solves run (each up to the stopping rule's iterations).
    pub solves: usize,
    /// Whether the last solve met the tolerance.
    pub converged: bool,
    /// Settle steps run after it.
    pub settle_steps: usize,
    /// Whether nothing is left to settle (a converged solve, and a settle step that said
    /// converged, or nothing to settle).
    pub settled: bool,
    /// Local-global iterations of all solves and steps, fine iterations included.
    pub iterations: usize,
    /// The energy of the last solve or settle step: the full mesh's after iterations on it,
    /// else what its method minimizes (the coarse level's, the base's).
    pub energy: f64,
}

/// The energy a solve's statistics give of the full mesh where its fine or settle iterations
/// ran on it ([`crate::FrameStats::fine_energy`]), else its own ([`SolveStats::energy`]).
fn mesh_energy(stats: &SolveStats) -> f64 {
    stats.frame_stats().fine_energy.unwrap_or_else(|| stats.energy())
}

/// The deformation method.
/// Serialized as [`Method::name`] (scenes, JSON reports).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum Method {
    /// ARAP on the mesh itself.
    #[serde(rename = "arap")]
    Arap,
    /// The paper's BS-ARAP: ARAP on the bi-harmonic base, details rotated with it.
    #[default]
    #[serde(rename = "bsarap", alias = "bs-arap")]
    BsArap,
    /// BS-ARAP on a faired base that does not collapse (bi-Laplacian with a data term).
    #[serde(rename = "bsarap-faired")]
    BsArapFaired,
    /// Faired base, decimated: ARAP runs on a coarse copy, details prolonged to the full mesh.
    #[serde(rename = "bsarap-coarse")]
    BsArapCoarse,
}

impl Method {
    /// Short name used by the CLI and in reports (`arap`, `bsarap`).
    pub fn name(self) -> &'static str {
        match self {
            Method::Arap => "arap",
            Method::BsArap => "bsarap",
            Method::BsArapFaired => "bsarap-faired",
            Method::BsArapCoarse => "bsarap-coarse",
        }
    }

    /// Every method, in the order reports list them.
    pub const ALL: [Method; 4] =
        [Method::Arap, Method::BsArap, Method::BsArapFaired, Method::BsArapCoarse];

    /// Parses a [`Method::name`].
    pub fn from_name(name: &str) -> Option<Method> {
        Method::ALL.into_iter().find(|m| m.name() == name)
    }
}

/// The solver of one method (what a [`Deformer`] runs).
#[derive(Debug)]
pub enum Solver {
    Arap(Arap),
    BsArap(BsArap),
    Coarse(Box<CoarseBsArap>),
}

impl Solver {
    /// The solver's result of the last solve, loose parts at rest (`#V×3`).
    pub fn positions(&self) -> &[[f64; 3]] {
        match self {
            Solver::Arap(a) => a.positions(),
            Solver::BsArap(b) => b.positions(),
            Solver::Coarse(c) => c.positions(),
        }
    }

    /// The solver's deformed base, loose parts at rest; `None` for ARAP.
    pub fn deformed_base(&self) -> Option<&[[f64; 3]]> {
        match self {
            Solver::Arap(_) => None,
            Solver::BsArap(b) => Some(b.deformed_base()),
            Solver::Coarse(c) => Some(c.deformed_base()),
        }
    }
}

/// What the methods precompute per mesh whatever the handles, kept for the next handle set
/// of the same mesh: the coarse BS-ARAP's [`CoarseBase`] (the other methods' precomputation
/// all depends on the handles). Entries are checked against the mesh and settings before
/// reuse ([`CoarseBase::fits`]); a cache holds one mesh's entry at a time. With a directory
/// ([`MeshCache::on_disk`]) it also keeps each base in a file there
/// ([`crate::deform::coarse::cache`]), so that reopening a mesh reads it instead of building it.
#[derive(Debug, Clone, Default)]
pub struct MeshCache {
    coarse: Option<Arc<CoarseBase>>,
    disk: Option<std::path::PathBuf>,
    /// Why the last file was not read or written (none: read, written, or no directory).
    disk_note: Option<String>,
}

/// A base [`MeshCache::prepare_unwritten`] built and did not write to its file yet.
#[derive(Debug)]
pub struct UnwrittenBase {
    base: Arc<CoarseBase>,
    path: std::path::PathBuf,
}

impl UnwrittenBase {
    /// Writes the file ([`coarse_cache::save`]: a temporary file renamed over it); the error
    /// in words.
    pub fn write(self) -> Result<(), String> {
        coarse_cache::save(&self.base, &self.path)
            .map_err(|e| format!("writing {}: {e}", self.path.display()))
    }
}

impl MeshCache {
    /// A cache that also reads and writes its bases as files in `dir` (created when first
    /// written).
    pub fn on_disk(dir: std::path::PathBuf) -> MeshCache {
        MeshCache { disk: Some(dir), ..MeshCache::default() }
    }

    /// Why the last [`MeshCache::prepare`] did not read its file, or could not write it: a
    /// stale or damaged file (never used, rebuilt and rewritten), an unreadable directory, a
    /// full disk. A new mesh's missing file is not worth a note.
    pub fn disk_note(&self) -> Option<&str> {
        self.disk_note.as_deref()
    }

    /// Builds (or finds) what `method` precomputes per mesh for `mesh` and `base`: the
    /// [`CoarseBase`] for [`Method::BsArapCoarse`] (with the Galerkin coarse energy's mesh part
    /// when `base` asks for that energy), `None` for the other methods. Call it
    /// right after loading, in the background, so that the first handle set waits only for
    /// its own part. A base built anew, or one that gained its Galerkin part, is written to
    /// the cache directory before it returns.
    pub fn prepare(
        &mut self,
        method: Method,
        mesh: &Mesh,
        base: &BaseConfig,
    ) -> Result<Option<Arc<CoarseBase>>, SolveError> {
        let (c, unwritten) = self.prepare_unwritten(method, mesh, base, &|| false)?;
        if let Some(w) = unwritten
            && let Err(e) = w.write()
        {
            self.disk_note = Some(e);
        }
        Ok(c)
    }

    /// [`MeshCache::prepare`] that leaves the writing of a base built anew to the caller
    /// ([`UnwrittenBase::write`]), so that a cache shared between threads need not be held
    /// while the file is written (about 50 MiB at 1.5M vertices). Once `stop` returns true a
    /// base not found in the cache is not read or built: [`SolveError::Cancelled`], before
    /// the cached one is let go (asked already), between the build's stages
    /// ([`CoarseBase::new_until`]; nothing is kept), or before the Galerkin part is gathered
    /// (the base is kept, without it).
    pub fn prepare_unwritten(
        &mut self,
        method: Method,
        mesh: &Mesh,
        base: &BaseConfig,
        stop: &(dyn Fn() -> bool + Sync),
    ) -> Result<(Option<Arc<CoarseBase>>, Option<UnwrittenBase>), SolveError> {
        if method != Method::BsArapCoarse {
            return Ok((None, None));
        }
        let path = self.disk.as_ref().map(|dir| coarse_cache::cache_path(dir, mesh, base));
        let (c, built) = match self.coarse.clone().filter(|c| c.fits(mesh, base)) {
            Some(c) => (c, false),
            // Stopped before it began: the cached base (another mesh's, maybe the one wanted
            // now) stays.
            None if stop() => return Err(SolveError::Cancelled),
            None => {
                self.coarse = None;
                self.disk_note = None;
                let (c, built) = match path.as_ref().map(|p| coarse_cache::load(p, mesh, base)) {
                    Some(Ok(c)) => (c, false),
                    other => {
                        // A mesh opened for the first time has no file yet: nothing to say.
                        if let Some(Err(e)) = other
                            && !e.is_missing()
                        {
                            self.disk_note = Some(e.to_string());
                        }
                        (in_pool(|| CoarseBase::new_until(mesh, base, stop))?, true)
                    }
                };
                let c = Arc::new(c);
                self.coarse = Some(c.clone());
                (c, built)
            }
        };
        // Written when built anew, or when it gained its Galerkin part now.
        let gathered = gather_galerkin(&c, mesh, base, stop)?;
        let path = path.filter(|_| built || gathered);
        let unwritten = path.map(|path| UnwrittenBase { base: c.clone(), path });
        Ok((Some(c), unwritten))
    }

    /// The cached coarse base, if any (whatever mesh it belongs to).
    pub fn coarse_base(&self) -> Option<&Arc<CoarseBase>> {
        self.coarse.as_ref()
    }
}

/// Gathers the Galerkin coarse energy's mesh part of `coarse` when `base` asks for that
/// energy ([`galerkin_mesh`]; nothing when gathered already, or read from the
/// disk cache). Whether it gathered it now; [`SolveError::Cancelled`] when `stop` says so
/// before it begins.
fn gather_galerkin(
    coarse: &CoarseBase,
    mesh: &Mesh,
    base: &BaseConfig,
    stop: &(dyn Fn() -> bool + Sync),
) -> Result<bool, SolveError> {
    let wanted = base.coarse_energy == crate::deform::config::CoarseEnergy::Galerkin;
    if !wanted || coarse.galerkin.get().is_some() {
        return Ok(false);
    }
    if stop() {
        return Err(SolveError::Cancelled);
    }
    in_pool(|| galerkin_mesh(coarse, mesh))?;
    Ok(true)
}

/// A precomputed deformer of any method, with the loose parts riding along
/// ([`crate::deform::riders`]): components without handles are fixed at rest in the solve,
/// then the following ones are moved rigidly with their anchor patch in
/// [`Deformer::positions`] and [`Deformer::deformed_base`] (the solver's own views keep them
/// at rest).
#[derive(Debug)]
pub struct Deformer {
    solver: Solver,
    riders: Riders,
    /// The solver's pose with the riders moved; unused (empty) when no component follows.
    positions: Vec<[f64; 3]>,
    /// The same for the deformed base.
    base: Vec<[f64; 3]>,
    /// What group motions act on ([`Deformer::solve_groups`]).
    group_rest: GroupRest,
    /// The per-vertex targets of the last group motions solved, begun or settled, and the
    /// groups' motions.
    group_targets: Vec<[f64; 3]>,
    group_motions: Vec<Motion>,
}

/// `pose` with the following loose parts moved with their anchor patches, into `out`; returns
/// the riders' motions.
fn ride_pose(riders: &Riders, pose: &[[f64; 3]], out: &mut Vec<[f64; 3]>) -> Vec<Motion> {
    out.clear();
    out.extend_from_slice(pose);
    riders.ride(out)
}

/// How [`Deformer::new`] builds a deformer, besides the mesh and the handles. Every field
/// has a default, so a call names only what it sets:
/// `DeformerOptions { method: Method::Arap, config, ..Default::default() }`. Passed by value,
/// since it may lend the `&mut` [`MeshCache`].
#[derive(Debug, Default)]
pub struct DeformerOptions<'a> {
    /// The deformation method (default [`Method::BsArap`]).
    pub method: Method,
    /// The ARAP iterations' settings, for every method: energy, stopping rule, acceleration
    /// (default [`ArapConfig::default`]).
    pub config: ArapConfig,
    /// The base surface's settings: the smoothing of [`Method::BsArapFaired`], all of them for
    /// [`Method::BsArapCoarse`]; [`Method::Arap`] and [`Method::BsArap`] ignore it (default
    /// [`BaseConfig::default`]).
    pub base: BaseConfig,
    /// The modes of the components without handles; `None` (the default):
    /// [`LooseParts::default`], every loose part follows its anchor patch. They can be changed
    /// later without refactoring ([`Deformer::set_loose_parts`]).
    pub loose_parts: Option<&'a LooseParts>,
    /// Where what depends on the mesh only is taken from, or built and kept
    /// ([`MeshCache::prepare`]): a new handle set of the same mesh then costs only its own
    /// part. Only [`Method::BsArapCoarse`] precomputes per mesh. `None` (the default): built
    /// for this deformer alone and not kept.
    pub cache: Option<&'a mut MeshCache>,
}

impl Deformer {
    /// Precomputes `options.method` for `mesh` and `handles` (factorizations; may take
    /// seconds), with the settings, loose parts and cache of `options` ([`DeformerOptions`]).
    pub fn new(
        mesh: &Mesh,
        handles: &Handles,
        options: DeformerOptions<'_>,
    ) -> Result<Deformer, SolveError> {
        let DeformerOptions { method, config, base, loose_parts, cache } = options;
        // The settings as the command line, scenes and Python check them (an Anderson window of
        // 2²⁰ took the memory, a coarse size of usize::MAX overflowed, a NaN smoothing faired
        // nothing and blamed the geometry).
        config.validate()?;
        base.validate()?;
        let (config, base) = (&config, &base);
        let all_follow = LooseParts::default();
        let parts = loose_parts.unwrap_or(&all_follow);
        let mut own_cache = MeshCache::default();
        let cache = cache.unwrap_or(&mut own_cache);
        let solver = match method {
            Method::Arap => Solver::Arap(Arap::new(mesh, handles, config)?),
            Method::BsArap => Solver::BsArap(BsArap::new(mesh, handles, config)?),
            Method::BsArapFaired => Solver::BsArap(BsArap::with_base(
                mesh,
                handles,
                config,
                BaseKind::Faired { smoothing: base.smoothing },
            )?),
            Method::BsArapCoarse => {
                let coarse = match cache.prepare(method, mesh, base)? {
                    Some(c) => c,
                    None => Arc::new(CoarseBase::new(mesh, base)?),
                };
                Solver::Coarse(Box::new(CoarseBsArap::with_base(
                    coarse, mesh, handles, config, base,
                )?))
            }
        };
        let mut d = Deformer {
            solver,
            riders: Riders::new(mesh, Some(handles), parts),
            positions: Vec::new(),
            base: Vec::new(),
            group_rest: GroupRest::new(mesh.positions(), handles),
            group_targets: Vec::new(),
            group_motions: Vec::new(),
        };
        d.ride();
        Ok(d)
    }

    /// Changes the loose parts' modes without refactoring (cheap: no solve, no factorization);
    /// the current pose is updated. `mesh` and `handles` must be those the deformer was built
    /// for (other vertex counts are an error).
    pub fn set_loose_parts(
        &mut self,
        mesh: &Mesh,
        handles: &Handles,
        parts: &LooseParts,
    ) -> Result<(), SolveError> {
        let n = self.solver_positions().len();
        for got in [mesh.n_vertices(), handles.n_vertices()] {
            if got != n {
                return Err(SolveError::HandleCount { got, expected: n });
            }
        }
        self.riders = Riders::new(mesh, Some(handles), parts);
        self.ride();
        Ok(())
    }

    /// The components without handles and their anchor patches.
    pub fn riders(&self) -> &Riders {
        &self.riders
    }

    /// The method's solver. Its positions keep following loose parts at rest.
    pub fn solver(&self) -> &Solver {
        &self.solver
    }

    /// The method's solver, mutably (stopping rules, starting guesses); a pose set through it
    /// reaches [`Deformer::positions`] at the next solve, settle or reset.
    pub fn solver_mut(&mut self) -> &mut Solver {
        &mut self.solver
    }

    /// Moves the following loose parts with their anchor patches in the published pose.
    fn ride(&mut self) {
        if self.riders.is_empty() {
            return;
        }
        let motions = ride_pose(&self.riders, self.solver.positions(), &mut self.positions);
        self.ride_base(&motions);
    }

    /// Moves the following loose parts of the deformed base by the riders' `motions`.
    fn ride_base(&mut self, motions: &[Motion]) {
        self.base.clear();
        if let Some(b) = self.solver.deformed_base() {
            self.base.extend_from_slice(b);
            self.riders.apply(motions, &mut self.base);
        }
    }

    fn solver_positions(&self) -> &[[f64; 3]] {
        self.solver.positions()
    }

    /// Solves for `targets` (`#H×3`, order of [`Handles::handle_vertices`]), warm-started.
    /// The whole solve runs on rayon's pool (`pool::in_pool`); the loose parts
    /// follow after it.
    pub fn solve(&mut self, targets: &[[f64; 3]]) -> Result<SolveStats, SolveError> {
        let result = in_pool(|| match &mut self.solver {
            Solver::Arap(a) => a.solve(targets),
            Solver::BsArap(b) => b.solve(targets),
            Solver::Coarse(c) => c.solve(targets),
        });
        self.ride();
        result
    }

    /// Solves for the handle groups moved by `transforms` (`(group, transform)` pairs; groups
    /// not listed stay at rest), warm-started: the group motions as they are, per-vertex
    /// targets ([`GroupRest::targets`], [`Deformer::group_targets`]) derived here for the
    /// methods that hold vertices. The coarse BS-ARAP moves its coarse handles by the motions
    /// themselves ([`CoarseBsArap::solve_groups`]) instead of fitting them back to the targets.
    /// An unknown group is an error.
    pub fn solve_groups(
        &mut self,
        transforms: &[(usize, GroupTransform)],
    ) -> Result<SolveStats, SolveError> {
        self.group_rest.targets(transforms, &mut self.group_targets)?;
        let targets = &self.group_targets;
        let result = match &mut self.solver {
            Solver::Arap(a) => in_pool(|| a.solve(targets)),
            Solver::BsArap(b) => in_pool(|| b.solve(targets)),
            Solver::Coarse(c) => {
                self.group_rest.motions(transforms, &mut self.group_motions)?;
                let motions = &self.group_motions;
                in_pool(|| c.solve_groups(targets, motions))
            }
        };
        self.ride();
        result
    }

    /// The first half of [`Deformer::solve_groups`] for the coarse BS-ARAP
    /// ([`CoarseBsArap::begin_groups`]): its coarse solve, whose pose the next
    /// [`Deformer::finish_beside`] prolongs and publishes. The other methods, and the coarse
    /// one with fine iterations, solve the whole frame here.
    pub fn begin_groups(
        &mut self,
        transforms: &[(usize, GroupTransform)],
    ) -> Result<SolveStats, SolveError> {
        let Solver::Coarse(c) = &mut self.solver else { return self.solve_groups(transforms) };
        if !c.pipelines() {
            return self.solve_groups(transforms);
        }
        self.group_rest.targets(transforms, &mut self.group_targets)?;
        self.group_rest.motions(transforms, &mut self.group_motions)?;
        let (targets, motions) = (&self.group_targets, &self.group_motions);
        in_pool(|| c.begin_groups(targets, motions))
    }

    /// The second half: `publish` gets the begun frame's pose (loose parts moved) as soon as it
    /// is there, and the group motions `next` begin beside it ([`CoarseBsArap::finish_beside`];
    /// their statistics returned). Without a begun frame, `publish` gets the current pose and
    /// `next` begins ([`Deformer::begin_groups`]). Motions `next` that give no targets (an
    /// unknown group, a move beyond the coordinate limit) are an error once the begun frame
    /// is finished and published.
    pub fn finish_beside(
        &mut self,
        next: Option<&[(usize, GroupTransform)]>,
        publish: &mut (dyn FnMut(&[[f64; 3]]) + Send),
    ) -> Result<Option<SolveStats>, SolveError> {
        let c = match &mut self.solver {
            Solver::Coarse(c) if c.pending() => c,
            _ => {
                publish(self.positions());
                return next.map(|t| self.begin_groups(t)).transpose();
            }
        };
        let refused = next.and_then(|t| {
            let targets = self.group_rest.targets(t, &mut self.group_targets);
            targets.and_then(|()| self.group_rest.motions(t, &mut self.group_motions)).err()
        });
        let next = next
            .filter(|_| refused.is_none())
            .map(|_| (self.group_targets.as_slice(), self.group_motions.as_slice()));
        let (riders, positions) = (&self.riders, &mut self.positions);
        let mut rode = None;
        let mut ride_and_publish = |p: &[[f64; 3]]| {
            if riders.is_empty() {
                publish(p);
            } else {
                rode = Some(ride_pose(riders, p, positions));
                publish(positions);
            }
        };
        let result = in_pool(|| c.finish_beside(next, &mut ride_and_publish));
        if let Some(motions) = rode {
            self.ride_base(&motions);
        }
        match refused {
            Some(e) => result.and(Err(e.into())),
            None => result,
        }
    }

    /// [`Deformer::settle`] at the targets of the group motions `transforms` (those of the
    /// last [`Deformer::solve_groups`] to refine it).
    pub fn settle_groups(
        &mut self,
        transforms: &[(usize, GroupTransform)],
    ) -> Result<Option<SolveStats>, SolveError> {
        let mut targets = std::mem::take(&mut self.group_targets);
        let result = self.group_rest.targets(transforms, &mut targets).map_err(SolveError::from);
        let result = result.and_then(|()| self.settle(&targets));
        self.group_targets = targets;
        result
    }

    /// Solves at the group motions `transforms` as an editor does once its handles stop:
    /// [`Deformer::solve_groups`] again, warm-started, until a solve converges, then
    /// [`Deformer::settle_groups`] until a step says converged (the methods without settling,
    /// or a deformer without settle iterations, have no steps). At most `max_steps` solves and
    /// as many settle steps.
    pub fn solve_to_rest(
        &mut self,
        transforms: &[(usize, GroupTransform)],
        max_steps: usize,
    ) -> Result<AtRest, SolveError> {
        let mut rest = AtRest::default();
        self.solve_to_rest_with(transforms, max_steps, &mut rest, &mut || {
            ControlFlow::Continue(())
        })?;
        Ok(rest)
    }

    /// [`Deformer::solve_to_rest`] for a caller that may stop it (Python's Ctrl-C): `between()`
    /// is asked before every step but the first, and `Break` stops there, the deformer as
    /// after the last step that ran (`rest.settled` false). `rest` counts what ran as it goes,
    /// also before an error.
    pub fn solve_to_rest_with(
        &mut self,
        transforms: &[(usize, GroupTransform)],
        max_steps: usize,
        rest: &mut AtRest,
        between: &mut dyn FnMut() -> ControlFlow<()>,
    ) -> Result<(), SolveError> {
        *rest = AtRest::default();
        while rest.solves < max_steps.max(1) {
            if rest.solves > 0 && between().is_break() {
                return Ok(());
            }
            let stats = self.solve_groups(transforms)?;
            rest.solves += 1;
            rest.iterations += stats.iterations + stats.fine_iterations;
            rest.converged = stats.converged;
            rest.energy = mesh_energy(&stats);
            if stats.converged || stats.iterations == 0 {
                break;
            }
        }
        // Settled unless a step left more to do (`None`: nothing to settle).
        let mut settled = true;
        while rest.converged && rest.settle_steps < max_steps {
            if between().is_break() {
                return Ok(());
            }
            let Some(stats) = self.settle_groups(transforms)? else { break };
            rest.settle_steps += 1;
            rest.iterations += stats.iterations + stats.fine_iterations;
            rest.energy = mesh_energy(&stats);
            settled = stats.converged;
            if settled {
                break;
            }
        }
        rest.settled = rest.converged && settled && !self.settle_pending();
        Ok(())
    }

    /// The per-vertex targets (`#H×3`, order of [`Handles::handle_vertices`]) the last
    /// [`Deformer::solve_groups`], [`Deformer::settle_groups`], [`Deformer::begin_groups`] or
    /// next frame of [`Deformer::finish_beside`] derived (a begun frame's, while its pose is not
    /// yet [`Deformer::positions`]); empty before any.
    pub fn group_targets(&self) -> &[[f64; 3]] {
        &self.group_targets
    }

    /// What group motions act on: the groups' rest centroids and the handles' rest positions.
    pub fn group_rest(&self) -> &GroupRest {
        &self.group_rest
    }

    /// Whether [`Deformer::settle`] has work after the last solve (then the caller should call
    /// it with the same targets until it says converged).
    pub fn settle_pending(&self) -> bool {
        match &self.solver {
            Solver::Coarse(c) => c.settle_pending(),
            Solver::Arap(_) | Solver::BsArap(_) => false,
        }
    }

    /// Whether [`Deformer::settle`] can run now without waiting for a factorization. The coarse
    /// method first starts factoring what settling needs on a thread of its own
    /// ([`CoarseBsArap::factor_fine_in_background`]), so a caller that must stay responsive
    /// (the editor's solver thread) asks again until this says true, then settles; the other
    /// methods have nothing to factor (true).
    pub fn settle_ready(&mut self) -> bool {
        match &mut self.solver {
            Solver::Coarse(c) => c.factor_fine_in_background(),
            Solver::Arap(_) | Solver::BsArap(_) => true,
        }
    }

    /// Refines the last solve's pose once its handles have stopped at `targets`
    /// ([`CoarseBsArap::settle`]); `None` when there is nothing to refine (other methods: their
    /// solve already iterates on the full mesh to the tolerance).
    pub fn settle(&mut self, targets: &[[f64; 3]]) -> Result<Option<SolveStats>, SolveError> {
        let result = in_pool(|| match &mut self.solver {
            Solver::Coarse(c) => c.settle(targets),
            Solver::Arap(_) | Solver::BsArap(_) => Ok(None),
        });
        if matches!(result, Ok(Some(_))) {
            self.ride();
        }
        result
    }

    /// The deformed positions of the last solve (rest before any), `#V×3`, loose parts
    /// included.
    pub fn positions(&self) -> &[[f64; 3]] {
        if self.riders.is_empty() { self.solver_positions() } else { &self.positions }
    }

    /// The deformed base surface $B'$ of the last solve at the mesh's vertices (`#V×3`, loose
    /// parts moved as in [`Deformer::positions`]); `None` for ARAP, which has no base.
    pub fn deformed_base(&self) -> Option<&[[f64; 3]]> {
        let base = self.solver.deformed_base();
        if self.riders.is_empty() { base } else { base.map(|_| self.base.as_slice()) }
    }

    /// Details $D = M - B$ at rest (`#V×3`); `None` for ARAP.
    pub fn details(&self) -> Option<&[[f64; 3]]> {
        match &self.solver {
            Solver::Arap(_) => None,
            Solver::BsArap(b) => Some(b.details()),
            Solver::Coarse(c) => Some(c.details()),
        }
    }

    /// The ARAP solver doing the iterations (on $M$ or on $B$); `None` for the coarse variant
    /// with the Galerkin coarse energy ([`crate::CoarseEnergy::Galerkin`]), which iterates on
    /// no mesh of its own.
    pub fn arap(&self) -> Option<&Arap> {
        match &self.solver {
            Solver::Arap(a) => Some(a),
            Solver::BsArap(b) => Some(b.base_arap()),
            Solver::Coarse(c) => c.base_arap(),
        }
    }

    /// The ARAP solver doing the iterations, mutably (starting guesses, benchmarks); see
    /// [`Deformer::solver_mut`] and [`Deformer::arap`].
    pub fn arap_mut(&mut self) -> Option<&mut Arap> {
        match &mut self.solver {
            Solver::Arap(a) => Some(a),
            Solver::BsArap(b) => Some(b.base_arap_mut()),
            Solver::Coarse(c) => c.base_arap_mut(),
        }
    }

    /// Changes the stopping rule without refactoring.
    pub fn set_stopping(&mut self, tolerance: f64, max_iterations: usize) {
        match &mut self.solver {
            Solver::Arap(a) => a.set_stopping(tolerance, max_iterations),
            Solver::BsArap(b) => b.base_arap_mut().set_stopping(tolerance, max_iterations),
            Solver::Coarse(c) => c.set_stopping(tolerance, max_iterations),
        }
    }

    /// Restarts the next solve from rest.
    pub fn reset(&mut self) {
        match &mut self.solver {
            Solver::Arap(a) => a.reset(),
            Solver::BsArap(b) => b.reset(),
            Solver::Coarse(c) => c.reset(),
        }
        self.ride();
    }

    /// A sentence for the UI and the CLI about the loose parts ([`Riders::notice`]).
    pub fn notice(&self) -> Option<String> {
        self.riders.notice()
    }
}
