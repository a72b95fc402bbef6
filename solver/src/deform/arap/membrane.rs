//! Triangle cells blended into the spokes-and-rims energy: the membrane share $\mu$ of
//! [`ArapConfig::membrane`](super::ArapConfig::membrane), used on the coarse level of the
//! coarse BS-ARAP.
//!
//! $E_\mu = (1-\mu)\,E_{SR} + 3\mu\,E_T$, with $E_{SR}$ the spokes-and-rims energy (one
//! rotation $R_i$ per vertex over the edges of its triangles) and
//! $E_T = \sum_t \sum_k w^t_k\,\lVert e'^t_k - R_t\,e^t_k\rVert^2$ one rotation $R_t$ per
//! triangle over its own three edges ($w^t_k$ the half cotangents, $e^t_k$ the rest edge
//! opposite corner $k$; Liu et al. 2008, "A local/global approach to mesh parameterization",
//! cells of single triangles). Every triangle edge is in three vertex cells, so
//! $E_{SR}$ and $3E_T$ have the same Hessian in the positions, $6L$: the factorization of $L_{FF}$
//! stays. The local step also fits each $R_t$ to $S_t = \sum_k w^t_k e^t_k (x_a - x_b)^\top$;
//! the global step's rhs $b_i = \sum_{t \ni i} \bar R_t v_{it}$ (`precompute::ring_coefficients`)
//! becomes $\sum_{t \ni i} ((1-\mu)\bar R_t + \mu R_t)\, v_{it}$.
//!
//! Why: a triangle cell resists stretching and shearing but not bending (it is flat), while a
//! vertex cell also resists bending, by an amount that grows with the square of the edge length
//! relative to its resistance to stretching. A coarse level made of vertex cells alone is thus
//! far stiffer in bending than the mesh it stands for, and bends a wider region around a small
//! handle less than ARAP on the mesh does; the membrane share takes part of that stiffness
//! away (BENCHMARKS.md, "The membrane share on the coarse level").

use super::Csr;
use super::local::{LocalSums, fit_block};
use super::precompute::corner_edges;
use crate::geometry::cotan::opposite_edge;
use crate::geometry::mesh::{add, norm2, scale, sub};
use crate::linalg::rotation::{IDENTITY, Mat3, add_outer, mul_mat, mul_vec};
use rayon::prelude::*;

/// Triangles per parallel task of the triangles' local step.
const TRIANGLES_PER_TASK: usize = 1024;
/// Triangles whose covariances a task computes and fits at a time (a buffer on its stack, as
/// the vertex cells' local step does), a multiple of the fits' lanes.
const SCRATCH: usize = 64;

/// The triangle cells of $E_\mu$ (module doc) in the solver's internal numbering.
#[derive(Debug, Clone)]
pub(super) struct Membrane {
    /// $\mu$, in $(0, 1]$.
    pub(super) share: f64,
    /// $R_t$ of the last local step.
    pub(super) rotations: Vec<Mat3>,
    /// Per vertex $i$: (triangle $t \ni i$, $v_{it}$), the weighted rest edges of $t$ at $i$.
    incident: Csr<(u32, [f64; 3])>,
    /// $\sum_t \sum_k w^t_k \lVert e^t_k\rVert^2$.
    rest_term: f64,
}

impl Membrane {
    /// The triangle cells of `tris` (internal numbering, `n` vertices) with half cotangents
    /// `cot` and rest edges `edges` (as the spokes-and-rims cells keep them), share `share`.
    pub(super) fn new(
        n: usize,
        tris: &[[u32; 3]],
        cot: &[[f64; 3]],
        edges: &[[[f64; 3]; 3]],
        share: f64,
    ) -> Membrane {
        let mut pairs = Vec::with_capacity(3 * tris.len());
        let mut rest_term = 0.0;
        for (f, ((t, w), e)) in tris.iter().zip(cot).zip(edges).enumerate() {
            for c in 0..3 {
                pairs.push((t[c], (f as u32, corner_edges(w, e, c))));
                rest_term += w[c] * norm2(e[c]);
            }
        }
        Membrane {
            share,
            rotations: vec![IDENTITY; tris.len()],
            incident: Csr::from_pairs(n, &pairs),
            rest_term,
        }
    }

    /// Fits every $R_t$ to the pose `x` (started from the last ones) and returns the sums
    /// of the triangles' energy, taken per fixed block of triangles and then in order (so
    /// they do not depend on the scheduling).
    pub(super) fn fit(
        &mut self,
        x: &[[f64; 3]],
        tris: &[[u32; 3]],
        cot: &[[f64; 3]],
        edges: &[[[f64; 3]; 3]],
    ) -> LocalSums {
        let parts: Vec<LocalSums> = self
            .rotations
            .par_chunks_mut(TRIANGLES_PER_TASK)
            .enumerate()
            .map(|(c, rots)| {
                let mut sums = LocalSums::default();
                let mut covs = [[[0.0; 3]; 3]; SCRATCH];
                for (k, rots) in rots.chunks_mut(SCRATCH).enumerate() {
                    let first = c * TRIANGLES_PER_TASK + k * SCRATCH;
                    let covs = &mut covs[..rots.len()];
                    for (l, s) in covs.iter_mut().enumerate() {
                        let f = first + l;
                        let (t, w, e) = (tris[f], cot[f], &edges[f]);
                        *s = [[0.0; 3]; 3];
                        for k in 0..3 {
                            let (a, b) = opposite_edge(t, k);
                            let d = sub(x[a as usize], x[b as usize]);
                            add_outer(s, w[k], e[k], d);
                            sums.edges += w[k] * norm2(d);
                        }
                    }
                    sums.fitted = fit_block(rots, covs, sums.fitted);
                }
                sums
            })
            .collect();
        LocalSums::total(&parts)
    }

    /// $E_T$ from the sums of [`Membrane::fit`].
    pub(super) fn energy_from(&self, sums: LocalSums) -> f64 {
        (sums.edges + self.rest_term - 2.0 * sums.fitted).max(0.0)
    }

    /// $E_T$ of the pose `x` with the current $R_t$.
    pub(super) fn energy(
        &self,
        x: &[[f64; 3]],
        tris: &[[u32; 3]],
        cot: &[[f64; 3]],
        edges: &[[[f64; 3]; 3]],
    ) -> f64 {
        (tris, cot, edges, &self.rotations)
            .into_par_iter()
            .map(|(t, w, e, r)| {
                (0..3)
                    .map(|k| {
                        let (a, b) = opposite_edge(*t, k);
                        let d = sub(sub(x[a as usize], x[b as usize]), mul_vec(r, e[k]));
                        w[k] * norm2(d)
                    })
                    .sum::<f64>()
            })
            .sum()
    }

    /// $\mu \sum_{t \ni i} R_t v_{it}$: the membrane's part of vertex `i`'s rhs.
    pub(super) fn rhs(&self, i: usize) -> [f64; 3] {
        let mut b = [0.0; 3];
        for &(t, v) in self.incident.row(i) {
            b = add(b, mul_vec(&self.rotations[t as usize], v));
        }
        scale(b, self.share)
    }

    /// Every $R_t$ set to `r` (rest: the identity; a rigid start: its rotation).
    pub(super) fn fill(&mut self, r: Mat3) {
        self.rotations.fill(r);
    }

    /// Every $R_t$ turned by `r` (the pose moved rigidly by it).
    pub(super) fn turn(&mut self, r: &Mat3) {
        for t in &mut self.rotations {
            *t = mul_mat(r, t);
        }
    }
}
