//! Rigid poses of handle groups and the handle targets they imply.
//!
//! A group's pose is a rotation about the centroid of its rest positions followed by a
//! translation: `target_v = c + R (p_v − c) + t`. This is the convention of the `bsarap deform`
//! CLI (`--rotate` is about the group's centroid), so a pose set in the editor means the same
//! thing on the command line.

use glam::{DQuat, DVec3};
use solver::{GroupTransform, Handles, Mesh};

/// Pose of one handle group. The default is the rest pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GroupPose {
    pub translation: [f64; 3],
    /// Unit quaternion `[x, y, z, w]`.
    pub rotation: [f64; 4],
}

impl Default for GroupPose {
    fn default() -> Self {
        GroupPose { translation: [0.0; 3], rotation: [0.0, 0.0, 0.0, 1.0] }
    }
}

impl GroupPose {
    pub fn quat(&self) -> DQuat {
        let q = DQuat::from_array(self.rotation);
        if q.length_squared() > 0.0 { q.normalize() } else { DQuat::IDENTITY }
    }

    pub fn set_quat(&mut self, q: DQuat) {
        self.rotation = q.normalize().to_array();
    }

    /// Whether every component is a finite number (what a typed value must give).
    pub fn is_finite(&self) -> bool {
        self.translation.iter().chain(&self.rotation).all(|x| x.is_finite())
    }

    pub fn is_rest(&self) -> bool {
        *self == GroupPose::default()
    }
}

/// Centroid of the rest positions of `vertices` (`None` when empty), for display: the
/// solver's [`solver::deform::pose::centroid`], the one the poses rotate about.
pub fn group_centroid(positions: &[[f64; 3]], vertices: &[u32]) -> Option<DVec3> {
    solver::deform::pose::centroid(positions, vertices).map(DVec3::from_array)
}

/// The group motions of `poses` as the solver takes them (`solver::Deformer::solve_groups`):
/// `poses[k]` is the pose of group `k`; groups of `handles` without a pose are not listed
/// (they stay at rest), nor are poses of groups `handles` lacks.
pub fn group_transforms(handles: &Handles, poses: &[GroupPose]) -> Vec<(usize, GroupTransform)> {
    handles.group_ids().filter_map(|k| poses.get(k).map(|p| (k, p.transform()))).collect()
}

/// Targets of `handles.handle_vertices()`, in that order, through `solver::handle_targets`
/// of [`group_transforms`], for what needs them per vertex (the quality reference).
pub fn handle_targets(
    mesh: &Mesh,
    handles: &Handles,
    poses: &[GroupPose],
) -> Result<Vec<[f64; 3]>, String> {
    solver::handle_targets(mesh.positions(), handles, &group_transforms(handles, poses))
        .map_err(|e| e.to_string())
}

impl GroupPose {
    /// From the solver's rigid transform (the inverse of [`GroupPose::transform`]).
    pub fn from_transform(t: &GroupTransform) -> GroupPose {
        let mut pose = GroupPose { translation: t.translation, ..GroupPose::default() };
        pose.set_quat(solver::linalg::rotation::quat_of(&t.rotation));
        pose
    }

    /// A timeline key at `time` holding this pose.
    pub fn to_key(&self, time: f64) -> solver::animation::timeline::Key {
        let (axis, angle) = self.quat().to_axis_angle();
        let axis = if axis.is_finite() && angle.abs() > 0.0 { axis } else { DVec3::Z };
        solver::animation::timeline::Key {
            time,
            translation: self.translation,
            rotation: solver::animation::timeline::AxisAngle {
                axis: axis.to_array(),
                degrees: angle.to_degrees(),
            },
        }
    }

    /// As the solver's rigid transform (row-major rotation about the rest centroid).
    pub fn transform(&self) -> GroupTransform {
        let rotation = solver::linalg::rotation::mat3_of(self.quat());
        GroupTransform { translation: self.translation, rotation }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used)]
mod tests {
    use super::*;

    #[test]
    fn rotation_is_about_the_group_centroid() {
        let mesh =
            Mesh::new(vec![[1.0, 0.0, 0.0], [3.0, 0.0, 0.0], [0.0, 5.0, 0.0]], vec![[0, 1, 2]])
                .unwrap();
        let handles = Handles::from_options(vec![Some(0), Some(0), None]).unwrap();
        let mut pose = GroupPose::default();
        pose.set_quat(DQuat::from_rotation_z(std::f64::consts::FRAC_PI_2));
        pose.translation = [0.0, 0.0, 1.0];
        let t = handle_targets(&mesh, &handles, &[pose]).unwrap();
        assert!((DVec3::from_array(t[0]) - DVec3::new(2.0, -1.0, 1.0)).length() < 1e-12);
        assert!((DVec3::from_array(t[1]) - DVec3::new(2.0, 1.0, 1.0)).length() < 1e-12);
    }

    #[test]
    fn transform_and_key_round_trip() {
        let mut pose = GroupPose { translation: [0.5, -1.0, 2.0], ..Default::default() };
        pose.set_quat(DQuat::from_euler(glam::EulerRot::XYZ, 0.3, -1.1, 2.0));
        let back = GroupPose::from_transform(&pose.transform());
        assert_eq!(back.translation, pose.translation);
        assert!(back.quat().dot(pose.quat()).abs() > 1.0 - 1e-12);
        let key = pose.to_key(1.5);
        let from_key = solver::animation::timeline::KeyframedPath {
            keys: vec![key],
            interpolation: solver::animation::timeline::Interpolation::Linear,
        }
        .transform_at(1.5);
        let again = GroupPose::from_transform(&from_key);
        assert!(again.quat().dot(pose.quat()).abs() > 1.0 - 1e-12);
        assert!(
            (DVec3::from_array(again.translation) - DVec3::from_array(pose.translation)).length()
                < 1e-12
        );
        assert!(GroupPose::from_transform(&GroupPose::default().transform()).is_rest());
    }
}
