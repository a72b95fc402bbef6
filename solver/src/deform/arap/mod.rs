//! As-Rigid-As-Possible surface deformation (Sorkine & Alexa 2007) by local-global iteration.
//!
//! Energy (Sun et al. 2017, Eq. 3), over cells $\mathcal{C}_i$ of rest edges $e_{jk}=p_j-p_k$:
//! $$E(p') = \sum_i \sum_{(j,k)\in\mathcal{C}_i} w_{jk}\,\lVert (p'_j-p'_k) - R_i(p_j-p_k)\rVert^2.$$
//! - [`Energy::SpokesAndRims`] (default; Chao et al. 2010, the paper's Eq. 2, libigl's default
//!   for surfaces): the cell of vertex $i$ is every edge of every triangle around $i$, with the
//!   per-triangle weight $\tfrac12\cot$ of the opposite angle. Negative weights are kept.
//! - [`Energy::Spokes`]: the cell of $i$ is its one-ring edges $(i,j)$, weight $w_{ij}$, clamped
//!   at zero (negative spoke weights can make the local fit meaningless).
//! - [`Energy::SmoothRotations`]: the spokes cells plus $\beta\sum_i\sum_j w_{ij}\lVert R_i -
//!   R_j\rVert_F^2$ (SR-ARAP, Levi & Gotsman 2015), whose local step couples the rotations
//!   (`smooth_rotations`).
//!
//! **Local step** (Eq. 5): $S_i = \sum w_{jk} e_{jk} e'^\top_{jk}$, $R_i$ from
//! [`crate::linalg::rotation::fit_rotations_near`] (quaternion fit started from the previous $R_i$, four
//! cells at a time); parallel over vertices (rayon).
//! **Global step** (Eq. 4): $L_{FF}\,p'_F = b_F - L_{FH}\,p'_H$ with
//! $b_j = \sum_{t}\sum_{(j,k)\in t} w^t_{jk}\,\bar R_t\,e_{jk}$, $\bar R_t$ the mean of the three
//! rotations of triangle $t$ (spokes and rims), or $b_i = \sum_j \tfrac{w_{ij}}2(R_i+R_j)e_{ij}$
//! (spokes). $L_{FF}$ is factored once per handle set ([`crate::linalg::linsolve::SpdFactor`]); an
//! iteration is one 3-column back-substitution.
//!
//! Each local and each global step weakly decreases $E$; iteration stops when the relative
//! decrease $(E_{k-1}-E_k)/E_{k-1}$ falls below the tolerance, or at the iteration cap.
//!
//! Layout: the solver numbers the vertices in reverse Cuthill–McKee order
//! ([`crate::geometry::reorder`]) so that one-ring gathers stay in cache; poses, rotations and errors at
//! its interface are in the mesh's own order.
//!
//! Inputs: a [`Mesh`](crate::geometry::mesh::Mesh) (`#V×3`, `#F×3`), [`Handles`](crate::deform::handles::Handles),
//! an [`ArapConfig`]; targets `#H×3` in the order of
//! [`Handles::handle_vertices`](crate::deform::handles::Handles::handle_vertices). Known limitation:
//! convergence is linear, slow for large rotations of far-apart handles (what BS-ARAP's smooth
//! base is meant to help with).
//!
//! Files, one per step:
//! - `config`: the settings ([`ArapConfig`]) and what a solve reports ([`SolveStats`]);
//! - `precompute`: cells, weights and the factorization of $L_{FF}$ ([`Arap::new`]);
//! - `iterate`: the outer loop ([`Arap::solve`], [`Arap::refine`]), its stopping rule and the
//!   plain local-global loop;
//! - `accelerated`: the safeguarded Anderson loop;
//! - `local`: the local step (covariances and rotation fits, Eq. 5);
//! - `global`: the right-hand side and the solve (Eq. 4): back-substitution, or two-grid
//!   conjugate gradients on a level;
//! - `start`: the starting guesses (the rigid start of every solve, the predicted start of a
//!   drag, the Laplacian fit);
//! - `energy`: $E(p', R)$, directly and from the local step's sums;
//! - `avx`: the AVX2 build of the covariance pass;
//! - `membrane`: triangle cells blended into the energy (the coarse level's membrane share);
//! - `smooth_rotations`: the rotation-smoothness term, its local step and energy.
//! - `rotation_solve`: that term's implicit rotation step (one sparse solve per local step).

