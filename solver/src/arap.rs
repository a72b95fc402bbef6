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
//! [`crate::rotation::fit_rotation`]; parallel over vertices (rayon).
//! **Global step** (Eq. 4): $L_{FF}\,p'_F = b_F - L_{FH}\,p'_H$ with
//! $b_j = \sum_{t}\sum_{(j,k)\in t} w^t_{jk}\,\bar R_t\,e_{jk}$, $\bar R_t$ the mean of the three
//! rotations of triangle $t$ (spokes and rims), or $b_i = \sum_j \tfrac{w_{ij}}2(R_i+R_j)e_{ij}$
//! (spokes). $L_{FF}$ is factored once per handle set ([`crate::linsolve::SpdFactor`]); an
//! iteration is one 3-column back-substitution.
//!
//! Each local and each global step weakly decreases $E$; iteration stops when the relative
//! decrease $(E_{k-1}-E_k)/E_{k-1}$ falls below the tolerance, or at the iteration cap.
//!
//! Inputs: a [`Mesh`] (`#V×3`, `#F×3`), [`Handles`], an [`ArapConfig`]; targets `#H×3` in the
//! order of [`Handles::handle_vertices`]. Known limitation: convergence is linear, slow for
//! large rotations of far-apart handles (what BS-ARAP's smooth base is meant to help with).

use crate::constraints::Constraints;
use crate::cotan::{edge_weights, face_cotangents, laplacian_triplets, opposite_edge};
use crate::error::SolveError;
use crate::handles::Handles;
use crate::linsolve::SpdFactor;
use crate::mesh::{Mesh, sub};
use crate::rotation::{IDENTITY, Mat3, add_mat, add_outer, fit_rotation, mul_vec, scale_mat};
use faer::Mat;
use faer::sparse::Triplet;
use rayon::prelude::*;
use std::time::Instant;

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
}

impl Default for ArapConfig {
    fn default() -> Self {
        ArapConfig { energy: Energy::SpokesAndRims, tolerance: 1e-4, max_iterations: 100 }
    }
}

/// What one call of [`Arap::solve`] did.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct SolveStats {
    /// Local-global iterations run.
    pub iterations: usize,
    /// Whether the tolerance was met (false: stopped at the cap).
    pub converged: bool,
    /// $E(p'_0, R_1)$: the energy of the starting guess (with handles on target).
    pub initial_energy: f64,
    /// Energy after each iteration, $E(p'_k, R_k)$; never increases.
    pub energies: Vec<f64>,
    /// Milliseconds in the local steps (rotation fits), summed over iterations.
    pub local_ms: f64,
    /// Milliseconds assembling right-hand sides.
    pub rhs_ms: f64,
    /// Milliseconds in the back-substitutions.
    pub solve_ms: f64,
    /// Milliseconds evaluating the energy.
    pub energy_ms: f64,
}

impl SolveStats {
    /// Final energy (the initial one when no iteration ran).
    pub fn energy(&self) -> f64 {
        self.energies.last().copied().unwrap_or(self.initial_energy)
    }
    /// Total milliseconds of the solve.
    pub fn total_ms(&self) -> f64 {
        self.local_ms + self.rhs_ms + self.solve_ms + self.energy_ms
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
    /// Per face: half cotangents per corner; per vertex: (face, corner) incidences.
    SpokesAndRims { cot: Vec<[f64; 3]>, vertex_faces: Csr<(u32, u8)> },
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
    /// Per free row: (fixed vertex h, w_ih) so that rhs_i += Σ w_ih x_h.
    coupling: Csr<(u32, f64)>,
    /// `None` when every vertex is fixed.
    factor: Option<SpdFactor>,
    rotations: Vec<Mat3>,
    face_rotation: Vec<Mat3>,
    current: Vec<[f64; 3]>,
    rhs: Mat<f64>,
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
        Arap::with_constraints(mesh, constraints, config, 0.0)
    }

