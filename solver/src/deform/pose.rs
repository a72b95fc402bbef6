//! Handle targets from per-group rigid transforms.
//!
//! A group $g$ with rest vertices $p_v$ and centroid $c_g = \frac1{|g|}\sum_{v\in g} p_v$ moved by
//! rotation $R$ (about $c_g$) and translation $t$ has targets $p'_v = c_g + R(p_v - c_g) + t$,
//! the rigid motion $x \mapsto R x + (c_g - R c_g + t)$ ([`GroupTransform::motion`]).
//!
//! A [`GroupTransform`] holds glam types (`DVec3`, `DQuat`), as the editor, the timeline, the
//! CLI and the Python package give it; the row-major [`Mat3`] the solver's hot paths use
//! ([`Motion`], the targets) is made from it only here ([`GroupTransform::rotation_matrix`],
//! and back, [`GroupTransform::from_matrix`]).
//!
//! [`GroupRest`] holds what the transforms act on (each group's centroid, each handle vertex's
//! group and rest position), computed once per handle set: the [`crate::Deformer`] keeps one,
//! so that callers hand it the group motions as they are ([`crate::Deformer::solve_groups`])
//! and it derives the per-vertex targets where a method needs them. [`centroid`] is the one
//! place centroids of vertex sets are computed (the editor's gizmo uses it too).

use glam::{DQuat, DVec3};

use crate::deform::handles::{Handles, HandlesError};
use crate::geometry::mesh::in_range;
use crate::linalg::rigid::Motion;
use crate::linalg::rotation::{IDENTITY, Mat3, mat3_of, mul_vec, quat_of};

/// A rigid motion of one handle group, $p' = c + R(q)(p - c) + t$: rotate by `rotation` about
/// the group's rest centroid $c$, then translate by `translation`. The default (zero
/// translation, identity rotation) is the rest pose.
///
/// Convention: glam's `DQuat`, a unit quaternion, written as an array in glam's order
/// `[x, y, z, w]` (`DQuat::to_array`). The solver normalizes it where it becomes a matrix
/// ([`GroupTransform::rotation_matrix`]), so a quaternion off unit length by rounding is
/// harmless; `q` and `−q` are the same rotation.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct GroupTransform {
    /// Translation $t$ (mesh units).
    pub translation: DVec3,
    /// Rotation $q$ about the group's rest centroid (unit quaternion).
    pub rotation: DQuat,
}

impl GroupTransform {
    /// The rest pose: no translation, no rotation.
    pub const IDENTITY: GroupTransform =
        GroupTransform { translation: DVec3::ZERO, rotation: DQuat::IDENTITY };

    /// Rotation `rotation` about the rest centroid, then translation `translation`.
    pub fn new(translation: DVec3, rotation: DQuat) -> GroupTransform {
        GroupTransform { translation, rotation }
    }

    /// A translation alone.
    pub fn from_translation(translation: DVec3) -> GroupTransform {
        GroupTransform { translation, rotation: DQuat::IDENTITY }
    }

    /// The animation benchmark's motion (BENCHMARKS.md, "The animation benchmark"; `bsarap
    /// bench`): frame `frame` of `frames` on a circle of `radius` through rest in the plane of
    /// the first two axes, $\theta = 2\pi\,(\text{frame} \bmod \text{frames})/\text{frames}$,
    /// $t = r\,(\cos\theta - 1,\ \sin\theta,\ 0)$. Frame `frames` is exactly the rest pose
    /// ($\theta = 0$ rather than $2\pi$, whose sine is not 0 in floating point).
    pub fn on_bench_circle(radius: f64, frames: usize, frame: usize) -> GroupTransform {
        let theta = std::f64::consts::TAU * (frame % frames.max(1)) as f64 / frames.max(1) as f64;
        GroupTransform::from_translation(DVec3::new(
            radius * (theta.cos() - 1.0),
            radius * theta.sin(),
            0.0,
        ))
    }

    /// From a row-major rotation matrix (a proper rotation; [`quat_of`], normalized) and a
    /// translation: the inverse of [`GroupTransform::rotation_matrix`] up to rounding.
    pub fn from_matrix(translation: DVec3, rotation: &Mat3) -> GroupTransform {
        GroupTransform { translation, rotation: quat_of(rotation).normalize() }
    }

