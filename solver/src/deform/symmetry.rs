//! Mirror symmetry of a mesh: the symmetry plane by a best fit, the mirror vertex map, the
//! partner of a handle group, and a group transform mirrored across the plane (the editor's
//! mirrored painting and posing).
//!
//! **Plane**: axis-aligned, $\{x : x_a = c\}$ for an axis $a \in \{X, Y, Z\}$ (models are
//! authored in their axes; the user may pick the axis). Reflection $H(x) = x + 2(c - x_a)e_a$.
//! **Fit** ([`fit_plane`]): for each axis, start at the vertex centroid and at the bounding-box
//! centre, score each candidate by $\operatorname{err} = \frac{1}{n}\sum_i \min_j
//! \lVert H(p_i) - p_j\rVert$ over the vertices (nearest neighbour by [`KdTree`]), keep the
//! best, then refit the offset once from the pairs it found, $c = \operatorname{mean}_i
//! \tfrac12(p_i + p_{m(i)})_a$ (which removes a bias of the centroid on unevenly tessellated
//! sides). The score is returned as a fraction of the bounding-box diagonal: about 0 on a
//! symmetric mesh, small on a nearly symmetric one.
//! **Mirror map** ([`mirror_map`]): $m(i) = \arg\min_j \lVert H(p_i) - p_j\rVert$, the closest
//! vertex to the reflection (vertices on the plane map to themselves); it works on nearly
//! symmetric meshes and is not forced to be an involution there.
//! **Mirrored transform** ([`mirror_transform`]): a group pose $x \mapsto R(x - c_g) + c_g +
//! t$ becomes $x \mapsto (HRH)(x - H c_g) + H c_g + H t$ for the partner, with $H$ the linear
//! part ($HRH$ is a proper rotation). On the quaternion $q = (v, w)$ of $R$ that is
//! $(-Hv, w)$: the axis $v$ is a pseudovector, reflected with a change of sign.
//!
//! Known limitation: only axis-aligned planes; a model tilted against its axes fits badly (the
//! score says so).

use glam::{DQuat, DVec3};

use crate::deform::pose::GroupTransform;
use crate::geometry::kdtree::KdTree;
use crate::geometry::mesh::bounding_box;

/// A coordinate axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Axis {
    /// Left/right for most models. The default.
    #[default]
    X,
    Y,
    Z,
}

impl Axis {
    pub const ALL: [Axis; 3] = [Axis::X, Axis::Y, Axis::Z];

    /// 0, 1 or 2.
    pub fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }

    /// "X", "Y" or "Z".
    pub fn name(self) -> &'static str {
        ["X", "Y", "Z"][self.index()]
    }
}

/// The plane $x_{\text{axis}} = $ `offset` (mesh units).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SymmetryPlane {
    pub axis: Axis,
    pub offset: f64,
}

impl SymmetryPlane {
    /// $H(x)$: the point reflected across the plane.
    pub fn reflect(&self, mut x: [f64; 3]) -> [f64; 3] {
        let a = self.axis.index();
        x[a] = 2.0 * self.offset - x[a];
        x
    }

    /// The linear part of the reflection (a direction or displacement).
    pub fn reflect_vector(&self, mut v: [f64; 3]) -> [f64; 3] {
        v[self.axis.index()] = -v[self.axis.index()];
        v
    }

    /// $|x_{\text{axis}} - \text{offset}|$: how far `x` is from the plane.
    pub fn distance(&self, x: [f64; 3]) -> f64 {
        (x[self.axis.index()] - self.offset).abs()
    }
}

/// The mirror vertex map and how far the reflections land from their partners.
#[derive(Debug, Clone, PartialEq)]
pub struct MirrorMap {
    /// Per vertex, the vertex closest to its reflection.
    pub partner: Vec<u32>,
    /// Mean distance from a reflected vertex to its partner, as a fraction of the diagonal.
    pub mean_error: f64,
}

