//! Lumped (diagonal) mass matrix $A$ of a triangle mesh.
//!
//! - Barycentric: $A_{ii} = \tfrac13 \sum_{t \ni i} |t|$.
//! - Voronoi (mixed, Meyer et al. 2003, libigl's default): for a non-obtuse triangle the corner
//!   $i$ gets its Voronoi area $\tfrac18(\lVert e_{ij}\rVert^2\cot\gamma_k + \lVert e_{ik}\rVert^2\cot\gamma_j)$;
//!   for an obtuse triangle the obtuse corner gets $|t|/2$ and the others $|t|/4$.
//!
//! Input positions `#V×3`, triangles `#F×3`; output `#V` areas (units: length²). Every entry is
//! positive on a cleaned mesh (each vertex has a triangle of positive area).

use crate::geometry::mesh::{cross, dot, norm, sub};
use faer::sparse::{SparseColMat, Triplet};

/// Which lumping rule to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum MassKind {
    Barycentric,
    #[default]
    Voronoi,
}

/// Diagonal of the lumped mass matrix, `#V` entries.
pub fn lumped_mass(positions: &[[f64; 3]], triangles: &[[u32; 3]], kind: MassKind) -> Vec<f64> {
    let mut a = vec![0.0; positions.len()];
    for t in triangles {
        let p = t.map(|v| positions[v as usize]);
        let area = 0.5 * norm(cross(sub(p[1], p[0]), sub(p[2], p[0])));
        match kind {
            MassKind::Barycentric => {
                for &v in t {
                    a[v as usize] += area / 3.0;
                }
            }
            MassKind::Voronoi => {
                // Corner k: angle between edges to the other two corners.
                let cosines: [f64; 3] = std::array::from_fn(|k| {
                    dot(sub(p[(k + 1) % 3], p[k]), sub(p[(k + 2) % 3], p[k]))
                });
                if let Some(obtuse) = (0..3).find(|&k| cosines[k] < 0.0) {
                    for k in 0..3 {
                        a[t[k] as usize] += if k == obtuse { area / 2.0 } else { area / 4.0 };
                    }
                } else if area > 0.0 {
                    for k in 0..3 {
                        let (j, l) = ((k + 1) % 3, (k + 2) % 3);
                        // cot of the angle at corner l weights the edge k–j, and vice versa.
                        let cot_l = cosines[l] / (2.0 * area);
                        let cot_j = cosines[j] / (2.0 * area);
                        let e_kj = sub(p[j], p[k]);
                        let e_kl = sub(p[l], p[k]);
                        a[t[k] as usize] +=
                            (dot(e_kj, e_kj) * cot_l + dot(e_kl, e_kl) * cot_j) / 8.0;
                    }
                }
            }
        }
    }
    a
}

/// The lumped mass matrix $A$ as a diagonal `#V×#V` faer sparse matrix.
pub fn mass_matrix(
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
    kind: MassKind,
) -> SparseColMat<usize, f64> {
    let a = lumped_mass(positions, triangles, kind);
    let n = a.len();
    let t: Vec<Triplet<usize, usize, f64>> =
        a.into_iter().enumerate().map(|(i, x)| Triplet::new(i, i, x)).collect();
    match SparseColMat::try_new_from_triplets(n, n, &t) {
        Ok(m) => m,
        // A diagonal with in-range indices always builds.
        Err(e) => unreachable!("diagonal mass matrix: {e:?}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn masses_sum_to_total_area() {
        let p = vec![[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 1.0, 0.0], [3.0, 2.0, 0.5]];
        let t = vec![[0, 1, 2], [1, 3, 2]];
        let total: f64 = t
            .iter()
            .map(|t| {
                let q = t.map(|v| p[v as usize]);
                0.5 * norm(cross(sub(q[1], q[0]), sub(q[2], q[0])))
            })
            .sum();
        for kind in [MassKind::Barycentric, MassKind::Voronoi] {
            let a = lumped_mass(&p, &t, kind);
            assert!((a.iter().sum::<f64>() - total).abs() < 1e-12, "{kind:?}");
            assert!(a.iter().all(|&x| x > 0.0));
        }
        // Equilateral triangle: Voronoi areas equal the barycentric thirds.
        let s = 3f64.sqrt() / 2.0;
        let e = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, s, 0.0]];
        let v = lumped_mass(&e, &[[0, 1, 2]], MassKind::Voronoi);
        for x in v {
            assert!((x - s / 6.0).abs() < 1e-14);
        }
        let m = mass_matrix(&e, &[[0, 1, 2]], MassKind::Voronoi);
        assert_eq!(m.compute_nnz(), 3);
        assert!((m.as_ref().val_of_col(2)[0] - s / 6.0).abs() < 1e-14);
    }
}
