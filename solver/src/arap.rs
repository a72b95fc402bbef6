//! As-Rigid-As-Possible surface deformation (Sorkine & Alexa 2007) by local-global iteration.
//!
//! Energy (Sun et al. 2017, Eq. 3), over cells $\mathcal{C}_i$ of rest edges $e_{jk}=p_j-p_k$:
//! $$E(p') = \sum_i \sum_{(j,k)\in\mathcal{C}_i} w_{jk}\,\lVert (p'_j-p'_k) - R_i(p_j-p_k)\rVert^2.$$
//! - [`Energy::SpokesAndRims`] (default; Chao et al. 2010, the paper's Eq. 2, libigl's default
//!   for surfaces): the cell of vertex $i$ is every edge of every triangle around $i$, with the
//!   per-triangle weight $\tfrac12\cot$ of the opposite angle. Negative weights are kept.
//! - [`Energy::Spokes`]: the cell of $i$ is its one-ring edges $(i,j)$, weight $w_{ij}$, clamped
//!   at zero (negative spoke weights can make the local fit meaningless).
//!
//! **Local step** (Eq. 5): $S_i = \sum w_{jk} e_{jk} e'^\top_{jk}$, $R_i$ from
//! [`crate::rotation::fit_rotations_near`] (quaternion fit started from the previous $R_i$, four
//! cells at a time); parallel over vertices (rayon).
//! **Global step** (Eq. 4): $L_{FF}\,p'_F = b_F - L_{FH}\,p'_H$ with
//! $b_j = \sum_{t}\sum_{(j,k)\in t} w^t_{jk}\,\bar R_t\,e_{jk}$, $\bar R_t$ the mean of the three
//! rotations of triangle $t$ (spokes and rims), or $b_i = \sum_j \tfrac{w_{ij}}2(R_i+R_j)e_{ij}$
//! (spokes). $L_{FF}$ is factored once per handle set ([`crate::linsolve::SpdFactor`]); an
//! iteration is one 3-column back-substitution.
//!
//! Each local and each global step weakly decreases $E$; iteration stops when the relative
//! decrease $(E_{k-1}-E_k)/E_{k-1}$ falls below the tolerance, or at the iteration cap.
//!
//! Layout: the solver numbers the vertices in reverse Cuthill–McKee order
//! ([`crate::reorder`]) so that one-ring gathers stay in cache; poses, rotations and errors at
//! its interface are in the mesh's own order.
//!
//! Inputs: a [`Mesh`] (`#V×3`, `#F×3`), [`Handles`], an [`ArapConfig`]; targets `#H×3` in the
//! order of [`Handles::handle_vertices`]. Known limitation: convergence is linear, slow for
//! large rotations of far-apart handles (what BS-ARAP's smooth base is meant to help with).

use crate::constraints::Constraints;
use crate::cotan::{edge_weights, face_cotangents_or, laplacian_triplets, opposite_edge};
use crate::error::SolveError;
use crate::handles::Handles;
use crate::linsolve::{Layout, SpdFactor};
use crate::mesh::{Mesh, add, sub};
use crate::reorder::VertexOrder;
use crate::rotation::{
    IDENTITY, LANES, Mat3, add_mat, add_outer, fit_rotation_near, fit_rotations_near, mul_vec,
    scale_mat, trace_of_product,
};
use faer::MatMut;
use faer::sparse::Triplet;
use rayon::prelude::*;
use std::time::Instant;

#[cfg(target_arch = "x86_64")]
mod avx;

/// Whether this processor runs the AVX2 build of the covariance pass.
fn avx2_detected() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Runs `f` on a thread of rayon's pool. Called from outside the pool (the editor's solver
/// thread, the command line's main thread), every parallel pass inside `f` would otherwise be
/// handed to the pool and waited for by a sleeping caller, two thread switches per pass; on a
/// worker, `join` runs one half itself and the other may be taken by the second worker. On a
/// 2,000-vertex coarse level (Cheburashka's) an iteration took 0.30–0.35 ms instead of
/// 0.41–0.45, the rhs 0.026–0.035 ms instead of 0.050–0.057 (BENCHMARKS.md, "Eighth round").
pub(crate) fn in_pool<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    if rayon::current_thread_index().is_some() { f() } else { rayon::scope(|_| f()) }
}

/// Vertices per parallel task for a mesh of `n` vertices: a sixteenth of the mesh, between
/// 256 and 2048, a multiple of [`LANES`]. Sixteen tasks balance two threads (a 6,669-vertex mesh
/// in 2048-vertex tasks split 4096 : 2573 and its iterations took 15–17 % longer than in
/// 420-vertex tasks); tasks of at least 256 vertices (about 0.05 ms of work) keep the wake-ups
/// and joins a small share. The task size also fixes the blocks of the energy's sums, so
/// results do not depend on the number of threads.
fn vertices_per_task(n: usize) -> usize {
    n.div_ceil(16).clamp(256, 2048).next_multiple_of(LANES)
}

/// Vertices whose covariances [`Arap::local_pass`] computes and fits at a time (4.6 KB of
/// covariances), a multiple of [`LANES`] so that the fits' sums run as over the whole block.
const SCRATCH: usize = 64;

/// Anderson window of [`Arap::refine`].
pub const REFINE_ANDERSON_WINDOW: usize = 5;

/// The ARAP cell type.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Energy {
    /// Every edge of the triangles around a vertex (Chao et al. 2010). The default.
    #[default]
    SpokesAndRims,
    /// The one-ring edges of a vertex (Sorkine & Alexa 2007).
    Spokes,
}

/// How the local-global iteration is accelerated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Acceleration {
    /// Plain local-global (Sorkine & Alexa 2007). The default.
    #[default]
    None,
    /// Anderson acceleration of the free positions with a window of `window` past steps
    /// (Peng et al. 2018; [`crate::anderson`]), safeguarded: an accelerated iterate whose
    /// energy $E(x, R(x))$ exceeds the last accepted one is replaced by the plain step.
    Anderson { window: usize },
}

/// Settings of the local-global iteration.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ArapConfig {
    /// Cell type of the energy. Default: spokes and rims.
    pub energy: Energy,
    /// Stop when the relative energy decrease of an iteration falls below this (unitless).
    /// `0` runs exactly `max_iterations`. Default `1e-4` (the reference run of DESIGN.md §5).
    pub tolerance: f64,
    /// Iteration cap per solve. Default 100.
    pub max_iterations: usize,
    /// Acceleration of the loop. Default none (plain local-global).
    #[serde(default)]
    pub acceleration: Acceleration,
    /// Also stop once $E_k \le$ `energy_threshold`$\cdot E_0$, $E_0$ the energy of the solve's
    /// starting guess: the paper's absolute threshold on the energy normalized to 0–1 (its
    /// Fig. 10). `0` (the default) disables it.
    #[serde(default)]
    pub energy_threshold: f64,
}

impl Default for ArapConfig {
    fn default() -> Self {
        ArapConfig {
            energy: Energy::SpokesAndRims,
            tolerance: 1e-4,
            max_iterations: 100,
            acceleration: Acceleration::None,
            energy_threshold: 0.0,
        }
    }
}

