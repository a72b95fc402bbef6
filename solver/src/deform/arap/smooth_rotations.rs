//! Smooth-rotation ARAP, SR-ARAP (Levi & Gotsman, "Smooth Rotation Enhanced
//! As-Rigid-As-Possible Mesh Animation", TVCG 2015): the spokes energy plus a term that asks
//! neighbouring rotations to agree, [`Energy::SmoothRotations`](super::Energy::SmoothRotations).
//!
//! **Energy.** With the clamped cotangent spoke weights
//! $w_{ij} = \max(0, \tfrac12(\cot\alpha_{ij} + \cot\beta_{ij}))$ (the spokes cells'
//! weights) and $\beta = \ell^2$,
//! $$E(p', R) = \sum_i \sum_{j\in N(i)} w_{ij}\,\lVert (p'_i-p'_j) - R_i(p_i-p_j)\rVert^2 +
//! \beta \sum_i \sum_{j\in N(i)} w_{ij}\,\lVert R_i - R_j\rVert_F^2,$$
//! both sums over ordered pairs (every edge twice). $\ell$ is the *bending length* in world
//! units: [`ArapConfig::bending_length`](super::ArapConfig::bending_length) times the rest
//! bounding-box diagonal.
//!
//! **Continuum limit.** For a function $f$ linear on each triangle, the cotangent formula
//! (Pinkall & Polthier 1993) is exact: $\int_S \lVert\nabla f\rVert^2\,dA = \sum_{\text{edges}}
//! \tfrac12(\cot\alpha+\cot\beta)(f_i-f_j)^2 = \tfrac12\sum_i\sum_j w_{ij}(f_i-f_j)^2$. Applied to
//! each entry of the rotation field interpolated linearly over the triangles, the second sum is
//! $2\int_S \lVert\nabla R\rVert^2\,dA$ whatever the triangulation (on Delaunay-like meshes,
//! where the clamp does not act). Applied to the entries of $M x$ for a constant matrix $M$,
//! $\sum_i\sum_j w_{ij}\lVert M e_{ij}\rVert^2 = 2\int_S\lVert M P\rVert_F^2\,dA$ with $P$ the
//! tangent projector, so where $\nabla\varphi$ and $R$ vary slowly over a one-ring the first
//! sum is $2\int_S\lVert(\nabla\varphi - R)P\rVert_F^2\,dA$. Both carry the same factor 2 and
//! cotangent weights are dimensionless, so no area normalisation enters $\beta$:
//! $$E \approx 2\Big(\int_S \lVert\nabla\varphi - R\rVert^2\,dA + \ell^2\int_S \lVert\nabla
//! R\rVert^2\,dA\Big),$$
//! an energy of the surface, not of its mesh; plain ARAP is the limit $\ell \to 0$ at fixed mesh
//! and has no mesh-independent counterpart (its rotations may jump from cell to cell, so its
//! bending stiffness falls with the edge length). CGAL's `SRE_ARAP` uses uniform weights and
//! $\beta = \alpha\cdot$area instead.
//!
//! **Local step.** The rotations couple, so the local step is block-coordinate descent over
//! $R_i$ with the pose and the other rotations fixed. The terms of $E$ with $R_i$ are
//! $-2\operatorname{tr}(R_i S_i)$ with $S_i = \sum_j w_{ij}(p_i-p_j)(p'_i-p'_j)^\top$ (the
//! spokes covariance), and, from the pairs $(i,j)$ and $(j,i)$,
//! $2\beta\sum_j w_{ij}\lVert R_i-R_j\rVert_F^2 = \text{const} - 4\beta\sum_j
//! w_{ij}\operatorname{tr}(R_i R_j^\top)$. So $R_i$ maximizes
//! $$\operatorname{tr}\big(R_i X_i\big),\qquad X_i = S_i + 2\beta\sum_j w_{ij} R_j^\top,$$
//! the ARAP fit ([`fit_rotation_near`]) of the augmented covariance. The update is taken only
//! when it does not lower $\operatorname{tr}(R_i X_i)$ (the fit's own tolerance can miss the
//! maximum), so each update does not raise $E$.
//!
//! Rotation updates are Gauss–Seidel by colours: a greedy colouring of the vertex graph
//! ([`colour_classes`], 6–9 colours on a triangle mesh) makes the vertices of one colour
//! independent, so each colour's fits run in parallel and the sweep is exactly a sequential
//! Gauss–Seidel sweep in colour order, which never raises $E$ (each update is an exact block
//! minimization, safeguarded as above). Simultaneous (Jacobi) updates of all vertices from the
//! old neighbours are not guaranteed to descend once the fits project onto rotations (for the
//! linearized problem with nonnegative weights they do: $2D - H = D + A \succeq 0$); from
//! scrambled rotations one colour sweep lowers $E$ further than one Jacobi update (test
//! `colour_sweeps_descend_and_beat_jacobi`), and whole solves took fewer iterations (bumpy bar
//! of 10,242 vertices, one cap turned 0.9 rad, tolerance $10^{-8}$, release build: ℓ = 0.02·diag
//! 1,288 iterations with colours against 2,334 Jacobi; ℓ = 0.05·diag 2,865 against the
//! 3,000 cap, unconverged), so colours it is, at the same cost per sweep
//! (one fit per vertex) plus one fork–join per colour. One sweep per local step.
//!
//! **Global step**: unchanged (the rotation term does not depend on $p'$): the spokes system
//! $L_{FF}p'_F = b_F - L_{FH}p'_H$, $b_i = \sum_j \tfrac{w_{ij}}2(R_i+R_j)(p_i-p_j)$. Each
//! global step and each sweep weakly lowers $E$, so plain iterations descend monotonically;
//! the Anderson loop's safeguard restores the rotations of the last accepted iterate before its
//! fallback step, since here the rotations are state, not a function of the pose.
//!
//! Inputs: the spokes cells' neighbour lists with their weights, the current pose and
//! rotations of the [`Arap`]. [`SmoothRotations`] takes the neighbour lists and the rotations
//! as arguments, so the Galerkin coarse energy (`deform::coarse::galerkin`) runs the same
//! sweep, implicit step and safeguard on its clusters. A sweep smooths the rotation field like one step of heat flow, so
//! on its own it needs $\sim(\ell/h)^2$ local steps for a field $\ell$ many edge lengths
//! stiff; each local step therefore first takes the implicit step of [`super::rotation_solve`]
//! (one prefactored three-column solve), kept when it and the sweep after it lower $E$
//! ([`Arap::smooth_local_steps`]). On Cheburashka (bench set
//! `cheburashka-b`, ℓ = 0.02·diag, tolerance $10^{-9}$, Anderson 5) that took converged solves
//! from 1,702 to 165 iterations, and 151 and 146 at 4× and 16× its vertices
//! (`examples/refinement.rs`): iterations no longer grow with the resolution.

