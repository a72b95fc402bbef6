//! The smooth-rotations energy of the full mesh restricted to the coarse variant's space (a
//! Galerkin coarse energy), solved at the coarse level's cost per iteration: the coarse
//! variant's coarse energy when [`crate::BaseConfig::coarse_energy`] asks for it
//! ([`crate::deform::coarse::energy`]). [`crate::deform::coarse::fit`] showed that the space
//! holds converged ARAP within hundredths of a percent of the diagonal while ARAP on the
//! decimated base has its minimum tenths of a percent away; this is the coarse energy that
//! aims at the dense one (BENCHMARKS.md, "One pose at every resolution", "The coarse
//! energy").
//!
//! **The restriction.** Fine positions $p_i = P_i c + R_{k(i)} D_i$: coarse positions $c$
//! (`#Vc×3`), the embedding's row $P_i$, the detail $D_i$ turned by the rotation of the
//! cluster $k(i)$ (the fine vertex's representative coarse vertex), and one rotation per
//! cluster for the cells of its fine vertices. The rest edge is
//! $e_{ij} = \delta_{ij} B_c + D_i - D_j$ with $\delta_{ij} = P_i - P_j$, so the spoke residual
//! of the ordered pair $(i,j)$, $i$ in cluster $k$, $j$ in $l$, is
//! $$\delta_{ij} c - R_k\,\delta_{ij} B_c + (R_k - R_l) D_j,$$
//! and the last term, nonzero only across clusters and second order where the rotations vary
//! smoothly, is dropped (kept with the other cluster's rotation lagged, at a fine edge's cost per
//! crossing pair, it changed the armadillo's distance from converged ARAP from 0.607 to 0.611 %
//! of the diagonal in an experiment with a stiffer handle penalty). What is left is quadratic in
//! $c$ with coefficients gathered through the prolongation: the full mesh's edges once per mesh
//! and coarse base ([`GalerkinMesh`]), the handles' terms once per handle set
//! ([`GalerkinCoarse::new`]). With the spokes weights $w_{ij}$ of the full mesh (the
//! smooth-rotations energy's, `deform::arap::smooth_rotations`):
//! - the global matrix $G = \sum_{(i,j)} w_{ij}\,\delta_{ij}^\top\delta_{ij} = P^\top L P$;
//! - per cluster $k$ and coarse vertex $b$ a vector
//!   $g_{kb} = \sum_{(i,j),\,i\in k} w_{ij}\,(\delta_{ij})_b\,(\beta_i - \beta_j)$,
//!   $\beta = P B_c$, from which the covariance is $S_k = \sum_b g_{kb}\,c_b^\top$ and the
//!   global right-hand side $r_b = \sum_k R_k g_{kb}$: both cost the number of pairs $(k, b)$,
//!   about ten per coarse vertex, whatever the full mesh's size.
//! - The rotation term is the coarse mesh's: $\beta_\ell \sum_k\sum_{l} w^c_{kl}\lVert R_k -
//!   R_l\rVert_F^2$ with $B_c$'s clamped cotangent weights and $\beta_\ell = \ell^2$ (a linear
//!   rotation field's Dirichlet energy on any triangulation; the full mesh's weights summed
//!   across cluster borders would grow with its resolution).
//! - Handles ([`HandleRule`]): the coarse variant's rule ([`HandleRule::Exact`],
//!   `galerkin/exact.rs`) puts every fine handle vertex on its target in the energy, as in the
//!   pose shown, so that the terms of the edges at a handle change and nothing is to be chosen.
//!   Measured beside it: the coarse variant's coarse handles held exactly on their group's rigid
//!   motion (the free block of the matrix factored), or every fine handle vertex on its target
//!   $t_i$ by a penalty $\mu\sum_i \lVert P_i c + R_{k(i)} D_i - t_i\rVert^2$, $\mu$ a weight
//!   times $\max_a G_{aa}$, which adds $\mu P_H^\top P_H$ to the matrix, its part to each
//!   $g_{kb}$ and a per-frame term to $S_k$ and $r$ (the coarse variant's rule before the exact
//!   one: its pose lies as near converged ARAP on average on the paper's sets, with two to three
//!   times the exact rule's excess energy, and its weight is a free scale; BENCHMARKS.md, "The
//!   coarse energy"). Vertices of components without handles are held at rest by the same
//!   penalty (weight $10^3$).
//!
//! **Iterations**: a local step and a global step (the matrix factored once) until the coarse
//! positions move less than a tolerance. The local step forms the clusters' covariances and
//! hands them to the rotation field of `deform::arap::smooth_rotations`, the same code as the
//! full mesh's smooth rotations with the clusters for vertices and the coarse mesh's weights
//! $w^c$: the implicit rotation step of `deform::arap::rotation_solve`
//! ($R_k \leftarrow \exp([\omega_k]_\times) R_k$, $(8\beta_\ell L^c + \operatorname{diag} h)\,
//! \omega = -g$ with $L^c$ the coarse mesh's weighted graph Laplacian, $h_k = \tfrac43
//! \operatorname{tr} S_k$ at rest, factored once), then one Gauss–Seidel sweep by colours of the
//! fits of $X_k = S_k + 2\beta_\ell\sum_l w^c_{kl} R_l^\top$ (each an exact block
//! minimization, a colour's clusters in parallel), the step kept only when step and sweep
//! together lower the rotations' objective. Without the step the rotation field took thousands
//! of iterations (armadillo's bench set from rest: 2,762 against 367 with it, sweeping in index
//! order, to the same pose). The covariances and the global step's right-hand side are gathered
//! per cluster and per coarse vertex in parallel. The energy after each local step is read from
//! its sums (the quadratic in $c$, the rotation objective, constants), so a solve stops either
//! when the positions stop moving or when an iteration lowers the energy by less than a
//! tolerance of it ([`Stop`], the rule of ARAP's solves), and Anderson acceleration of the coarse
//! positions is safeguarded by it ([`GalerkinCoarse::set_acceleration`]). The pose shown is the
//! prolongation of [`mod@crate::deform::coarse::prolong`] (details on the blend of the corner
//! rotations), with constrained vertices on their targets.