/// The mirror map of `positions` (`#V×3`) across `plane` (module doc).
pub fn mirror_map(positions: &[[f64; 3]], plane: &SymmetryPlane) -> MirrorMap {
    let tree = KdTree::new(positions.iter().enumerate().map(|(i, &p)| (i as u32, p)));
    let mut sum = 0.0;
    let partner = positions
        .iter()
        .enumerate()
        .map(|(i, &p)| {
            let q = plane.reflect(p);
            match tree.nearest(q, 1).first() {
                Some(&(j, d2)) => {
                    sum += d2.max(0.0).sqrt();
                    j
                }
                None => i as u32,
            }
        })
        .collect();
    let (lo, hi) = bounding_box(positions.iter().copied());
    let diag = crate::geometry::mesh::norm2(crate::geometry::mesh::sub(hi, lo)).sqrt();
    let n = positions.len().max(1) as f64;
    MirrorMap { partner, mean_error: if diag > 0.0 { sum / n / diag } else { 0.0 } }
}

/// The best-fitting plane along `axis` (module doc), with its mean error (fraction of the
/// diagonal).
pub fn fit_plane_on(positions: &[[f64; 3]], axis: Axis) -> (SymmetryPlane, f64) {
    let a = axis.index();
    let n = positions.len().max(1) as f64;
    let centroid = positions.iter().map(|p| p[a]).sum::<f64>() / n;
    let (lo, hi) = bounding_box(positions.iter().copied());
    let mut best: Option<(SymmetryPlane, MirrorMap)> = None;
    for offset in [centroid, 0.5 * (lo[a] + hi[a])] {
        let plane = SymmetryPlane { axis, offset };
        let map = mirror_map(positions, &plane);
        if best.as_ref().is_none_or(|(_, b)| map.mean_error < b.mean_error) {
            best = Some((plane, map));
        }
    }
    let Some((plane, map)) = best else { return (SymmetryPlane { axis, offset: 0.0 }, 0.0) };
    let offset = positions
        .iter()
        .zip(&map.partner)
        .map(|(p, &j)| 0.5 * (p[a] + positions[j as usize][a]))
        .sum::<f64>()
        / n;
    let refit = SymmetryPlane { axis, offset };
    let refit_map = mirror_map(positions, &refit);
    if refit_map.mean_error <= map.mean_error {
        (refit, refit_map.mean_error)
    } else {
        (plane, map.mean_error)
    }
}

/// The best-fitting plane over the three axes, with its mean error (fraction of the diagonal).
pub fn fit_plane(positions: &[[f64; 3]]) -> (SymmetryPlane, f64) {
    let mut fits = Axis::ALL.map(|a| fit_plane_on(positions, a));
    fits.sort_by(|a, b| a.1.total_cmp(&b.1));
    fits[0]
}

/// The partner of handle group `group` under `map`: the group most of its vertices' mirror
/// images belong to, when that is another group holding at least half of them.
pub fn partner_group(labels: &[Option<u32>], map: &MirrorMap, group: u32) -> Option<u32> {
    mirror_image(labels, map, group).filter(|&g| g != group)
}

/// The group most of handle group `group`'s vertices' mirror images belong to, when it holds at
/// least half of them: another group (its pair, [`partner_group`]), or `group` itself (a group
/// on the midline, its own mirror image).
pub fn mirror_image(labels: &[Option<u32>], map: &MirrorMap, group: u32) -> Option<u32> {
    let mut counts = std::collections::BTreeMap::new();
    let mut total = 0usize;
    for (v, l) in labels.iter().enumerate() {
        if *l == Some(group) {
            total += 1;
            if let Some(g) = labels.get(map.partner[v] as usize).copied().flatten() {
                *counts.entry(g).or_insert(0usize) += 1;
            }
        }
    }
    let (g, c) = counts.into_iter().max_by_key(|&(g, c)| (c, std::cmp::Reverse(g)))?;
    (2 * c >= total).then_some(g)
}