use super::rotation_solve::{self, RotationSolve};
use super::{Arap, Cells, Csr};
use crate::geometry::mesh::{norm2, sub};
use crate::linalg::linsolve::FactorError;
use crate::linalg::rotation::{
    IDENTITY, LANES, Mat3, fit_rotation_near, fit_rotations_near, trace_of_product,
};
use crate::linalg::two_grid::Interpolation;
use rayon::prelude::*;
use std::sync::Arc;

/// The state of the rotation term: $\beta$, the colour classes and the buffers of one local
/// step.
#[derive(Debug)]
pub(crate) struct SmoothRotations {
    /// $\beta = \ell^2$ in world units squared.
    pub(super) beta: f64,
    /// The vertices of each colour (internal numbering, ascending).
    colours: Vec<Vec<u32>>,
    /// The colour of each vertex (the index of its class in `colours`).
    colour: Vec<u32>,
    /// $S_i$ of the current pose (the spokes covariances).
    covs: Vec<Mat3>,
    /// New rotations of one colour class, aligned with it.
    fitted: Vec<Mat3>,
    /// The rotations of the last accepted Anderson iterate (`save_rotations`).
    saved: Vec<Mat3>,
    /// The implicit step taken before each sweep ([`super::rotation_solve`]).
    implicit: RotationSolve,
    /// Rotations the implicit step proposes (all vertices).
    proposed: Vec<Mat3>,
    /// Whether the implicit step runs ([`Arap::set_implicit_rotation_step`]).
    use_implicit: bool,
}