mod exact;
mod gathering;
pub(crate) mod mesh_part;

use gathering::{Combiner, add_penalty};
pub use gathering::{galerkin_mesh, gather_mesh_part};
pub use mesh_part::GalerkinMesh;
use mesh_part::{pair_of, row_entry};

use crate::deform::arap::{Acceleration, Csr, SmoothRotations, SolveStats, vertices_per_task};
use crate::deform::coarse::base::CoarseBase;
use crate::deform::coarse::groups::CoarseGroups;
use crate::deform::coarse::prolong::{Prolongation, prolong, quaternion_of};
use crate::deform::constraints::Constraints;
use crate::deform::handles::Handles;
use crate::error::{SolveError, check_bending_length, check_targets};
use crate::geometry::mesh::{Mesh, norm2, sub};
use crate::linalg::anderson::Anderson;
use crate::linalg::linsolve::{FactorError, Layout, SpdFactor, SpdPattern, matrix_of};
use crate::linalg::rotation::{IDENTITY, Mat3, add_outer, mul_vec};
use faer::MatMut;
use faer::sparse::Triplet;
use glam::DQuat;
use rayon::prelude::*;
use std::time::Instant;

/// A constrained fine vertex: its cluster, its embedding, its detail.
#[derive(Debug, Clone, Copy)]
struct Held {
    vertex: u32,
    /// Its index in the handle targets, or `None` for a vertex held at rest.
    target: Option<usize>,
    /// Its rest position.
    rest: [f64; 3],
    /// Its penalty weight $\mu$: the handles' rule's, or [`PINNED_WEIGHT`] (times the unit)
    /// for a vertex held at rest.
    mu: f64,
    cluster: u32,
    corners: [u32; 3],
    weights: [f64; 3],
    detail: [f64; 3],
}

/// The handles' penalty weight of [`HandleRule::Penalty`] where one is measured, times the
/// largest diagonal entry of $G$: on each of the eleven bench sets, the weight (of 1, 0.3, 0.1,
/// 0.03, 0.01) with the least mean distance from converged ARAP over the other ten sets
/// (`bench/results/coarse_space/penalty.txt`).
pub const DEFAULT_PENALTY: f64 = 0.03;

/// The penalty weight of vertices of components without handles (held at rest), times the
/// largest diagonal entry of $G$.
const PINNED_WEIGHT: f64 = 1e3;