    /// The rotation as a row-major matrix ([`mat3_of`] of the normalized quaternion); a zero
    /// quaternion (no rotation given) is the identity. The one place a group's quaternion
    /// becomes the solver's matrix.
    pub fn rotation_matrix(&self) -> Mat3 {
        let q = self.rotation;
        if q.length_squared() == 0.0 { IDENTITY } else { mat3_of(q.normalize()) }
    }

    /// Whether this is the rest pose: zero translation and a rotation whose matrix is exactly
    /// the identity (`q` or `−q` of the identity).
    pub fn is_identity(&self) -> bool {
        self.moving_rotation().is_none()
    }

    /// The rotation matrix, `None` at the rest pose (which leaves a group exactly at rest:
    /// `c + (p − c)` may round).
    fn moving_rotation(&self) -> Option<Mat3> {
        let rotation = self.rotation_matrix();
        (self.translation != DVec3::ZERO || rotation != IDENTITY).then_some(rotation)
    }

    /// Whether every component is a finite number.
    pub fn is_finite(&self) -> bool {
        self.translation.is_finite() && self.rotation.is_finite()
    }

    /// Whether the motion is finite and moves within the coordinate limit
    /// (±[`crate::geometry::mesh::MAX_COORDINATE`]): a pose no mesh reader takes back, and no
    /// scene holding it reads, otherwise ([`HandlesError::MoveOutOfRange`]).
    pub fn in_range(&self) -> bool {
        self.rotation.is_finite() && self.translation.to_array().into_iter().all(in_range)
    }

    /// The motion $x \mapsto R x + (c - R c + t)$ this transform makes of a group with rest
    /// centroid `centroid`; the identity transform gives [`Motion::IDENTITY`] exactly.
    pub fn motion(&self, centroid: [f64; 3]) -> Motion {
        let Some(rotation) = self.moving_rotation() else {
            return Motion::IDENTITY;
        };
        let rc = mul_vec(&rotation, centroid);
        let t = self.translation.to_array();
        Motion { rotation, translation: std::array::from_fn(|d| centroid[d] - rc[d] + t[d]) }
    }
}

/// Centroid $\frac1{|S|}\sum_{v\in S} p_v$ of the vertices `vertices` of `positions` (`#V×3`);
/// `None` for an empty set. An index out of range is skipped.
pub fn centroid(positions: &[[f64; 3]], vertices: &[u32]) -> Option<[f64; 3]> {
    let mut c = [0.0; 3];
    let mut n = 0usize;
    for p in vertices.iter().filter_map(|&v| positions.get(v as usize)) {
        for d in 0..3 {
            c[d] += p[d];
        }
        n += 1;
    }
    (n > 0).then(|| c.map(|x| x / n as f64))
}

/// Rest centroid of group `k` ([`centroid`] of [`Handles::group`]).
pub fn group_centroid(
    rest: &[[f64; 3]],
    handles: &Handles,
    k: usize,
) -> Result<[f64; 3], HandlesError> {
    let g = handles.group(k)?;
    Ok(centroid(rest, g).unwrap_or([0.0; 3]))
}

/// A moved group's rotation, rest centroid and translation.
type Moved = (Mat3, [f64; 3], [f64; 3]);

/// What group transforms act on, for one handle set: per group its rest centroid, per handle
/// vertex (order of [`Handles::handle_vertices`]) its group and rest position. Inputs of
/// [`GroupRest::targets`] and [`GroupRest::motions`].
#[derive(Debug, Clone, Default)]
pub struct GroupRest {
    /// Per group id, its rest centroid (`None`: no such group).
    centroids: Vec<Option<[f64; 3]>>,
    /// Per handle vertex, its group and rest position.
    vertices: Vec<(u32, [f64; 3])>,
    /// The groups that exist, for error messages.
    available: String,
}

impl GroupRest {
    /// The centroids and handle rest positions of `handles` on `rest` (`#V×3`).
    pub fn new(rest: &[[f64; 3]], handles: &Handles) -> GroupRest {
        let centroids = (0..handles.n_groups())
            .map(|k| handles.group(k).ok().and_then(|g| centroid(rest, g)))
            .collect();
        let labels = handles.labels();
        let vertices = handles
            .handle_vertices()
            .iter()
            .filter_map(|&v| Some((labels.get(v as usize).copied().flatten()?, rest[v as usize])))
            .collect();
        GroupRest { centroids, vertices, available: handles.group_list() }
    }

    /// Number of handle vertices (the length of [`GroupRest::targets`]).
    pub fn n_handles(&self) -> usize {
        self.vertices.len()
    }