impl SmoothRotations {
    /// For `n` vertices with the spokes `neighbours` and bending length `ell` in world units.
    /// `rest` holds the rest positions (internal numbering); the implicit step solves on a
    /// level when given its interpolation `level` ([`RotationSolve::new`]).
    pub(super) fn new(
        neighbours: &Csr<(u32, f64)>,
        rest: &[[f64; 3]],
        ell: f64,
        level: Option<Arc<Interpolation>>,
    ) -> Result<SmoothRotations, FactorError> {
        let masses: Vec<f64> = (0..rest.len())
            .map(|i| {
                let row = neighbours.row(i);
                row.iter().map(|&(j, w)| w * norm2(sub(rest[i], rest[j as usize]))).sum()
            })
            .collect();
        SmoothRotations::with_masses(neighbours, &masses, ell, level)
    }

    /// For the `neighbours` and bending length `ell` in world units, with `masses` $m_i$ the
    /// rest values of $\operatorname{tr}(R_iS_i)$ for the implicit step's diagonal
    /// ([`super::rotation_solve`]): the cells of a mesh ([`SmoothRotations::new`]) or the
    /// clusters of the Galerkin coarse energy (`deform::coarse::galerkin`).
    pub(crate) fn with_masses(
        neighbours: &Csr<(u32, f64)>,
        masses: &[f64],
        ell: f64,
        level: Option<Arc<Interpolation>>,
    ) -> Result<SmoothRotations, FactorError> {
        let n = masses.len();
        let colours = colour_classes(n, neighbours);
        let mut colour = vec![0; n];
        for (c, class) in colours.iter().enumerate() {
            class.iter().for_each(|&i| colour[i as usize] = c as u32);
        }
        let largest = colours.iter().map(Vec::len).max().unwrap_or(0);
        let beta = ell * ell;
        Ok(SmoothRotations {
            beta,
            colours,
            colour,
            covs: vec![[[0.0; 3]; 3]; n],
            fitted: vec![[[0.0; 3]; 3]; largest],
            saved: Vec::new(),
            implicit: RotationSolve::new(neighbours, masses, beta, level)?,
            proposed: vec![[[0.0; 3]; 3]; n],
            use_implicit: true,
        })
    }

    /// The number of colour classes.
    #[cfg(test)]
    pub(super) fn n_colours(&self) -> usize {
        self.colours.len()
    }

    /// $\beta = \ell^2$.
    pub(crate) fn beta(&self) -> f64 {
        self.beta
    }

    /// The covariances $S_i$ a caller's pass fills before [`SmoothRotations::start_sums`].
    pub(crate) fn covariances_mut(&mut self) -> &mut [Mat3] {
        &mut self.covs
    }

    /// For the covariances in [`SmoothRotations::covariances_mut`] and the current
    /// `rotations`: $\sum_i\operatorname{tr}(R_iS_i)$ and $\sum_i\sum_j w_{ij}\lVert
    /// R_i-R_j\rVert_F^2$ over all ordered pairs, and the implicit step's gradient when it runs;
    /// summed per `block` of vertices and then in order. (`Arap` folds the same into its
    /// covariance pass.)
    pub(crate) fn start_sums(
        &mut self,
        neighbours: &Csr<(u32, f64)>,
        rotations: &[Mat3],
        block: usize,
    ) -> RotationSums {
        let (covs, beta, implicit) = (&self.covs, self.beta, self.use_implicit);
        let parts: Vec<RotationSums> = covs
            .par_chunks(block)
            .zip(self.implicit.gradient_mut().par_chunks_mut(block))
            .enumerate()
            .map(|(c, (covs, gradient))| {
                let mut sums = RotationSums::default();
                let first = c * block;
                sums.add_starts(first, covs, gradient, neighbours, rotations, beta, implicit);
                sums
            })
            .collect();
        RotationSums::total(&parts)
    }