/// How the handles hold the Galerkin coarse energy's pose (module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum HandleRule {
    /// Every fine handle vertex by a penalty of `weight` times the largest diagonal entry of
    /// $G$.
    Penalty { weight: f64 },
    /// The coarse variant's coarse handles ([`crate::deform::coarse`], "Handles on the coarse
    /// level") held exactly on their group's rigid motion.
    CoarseVertices,
    /// The penalty of [`HandleRule::Penalty`], and the coarse vertices inside a handle (all
    /// the fine vertices they represent in one group) held exactly on its rigid motion: exact
    /// where a handle covers whole clusters, a penalty only at its border.
    PenaltyAndInterior { weight: f64 },
    /// The penalty of [`HandleRule::Penalty`] with the median diagonal entry of $G$ for its unit
    /// instead of the largest, which is an outlier. Measured, not better on the paper's sets
    /// held out (`bench/results/coarse_space/README.md`, "The penalty's unit").
    PenaltyOfMedian { weight: f64 },
    /// Every fine handle vertex on its target in the energy, as in the pose shown
    /// (`galerkin/exact.rs`): no weight.
    Exact,
}

/// Anderson acceleration of the free coarse positions (as `deform::arap`'s Anderson loop):
/// its history, the extrapolated iterate and the rotations of the last accepted one.
#[derive(Debug)]
struct AndersonWork {
    aa: Anderson,
    xa: Vec<f64>,
    rotations: Vec<Mat3>,
}

/// The buffers of one [`GalerkinCoarse::solve`], kept between solves.
#[derive(Debug, Default)]
struct FrameScratch {
    tau: Vec<[f64; 3]>,
    sigma: Vec<Mat3>,
    rhs: Vec<f64>,
    x: Vec<f64>,
}

/// When [`GalerkinCoarse::solve`] stops.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Stop {
    /// When the coarse positions move less than `distance` in an iteration.
    Moved { distance: f64 },
    /// When an iteration lowers the energy by less than `tolerance` of it: the rule of ARAP's
    /// solves ([`crate::ArapConfig::tolerance`]).
    Decrease { tolerance: f64 },
}

/// The Galerkin coarse energy for one mesh, coarse base and handle set (module doc).
#[derive(Debug)]
pub struct GalerkinCoarse {
    /// Per cluster $k$, its pairs $(b, g_{kb})$.
    pairs: Csr<(u32, [f64; 3])>,
    /// Per coarse vertex $b$, its pairs $(k, g_{kb})$ (the same values by coarse vertex, for
    /// the global step's right-hand side).
    by_coarse: Csr<(u32, [f64; 3])>,
    /// The coarse mesh's clamped cotangent edges: per cluster $k$, its $(l, w^c_{kl})$.
    neighbours: Csr<(u32, f64)>,
    /// The penalized vertices: the handle vertices under the penalty rules (under the exact
    /// rule their tiny penalty is in `exact_terms`), then the vertices held at rest.
    held: Vec<Held>,
    /// The per-frame terms of the edges with a handle end under [`HandleRule::Exact`] (none
    /// under the other rules).
    exact_terms: exact::FrameTerms,
    /// The fine handle vertices (order of their targets) and their rest positions.
    handle_vertices: Vec<u32>,
    handle_rest: Vec<[f64; 3]>,
    factor: SpdFactor,
    /// $G$ with the handles' terms, every coarse vertex, both orders (for the energy).
    matrix: Csr<(u32, f64)>,
    /// The energy's constants: the edges' ([`GalerkinMesh`], changed at the handles by the
    /// exact rule) and the held vertices' $\mu\sum_i\lVert D_i\rVert^2$ (the targets'
    /// $\mu\sum_i\lVert t_i\rVert^2$ and the exact rule's are added per solve).
    constant: f64,
    /// The energy after the last iteration ([`GalerkinCoarse::energy`]).
    energy: f64,
    /// Per coarse vertex, its row in the factored (free) block, or `None` when a coarse
    /// handle ([`HandleRule::CoarseVertices`]).
    free: Vec<Option<u32>>,
    /// The matrix's entries coupling free rows to coarse handles: (free row, coarse vertex, value).
    coupling: Vec<(u32, u32, f64)>,
    /// The coarse handles' groups and their targets' rule, with [`HandleRule::CoarseVertices`].
    groups: Option<CoarseGroups>,
    c: Vec<[f64; 3]>,
    /// The coarse mesh's rest positions.
    rest_c: Vec<[f64; 3]>,
    rotations: Vec<Mat3>,
    /// The rotation field's local step on the clusters (`deform::arap`'s smooth rotations:
    /// the implicit step, the sweep by colours, the safeguard) with its buffers.
    field: SmoothRotations,
    /// Clusters per parallel task.
    block: usize,
    /// $\sum_k R_k g_{kb}$ per coarse vertex (scratch of the global step).
    gathered: Vec<[f64; 3]>,
    /// Per solve, reused: τ, σ (module doc) and the global step's right-hand side and iterate
    /// (as [`gather`] writes them).
    frame: FrameScratch,
    /// Anderson acceleration's state and scratch, when on
    /// ([`GalerkinCoarse::set_acceleration`]).
    anderson: Option<AndersonWork>,
}

