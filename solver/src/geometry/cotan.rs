//! Cotangent weights and the cotangent Laplacian (Pinkall & Polthier 1993; Meyer et al. 2003).
//!
//! For an edge $(i,j)$ with opposite angles $\alpha_{ij}$ and $\beta_{ij}$ in its (one or two)
//! triangles, $w_{ij} = \tfrac12(\cot\alpha_{ij} + \cot\beta_{ij})$.
//!
//! **Sign convention**: this crate's Laplacian is positive semi-definite,
//! $L_{ij} = -w_{ij}$ for $i \ne j$ and $L_{ii} = \sum_j w_{ij}$, so that
//! $x^\top L x = \sum_{(i,j)} w_{ij}\lVert x_i - x_j\rVert^2$ (libigl's `cotmatrix` is $-L$).
//! Rows sum to zero and $L$ is symmetric. Weights may be negative (obtuse angles); they are
//! kept, which keeps $L$ the exact linear-FEM Dirichlet matrix (still PSD).
//!
//! Inputs: positions `#V×3 f64`, triangles `#F×3 u32`. A triangle whose doubled area is not
//! above `1e-15·(longest edge)²` has no finite cotangents: [`face_cotangents`] names it.

use crate::geometry::mesh::{cross, dot, norm, sub};
use faer::sparse::{SparseColMat, Triplet};
use thiserror::Error;

/// A triangle too thin for cotangent weights.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("triangle {face} is degenerate (zero or near-zero area): cotangent weights are undefined")]
pub struct DegenerateFace {
    pub face: usize,
}

/// Per triangle `t = (a, b, c)`: `[½cot∠a, ½cot∠b, ½cot∠c]`, the half-cotangent of the angle at
/// each corner, which is the weight of the opposite edge (`bc`, `ca`, `ab`) within `t`.
/// Output `#F×3`. A triangle is degenerate when its doubled area is not above
/// `1e-15·(longest edge)²` (a needle or a cap) or not above `min_double_area` (an absolute floor
/// in length², for shapes such as a collapsed base surface whose triangles shrink uniformly).
pub fn face_cotangents(
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
    min_double_area: f64,
) -> Result<Vec<[f64; 3]>, DegenerateFace> {
    face_cotangents_or(positions, None, triangles, min_double_area).map(|(cot, _)| cot)
}