/// `t` mirrored across `plane`: the pose of the partner group (module doc).
pub fn mirror_transform(plane: &SymmetryPlane, t: &GroupTransform) -> GroupTransform {
    let axis = -DVec3::from_array(plane.reflect_vector(t.rotation.xyz().to_array()));
    GroupTransform {
        translation: DVec3::from_array(plane.reflect_vector(t.translation.to_array())),
        rotation: DQuat::from_vec4(axis.extend(t.rotation.w)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::rotation::{IDENTITY, Mat3, mul_mat, mul_vec};

    /// A lopsided but mirror-symmetric point set about x = 0.3 (plus a ragged y/z).
    fn points() -> Vec<[f64; 3]> {
        let mut p = Vec::new();
        for k in 0..40 {
            let (y, z) = ((k as f64 * 0.37).sin() * 2.0, (k as f64 * 0.91).cos() + 0.05 * k as f64);
            let x = 0.3 + 0.2 + (k % 7) as f64 * 0.1;
            p.push([x, y, z]);
            p.push([0.6 - x, y, z]);
        }
        p.push([0.3, 5.0, 1.0]);
        p
    }

    #[test]
    fn fits_the_plane_and_pairs() {
        let p = points();
        let (plane, err) = fit_plane(&p);
        assert_eq!(plane.axis, Axis::X);
        assert!((plane.offset - 0.3).abs() < 1e-12 && err < 1e-12, "{plane:?} {err}");
        let map = mirror_map(&p, &plane);
        for k in 0..40 {
            assert_eq!(map.partner[2 * k], 2 * k as u32 + 1);
            assert_eq!(map.partner[2 * k + 1], 2 * k as u32);
        }
        assert_eq!(map.partner[80], 80);
        // Nearly symmetric: a little noise keeps the pairs.
        let noisy: Vec<[f64; 3]> = p
            .iter()
            .enumerate()
            .map(|(i, q)| [q[0] + 1e-3 * (i as f64).sin(), q[1], q[2]])
            .collect();
        let (plane, err) = fit_plane(&noisy);
        assert!(plane.axis == Axis::X && (plane.offset - 0.3).abs() < 1e-3 && err < 1e-3);
        assert_eq!(mirror_map(&noisy, &plane).partner, map.partner);
    }

    #[test]
    fn partner_groups() {
        let p = points();
        let map = mirror_map(&p, &SymmetryPlane { axis: Axis::X, offset: 0.3 });
        let mut labels = vec![None; p.len()];
        for k in 0..5 {
            labels[2 * k] = Some(0);
            labels[2 * k + 1] = Some(3);
        }
        labels[20] = Some(1);
        assert_eq!(partner_group(&labels, &map, 0), Some(3));
        assert_eq!(partner_group(&labels, &map, 3), Some(0));
        assert_eq!(partner_group(&labels, &map, 1), None);
        // A group that is its own mirror image has no partner.
        let mut midline = vec![None; p.len()];
        for v in 0..4 {
            midline[v] = Some(2);
            midline[map.partner[v] as usize] = Some(2);
        }
        assert_eq!(mirror_image(&midline, &map, 2), Some(2));
        assert_eq!(partner_group(&midline, &map, 2), None);
        assert_eq!(mirror_image(&labels, &map, 0), Some(3));
    }

    /// Mirroring a posed group's points equals posing the mirrored points with the mirrored
    /// transform.
    #[test]
    fn mirrored_transform_commutes_with_reflection() {
        let plane = SymmetryPlane { axis: Axis::Y, offset: -0.7 };
        let t = GroupTransform::new(
            DVec3::new(0.3, -0.2, 0.5),
            DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 0.5).normalize(), 0.8),
        );
        let m = mirror_transform(&plane, &t);
        let c = [0.4, 1.0, -0.3];
        let mc = plane.reflect(c);
        let pose = |t: &GroupTransform, c: [f64; 3], x: [f64; 3]| {
            let r = mul_vec(&t.rotation_matrix(), [x[0] - c[0], x[1] - c[1], x[2] - c[2]]);
            [
                r[0] + c[0] + t.translation[0],
                r[1] + c[1] + t.translation[1],
                r[2] + c[2] + t.translation[2],
            ]
        };
        for x in [[1.0, 2.0, 3.0], [-0.5, 0.1, 0.0]] {
            let a = plane.reflect(pose(&t, c, x));
            let b = pose(&m, mc, plane.reflect(x));
            for k in 0..3 {
                assert!((a[k] - b[k]).abs() < 1e-12);
            }
        }
        let det = |r: &Mat3| {
            r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1])
                - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0])
                + r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0])
        };
        let r = m.rotation_matrix();
        assert!((det(&r) - 1.0).abs() < 1e-12);
        // The quaternion form is the matrix form H R H.
        let mut h = IDENTITY;
        h[1][1] = -1.0;
        let hrh = mul_mat(&h, &mul_mat(&t.rotation_matrix(), &h));
        let err = r.iter().flatten().zip(hrh.iter().flatten()).map(|(a, b)| (a - b).abs());
        assert!(err.fold(0.0, f64::max) < 1e-15, "{r:?} vs {hrh:?}");
        assert_eq!(mirror_transform(&plane, &m), t);
    }
}