impl GalerkinCoarse {
    /// The energy for the handles of `handles` (their partition `constraints`,
    /// [`Constraints::new`] of `mesh` and `handles`, which the caller has made for its own
    /// use) and the bending length `bending_length`·diag of `mesh`: the handles' terms added
    /// to `gathered`, the mesh's part for `mesh` and `base` ([`gather_mesh_part`]);
    /// [`SolveError::StaleBase`] when `gathered` was gathered for another mesh or base.
    pub fn new(
        mesh: &Mesh,
        base: &CoarseBase,
        gathered: &GalerkinMesh,
        handles: &Handles,
        constraints: &Constraints,
        bending_length: f64,
        rule: HandleRule,
    ) -> Result<GalerkinCoarse, SolveError> {
        check_bending_length(bending_length)?;
        debug_assert_eq!(
            constraints.handle_vertices,
            handles.handle_vertices(),
            "another handle set"
        );
        let coarse = &base.coarse_mesh;
        let m = coarse.n_vertices();
        if gathered.sizes != (mesh.n_vertices(), m) || base.details.len() != mesh.n_vertices() {
            return Err(SolveError::StaleBase);
        }
        let (mut g, mut pair, g_max) = (gathered.g.clone(), gathered.pair.clone(), gathered.g_max);
        let g_median = gathered.g_median;
        let neighbours = gathered.neighbours.clone();
        let pinned_mu = PINNED_WEIGHT * g_max;
        // The exact rule's handles keep their tiny penalty in its per-frame terms (`exact.rs`).
        let hold = exact::HOLD * g_max;
        let (mu, penalized, groups) = match rule {
            // No handle vertex in `held`: its penalty is the exact rule's (`hold`).
            HandleRule::Exact => (0.0, 0, None),
            HandleRule::Penalty { weight } => {
                (weight * g_max, constraints.handle_vertices.len(), None)
            }
            HandleRule::PenaltyOfMedian { weight } => {
                (weight * g_median, constraints.handle_vertices.len(), None)
            }
            HandleRule::CoarseVertices => {
                (pinned_mu, 0, Some(CoarseGroups::new(base, handles, mesh.positions())))
            }
            HandleRule::PenaltyAndInterior { weight } => (
                weight * g_max,
                constraints.handle_vertices.len(),
                Some(CoarseGroups::inside(base, handles, mesh.positions())),
            ),
        };
        // Handle vertices under the penalty (all or none), then pinned vertices (always).
        let held: Vec<Held> = constraints.handle_vertices[..penalized]
            .iter()
            .enumerate()
            .map(|(t, &v)| (Some(t), v, mu))
            .chain(constraints.pinned_vertices.iter().map(|&v| (None, v, pinned_mu)))
            .map(|(target, v, mu)| {
                let (corners, weights) = base.embedding(v as usize);
                Held {
                    vertex: v,
                    target,
                    rest: mesh.positions()[v as usize],
                    mu,
                    cluster: base.representative[v as usize],
                    corners,
                    weights,
                    detail: base.details[v as usize],
                }
            })
            .collect();
        let mut constant = gathered.rest_term;
        {
            let (mut g, mut pair) = (Combiner::new(&mut g), Combiner::new(&mut pair));
            for h in &held {
                let row = (h.corners, h.weights);
                constant += add_penalty(&mut g, &mut pair, row, h.cluster, h.mu, h.detail);
            }
        }
        let exact_terms = if rule == HandleRule::Exact {
            let (handles, blocks) = (&constraints.handle_vertices, exact::Blocks::PARALLEL);
            let (terms, change) =
                exact::hold_exactly(mesh, base, handles, hold, &mut g, &mut pair, blocks)?;
            constant += change;
            terms
        } else {
            exact::FrameTerms::none(m)
        };
        let eps = 1e-12 * g_max;
        // The free block: every coarse vertex but the coarse handles.
        let mut free = vec![None; m];
        let mut n_free = 0u32;
        for (k, f) in free.iter_mut().enumerate() {
            if groups.as_ref().is_none_or(|g| g.labels[k].is_none()) {
                *f = Some(n_free);
                n_free += 1;
            }
        }
        let mut triplets: Vec<_> = (0..n_free as usize).map(|a| Triplet::new(a, a, eps)).collect();
        let mut coupling = Vec::new();
        // By key, so that the sums do not depend on the maps' history (gathered here, or read
        // from the disk cache).
        let mut g: Vec<(u64, f64)> = g.into_iter().collect();
        g.sort_unstable_by_key(|e| e.0);
        let mut pair: Vec<(u64, [f64; 3])> = pair.into_iter().collect();
        pair.sort_unstable_by_key(|e| e.0);
        for &(key, v) in &g {
            let (a, b) = pair_of(key);
            match (free[a as usize], free[b as usize]) {
                (Some(fa), Some(fb)) => triplets.push(Triplet::new(fa as usize, fb as usize, v)),
                (Some(fa), None) => coupling.push((fa, b, v)),
                (None, Some(fb)) => coupling.push((fb, a, v)),
                (None, None) => {}
            }
        }
        let factor = coarse_factor(gathered, n_free as usize, &triplets, groups.is_none())
            .map_err(|source| SolveError::Factorization { matrix: "PᵀLP (Galerkin)", source })?;
        let entries: Vec<_> = g
            .iter()
            .flat_map(|&(key, v)| {
                let (a, b) = pair_of(key);
                let mirrored = (a != b).then_some((b, (a, v)));
                std::iter::once((a, (b, v))).chain(mirrored)
            })
            .collect();
        let matrix = Csr::from_pairs(m, &entries);
        let pairs: Vec<_> = pair.into_iter().map(row_entry).collect();
        let pairs = Csr::from_pairs(m, &pairs);
        let by_coarse: Vec<_> = (0..m)
            .flat_map(|k| pairs.row(k).iter().map(move |&(b, g)| (b, (k as u32, g))))
            .collect();
        let by_coarse = Csr::from_pairs(m, &by_coarse);
        // The masses m_k = tr S_k at rest: Σ_b g_kb·B_c,b, and the penalty's μ‖D_i‖² (its −d
        // part is in g already, its σ part at rest targets is μ D_i·M_i).
        let rest_c = coarse.positions();
        let mut masses = vec![0.0; m];
        for (k, mk) in masses.iter_mut().enumerate() {
            for &(b, gv) in pairs.row(k) {
                let p = rest_c[b as usize];
                *mk += gv[0] * p[0] + gv[1] * p[1] + gv[2] * p[2];
            }
        }
        for hd in &held {
            let p = mesh.positions()[hd.vertex as usize];
            let d = hd.detail;
            masses[hd.cluster as usize] += hd.mu * (d[0] * p[0] + d[1] * p[1] + d[2] * p[2]);
        }
        // The exact rule's σ_k at rest targets.
        let rest_targets: Vec<_> =
            constraints.handle_vertices.iter().map(|&v| mesh.positions()[v as usize]).collect();
        let mut rest_sigma = vec![[[0.0; 3]; 3]; m];
        exact_terms.add(&rest_targets, &mut vec![[0.0; 3]; m], &mut rest_sigma);
        for (mk, s) in masses.iter_mut().zip(&rest_sigma) {
            *mk += s[0][0] + s[1][1] + s[2][2];
        }
        let ell = bending_length * mesh.bbox_diagonal();
        let field =
            SmoothRotations::with_masses(&neighbours, &masses, ell, None).map_err(|source| {
                SolveError::Factorization { matrix: "rotation step (Galerkin)", source }
            })?;
        Ok(GalerkinCoarse {
            pairs,
            by_coarse,
            neighbours,
            held,
            handle_rest: rest_targets,
            exact_terms,
            handle_vertices: constraints.handle_vertices.clone(),
            factor,
            matrix,
            constant,
            energy: 0.0,
            free,
            coupling,
            groups,
            c: coarse.positions().to_vec(),
            rest_c: coarse.positions().to_vec(),
            rotations: vec![IDENTITY; m],
            field,
            block: vertices_per_task(m),
            gathered: vec![[0.0; 3]; m],
            frame: FrameScratch::default(),
            anderson: None,
        })
    }

