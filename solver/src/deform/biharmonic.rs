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
//! fixed vertices only). Output `#V×3`. A free vertex that no triangle uses (no row in $L$ or
//! $A$) stays at its rest position. Known limitation: with small, sparse handles the pure
//! bi-harmonic minimizer shrinks the free regions (docs/DESIGN.md, "The reference run"), which can collapse triangles
//! of $B$; a finite smoothing length prevents it.

use crate::deform::constraints::Constraints;
use crate::error::SolveError;
use crate::geometry::cotan::{edge_weights, face_cotangents};
use crate::geometry::mass::{MassKind, lumped_mass};
use crate::geometry::mesh::Mesh;
use crate::linalg::linsolve::{Layout, SpdFactor};
use faer::Mat;
use faer::sparse::{SparseColMat, SymbolicSparseColMat};

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
    let cols = laplacian_columns(mesh)?;
    let mass = lumped_mass(mesh.positions(), mesh.triangles(), MassKind::Voronoi);
    let (given, held) = (&constraints.free_index, hold_unreferenced(constraints, &mass));
    let constraints = match &held {
        Some(c) => c,
        None => constraints,
    };
    let free = &constraints.free_index;
    let n_free = constraints.free_vertices.len();
    let mut out = mesh.positions().to_vec();
    for v in 0..n {
        if given[v].is_none() {
            out[v] = fixed_values[v];
        }
    }
    if n_free == 0 {
        return Ok(out);
    }
    // The fixed vertices' part of the right-hand side, -Q_FH X_H: Q_ij = Σ_k L_ik L_kj / a_k
    // over the columns k where both i and j appear.
    let mut rhs = Mat::<f64>::zeros(n_free, 3);
    if n_free < n {
        for (k, col) in cols.iter().enumerate() {
            let inv_a = 1.0 / mass[k];
            for &(i, lik) in col {
                let Some(r) = free[i as usize] else { continue };
                for &(j, ljk) in col.iter().filter(|(j, _)| free[*j as usize].is_none()) {
                    let (v, xj) = (lik * ljk * inv_a, out[j as usize]);
                    for d in 0..3 {
                        rhs[(r as usize, d)] -= v * xj[d];
                    }
                }
            }
        }
    }
    if lambda > 0.0 {
        for (r, &v) in constraints.free_vertices.iter().enumerate() {
            let w = lambda * mass[v as usize];
            let p = mesh.positions()[v as usize];
            for d in 0..3 {
                rhs[(r, d)] += w * p[d];
            }
        }
    }
    let q = free_block(&cols, &mass, constraints, lambda);
    let mut factor = SpdFactor::new(&q, Layout::Auto).map_err(|source| {
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

/// `constraints` with the free vertices that no triangle uses (zero mass: no row in $L$ or $A$,
/// so $(Q+\lambda A)_{FF}$ would be singular there) held at their rest positions; `None`
/// when there are none. A lone point has no surface to fair: the base is the point itself, as
/// for the loose parts the deformer keeps at rest or moves rigidly ([`crate::deform::riders`]).
fn hold_unreferenced(constraints: &Constraints, mass: &[f64]) -> Option<Constraints> {
    let lone = |v: &u32| mass[*v as usize] <= 0.0;
    if !constraints.free_vertices.iter().any(lone) {
        return None;
    }
    let mut held = constraints.clone();
    let free: Vec<u32> = constraints.free_vertices.iter().copied().filter(|v| !lone(v)).collect();
    held.free_index.fill(None);
    for (r, &v) in free.iter().enumerate() {
        held.free_index[v as usize] = Some(r as u32);
    }
    held.free_vertices = free.into();
    Some(held)
}

/// Column k of the cotangent Laplacian $L$: (row, value) for k (first) and its neighbours.
fn laplacian_columns(mesh: &Mesh) -> Result<Vec<Vec<(u32, f64)>>, SolveError> {
    let cot = face_cotangents(mesh.positions(), mesh.triangles(), 0.0)
        .map_err(|d| SolveError::DegenerateFace { face: d.face })?;
    let mut cols: Vec<Vec<(u32, f64)>> =
        (0..mesh.n_vertices() as u32).map(|k| vec![(k, 0.0)]).collect();
    for (i, j, w) in edge_weights(mesh.triangles(), &cot, false) {
        cols[i as usize].push((j, -w));
        cols[j as usize].push((i, -w));
        cols[i as usize][0].1 += w;
        cols[j as usize][0].1 += w;
    }
    Ok(cols)
}

/// The lower triangle of $(Q + \lambda A)_{FF}$ in compressed columns, column by column (a
/// sparse product with a dense accumulator, Gustavson's method): free column $c$ gathers
/// $L_{:,k} L_{kc} / a_k$ over the entries $k$ of $L$'s column $c$, rows $r \ge c$ kept.
/// `cols` holds $L$'s columns as (row, value), the diagonal first.
fn free_block(
    cols: &[Vec<(u32, f64)>],
    mass: &[f64],
    constraints: &Constraints,
    lambda: f64,
) -> SparseColMat<usize, f64> {
    let free = &constraints.free_index;
    let n_free = constraints.free_vertices.len();
    let mut col_ptr = Vec::with_capacity(n_free + 1);
    let mut row_idx = Vec::new();
    let mut values = Vec::new();
    let mut acc = vec![0.0; n_free];
    let mut in_column = vec![false; n_free];
    let mut rows: Vec<usize> = Vec::new();
    col_ptr.push(0);
    for (c, &v) in constraints.free_vertices.iter().enumerate() {
        rows.clear();
        for &(k, lkc) in &cols[v as usize] {
            // The same product as the right-hand side's (lik · ljk · 1/a_k): the rows of Q sum
            // to zero in floating point as closely as they did, which a translation of every
            // handle relies on to move the free vertices by the same vector.
            let inv_a = 1.0 / mass[k as usize];
            for &(i, lik) in &cols[k as usize] {
                let Some(r) = free[i as usize].map(|r| r as usize) else { continue };
                if r < c {
                    continue;
                }
                if !in_column[r] {
                    in_column[r] = true;
                    rows.push(r);
                }
                acc[r] += lik * lkc * inv_a;
            }
        }
        acc[c] += lambda * mass[v as usize];
        if !in_column[c] {
            rows.push(c);
        }
        rows.sort_unstable();
        for &r in &rows {
            in_column[r] = false;
            row_idx.push(r);
            values.push(std::mem::take(&mut acc[r]));
        }
        col_ptr.push(row_idx.len());
    }
    let symbolic = SymbolicSparseColMat::new_checked(n_free, n_free, col_ptr, None, row_idx);
    SparseColMat::new(symbolic, values)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::cotan::cotan_laplacian;

    /// The free block assembled column by column equals $(L A^{-1} L + \lambda A)_{FF}$
    /// multiplied out densely from the cotangent Laplacian, every entry of its lower triangle
    /// (a bumpy bar with its two handle regions fixed).
    #[test]
    fn the_free_block_is_the_dense_product() {
        let (mesh, handles) = crate::geometry::shapes::bumpy_bar(1);
        let n = mesh.n_vertices();
        let constraints = Constraints::new(&mesh, &handles);
        let free = &constraints.free_vertices;
        assert!(free.len() < n && !free.is_empty());
        let lambda = 0.7;
        let mass = lumped_mass(mesh.positions(), mesh.triangles(), MassKind::Voronoi);
        let l = cotan_laplacian(mesh.positions(), mesh.triangles()).unwrap().to_dense();
        let block = free_block(&laplacian_columns(&mesh).unwrap(), &mass, &constraints, lambda);
        let block = block.to_dense();
        let mut checked = 0;
        for (c, &vc) in free.iter().enumerate() {
            for (r, &vr) in free.iter().enumerate() {
                let (vr, vc) = (vr as usize, vc as usize);
                let mut q: f64 = (0..n).map(|k| l[(vr, k)] * l[(k, vc)] / mass[k]).sum();
                if vr == vc {
                    q += lambda * mass[vr];
                }
                let got = if r >= c { block[(r, c)] } else { 0.0 };
                let want = if r >= c { q } else { 0.0 };
                assert!(
                    (got - want).abs() <= 1e-9 * (1.0 + want.abs()),
                    "({r}, {c}): {got} {want}"
                );
                checked += usize::from(r >= c && want != 0.0);
            }
        }
        assert!(checked > 4 * free.len(), "{checked} nonzeros");
    }
}