/// What one call of [`Arap::solve`] (or of a BS-ARAP variant's solve, which runs it on the base)
/// did.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct SolveStats {
    /// Local-global iterations run.
    pub iterations: usize,
    /// Whether the tolerance was met (false: stopped at the cap). For the coarse variant, its
    /// coarse solve; the fine iterations after it report in `fine_unconverged`.
    pub converged: bool,
    /// $E(p'_0, R(p'_0))$: the energy of the starting guess (with handles on target).
    pub initial_energy: f64,
    /// Energy after each iteration, $E(p'_k, R(p'_k))$ with the rotations fitted to the pose
    /// (with Anderson acceleration, to the accepted iterate); never increases.
    /// Evaluated from the local step's covariances as $A + \sum w\lVert e\rVert^2 - 2\sum_i
    /// \operatorname{tr}(R_i S_i)$, which agrees with [`Arap::energy`] to rounding of the
    /// terms (relative $10^{-16}\cdot$ their sum over $E$).
    pub energies: Vec<f64>,
    /// Milliseconds in the local steps (rotation fits), summed over iterations.
    pub local_ms: f64,
    /// Milliseconds assembling right-hand sides.
    pub rhs_ms: f64,
    /// Milliseconds in the back-substitutions.
    pub solve_ms: f64,
    /// Milliseconds evaluating the energy: the local pass after the last global step, which
    /// serves the stopping rule and the published rotations (the others also feed the next
    /// global step and count as local).
    pub energy_ms: f64,
    /// Anderson steps rejected by the energy safeguard (0 without acceleration).
    pub rejected_steps: usize,
    /// Iterations of ARAP on the full mesh after a coarse solve ([`crate::coarse`]; 0
    /// otherwise); `iterations` and the phase times above count the coarse ones only.
    pub fine_iterations: usize,
    /// Milliseconds of those fine iterations.
    pub fine_ms: f64,
    /// The ARAP energy on the full mesh after them, $E(x, R(x))$ (0 without fine iterations;
    /// the energies above are the coarse solve's).
    pub fine_energy: f64,
    /// Fine iterations ran and were still lowering the energy by more than the tolerance per
    /// iteration: solving again at the same targets would still change the pose.
    pub fine_unconverged: bool,
}

impl SolveStats {
    /// Nothing more to do at these targets: the solve converged, and so did the fine
    /// iterations after it, if any.
    pub fn done(&self) -> bool {
        self.converged && !self.fine_unconverged
    }

    /// Final energy (the initial one when no iteration ran).
    pub fn energy(&self) -> f64 {
        self.energies.last().copied().unwrap_or(self.initial_energy)
    }
    /// Total milliseconds of the solve, fine iterations included.
    pub fn total_ms(&self) -> f64 {
        self.local_ms + self.rhs_ms + self.solve_ms + self.energy_ms + self.fine_ms
    }

    /// Milliseconds per (coarse) iteration, without the fine iterations' time.
    pub fn ms_per_iteration(&self) -> f64 {
        (self.total_ms() - self.fine_ms) / self.iterations.max(1) as f64
    }
}

/// Compressed adjacency lists: `items[offsets[i]..offsets[i+1]]` belong to `i`.
#[derive(Debug, Clone)]
struct Csr<T> {
    offsets: Vec<usize>,
    items: Vec<T>,
}

impl<T: Copy> Csr<T> {
    fn from_pairs(n: usize, pairs: &[(u32, T)]) -> Csr<T> {
        let mut offsets = vec![0usize; n + 1];
        for &(i, _) in pairs {
            offsets[i as usize + 1] += 1;
        }
        for i in 0..n {
            offsets[i + 1] += offsets[i];
        }
        let mut fill = offsets.clone();
        let mut items: Vec<Option<T>> = vec![None; pairs.len()];
        for &(i, x) in pairs {
            items[fill[i as usize]] = Some(x);
            fill[i as usize] += 1;
        }
        Csr { offsets, items: items.into_iter().flatten().collect() }
    }
    #[inline]
    fn row(&self, i: usize) -> &[T] {
        &self.items[self.offsets[i]..self.offsets[i + 1]]
    }
}

/// The cells of the energy, with their weights.
#[derive(Debug, Clone)]
enum Cells {
    /// Per face: half cotangents per corner and the rest edge opposite each corner
    /// ($p_a - p_b$ for [`opposite_edge`]), for the energy. Per vertex $i$, over $j \in$
    /// one-ring$(i) \cup \{i\}$ (`ring`, sorted): the covariance coefficient $k_{ij}$ with
    /// $S_i = \sum_j k_{ij}\,(x_j - x_i)^\top$ and the rhs coefficient $u_{ij}$ with
    /// $b_i = \sum_j R_j\,u_{ij}$ (see [`ring_coefficients`]).
    SpokesAndRims {
        cot: Vec<[f64; 3]>,
        edges: Vec<[[f64; 3]; 3]>,
        ring: Csr<u32>,
        cov_coef: Vec<[f64; 3]>,
        rhs_coef: Vec<[f64; 3]>,
        /// $c_{ij} = \tfrac32 w_{ij}$ (edge weight, 0 for $j = i$): $\sum_i\sum_j c_{ij}
        /// \lVert x_j - x_i\rVert^2$ is the energy's $\sum \lVert e'\rVert^2$ term.
        edge_coef: Vec<f64>,
    },
    /// Per vertex: (neighbour, clamped weight).
    Spokes { neighbours: Csr<(u32, f64)> },
}

/// ARAP precomputed for one mesh and one handle set: the factorization of $L_{FF}$ and the
/// current pose (the warm start of the next solve).
#[derive(Debug)]
pub struct Arap {
    rest: Vec<[f64; 3]>,
    triangles: Vec<[u32; 3]>,
    config: ArapConfig,
    cells: Cells,
    constraints: Constraints,
    /// The partition in the internal numbering (free rows ascending in it; handles in the
    /// order of the targets).
    inner: Constraints,
    /// Internal vertex `i` is mesh vertex `order.to_mesh[i]` ([`VertexOrder`]): one-rings close
    /// in memory. Everything but the public pose, rotations and rest is kept in this order.
    order: VertexOrder,
    /// [`Arap::positions`], [`Arap::rotations`] and [`Arap::rest`] in mesh order, written when a
    /// call changes the pose ([`Arap::publish`]).
    mesh_current: Vec<[f64; 3]>,
    mesh_rotations: Vec<Mat3>,
    mesh_rest: Vec<[f64; 3]>,
    /// Vertices per parallel task ([`vertices_per_task`]).
    task: usize,
    /// Whether the covariance pass may run its AVX2 build (`avx`), detected once.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    avx2: bool,
    /// Per free row: (fixed vertex h, w_ih) so that rhs_i += Σ w_ih x_h.
    coupling: Csr<(u32, f64)>,
    /// `None` when every vertex is fixed.
    factor: Option<SpdFactor>,
    rotations: Vec<Mat3>,
    /// The energy's rest term $\sum w\lVert e\rVert^2$ over all cells (constant).
    rest_term: f64,
    current: Vec<[f64; 3]>,
    /// The global step's three columns (x, then y, then z) over the free rows: the rhs, then
    /// in place the solution.
    rhs: Vec<f64>,
    /// Anderson state and its iterate buffers, kept between solves (13 MB on a 43k-vertex
    /// mesh: allocating them per call cost milliseconds per frame).
    anderson: Option<Box<AndersonWork>>,
    /// The targets of the last [`Arap::refine`], while the pose is still its result: a refine
    /// that continues from there at the same targets keeps the Anderson history.
    refined_at: Option<Vec<[f64; 3]>>,
}