    /// Iterates from the last solve's coarse pose and rotations (rest at first) until `stop`
    /// holds or `max_iterations`. An iteration is a global step and a local step, after one
    /// local step for the new targets, so that the energy ([`GalerkinCoarse::energy`]) is read
    /// from the local step's sums at no extra pass and the rotations end fitted to the result.
    /// `targets` are the handle vertices' (order of [`Handles::handle_vertices`]); components
    /// without handles stay at rest. Every target at its rest position gives the rest pose
    /// (the minimizer, energy 0) without iterating. A wrong number of targets or a non-finite
    /// one is an error. The statistics: the iterations, whether `stop` held, the energy of the
    /// start and after each iteration, the milliseconds (all counted as local steps) and the
    /// rejected Anderson steps.
    pub fn solve(
        &mut self,
        targets: &[[f64; 3]],
        stop: Stop,
        max_iterations: usize,
    ) -> Result<SolveStats, SolveError> {
        check_targets(targets, self.handle_vertices.len())?;
        if self.handle_rest.iter().zip(targets).all(|(r, t)| r == t) {
            self.reset();
            return Ok(SolveStats { converged: true, ..SolveStats::default() });
        }
        let started = Instant::now();
        let m = self.c.len();
        // Per frame: τ = μ P_Cᵀ t, σ_k = μ Σ_{i∈C∩k} D_i t_iᵀ and the constant μ Σ ‖t_i‖².
        let FrameScratch { mut tau, mut sigma, mut rhs, mut x } = std::mem::take(&mut self.frame);
        tau.clear();
        tau.resize(m, [0.0; 3]);
        sigma.clear();
        sigma.resize(m, [[0.0; 3]; 3]);
        let mut constant = self.constant;
        for h in &self.held {
            let t = h.target.map_or(h.rest, |t| targets[t]);
            for a in 0..3 {
                let e = &mut tau[h.corners[a] as usize];
                for d in 0..3 {
                    e[d] += h.mu * h.weights[a] * t[d];
                }
            }
            add_outer(&mut sigma[h.cluster as usize], h.mu, h.detail, t);
            constant += h.mu * norm2(t);
        }
        constant += self.exact_terms.add(targets, &mut tau, &mut sigma);
        // Coarse handles on their group's rigid motion (the coarse variant's rule).
        if let Some(groups) = &self.groups {
            let (mut motions, mut coarse_targets) = (Vec::new(), Vec::new());
            groups.targets(targets, None, &mut motions, &mut coarse_targets);
            // The coarse handles in ascending order, as their targets come.
            let held = self.c.iter_mut().zip(&self.free).filter(|(_, f)| f.is_none());
            for ((c, _), t) in held.zip(&coarse_targets) {
                *c = *t;
            }
        }
        let nf = self.factor.n();
        rhs.resize(3 * nf, 0.0);
        x.resize(3 * nf, 0.0);
        gather(&self.free, &self.c, &mut x);
        let mut accelerated = self.anderson.take();
        if let Some(work) = &mut accelerated {
            work.aa.reset();
        }
        self.energy = self.local_step(&sigma, &tau, constant);
        let mut stats = SolveStats { initial_energy: self.energy, ..SolveStats::default() };
        for iteration in 1..=max_iterations {
            // Global step on the free block: r = τ + Σ_k R_k g_k − A_FH c_H.
            let (by_coarse, rotations) = (&self.by_coarse, &self.rotations);
            self.gathered.par_iter_mut().zip(&tau).enumerate().for_each(|(b, (r, t))| {
                *r = *t;
                for &(k, gv) in by_coarse.row(b) {
                    let v = mul_vec(&rotations[k as usize], gv);
                    for d in 0..3 {
                        r[d] += v[d];
                    }
                }
            });
            for (r, f) in self.gathered.iter().zip(&self.free) {
                if let Some(f) = f {
                    for d in 0..3 {
                        rhs[d * nf + *f as usize] = r[d];
                    }
                }
            }
            for &(f, h, v) in &self.coupling {
                let c = self.c[h as usize];
                for d in 0..3 {
                    rhs[d * nf + f as usize] -= v * c[d];
                }
            }
            self.factor.solve_in_place(MatMut::from_column_major_slice_mut(&mut rhs, nf, 3));
            // rhs = G(x), the plain step; with Anderson, the extrapolated step when it does not
            // raise the energy.
            let previous = self.energy;
            let mut moved = 0.0;
            let plain = match &mut accelerated {
                None => true,
                Some(work) => {
                    // x stays for the move's size: the step extrapolates a copy.
                    work.xa.copy_from_slice(&x);
                    work.aa.step(&mut work.xa, &rhs);
                    // The rotations are state: the fallback starts from those of x.
                    work.rotations.clone_from(&self.rotations);
                    scatter(&self.free, &work.xa, &mut self.c);
                    let e = self.local_step(&sigma, &tau, constant);
                    if e <= previous {
                        self.energy = e;
                        moved = largest_move(&x, &work.xa, nf);
                        std::mem::swap(&mut x, &mut work.xa);
                        false
                    } else {
                        // Safeguard: the plain step instead, and the history restarts.
                        stats.rejected_steps += 1;
                        work.aa.reset();
                        self.rotations.clone_from(&work.rotations);
                        true
                    }
                }
            };
            if plain {
                moved = largest_move(&x, &rhs, nf);
                std::mem::swap(&mut x, &mut rhs);
                scatter(&self.free, &x, &mut self.c);
                self.energy = self.local_step(&sigma, &tau, constant);
            }
            stats.iterations = iteration;
            stats.energies.push(self.energy);
            let done = match stop {
                Stop::Moved { distance } => moved < distance,
                Stop::Decrease { tolerance } => {
                    previous <= f64::MIN_POSITIVE || (previous - self.energy) / previous < tolerance
                }
            };
            if done {
                stats.converged = true;
                break;
            }
        }
        self.anderson = accelerated;
        self.frame = FrameScratch { tau, sigma, rhs, x };
        stats.local_ms = started.elapsed().as_secs_f64() * 1e3;
        Ok(stats)
    }