    /// As [`Arap::new`] with a precomputed partition (shared with the bi-harmonic base) and an
    /// absolute floor on doubled triangle areas (see [`face_cotangents`]).
    pub(crate) fn with_constraints(
        mesh: &Mesh,
        constraints: Constraints,
        config: &ArapConfig,
        min_double_area: f64,
    ) -> Result<Arap, SolveError> {
        let n = mesh.n_vertices();
        let tris = mesh.triangles();
        let cot = face_cotangents(mesh.positions(), tris, min_double_area)
            .map_err(|d| SolveError::DegenerateFace { face: d.face })?;
        let clamp = config.energy == Energy::Spokes;
        let weights = edge_weights(tris, &cot, clamp);

        // Free block L_FF (lower triangle) and the coupling to fixed vertices.
        let mut ff = Vec::with_capacity(n + weights.len());
        let mut coupling = Vec::new();
        let mut diag = vec![0.0; constraints.free_vertices.len()];
        for t in laplacian_triplets(n, tris, &cot, clamp) {
            let (fi, fj) = (constraints.free_index[t.row], constraints.free_index[t.col]);
            match (fi, fj) {
                (Some(r), Some(_)) if t.row == t.col => diag[r as usize] += t.val,
                (Some(r), Some(c)) if r > c => ff.push(Triplet::new(r as usize, c as usize, t.val)),
                (Some(r), None) => coupling.push((r, (t.col as u32, -t.val))),
                _ => {}
            }
        }
        ff.extend(diag.iter().enumerate().map(|(r, &d)| Triplet::new(r, r, d)));
        let n_free = constraints.free_vertices.len();
        let factor = if n_free == 0 {
            None
        } else {
            Some(SpdFactor::from_triplets(n_free, &ff).map_err(|source| {
                SolveError::Factorization {
                    matrix: "the free block of the cotangent Laplacian",
                    source,
                }
            })?)
        };
        let coupling = Csr::from_pairs(n_free, &coupling);

        let cells = match config.energy {
            Energy::SpokesAndRims => {
                let mut inc = Vec::with_capacity(3 * tris.len());
                for (f, t) in tris.iter().enumerate() {
                    for (k, &v) in t.iter().enumerate() {
                        inc.push((v, (f as u32, k as u8)));
                    }
                }
                Cells::SpokesAndRims { cot, vertex_faces: Csr::from_pairs(n, &inc) }
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
        Ok(Arap {
            rest: mesh.positions().to_vec(),
            triangles: tris.to_vec(),
            config: *config,
            cells,
            coupling,
            factor,
            rotations: vec![IDENTITY; n],
            face_rotation: vec![IDENTITY; tris.len()],
            current: mesh.positions().to_vec(),
            rhs: Mat::zeros(n_free, 3),
            constraints,
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
        &self.current
    }

    /// Per-vertex rotations $R_i$ of the last local step.
    pub fn rotations(&self) -> &[Mat3] {
        &self.rotations
    }

    /// Rest positions `#V×3`.
    pub fn rest(&self) -> &[[f64; 3]] {
        &self.rest
    }

    /// Nonzeros of the Cholesky factor of $L_{FF}$ (0 when every vertex is fixed).
    pub fn factor_nonzeros(&self) -> usize {
        self.factor.as_ref().map_or(0, |f| f.factor_nonzeros())
    }

    /// Restarts the next solve from the rest pose.
    pub fn reset(&mut self) {
        self.current.copy_from_slice(&self.rest);
        self.rotations.fill(IDENTITY);
    }

    /// Sets the starting guess of the next solve (`#V×3`, finite; other lengths are ignored).
    pub fn set_positions(&mut self, x: &[[f64; 3]]) {
        if x.len() == self.current.len() && x.iter().flatten().all(|c| c.is_finite()) {
            self.current.copy_from_slice(x);
        }
    }

    /// Runs local-global iterations from the current pose with the handle vertices moved to
    /// `targets` (`#H×3`, order of [`Handles::handle_vertices`]) and pinned vertices at rest.
    /// On a non-finite result the previous pose is kept and an error returned.
    pub fn solve(&mut self, targets: &[[f64; 3]]) -> Result<SolveStats, SolveError> {
        let hv = &self.constraints.handle_vertices;
        if targets.len() != hv.len() {
            return Err(SolveError::TargetCount { got: targets.len(), expected: hv.len() });
        }
        if let Some(index) = targets.iter().position(|t| !t.iter().all(|c| c.is_finite())) {
            return Err(SolveError::NonFiniteTarget { index });
        }
        let previous = self.current.clone();
        for (&v, t) in hv.iter().zip(targets) {
            self.current[v as usize] = *t;
        }
        for &v in &self.constraints.pinned_vertices {
            self.current[v as usize] = self.rest[v as usize];
        }
        let mut stats = SolveStats::default();
        let tol = self.config.tolerance;
        for it in 0..self.config.max_iterations {
            let t0 = Instant::now();
            self.local_step();
            let t1 = Instant::now();
            stats.local_ms += ms(t0, t1);
            if it == 0 {
                stats.initial_energy = self.energy();
                stats.energy_ms += ms(t1, Instant::now());
            }
            let t2 = Instant::now();
            self.assemble_rhs();
            let t3 = Instant::now();
            stats.rhs_ms += ms(t2, t3);
            if let Some(f) = self.factor.as_mut() {
                f.solve_in_place(self.rhs.as_mut());
            }
            for (r, &v) in self.constraints.free_vertices.iter().enumerate() {
                self.current[v as usize] = [self.rhs[(r, 0)], self.rhs[(r, 1)], self.rhs[(r, 2)]];
            }
            let t4 = Instant::now();
            stats.solve_ms += ms(t3, t4);
            let e = self.energy();
            stats.energy_ms += ms(t4, Instant::now());
            let prev = stats.energies.last().copied().unwrap_or(stats.initial_energy);
            stats.energies.push(e);
            stats.iterations = it + 1;
            if tol > 0.0 && (prev <= f64::MIN_POSITIVE || (prev - e) / prev < tol) {
                stats.converged = true;
                break;
            }
        }
        if let Some(vertex) = self.current.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
            self.current = previous;
            return Err(SolveError::NonFiniteResult { vertex });
        }
        Ok(stats)
    }

    /// Local step: $R_i$ = best rotation of cell $i$ for the current pose.
    fn local_step(&mut self) {
        let x = &self.current;
        let p = &self.rest;
        match &self.cells {
            Cells::SpokesAndRims { cot, vertex_faces } => {
                let tris = &self.triangles;
                // Per-face covariance, then per-vertex sums over the incident faces.
                let face_cov: Vec<Mat3> = tris
                    .par_iter()
                    .zip(cot.par_iter())
                    .map(|(t, w)| {
                        let mut c = [[0.0; 3]; 3];
                        for (k, &wk) in w.iter().enumerate() {
                            let (a, b) = opposite_edge(*t, k);
                            let (a, b) = (a as usize, b as usize);
                            add_outer(&mut c, wk, sub(p[a], p[b]), sub(x[a], x[b]));
                        }
                        c
                    })
                    .collect();
                self.rotations.par_iter_mut().enumerate().for_each(|(i, r)| {
                    let mut s = [[0.0; 3]; 3];
                    for &(f, _) in vertex_faces.row(i) {
                        s = add_mat(&s, &face_cov[f as usize]);
                    }
                    *r = fit_rotation(&s);
                });
            }
            Cells::Spokes { neighbours } => {
                self.rotations.par_iter_mut().enumerate().for_each(|(i, r)| {
                    let mut s = [[0.0; 3]; 3];
                    for &(j, w) in neighbours.row(i) {
                        let j = j as usize;
                        add_outer(&mut s, w, sub(p[i], p[j]), sub(x[i], x[j]));
                    }
                    *r = fit_rotation(&s);
                });
            }
        }
    }

    /// Right-hand side of the global step for the free rows: $b_F - L_{FH} x_H$.
    fn assemble_rhs(&mut self) {
        let p = &self.rest;
        let x = &self.current;
        let rot = &self.rotations;
        let free = &self.constraints.free_vertices;
        let coupling = &self.coupling;
        let rows: Vec<[f64; 3]> = match &self.cells {
            Cells::SpokesAndRims { cot, vertex_faces } => {
                let tris = &self.triangles;
                self.face_rotation.par_iter_mut().zip(tris.par_iter()).for_each(|(fr, t)| {
                    let [a, b, c] = t.map(|v| &rot[v as usize]);
                    *fr = scale_mat(&add_mat(&add_mat(a, b), c), 1.0 / 3.0);
                });
                let face_rotation = &self.face_rotation;
                free.par_iter()
                    .enumerate()
                    .map(|(r, &i)| {
                        let i = i as usize;
                        let mut b = [0.0; 3];
                        for &(f, c) in vertex_faces.row(i) {
                            let t = tris[f as usize];
                            let w = cot[f as usize];
                            let c = c as usize;
                            let (n1, n2) = (t[(c + 1) % 3] as usize, t[(c + 2) % 3] as usize);
                            // Edge (i, n2) is opposite corner c+1; edge (i, n1) opposite c+2.
                            let e = sub(p[i], p[n2]);
                            let g = sub(p[i], p[n1]);
                            let v = [
                                w[(c + 1) % 3] * e[0] + w[(c + 2) % 3] * g[0],
                                w[(c + 1) % 3] * e[1] + w[(c + 2) % 3] * g[1],
                                w[(c + 1) % 3] * e[2] + w[(c + 2) % 3] * g[2],
                            ];
                            let rv = mul_vec(&face_rotation[f as usize], v);
                            b = [b[0] + rv[0], b[1] + rv[1], b[2] + rv[2]];
                        }
                        add_coupling(b, coupling.row(r), x)
                    })
                    .collect()
            }
            Cells::Spokes { neighbours } => free
                .par_iter()
                .enumerate()
                .map(|(r, &i)| {
                    let i = i as usize;
                    let mut b = [0.0; 3];
                    for &(j, w) in neighbours.row(i) {
                        let j = j as usize;
                        let rr = scale_mat(&add_mat(&rot[i], &rot[j]), 0.5 * w);
                        let rv = mul_vec(&rr, sub(p[i], p[j]));
                        b = [b[0] + rv[0], b[1] + rv[1], b[2] + rv[2]];
                    }
                    add_coupling(b, coupling.row(r), x)
                })
                .collect(),
        };
        for (r, b) in rows.iter().enumerate() {
            for (k, &bk) in b.iter().enumerate() {
                self.rhs[(r, k)] = bk;
            }
        }
    }

    /// $E(p', R)$ for the current pose and rotations.
    pub fn energy(&self) -> f64 {
        let x = &self.current;
        let p = &self.rest;
        let rot = &self.rotations;
        match &self.cells {
            Cells::SpokesAndRims { cot, .. } => self
                .triangles
                .par_iter()
                .zip(cot.par_iter())
                .map(|(t, w)| {
                    let mut e = 0.0;
                    for (k, &wk) in w.iter().enumerate() {
                        let (a, b) = opposite_edge(*t, k);
                        let (a, b) = (a as usize, b as usize);
                        let (re, de) = (sub(p[a], p[b]), sub(x[a], x[b]));
                        for &v in t {
                            let d = sub(de, mul_vec(&rot[v as usize], re));
                            e += wk * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
                        }
                    }
                    e
                })
                .sum(),
            Cells::Spokes { neighbours } => (0..x.len())
                .into_par_iter()
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
