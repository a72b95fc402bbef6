//! Bi-harmonic base surface (Jacobson et al. 2010; Sun et al. 2017, Eqs. 6–9).
//!
//! Minimizes the discrete Laplacian energy $X^\top Q X$ with the bi-Laplacian
//! $$Q = L A^{-1} L$$
//! ($L$ the PSD cotangent Laplacian of [`crate::geometry::cotan`], $A$ the lumped mass of [`crate::geometry::mass`]),
//! with the fixed vertices held at given positions. Its optimality condition is the discrete
//! $\Delta^2 X = 0$ on the free vertices:
//! $$Q_{FF} X_F = -Q_{FH} X_H.$$
//! $Q_{FF}$ is factored once per handle set. With $X_H$ the rest positions of the handle regions
//! the solution $B$ interpolates them and smooths the free regions' details away.
//!
//! **Fairing with a data term** (our remedy for that collapse; docs/DESIGN.md, "The faired base"): with a smoothing length
//! $h$ (mesh units) and $\lambda = h^{-4}$,
//! $$\min_X\; X^\top Q X + \lambda\,(X-M)^\top A\,(X-M) \;\Rightarrow\;
//!   (Q+\lambda A)_{FF} X_F = \lambda A_{FF} M_F - Q_{FH} X_H,$$
//! which removes features much shorter than $h$ and keeps the surface close to $M$ elsewhere
//! ($\lambda = 0$ is the paper's bi-harmonic surface). $Q$ scales as length$^{-2}$ and $A$ as
//! length$^2$, so $h^{-4}$ makes the two terms commensurate and the result scale-invariant.
//!
//! Inputs: a [`Mesh`] `#V×3`/`#F×3`, a [`Constraints`] partition, fixed values `#V×3` (read on
//! fixed vertices only). Output `#V×3`. Known limitation: with small, sparse handles the pure
//! bi-harmonic minimizer shrinks the free regions (docs/DESIGN.md, "The reference run"), which can collapse triangles
//! of $B$; a finite smoothing length prevents it.

use crate::deform::constraints::Constraints;
use crate::error::SolveError;
use crate::geometry::cotan::{edge_weights, face_cotangents};
use crate::geometry::mass::{MassKind, lumped_mass};
use crate::geometry::mesh::Mesh;
use crate::linalg::linsolve::{Layout, SpdFactor};
use faer::Mat;
use faer::sparse::Triplet;

/// The bi-harmonic surface interpolating `fixed_values` on the fixed vertices of `constraints`.
pub fn biharmonic_surface(
    mesh: &Mesh,
    constraints: &Constraints,
    fixed_values: &[[f64; 3]],
) -> Result<Vec<[f64; 3]>, SolveError> {
    faired_surface(mesh, constraints, fixed_values, None)
}

/// The faired surface for smoothing length `smoothing` (mesh units; `None` = pure bi-harmonic,
/// see the module doc), interpolating `fixed_values` on the fixed vertices.
pub fn faired_surface(
    mesh: &Mesh,
    constraints: &Constraints,
    fixed_values: &[[f64; 3]],
    smoothing: Option<f64>,
) -> Result<Vec<[f64; 3]>, SolveError> {
    let lambda = match smoothing {
        Some(h) if h.is_finite() && h > 0.0 => h.powi(-4),
        _ => 0.0,
    };
    let n = mesh.n_vertices();
    let cot = face_cotangents(mesh.positions(), mesh.triangles(), 0.0)
        .map_err(|d| SolveError::DegenerateFace { face: d.face })?;
    let mass = lumped_mass(mesh.positions(), mesh.triangles(), MassKind::Voronoi);
    // Column k of L: (row, value) for k and its neighbours.
    let mut cols: Vec<Vec<(u32, f64)>> = (0..n as u32).map(|k| vec![(k, 0.0)]).collect();
    for (i, j, w) in edge_weights(mesh.triangles(), &cot, false) {
        cols[i as usize].push((j, -w));
        cols[j as usize].push((i, -w));
        cols[i as usize][0].1 += w;
        cols[j as usize][0].1 += w;
    }
    let free = &constraints.free_index;
    let n_free = constraints.free_vertices.len();
    let mut out = mesh.positions().to_vec();
    for v in 0..n {
        if free[v].is_none() {
            out[v] = fixed_values[v];
        }
    }
    if n_free == 0 {
        return Ok(out);
    }
    // Q_ij = Σ_k L_ik L_kj / a_k over the columns k where both i and j appear.
    let mut q = Vec::new();
    let mut rhs = Mat::<f64>::zeros(n_free, 3);
    for (k, col) in cols.iter().enumerate() {
        let inv_a = 1.0 / mass[k];
        for &(i, lik) in col {
            let Some(r) = free[i as usize] else { continue };
            for &(j, ljk) in col {
                let v = lik * ljk * inv_a;
                match free[j as usize] {
                    Some(c) if r >= c => q.push(Triplet::new(r as usize, c as usize, v)),
                    Some(_) => {}
                    None => {
                        let xj = out[j as usize];
                        for d in 0..3 {
                            rhs[(r as usize, d)] -= v * xj[d];
                        }
                    }
                }
            }
        }
    }
    if lambda > 0.0 {
        for (r, &v) in constraints.free_vertices.iter().enumerate() {
            let w = lambda * mass[v as usize];
            q.push(Triplet::new(r, r, w));
            let p = mesh.positions()[v as usize];
            for d in 0..3 {
                rhs[(r, d)] += w * p[d];
            }
        }
    }
    let mut factor = SpdFactor::from_triplets(n_free, &q, Layout::Auto).map_err(|source| {
        SolveError::Factorization { matrix: "the free block of the bi-Laplacian", source }
    })?;
    factor.solve_in_place(rhs.as_mut());
    for (r, &v) in constraints.free_vertices.iter().enumerate() {
        out[v as usize] = [rhs[(r, 0)], rhs[(r, 1)], rhs[(r, 2)]];
    }
    if let Some(vertex) = out.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(SolveError::NonFiniteResult { vertex });
    }
    Ok(out)
}