    /// The coarse positions of the last solve (rest before any), `#Vc×3`.
    pub fn positions(&self) -> &[[f64; 3]] {
        &self.c
    }

    /// The clusters' rotations of the last solve, fitted to its positions.
    pub fn rotations(&self) -> &[Mat3] {
        &self.rotations
    }

    /// Puts the coarse positions back to `c` (`#Vc×3`; a caller's roll-back after a failed
    /// step); the rotations are fitted to them by the next solve's first local step.
    pub fn set_positions(&mut self, c: &[[f64; 3]]) {
        self.c.copy_from_slice(c);
    }

    /// Restarts from rest: the coarse rest positions, identity rotations, energy 0.
    pub fn reset(&mut self) {
        self.c.copy_from_slice(&self.rest_c);
        self.rotations.fill(IDENTITY);
        self.energy = 0.0;
    }

    /// The local step at the current coarse pose: the clusters' covariances
    /// $S_k = \sigma_k + \sum_b g_{kb} c_b^\top$, then the rotation field's step (implicit
    /// step, sweep by colours, safeguard). Returns the energy of the pose with the new
    /// rotations, $c^\top G c - 2\tau\cdot c - 2\sum_k\operatorname{tr}(R_kS_k) + \beta_\ell
    /// \sum_k\sum_l w^c_{kl}\lVert R_k - R_l\rVert_F^2$ plus `constant`.
    fn local_step(&mut self, sigma: &[Mat3], tau: &[[f64; 3]], constant: f64) -> f64 {
        let (pairs, c) = (&self.pairs, &self.c);
        let covariances = self.field.covariances_mut();
        covariances.par_iter_mut().zip(sigma).enumerate().for_each(|(k, (x, s))| {
            *x = *s;
            for &(b, gv) in pairs.row(k) {
                add_outer(x, 1.0, gv, c[b as usize]);
            }
        });
        let start = self.field.start_sums(&self.neighbours, &self.rotations, self.block);
        let swept =
            self.field.rotation_step(&self.neighbours, &mut self.rotations, &start, self.block);
        // Summed per block and then in order, so that the sum does not depend on the scheduling.
        let (matrix, block) = (&self.matrix, self.block);
        let parts: Vec<f64> = c
            .par_chunks(block)
            .zip(tau.par_chunks(block))
            .enumerate()
            .map(|(chunk, (cs, ts))| {
                let mut sum = 0.0;
                for (i, (ca, ta)) in cs.iter().zip(ts).enumerate() {
                    let mut gc = [0.0; 3];
                    for &(b, v) in matrix.row(chunk * block + i) {
                        let cb = c[b as usize];
                        for d in 0..3 {
                            gc[d] += v * cb[d];
                        }
                    }
                    sum += (0..3).map(|d| ca[d] * (gc[d] - 2.0 * ta[d])).sum::<f64>();
                }
                sum
            })
            .collect();
        let quadratic: f64 = parts.iter().sum();
        quadratic + swept.objective(self.field.beta()) + constant
    }

