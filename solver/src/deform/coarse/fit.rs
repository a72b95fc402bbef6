//! The coarse variant's space and the pose in it nearest a given pose of the full mesh: how
//! much of a target pose the prolongation (step 4 of [`crate::deform::coarse`]) can represent
//! at all, whichever coarse energy chooses the coarse pose. A measurement, not a solver: if
//! converged ARAP on the full mesh lies far outside the space, no coarse energy can reach it
//! and only a finer coarse mesh (or fine iterations) can; if it lies close, the distance of
//! the coarse variant's own minimum from it is the coarse energy's (BENCHMARKS.md, "One pose at
//! every resolution").
//!
//! The space: $p_i = \sum_k w_{ik} c_k + R_i D_i$, coarse positions $c$ (`#Vc×3`) and detail
//! rotations $R_i$. For given rotations the nearest point is linear least squares,
//! $$ (P^\top P + \varepsilon I)\, c = P^\top (x - R D), $$
//! $P$ the embedding's `#V×#Vc` weights and $\varepsilon = 10^{-10}\max_k (P^\top P)_{kk}$ (every
//! coarse vertex is one of the fine vertices and carries its weight, so $P^\top P$ is regular
//! and $\varepsilon$ only guards rounding). The rotations are one of [`DetailRotations`]:
//! - `Fine`: each fine vertex's own one-ring fit to $x$ (Sorkine & Alexa 2007's local step,
//!   uniform weights), $R_i$ = the rotation closest to $S_i = \sum_{j \in N(i)} e_{ij} e'^\top_{ij}$
//!   with $e$ the rest edges of $M$ and $e'$ those of $x$: the details turned as the target
//!   turns them, whatever the coarse level's rotations;
//! - `Coarse`: what the prolongation does, the normalized quaternion blend of coarse rotations
//!   $R_k$ over the corners of $t_i$, each $R_k$ the one-ring fit of coarse vertex $k$ from
//!   $B_c$ to $c$ (uniform weights); alternated with the least squares for a given number of
//!   sweeps, started from the `Fine` rotations at the kept vertices. A fixed point, not a
//!   minimum: the coarse variant's own rotations come from its energy's local step.
//!
//! Vertices of handles and of components without handles take $x$'s positions, as step 4 puts
//! them on their targets and at rest.

use crate::deform::coarse::base::CoarseBase;
use crate::deform::coarse::prolong::{Prolongation, prolong, quaternion_of};
use crate::deform::constraints::Constraints;
use crate::deform::handles::Handles;
use crate::error::SolveError;
use crate::geometry::embedding::from_stored;
use crate::geometry::mesh::{Mesh, sub};
use crate::geometry::topology::Adjacency;
use crate::linalg::linsolve::{Layout, SpdFactor};
use crate::linalg::rotation::{Mat3, add_outer, fit_rotation, mul_vec};
use faer::MatMut;
use faer::sparse::Triplet;
use glam::DQuat;
use rayon::prelude::*;

/// Which rotations turn the details in [`nearest_pose`] (module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DetailRotations {
    /// Each fine vertex's own fit to the target.
    Fine,
    /// The prolongation's blend of coarse rotations fitted to the coarse pose, alternated with
    /// the positions this many times.
    Coarse { sweeps: usize },
}

/// The pose of the coarse variant's space nearest `x` (`#V×3`, a pose of `mesh`) for `base`
/// (built for `mesh`), with the detail rotations of `rotations` (module doc). The result is
/// `#V×3`.
pub fn nearest_pose(
    mesh: &Mesh,
    base: &CoarseBase,
    handles: &Handles,
    x: &[[f64; 3]],
    rotations: DetailRotations,
) -> Result<Vec<[f64; 3]>, SolveError> {
    let n = mesh.n_vertices();
    let nc = base.coarse_mesh.n_vertices();
    let triangles = base.coarse_mesh.triangles();
    let corners: Vec<([u32; 3], [f64; 3])> = (0..n)
        .map(|i| {
            let [w0, w1] = base.weights[i];
            (triangles[base.faces[i] as usize], from_stored(w0, w1))
        })
        .collect();
    let mut normal = Vec::with_capacity(9 * n + nc);
    for (t, w) in &corners {
        for a in 0..3 {
            for b in 0..3 {
                normal.push(Triplet::new(t[a] as usize, t[b] as usize, w[a] * w[b]));
            }
        }
    }
    let mut diagonal = vec![0.0; nc];
    for (t, w) in &corners {
        for a in 0..3 {
            diagonal[t[a] as usize] += w[a] * w[a];
        }
    }
    let eps = 1e-10 * diagonal.iter().fold(0.0f64, |m, &d| m.max(d));
    normal.extend((0..nc).map(|k| Triplet::new(k, k, eps)));
    let mut factor = SpdFactor::from_triplets(nc, &normal, Layout::Auto)
        .map_err(|source| SolveError::Factorization { matrix: "PᵀP (coarse fit)", source })?;
    // The coarse positions nearest x − R D, as columns.
    let mut positions = |turned: &[[f64; 3]]| {
        let mut rhs = vec![0.0; 3 * nc];
        for ((t, w), (xi, ri)) in corners.iter().zip(x.iter().zip(turned)) {
            for a in 0..3 {
                for d in 0..3 {
                    rhs[d * nc + t[a] as usize] += w[a] * (xi[d] - ri[d]);
                }
            }
        }
        factor.solve_in_place(MatMut::from_column_major_slice_mut(&mut rhs, nc, 3));
        (0..nc).map(|k| [rhs[k], rhs[nc + k], rhs[2 * nc + k]]).collect::<Vec<_>>()
    };
    let fine = one_ring_fits(mesh.adjacency(), mesh.positions(), x);
    let mut pose = match rotations {
        DetailRotations::Fine => {
            let turned: Vec<_> =
                fine.iter().zip(&base.details).map(|(r, d)| mul_vec(r, *d)).collect();
            let c = positions(&turned);
            corners
                .iter()
                .zip(&turned)
                .map(|((t, w), r)| {
                    let b = (0..3).fold([0.0; 3], |acc, a| {
                        let p = c[t[a] as usize];
                        [acc[0] + w[a] * p[0], acc[1] + w[a] * p[1], acc[2] + w[a] * p[2]]
                    });
                    [b[0] + r[0], b[1] + r[1], b[2] + r[2]]
                })
                .collect()
        }
        DetailRotations::Coarse { sweeps } => {
            let mut q: Vec<DQuat> =
                base.kept.iter().map(|&v| quaternion_of(&fine[v as usize])).collect();
            let mut c = base.coarse_mesh.positions().to_vec();
            let zeros = vec![[0.0; 3]; nc];
            let mut turned = vec![[0.0; 3]; n];
            for _ in 0..sweeps.max(1) {
                // R̂ D alone: the prolongation of a coarse pose at the origin.
                prolong(input(base, &zeros, &q), &mut turned);
                c = positions(&turned);
                q = one_ring_fits(base.coarse_mesh.adjacency(), base.coarse_mesh.positions(), &c)
                    .iter()
                    .map(quaternion_of)
                    .collect();
            }
            let mut out = vec![[0.0; 3]; n];
            prolong(input(base, &c, &q), &mut out);
            out
        }
    };
    let fixed = Constraints::new(mesh, handles);
    for &v in fixed.handle_vertices.iter().chain(&fixed.pinned_vertices) {
        pose[v as usize] = x[v as usize];
    }
    Ok(pose)
}