/// What [`Arap::iterate_anderson`] needs besides the solver: the acceleration state and the
/// flattened free positions $x_k$, $G(x_k)$ and the accelerated iterate.
#[derive(Debug)]
struct AndersonWork {
    aa: crate::anderson::Anderson,
    x: Vec<f64>,
    g: Vec<f64>,
    xa: Vec<f64>,
    /// $E(x, R(x))$ of the pose the last call ended on (its rotations are the current ones).
    energy: Option<f64>,
}

impl Arap {
    /// Precomputes cells and weights and factors $L_{FF}$ (once per handle set).
    pub fn new(mesh: &Mesh, handles: &Handles, config: &ArapConfig) -> Result<Arap, SolveError> {
        if handles.n_vertices() != mesh.n_vertices() {
            return Err(SolveError::HandleCount {
                got: handles.n_vertices(),
                expected: mesh.n_vertices(),
            });
        }
        let constraints = Constraints::new(mesh, handles);
        Arap::with_constraints(mesh, constraints, config, 0.0, None)
    }

    /// As [`Arap::new`] with a precomputed partition (shared with the bi-harmonic base), an
    /// absolute floor on doubled triangle areas, and optional fallback positions whose
    /// cotangents a degenerate triangle takes (see [`face_cotangents_or`]).
    pub(crate) fn with_constraints(
        mesh: &Mesh,
        constraints: Constraints,
        config: &ArapConfig,
        min_double_area: f64,
        fallback: Option<&[[f64; 3]]>,
    ) -> Result<Arap, SolveError> {
        let n = mesh.n_vertices();
        let order = VertexOrder::reverse_cuthill_mckee(n, mesh.triangles());
        let inner = constraints.renumbered(&order);
        let rest = order.gather(mesh.positions());
        let tris = &order.triangles(mesh.triangles());
        let fallback = fallback.map(|f| order.gather(f));
        let (cot, _) = face_cotangents_or(&rest, fallback.as_deref(), tris, min_double_area)
            .map_err(|d| SolveError::DegenerateFace { face: d.face })?;
        let clamp = config.energy == Energy::Spokes;
        let weights = edge_weights(tris, &cot, clamp);

        // Free block L_FF (lower triangle) and the coupling to fixed vertices.
        let mut ff = Vec::with_capacity(n + weights.len());
        let mut coupling = Vec::new();
        let mut diag = vec![0.0; inner.free_vertices.len()];
        for t in laplacian_triplets(n, tris, &cot, clamp) {
            let (fi, fj) = (inner.free_index[t.row], inner.free_index[t.col]);
            match (fi, fj) {
                (Some(r), Some(_)) if t.row == t.col => diag[r as usize] += t.val,
                (Some(r), Some(c)) if r > c => ff.push(Triplet::new(r as usize, c as usize, t.val)),
                (Some(r), None) => coupling.push((r, (t.col as u32, -t.val))),
                _ => {}
            }
        }
        ff.extend(diag.iter().enumerate().map(|(r, &d)| Triplet::new(r, r, d)));
        let n_free = inner.free_vertices.len();
        let factor = if n_free == 0 {
            None
        } else {
            Some(SpdFactor::from_triplets(n_free, &ff, Layout::Simplicial).map_err(|source| {
                SolveError::Factorization {
                    matrix: "the free block of the cotangent Laplacian",
                    source,
                }
            })?)
        };
        let coupling = Csr::from_pairs(n_free, &coupling);

        let cells = match config.energy {
            Energy::SpokesAndRims => {
                let p = &rest;
                let edges: Vec<[[f64; 3]; 3]> = tris
                    .iter()
                    .map(|t| {
                        std::array::from_fn(|k| {
                            let (a, b) = opposite_edge(*t, k);
                            sub(p[a as usize], p[b as usize])
                        })
                    })
                    .collect();
                let (ring, cov_coef, rhs_coef, edge_coef) =
                    ring_coefficients(n, tris, &cot, &edges);
                Cells::SpokesAndRims { cot, edges, ring, cov_coef, rhs_coef, edge_coef }
            }
            Energy::Spokes => {
                let mut nb = Vec::with_capacity(2 * weights.len());
                for &(i, j, w) in &weights {
                    nb.push((i, (j, w)));
                    nb.push((j, (i, w)));
                }
                Cells::Spokes { neighbours: Csr::from_pairs(n, &nb) }
            }
        };
        let rest_term = {
            let p = &rest;
            match &cells {
                Cells::SpokesAndRims { ring, edge_coef, .. } => (0..n)
                    .map(|i| {
                        let (lo, hi) = (ring.offsets[i], ring.offsets[i + 1]);
                        let row = ring.items[lo..hi].iter().zip(&edge_coef[lo..hi]);
                        row.map(|(&j, &c)| c * norm2(sub(p[j as usize], p[i]))).sum::<f64>()
                    })
                    .sum(),
                Cells::Spokes { neighbours } => (0..n)
                    .map(|i| {
                        let row = neighbours.row(i).iter();
                        row.map(|&(j, w)| w * norm2(sub(p[i], p[j as usize]))).sum::<f64>()
                    })
                    .sum(),
            }
        };
        Ok(Arap {
            current: rest.clone(),
            rest,
            triangles: tris.to_vec(),
            config: *config,
            cells,
            coupling,
            factor,
            rotations: vec![IDENTITY; n],
            rest_term,
            rhs: vec![0.0; 3 * n_free],
            constraints,
            inner,
            order,
            task: vertices_per_task(n),
            avx2: avx2_detected(),
            mesh_current: mesh.positions().to_vec(),
            mesh_rotations: vec![IDENTITY; n],
            mesh_rest: mesh.positions().to_vec(),
            anderson: None,
            refined_at: None,
        })
    }

    /// The fixed/free partition used (handles, pinned components).
    pub fn constraints(&self) -> &Constraints {
        &self.constraints
    }

    /// The settings.
    pub fn config(&self) -> &ArapConfig {
        &self.config
    }

    /// Changes tolerance, cap; an energy change needs a new [`Arap`] (other weights).
    pub fn set_stopping(&mut self, tolerance: f64, max_iterations: usize) {
        self.config.tolerance = tolerance;
        self.config.max_iterations = max_iterations;
    }

    /// The current pose `#V×3` (the result of the last solve, the warm start of the next).
    pub fn positions(&self) -> &[[f64; 3]] {
        &self.mesh_current
    }

    /// Per-vertex rotations $R_i$ of the last local step.
    #[expect(clippy::misnamed_getters, reason = "the mesh-order copy, not the internal one")]
    pub fn rotations(&self) -> &[Mat3] {
        &self.mesh_rotations
    }

    /// Rest positions `#V×3`.
    #[expect(clippy::misnamed_getters, reason = "the mesh-order copy, not the internal one")]
    pub fn rest(&self) -> &[[f64; 3]] {
        &self.mesh_rest
    }

    /// Nonzeros of the Cholesky factor of $L_{FF}$ (0 when every vertex is fixed).
    pub fn factor_nonzeros(&self) -> usize {
        self.factor.as_ref().map_or(0, |f| f.factor_nonzeros())
    }