    /// Plain iterations (the default) or Anderson acceleration of the free coarse positions
    /// with a window of `window` steps, safeguarded as ARAP's Anderson loop is: an extrapolated
    /// iterate whose energy exceeds the last accepted one is replaced by the plain step, from
    /// the rotations of that one. The history restarts with every solve.
    pub fn set_acceleration(&mut self, acceleration: Acceleration) {
        self.anderson = match acceleration {
            Acceleration::Anderson { window } if window > 0 => {
                let dim = 3 * self.factor.n();
                Some(AndersonWork {
                    aa: Anderson::new(window, dim),
                    xa: vec![0.0; dim],
                    rotations: Vec::new(),
                })
            }
            _ => None,
        };
    }

    /// The energy (module doc) of the last solve's result: its coarse pose with the rotations
    /// fitted to it.
    pub fn energy(&self) -> f64 {
        self.energy
    }

    /// The pose of the full mesh: the prolongation of the coarse pose and rotations, constrained
    /// vertices on `targets` and at rest.
    pub fn pose(&self, base: &CoarseBase, targets: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let mut out = self.prolonged(base);
        for h in &self.held {
            out[h.vertex as usize] = h.rest;
        }
        for (&v, t) in self.handle_vertices.iter().zip(targets) {
            out[v as usize] = *t;
        }
        out
    }