/// The prolongation of coarse pose `c` with rotations `q` and no carried corrections.
fn input<'a>(base: &'a CoarseBase, c: &'a [[f64; 3]], q: &'a [DQuat]) -> Prolongation<'a> {
    Prolongation {
        coarse: c,
        quaternions: q,
        triangles: base.coarse_mesh.triangles(),
        faces: &base.faces,
        weights: &base.weights,
        details: &base.details,
        corrections: &[],
    }
}

/// Per vertex, the rotation closest to its one-ring covariance from `rest` to `x` (uniform
/// weights; the identity for an isolated vertex).
fn one_ring_fits(adjacency: &Adjacency, rest: &[[f64; 3]], x: &[[f64; 3]]) -> Vec<Mat3> {
    (0..rest.len())
        .into_par_iter()
        .map(|i| {
            let mut s = [[0.0; 3]; 3];
            for &j in adjacency.neighbors(i as u32) {
                let j = j as usize;
                add_outer(&mut s, 1.0, sub(rest[i], rest[j]), sub(x[i], x[j]));
            }
            fit_rotation(&s)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::deform::config::BaseConfig;
    use crate::deform::quality::distances;
    use crate::linalg::rigid::Motion;
    use crate::linalg::rotation::axis_angle;

    /// A rigid motion of the rest pose lies in the space (coarse pose $T(B_c)$, every rotation
    /// the motion's): both kinds of rotations find it to rounding. A bent pose is not in it:
    /// its nearest pose is much nearer it than the rest pose, but not on it.
    #[test]
    fn rigid_motions_are_in_the_space_and_bends_are_not() {
        let (mesh, handles) = crate::geometry::shapes::bumpy_bar(3);
        let base = CoarseBase::new(&mesh, &BaseConfig::default()).unwrap();
        let diag = mesh.bbox_diagonal();
        let motion =
            Motion { rotation: axis_angle([0.3, -1.0, 0.4], 0.9), translation: [0.2, -0.1, 0.05] };
        let moved: Vec<_> = mesh.positions().iter().map(|&p| motion.apply(p)).collect();
        for kind in [DetailRotations::Fine, DetailRotations::Coarse { sweeps: 3 }] {
            let fit = nearest_pose(&mesh, &base, &handles, &moved, kind).unwrap();
            let d = distances(&fit, &moved, diag);
            assert!(d.max < 1e-9, "{kind:?}: {d:?}");
        }
        // Bend the bar: turn each vertex about the z axis by an angle growing along x.
        let bent: Vec<_> = mesh
            .positions()
            .iter()
            .map(|&p| mul_vec(&axis_angle([0.0, 0.0, 1.0], 0.8 * p[0] / diag), p))
            .collect();
        let rest = distances(mesh.positions(), &bent, diag).mean;
        let fine = nearest_pose(&mesh, &base, &handles, &bent, DetailRotations::Fine).unwrap();
        let coarse =
            nearest_pose(&mesh, &base, &handles, &bent, DetailRotations::Coarse { sweeps: 5 })
                .unwrap();
        let (fine, coarse) =
            (distances(&fine, &bent, diag).mean, distances(&coarse, &bent, diag).mean);
        assert!(fine > 0.0 && fine < 0.1 * rest, "fine {fine} rest {rest}");
        assert!(coarse > 0.0 && coarse < 0.1 * rest, "coarse {coarse} rest {rest}");
    }
}