    /// The prefactored free block $L_{FF}$ (`None` when every vertex is fixed), for benchmarks
    /// of the global solve; solving with it leaves the deformation untouched.
    pub fn global_factor(&mut self) -> Option<&mut SpdFactor> {
        self.factor.as_mut()
    }

    /// Restarts the next solve from the rest pose.
    pub fn reset(&mut self) {
        self.refined_at = None;
        self.current.copy_from_slice(&self.rest);
        self.rotations.fill(IDENTITY);
        self.publish();
    }

    /// Writes the pose and rotations in mesh order for [`Arap::positions`] and
    /// [`Arap::rotations`].
    fn publish(&mut self) {
        self.order.scatter(&self.current, &mut self.mesh_current);
        self.order.scatter(&self.rotations, &mut self.mesh_rotations);
    }

    /// Sets the starting guess of the next solve (`#V×3`, finite; other lengths are ignored).
    pub fn set_positions(&mut self, x: &[[f64; 3]]) {
        self.refined_at = None;
        if x.len() == self.current.len() && x.iter().flatten().all(|c| c.is_finite()) {
            self.order.gather_into(x, &mut self.current);
            self.mesh_current.copy_from_slice(x);
        }
    }

    /// The ARAP energy of pose `x` (`#V×3`) against this solver's rest shape with the best
    /// rotations, $\min_R E(x, R)$: a quality figure for results of other methods. The pose is
    /// kept as the next warm start.
    pub fn pose_energy(&mut self, x: &[[f64; 3]]) -> f64 {
        self.set_positions(x);
        self.local_pass();
        self.publish();
        self.energy()
    }

    /// Runs local-global iterations from the current pose with the handle vertices moved to
    /// `targets` (`#H×3`, order of [`Handles::handle_vertices`]) and pinned vertices at rest.
    /// When every target equals its rest position the result is the rest pose exactly, with
    /// identity rotations, zero energy and no iteration (it is the minimizer).
    /// On a non-finite result the previous pose is kept and an error returned.
    pub fn solve(&mut self, targets: &[[f64; 3]]) -> Result<SolveStats, SolveError> {
        self.refined_at = None;
        self.run(targets, None, false)
    }

    /// Exactly `iterations` local-global iterations with safeguarded Anderson acceleration
    /// (window [`REFINE_ANDERSON_WINDOW`], whatever the configuration says; no stopping rule)
    /// from the pose `start` (`#V×3`) with the handles moved to `targets`: the fine pass that
    /// follows a coarse solve ([`crate::coarse`]). Anderson because what is left after the
    /// coarse solve is smooth, the slow part for plain local-global. Rest targets give the rest
    /// pose exactly, as in [`Arap::solve`]; a `start` of another length or with non-finite
    /// values is ignored (the current pose is the start).
    ///
    /// A refine that goes on from the previous one's result at the same targets (nothing else
    /// touched the pose in between) continues its Anderson history instead of restarting it:
    /// the fixed-point map is the same, so repeated short refines (settling) converge like one
    /// long one.
    pub fn refine(
        &mut self,
        start: &[[f64; 3]],
        targets: &[[f64; 3]],
        iterations: usize,
    ) -> Result<SolveStats, SolveError> {
        let continues =
            self.refined_at.as_deref() == Some(targets) && start == self.mesh_current.as_slice();
        self.set_positions(start);
        let stats = self.run(targets, Some(iterations), continues)?;
        if stats.iterations > 0 {
            self.refined_at = Some(targets.to_vec());
        }
        Ok(stats)
    }

