//! Rigid poses of handle groups and the handle targets they imply.
//!
//! A group's pose is a rotation about the centroid of its rest positions followed by a
//! translation: `target_v = c + R (p_v − c) + t`. This is the convention of the `bsarap deform`
//! CLI (`--rotate` is about the group's centroid), so a pose set in the editor means the same
//! thing on the command line.

use glam::{DQuat, DVec3};
use solver::{Handles, Mesh};

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

    pub fn is_rest(&self) -> bool {
        *self == GroupPose::default()
    }
}

/// Centroid of the rest positions of group `k` (`None` for an empty group).
pub fn group_centroid(positions: &[[f64; 3]], vertices: &[u32]) -> Option<DVec3> {
    if vertices.is_empty() {
        return None;
    }
    let sum: DVec3 = vertices.iter().map(|&v| DVec3::from_array(positions[v as usize])).sum();
    Some(sum / vertices.len() as f64)
}

/// Targets of `handles.handle_vertices()`, in that order. Groups without a pose stay at rest.
pub fn handle_targets(mesh: &Mesh, handles: &Handles, poses: &[GroupPose]) -> Vec<[f64; 3]> {
    let p = mesh.positions();
    let mut target_of = vec![None; handles.n_groups()];
    for k in handles.group_ids() {
        let pose = poses.get(k).copied().unwrap_or_default();
        let verts = handles.group(k).unwrap_or(&[]);
        if let Some(c) = group_centroid(p, verts) {
            target_of[k] = Some((c, pose.quat(), DVec3::from_array(pose.translation)));
        }
    }
    handles
        .handle_vertices()
        .iter()
        .map(|&v| {
            let pv = DVec3::from_array(p[v as usize]);
            match handles.labels()[v as usize].and_then(|k| target_of[k as usize]) {
                Some((c, q, t)) => (c + q * (pv - c) + t).to_array(),
                None => pv.to_array(),
            }
        })
        .collect()
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
        let t = handle_targets(&mesh, &handles, &[pose]);
        assert!((DVec3::from_array(t[0]) - DVec3::new(2.0, -1.0, 1.0)).length() < 1e-12);
        assert!((DVec3::from_array(t[1]) - DVec3::new(2.0, 1.0, 1.0)).length() < 1e-12);
    }
}