    /// The largest distance between a handle vertex's prolonged position and its target: the
    /// step [`GalerkinCoarse::pose`] closes at the handle's border; NaN when a prolonged handle
    /// vertex or its target is not finite (`f64::max` would drop it and report a small gap).
    pub fn handle_gap(&self, base: &CoarseBase, targets: &[[f64; 3]]) -> f64 {
        let out = self.prolonged(base);
        self.handle_vertices
            .iter()
            .zip(targets)
            .map(|(&v, t)| norm2(sub(out[v as usize], *t)).sqrt())
            .fold(0.0, |m, d| if d > m || d.is_nan() { d } else { m })
    }

    /// The prolongation of the coarse pose and rotations, every vertex.
    fn prolonged(&self, base: &CoarseBase) -> Vec<[f64; 3]> {
        let q: Vec<DQuat> = self.rotations.iter().map(quaternion_of).collect();
        let mut out = vec![[0.0; 3]; base.details.len()];
        prolong(
            Prolongation {
                coarse: &self.c,
                quaternions: &q,
                triangles: base.coarse_mesh.triangles(),
                faces: &base.faces,
                weights: &base.weights,
                details: &base.details,
                corrections: &[],
            },
            &mut out,
        );
        out
    }
}

/// The factor of the free block (`n` rows, `triplets`); with every coarse vertex free
/// (`all_free`), on the mesh part's kept analysis of that pattern, made by the first such
/// handle set ([`GalerkinMesh`]'s `pattern`), unless this matrix's pattern is another.
/// Simplicial, as ARAP's global factor, so that each iteration's three-column solve runs on
/// the elimination-tree split (`linalg::linsolve`): faer's own choice was supernodal on the
/// bunny's, solved on one thread, and its coarse iterations took 1.2–1.4× as long (means of
/// alternated runs, `bench/results/coarse_energy/layout.txt`).
fn coarse_factor(
    gathered: &GalerkinMesh,
    n: usize,
    triplets: &[Triplet<usize, usize, f64>],
    all_free: bool,
) -> Result<SpdFactor, FactorError> {
    let a = matrix_of(n, triplets)?;
    if !all_free {
        return SpdFactor::new(&a, Layout::Simplicial);
    }
    let pattern = match gathered.pattern.get() {
        Some(pattern) => pattern,
        None => {
            let pattern = SpdPattern::new(&a, Layout::Simplicial)?;
            gathered.pattern.get_or_init(|| pattern)
        }
    };
    if pattern.fits(&a) {
        SpdFactor::with_pattern(pattern, &a)
    } else {
        SpdFactor::new(&a, Layout::Simplicial)
    }
}

/// The free rows of `c` into `x` (column-major, three columns of the free rows).
fn gather(free: &[Option<u32>], c: &[[f64; 3]], x: &mut [f64]) {
    let nf = x.len() / 3;
    for (c, f) in c.iter().zip(free) {
        if let Some(f) = f {
            for d in 0..3 {
                x[d * nf + *f as usize] = c[d];
            }
        }
    }
}

/// `x` (as [`gather`] writes it) into the free rows of `c`.
fn scatter(free: &[Option<u32>], x: &[f64], c: &mut [[f64; 3]]) {
    let nf = x.len() / 3;
    for (c, f) in c.iter_mut().zip(free) {
        if let Some(f) = f {
            *c = [x[*f as usize], x[nf + *f as usize], x[2 * nf + *f as usize]];
        }
    }
}

/// The largest distance a free row moves from `a` to `b` (as [`gather`] writes them).
fn largest_move(a: &[f64], b: &[f64], nf: usize) -> f64 {
    (0..nf)
        .map(|r| (0..3).map(|d| (b[d * nf + r] - a[d * nf + r]).powi(2)).sum::<f64>().sqrt())
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests;