    /// [`Arap::solve`] (`fixed: None`) or [`Arap::refine`] (`Some(iterations)`, keeping the
    /// Anderson history when `continues`).
    fn run(
        &mut self,
        targets: &[[f64; 3]],
        fixed: Option<usize>,
        continues: bool,
    ) -> Result<SolveStats, SolveError> {
        let hv = &self.inner.handle_vertices;
        if targets.len() != hv.len() {
            return Err(SolveError::TargetCount { got: targets.len(), expected: hv.len() });
        }
        if let Some(index) = targets.iter().position(|t| !t.iter().all(|c| c.is_finite())) {
            return Err(SolveError::NonFiniteTarget { index });
        }
        if hv.iter().zip(targets).all(|(&v, t)| *t == self.rest[v as usize]) {
            // Every handle at rest: the rest pose has $E = 0$ and $E \ge 0$ (per triangle the
            // cotangent form is the Dirichlet energy of an affine map; spokes weights are
            // clamped), so it is the minimizer. Return it exactly instead of iterating towards
            // it from the warm start, which stops at the tolerance short of it.
            self.reset();
            return Ok(SolveStats { converged: true, ..SolveStats::default() });
        }
        let previous = self.current.clone();
        for (&v, t) in hv.iter().zip(targets) {
            self.current[v as usize] = *t;
        }
        for &v in &self.inner.pinned_vertices {
            self.current[v as usize] = self.rest[v as usize];
        }
        let mut stats = SolveStats::default();
        in_pool(|| match (fixed, self.config.acceleration) {
            (Some(n), _) => {
                self.iterate_anderson(&mut stats, REFINE_ANDERSON_WINDOW, n, false, continues)
            }
            (None, Acceleration::None) => self.iterate_plain(&mut stats),
            (None, Acceleration::Anderson { window }) => {
                self.iterate_anderson(&mut stats, window, self.config.max_iterations, true, false)
            }
        });
        if let Some(vertex) = self.current.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
            self.current = previous;
            let vertex = self.order.to_mesh[vertex] as usize;
            return Err(SolveError::NonFiniteResult { vertex });
        }
        self.publish();
        Ok(stats)
    }

    /// The stopping rule: relative decrease below `tol`, or the normalized threshold.
    fn stop(&self, tol: f64, prev: f64, e: f64, e0: f64) -> bool {
        let th = self.config.energy_threshold;
        (tol > 0.0 && (prev <= f64::MIN_POSITIVE || (prev - e) / prev < tol))
            || (th > 0.0 && e <= th * e0)
    }

    /// Sets the starting guess to the Laplacian-editing fit for `targets` (Sun et al. 2017,
    /// step 4): one global step with every $R_i = I$, i.e. $L_{FF}x_F = Lp|_F - L_{FH}x_H$.
    /// Rotations are left at the identity.
    pub fn start_from_laplacian_fit(&mut self, targets: &[[f64; 3]]) -> Result<(), SolveError> {
        let hv = &self.inner.handle_vertices;
        if targets.len() != hv.len() {
            return Err(SolveError::TargetCount { got: targets.len(), expected: hv.len() });
        }
        self.refined_at = None;
        for (&v, t) in hv.iter().zip(targets) {
            self.current[v as usize] = *t;
        }
        for &v in &self.inner.pinned_vertices {
            self.current[v as usize] = self.rest[v as usize];
        }
        self.rotations.fill(IDENTITY);
        self.assemble_rhs();
        self.solve_rhs();
        for (r, &v) in self.inner.free_vertices.iter().enumerate() {
            let p = self.rhs_row(r);
            if p.iter().all(|c| c.is_finite()) {
                self.current[v as usize] = p;
            }
        }
        self.publish();
        Ok(())
    }

    /// The rhs and the global solve for the current rotations, timed into `stats`.
    fn global_step(&mut self, stats: &mut SolveStats) {
        let t2 = Instant::now();
        self.assemble_rhs();
        let t3 = Instant::now();
        stats.rhs_ms += ms(t2, t3);
        self.solve_rhs();
        for (r, &v) in self.inner.free_vertices.iter().enumerate() {
            self.current[v as usize] = self.rhs_row(r);
        }
        stats.solve_ms += ms(t3, Instant::now());
        stats.iterations += 1;
    }

    /// Plain local-global iterations (the handles already on target in `current`). Each global
    /// step is followed by the local pass ([`Arap::local_pass`]), whose sums give the energy
    /// $E(x_k, R(x_k))$ the stopping rule reads, with the rotations fitted to the new pose
    /// (the energy the Anderson loop and libigl's reference script measure). So the stopping
    /// rule costs no extra pass, and a solve ends with the rotations of its result.
    fn iterate_plain(&mut self, stats: &mut SolveStats) {
        let tol = self.config.tolerance;
        let n = self.config.max_iterations;
        let t0 = Instant::now();
        stats.initial_energy = self.local_step_energy();
        stats.local_ms += ms(t0, Instant::now());
        for it in 0..n {
            self.global_step(stats);
            let t1 = Instant::now();
            let e = self.local_step_energy();
            let prev = stats.energies.last().copied().unwrap_or(stats.initial_energy);
            stats.energies.push(e);
            let stop = self.stop(tol, prev, e, stats.initial_energy);
            if stop || it + 1 == n {
                // This pass served the energy and the published rotations.
                stats.energy_ms += ms(t1, Instant::now());
                stats.converged = stop;
                break;
            }
            stats.local_ms += ms(t1, Instant::now());
        }
    }

    /// Local-global with safeguarded Anderson acceleration of the free positions. Energies are
    /// $E(x_k, R(x_k))$: each iterate gets its own local step, which the next global step reuses.
    /// An accelerated iterate with a higher energy than the last accepted one is replaced by the
    /// plain step $G(x_k)$, for which $E(G(x), R(G(x))) \le E(G(x), R(x)) \le E(x, R(x))$.
    /// At most `max_iterations`; the stopping rule applies only when `stopping`. The history
    /// of the previous call is kept when `keep_history` (same map, same starting iterate).
    fn iterate_anderson(
        &mut self,
        stats: &mut SolveStats,
        window: usize,
        max_iterations: usize,
        stopping: bool,
        keep_history: bool,
    ) {
        let tol = self.config.tolerance;
        let free = self.inner.free_vertices.clone();
        let dim = 3 * free.len();
        let mut work = match self.anderson.take() {
            Some(w) if w.aa.shape() == (window.max(1), dim) => w,
            _ => Box::new(AndersonWork {
                aa: crate::anderson::Anderson::new(window, dim),
                x: vec![0.0; dim],
                g: vec![0.0; dim],
                xa: vec![0.0; dim],
                energy: None,
            }),
        };
        if !keep_history {
            work.aa.reset();
            work.energy = None;
        }
        let AndersonWork { aa, x, g, xa, energy: last_energy } = &mut *work;
        let gather = |cur: &[[f64; 3]], out: &mut [f64]| {
            for (r, &v) in free.iter().enumerate() {
                out[3 * r..3 * r + 3].copy_from_slice(&cur[v as usize]);
            }
        };
        let scatter = |src: &[f64], cur: &mut [[f64; 3]]| {
            for (r, &v) in free.iter().enumerate() {
                cur[v as usize] = [src[3 * r], src[3 * r + 1], src[3 * r + 2]];
            }
        };
        gather(&self.current, x);
        // Continuing: the pose and its rotations are where the last call left them, so its
        // last local step stands (one local step saved per call).
        let t0 = Instant::now();
        let mut accepted = match last_energy.take() {
            Some(e) => e,
            None => self.local_step_energy(),
        };
        stats.local_ms += ms(t0, Instant::now());
        stats.initial_energy = accepted;
        for it in 0..max_iterations {
            let t2 = Instant::now();
            self.assemble_rhs();
            let t3 = Instant::now();
            stats.rhs_ms += ms(t2, t3);
            self.solve_rhs();
            for r in 0..free.len() {
                g[3 * r..3 * r + 3].copy_from_slice(&self.rhs_row(r));
            }
            aa.step(x, g, xa);
            scatter(xa, &mut self.current);
            let t4 = Instant::now();
            stats.solve_ms += ms(t3, t4);
            let mut e = self.local_step_energy();
            let t6 = Instant::now();
            stats.local_ms += ms(t4, t6);
            if e <= accepted {
                std::mem::swap(x, xa);
            } else {
                // Safeguard: take the plain step instead and restart the history.
                stats.rejected_steps += 1;
                aa.reset();
                scatter(g, &mut self.current);
                e = self.local_step_energy();
                stats.local_ms += ms(t6, Instant::now());
                std::mem::swap(x, g);
            }
            let prev = accepted;
            accepted = e;
            stats.energies.push(e);
            stats.iterations = it + 1;
            if stopping && self.stop(tol, prev, e, stats.initial_energy) {
                stats.converged = true;
                break;
            }
        }
        *last_energy = Some(accepted);
        self.anderson = Some(work);
    }

    /// The local step, returning $E(x, R(x))$ for the rotations it fitted.
    fn local_step_energy(&mut self) -> f64 {
        let sums = self.local_pass();
        self.energy_from(sums.edges, sums.fitted)
    }

    /// The local step: the rotations fitted to the covariances of the current pose, in one
    /// parallel pass. Each task computes the covariances of [`SCRATCH`] vertices of its block at
    /// a time, $S_i = \sum_j k_{ij}(x_j - x_i)^\top$ over the one-ring (spokes and rims) or
    /// $S_i = \sum_j w_{ij}(p_i - p_j)(x_i - x_j)^\top$ (spokes), into a buffer on its stack,
    /// and fits their rotations ([`fit_rotations_near`], started from the current $R_i$,
    /// [`LANES`] cells per call) while they are in L1 (one fork and join per local step; on
    /// armadillo no faster than two passes within the machine's noise, BENCHMARKS.md "Seventh
    /// round"). The covariances are not kept: a mesh-sized array of them was 3 MB written
    /// per pass on armadillo.
    ///
    /// Returns the sums that make the energy $E(x, R(x)) = A + \sum w\lVert e\rVert^2 - 2T$
    /// ([`Arap::energy_from`]) for the fitted rotations. Sums are taken per fixed block of
    /// vertices and then in order, so they do not depend on the scheduling.
    fn local_pass(&mut self) -> LocalSums {
        let task = self.task;
        let mut rotations = std::mem::take(&mut self.rotations);
        let this = &*self;
        let parts: Vec<LocalSums> = rotations
            .par_chunks_mut(task)
            .enumerate()
            .map(|(c, rots)| {
                let mut sums = LocalSums::default();
                let mut covs = [[[0.0; 3]; 3]; SCRATCH];
                for (k, rots) in rots.chunks_mut(SCRATCH).enumerate() {
                    let covs = &mut covs[..rots.len()];
                    sums.edges = this.covariances(c * task + k * SCRATCH, covs, sums.edges);
                    sums.fitted = fit_block(rots, covs, sums.fitted);
                }
                sums
            })
            .collect();
        self.rotations = rotations;
        parts.iter().fold(LocalSums::default(), |acc, s| LocalSums {
            edges: acc.edges + s.edges,
            fitted: acc.fitted + s.fitted,
        })
    }

    /// $S_i$ of the current pose for $i$ = `first`, `first + 1`, … (one per entry of `out`),
    /// on AVX registers where detected ([`avx::covariances`], the same bits); returns `sum`
    /// plus the cells' $\sum_j c_{ij}\lVert x_j - x_i\rVert^2$, added vertex by vertex.
    fn covariances(&self, first: usize, out: &mut [Mat3], sum: f64) -> f64 {
        #[cfg(target_arch = "x86_64")]
        if let (true, Cells::SpokesAndRims { ring, cov_coef, edge_coef, .. }) =
            (self.avx2, &self.cells)
        {
            let ring =
                avx::Ring { offsets: &ring.offsets, items: &ring.items, cov_coef, edge_coef };
            // SAFETY: `avx2` is true only where AVX2 was detected.
            return unsafe { avx::covariances(first, out, &self.current, &ring, sum) };
        }
        let mut sum = sum;
        for (l, out) in out.iter_mut().enumerate() {
            let (s, a) = covariance(&self.cells, &self.current, &self.rest, first + l);
            sum += a;
            *out = s;
        }
        sum
    }

    /// $E = A + \sum w\lVert e\rVert^2 - 2T$ from [`Arap::local_pass`]' sums, at least 0
    /// (the expansion cancels when the pose is very close to rigid; the exact form is
    /// [`Arap::energy`]).
    fn energy_from(&self, a: f64, t: f64) -> f64 {
        (a + self.rest_term - 2.0 * t).max(0.0)
    }

    /// Right-hand side of the global step for the free rows: $b_F - L_{FH} x_H$, written in
    /// parallel straight into the three columns the solve reads (`rhs`). The constant
    /// rest-edge combinations are precomputed.
    fn assemble_rhs(&mut self) {
        let p = &self.rest;
        let x = &self.current;
        let rot = &self.rotations;
        let free = &self.inner.free_vertices;
        let coupling = &self.coupling;
        let cells = &self.cells;
        let row = |r: usize| -> [f64; 3] {
            let i = free[r] as usize;
            let mut b = [0.0; 3];
            match cells {
                Cells::SpokesAndRims { ring, rhs_coef, .. } => {
                    let (lo, hi) = (ring.offsets[i], ring.offsets[i + 1]);
                    for (&j, &u) in ring.items[lo..hi].iter().zip(&rhs_coef[lo..hi]) {
                        let rv = mul_vec(&rot[j as usize], u);
                        b = [b[0] + rv[0], b[1] + rv[1], b[2] + rv[2]];
                    }
                }
                Cells::Spokes { neighbours } => {
                    for &(j, w) in neighbours.row(i) {
                        let j = j as usize;
                        let rr = scale_mat(&add_mat(&rot[i], &rot[j]), 0.5 * w);
                        let rv = mul_vec(&rr, sub(p[i], p[j]));
                        b = [b[0] + rv[0], b[1] + rv[1], b[2] + rv[2]];
                    }
                }
            }
            add_coupling(b, coupling.row(r), x)
        };
        let task = self.task;
        let (bx, rest) = self.rhs.split_at_mut(free.len());
        let (by, bz) = rest.split_at_mut(free.len());
        let blocks =
            bx.par_chunks_mut(task).zip(by.par_chunks_mut(task)).zip(bz.par_chunks_mut(task));
        blocks.enumerate().for_each(|(c, ((bx, by), bz))| {
            for (l, ((x, y), z)) in bx.iter_mut().zip(by).zip(bz).enumerate() {
                [*x, *y, *z] = row(c * task + l);
            }
        });
    }

    /// Solves $L_{FF} X = $ `rhs` in place (the global step's back-substitution).
    fn solve_rhs(&mut self) {
        if let Some(f) = self.factor.as_mut() {
            let n = self.inner.free_vertices.len();
            f.solve_in_place(MatMut::from_column_major_slice_mut(&mut self.rhs, n, 3));
        }
    }

    /// Row `r` of `rhs`: after [`Arap::solve_rhs`], free vertex `r`'s new position.
    fn rhs_row(&self, r: usize) -> [f64; 3] {
        let n = self.inner.free_vertices.len();
        [self.rhs[r], self.rhs[n + r], self.rhs[2 * n + r]]
    }

    /// $E(p', R)$ for the current pose and rotations.
    pub fn energy(&self) -> f64 {
        let x = &self.current;
        let p = &self.rest;
        let rot = &self.rotations;
        match &self.cells {
            Cells::SpokesAndRims { cot, edges, .. } => self
                .triangles
                .par_iter()
                .zip(cot.par_iter().zip(edges.par_iter()))
                .with_min_len(2 * self.task)
                .map(|(t, (w, edge))| {
                    let mut e = 0.0;
                    let rs = t.map(|v| &rot[v as usize]);
                    for k in 0..3 {
                        let (a, b) = opposite_edge(*t, k);
                        let de = sub(x[a as usize], x[b as usize]);
                        let mut ek = 0.0;
                        for r in rs {
                            let d = sub(de, mul_vec(r, edge[k]));
                            ek += d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                        }
                        e += w[k] * ek;
                    }
                    e
                })
                .sum(),
            Cells::Spokes { neighbours } => (0..x.len())
                .into_par_iter()
                .with_min_len(self.task)
                .map(|i| {
                    let mut e = 0.0;
                    for &(j, w) in neighbours.row(i) {
                        let j = j as usize;
                        let d = sub(sub(x[i], x[j]), mul_vec(&rot[i], sub(p[i], p[j])));
                        e += w * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
                    }
                    e
                })
                .sum(),
        }
    }
}