    /// The rotations' half of a local step, from the sums `start` of the current `rotations`
    /// (with the covariances and the gradient in place): the implicit step, then one
    /// Gauss–Seidel sweep over the colour classes ([`SmoothRotations::sweep`]). The safeguard:
    /// when the step and the sweep together raise the rotation objective
    /// ([`RotationSums::objective`]) above its value at the start (by more than rounding,
    /// [`RotationSums::rounding`], so that a converged solve does not sweep twice), the
    /// rotations of the start come back and are swept alone, which never raises it. Checking
    /// after the sweep, not between the step and the sweep, saves a pass. Returns the sums of
    /// the rotations it leaves.
    pub(crate) fn rotation_step(
        &mut self,
        neighbours: &Csr<(u32, f64)>,
        rotations: &mut Vec<Mat3>,
        start: &RotationSums,
        block: usize,
    ) -> RotationSums {
        if self.use_implicit {
            // The rotations of the start wait in `proposed`.
            self.implicit.step(rotations, &mut self.proposed);
            std::mem::swap(rotations, &mut self.proposed);
            let swept = self.sweep(neighbours, rotations, block);
            if swept.objective(self.beta) <= start.objective(self.beta) + start.rounding(self.beta)
            {
                return swept;
            }
            std::mem::swap(rotations, &mut self.proposed);
        }
        self.sweep(neighbours, rotations, block)
    }

    /// One Gauss–Seidel sweep over the colour classes ([`SmoothRotations::update_class`]);
    /// returns the sums of the rotations it leaves, over all ordered pairs.
    fn sweep(
        &mut self,
        neighbours: &Csr<(u32, f64)>,
        rotations: &mut [Mat3],
        block: usize,
    ) -> RotationSums {
        let classes = std::mem::take(&mut self.colours);
        let mut swept = RotationSums::default();
        for class in &classes {
            swept.add(self.update_class(neighbours, rotations, class, block));
        }
        self.colours = classes;
        // Each unordered pair was counted once, at the later colour; the energy counts both.
        swept.term *= 2.0;
        swept
    }

    /// Fits $R_i$ to $X_i = S_i + 2\beta\sum_j w_{ij}R_j^\top$ for the vertices `class` at once
    /// (from the rotations before the call; [`fit_rotations_near`], [`LANES`] vertices per
    /// call), keeping $R_i$ where the fit does not raise $\operatorname{tr}(R_i X_i)$.
    /// Gauss–Seidel when `class` holds no two neighbours, Jacobi when it holds all vertices.
    ///
    /// Returns, for the rotations it leaves, $\sum_{i}\operatorname{tr}(R_iS_i)$ over `class`
    /// and $\sum_i\sum_{j:\,c(j)<c(i)} w_{ij}\lVert R_i-R_j\rVert_F^2$ over the neighbours of an
    /// earlier colour $c$: summed over the classes of a sweep in colour order, every pair is
    /// counted once, with both rotations final. Summed per `block` of `class` and then in order.
    pub(super) fn update_class(
        &mut self,
        neighbours: &Csr<(u32, f64)>,
        rotations: &mut [Mat3],
        class: &[u32],
        block: usize,
    ) -> RotationSums {
        if self.fitted.len() < class.len() {
            self.fitted.resize(class.len(), [[0.0; 3]; 3]);
        }
        let (rot, covs, beta, colour) = (&*rotations, &self.covs, self.beta, &self.colour);
        let fitted = &mut self.fitted[..class.len()];
        let parts: Vec<RotationSums> = fitted
            .par_chunks_mut(block)
            .zip(class.par_chunks(block))
            .map(|(out, class)| {
                let mut sums = RotationSums::default();
                for (out, class) in out.chunks_mut(LANES).zip(class.chunks(LANES)) {
                    let mut x = [[[0.0; 3]; 3]; LANES];
                    let mut new = [IDENTITY; LANES];
                    for ((x, new), &i) in x.iter_mut().zip(&mut new).zip(class) {
                        let i = i as usize;
                        *x = covs[i];
                        for &(j, w) in neighbours.row(i) {
                            add_transposed(x, 2.0 * beta * w, &rot[j as usize]);
                        }
                        *new = rot[i];
                    }
                    if class.len() == LANES {
                        fit_rotations_near(&x, &mut new);
                    } else {
                        for (new, x) in new.iter_mut().zip(&x).take(class.len()) {
                            *new = fit_rotation_near(x, new);
                        }
                    }
                    for (((out, new), x), &i) in out.iter_mut().zip(&new).zip(&x).zip(class) {
                        let i = i as usize;
                        let old = &rot[i];
                        let keep = trace_of_product(new, x) >= trace_of_product(old, x);
                        *out = if keep { *new } else { *old };
                        sums.traces += trace_of_product(out, &covs[i]);
                        sums.term += spread(out, neighbours.row(i), rot, |j| colour[j] < colour[i]);
                    }
                }
                sums
            })
            .collect();
        for (&i, r) in class.iter().zip(fitted.iter()) {
            rotations[i as usize] = *r;
        }
        RotationSums::total(&parts)
    }
}