    /// One past the largest group id (the length of [`GroupRest::motions`]).
    pub fn n_groups(&self) -> usize {
        self.centroids.len()
    }

    /// Rest centroid of group `k`, `None` for a group that does not exist.
    pub fn centroid(&self, k: usize) -> Option<[f64; 3]> {
        self.centroids.get(k).copied().flatten()
    }

    fn centroid_or_err(&self, k: usize) -> Result<[f64; 3], HandlesError> {
        self.centroid(k).ok_or_else(|| HandlesError::UnknownGroup {
            group: k,
            available: self.available.clone(),
        })
    }

    /// Per group id, the motion of `transforms` ([`GroupTransform::motion`]); groups not
    /// listed stay ([`Motion::IDENTITY`]). An unknown group is an error.
    pub fn motions(
        &self,
        transforms: &[(usize, GroupTransform)],
        out: &mut Vec<Motion>,
    ) -> Result<(), HandlesError> {
        out.clear();
        out.resize(self.n_groups(), Motion::IDENTITY);
        for (k, t) in transforms {
            out[*k] = t.motion(self.centroid_or_err(*k)?);
        }
        Ok(())
    }

    /// Targets `#H×3` in the order of [`Handles::handle_vertices`] for `(group, transform)`
    /// pairs, into `out`: $p'_v = c_g + R(p_v - c_g) + t$. Groups not listed, and groups with
    /// the identity transform, stay exactly at rest. An unknown group is an error.
    pub fn targets(
        &self,
        transforms: &[(usize, GroupTransform)],
        out: &mut Vec<[f64; 3]>,
    ) -> Result<(), HandlesError> {
        // Per group: its motion, or `None` to stay exactly at rest.
        let mut per_group: Vec<Option<Moved>> = vec![None; self.n_groups()];
        for &(k, t) in transforms {
            let c = self.centroid_or_err(k)?;
            // Targets beyond the limit would give a pose no mesh reader takes back.
            let out_of_range = |v: &&f64| !in_range(**v);
            if let Some(&value) = t.translation.to_array().iter().find(out_of_range) {
                return Err(HandlesError::MoveOutOfRange { group: k, value });
            }
            // (normalized, it made every target of the group NaN, reported by a vertex index)
            if !(t.rotation.is_finite() && t.rotation.length_squared() > 0.0) {
                return Err(HandlesError::BadRotation { group: k });
            }
            per_group[k] = t.moving_rotation().map(|r| (r, c, t.translation.to_array()));
        }
        out.clear();
        out.extend(self.vertices.iter().map(|&(k, p)| match &per_group[k as usize] {
            Some((rotation, c, t)) => {
                let r = mul_vec(rotation, [p[0] - c[0], p[1] - c[1], p[2] - c[2]]);
                std::array::from_fn(|d| c[d] + r[d] + t[d])
            }
            None => p,
        }));
        Ok(())
    }
}