/// The one-ring, the covariance, rhs and edge coefficients aligned with it.
type RingCoefficients = (Csr<u32>, Vec<[f64; 3]>, Vec<[f64; 3]>, Vec<f64>);

/// The per-vertex coefficients of the spokes-and-rims local step and rhs, over
/// $j \in$ one-ring$(i) \cup \{i\}$ (CSR, sorted by $j$). With the half cotangents $w^t_k$
/// and rest edges $e^t_k = p_a - p_b$ opposite corner $k$ of triangle $t$:
/// - covariance: $S_i = \sum_{t \ni i}\sum_k w^t_k e^t_k (x_a - x_b)^\top
///   = \sum_j k_{ij}(x_j - x_i)^\top$ with $k_{ij} = \sum_{t \ni i}\sum_k w^t_k e^t_k
///   ([a = j] - [b = j])$ (and $\sum_j k_{ij} = 0$, so the differences cost nothing and keep
///   precision far from the origin);
/// - energy: the cells' $\sum w \lVert e'\rVert^2$ is $3\sum_{\text{edges}} w_e \lVert x_a -
///   x_b\rVert^2 = \sum_i \sum_j c_{ij}\lVert x_j - x_i\rVert^2$ with $c_{ij} = \tfrac32 w_{ij}$
///   (every triangle edge is in the cells of the triangle's three vertices);
/// - rhs: $b_i = \sum_{t \ni i} \bar R_t v_{it}$ with $\bar R_t = \tfrac13\sum_{c \in t} R_c$
///   and $v_{it}$ the weighted rest edges of $t$ at $i$, so $b_i = \sum_j R_j u_{ij}$ with
///   $u_{ij} = \tfrac13\sum_{t \ni i, j} v_{it}$ (libigl's precomputed-matrix form).
fn ring_coefficients(
    n: usize,
    tris: &[[u32; 3]],
    cot: &[[f64; 3]],
    edges: &[[[f64; 3]; 3]],
) -> RingCoefficients {
    let mut inc = Vec::with_capacity(3 * tris.len());
    for (f, t) in tris.iter().enumerate() {
        for (c, &v) in t.iter().enumerate() {
            inc.push((v, (f as u32, c as u8)));
        }
    }
    let vertex_faces = Csr::from_pairs(n, &inc);
    let mut offsets = Vec::with_capacity(n + 1);
    offsets.push(0);
    let (mut items, mut cov_coef, mut rhs_coef) = (Vec::new(), Vec::new(), Vec::new());
    let mut edge_coef = Vec::new();
    let mut acc: Vec<(u32, [f64; 3], [f64; 3], f64)> = Vec::new();
    for i in 0..n {
        acc.clear();
        for &(f, c) in vertex_faces.row(i) {
            let (t, w, e) = (tris[f as usize], cot[f as usize], &edges[f as usize]);
            let c = c as usize;
            // v_it: the edges of t at i, e_{c+1} = p_{c+2} - p_c and e_{c+2} = p_c - p_{c+1}.
            let v = add(
                scale3(e[(c + 2) % 3], w[(c + 2) % 3]),
                scale3(e[(c + 1) % 3], -w[(c + 1) % 3]),
            );
            for k in 0..3 {
                let (a, b) = opposite_edge(t, k);
                // The spoke (i, other end) of this edge, if it has one.
                let spoke = if a as usize == i || b as usize == i { 1.5 * w[k] } else { 0.0 };
                acc.push((
                    a,
                    scale3(e[k], w[k]),
                    [0.0; 3],
                    if b as usize == i { spoke } else { 0.0 },
                ));
                acc.push((
                    b,
                    scale3(e[k], -w[k]),
                    [0.0; 3],
                    if a as usize == i { spoke } else { 0.0 },
                ));
                acc.push((t[k], [0.0; 3], scale3(v, 1.0 / 3.0), 0.0));
            }
        }
        acc.sort_by_key(|a| a.0);
        for &(j, k, u, c) in &acc {
            if items.len() > offsets[i] && items.last() == Some(&j) {
                let last = cov_coef.len() - 1;
                cov_coef[last] = add(cov_coef[last], k);
                rhs_coef[last] = add(rhs_coef[last], u);
                edge_coef[last] += c;
            } else {
                items.push(j);
                cov_coef.push(k);
                rhs_coef.push(u);
                edge_coef.push(c);
            }
        }
        offsets.push(items.len());
    }
    (Csr { offsets, items }, cov_coef, rhs_coef, edge_coef)
}