/// A greedy colouring of the graph `neighbours` in vertex order: each vertex takes the smallest
/// colour none of its earlier neighbours has. Returns the vertices of each colour, ascending;
/// no two vertices of one class are neighbours.
pub(super) fn colour_classes(n: usize, neighbours: &Csr<(u32, f64)>) -> Vec<Vec<u32>> {
    let mut colour = vec![u32::MAX; n];
    let mut taken: Vec<bool> = Vec::new();
    let mut classes: Vec<Vec<u32>> = Vec::new();
    for i in 0..n {
        taken.iter_mut().for_each(|t| *t = false);
        for &(j, _) in neighbours.row(i) {
            let c = colour[j as usize];
            if c != u32::MAX {
                taken[c as usize] = true;
            }
        }
        let c = taken.iter().position(|t| !t).unwrap_or(taken.len());
        if c == taken.len() {
            taken.push(false);
            classes.push(Vec::new());
        }
        colour[i] = c as u32;
        classes[c].push(i as u32);
    }
    classes
}

impl Arap {
    /// Turns the implicit rotation step (module `arap::rotation_solve`) of
    /// [`Energy::SmoothRotations`](super::Energy::SmoothRotations) on (the default) or off (sweeps
    /// only), for measuring what it gains; no effect on the other energies.
    pub fn set_implicit_rotation_step(&mut self, on: bool) {
        if let Some(sr) = self.smooth.as_deref_mut() {
            sr.use_implicit = on;
        }
    }

    /// The size of the matrix that [`Energy::SmoothRotations`](super::Energy::SmoothRotations)'
    /// implicit rotation step factors: the vertex count, or a coarser level's when it solves on
    /// one (the coarse variant's full mesh); `None` for the other energies.
    pub fn rotation_unknowns(&self) -> Option<usize> {
        self.smooth.as_deref().map(|sr| sr.implicit.unknowns())
    }