mod accelerated;
#[cfg(target_arch = "x86_64")]
mod avx;
mod config;
mod energy;
mod global;
mod iterate;
mod local;
mod membrane;
mod precompute;
mod rotation_solve;
mod smooth_rotations;
mod start;
#[cfg(test)]
mod tests;

pub use config::{
    Acceleration, ArapConfig, ArapConfigError, DEFAULT_BENDING_LENGTH, DEFAULT_MAX_ITERATIONS,
    DEFAULT_TOLERANCE, Energy, FrameStats, MAX_ANDERSON_WINDOW, MAX_BENDING_LENGTH,
    MAX_ENERGY_THRESHOLD, MAX_ITERATIONS_LIMIT, REFINE_ANDERSON_WINDOW, REFINE_ROTATION_STEPS,
    SolveStats,
};

pub(crate) use global::GlobalStep;
pub(crate) use precompute::vertices_per_task;
pub(crate) use rotation_solve::RotationStep;
pub(crate) use smooth_rotations::SmoothRotations;

use crate::deform::constraints::Constraints;
use crate::geometry::reorder::VertexOrder;
use crate::geometry::topology::bucketed;
use crate::linalg::lanes::Avx2;
use crate::linalg::linsolve::SpdFactor;
use crate::linalg::rotation::{IDENTITY, Mat3};
use accelerated::AndersonWork;
use std::time::Instant;

/// Compressed adjacency lists: `items[offsets[i]..offsets[i+1]]` belong to `i`.
#[derive(Debug, Clone)]
pub(crate) struct Csr<T> {
    offsets: Vec<usize>,
    items: Vec<T>,
}

impl<T: Copy + Default> Csr<T> {
    /// Rows `0..n` from `(row, item)` pairs, each row's items in their order in `pairs`.
    pub(crate) fn from_pairs(n: usize, pairs: &[(u32, T)]) -> Csr<T> {
        let (starts, items) = bucketed(n, || pairs.iter().copied());
        Csr { offsets: starts, items }
    }
    #[inline]
    pub(crate) fn row(&self, i: usize) -> &[T] {
        &self.items[self.offsets[i]..self.offsets[i + 1]]
    }
}

