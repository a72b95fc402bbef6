//! The implicit rotation step of [`Energy::SmoothRotations`](super::Energy::SmoothRotations):
//! one sparse solve that moves the whole rotation field at once, where a Gauss–Seidel sweep
//! ([`super::smooth_rotations`]) only smooths it locally.
//!
//! **Problem.** With the pose fixed, the rotations minimize
//! $$F(R) = -2\sum_i \operatorname{tr}(R_i S_i) - 2\beta\sum_i\sum_{j\in N(i)} w_{ij}
//! \operatorname{tr}(R_iR_j^\top) + \text{const}$$
//! over $R_i \in SO(3)$ ($S_i$ the spokes covariances; $\lVert R_i-R_j\rVert_F^2 = 6 -
//! 2\operatorname{tr}(R_iR_j^\top)$). A sweep corrects a long-wavelength error of the field by
//! a fraction $\sim (h/\ell)^2$ of itself ($h$ the edge length), so sweeps alone need
//! $\sim(\ell/h)^2$ local steps on dense meshes.
//!
//! **Step.** A Newton-like step in world-frame rotation increments, $R_i \leftarrow
//! \exp([\omega_i]_\times)R_i$. With $A_i = R_iS_i$, $B_{ij} = R_iR_j^\top$ and
//! $\operatorname{v}(A) = (A_{32}-A_{23}, A_{13}-A_{31}, A_{21}-A_{12})$, the expansions
//! $\operatorname{tr}(e^{[\omega]}A) = \operatorname{tr}A - \omega\cdot\operatorname{v}(A) +
//! \tfrac12\omega^\top(\operatorname{sym}A - \operatorname{tr}A\,I)\omega + O(\omega^3)$
//! give the gradient of $F$
//! $$g_i = 2\operatorname{v}(A_i) + 4\beta\sum_j w_{ij}\operatorname{v}(B_{ij}),$$
//! and, for a smooth field ($B_{ij}\approx I$) of nearly rigid cells ($\operatorname{tr}A_i
//! \approx m_i = \sum_j w_{ij}\lVert p_i-p_j\rVert^2$, the rest value), the Hessian
//! $8\beta L + \operatorname{blockdiag}\,2(\operatorname{tr}A_i\,I - \operatorname{sym}A_i)$
//! with the weighted graph Laplacian $L$ ($L_{ii}=\sum_j w_{ij}$, $L_{ij}=-w_{ij}$). Replacing
//! each $3\times3$ block by its mean eigenvalue at rest, $h_i = \tfrac43 m_i$, the step solves
//! $$(8\beta L + \operatorname{diag} h)\,\omega = -g,$$
//! one matrix for every pose (factorized once, [`SpdFactor`]) and three right-hand sides.
//!
//! **Safeguard.** The step is a model, not the function, so it may raise $F$: the local step
//! keeps it only when the step and the Gauss–Seidel sweep after it together end below the
//! starting $F$, and otherwise sweeps from the starting rotations, which never raises $F$; so
//! the local step still descends. The construction (a Laplacian-preconditioned Riemannian gradient step on
//! $SO(3)^n$) is ours.

use super::Csr;
use crate::geometry::mesh::{norm2, sub};
use crate::linalg::linsolve::{FactorError, Layout, SpdFactor};
use crate::linalg::rotation::{Mat3, axis_angle, mul_mat};
use faer::sparse::Triplet;
use rayon::prelude::*;

/// The factorized matrix $8\beta L + \operatorname{diag} h$ and the step's buffers.
pub(super) struct RotationSolve {
    factor: SpdFactor,
    /// The three right-hand sides, column-major `n×3`: $-g$, then in place $\omega$.
    rhs: Vec<f64>,
    /// $-g_i$ per vertex before it is copied into `rhs`.
    gradient: Vec<[f64; 3]>,
}

impl std::fmt::Debug for RotationSolve {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RotationSolve").field("n", &self.gradient.len()).finish()
    }
}

/// $\operatorname{v}(A)$ (module doc): minus twice the axial vector of $A$'s skew part.
#[inline]
fn vee(a: &Mat3) -> [f64; 3] {
    [a[2][1] - a[1][2], a[0][2] - a[2][0], a[1][0] - a[0][1]]
}