    /// `steps` (at least one) smooth-rotation local steps at the current pose, each the
    /// implicit step and one Gauss–Seidel sweep of the rotations over the colour classes;
    /// returns $E(x, R)$ for the rotations of the last. The pose does not change between them,
    /// so neither do its covariances $S_i$ nor the spokes' edge sum: the first step's pass
    /// computes them with the rotation objective and the implicit step's gradient, each later
    /// step's pass only the objective and the gradient for the rotations it starts from
    /// ([`SmoothRotations::start_sums`]). Passes over the mesh per step: that one, one for the
    /// implicit step's rotations, one per colour; the sweep sums the energy of the rotations
    /// it leaves.
    ///
    /// The safeguard: when the implicit step and the sweep together raise the rotation
    /// objective ([`RotationSums::objective`]) above its value at the start (by more than
    /// rounding, [`RotationSums::rounding`], so that a converged solve does not sweep twice),
    /// the rotations of the start come back and are swept alone, which never raises it; so no
    /// local step raises $E$. Checking after the sweep, not between the step and the sweep,
    /// saves a pass.
    pub(super) fn smooth_local_steps(&mut self, steps: usize) -> f64 {
        let Some(mut sr) = self.smooth.take() else { return self.local_step_energy() };
        let mut start = self.smooth_covariances(&mut sr);
        let mut e = self.energy_from(start.edges, start.traces, None) + sr.beta * start.term;
        // Smooth rotations are built on spokes cells only (`precompute`).
        if let Cells::Spokes { neighbours } = &self.cells {
            let block = (self.task / 4).max(LANES);
            for step in 0..steps.max(1) {
                if step > 0 {
                    let edges = start.edges;
                    start = sr.start_sums(neighbours, &self.rotations, self.task);
                    start.edges = edges;
                }
                let swept = sr.rotation_step(neighbours, &mut self.rotations, &start, block);
                e = self.energy_from(start.edges, swept.traces, None) + sr.beta * swept.term;
            }
        }
        self.smooth = Some(sr);
        e
    }

    /// $S_i$ for every vertex into `sr.covs`, with $\sum_i\operatorname{tr}(R_iS_i)$ and
    /// $\sum_i\sum_j w_{ij}\lVert R_i-R_j\rVert_F^2$ for the current rotations and, when the implicit step runs, its gradient
    /// ([`rotation_solve::minus_gradient`]), in one pass; `edges` is $\sum_i\sum_j
    /// w_{ij}\lVert x_i - x_j\rVert^2$. Summed per task block and then in block order.
    fn smooth_covariances(&self, sr: &mut SmoothRotations) -> RotationSums {
        let Cells::Spokes { neighbours } = &self.cells else { return RotationSums::default() };
        let (task, rot, beta, implicit) = (self.task, &self.rotations, sr.beta, sr.use_implicit);
        let parts: Vec<RotationSums> = sr
            .covs
            .par_chunks_mut(task)
            .zip(sr.implicit.gradient_mut().par_chunks_mut(task))
            .enumerate()
            .map(|(c, (covs, gradient))| {
                let first = c * task;
                let mut sums = RotationSums {
                    edges: self.covariances(first, covs, 0.0),
                    ..RotationSums::default()
                };
                sums.add_starts(first, covs, gradient, neighbours, rot, beta, implicit);
                sums
            })
            .collect();
        RotationSums::total(&parts)
    }

    /// $\sum_i\sum_j w_{ij}\lVert R_i - R_j\rVert_F^2$ over the spokes for the current
    /// rotations (0 for spokes and rims), summed per task block and then in block order.
    pub(super) fn rotation_term(&self) -> f64 {
        let Cells::Spokes { neighbours } = &self.cells else { return 0.0 };
        let rot = &self.rotations;
        let task = self.task;
        let parts: Vec<f64> = (0..rot.len().div_ceil(task))
            .into_par_iter()
            .map(|c| {
                (c * task..((c + 1) * task).min(rot.len()))
                    .map(|i| spread(&rot[i], neighbours.row(i), rot, |_| true))
                    .sum()
            })
            .collect();
        parts.iter().sum()
    }

    /// $\beta$ times [`Arap::rotation_term`] (0 for the other energies).
    pub(super) fn smooth_term(&self) -> f64 {
        self.smooth.as_deref().map_or(0.0, |sr| sr.beta * self.rotation_term())
    }

    /// Keeps the current rotations (smooth rotations only): the Anderson loop's fallback step
    /// starts from them.
    pub(super) fn save_rotations(&mut self) {
        if let Some(sr) = self.smooth.as_deref_mut() {
            sr.saved.clone_from(&self.rotations);
        }
    }

    /// Puts back the rotations of [`Arap::save_rotations`] (smooth rotations only).
    pub(super) fn restore_rotations(&mut self) {
        if let Some(sr) = self.smooth.as_deref() {
            self.rotations.copy_from_slice(&sr.saved);
        }
    }
}