/// The sums of one [`Arap::local_pass`]: $A = \sum_i\sum_j c_{ij}\lVert x_j - x_i\rVert^2$
/// over the cells, and $T = \sum_i \operatorname{tr}(R_i S_i)$ for the fitted rotations.
#[derive(Debug, Clone, Copy, Default)]
struct LocalSums {
    edges: f64,
    fitted: f64,
}

/// $S_i$ of the pose `x` and the cell's $\sum c\lVert x_j - x_i\rVert^2$ (the scalar form of
/// [`Arap::local_pass`]'s covariances).
fn covariance(cells: &Cells, x: &[[f64; 3]], p: &[[f64; 3]], i: usize) -> (Mat3, f64) {
    let mut s = [[0.0; 3]; 3];
    let mut a = 0.0;
    match cells {
        Cells::SpokesAndRims { ring, cov_coef, edge_coef, .. } => {
            let (lo, hi) = (ring.offsets[i], ring.offsets[i + 1]);
            let xi = x[i];
            for ((&j, &k), &c) in
                ring.items[lo..hi].iter().zip(&cov_coef[lo..hi]).zip(&edge_coef[lo..hi])
            {
                let d = sub(x[j as usize], xi);
                add_outer(&mut s, 1.0, k, d);
                a += c * norm2(d);
            }
        }
        Cells::Spokes { neighbours } => {
            for &(j, w) in neighbours.row(i) {
                let j = j as usize;
                let d = sub(x[i], x[j]);
                add_outer(&mut s, w, sub(p[i], p[j]), d);
                a += w * norm2(d);
            }
        }
    }
    (s, a)
}

/// $R_i$ = [`fit_rotations_near`] of $S_i$ started from the current $R_i$, [`LANES`] cells per
/// call, over one block; returns `t` plus $\sum_i \operatorname{tr}(R_i S_i)$ for the new
/// rotations, added [`LANES`] cells at a time.
fn fit_block(rots: &mut [Mat3], covs: &[Mat3], t: f64) -> f64 {
    let mut t = t;
    for (r, s) in rots.chunks_mut(LANES).zip(covs.chunks(LANES)) {
        t += match (<&mut [Mat3; LANES]>::try_from(&mut *r), <&[Mat3; LANES]>::try_from(s)) {
            (Ok(lanes), Ok(s)) => fit_rotations_near(s, lanes),
            _ => {
                for (r, s) in r.iter_mut().zip(s) {
                    *r = fit_rotation_near(s, r);
                }
                r.iter().zip(s).map(|(r, s)| trace_of_product(r, s)).sum::<f64>()
            }
        };
    }
    t
}

#[inline]
fn scale3(a: [f64; 3], s: f64) -> [f64; 3] {
    [s * a[0], s * a[1], s * a[2]]
}

#[inline]
fn norm2(a: [f64; 3]) -> f64 {
    a[0] * a[0] + a[1] * a[1] + a[2] * a[2]
}

#[inline]
fn add_coupling(mut b: [f64; 3], row: &[(u32, f64)], x: &[[f64; 3]]) -> [f64; 3] {
    for &(h, w) in row {
        let xh = x[h as usize];
        b = [b[0] + w * xh[0], b[1] + w * xh[1], b[2] + w * xh[2]];
    }
    b
}