/// The cells of the energy, with their weights.
#[derive(Debug, Clone)]
enum Cells {
    /// Per face (`tris`, internal numbering; the spokes cells keep no faces): half cotangents
    /// per corner and the rest edge opposite each corner ($p_a - p_b$ for
    /// [`opposite_edge`](crate::geometry::cotan::opposite_edge)), for the energy. Per vertex
    /// $i$, over $j \in$ one-ring$(i) \cup \{i\}$ (`ring`, sorted): the covariance coefficient
    /// $k_{ij}$ with
    /// $S_i = \sum_j k_{ij}\,(x_j - x_i)^\top$ and the rhs coefficient $u_{ij}$ with
    /// $b_i = \sum_j R_j\,u_{ij}$ (see `precompute::ring_coefficients`).
    SpokesAndRims {
        tris: Vec<[u32; 3]>,
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
    /// call changes the pose ([`Arap::publish`]). The rotations' copy is made by the first
    /// [`Arap::rotations`] and kept up from then on, the rest's by the first [`Arap::rest`]: a
    /// solver nobody asks for them (the coarse variant's full mesh, `deform`) keeps neither
    /// (96 bytes a vertex).
    mesh_current: Vec<[f64; 3]>,
    mesh_rotations: std::sync::OnceLock<Vec<Mat3>>,
    mesh_rest: std::sync::OnceLock<Vec<[f64; 3]>>,
    /// Vertices per parallel task (`precompute::vertices_per_task`).
    task: usize,
    /// The token of the covariance pass's AVX2 build (`avx`), where detected (once); `None`:
    /// the scalar loop.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    avx2: Option<Avx2>,
    /// Per free row: (fixed vertex h, w_ih) so that rhs_i += Σ w_ih x_h.
    coupling: Csr<(u32, f64)>,
    /// The global step's solver (`global`); `None` when every vertex is fixed.
    global: Option<global::GlobalSolve>,
    rotations: Vec<Mat3>,
    /// The energy's rest term $\sum w\lVert e\rVert^2$ over all cells (constant).
    rest_term: f64,
    current: Vec<[f64; 3]>,
    /// The global step's three columns (x, then y, then z) over the free rows: the rhs, then
    /// in place the factor's solution (the two-grid solve's is its own `x`: `solved_row`).
    rhs: Vec<f64>,
    /// Anderson state and its iterate buffers, kept between solves (13 MB on a 43k-vertex
    /// mesh: allocating them per call cost milliseconds per frame).
    anderson: Option<Box<AndersonWork>>,
    /// The targets of the last [`Arap::refine`], while the pose is still its result: a refine
    /// that continues from there at the same targets keeps the Anderson history.
    refined_at: Option<Vec<[f64; 3]>>,
    /// Whether the pose is the rest pose (a new solver, or reset): the next solve may start
    /// from the handles' rigid motion (`start`).
    at_rest: bool,
    /// The targets of the last solve, while the pose is still its result: the next solve
    /// moves the pose along when the handles moved rigidly from them (`start`).
    solved_at: Option<Vec<[f64; 3]>>,
    /// The last solve's step, when it continued from the solve before it and prediction is on:
    /// the next solve starts along it (`start`, "Predicted start").
    trend: Option<Box<start::Trend>>,
    /// Whether solves that continue a drag start from the predicted pose ([`Arap::set_prediction`];
    /// off by default).
    predict: bool,
    /// The rest bounding-box diagonal (the scale of the rigid-motion test).
    rest_diagonal: f64,
    /// Soft-handle penalties (`None`: hard handles only; [`crate::deform::rig`]).
    soft: Option<Box<Soft>>,
    /// Triangle cells blended into the energy (`None`: [`ArapConfig::membrane`] is 0).
    membrane: Option<Box<membrane::Membrane>>,
    /// The rotation-smoothness term (`None` unless [`Energy::SmoothRotations`]).
    smooth: Option<Box<smooth_rotations::SmoothRotations>>,
}

/// The soft-handle terms $\lambda_v \lVert x_v - T_g(p_v)\rVert^2$ in the internal numbering.
#[derive(Debug, Clone)]
struct Soft {
    /// (free row, vertex, group, $\lambda_v$).
    terms: Vec<(u32, u32, u32, f64)>,
    /// Per group id: the positions of its vertices in the targets.
    groups: Vec<Vec<u32>>,
    /// Per term, $T_g(p_v)$ for the current targets (written by `place_handles`).
    targets: Vec<[f64; 3]>,
}

impl Arap {
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

    /// Per-vertex rotations $R_i$ of the last local step, in mesh order (the first call makes
    /// the copy, kept up from then on).
    pub fn rotations(&self) -> &[Mat3] {
        self.mesh_rotations.get_or_init(|| self.order.scattered(&self.rotations))
    }

    /// Rest positions `#V×3`.
    pub fn rest(&self) -> &[[f64; 3]] {
        self.mesh_rest.get_or_init(|| self.order.scattered(&self.rest))
    }

    /// Nonzeros of the Cholesky factor of $L_{FF}$, or of the level's Galerkin matrix where
    /// the global step solves on a level (0 when every vertex is fixed).
    pub fn factor_nonzeros(&self) -> usize {
        match &self.global {
            None => 0,
            Some(global::GlobalSolve::Factor(f)) => f.factor_nonzeros(),
            Some(global::GlobalSolve::TwoGrid { solver, .. }) => solver.coarse_factor_nonzeros(),
        }
    }

    /// The prefactored free block $L_{FF}$ (`None` when every vertex is fixed or the global
    /// step solves on a level), for benchmarks of the global solve; solving with it leaves
    /// the deformation untouched.
    pub fn global_factor(&mut self) -> Option<&mut SpdFactor> {
        match self.global.as_mut() {
            Some(global::GlobalSolve::Factor(f)) => Some(f),
            _ => None,
        }
    }