/// Targets `#H×3` in the order of [`Handles::handle_vertices`] for `(group, transform)` pairs
/// ([`GroupRest::targets`]); groups not listed, and groups with the identity transform, stay
/// exactly at rest. An unknown group is an error.
pub fn handle_targets(
    rest: &[[f64; 3]],
    handles: &Handles,
    transforms: &[(usize, GroupTransform)],
) -> Result<Vec<[f64; 3]>, HandlesError> {
    let mut out = Vec::new();
    GroupRest::new(rest, handles).targets(transforms, &mut out)?;
    Ok(out)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::linalg::rotation::axis_angle;

    /// A move beyond the coordinate limit is refused, naming the group: its pose could not be
    /// written to a file any reader takes back.
    #[test]
    fn a_move_beyond_the_coordinate_limit_is_an_error() {
        let rest = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let handles = Handles::from_labels(&[0, -1, 1], 3).unwrap();
        let far = GroupTransform::from_translation(DVec3::new(0.0, 1e100, 0.0));
        let e = handle_targets(&rest, &handles, &[(1, far)]).unwrap_err();
        assert!(matches!(e, HandlesError::MoveOutOfRange { group: 1, .. }), "{e}");
        assert!(e.to_string().contains("1e100"), "{e}");
        let near = GroupTransform::from_translation(DVec3::new(0.0, 1e29, 0.0));
        assert!(handle_targets(&rest, &handles, &[(1, near)]).is_ok());
    }

    #[test]
    fn the_bench_circle_starts_and_ends_at_rest() {
        let r = 0.5;
        assert!(GroupTransform::on_bench_circle(r, 20, 20).is_identity());
        assert!(GroupTransform::on_bench_circle(r, 20, 0).is_identity());
        let half = GroupTransform::on_bench_circle(r, 20, 10).translation;
        assert!((half - DVec3::new(-2.0 * r, 0.0, 0.0)).length() < 1e-12, "{half}");
        let quarter = GroupTransform::on_bench_circle(r, 20, 5).translation;
        assert!((quarter - DVec3::new(-r, r, 0.0)).length() < 1e-12, "{quarter}");
    }

    #[test]
    fn motion_moves_like_the_targets() {
        let rest = [[1.0, 0.0, 0.0], [3.0, 0.5, 0.0], [0.0, 5.0, 1.0], [9.0, 9.0, 9.0]];
        let h = Handles::from_options(vec![Some(0), Some(0), Some(0), None]).unwrap();
        let t = GroupTransform::new(
            DVec3::new(0.3, -0.2, 1.0),
            DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 0.5).normalize(), 0.7),
        );
        let gr = GroupRest::new(&rest, &h);
        let targets = handle_targets(&rest, &h, &[(0, t)]).unwrap();
        let mut motions = Vec::new();
        gr.motions(&[(0, t)], &mut motions).unwrap();
        for (v, q) in targets.iter().enumerate() {
            let m = motions[0].apply(rest[v]);
            assert!((0..3).all(|d| (m[d] - q[d]).abs() < 1e-12), "{m:?} vs {q:?}");
        }
        assert_eq!(gr.centroid(0), Some([4.0 / 3.0, 5.5 / 3.0, 1.0 / 3.0]));
        assert!(gr.motions(&[(3, t)], &mut motions).is_err());
        assert!(handle_targets(&rest, &h, &[(1, t)]).is_err());
        assert_eq!(GroupTransform::default().motion([1.0, 2.0, 3.0]), Motion::IDENTITY);
        assert_eq!(centroid(&rest, &[]), None);
    }

    /// The quaternion becomes the same matrix as Rodrigues' formula (to rounding), `q` and
    /// `−q` are one rotation, the identity (either sign) leaves the group exactly at rest, and
    /// [`GroupTransform::from_matrix`] gives the quaternion back.
    #[test]
    fn quaternion_and_matrix_agree() {
        let axis = [1.0, 2.0, 0.5];
        let t = GroupTransform::new(
            DVec3::new(0.3, -0.2, 1.0),
            DQuat::from_axis_angle(DVec3::from_array(axis).normalize(), 0.7),
        );
        let r = t.rotation_matrix();
        let rodrigues = axis_angle(axis, 0.7);
        let err = r.iter().flatten().zip(rodrigues.iter().flatten()).map(|(a, b)| (a - b).abs());
        assert!(err.fold(0.0, f64::max) < 1e-15, "{r:?} vs {rodrigues:?}");
        let negated = GroupTransform { rotation: -t.rotation, ..t };
        assert_eq!(negated.rotation_matrix(), r);
        let back = GroupTransform::from_matrix(t.translation, &r);
        assert!(back.rotation.dot(t.rotation).abs() > 1.0 - 1e-15, "{back:?}");
        assert_eq!(back.translation, t.translation);
        let flipped = GroupTransform { rotation: -DQuat::IDENTITY, ..GroupTransform::IDENTITY };
        assert!(flipped.is_identity() && GroupTransform::default().is_identity());
        assert_eq!(flipped.motion([1.0, 2.0, 3.0]), Motion::IDENTITY);
        let rest = [[1.0, 0.1, 0.0], [3.0, 0.5, 0.3]];
        let h = Handles::from_options(vec![Some(0), Some(0)]).unwrap();
        assert_eq!(handle_targets(&rest, &h, &[(0, flipped)]).unwrap(), rest);
        assert!(!t.is_identity() && t.is_finite());
        assert!(!GroupTransform::from_translation(DVec3::new(0.0, f64::NAN, 0.0)).is_finite());
        // a rotation that is not one is refused by its group, not by a target's vertex index
        for rotation in
            [DQuat::from_xyzw(f64::INFINITY, 0.0, 0.0, 1.0), DQuat::from_xyzw(0.0, 0.0, 0.0, 0.0)]
        {
            let bad = GroupTransform { rotation, ..GroupTransform::IDENTITY };
            let e = handle_targets(&rest, &h, &[(0, bad)]).unwrap_err();
            assert_eq!(e, HandlesError::BadRotation { group: 0 });
        }
    }
}