/// $\operatorname{v}(AB^\top)$ from the six entries of $AB^\top$ it needs,
/// $(AB^\top)_{rc} = a_r\cdot b_c$ for the rows $a_r$, $b_c$.
#[inline]
fn vee_of_transposed_product(a: &Mat3, b: &Mat3) -> [f64; 3] {
    let dot = |r: usize, c: usize| a[r][0] * b[c][0] + a[r][1] * b[c][1] + a[r][2] * b[c][2];
    [dot(2, 1) - dot(1, 2), dot(0, 2) - dot(2, 0), dot(1, 0) - dot(0, 1)]
}

/// $-g_i$ (module doc) for the rotation `r` $= R_i$ with covariance `s` $= S_i$, the spokes
/// `row` $(j, w_{ij})$ of vertex $i$, all `rotations` and $\beta$.
#[inline]
pub(super) fn minus_gradient(
    r: &Mat3,
    s: &Mat3,
    row: &[(u32, f64)],
    rotations: &[Mat3],
    beta: f64,
) -> [f64; 3] {
    let mut v = vee(&mul_mat(r, s)).map(|c| 2.0 * c);
    for &(j, w) in row {
        let b = vee_of_transposed_product(r, &rotations[j as usize]);
        for k in 0..3 {
            v[k] += 4.0 * beta * w * b[k];
        }
    }
    v.map(|c| -c)
}

impl RotationSolve {
    /// For the spokes `neighbours` (weights $w_{ij}$), rest positions `rest` and $\beta$.
    pub(super) fn new(
        neighbours: &Csr<(u32, f64)>,
        rest: &[[f64; 3]],
        beta: f64,
    ) -> Result<RotationSolve, FactorError> {
        let n = rest.len();
        let mut triplets = Vec::with_capacity(n + neighbours.items.len());
        let mut diagonal = vec![0.0; n];
        let mut scale = 0.0f64;
        for (i, d) in diagonal.iter_mut().enumerate() {
            let (mut degree, mut m) = (0.0, 0.0);
            for &(j, w) in neighbours.row(i) {
                m += w * norm2(sub(rest[i], rest[j as usize]));
                degree += w;
                triplets.push(Triplet::new(i, j as usize, -8.0 * beta * w));
            }
            *d = 8.0 * beta * degree + 4.0 / 3.0 * m;
            scale = scale.max(*d);
        }
        // An isolated or zero-weight vertex still needs a positive diagonal.
        let floor = 1e-12 * scale.max(f64::MIN_POSITIVE);
        triplets
            .extend(diagonal.iter().enumerate().map(|(i, &d)| Triplet::new(i, i, d.max(floor))));
        let factor = SpdFactor::from_triplets(n, &triplets, Layout::Simplicial)?;
        Ok(RotationSolve { factor, rhs: vec![0.0; 3 * n], gradient: vec![[0.0; 3]; n] })
    }

    /// The buffer of $-g$, one entry per vertex, that [`RotationSolve::step`] reads: the
    /// caller fills it with [`minus_gradient`] (in its own pass over the covariances).
    pub(super) fn gradient_mut(&mut self) -> &mut [[f64; 3]] {
        &mut self.gradient
    }

    /// The step (module doc) from the gradient in [`RotationSolve::gradient_mut`] at the
    /// rotations `rotations`: writes $\exp([\omega_i]_\times)R_i$ into `out`.
    pub(super) fn step(&mut self, rotations: &[Mat3], out: &mut [Mat3]) {
        let n = rotations.len();
        for (k, col) in self.rhs.chunks_mut(n).enumerate() {
            for (x, g) in col.iter_mut().zip(&self.gradient) {
                *x = g[k];
            }
        }
        let rhs = faer::MatMut::from_column_major_slice_mut(&mut self.rhs, n, 3);
        self.factor.solve_in_place(rhs);
        let (x, y, z) = (&self.rhs[..n], &self.rhs[n..2 * n], &self.rhs[2 * n..]);
        out.par_iter_mut().enumerate().for_each(|(i, o)| {
            let w = [x[i], y[i], z[i]];
            let angle = norm2(w).sqrt();
            *o = mul_mat(&axis_angle(w, angle), &rotations[i]);
        });
    }
}