    /// The conjugate-gradient iterations the global steps took since this solver was made,
    /// where they solve on a level (`None`: with the factor).
    pub fn two_grid_iterations(&self) -> Option<usize> {
        match &self.global {
            Some(global::GlobalSolve::TwoGrid { iterations, .. }) => Some(*iterations),
            _ => None,
        }
    }

    /// Restarts the next solve from the rest pose.
    pub fn reset(&mut self) {
        self.refined_at = None;
        self.solved_at = None;
        self.trend = None;
        self.at_rest = true;
        self.current.copy_from_slice(&self.rest);
        self.rotations.fill(IDENTITY);
        if let Some(m) = self.membrane.as_deref_mut() {
            m.fill(IDENTITY);
        }
        self.publish();
    }

    /// Writes the pose and rotations in mesh order for [`Arap::positions`] and
    /// [`Arap::rotations`].
    fn publish(&mut self) {
        self.order.scatter(&self.current, &mut self.mesh_current);
        if let Some(r) = self.mesh_rotations.get_mut() {
            self.order.scatter(&self.rotations, r);
        }
    }

    /// Sets the starting guess of the next solve (`#V×3`, finite; other lengths are ignored).
    pub fn set_positions(&mut self, x: &[[f64; 3]]) {
        self.refined_at = None;
        self.solved_at = None;
        self.trend = None;
        if x.len() == self.current.len() && x.iter().flatten().all(|c| c.is_finite()) {
            self.order.gather_into(x, &mut self.current);
            self.mesh_current.copy_from_slice(x);
            self.at_rest = false;
        }
    }

    /// Puts the pose back to `x` (`#V×3`, finite) after a caller's failed step (BS-ARAP's
    /// overflowing details, the coarse variant's failed frame), with the rotations fitted to
    /// it: [`Arap::rotations`] then belong to [`Arap::positions`], not to the failed solve.
    pub(crate) fn roll_back(&mut self, x: &[[f64; 3]]) {
        self.set_positions(x);
        self.refit_rotations();
    }

    /// Fits the rotations to the current pose and publishes both: after a roll-back, so that
    /// the rotations are not a failed solve's ([`Arap::roll_back`], a failed `solve`).
    fn refit_rotations(&mut self) {
        self.local_pass();
        self.publish();
    }

    /// The ARAP energy of pose `x` (`#V×3`) against this solver's rest shape with the best
    /// rotations, $\min_R E(x, R)$: a quality figure for results of other methods. The pose is
    /// kept as the next warm start. With [`Energy::SmoothRotations`] the rotations couple: they
    /// are fitted per vertex, then improved by [`POSE_ENERGY_SWEEPS`] Gauss–Seidel sweeps
    /// (an upper bound on the minimum, close to it for poses near this energy's minimum).
    pub fn pose_energy(&mut self, x: &[[f64; 3]]) -> f64 {
        self.set_positions(x);
        self.local_pass();
        if self.smooth.is_some() {
            let e = self.smooth_local_steps(POSE_ENERGY_SWEEPS);
            self.publish();
            return e;
        }
        self.fit_membrane();
        self.publish();
        self.energy()
    }
}

/// Rotation sweeps of [`Arap::pose_energy`] for [`Energy::SmoothRotations`].
pub const POSE_ENERGY_SWEEPS: usize = 50;

#[inline]
pub(super) fn ms(a: Instant, b: Instant) -> f64 {
    (b - a).as_secs_f64() * 1e3
}

/// $v_{it}$: the weighted rest edges of triangle $t$ (half cotangents `w`, rest edges `e`
/// opposite each corner) at its corner `c`, $w_{c+2} e_{c+2} - w_{c+1} e_{c+1}$ with
/// $e_{c+1} = p_{c+2} - p_c$ and $e_{c+2} = p_c - p_{c+1}$: what the rhs of vertex $i$ at
/// corner `c` gets from $t$'s rotation.
fn corner_edges(w: &[f64; 3], e: &[[f64; 3]; 3], c: usize) -> [f64; 3] {
    use crate::geometry::mesh::{add, scale};
    add(scale(e[(c + 2) % 3], w[(c + 2) % 3]), scale(e[(c + 1) % 3], -w[(c + 1) % 3]))
}