/// As [`face_cotangents`], except that a degenerate triangle takes the cotangents of the same
/// triangle in `fallback` positions (when given and not degenerate there, floor 0): for a
/// smoothed base surface $B$ whose features thinner than the smoothing length have flattened,
/// the weights of the rest mesh $M$ keep $L$ PSD and finite where $B$'s own are undefined.
/// Returns the cotangents and how many triangles took the fallback.
pub fn face_cotangents_or(
    positions: &[[f64; 3]],
    fallback: Option<&[[f64; 3]]>,
    triangles: &[[u32; 3]],
    min_double_area: f64,
) -> Result<(Vec<[f64; 3]>, usize), DegenerateFace> {
    let mut replaced = 0;
    let cot = triangles
        .iter()
        .enumerate()
        .map(|(face, t)| {
            if let Some(w) = triangle_cotangents(t.map(|v| positions[v as usize]), min_double_area)
            {
                return Ok(w);
            }
            let w = fallback.and_then(|f| triangle_cotangents(t.map(|v| f[v as usize]), 0.0));
            replaced += 1;
            w.ok_or(DegenerateFace { face })
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok((cot, replaced))
}

/// `[½cot∠a, ½cot∠b, ½cot∠c]` of one triangle, `None` when it is degenerate (see
/// [`face_cotangents`]).
fn triangle_cotangents(p: [[f64; 3]; 3], min_double_area: f64) -> Option<[f64; 3]> {
    let mut w = [0.0; 3];
    for k in 0..3 {
        let u = sub(p[(k + 1) % 3], p[k]);
        let v = sub(p[(k + 2) % 3], p[k]);
        let twice_area = norm(cross(u, v));
        let scale = dot(u, u).max(dot(v, v));
        let valid =
            twice_area.is_finite() && twice_area > 1e-15 * scale && twice_area > min_double_area;
        if !valid {
            return None;
        }
        w[k] = 0.5 * dot(u, v) / twice_area;
    }
    Some(w)
}

/// The edge `(i, j)` opposite corner `k` of triangle `t`.
#[inline]
pub fn opposite_edge(t: [u32; 3], k: usize) -> (u32, u32) {
    (t[(k + 1) % 3], t[(k + 2) % 3])
}

/// Triplets of the PSD cotangent Laplacian (duplicates to be summed), from per-face half
/// cotangents. With `clamp_negative`, negative per-edge sums are set to zero (plain-spokes ARAP).
pub fn laplacian_triplets(
    n_vertices: usize,
    triangles: &[[u32; 3]],
    cot: &[[f64; 3]],
    clamp_negative: bool,
) -> Vec<Triplet<usize, usize, f64>> {
    let mut out = Vec::with_capacity(n_vertices + 4 * 3 * triangles.len());
    let weights = edge_weights(triangles, cot, clamp_negative);
    for &(i, j, w) in &weights {
        let (i, j) = (i as usize, j as usize);
        out.push(Triplet::new(i, j, -w));
        out.push(Triplet::new(j, i, -w));
        out.push(Triplet::new(i, i, w));
        out.push(Triplet::new(j, j, w));
    }
    out
}

/// Unique undirected edges `(i < j, w_ij)` with $w_{ij} = \tfrac12(\cot\alpha+\cot\beta)$ summed
/// over the triangles sharing the edge, sorted by `(i, j)`.
pub fn edge_weights(
    triangles: &[[u32; 3]],
    cot: &[[f64; 3]],
    clamp_negative: bool,
) -> Vec<(u32, u32, f64)> {
    let mut e: Vec<(u32, u32, f64)> = Vec::with_capacity(3 * triangles.len());
    for (t, w) in triangles.iter().zip(cot) {
        for (k, &wk) in w.iter().enumerate() {
            let (a, b) = opposite_edge(*t, k);
            e.push((a.min(b), a.max(b), wk));
        }
    }
    e.sort_unstable_by_key(|&(a, b, _)| (a, b));
    let mut out: Vec<(u32, u32, f64)> = Vec::with_capacity(e.len() / 2 + 1);
    for (a, b, w) in e {
        match out.last_mut() {
            Some(last) if last.0 == a && last.1 == b => last.2 += w,
            _ => out.push((a, b, w)),
        }
    }
    if clamp_negative {
        for x in &mut out {
            x.2 = x.2.max(0.0);
        }
    }
    out
}

/// The PSD cotangent Laplacian `#V×#V` (see the module doc for the convention).
pub fn cotan_laplacian(
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
) -> Result<SparseColMat<usize, f64>, DegenerateFace> {
    let cot = face_cotangents(positions, triangles, 0.0)?;
    let n = positions.len();
    let t = laplacian_triplets(n, triangles, &cot, false);
    // Indices are in range by construction (Mesh invariants), so this cannot fail.
    SparseColMat::try_new_from_triplets(n, n, &t).map_err(|_| DegenerateFace { face: 0 })
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;

    fn tetra() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let s = 1.0 / 2f64.sqrt();
        let p = vec![[1.0, 0.0, -s], [-1.0, 0.0, -s], [0.0, 1.0, s], [0.0, -1.0, s]];
        let t = vec![[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]];
        (p, t)
    }

    fn dense(l: &SparseColMat<usize, f64>) -> Vec<Vec<f64>> {
        let n = l.nrows();
        let mut d = vec![vec![0.0; n]; n];
        for j in 0..n {
            for (i, v) in
                l.as_ref().symbolic().row_idx_of_col(j).zip(l.as_ref().val_of_col(j).iter())
            {
                d[i][j] += *v;
            }
        }
        d
    }

    #[test]
    fn rows_sum_to_zero_and_symmetric() {
        let (p, t) = tetra();
        let l = dense(&cotan_laplacian(&p, &t).unwrap());
        for i in 0..4 {
            assert!(l[i].iter().sum::<f64>().abs() < 1e-14);
            for j in 0..4 {
                assert!((l[i][j] - l[j][i]).abs() < 1e-14);
            }
        }
    }

    /// Regular tetrahedron: every angle is 60°, every edge lies in two triangles, so
    /// w_ij = ½(2·cot 60°) = 1/√3, and L_ii = 3/√3 = √3 (libigl's test uses −3/tan 60°·½·2).
    #[test]
    fn regular_tetrahedron_hand_computed() {
        let (p, t) = tetra();
        let l = dense(&cotan_laplacian(&p, &t).unwrap());
        let w = 1.0 / 3f64.sqrt();
        for i in 0..4 {
            assert!((l[i][i] - 3.0 * w).abs() < 1e-12, "{}", l[i][i]);
            for j in 0..4 {
                if i != j {
                    assert!((l[i][j] + w).abs() < 1e-12);
                }
            }
        }
    }

    /// Right isoceles triangle (0,0),(1,0),(0,1): angles 90°, 45°, 45°;
    /// w_12 = ½cot 90° = 0, w_01 = w_02 = ½cot 45° = ½.
    #[test]
    fn single_right_triangle() {
        let p = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let l = dense(&cotan_laplacian(&p, &[[0, 1, 2]]).unwrap());
        assert!((l[0][1] + 0.5).abs() < 1e-15);
        assert!((l[0][2] + 0.5).abs() < 1e-15);
        assert!(l[1][2].abs() < 1e-15);
        assert!((l[0][0] - 1.0).abs() < 1e-15);
    }

    #[test]
    fn scale_invariant_and_degenerate_named() {
        let (p, t) = tetra();
        for s in [1e-8, 1e8] {
            let q: Vec<[f64; 3]> = p.iter().map(|x| x.map(|c| c * s)).collect();
            let l = dense(&cotan_laplacian(&q, &t).unwrap());
            assert!((l[0][0] - 3f64.sqrt()).abs() < 1e-10);
        }
        let flat = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
        assert_eq!(face_cotangents(&flat, &[[0, 1, 2]], 0.0), Err(DegenerateFace { face: 0 }));
        let tiny = vec![[0.0, 0.0, 0.0], [1e-9, 0.0, 0.0], [0.0, 1e-9, 0.0]];
        assert!(face_cotangents(&tiny, &[[0, 1, 2]], 0.0).is_ok());
        assert_eq!(face_cotangents(&tiny, &[[0, 1, 2]], 1e-12), Err(DegenerateFace { face: 0 }));
        // A collapsed triangle takes the cotangents of the same triangle in the fallback.
        let rest = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let (w, replaced) = face_cotangents_or(&flat, Some(&rest), &[[0, 1, 2]], 0.0).unwrap();
        assert_eq!((w, replaced), (face_cotangents(&rest, &[[0, 1, 2]], 0.0).unwrap(), 1));
        assert_eq!(
            face_cotangents_or(&flat, Some(&flat), &[[0, 1, 2]], 0.0),
            Err(DegenerateFace { face: 0 })
        );
    }
}