#[inline]
fn ms(a: Instant, b: Instant) -> f64 {
    (b - a).as_secs_f64() * 1e3
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used, clippy::needless_range_loop)]
    use super::*;
    use crate::rotation::{axis_angle, fit_rotation_svd};

    /// A bumpy ellipsoid with two end caps as handle groups.
    fn setup() -> (Mesh, Handles) {
        crate::shapes::bumpy_bar(3)
    }

    /// A deformed pose: a twist and bend of the rest shape.
    fn pose(rest: &[[f64; 3]]) -> Vec<[f64; 3]> {
        rest.iter()
            .map(|&p| {
                let r = axis_angle([1.0, 0.3, 0.0], 0.4 * p[0]);
                let q = mul_vec(&r, p);
                [q[0], q[1] + 0.1 * p[0] * p[0], q[2]]
            })
            .collect()
    }

    /// The covariance pass's AVX2 build gives the same bits as the scalar loop: covariances and
    /// the edge-length sum.
    #[test]
    fn avx_covariances_match_scalar() {
        if !crate::testing::avx2_or_skip() {
            return;
        }
        let (m, h) = setup();
        let mut a = Arap::new(&m, &h, &ArapConfig::default()).unwrap();
        a.set_positions(&pose(m.positions()));
        let mut run = |avx2: bool| {
            a.avx2 = avx2;
            let mut cov = vec![[[0.0; 3]; 3]; m.n_vertices()];
            let sum = a.covariances(0, &mut cov, 0.5);
            let bits = |m: &Mat3| m.map(|row| row.map(f64::to_bits));
            (sum.to_bits(), cov.iter().map(bits).collect::<Vec<_>>())
        };
        let (avx, scalar) = (run(true), run(false));
        assert!(avx.1.iter().any(|s| s[0][0] != 0));
        assert_eq!(avx, scalar);
    }

    /// The optimized local step and rhs (buffers, precomputed edges, quaternion fit) against a
    /// direct transcription of the formulas with the SVD fit.
    #[test]
    fn optimized_local_step_and_rhs_match_reference() {
        let (m, h) = setup();
        let mut a = Arap::new(&m, &h, &ArapConfig::default()).unwrap();
        let x = pose(m.positions());
        a.set_positions(&x);
        a.local_pass();
        a.assemble_rhs();
        a.publish();
        let p = m.positions();
        let tris = m.triangles();
        let cot = crate::cotan::face_cotangents(p, tris, 0.0).unwrap();
        // Reference rotations: S_i = Σ_{t ∋ i} Σ_k w_k (p_a - p_b)(x_a - x_b)^T.
        let mut s = vec![[[0.0; 3]; 3]; p.len()];
        for (t, w) in tris.iter().zip(&cot) {
            for k in 0..3 {
                let (u, v) = opposite_edge(*t, k);
                let (u, v) = (u as usize, v as usize);
                for &i in t {
                    add_outer(&mut s[i as usize], w[k], sub(p[u], p[v]), sub(x[u], x[v]));
                }
            }
        }
        let mut max_r: f64 = 0.0;
        for (i, si) in s.iter().enumerate() {
            let r = fit_rotation_svd(si);
            for (ra, rb) in r.iter().flatten().zip(a.rotations()[i].iter().flatten()) {
                max_r = max_r.max((ra - rb).abs());
            }
        }
        assert!(max_r < 1e-10, "rotations differ by {max_r}");
        // Reference rhs: b_i = Σ_t Σ_{(j,k) ∋ i} w (R̄_t e) with signs, plus the coupling.
        let rot = a.rotations().to_vec();
        let mut b = vec![[0.0; 3]; p.len()];
        for (t, w) in tris.iter().zip(&cot) {
            let rbar = scale_mat(
                &add_mat(&add_mat(&rot[t[0] as usize], &rot[t[1] as usize]), &rot[t[2] as usize]),
                1.0 / 3.0,
            );
            for k in 0..3 {
                let (u, v) = opposite_edge(*t, k);
                let re = mul_vec(&rbar, sub(p[u as usize], p[v as usize]));
                for c in 0..3 {
                    b[u as usize][c] += w[k] * re[c];
                    b[v as usize][c] -= w[k] * re[c];
                }
            }
        }
        // Free rows and coupled vertices are in the solver's internal numbering.
        let mesh_vertex = |i: u32| a.order.to_mesh[i as usize] as usize;
        let mut max_b: f64 = 0.0;
        for (r, &v) in a.inner.free_vertices.iter().enumerate() {
            let mut want = b[mesh_vertex(v)];
            for &(hv, w) in a.coupling.row(r) {
                for k in 0..3 {
                    want[k] += w * x[mesh_vertex(hv)][k];
                }
            }
            for k in 0..3 {
                max_b = max_b.max((want[k] - a.rhs_row(r)[k]).abs());
            }
        }
        assert!(max_b < 1e-12, "rhs differs by {max_b}");
    }

    /// Anderson-accelerated solves never increase the energy, reach the same pose as the plain
    /// loop, and need no more iterations to a tight tolerance.
    #[test]
    fn anderson_is_monotone_and_agrees_with_plain() {
        let (m, h) = setup();
        let hv = h.handle_vertices();
        let targets: Vec<[f64; 3]> = hv
            .iter()
            .map(|&v| {
                let q = m.positions()[v as usize];
                if q[0] > 0.0 { mul_vec(&axis_angle([0.0, 0.0, 1.0], 0.8), q) } else { q }
            })
            .collect();
        let run = |acceleration| {
            let cfg = ArapConfig {
                tolerance: 1e-9,
                max_iterations: 3000,
                acceleration,
                ..Default::default()
            };
            let mut a = Arap::new(&m, &h, &cfg).unwrap();
            let s = a.solve(&targets).unwrap();
            (s, a.positions().to_vec())
        };
        let (plain, xp) = run(Acceleration::None);
        let (acc, xa) = run(Acceleration::Anderson { window: 5 });
        let mut prev = acc.initial_energy;
        for &e in &acc.energies {
            assert!(e <= prev * (1.0 + 1e-12), "energy rose from {prev} to {e}");
            prev = e;
        }
        assert!(acc.converged && plain.converged);
        assert!(acc.iterations <= plain.iterations, "{} vs {}", acc.iterations, plain.iterations);
        let d = xp.iter().zip(&xa).flat_map(|(a, b)| (0..3).map(move |k| (a[k] - b[k]).abs()));
        let d = d.fold(0.0, f64::max);
        assert!(d < 1e-3, "poses differ by {d}");
    }

    /// The energies the local pass reports are the direct form's, $E(x_k, R(x_k))$: the last
    /// one for the final pose and rotations, which are the rotations fitted to that pose; they
    /// never increase from the starting guess on.
    #[test]
    fn energies_come_with_the_local_step_and_match_the_direct_form() {
        let (m, h) = setup();
        let targets: Vec<[f64; 3]> = h
            .handle_vertices()
            .iter()
            .map(|&v| {
                let q = m.positions()[v as usize];
                if q[0] > 0.0 { mul_vec(&axis_angle([0.0, 0.0, 1.0], 0.5), q) } else { q }
            })
            .collect();
        let cfg = ArapConfig { tolerance: 0.0, max_iterations: 12, ..Default::default() };
        let mut a = Arap::new(&m, &h, &cfg).unwrap();
        let s = a.solve(&targets).unwrap();
        assert_eq!((s.iterations, s.energies.len()), (12, 12));
        // The direct evaluation, for the final pose and rotations.
        let direct = a.energy();
        let rel = (s.energy() - direct).abs() / direct;
        assert!(rel < 1e-10, "energy from the covariances {} vs direct {direct}", s.energy());
        // The rotations are those of the final pose: a fresh fit does not move them.
        let (x, r) = (a.positions().to_vec(), a.rotations().to_vec());
        a.pose_energy(&x);
        let refit = r.iter().flatten().flatten().zip(a.rotations().iter().flatten().flatten());
        let moved = refit.map(|(p, q)| (p - q).abs()).fold(0.0, f64::max);
        assert!(moved < 1e-9, "a fit at the final pose moves the rotations by {moved}");
        assert!(s.energy() < s.initial_energy);
        let trace: Vec<f64> =
            std::iter::once(s.initial_energy).chain(s.energies.iter().copied()).collect();
        assert!(trace.windows(2).all(|w| w[1] <= w[0] * (1.0 + 1e-12)), "{trace:?}");
    }
}
