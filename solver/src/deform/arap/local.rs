//! The local step (Sun et al. 2017, Eq. 5): per vertex the covariance
//! $S_i = \sum_{(j,k)\in\mathcal{C}_i} w_{jk}\, e_{jk} e'^\top_{jk}$ of its cell and the
//! rotation $R_i$ that maximizes $\operatorname{tr}(R_i S_i)$, in one parallel pass that also
//! returns the sums of the energy.

#[cfg(target_arch = "x86_64")]
use super::avx;
use super::{Arap, Cells};
use crate::geometry::mesh::{norm2, sub};
use crate::linalg::rotation::{
    LANES, Mat3, add_outer, fit_rotation_near, fit_rotations_near, trace_of_product,
};
use rayon::prelude::*;

/// Vertices whose covariances [`Arap::local_pass`] computes and fits at a time (4.6 KB of
/// covariances), a multiple of [`LANES`] so that the fits' sums run as over the whole block.
const SCRATCH: usize = 64;

impl Arap {
    /// The local step, returning $E(x, R(x))$ for the rotations it fitted.
    pub(super) fn local_step_energy(&mut self) -> f64 {
        self.local_steps_energy(1)
    }

    /// `steps` local steps at the current pose on smooth rotations, whose rotations are state
    /// that each step moves on ([`Arap::smooth_local_steps`]); the other energies' rotations are
    /// a function of the pose, fitted by one step, which they take whatever `steps`. Returns
    /// $E(x, R)$ for the rotations it leaves.
    pub(super) fn local_steps_energy(&mut self, steps: usize) -> f64 {
        if self.smooth.is_some() {
            return self.smooth_local_steps(steps);
        }
        let sums = self.local_pass();
        let membrane = self.fit_membrane();
        self.energy_from(sums.edges, sums.fitted, membrane)
    }

    /// The triangle cells' local step ([`super::membrane`]), when the energy has them:
    /// returns their energy $E_T$ for the fitted rotations.
    pub(super) fn fit_membrane(&mut self) -> Option<f64> {
        let Cells::SpokesAndRims { tris, cot, edges, .. } = &self.cells else { return None };
        let m = self.membrane.as_deref_mut()?;
        let sums = m.fit(&self.current, tris, cot, edges);
        Some(m.energy_from(sums))
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
    pub(super) fn local_pass(&mut self) -> LocalSums {
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
        LocalSums::total(&parts)
    }

    /// $S_i$ of the current pose for $i$ = `first`, `first + 1`, … (one per entry of `out`),
    /// on AVX registers where detected ([`avx::covariances`], the same bits); returns `sum`
    /// plus the cells' $\sum_j c_{ij}\lVert x_j - x_i\rVert^2$, added vertex by vertex.
    pub(super) fn covariances(&self, first: usize, out: &mut [Mat3], sum: f64) -> f64 {
        #[cfg(target_arch = "x86_64")]
        if let (Some(avx2), Cells::SpokesAndRims { ring, cov_coef, edge_coef, .. }) =
            (self.avx2, &self.cells)
        {
            let ring =
                avx::Ring { offsets: &ring.offsets, items: &ring.items, cov_coef, edge_coef };
            return avx::covariances(avx2, first, out, &self.current, &ring, sum);
        }
        let mut sum = sum;
        for (l, out) in out.iter_mut().enumerate() {
            let (s, a) = covariance(&self.cells, &self.current, &self.rest, first + l);
            sum += a;
            *out = s;
        }
        sum
    }
}

/// The sums of one local step over its cells (the vertex cells' [`Arap::local_pass`], the
/// triangle cells' [`super::membrane::Membrane::fit`]): $A = \sum w\lVert x_a - x_b\rVert^2$
/// over the cells' edges, and $T = \sum \operatorname{tr}(R S)$ for the fitted rotations.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct LocalSums {
    pub(super) edges: f64,
    pub(super) fitted: f64,
}

impl LocalSums {
    /// The sums of the parallel tasks' blocks, added in block order (so they do not depend on
    /// the scheduling).
    pub(super) fn total(parts: &[LocalSums]) -> LocalSums {
        parts.iter().fold(LocalSums::default(), |acc, s| LocalSums {
            edges: acc.edges + s.edges,
            fitted: acc.fitted + s.fitted,
        })
    }
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