/// Sums of one pass over the rotations: the spokes' $\sum w\lVert x_i-x_j\rVert^2$ (`edges`,
/// where the pass computes covariances), $\sum\operatorname{tr}(R_iS_i)$ (`traces`) and the
/// rotation term's $\sum w_{ij}\lVert R_i-R_j\rVert_F^2$ over the pairs the pass counts (`term`).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct RotationSums {
    pub(crate) edges: f64,
    pub(crate) traces: f64,
    pub(crate) term: f64,
}

impl RotationSums {
    /// Adds, for the vertices `first..` with the covariances `covs`, $\operatorname{tr}(R_iS_i)$
    /// and $\sum_j w_{ij}\lVert R_i-R_j\rVert_F^2$ for the current `rotations`, and writes the
    /// implicit step's gradient into `gradient` when it runs: the per-vertex start of a local
    /// step ([`SmoothRotations::start_sums`], and `Arap`'s folded covariance pass).
    #[expect(clippy::too_many_arguments, reason = "one vertex block's inputs, each used")]
    fn add_starts(
        &mut self,
        first: usize,
        covs: &[Mat3],
        gradient: &mut [[f64; 3]],
        neighbours: &Csr<(u32, f64)>,
        rotations: &[Mat3],
        beta: f64,
        implicit: bool,
    ) {
        for (k, (s, g)) in covs.iter().zip(gradient).enumerate() {
            let (i, row) = (first + k, neighbours.row(first + k));
            self.traces += trace_of_product(&rotations[i], s);
            self.term += spread(&rotations[i], row, rotations, |_| true);
            if implicit {
                *g = rotation_solve::minus_gradient(&rotations[i], s, row, rotations, beta);
            }
        }
    }

    /// Adds `other` into `self`.
    fn add(&mut self, other: RotationSums) {
        self.edges += other.edges;
        self.traces += other.traces;
        self.term += other.term;
    }

    /// The sums of the blocks `parts`, added in order.
    fn total(parts: &[RotationSums]) -> RotationSums {
        let mut sum = RotationSums::default();
        parts.iter().for_each(|p| sum.add(*p));
        sum
    }

    /// The rotations' part of $E$ at a fixed pose: $-2\sum_i\operatorname{tr}(R_iS_i) +
    /// \beta\sum_i\sum_j w_{ij}\lVert R_i-R_j\rVert_F^2$ (for sums over all ordered pairs).
    pub(crate) fn objective(&self, beta: f64) -> f64 {
        -2.0 * self.traces + beta * self.term
    }

    /// The rounding error of [`RotationSums::objective`], taken as $10^{-13}$ of the sum of its
    /// terms' sizes.
    fn rounding(&self, beta: f64) -> f64 {
        1e-13 * (2.0 * self.traces.abs() + beta * self.term)
    }
}

/// $\sum_j w_{ij}\lVert R - R_j\rVert_F^2$ over the neighbours $(j, w_{ij})$ in `row` for which
/// `counts(j)` holds.
#[inline]
fn spread(r: &Mat3, row: &[(u32, f64)], rot: &[Mat3], counts: impl Fn(usize) -> bool) -> f64 {
    let mut sum = 0.0;
    for &(j, w) in row {
        let j = j as usize;
        if counts(j) {
            sum += w * frobenius2_of_difference(r, &rot[j]);
        }
    }
    sum
}

/// `x += s * r^T`.
#[inline]
fn add_transposed(x: &mut Mat3, s: f64, r: &Mat3) {
    for a in 0..3 {
        for b in 0..3 {
            x[a][b] += s * r[b][a];
        }
    }
}

/// $\lVert a - b\rVert_F^2$.
#[inline]
fn frobenius2_of_difference(a: &Mat3, b: &Mat3) -> f64 {
    (0..3).map(|r| norm2([a[r][0] - b[r][0], a[r][1] - b[r][1], a[r][2] - b[r][2]])).sum()
}

#[cfg(test)]
pub(super) mod tests;
