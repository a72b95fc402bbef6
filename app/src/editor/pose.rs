//! Rigid poses of handle groups and the handle targets they imply.
//!
//! A group's pose is a rotation about the centroid of its rest positions followed by a
//! translation: `target_v = c + R (p_v − c) + t`. This is the convention of the `bsarap deform`
//! CLI (`--rotate` is about the group's centroid), so a pose set in the editor means the same
//! thing on the command line.
//!
//! A group's pose is the solver's own [`GroupTransform`] (glam's `DVec3` translation and unit
//! `DQuat` rotation, `[x, y, z, w]` as an array), handed to the solver threads as it is; the
//! default is the rest pose. A pose becomes a timeline key by
//! [`solver::animation::timeline::Key::from_transform`].

use glam::DVec3;
use solver::{GroupTransform, Handles, Mesh};

/// Centroid of the rest positions of `vertices` (`None` when empty), for display: the
/// solver's [`solver::deform::pose::centroid`], the one the poses rotate about.
pub fn group_centroid(positions: &[[f64; 3]], vertices: &[u32]) -> Option<DVec3> {
    solver::deform::pose::centroid(positions, vertices).map(DVec3::from_array)
}

/// The group motions of `poses` as the solver takes them (`solver::Deformer::solve_groups`):
/// `poses[k]` is the pose of group `k`; groups of `handles` without a pose are not listed
/// (they stay at rest), nor are poses of groups `handles` lacks.
pub fn group_transforms(
    handles: &Handles,
    poses: &[GroupTransform],
) -> Vec<(usize, GroupTransform)> {
    handles.group_ids().filter_map(|k| poses.get(k).map(|p| (k, *p))).collect()
}

/// Targets of `handles.handle_vertices()`, in that order, through `solver::handle_targets`
/// of [`group_transforms`], for what needs them per vertex (the quality reference).
pub fn handle_targets(
    mesh: &Mesh,
    handles: &Handles,
    poses: &[GroupTransform],
) -> Result<Vec<[f64; 3]>, String> {
    solver::handle_targets(mesh.positions(), handles, &group_transforms(handles, poses))
        .map_err(|e| e.to_string())
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used)]
mod tests {
    use super::*;
    use glam::DQuat;
    use solver::animation::timeline::{Interpolation, Key, KeyframedPath};

    #[test]
    fn rotation_is_about_the_group_centroid() {
        let mesh =
            Mesh::new(vec![[1.0, 0.0, 0.0], [3.0, 0.0, 0.0], [0.0, 5.0, 0.0]], vec![[0, 1, 2]])
                .unwrap();
        let handles = Handles::from_options(vec![Some(0), Some(0), None]).unwrap();
        let pose = GroupTransform::new(
            DVec3::new(0.0, 0.0, 1.0),
            DQuat::from_rotation_z(std::f64::consts::FRAC_PI_2),
        );
        let t = handle_targets(&mesh, &handles, &[pose]).unwrap();
        assert!((DVec3::from_array(t[0]) - DVec3::new(2.0, -1.0, 1.0)).length() < 1e-12);
        assert!((DVec3::from_array(t[1]) - DVec3::new(2.0, 1.0, 1.0)).length() < 1e-12);
    }

    /// A pose written as a timeline key (what a saved scene holds) and read back is the pose.
    #[test]
    fn key_round_trip() {
        let pose = GroupTransform::new(
            DVec3::new(0.5, -1.0, 2.0),
            DQuat::from_euler(glam::EulerRot::XYZ, 0.3, -1.1, 2.0),
        );
        let key = Key::from_transform(1.5, &pose);
        assert_eq!(key.translation, pose.translation.to_array());
        let from_key = KeyframedPath { keys: vec![key], interpolation: Interpolation::Linear }
            .transform_at(1.5);
        assert!(from_key.rotation.dot(pose.rotation).abs() > 1.0 - 1e-12);
        assert!((from_key.translation - pose.translation).length() < 1e-12);
        let rest = Key::from_transform(0.0, &GroupTransform::default());
        assert_eq!((rest.rotation.axis, rest.rotation.degrees), ([0.0, 0.0, 1.0], 0.0));
    }
}
